"""The collector settings of a process that makes jobs."""

from __future__ import annotations

import gc
import sys

import pytest

from stencil_cad.runtime import THRESHOLDS, tune_allocator, tune_collector


@pytest.fixture
def restored_collector():
    before = gc.get_threshold()
    yield
    gc.unfreeze()
    gc.set_threshold(*before)


def test_tune_collector_raises_thresholds_and_freezes_once(restored_collector):
    gc.set_threshold(700, 10, 10)
    tune_collector()
    assert gc.get_threshold() == THRESHOLDS
    frozen = gc.get_freeze_count()
    assert frozen > 0
    kept = [object() for _ in range(10)], {"cycle": None}
    kept[1]["cycle"] = kept  # a new tracked object, alive now
    tune_collector()
    # Tuned already: nothing more is frozen.
    assert gc.get_freeze_count() == frozen


def test_the_command_line_tunes_its_process(restored_collector, tmp_path, capsys):
    from stencil_cad.cli import main

    gc.set_threshold(700, 10, 10)
    assert main([]) == 2  # no command: the help, and no job
    assert gc.get_threshold() == (700, 10, 10)
    assert main(["run", str(tmp_path / "missing.yaml")]) == 2
    capsys.readouterr()
    assert gc.get_threshold() == THRESHOLDS


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_tune_allocator_sets_glibc_settings():
    import platform

    if platform.libc_ver()[0] != "glibc":
        pytest.skip("not glibc")
    assert tune_allocator() is True
