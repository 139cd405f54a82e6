"""Where the tasks of a job run: in this process, or on a Dask cluster (local or remote).

The only module that imports Dask. Stages never import it: they offer pure task functions
over small inputs (a tile and its halo), and :mod:`stencil_cad.pipeline` hands those to
:meth:`Executor.map`, which returns the results in task order whatever ran them. The
result of a job therefore does not depend on where it ran: in this process, on a local
cluster of any size or on a remote one, the same config gives byte-identical files.

When a local cluster starts (see :func:`plan`):

- ``compute.scheduler`` (or ``--scheduler``) set: connect to that scheduler;
- ``compute.workers`` (or ``--workers``) 0: in this process; N >= 1: a local cluster of N
  single-threaded worker processes;
- ``compute.workers`` null (the default): one worker per core, but only when the working
  picture has more than ``compute.dask_above_mpx`` megapixels. Smaller jobs run in this
  process and pay no start-up cost (Dask's import and worker start take about 2 s here,
  each worker then loads the compiled kernels again). A tiled mural whose plan estimates more
  than :data:`MURAL_CLUSTER_SECONDS` of work also gets one worker per core (at least two),
  whatever its picture's size: its tiles' tasks share the cores.

Tasks are submitted a few per worker at a time and their results collected as they finish,
so neither the workers nor this process ever hold every tile's inputs at once. A stage's few
long tasks that this process need not wait for (a mural's plates and walls, the simulation's
other cans and registration cases) are started at once instead (:meth:`Executor.start`), at a
lower priority than mapped tasks, and collected later: a cluster runs them while this process
goes on with its own work. One progress bar counts every task of the job.
"""

from .executors import (
    CLOSE_SECONDS,
    CONNECT_TIMEOUT,
    IN_FLIGHT_PER_WORKER,
    INLINE_BYTES,
    PROBE_SECONDS,
    REMOTE_INLINE_BYTES,
    RESEND,
    DaskExecutor,
    Executor,
    Started,
    executor,
)
from .planning import (
    MURAL_CLUSTER_SECONDS,
    WORKER_BASE_BYTES,
    Plan,
    TaskMemoryError,
    available_memory,
    capped_workers,
    check_fits,
    cores,
    plan,
)

__all__ = [
    "CLOSE_SECONDS",
    "CONNECT_TIMEOUT",
    "INLINE_BYTES",
    "IN_FLIGHT_PER_WORKER",
    "MURAL_CLUSTER_SECONDS",
    "PROBE_SECONDS",
    "REMOTE_INLINE_BYTES",
    "RESEND",
    "WORKER_BASE_BYTES",
    "DaskExecutor",
    "Executor",
    "Plan",
    "Started",
    "TaskMemoryError",
    "available_memory",
    "capped_workers",
    "check_fits",
    "cores",
    "executor",
    "plan",
]
