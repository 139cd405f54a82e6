"""Can lists (stencil_cad.decompose.paints): parsing, the nearest can, paint estimates, palettes from a list."""

import json
from pathlib import Path

import numpy as np
import pytest

from stencil_cad.cli import main
from stencil_cad.decompose import paints

CATALOGUE = Path(__file__).resolve().parents[2] / "stencil_cad" / "data" / "example_cans.csv"


def test_can_list_parsing_and_errors():
    cans = paints.parse_cans("# my cans\nname,code,hex\nRed,R1,#ff0000\n\nBlue,,#0000FF\n")
    assert [c.hex for c in cans] == ["#ff0000", "#0000ff"]
    assert cans[0].label == "Red (R1)" and cans[1].label == "Blue"
    with pytest.raises(ValueError, match="missing column"):
        paints.parse_cans("name,colour\nRed,#ff0000\n")
    with pytest.raises(ValueError, match="line 3: hex"):
        paints.parse_cans("name,code,hex\nRed,R1,#ff0000\nBad,B,#zz0000\n")
    with pytest.raises(ValueError, match="line 3: colour #ff0000 is already can 1"):
        paints.parse_cans("name,code,hex\nRed,R1,#ff0000\nRed again,R2,#FF0000\n")
    with pytest.raises(ValueError, match="no cans"):
        paints.parse_cans("name,code,hex\n")
    assert len(paints.load_cans(CATALOGUE)) >= 8


def test_nearest_can_is_the_ciede2000_nearest():
    cans = paints.load_cans(CATALOGUE)
    for c in cans:
        idx, de = paints.nearest_cans(np.array([c.rgb]), cans)
        assert cans[idx[0]].hex == c.hex and de[0] < 1e-6
    from skimage.color import deltaE_ciede2000, rgb2lab

    colour = np.array([[0.8, 0.3, 0.1]])
    idx, de = paints.nearest_cans(colour, cans)
    lab = rgb2lab(np.array([[c.rgb for c in cans]]))[0]
    all_de = deltaE_ciede2000(rgb2lab(colour[None])[0], lab)
    assert idx[0] == int(np.argmin(all_de)) and de[0] == pytest.approx(all_de.min())


def test_paint_estimate():
    est = paints.paint_estimate(1e6, 0.5, coverage_m2_per_can=1.5, can_ml=400)
    assert est["covered_m2"] == pytest.approx(0.5)
    assert est["cans"] == pytest.approx(1 / 3)
    assert est["ml"] == pytest.approx(400 / 3)
    assert est["cans_to_buy"] == 1
    assert paints.paint_estimate(4e6, 1.0)["cans_to_buy"] == 3  # 4 m² / 1.5 m² per can


def test_palette_as_a_can_list_in_config(tmp_path):
    from stencil_cad.config.io import load_config

    (tmp_path / "mine.csv").write_text("name,code,hex\nRed,R1,#ff0000\nBlue,B1,#0000ff\n")
    cfg_path = tmp_path / "job.yaml"
    cfg_path.write_text(
        "decompose:\n  palette: mine.csv\nhard:\n  palette: mine.csv\npaints:\n  catalogue: mine.csv\n"
    )
    cfg = load_config(cfg_path)
    assert cfg.decompose.palette == tmp_path / "mine.csv"
    assert cfg.hard.palette == tmp_path / "mine.csv"
    assert cfg.paints.catalogue == tmp_path / "mine.csv"
    cfg_path.write_text("decompose:\n  palette: mine.txt\n")
    from stencil_cad.errors import ConfigError

    with pytest.raises(ConfigError, match="decompose.palette"):
        load_config(cfg_path)


def test_decompose_with_a_can_list_picks_cans_from_it(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(
        f"size:\n  width_mm: 30\n  px_per_mm: 2\ndecompose:\n  layers: 2\n  palette: {CATALOGUE}\n"
    )
    out = tmp_path / "out"
    assert main(["decompose", str(cfg), "--out", str(out), "-q"]) == 0
    m = json.loads((out / "manifest.json").read_text())
    hexes = {c.hex for c in paints.load_cans(CATALOGUE)}
    assert len(m["decompose"]["colours"]) == 2
    assert set(m["decompose"]["colours"]) <= hexes
    assert set(m["decompose"]["cans_chosen"]) <= hexes


def test_missing_can_list_is_a_clear_error(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("size:\n  width_mm: 30\n  px_per_mm: 2\ndecompose:\n  palette: nowhere.csv\n")
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "decompose.palette: can list not found" in err and "nowhere.csv" in err
    assert not out.exists() or not any(out.iterdir())
