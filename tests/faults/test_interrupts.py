"""Signals stop a run cleanly even where Python would lose or misreport them."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest

from stencil_cad import interrupts
from stencil_cad.cli import main
from stencil_cad.output import OutputDir


def _swallowed(sig: int) -> None:
    """Deliver ``sig`` where its exception is dropped, as a C library's callback does."""
    try:
        os.kill(os.getpid(), sig)
        for _ in range(1000):  # the handler runs between bytecodes, soon after the kill
            pass
    except BaseException:  # noqa: BLE001 - the point: the exception is lost here
        pass


@pytest.mark.parametrize("sig", interrupts.SIGNALS)
def test_a_signal_raises_interrupted_with_its_number(sig):
    with pytest.raises(interrupts.Interrupted) as info, interrupts.as_interrupts():
        os.kill(os.getpid(), sig)
        for _ in range(1000):
            pass
    assert info.value.signum == sig
    assert info.value.name == signal.Signals(sig).name
    assert isinstance(info.value, KeyboardInterrupt)
    assert interrupts.pending() is None


def test_the_handlers_are_put_back():
    before = {s: signal.getsignal(s) for s in interrupts.SIGNALS}
    with interrupts.as_interrupts():
        assert all(signal.getsignal(s) is not before[s] for s in interrupts.SIGNALS)
    assert {s: signal.getsignal(s) for s in interrupts.SIGNALS} == before


def test_a_dropped_signal_stops_the_run_at_the_next_check():
    with pytest.raises(interrupts.Interrupted) as info, interrupts.as_interrupts():
        _swallowed(signal.SIGTERM)
        assert interrupts.pending() == signal.SIGTERM
        interrupts.check()
        raise AssertionError("check() did not raise")
    assert info.value.signum == signal.SIGTERM


def test_an_error_after_a_dropped_signal_is_reported_as_the_interrupt():
    with pytest.raises(interrupts.Interrupted) as info, interrupts.as_interrupts():
        _swallowed(signal.SIGHUP)
        raise RuntimeError("no compiled object yet")
    assert info.value.signum == signal.SIGHUP
    assert isinstance(info.value.__cause__, RuntimeError)


def test_an_error_without_a_signal_stays_itself():
    with pytest.raises(ValueError), interrupts.as_interrupts():
        raise ValueError("x")


def test_no_results_land_after_a_dropped_signal(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(interrupts.Interrupted), interrupts.as_interrupts():
        od = OutputDir(out)
        try:
            od.write_bytes("a.txt", b"a")
            _swallowed(signal.SIGTERM)
            od.commit()
        finally:
            od.abort()
    assert not out.exists() or not any(out.iterdir())


def test_the_command_line_reports_a_dropped_signal(tmp_path, capsys, monkeypatch):
    import stencil_cad.cli as cli

    def dispatch(_args):
        _swallowed(signal.SIGTERM)
        raise RuntimeError("half-done compile")

    monkeypatch.setattr(cli, "_dispatch", dispatch)
    code = main(["schema"])
    err = capsys.readouterr().err
    assert code == 128 + signal.SIGTERM, err
    assert "interrupted (SIGTERM); no partial outputs were kept" in err
    assert "internal error" not in err


def test_an_interrupt_out_of_exec_keeps_its_exit_code(tmp_path):
    # CPython marks a bare KeyboardInterrupt that leaves exec() of source text and, under
    # `python -m`, kills the process with SIGINT at exit even though it was caught: exit -2.
    mod = tmp_path / "interrupt_in_exec.py"
    mod.write_text(
        textwrap.dedent(
            """
            import os, signal
            from stencil_cad import interrupts
            try:
                with interrupts.as_interrupts():
                    exec("os.kill(os.getpid(), signal.SIGHUP)\\nfor _ in range(1000): pass")
            except KeyboardInterrupt as exc:
                raise SystemExit(128 + exc.signum)
            """
        )
    )
    proc = subprocess.run(
        [sys.executable, "-m", "interrupt_in_exec"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 128 + signal.SIGHUP, proc.stderr


def test_a_signal_during_a_held_block_waits_for_its_end():
    done = []
    with pytest.raises(interrupts.Interrupted) as info, interrupts.as_interrupts():
        with interrupts.held():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
            done.append(True)
        interrupts.check()
    assert done == [True] and info.value.signum == signal.SIGTERM


def test_an_ignored_signal_stays_ignored():
    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        with interrupts.as_interrupts():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)
            for _ in range(1000):
                pass
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, old)


def _drop_a_signal(i):
    if i == 0:
        _swallowed(signal.SIGTERM)
    return i


def test_the_tasks_stop_at_the_next_item_after_a_dropped_signal():
    from stencil_cad import compute

    ex = compute.Executor(compute.Plan("in_process", reason="test"), quiet=True)
    seen = []
    with pytest.raises(interrupts.Interrupted), interrupts.as_interrupts():
        for r in ex.map(_drop_a_signal, range(5), "test"):
            seen.append(r)
    ex.close()
    assert seen == [0]


def test_a_stage_ends_the_run_after_a_dropped_signal(tmp_path):
    from stencil_cad.config import JobConfig
    from stencil_cad.pipeline import Run

    run = Run(cfg=JobConfig(), out=OutputDir(tmp_path / "out"), quiet=True)
    with pytest.raises(interrupts.Interrupted), interrupts.as_interrupts():
        with run.stage("one"):
            _swallowed(signal.SIGHUP)
    assert "one" not in run.times
