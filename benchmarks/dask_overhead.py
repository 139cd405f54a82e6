"""What a local Dask cluster of 2 workers costs on top of the work it runs.

Every task burns a fixed amount of its own thread's CPU time, so the ideal wall clock is the
total over the 2 workers; ``seconds`` is the measured wall clock of the map (cluster already
started and warm), ``efficiency`` the ideal over it. Cases:

* ``even-project`` / ``even-dask-defaults``: 40 tasks of 2.0 CPU-s through
  :class:`stencil_cad.compute.DaskExecutor`, with the project's cluster settings
  (``compute.executors._LOCAL_DASK_CONFIG``: no stack sampler, slower health checks and monitors) and
  with Dask's defaults — the baseline of the same run.
* ``uneven-inline`` / ``uneven-scattered``: 40 tasks of 0.3-4.0 CPU-s (a fixed draw), their
  inputs sent inside the tasks or, as large inputs are, scattered to the least busy worker first.
* ``sleep-scattered-10mb``: 40 tasks that sleep 0.5 s on a 10 MB input each (scattered, as a
  picture tile is): the cost of moving and keeping the inputs, which other load on the machine
  hardly changes (the tasks wait, they do not compute). The ideal is 10 s.

Run ``python -m benchmarks dask_overhead`` on a quiet machine (about 4 minutes); quote the
medians of a few runs.
"""

from __future__ import annotations

import random
import time

from stencil_cad import compute
from stencil_cad.compute import executors
from stencil_cad.config.compute import ComputeConfig

CASES = ["even-project", "even-dask-defaults", "uneven-inline", "uneven-scattered", "sleep-scattered-10mb"]
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("tasks", "seconds", "ideal_seconds", "efficiency")


def burn(seconds: float) -> float:
    """Spend ``seconds`` of this thread's CPU time in Python."""
    t0 = time.thread_time()
    x = 0
    while time.thread_time() - t0 < seconds:
        for i in range(10_000):
            x += i * i
    return seconds


def nap(item: tuple) -> float:
    """Sleep ``item[0]`` seconds beside the input ``item[1]``; return the seconds."""
    time.sleep(item[0])
    return item[0]


def _run_sleep(case: str) -> dict:
    import numpy as np

    items = [(0.5, np.full(10 * 2**20 // 8, i, dtype=np.float64)) for i in range(40)]
    with compute.executor(ComputeConfig(workers=2), 10**9, quiet=True) as ex:
        list(ex.map(nap, [(0.1, None)] * 2, "warm-up"))
        t0 = time.perf_counter()
        out = list(ex.map(nap, items, "nap"))
        seconds = time.perf_counter() - t0
    if out != [0.5] * 40:
        raise RuntimeError(f"{case}: results out of order")
    return {
        "bench": "dask_overhead",
        "case": case,
        "tasks": len(items),
        "seconds": round(seconds, 2),
        "ideal_seconds": 10.0,
        "efficiency": round(10.0 / seconds, 3),
    }


def _jobs(case: str) -> list[float]:
    if case.startswith("even"):
        return [2.0] * 40
    rng = random.Random(1)
    return [rng.choice([0.3, 0.6, 1.0, 2.5, 4.0]) for _ in range(40)]


def _run_case(case: str, jobs: list[float] | None = None) -> dict:
    settings, inline = executors._LOCAL_DASK_CONFIG, executors.INLINE_BYTES
    try:
        if case == "even-dask-defaults":
            executors._LOCAL_DASK_CONFIG = {}
        if case == "uneven-scattered":
            executors.INLINE_BYTES = -1
        jobs = jobs or _jobs(case)
        with compute.executor(ComputeConfig(workers=2), 10**9, quiet=True) as ex:
            list(ex.map(burn, [0.2, 0.2], "warm-up"))
            t0 = time.perf_counter()
            out = list(ex.map(burn, jobs, "burn"))
            seconds = time.perf_counter() - t0
    finally:
        executors._LOCAL_DASK_CONFIG, executors.INLINE_BYTES = settings, inline
    if out != jobs:
        raise RuntimeError(f"{case}: results out of order")
    ideal = sum(jobs) / 2
    return {
        "bench": "dask_overhead",
        "case": case,
        "tasks": len(jobs),
        "seconds": round(seconds, 2),
        "ideal_seconds": round(ideal, 2),
        "efficiency": round(ideal / seconds, 3),
    }


def run(cases=None):
    for case in CASES:
        if cases and case not in cases:
            continue
        yield _run_sleep(case) if case.startswith("sleep") else _run_case(case)


def smoke() -> object:
    """8 tasks of 0.25 CPU-s on a local cluster of 2 workers, the project's settings."""
    row = _run_case("even-project", jobs=[0.25] * 8)
    yield {**row, "case": "smoke-even-project"}
