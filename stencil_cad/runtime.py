"""Settings of a process that makes jobs: the command line's, and the studio's job worker.

A job allocates millions of small objects (pydantic models, NumPy views, OCCT wrappers) but
keeps few cycles, so CPython's default collector, which runs a young-generation pass every 700
allocations, spends its time tracing objects that live on. Measured on the bundled example
(``stencil-cad run``, the collector's own CPU from ``gc.callbacks`` with ``time.thread_time``):
1,198 collections and 0.52 CPU-s with the defaults; with the modules imported frozen out of the
collector (``gc.freeze``) and the thresholds of :data:`THRESHOLDS`, 37 collections and 0.10 CPU-s,
the same files. A library caller's process is left as it is: only the command line's
``main`` and the studio's job worker call :func:`tune_collector`.
"""

from __future__ import annotations

import gc

#: The collector's thresholds (young, middle, old generations) for a job's process.
THRESHOLDS = (20_000, 20, 100)


def tune_collector() -> None:
    """Freeze what is alive now (the modules imported so far) out of the collector and raise its thresholds.

    Once per process: a test calling the command line's ``main`` many times freezes only once, and
    what it freezes was collected first, so no garbage is kept for good.
    """
    if gc.get_threshold() == THRESHOLDS:
        return
    gc.collect()
    gc.freeze()
    gc.set_threshold(*THRESHOLDS)
