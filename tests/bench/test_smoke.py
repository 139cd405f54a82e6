"""Every benchmark has a tiny case CI runs (`python -m benchmarks --smoke`), checked for its readers' keys."""

from __future__ import annotations

import importlib

import pytest

from benchmarks.__main__ import NAMES, SMOKE_ONLY, smoke_problems


@pytest.mark.parametrize("name", NAMES + SMOKE_ONLY)
def test_every_benchmark_has_a_smoke_case_and_the_keys_its_readers_use(name):
    module = importlib.import_module(f"benchmarks.{name}")
    assert callable(getattr(module, "smoke", None)), f"benchmarks/{name}.py has no smoke()"
    keys = getattr(module, "SMOKE_KEYS", None)
    assert isinstance(keys, tuple) and keys and all(isinstance(k, str) for k in keys)


def test_a_smoke_row_without_a_key_or_with_an_error_is_a_problem():
    good = {"bench": "spray", "case": "x", "seconds": 1.0}
    assert smoke_problems("spray", [good], ("seconds",)) == []
    assert smoke_problems("spray", [], ("seconds",)) == ["spray: no rows"]
    assert "missing seconds" in smoke_problems("spray", [{"bench": "spray", "case": "x"}], ("seconds",))[0]
    assert "error" in smoke_problems("spray", [{**good, "error": "ValueError: boom"}], ("seconds",))[0]


def test_the_smoke_runner_exits_1_when_a_benchmark_breaks(monkeypatch, capsys):
    from benchmarks import __main__ as runner
    from benchmarks import wall_dxf

    monkeypatch.setattr(
        wall_dxf, "smoke", lambda: iter([{"bench": "wall_dxf", "case": "x", "error": "boom"}])
    )
    assert runner.main(["wall_dxf", "--smoke"]) == 1
    assert "FAILED" in capsys.readouterr().err
