"""Tasks in this process: :class:`Executor` (the base of :class:`~.executors.DaskExecutor`) and :class:`Started`.

Nothing here imports Dask.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from .. import interrupts
from .planning import Plan


class Executor:
    """Runs task functions in this process; :class:`DaskExecutor` runs them on a cluster.

    Args:
        plan: Where the job runs.
        quiet: No progress bar.
    """

    def __init__(self, plan: Plan, quiet: bool = False):
        self.plan = plan
        self.quiet = quiet
        self._bar: Any = None  # a tqdm bar (tqdm ships no type information)
        self.tasks = 0

    @property
    def workers(self) -> int:
        """Processes running tasks (1 for this process)."""
        return 1

    def _progress(self, n: int, desc: str):
        """The job's one progress bar, grown by ``n`` tasks."""
        if self._bar is None:
            from tqdm.auto import tqdm

            # disable=None: no bar when stderr is not a terminal (logs, CI).
            self._bar = tqdm(
                total=0, desc="tasks", disable=True if self.quiet else None, leave=False, unit="task"
            )
        self._bar.total += n
        self._bar.set_description(desc, refresh=False)
        self._bar.refresh()
        self.tasks += n
        return self._bar

    def map(
        self, fn: Callable[[Any], Any], items: Iterable[Any], desc: str, count: int | None = None
    ) -> Iterator:
        """Apply ``fn`` to every item; yield the results in item order.

        Args:
            fn: A module-level function (a cluster imports it by name).
            items: Its arguments, one per task; consumed lazily.
            desc: What the tasks do, for the progress bar.
            count: Number of items, when ``items`` has no length.

        Yields:
            ``fn(item)`` for each item, in order.
        """
        items = list(items) if count is None and not isinstance(items, Sequence) else items
        bar = self._progress(count if count is not None else len(items), desc)  # type: ignore[arg-type]
        for item in items:
            interrupts.check()
            result = fn(item)
            bar.update(1)
            yield result

    def start(self, fn: Callable[..., Any], items: Iterable[Any], desc: str, shared: Any = None) -> Started:
        """Start ``fn(item, shared)`` (``fn(item)`` without ``shared``) on every item now; collect the results later.

        For the few long tasks of a stage that this process need not wait for (the simulation's
        other cans, a mural's registration cases): a cluster runs them while this process goes on
        with its own work. Here in this process they run when their results are asked for, in order.

        Args:
            fn: A module-level function (a cluster imports it by name).
            items: Its first argument, one per task.
            desc: What the tasks do, for the progress bar.
            shared: Its second argument, the same for every task (a cluster receives it once per
                worker, however many tasks read it), or None: ``fn`` takes the item alone.

        Returns:
            The started tasks.
        """
        items = list(items)
        bar = self._progress(len(items), desc)

        def results() -> Iterator[Any]:
            for item in items:
                interrupts.check()
                result = fn(item) if shared is None else fn(item, shared)
                bar.update(1)
                yield result

        return Started(results)

    def close(self) -> None:
        """Stop the progress bar (and the cluster)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


class Started:
    """Tasks started by :meth:`Executor.start`: their results, in item order, once asked for.

    Args:
        results: Yields the results in item order, waiting for each.
        cancel: Drops the tasks not yet collected, or None.
    """

    def __init__(self, results: Callable[[], Iterator[Any]], cancel: Callable[[], None] | None = None):
        self._results = results
        self._cancel = cancel
        self._done: list[Any] | None = None

    def results(self) -> list[Any]:
        """Every task's result, in item order (waits for the ones still running; collected once)."""
        if self._done is None:
            try:
                self._done = list(self._results())
            finally:
                self.cancel()
        return self._done

    def cancel(self) -> None:
        """Drop the tasks whose results were not collected (a stage that failed meanwhile)."""
        if self._cancel is not None:
            self._cancel()
            self._cancel = None
