"""Stage commands in a run's folder: the folder's config, and later stages' files kept and marked stale."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from stencil_cad.cli import main

SMALL = "name: small\nsize: {width_mm: 40, px_per_mm: 2}\ndecompose: {layers: 2}\nstipple: {process: sla}\n"


def _shas(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir() if p.is_file()}


@pytest.mark.slow
def test_an_early_stage_keeps_later_files_and_marks_them_stale(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL)
    out = tmp_path / "run"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    before = _shas(out)
    capsys.readouterr()
    # No CONFIG: the folder's config.yaml (not the bundled example), and nothing removed.
    assert main(["decompose", "--out", str(out), "--force"]) == 0
    summary = capsys.readouterr().out
    after = _shas(out)
    assert set(after) == set(before)
    man = json.loads((out / "manifest.json").read_text())
    assert man["config"]["name"] == "small" and man["config"]["decompose"]["layers"] == 2
    later = {
        "layer_01_dots.csv",
        "spray.json",
        "layer_01.stl",
        "wall.step",
        "simulated.png",
        "instructions.pdf",
    }
    assert later <= set(man["stale"]["files"])
    assert all(after[n] == before[n] for n in man["stale"]["files"])
    assert "layers.npz" not in man["stale"]["files"] and "stipple" in man["stale"]["why"]
    assert "stale     " in summary and "layer_01_dots.csv" in summary
    # Stippling again brings the dots up to date; the plates and the simulation stay stale.
    assert main(["stipple", "--out", str(out), "--force", "-q"]) == 0
    man = json.loads((out / "manifest.json").read_text())
    stale = set(man["stale"]["files"])
    assert "layer_01_dots.csv" not in stale and "spray.json" not in stale
    assert {"layer_01.stl", "simulated.png", "instructions.html"} <= stale
