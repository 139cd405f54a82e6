"""The record of one command: its config, output folder, executor, timings and figures.

Every stage's glue takes a :class:`Run`; the manifest, the terminal summary and the instruction
sheet are made from what the stages record in it.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from . import interrupts
from .figures import Figures

if TYPE_CHECKING:
    from .compute import Executor
    from .config import JobConfig
    from .output import OutputDir

log = logging.getLogger(__name__)


@dataclass
class Run:
    """State of one command: config, output folder, timings and the figures for the manifest.

    ``cfg`` is the maker's config as given, and it stays so: it cannot be set again. What the job
    decides beyond it (the thickness, the primer, the plate design …) is its plan
    (:class:`stencil_cad.plan.plan.Plan`), which the orchestrator passes to the stages.
    """

    cfg: JobConfig
    out: OutputDir
    quiet: bool = False
    executor: Executor | None = None
    times: dict[str, Any] = field(default_factory=dict[str, Any])
    #: What each stage recorded, typed per stage; written as the manifest's stage sections.
    figures: Figures = field(default_factory=Figures)
    summary: list[Any] = field(default_factory=list[Any])
    #: The plate template in use: ``{"path", "sha256", "builtin"}`` (None before it is checked).
    template: dict[str, Any] | None = None
    #: Images for the instruction sheet that are not result files (PNG bytes by name).
    sheet_images: dict[str, Any] = field(default_factory=dict[str, Any])
    #: Files of later stages this stage command left in the folder, made from older inputs.
    stale: list[Any] = field(default_factory=list[Any])
    #: Told ``(event, stage)`` as each stage starts (``"start"``) and ends (``"done"``); None: nobody listens.
    progress: Callable[[str, str], None] | None = None
    #: Checked at every stage edge and progress step: the caller's way to stop the run.
    cancel: interrupts.CancelToken | None = None
    #: Results a stage computed, by what they depend on, shared with the run's plate-design trials:
    #: the job's stipple reuses the holes the trials made for the design it keeps.
    kept: dict[Any, Any] = field(default_factory=dict[Any, Any])

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "cfg" and "cfg" in self.__dict__:
            raise AttributeError("Run.cfg is the maker's config as given; a job's decisions go in its Plan")
        object.__setattr__(self, name, value)

    def keep(self, key: Any, make: Callable[[], Any]) -> tuple[Any, bool]:
        """``(what was kept under key, True)``, or ``(make(), False)`` after keeping it under ``key``."""
        if key in self.kept:
            return self.kept[key], True
        value = self.kept[key] = make()
        return value, False

    def rng_for(self, stage: str, index: int = 0) -> np.random.Generator:
        """An independent generator per stage and layer, derived from the seed.

        A stage command re-run on saved intermediates therefore gives the same result as
        the same stage inside a whole run.
        """
        return np.random.default_rng(self.seed_for(stage, index))

    def seed_for(self, stage: str, *index: int) -> np.random.SeedSequence:
        """The seed sequence of :meth:`rng_for`, for any number of indices (layer, tile, …)."""
        import zlib

        key = (zlib.crc32(stage.encode()), *index)
        return np.random.SeedSequence(self.cfg.seed, spawn_key=key)

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time a stage; a signal whose exception was dropped stops the run at its edges."""
        self.check()
        log.info("stage %s …", name)
        if self.progress is not None:
            self.progress("start", name)
        t0 = time.perf_counter()
        yield
        self.check()
        self.times[name] = round(self.times.get(name, 0.0) + time.perf_counter() - t0, 3)
        if self.progress is not None:
            self.progress("done", name)

    def check(self) -> None:
        """Stop the run if a signal arrived or the caller cancelled it.

        Raises:
            Interrupted: A signal was received during this run.
            Cancelled: The run's :attr:`cancel` token was set.
        """
        interrupts.check()
        if self.cancel is not None:
            self.cancel.check()

    @property
    def tasks(self) -> Executor:
        """Where tile tasks run: the executor :func:`computing` opened, else this process."""
        if self.executor is None:
            from . import compute

            self.executor = compute.Executor(
                compute.Plan("in_process", reason="no cluster opened"), self.quiet
            )
        return self.executor

    def bar(self, total: int | None, desc: str) -> Any:
        """A progress bar on stderr (silent with -q)."""
        from tqdm.auto import tqdm

        # disable=None: no bar when stderr is not a terminal (logs, CI).
        bar = tqdm(total=total, desc=desc, disable=True if self.quiet else None, leave=False, unit="it")
        if self.cancel is None:
            return bar
        return _Checked(bar, self.cancel)


class _Checked:
    """A progress bar whose every step checks the cancel token: long loops stop within one step."""

    def __init__(self, bar: Any, cancel: interrupts.CancelToken) -> None:
        self._bar = bar
        self._cancel = cancel

    def update(self, n: int = 1) -> Any:
        self._cancel.check()
        return self._bar.update(n)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._bar, name)

    def __enter__(self) -> _Checked:
        self._bar.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self._bar.__exit__(*exc)
