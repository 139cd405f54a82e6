"""Config section `compute`: where the work runs (this process, a local Dask cluster, a remote one).

Where the work runs never changes the result: the same config and seed give byte-identical
files in this process, on a local cluster of any size and on a remote cluster. What the
work is split into (tiles and their sizes) follows the picture and this section's
``memory_per_task``, never the number of workers.
"""

from __future__ import annotations

import re

from pydantic import Field, field_validator

from .base import StrictModel

_UNITS = {"": 1e9, "b": 1.0, "kb": 1e3, "mb": 1e6, "gb": 1e9, "tb": 1e12, "kib": 2**10, "mib": 2**20}
_UNITS.update({"gib": 2**30, "tib": 2**40, "k": 1e3, "m": 1e6, "g": 1e9, "t": 1e12})


def parse_memory(value: float | int | str) -> float:
    """A memory size in bytes from a number of GB or a string such as ``"4 GB"`` or ``"512MiB"``.

    Raises:
        ValueError: Naming the accepted forms.
    """
    if isinstance(value, bool):
        raise ValueError("must be a size such as 2 (GB) or '1.5 GB', not a true/false value")
    if isinstance(value, (int, float)):
        return float(value) * 1e9
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(value))
    if m is None or m.group(2).lower() not in _UNITS:
        raise ValueError(f"must be a size such as 2 (GB), '1.5 GB', '512 MB' or '4 GiB', got {value!r}")
    return float(m.group(1)) * _UNITS[m.group(2).lower()]


class ComputeConfig(StrictModel):
    """Where the job's tasks run, and how much memory one task may use."""

    workers: int | None = Field(
        None,
        ge=0,
        le=1024,
        description=(
            "Worker processes of a local Dask cluster (one thread each). null: one per core, and only "
            "for big jobs (see dask_above_mpx) and murals of several tiles whose plan estimates more "
            "than a minute of work (on two cores or more); smaller jobs run in this process with no "
            "cluster to start. 0: always in this process. N >= 1: always a local cluster of N workers. "
            "Ignored when scheduler is set. The command line's --workers overrides it."
        ),
    )
    scheduler: str | None = Field(
        None,
        description=(
            "Address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (start one with "
            "`dask scheduler` and workers with `dask worker ADDRESS`). null: no remote cluster. "
            "The command line's --scheduler overrides it."
        ),
    )
    memory_per_task: float = Field(
        2.0,
        gt=0.0,
        le=4096.0,
        description=(
            "Memory one task may use, in GB (a number, or a string such as '1.5 GB' or '512 MB'). "
            "Range (0, 4096] GB. Big pictures are cut into tiles small enough to fit it, and a local "
            "cluster's workers are limited to it plus their start-up size; a task that cannot fit "
            "(a decomposition tile of the smallest size) stops the job before any work with a message "
            "giving the size it needs."
        ),
    )
    dask_above_mpx: float = Field(
        6.0,
        ge=0.0,
        le=1e6,
        description=(
            "With workers: null and no scheduler, a local Dask cluster starts only when the working "
            "picture has more than this many megapixels (about 1.5 m2 at 2 px/mm); below, starting "
            "worker processes costs more than it saves. Range [0, 1e6] MP."
        ),
    )

    @field_validator("memory_per_task", mode="before")
    @classmethod
    def _memory(cls, value):
        if isinstance(value, str):
            return parse_memory(value) / 1e9
        return value

    @field_validator("scheduler")
    @classmethod
    def _address(cls, value: str | None) -> str | None:
        if value is None:
            return None
        value = value.strip()
        if not re.fullmatch(r"(tcp|tls|inproc|ucx|ws|wss)://\S+", value):
            raise ValueError(
                f"must be a Dask scheduler address such as tcp://HOST:8786 (as `dask scheduler` prints), got {value!r}"
            )
        return value

    @property
    def memory_per_task_bytes(self) -> int:
        """``memory_per_task`` in bytes."""
        return int(self.memory_per_task * 1e9)


def with_command_line(cfg: ComputeConfig, workers: int | None, scheduler: str | None) -> ComputeConfig:
    """The section with ``--workers`` / ``--scheduler`` applied, validated like config values.

    These choose where this run's tasks go; they are not part of the job, so the saved
    ``config.yaml`` keeps the file's values and runs on any cluster write the same files.

    Raises:
        ConfigError: A bad value, named as the command-line option.
    """
    from pydantic import ValidationError

    from ..errors import ConfigError
    from .io import format_validation_error

    data = cfg.model_dump()
    if workers is not None:
        data["workers"] = workers
    if scheduler is not None:
        data["scheduler"] = scheduler
    try:
        return ComputeConfig.model_validate(data)
    except ValidationError as exc:
        msg = format_validation_error(exc, "command line")
        raise ConfigError(
            msg.replace("command line: workers:", "--workers:").replace(
                "command line: scheduler:", "--scheduler:"
            )
        ) from None
