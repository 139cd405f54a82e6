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


def test_the_last_paint_step_is_the_simulated_picture():
    # The stage passes simulated.png's bytes for the last step instead of encoding it again.
    import numpy as np

    from stencil_cad.config import JobConfig
    from stencil_cad.exchange.png import png_bytes
    from stencil_cad.model import composite
    from stencil_cad.pipeline.simulate import paint_steps

    rng = np.random.default_rng(2)
    primer, colours, alphas = rng.random(3), rng.random((3, 3)), rng.random((3, 20, 30))
    whole = png_bytes(np.clip(composite(primer, colours, alphas), 0.0, 1.0))
    steps, paint = paint_steps(JobConfig(), primer, colours, alphas, 0.5)
    again, same = paint_steps(JobConfig(), primer, colours, alphas, 0.5, whole)
    assert steps == again and paint == same and steps[-1] == whole
    assert steps[0] == png_bytes(np.clip(composite(primer, colours[:1], alphas[:1]), 0.0, 1.0))
