"""The executors: tasks in this process (:class:`Executor`, from :mod:`.tasks`) or on a Dask cluster (:class:`DaskExecutor`).

The only module that imports Dask (see :mod:`stencil_cad.compute` for when a cluster starts
and how tasks are sent to it).
"""

from __future__ import annotations

import contextlib
import copy
import logging
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import CancelledError
from typing import Any

from .. import interrupts
from ..config.compute import ComputeConfig
from ..errors import UserError
from .planning import WORKER_BASE_BYTES, Plan, plan
from .tasks import Executor, Started

log = logging.getLogger(__name__)


# How long to wait for a remote scheduler to answer. A refused connection fails at once
# (see _probe): Dask itself retries it until this timeout.
CONNECT_TIMEOUT = "15s"
PROBE_SECONDS = 5.0
# How long a scheduler that accepted the connection may take to send its handshake.
HANDSHAKE_SECONDS = 10.0
CLOSE_SECONDS = 5

# How long tasks may wait on a cluster without a single worker before the job ends (Dask itself
# waits for good): time for a killed worker to be replaced.
WORKERLESS_SECONDS = 30.0

# Times a task whose scattered input was lost with its worker is sent again (with its input).
RESEND = 3

# Tasks kept in flight per worker: one running, one queued so a worker never waits for
# the next input, and no more, so inputs waiting on workers stay bounded.
IN_FLIGHT_PER_WORKER = 2

# Task inputs up to this size (pickled) travel inside the task, and the scheduler gives the task
# to the first free worker; larger ones are scattered first, to the worker with the fewest of
# this map's tasks in flight, and the task runs there (Dask warns of task graphs over 10 MB).
# Inputs scattered to the workers in turn pin their tasks to a worker that may be busy: 40 tasks
# of 0.3-4 CPU-s on 2 workers took 37.2 s that way; sent inside the tasks 33.8 s, scattered to
# the least busy worker 33.9 s (medians of two; the ideal is 32.75).
# On a remote cluster an input inside a task crosses the network twice (to the scheduler, which
# keeps it until the task ends, then to the worker), so there only small ones do (a plate's
# holes are 5-35 KB).
INLINE_BYTES = 8 << 20
REMOTE_INLINE_BYTES = 64 << 10

# Environment of local worker processes: each worker runs one task on one core, so the
# compiled kernels and BLAS must not start a thread per core inside every worker too.
_WORKER_ENV = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}


# Dask settings of a local cluster (its scheduler, nannies and workers), for the housekeeping
# that serves Dask's dashboard and diagnostics, which a local cluster here does not serve:
# - the statistical profiler samples the running task's stack every 10 ms; switched off, the
#   build of a 0.6 m x 0.6 m mural (80 plates and walls) on 2 workers took 98-99 s instead of
#   102-106 s and about 5 % less CPU (two runs each, same files);
# - every event loop checks its own health every 20 ms ("tick"), the system monitor samples
#   CPU and memory every 0.5 s and each nanny reads its worker's memory every 0.1 s. An idle
#   cluster of 2 workers spends 4.1 CPU-s per 30 s on them with Dask's defaults, 0.7 with these
#   (the nannies run in this process: 2.3 -> 0.4); 40 tasks of 2 CPU-s took 43.3 s instead of
#   41.2 (medians of two; the ideal is 40). `python -m benchmarks dask_overhead` measures both.
#   The memory limit is still enforced, and a worker still pauses or spills, but checked every
#   0.5 s: a task can overshoot its limit for that long before its worker is stopped.
_LOCAL_DASK_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "500ms",
    # Dask's nannies start every worker with MALLOC_TRIM_THRESHOLD_=65536 so that glibc hands
    # freed memory back to the OS at once. Setting it switches off glibc's sliding mmap
    # threshold: every array over 128 KB is then mapped, faulted in page by page and unmapped
    # again, and our numpy-heavy tasks ran about 1.7x slower. One S-CIELAB score of 1000 x 1000 px
    # at 1 m (9 blocks, one process, one thread): 5.4-5.6 s by default, 9.0-9.5 s with 65536,
    # 7.9-8.5 s with 64 MiB, 7.2 s with MALLOC_MMAP_THRESHOLD_=32 MiB beside it. Without the
    # variable a worker keeps the memory its largest task freed for the next one. (A nanny reads
    # this when it is made, so only the workers started with the cluster get it: it never scales.)
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}


class DaskExecutor(Executor):
    """Runs task functions on a Dask cluster: a local one it started, or a remote one.

    Args:
        plan: ``kind`` ``"local"`` or ``"remote"``.
        cfg: The ``compute`` section (memory per task).
        quiet: No progress bar.

    Raises:
        UserError: The scheduler cannot be reached, or its workers have less memory than
            ``compute.memory_per_task``.
    """

    def __init__(self, plan: Plan, cfg: ComputeConfig, quiet: bool = False):
        super().__init__(plan, quiet)
        from distributed import Client, LocalCluster

        self._cluster = None
        self._maps = 0
        # Every worker address the cluster has had, to name the lost ones.
        self._seen: set[str] = set()
        _quiet_dask_logs()
        if plan.kind == "local":
            import dask

            # No dashboard (no port to bind), worker chatter only on real trouble. The scheduler
            # reads the settings while this block is in force; the nannies get a copy of their
            # own, which they hand to every worker they start or restart (after one ran out of
            # memory), so the exit of this block cannot put Dask's defaults back into it.
            with dask.config.set(_LOCAL_DASK_CONFIG):
                settings = {"distributed": copy.deepcopy(dask.config.get("distributed"))}
                self._cluster = LocalCluster(
                    config=settings,
                    n_workers=plan.workers,
                    threads_per_worker=1,
                    processes=True,
                    memory_limit=cfg.memory_per_task_bytes + WORKER_BASE_BYTES,
                    scheduler_kwargs={"dashboard": False},
                    host="127.0.0.1",
                    silence_logs=logging.ERROR,
                    env=dict(_WORKER_ENV),
                )
            self.client = Client(self._cluster, set_as_default=False)
        else:
            try:
                _probe(str(plan.address))
                self.client = Client(plan.address, timeout=CONNECT_TIMEOUT, set_as_default=False)
            except (OSError, TimeoutError) as exc:
                raise UserError(
                    f"compute.scheduler: cannot reach the Dask scheduler at {plan.address} ({exc}); start "
                    "it with `dask scheduler` and workers with `dask worker ADDRESS`, or drop --scheduler"
                ) from None
            self._check_remote(cfg)

    def _check_remote(self, cfg: ComputeConfig) -> None:
        workers = self._worker_info()
        if not workers:
            self.client.close()
            raise UserError(
                f"compute.scheduler: the scheduler at {self.plan.address} has no workers; start some with "
                f"`dask worker {self.plan.address}`"
            )
        limits = [w.get("memory_limit") or 0 for w in workers.values()]
        small = [m for m in limits if 0 < m < cfg.memory_per_task_bytes]
        if len(small) == len(limits):
            self.client.close()
            raise UserError(
                f"compute.memory_per_task: {cfg.memory_per_task:g} GB per task, but the workers at "
                f"{self.plan.address} are limited to {max(small) / 1e9:.2f} GB; lower "
                "compute.memory_per_task or start workers with a larger --memory-limit"
            )

    @property
    def workers(self) -> int:
        """Worker processes of the cluster (at the time of asking)."""
        return max(len(self._worker_info()), 1)

    def map(
        self, fn: Callable[[Any], Any], items: Iterable[Any], desc: str, count: int | None = None
    ) -> Iterator:
        """Apply ``fn`` to every item on the cluster; yield the results in item order.

        At most :data:`IN_FLIGHT_PER_WORKER` tasks per worker are in flight; results are
        yielded in order as soon as every earlier one has arrived.
        """
        from distributed import as_completed

        if not self._connected():
            raise self._scheduler_lost(desc)
        items = list(items) if count is None and not isinstance(items, Sequence) else items
        total = count if count is not None else len(items)  # type: ignore[arg-type]
        bar = self._progress(total, desc)
        window = max(self.workers * IN_FLIGHT_PER_WORKER, 1)
        self._maps += 1
        tag = f"{desc.replace(' ', '_')}-{self._maps}"
        source = iter(enumerate(items))
        # future: (index, input, scattered data or None, worker or None, times sent)
        pending: dict = {}
        inline = INLINE_BYTES if self.plan.kind == "local" else REMOTE_INLINE_BYTES
        # This map's tasks in flight on each worker (scattered inputs only).
        load: dict[str, int] = {}
        done: dict[int, Any] = {}
        next_out = 0
        ac = as_completed(loop=self.client.loop)

        def send(i: int, item: Any, sent: int) -> None:
            key = f"{tag}-{i}" if sent == 0 else f"{tag}-{i}-again{sent}"
            fut, data, where = self._submit(fn, item, key, inline, load, desc)
            pending[fut] = (i, item if data is not None else None, data, where, sent)
            ac.add(fut)

        def submit() -> bool:
            try:
                i, item = next(source)
            except StopIteration:
                return False
            send(i, item, 0)
            return True

        try:
            for _ in range(window):
                if not submit():
                    break
            for fut in self._completed(ac, desc):
                i, item, data, where, sent = pending.pop(fut)
                if where in load:
                    load[where] = max(load[where] - 1, 0)
                if data is not None:
                    data.release()
                if self._lost_input(fut, data) and sent < RESEND:
                    log.info("%s: task %d lost its input with a worker; sending both again", desc, i)
                    fut.release()
                    send(i, item, sent + 1)
                    continue
                done[i] = self._result(fut, desc)
                fut.release()
                bar.update(1)
                interrupts.check()
                submit()
                while next_out in done:
                    yield done.pop(next_out)
                    next_out += 1
        except (OSError, CancelledError, TimeoutError) as exc:
            self._name_loss(desc, exc)
            raise
        finally:
            for fut in pending:
                fut.cancel()

    def start(self, fn: Callable[..., Any], items: Iterable[Any], desc: str, shared: Any = None) -> Started:
        """Submit every task now, behind any task submitted later (:meth:`Executor.start`).

        ``shared`` is scattered once to every worker; each item travels inside its task, so keep
        the items small. The started tasks run at a lower priority than :meth:`map`'s, so a
        score's blocks asked for meanwhile run on the next free worker rather than after every
        started task. Dask runs a task again elsewhere when its worker dies; a task cancelled
        because ``shared`` went with every worker that held it is sent again with ``shared``
        (:data:`RESEND` times), and a scatter that meets a dying worker is tried again.
        """
        if not self._connected():
            raise self._scheduler_lost(desc)
        items = list(items)
        bar = self._progress(len(items), desc)
        self._maps += 1
        tag = f"{desc.replace(' ', '_')}-{self._maps}"
        held: list[Any] = []  # the futures of ``shared`` on the cluster, the newest last

        def scatter_shared() -> tuple[Any, ...]:
            if shared is not None:
                held.append(self._broadcast(shared, desc))
            return () if shared is None else (held[-1],)

        args = scatter_shared()

        def send(i: int, sent: int) -> Any:
            key = f"{tag}-{i}" if sent == 0 else f"{tag}-{i}-again{sent}"
            return self.client.submit(fn, items[i], *args, pure=False, key=key, priority=-1)

        live = {i: send(i, 0) for i in range(len(items))}

        def results() -> Iterator[Any]:
            nonlocal args
            try:
                for i in range(len(items)):
                    sent = 0
                    while True:
                        fut = live[i]
                        try:
                            result = self._result(fut, desc)
                            break
                        except CancelledError:
                            lost = shared is not None and fut.status == "cancelled" and self._connected()
                            if not lost or sent >= RESEND or not self._workers_left():
                                raise
                        log.info(
                            "%s: task %d lost its shared input with a worker; sending both again", desc, i
                        )
                        fut.release()
                        sent += 1
                        args = scatter_shared()
                        live[i] = send(i, sent)
                    live.pop(i).release()
                    bar.update(1)
                    interrupts.check()
                    yield result
            except (OSError, CancelledError, TimeoutError) as exc:
                self._name_loss(desc, exc)
                raise

        def cancel() -> None:
            for fut in live.values():
                fut.cancel()
            live.clear()
            for data in held:
                data.release()

        return Started(results, cancel)

    def _name_loss(self, desc: str, exc: BaseException) -> None:
        """Raise the user's error for a lost scheduler or the loss of every worker behind ``exc``; else return."""
        if not self._connected():
            raise self._scheduler_lost(desc) from exc
        if not self._workers_left():
            raise self._workers_lost(desc) from exc

    def _broadcast(self, data: Any, desc: str) -> Any:
        """Scatter ``data`` to every worker: its future. Tried again when it meets a worker that dies."""
        for attempt in range(1, RESEND + 1):
            try:
                return self.client.scatter([data], broadcast=True, hash=False)[0]
            except (KeyError, OSError):
                # A worker that died as the data went out (its address gone from the scheduler,
                # or its connection closed): the other workers take it.
                if not self._connected():
                    raise self._scheduler_lost(desc) from None
                if not self._workers_left():
                    raise self._workers_lost(desc) from None
                if attempt == RESEND:
                    raise
        raise AssertionError("unreachable")

    def _submit(
        self, fn: Callable[[Any], Any], item: Any, key: str, inline: int, load: dict[str, int], desc: str
    ):
        """Submit one task under ``key``: ``(future, scattered input or None, its worker or None)``."""
        if _pickled_size(item) <= inline:
            # A small input travels with its task, which the scheduler then gives to
            # whichever worker is free first (and runs again elsewhere if that worker dies).
            return self.client.submit(fn, item, pure=False, key=key), None, None
        # A large one goes to the cluster as data of its own, not inside the task graph
        # (a decomposition tile is tens of MB), to the least busy worker; released with
        # the result. It lives on that worker only: this process keeps the input until
        # the result arrives, and sends both again if the worker dies first.
        data, where = self._scatter(item, load, desc)
        return self.client.submit(fn, data, pure=False, key=key), data, where

    def _connected(self) -> bool:
        """True while the client is connected to its scheduler."""
        return getattr(self.client, "status", "running") == "running"

    def _lost_input(self, fut, data) -> bool:
        """True when ``fut`` was cancelled because its scattered input went with a worker that died."""
        return data is not None and fut.status == "cancelled" and self._connected()

    def _scheduler_lost(self, desc: str) -> UserError:
        where = (
            f"the Dask scheduler at {self.plan.address}"
            if self.plan.kind == "remote"
            else "the local Dask cluster"
        )
        fix = (
            f"restart it (`dask scheduler`) and its workers (`dask worker {self.plan.address}`), then run the job again"
            if self.plan.kind == "remote"
            else "run the job again"
        )
        return UserError(
            f"{desc}: lost the connection to {where} (it stopped, or the network dropped); {fix}; no partial "
            "outputs were kept"
        )

    def _scatter(self, item: Any, load: dict[str, int], desc: str = "tasks") -> tuple[Any, str | None]:
        """Send ``item`` to the running worker with the fewest of ``load``'s tasks; count it there.

        ``load`` (worker address: this map's tasks in flight) follows the cluster: a worker that
        left is dropped, one that joined starts at 0, a paused one is skipped. When no worker
        can be chosen, or the chosen one went away meanwhile, the scheduler picks one.

        Returns:
            ``(future of the data, the worker's address or None)``.
        """
        running = {a for a, w in self._worker_info().items() if w.get("status") == "running"}
        for a in set(load) - running:
            del load[a]
        for a in running - set(load):
            load[a] = 0
        if load:
            # The lowest address among the least busy, so the choice does not hang on dict order.
            where = min(load, key=lambda a: (load[a], a))
            try:
                # In a list of one: Dask scatters the elements of a list or tuple one by one.
                data = self.client.scatter([item], hash=False, workers=[where])[0]
            except (KeyError, OSError):
                pass  # gone meanwhile (a timeout, or its connection closed as it died)
            else:
                load[where] += 1
                return data, where
        for attempt in (1, 2):
            try:
                return self.client.scatter([item], hash=False)[0], None
            except OSError:
                # Dask's "No valid workers found" (a TimeoutError) after waiting for one as long as
                # the client's timeout, or the connection to a worker that died meanwhile: once the
                # scheduler has seen it go, try another worker, or name the lost ones.
                if not self._connected():
                    raise
                if not self._workers_left():
                    raise self._workers_lost(desc) from None
                if attempt == 2:
                    raise
        raise AssertionError("unreachable")

    def _worker_info(self) -> dict[str, Any]:
        """The scheduler's workers (address: info); every address seen is remembered for messages."""
        workers = self.client.scheduler_info().get("workers", {})
        self._seen.update(workers)
        return workers

    def _workers_left(self, settle_s: float = 2.0) -> bool:
        """Whether the cluster still has a worker once the scheduler has had time to see a death."""
        import time

        deadline = time.monotonic() + settle_s
        while self._worker_info():
            if time.monotonic() > deadline:
                return True
            time.sleep(0.2)
        return False

    def _completed(self, ac, desc: str) -> Iterator[Any]:
        """The futures of ``ac`` as they finish, until it is empty.

        Dask keeps tasks waiting for workers for good: when the cluster has had no worker for
        :data:`WORKERLESS_SECONDS`, the job ends with a message naming the workers it lost.
        """
        import time

        since: float | None = None
        checked = 0.0
        while True:
            if ac.has_ready():
                since = None
                yield next(ac)
                continue
            if ac.is_empty():
                return
            now = time.monotonic()
            if now - checked >= 1.0 and self._connected():
                checked = now
                if self._worker_info():
                    since = None
                elif since is None:
                    since = now
                elif now - since > WORKERLESS_SECONDS:
                    raise self._workers_lost(desc)
            with ac.thread_condition:
                ac.thread_condition.wait(timeout=0.1)

    def _workers_lost(self, desc: str) -> UserError:
        where = (
            f"the Dask scheduler at {self.plan.address}"
            if self.plan.kind == "remote"
            else "the local Dask cluster"
        )
        lost = ", ".join(sorted(self._seen)) or "none seen"
        fix = (
            f"start workers with `dask worker {self.plan.address}` (each with at least compute.memory_per_task), "
            "then run the job again"
            if self.plan.kind == "remote"
            else "run the job again, with fewer workers (--workers) or a larger compute.memory_per_task"
        )
        return UserError(
            f"{desc}: every worker of {where} is gone (lost: {lost}) and none joined within "
            f"{WORKERLESS_SECONDS:g} s; {fix}; no partial outputs were kept"
        )

    def _result(self, fut, desc: str) -> Any:
        from distributed import KilledWorker

        try:
            return fut.result()
        except CancelledError:
            if not self._connected():
                raise self._scheduler_lost(desc) from None
            raise
        except KilledWorker:
            raise UserError(
                f"{desc}: a worker died running a task (most often it ran out of memory: each worker may use "
                "compute.memory_per_task plus its start-up size); raise compute.memory_per_task or use fewer, "
                "larger workers"
            ) from None

    def close(self) -> None:
        """Stop the progress bar, the client and a cluster this executor started."""
        super().close()
        with contextlib.suppress(Exception):
            # A client that lost its scheduler would otherwise try to reconnect until its timeout.
            self.client.close(timeout=CLOSE_SECONDS)
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close()
            self._cluster = None


def _probe(address: str) -> None:
    """Fail fast when nothing listens at a TCP scheduler address, or something listens and never speaks.

    Dask retries a refused connection until its timeout, and waits for a silent server's
    handshake for good; this fails at once, or after :data:`HANDSHAKE_SECONDS`.

    Raises:
        ConnectionRefusedError: The host answered that nothing listens on that port.
        TimeoutError: The port accepted the connection but sent no handshake.
        ConnectionResetError: The port accepted the connection and closed it at once.
    """
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(address)
        host, port = parse_host_port(loc, default_port=8786)
    except (ValueError, TypeError):
        return  # Dask names the problem with the address itself
    if scheme not in ("tcp", "tls"):
        return
    try:
        sock = socket.create_connection((host, port), timeout=PROBE_SECONDS)
    except ConnectionRefusedError as exc:
        raise ConnectionRefusedError(exc.errno, f"connection refused by {host}:{port}") from None
    except OSError:
        return  # no answer yet (a slow network): Dask waits up to CONNECT_TIMEOUT
    if scheme != "tcp":
        sock.close()
        return  # a TLS server waits for the client's hello
    # A Dask server speaks first (its handshake), and Dask's client waits for it without a
    # timeout: a port that accepts and stays silent would hang the job for good.
    with sock:
        sock.settimeout(HANDSHAKE_SECONDS)
        try:
            greeting = sock.recv(1)
        except TimeoutError:
            raise TimeoutError(
                f"{host}:{port} accepted the connection but sent nothing in {HANDSHAKE_SECONDS:g} s: "
                "not a Dask scheduler, or one that hangs"
            ) from None
        except OSError:
            return  # reset or the like: Dask names it
    if not greeting:
        raise ConnectionResetError(f"{host}:{port} closed the connection at once: not a Dask scheduler")


def _pickled_size(item: Any) -> int:
    """Bytes of ``item`` pickled as Dask sends it (its pickler, arrays as out-of-band buffers)."""
    from distributed.protocol.pickle import dumps

    buffers: list = []
    head = dumps(item, buffer_callback=buffers.append)
    return len(head) + sum(memoryview(b).nbytes for b in buffers)


def _quiet_dask_logs() -> None:
    """Dask's own log lines are noise to a user; -v keeps them.

    Its INFO lines report a cluster's start and slow event loops; its ERROR lines repeat, less
    clearly, what the job then reports in one line (a lost scheduler was logged as "failed to
    reconnect after 15.00 seconds" whatever the time it took).
    """
    level = (
        logging.DEBUG if logging.getLogger("stencil_cad").isEnabledFor(logging.DEBUG) else logging.CRITICAL
    )
    # Dask's logging config gives some of its loggers (distributed.client ...) a level of their own.
    names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] in ("distributed", "tornado")]
    for name in {"distributed", "tornado", "distributed.client", *names}:
        logging.getLogger(name).setLevel(level)


@contextlib.contextmanager
def executor(
    cfg: ComputeConfig, picture_px: int, quiet: bool = False, mural_seconds: float | None = None
) -> Iterator[Executor]:
    """The executor for a job: in this process, or a cluster started (and stopped) here.

    Args:
        cfg: The ``compute`` section.
        picture_px: Pixels of the working picture, for :func:`plan`.
        quiet: No progress bar.
        mural_seconds: A tiled mural's estimated work in seconds, for :func:`plan`, or None.
    """
    p = plan(cfg, picture_px, mural_seconds)
    log.info("compute: %s (%s)", p.kind, p.reason)
    ex: Executor = Executor(p, quiet) if p.kind == "in_process" else DaskExecutor(p, cfg, quiet)
    try:
        yield ex
    finally:
        ex.close()
