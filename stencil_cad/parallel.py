"""Numba's parallel kernels, on a threading layer that lets the process exit.

Numba takes Intel TBB first wherever the system has ``libtbb`` (on Debian PrusaSlicer, FreeCAD and
Cura bring it). Measured here, on a two-core machine loaded with other jobs: a ``stencil-cad run``
that had written every file and printed its summary stayed in TBB's finalizer (``tbb::finalize``
spinning on ``sched_yield`` at interpreter exit) for more than ten minutes, and so did a benchmark
after its last row. So the kernels prefer OpenMP (thread-safe, which the studio's concurrent previews
need), then TBB, then numba's own workqueue. OpenMP is not fork-safe, and nothing here forks a process
that runs kernels: Dask's workers and the studio's job process are spawned. A layer named in
``NUMBA_THREADING_LAYER`` (or numba's own priority variable) is left as given.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numba

#: The threading layers in the order the kernels take the first one present.
LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

if "NUMBA_THREADING_LAYER" not in os.environ and "NUMBA_THREADING_LAYER_PRIORITY" not in os.environ:
    numba.config.THREADING_LAYER_PRIORITY = LAYER_PRIORITY  # type: ignore[attr-defined]

#: OpenMP's threads sleep when a kernel ends instead of spinning for the next one (unless the user set
#: the policy). The refinement launches thousands of short kernels, and between them GNU OpenMP's
#: threads spun on the cores: the bundled example took 83 and 93 CPU-seconds with the default policy
#: and 66 and 61 with ``PASSIVE``, in the same wall time and with the same files (two runs of each,
#: alternated, ``/usr/bin/time stencil-cad run``). Read when the OpenMP runtime loads, at the first
#: parallel kernel, so it is set here, before any.
WAIT_POLICY = "PASSIVE"
os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)


def njit_parallel(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(parallel=True, **options)``, with the threading layer of this module."""
    return numba.njit(parallel=True, **options)
