"""``benchmarks.e2e.paired``: both trees warm first, then their runs in turn, each side's median run."""

from __future__ import annotations

from benchmarks import e2e


def test_warm_once_each_then_alternate_and_take_the_median_run(tmp_path):
    root = tmp_path / "baseline"
    events = []
    cpu = {root: iter([50.0, 40.0, 45.0]), e2e.REPO: iter([70.0, 90.0, 60.0])}

    def warm(where, folder):
        events.append(("warm", where == e2e.REPO))

    def make(where, folder):
        events.append(("make", where == e2e.REPO))
        return {"cpu_seconds": next(cpu[where]), "folder": folder.name}

    ours, theirs = e2e.paired(tmp_path, root, make, warm)
    assert events == [("warm", False), ("warm", True)] + [("make", False), ("make", True)] * 3
    assert ours["cpu_seconds"] == 70.0 and ours["cpu_seconds_runs"] == [70.0, 90.0, 60.0]
    assert theirs["cpu_seconds"] == 45.0 and theirs["cpu_seconds_runs"] == [50.0, 40.0, 45.0]
    # Each side's median is one of its own runs, made in the folder of its turn.
    assert ours["folder"] == "paired-0" and theirs["folder"] == "paired-2"


def test_a_failed_run_is_not_the_median(tmp_path):
    runs = iter([{"cpu_seconds": 1.0, "error": "boom"}, {"cpu_seconds": 30.0}, {"cpu_seconds": 20.0}])
    ours, _ = e2e.paired(
        tmp_path,
        tmp_path / "b",
        lambda where, folder: next(runs) if where == e2e.REPO else {"cpu_seconds": 5.0},
        lambda where, folder: None,
    )
    assert "error" not in ours and ours["cpu_seconds"] in (20.0, 30.0)
