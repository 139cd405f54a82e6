"""The manifest's figures read back: ``Figures.from_json`` then ``to_json`` gives the same JSON, key for
key and in the same order, for a soft job (its paints snapped to a catalogue), a hard job and a
two-tile mural; the instruction sheet read from the manifest on disk says what the job's sheet says."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from jobs import HARD_CANS, small_hard, small_soft

from stencil_cad import instructions
from stencil_cad.cli import main
from stencil_cad.figures import Figures, PlateRow

SOFT = small_soft("figures soft")
HARD = small_hard("figures hard")
CANS = HARD_CANS

#: Two tiles on the MK4's bed (as ``benchmarks.compare_outputs``' mural, smaller).
MURAL = """\
name: figures mural
size: {width_mm: 240, height_mm: 60, px_per_mm: 2}
bed: prusa_mk4
decompose: {layers: 2}
stipple: {process: fdm}
"""


def _job(root: Path, text: str, command: str) -> Path:
    (root / "cans.csv").write_text(CANS)
    cfg = root / "job.yaml"
    cfg.write_text(text)
    out = root / "out"
    assert main([command, str(cfg), "--out", str(out), "-q", "--workers", "0"]) == 0
    return out


# The hard job runs in the fast suite; the soft job and the mural (a minute together) are slow.
@pytest.fixture(
    scope="module",
    params=[
        pytest.param("soft", marks=pytest.mark.slow),
        "hard",
        pytest.param("mural", marks=pytest.mark.slow),
    ],
)
def job(request, tmp_path_factory):
    text, command = {"soft": (SOFT, "run"), "hard": (HARD, "hard"), "mural": (MURAL, "run")}[request.param]
    return request.param, _job(tmp_path_factory.mktemp(request.param), text, command)


def test_figures_read_back_give_the_same_json(job):
    name, out = job
    manifest = json.loads((out / "manifest.json").read_text())
    figures = Figures.from_json(manifest)
    again = figures.to_json()
    sections = {k: v for k, v in manifest.items() if k in again}
    # Every stage section is read, and written again as it was (order included).
    assert set(sections) >= {"picture", "plate", "spray_order", "build", "simulate", "spraying"}
    assert json.dumps(again) == json.dumps(sections)
    assert Figures.from_json(json.loads(json.dumps(again))).to_json() == again
    if name == "soft":
        assert figures.cans is not None and figures.cans.snap is not None and figures.cans.snap.paints
    if name == "hard":
        assert figures.hard is not None and figures.hard.per_layer
        assert all(p.cutouts is not None for p in figures.build.plates)
    if name == "mural":
        assert figures.mural is not None and figures.mural.tiled and figures.build.tiled
        assert figures.mural.simulation is not None and figures.mural.simulation.registration_cost


def test_the_sheet_from_disk_says_what_the_jobs_sheet_says(job):
    _, out = job
    manifest = json.loads((out / "manifest.json").read_text())
    sheet = instructions.sheet_from_manifest(manifest)
    html = (out / "instructions.html").read_text()
    for step in sheet.steps:
        assert step.plate in html and step.hex in html
    assert all(text in html for text, _ in sheet.checks[:5])
    assert sheet.viewing.split(" (")[0] in html


def test_a_keyed_row_keeps_the_keys_it_does_not_type():
    row = {"layer": 2, "volume": 10.5, "valid": True, "mesh": {"genus": 3, "triangles": 9}, "print": "no"}
    plate = PlateRow.from_json(row)
    assert plate.layer == 2 and plate.valid and plate.mesh is not None and plate.mesh.genus == 3
    assert plate.other == {"volume": 10.5, "print": "no"}
    assert list(plate.to_json().items()) == list(row.items())
