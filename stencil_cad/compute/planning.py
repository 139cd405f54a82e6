"""Where a job runs and how many workers it gets: the plan, and the memory check of one task.

Nothing here imports Dask; :mod:`.executors` starts what the plan says.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass

from ..config.compute import ComputeConfig
from ..errors import UserError

log = logging.getLogger(__name__)

# Memory a worker process needs before its first task (Python, numpy, numba and the
# compiled kernels, Dask itself), in bytes; measured about 0.35 GB here, rounded up.
WORKER_BASE_BYTES = int(0.6e9)


def cores() -> int:
    """Cores this process may use (the affinity mask where the OS has one)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not Linux
        return max(os.cpu_count() or 1, 1)


@dataclass(frozen=True)
class Plan:
    """Where a job runs.

    Attributes:
        kind: ``"in_process"``, ``"local"`` (a local cluster) or ``"remote"``.
        workers: Worker processes of a local cluster (0 otherwise).
        address: Scheduler address of a remote cluster, or None.
        reason: Why, in words, for the log and the manifest.
    """

    kind: str
    workers: int = 0
    address: str | None = None
    reason: str = ""

    def summary(self) -> dict:
        """For the manifest."""
        return {"kind": self.kind, "workers": self.workers, "address": self.address, "reason": self.reason}


def plan(cfg: ComputeConfig, picture_px: int) -> Plan:
    """Decide where a job runs, before any work.

    Args:
        cfg: The ``compute`` section.
        picture_px: Pixels of the working picture (H x W).

    Returns:
        The plan; nothing is started yet.
    """
    if cfg.scheduler is not None:
        return Plan("remote", address=cfg.scheduler, reason="compute.scheduler is set")
    if cfg.workers == 0:
        return Plan("in_process", reason="compute.workers is 0")
    if cfg.workers is not None:
        n, cut = capped_workers(int(cfg.workers), cfg)
        if cut:
            log.warning("compute: %s", cut)
        return Plan(
            "local", workers=n, reason=f"compute.workers is {cfg.workers}" + (f"; {cut}" if cut else "")
        )
    mpx = picture_px / 1e6
    if mpx <= cfg.dask_above_mpx:
        return Plan(
            "in_process",
            reason=f"the picture has {mpx:.3g} MP, not more than compute.dask_above_mpx {cfg.dask_above_mpx:g}",
        )
    n, cut = capped_workers(cores(), cfg)
    return Plan(
        "local",
        workers=n,
        reason=f"the picture has {mpx:.3g} MP, more than compute.dask_above_mpx {cfg.dask_above_mpx:g}"
        + (f"; {cut}" if cut else ""),
    )


def available_memory() -> int | None:
    """Bytes the OS can give new processes without swapping (Linux ``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            return next(int(ln.split()[1]) * 1024 for ln in f if ln.startswith("MemAvailable:"))
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def capped_workers(asked: int, cfg: ComputeConfig) -> tuple[int, str]:
    """Local worker processes to start: ``asked``, cut to the cores and to the memory they may use.

    Each worker runs one task on one core and may use ``compute.memory_per_task`` plus its
    start-up size, so more workers than cores only queue, and more than the memory holds
    end in the OS killing them.

    Returns:
        ``(workers, why it was cut or "")``.
    """
    per_worker = cfg.memory_per_task_bytes + WORKER_BASE_BYTES
    free = available_memory()
    by_memory = max(1, int(free // per_worker)) if free is not None else asked
    n_cores = cores()
    n = max(1, min(asked, n_cores, by_memory))
    if n == asked:
        return n, ""
    if free is not None and by_memory < min(asked, n_cores):
        why = (
            f"{free / 1e9:.1f} GB of free memory, {per_worker / 1e9:.1f} GB per worker "
            "(compute.memory_per_task plus the worker's start-up size)"
        )
    else:
        why = f"{n_cores} core(s), one worker per core"
    return n, f"{asked} workers asked, starting {n}: this machine has {why}"


class TaskMemoryError(UserError):
    """A task cannot fit ``compute.memory_per_task``."""


def check_fits(what: str, need_bytes: float, cfg: ComputeConfig) -> None:
    """Stop before any work when one task needs more than ``compute.memory_per_task``.

    Args:
        what: The task, in words ("a decomposition tile of 320 x 320 px, 4 layers").
        need_bytes: Its estimated peak in bytes.
        cfg: The ``compute`` section.

    Raises:
        TaskMemoryError: Naming the task, what it needs and the setting to change.
    """
    if need_bytes > cfg.memory_per_task_bytes:
        raise TaskMemoryError(
            f"compute.memory_per_task: {what} needs about {need_bytes / 1e9:.2f} GB, more than the "
            f"{cfg.memory_per_task:g} GB allowed; raise compute.memory_per_task to at least "
            f"{_round_up_gb(need_bytes)} GB (or make the picture smaller)"
        )


def _round_up_gb(n_bytes: float) -> str:
    import math

    return f"{math.ceil(n_bytes / 1e8) / 10:g}"
