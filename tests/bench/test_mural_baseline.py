"""``python -m benchmarks mural --baseline COMMIT``: the same job with the commit's code, in the same call."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks import mural
from benchmarks.__main__ import main


def test_the_baseline_row_gives_the_commits_seconds_and_the_ratio(monkeypatch, tmp_path):
    calls = []

    def fake_run_case(name, case, tmp, job=None, root=mural.REPO):
        calls.append((name, root == mural.REPO))
        seconds = 100.0 if root == mural.REPO else 400.0
        out = Path(tmp) / f"{name}{'' if root == mural.REPO else '-baseline'}"
        out.mkdir()
        return {
            "bench": "mural",
            "case": name,
            "seconds": seconds,
            "cpu_seconds": seconds * 1.5,
            "scielab": 1.7,
        }, out

    def fake_export(commit, dest):
        dest.mkdir(parents=True)
        return "f" * 40

    monkeypatch.setattr(mural, "_run_case", fake_run_case)
    monkeypatch.setattr(mural, "export_tree", fake_export)
    rows = list(mural.run(baseline="1e9aeab"))
    # Only the issue's mural by default, the commit's run first.
    assert calls == [("mural600", False), ("mural600", True)]
    (row,) = rows
    assert row["baseline_seconds"] == 400.0 and row["baseline_cpu_seconds"] == 600.0
    assert row["ratio_vs_baseline"] == 0.25 and row["cpu_ratio_vs_baseline"] == 0.25
    assert row["baseline_commit"] == "f" * 40 and row["baseline"]["case"] == "mural600"


def test_the_mural600_job_is_the_issues(tmp_path):
    out, cmd = mural._command("mural600", mural.CASES["mural600"], tmp_path, None, mural.REPO)
    import yaml

    cfg = yaml.safe_load((tmp_path / "mural600.yaml").read_text())
    assert cfg["size"] == {"width_mm": 600.0} and cfg["decompose"] == {"layers": 3}
    assert cfg["stipple"] == {"process": "fdm"} and cfg["view"] == {"distance_m": 3}
    assert Path(cfg["image"]).name == "coffee.png"
    assert cmd[cmd.index("--bed") + 1] == "prusa_mk4" and "--workers" not in cmd


@pytest.mark.parametrize(
    "argv",
    [
        ["mural", "--baseline", "no-such-commit-xyz"],
        ["mural", "--case", "no-such-case"],
        ["spray", "--baseline", "HEAD"],
    ],
)
def test_bad_baseline_or_case_is_a_usage_error(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert "error:" in capsys.readouterr().err
