"""No placeholder reaches a maker's page: the sheets of the example, a hard laser job (and, in
tests/mural/test_sheet.py, a mural) hold a value wherever one belongs, never "?", "None", "nan" or "–"."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from jobs import HARD_CANS, small_hard
from placeholders import html_text, placeholders
from readers import need, run

from stencil_cad.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "stencil_cad" / "data" / "example.yaml"

HARD = small_hard("hard placeholders")


def test_the_checker_finds_placeholders():
    text = html_text(
        "<table><tr><td>primer</td><td>–</td></tr></table><p>The plate (? cut-outs)</p>"
        "<p>spray time None</p><li>score nan</li><p>x 120.0–240.0 mm, 3 passes</p>"
    )
    found = placeholders(text)
    assert len(found) == 4 and not any("120.0" in f for f in found)


def _pages(out: Path) -> tuple[str, str]:
    pdf = run([need("pdftotext"), "-layout", str(out / "instructions.pdf"), "-"])
    assert pdf.returncode == 0, pdf.stderr
    return html_text((out / "instructions.html").read_text()), pdf.stdout


@pytest.mark.slow
def test_example_sheet_has_no_placeholder(tmp_path):
    """The bundled example's job at a third of its size (the same layers, process and calibration)."""
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg["image"] = str(EXAMPLE.parent / cfg["image"])
    cfg["size"]["width_mm"] = 50.0
    path = tmp_path / "example.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "-q"]) == 0
    html, pdf = _pages(out)
    assert placeholders(html) == [] and placeholders(pdf) == []
    # Every paint has a name (the shipped colour names), and the print advice names the FDM profile the
    # example is designed for.
    spray = json.loads((out / "spray.json").read_text())
    assert spray["primer"]["name"].startswith("~") and all(o["name"].startswith("~") for o in spray["order"])
    assert "prusa_fdm" in html


@pytest.mark.slow
def test_hard_sheet_and_summary_speak_of_cut_outs(tmp_path, capsys):
    (tmp_path / "cans.csv").write_text(HARD_CANS)
    (tmp_path / "job.yaml").write_text(HARD)
    out = tmp_path / "out"
    assert main(["hard", str(tmp_path / "job.yaml"), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "0 mm holes" not in said and "cut-outs  plate 01" in said
    html, pdf = _pages(out)
    assert placeholders(html) == [] and placeholders(pdf) == []
    m = json.loads((out / "manifest.json").read_text())
    for p in m["build"]["plates"]:
        c = p["cutouts"]
        assert c["count"] == p["hole_count"] > 0 and 0 < c["span_min_mm"] <= c["span_max_mm"]
        assert f"The plate ({c['count']:,} cut-outs, " in html
        # A laser job: cut length and an estimated cut time per plate.
        assert f"cut length {p['cut_length_mm'] / 1000:.2f} m, about" in html
