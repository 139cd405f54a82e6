"""``python -m benchmarks mural --baseline COMMIT``: the same job with the commit's code, in the same call."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks import mural
from benchmarks.__main__ import main


def test_the_baseline_row_gives_the_commits_seconds_and_the_ratio(monkeypatch, tmp_path):
    calls = []
    # CPU seconds of the counted runs, in the order they are made: the baseline's then ours, three times.
    theirs_cpu = iter([700.0, 600.0, 650.0])
    ours_cpu = iter([150.0, 140.0, 160.0])

    def fake_run_case(name, case, tmp, job=None, root=mural.REPO):
        ours = root == mural.REPO
        calls.append((name, ours))
        out = Path(tmp) / f"{name}{'' if ours else '-baseline'}"
        out.mkdir()
        (out / "manifest.json").write_text("{}")
        if name == "smoke":
            # The warm-up: it compiles the kernels and is not counted.
            return {"bench": "mural", "case": name, "seconds": 1.0, "cpu_seconds": 9999.0}, out
        cpu = next(ours_cpu) if ours else next(theirs_cpu)
        return {
            "bench": "mural",
            "case": name,
            "seconds": cpu / 1.5,
            "cpu_seconds": cpu,
            "scielab": 1.7,
        }, out

    def fake_export(commit, dest):
        dest.mkdir(parents=True)
        return "f" * 40

    monkeypatch.setattr(mural, "_run_case", fake_run_case)
    monkeypatch.setattr(mural, "export_tree", fake_export)
    rows = list(mural.run(baseline="1e9aeab"))
    # Only the issue's mural by default: each tree warms up once, then the commit's run and ours in turn.
    assert calls == [("smoke", False), ("smoke", True)] + [("mural600", False), ("mural600", True)] * 3
    (row,) = rows
    # Each side's median run by CPU seconds.
    assert row["cpu_seconds"] == 150.0 and row["baseline_cpu_seconds"] == 650.0
    assert row["cpu_seconds_runs"] == [150.0, 140.0, 160.0]
    assert row["baseline"]["cpu_seconds_runs"] == [700.0, 600.0, 650.0]
    assert row["cpu_ratio_vs_baseline"] == round(150.0 / 650.0, 3)
    assert row["ratio_vs_baseline"] == round(100.0 / (650.0 / 1.5), 3)
    assert row["baseline_commit"] == "f" * 40 and row["baseline"]["case"] == "mural600"
    assert "folder" not in row


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
