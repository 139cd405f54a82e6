"""The cost model against PrusaSlicer on the bundled example: the manifest's ``cost`` within 15 % of the slicer."""

from __future__ import annotations

import json

import pytest

from stencil_cad import slicing as sl
from stencil_cad.cli import main
from stencil_cad.mural.cost import FILAMENT_MM2, PLA_G_PER_MM3
from stencil_cad.pipeline import print_estimate, slice_plates

needs_prusa = pytest.mark.skipif(sl.find_slicer(sl.Slicer.PRUSA) is None, reason="prusa-slicer not installed")


@pytest.mark.slow
@needs_prusa
def test_example_cost_is_within_15_percent_of_the_slicer(tmp_path):
    out = tmp_path / "example"
    assert main(["run", "--out", str(out), "-q"]) == 0
    cost = json.loads((out / "manifest.json").read_text())["cost"]
    assert cost["basis"] == "holes" and cost["printer_hours"] > 0 and cost["filament_g"] > 0
    stems = {
        (p["kind"], p["layer"]): ("wall" if p["kind"] == "wall" else f"layer_{p['layer']:02d}")
        for p in cost["parts"]
    }
    hours = grams = 0.0
    for (kind, layer), stem in stems.items():
        [(_, gcode, result)] = list(slice_plates([out / f"{stem}.stl"], "prusa_fdm", timeout_s=900))
        assert result.ok, result.errors
        est = print_estimate(gcode)
        part = next(p for p in cost["parts"] if (p["kind"], p["layer"]) == (kind, layer))
        got_h, got_g = est.print_s / 3600, est.filament_m * 1000 * FILAMENT_MM2 * PLA_G_PER_MM3
        assert part["print_hours"] == pytest.approx(got_h, rel=0.15), stem
        assert part["filament_g"] == pytest.approx(got_g, rel=0.15), stem
        hours, grams = hours + got_h, grams + got_g
    assert cost["printer_hours"] == pytest.approx(hours, rel=0.15)
    assert cost["filament_g"] == pytest.approx(grams, rel=0.15)
