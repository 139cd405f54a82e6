"""The whole job through the command line on a small picture: outputs, manifest, stage commands."""

import json
import struct

import numpy as np
import pytest

from stencil_cad.cli import main

# Every test here runs whole jobs through the command line: the full suite's, not the quick loop's.
pytestmark = pytest.mark.slow

SMALL = """\
name: small
size:
  width_mm: 40
  px_per_mm: 2
decompose:
  layers: 2
stipple:
  process: sla
  tone: response
"""


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("job")
    cfg = root / "small.yaml"
    cfg.write_text(SMALL)
    out = root / "out"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    return root, cfg, out


def test_every_output_is_written(small_run):
    _, _, out = small_run
    names = {p.name for p in out.iterdir()}
    for i in (1, 2):
        for ext in (".step", ".stl", ".dxf", "_dots.csv", "_dots.png", "_opacity.png"):
            assert f"layer_{i:02d}{ext}" in names
    for n in (
        "wall.step",
        "wall.stl",
        "manifest.json",
        "preview.png",
        "simulated.png",
        "sweep.png",
        "layers.npz",
        "swatch.png",
        "composite.png",
        "energy.csv",
        "config.yaml",
    ):
        assert n in names
    assert not any(n.startswith(".") for n in names)


def test_manifest_lists_every_file_with_its_hash(small_run):
    import hashlib

    _, _, out = small_run
    m = json.loads((out / "manifest.json").read_text())
    listed = {row["name"]: row for row in m["files"]}
    on_disk = {p.name for p in out.iterdir()} - {"manifest.json"}
    assert set(listed) == on_disk
    for name, row in listed.items():
        data = (out / name).read_bytes()
        assert row["bytes"] == len(data)
        assert row["sha256"] == hashlib.sha256(data).hexdigest()
    assert m["versions"]["build123d"].startswith("0.12")
    assert m["versions"]["OCP"].startswith("7.9")
    assert set(m["seconds"]) >= {"decompose", "stipple", "build", "simulate"}
    assert m["config"]["name"] == "small"


def test_plates_valid_and_hole_counts_match_the_dots(small_run):
    _, _, out = small_run
    m = json.loads((out / "manifest.json").read_text())
    for plate, st in zip(m["build"]["plates"], m["stipple"], strict=True):
        assert plate["valid"] and plate["n_solids"] == 1
        # A hybrid plate's windows are through holes too.
        assert plate["hole_count"] == st["dots"] + st.get("windows", 0) and st["dots"] > 0
        assert plate["rel_error"] < 1e-6
        rows = (out / f"layer_{plate['layer']:02d}_dots.csv").read_text().strip().splitlines()
        assert len(rows) - 1 == st["dots"]
    assert all(w["valid"] for w in m["build"]["walls"])


def test_stl_is_binary_and_closed(small_run):
    _, _, out = small_run
    data = (out / "layer_01.stl").read_bytes()
    (n,) = struct.unpack("<I", data[80:84])
    assert len(data) == 84 + 50 * n
    tri = np.frombuffer(data[84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))["v"]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]).reshape(-1, 6)
    directed = {tuple(e) for e in np.round(edges, 5).tolist()}
    reverse = {tuple(e[3:] + e[:3]) for e in directed}
    assert directed == reverse, "every directed edge must meet its reverse (closed, consistently wound)"


def test_quality_figures_reach_the_manifest(small_run):
    _, _, out = small_run
    sim = json.loads((out / "manifest.json").read_text())["simulate"]
    for k in ("de2000_mean", "de2000_p95", "psnr", "ssim"):
        assert np.isfinite(sim[k])
    # One figure per plate: two paints, each a light and a dark plate.
    assert len(sim["layer_rmse"]) == 4


def test_same_seed_same_dots(small_run, tmp_path):
    _, cfg, out = small_run
    again = tmp_path / "again"
    assert main(["stipple", str(cfg), "--from", str(out), "--out", str(again), "-q"]) == 0
    for i in (1, 2):
        assert (again / f"layer_{i:02d}_dots.csv").read_text() == (
            out / f"layer_{i:02d}_dots.csv"
        ).read_text()


def test_stage_commands_chain(small_run, tmp_path):
    _, cfg, _ = small_run
    d = tmp_path / "stages"
    assert main(["decompose", str(cfg), "--out", str(d), "-q"]) == 0
    assert (d / "layers.npz").exists() and (d / "config.yaml").exists()
    assert main(["stipple", "--out", str(d), "-q"]) == 0
    assert (d / "layer_02_dots.csv").exists()
    assert main(["build", "--out", str(d), "-q"]) == 0
    assert (d / "layer_02.step").exists() and (d / "wall.stl").exists()
    assert main(["simulate", "--out", str(d), "-q"]) == 0
    assert (d / "simulated.png").exists()
    # A stage does not replace files it already wrote unless asked.
    assert main(["stipple", "--out", str(d), "-q"]) == 2
    assert main(["stipple", "--out", str(d), "-q", "--force"]) == 0


def test_build_rejects_overlapping_dots_and_writes_nothing(small_run, tmp_path, capsys):
    _, _, out = small_run
    d = tmp_path / "bad"
    d.mkdir()
    for name in (
        "layers.npz",
        "plan.json",
        "config.yaml",
        *(f"layer_{i:02d}_dots.csv" for i in (1, 2, 3, 4)),
    ):
        (d / name).write_bytes((out / name).read_bytes())
    rows = (d / "layer_01_dots.csv").read_text().splitlines()
    x, y, r = rows[1].split(",")
    rows.insert(2, f"{float(x) + 0.1:.4f},{y},{r}")
    (d / "layer_01_dots.csv").write_text("\n".join(rows) + "\n")
    before = sorted(p.name for p in d.iterdir())
    capsys.readouterr()
    assert main(["build", "--out", str(d)]) == 2
    err = capsys.readouterr().err
    assert "layer_01_dots.csv" in err and "dot 0" in err
    assert sorted(p.name for p in d.iterdir()) == before


def test_interrupted_run_leaves_nothing(tmp_path, monkeypatch):
    from stencil_cad.pipeline import run as pipeline_run

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline_run, "start_build", boom)
    cfg = tmp_path / "c.yaml"
    cfg.write_text(SMALL)
    assert main(["run", str(cfg), "--out", str(tmp_path / "o"), "-q"]) == 130
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]


@pytest.mark.slow
def test_slice_command_writes_gcode(small_run, tmp_path, capsys):
    from readers import need

    need("prusa-slicer")
    _, _, out = small_run
    stl = tmp_path / "layer_01.stl"
    stl.write_bytes((out / "layer_01.stl").read_bytes())
    assert main(["slice", str(stl)]) == 0
    gcode = tmp_path / "layer_01.gcode"
    assert gcode.stat().st_size > 10_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layer_01.gcode", "layer_01.stl"]
    assert main(["slice", str(stl)]) == 2  # no silent overwrite


def test_scores_are_against_the_source_image_on_the_simulated_grid(tmp_path):
    from PIL import Image

    from stencil_cad import pipeline
    from stencil_cad.config.io import parse_config
    from stencil_cad.model import Layers, Picture

    # A source with detail finer than the working grid: 1 px stripes at 8 px/mm.
    src = np.zeros((160, 160, 3), np.uint8)
    src[:, ::2] = 255
    path = tmp_path / "stripes.png"
    Image.fromarray(src).save(path)
    cfg = parse_config({"image": str(path), "size": {"width_mm": 20, "px_per_mm": 1}}, "test")
    pic = pipeline.load_picture(cfg)
    layers = Layers(np.ones(3), np.zeros((0, 3)), np.zeros((0, 20, 20)), 1.0)
    ref = pipeline.source_reference(cfg, pic, layers, (160, 160), 0.125)
    assert ref.shape == (160, 160, 3)
    # On the simulated grid the stripes are back; the working picture had averaged them to grey.
    assert np.abs(ref[80, 1:120:2, 0] - ref[80, 0:120:2, 0]).mean() > 0.5
    assert np.ptp(pic.rgb[..., 0]) < 0.2
    # A picture made in code (not the job's file) is its own reference.
    made = Picture(rgb=np.full((20, 20, 3), 0.3), mm_per_px=1.0, source="made in code")
    assert np.allclose(pipeline.source_reference(cfg, made, layers, (40, 40), 0.5), 0.3)
