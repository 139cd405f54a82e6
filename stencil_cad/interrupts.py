"""Signals that stop a run: Ctrl-C, SIGTERM (``timeout``, ``docker stop``), SIGHUP (a closed terminal).

Each raises :class:`Interrupted` in the main thread, so every ``finally`` and ``with`` on the way
up discards what the run staged, and the command line exits with 128 + the signal number.

Two traps of raising from a signal handler, both measured on CPython 3.11 by sending signals at
random moments to `stencil-cad run` with an empty numba cache (4 runs in 24 went wrong):

- An exception raised while C code runs a Python callback is printed ("Exception ignored on calling
  ctypes callback") and dropped: numba compiles through such callbacks. The run then went on
  to finish (exit 0), or the half-done compile failed later with a ``RuntimeError``. So the handler
  also *records* the signal: :func:`check` raises it again at the next stage boundary, before the
  results are moved into place, and a failure after a recorded signal is reported as the interrupt.
- A bare ``KeyboardInterrupt`` that leaves an ``exec()`` of source text (dataclasses and numba build
  functions that way) marks the interpreter to kill itself with SIGINT at exit when run as
  ``python -m``, even if the exception is caught later: the exit code became -2 instead of 129.
  A subclass of ``KeyboardInterrupt`` is not marked, so the handler raises :class:`Interrupted`.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

#: The signals turned into :class:`Interrupted` (SIGHUP does not exist on Windows).
SIGNALS = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None)

_pending: int | None = None
#: True while a block runs that a signal must not cut short (see :func:`held`).
_deferred = False


class Interrupted(KeyboardInterrupt):
    """A signal stopped the run; ``signum`` is its number."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``SIGTERM``."""
        return signal.Signals(self.signum).name


def pending() -> int | None:
    """The signal received during the current run, if any."""
    return _pending


def check() -> None:
    """Raise :class:`Interrupted` if a signal arrived whose exception was dropped on the way.

    Raises:
        Interrupted: A signal was received during this run.
    """
    if _pending is not None:
        raise Interrupted(_pending)


def _handler(signum: int, _frame) -> None:
    global _pending
    _pending = signum
    if not _deferred:
        raise Interrupted(signum)


@contextlib.contextmanager
def held() -> Iterator[None]:
    """Run a block that must not be cut short (moving results into place, putting them back).

    A signal received before the block stops the run before it starts; one received during it
    is only recorded (the handler runs in the main thread whichever thread the OS woke, so a
    signal mask could not hold it back): the block finishes, and the next :func:`check` stops
    the run.

    Raises:
        Interrupted: A signal was received before the block.
    """
    global _deferred
    check()
    outer, _deferred = _deferred, True
    try:
        yield
    finally:
        _deferred = outer


@contextlib.contextmanager
def as_interrupts() -> Iterator[None]:
    """Turn the stopping signals into :class:`Interrupted` for the duration of the block.

    Outside the main thread (where Python cannot set handlers) the block runs unchanged, and a
    signal the parent set to be ignored (``nohup``, a background job of a script) stays ignored.
    An error raised after a signal was received leaves the block as that :class:`Interrupted`,
    chained to the error: the signal caused it (a compile it cut short, say). A signal recorded
    but dropped after the last check (the results have landed) does not undo them: the block
    ends normally.
    """
    global _pending, _deferred
    outer = _pending
    old: dict[int, object] = {}
    try:
        _pending = None
        if threading.current_thread() is threading.main_thread():
            for sig in SIGNALS:
                current = signal.getsignal(sig)
                if current is signal.SIG_IGN or current is None:
                    continue
                old[sig] = signal.signal(sig, _handler)
        yield
    except Interrupted:
        raise
    except BaseException as exc:
        if _pending is not None:
            raise Interrupted(_pending) from exc
        raise
    finally:
        # A signal while the handlers are put back is recorded, not raised half-way through.
        deferred, _deferred = _deferred, True
        for sig, h in old.items():
            signal.signal(sig, h)  # type: ignore[arg-type]
        _deferred = deferred
        _pending = outer


class Cancelled(Exception):
    """A caller of the Python API (the studio, a script) cancelled the run through its :class:`CancelToken`.

    Like :class:`Interrupted` it leaves through every ``finally`` and ``with`` on the way up, so
    the output folder discards what the run staged.
    """


class CancelToken:
    """A flag a caller sets from any thread to stop a run at its next check.

    The run checks it at every stage edge and at every progress step of its long loops
    (decomposition iterations, refinement iterations, plates built).
    """

    def __init__(self) -> None:
        self._event = threading.Event()

    def cancel(self) -> None:
        """Ask the run to stop at its next check."""
        self._event.set()

    @property
    def cancelled(self) -> bool:
        """True once :meth:`cancel` was called."""
        return self._event.is_set()

    def check(self) -> None:
        """Raise :class:`Cancelled` if :meth:`cancel` was called.

        Raises:
            Cancelled: The run was cancelled.
        """
        if self._event.is_set():
            raise Cancelled("cancelled")
