"""Settings of a process that makes jobs: the command line's, and the studio's job worker.

Both are process-wide, so a library caller's process is left as it is: only the command line's
``main`` and the studio's job worker call :func:`tune_process`.

- **The garbage collector.** A job allocates millions of small objects (pydantic models, NumPy
  views, OCCT wrappers) but keeps few cycles, so CPython's default collector, which runs a
  young-generation pass every 700 allocations, spends its time tracing objects that live on.
  Measured on the bundled example (``stencil-cad run``, the collector's own CPU from
  ``gc.callbacks`` with ``time.thread_time``): 1,198 collections and 0.47 CPU-s with the defaults;
  with the modules imported frozen out of the collector (``gc.freeze``) and the thresholds of
  :data:`THRESHOLDS`, 48 collections and 0.11 CPU-s, the same files.
- **The C allocator** (glibc's, where the process has it). A job makes and frees arrays of a few
  MB thousands of times (a layer on the simulation grid is 6.5 MB); glibc maps each one afresh
  from the kernel and unmaps it when freed, so every page is faulted in again. With
  :data:`MALLOC_SETTINGS` freed memory stays in the heap for the next array: the bundled example's
  minor page faults 300,000-326,000 -> 149,000-152,000 and its system CPU 1.46-1.78 -> 1.09-1.57 s
  (three runs each, alternated, ``/usr/bin/time``), its peak memory 1.0 GB either way.
"""

from __future__ import annotations

import ctypes
import gc
import sys

#: The collector's thresholds (young, middle, old generations) for a job's process.
THRESHOLDS = (20_000, 20, 100)

#: glibc ``mallopt`` parameters and values: arrays up to 32 MB (glibc's largest mapping threshold
#: on 64 bits) come from the heap, and up to 1 GB freed at its top stays mapped, 64 MB padded.
MALLOC_SETTINGS = {
    "M_MMAP_THRESHOLD": (-3, 32 * 2**20),
    "M_TRIM_THRESHOLD": (-1, 2**30),
    "M_TOP_PAD": (-2, 64 * 2**20),
}


def tune_process() -> None:
    """Tune the collector (:func:`tune_collector`) and the C allocator (:func:`tune_allocator`)."""
    tune_collector()
    tune_allocator()


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


def tune_allocator() -> bool:
    """Set glibc's :data:`MALLOC_SETTINGS`; False where the process has no glibc ``mallopt``."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # musl and other C libraries have no mallopt
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    done = [mallopt(param, value) == 1 for param, value in MALLOC_SETTINGS.values()]
    return all(done)
