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


#: With ``compute.workers`` null, a tiled mural whose plan estimates more than this many seconds
#: of work (:func:`stencil_cad.mural.plan_cost`) runs on a local cluster of one worker per core,
#: whatever its picture's size: its tiles' tasks (placing and refining the holes, building the
#: plates, the scores' blocks) then share the cores. The 600 x 400 mm coffee mural of
#: ``python -m benchmarks mural --case mural600`` (0.96 MP, 8 tiles, planned at 83 s) on 2 workers
#: of a shared 2-core machine: its refinement 59 s against 108 s in this process, the plates 51 s
#: against 66 s, the hole placement 18 s against 31 s, the same files. A cluster costs a few seconds
#: to start (and each worker loads the compiled kernels), which a small mural would not win back.
MURAL_CLUSTER_SECONDS = 60.0


def plan(cfg: ComputeConfig, picture_px: int, mural_seconds: float | None = None) -> Plan:
    """Decide where a job runs, before any work.

    Args:
        cfg: The ``compute`` section.
        picture_px: Pixels of the working picture (H x W).
        mural_seconds: A tiled mural's estimated work in seconds (its plan's), or None when the
            job is not a tiled mural.

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
    if mpx <= cfg.dask_above_mpx and mural_seconds is not None and mural_seconds > MURAL_CLUSTER_SECONDS:
        n, cut = capped_workers(cores(), cfg)
        if n > 1:
            return Plan(
                "local",
                workers=n,
                reason=f"the mural's tiles (about {mural_seconds:.0f} s of work) share {n} workers"
                + (f"; {cut}" if cut else ""),
            )
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
