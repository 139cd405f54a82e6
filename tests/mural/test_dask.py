"""A small mural on a local Dask cluster of two workers against the same job in this process."""

import json
import sys
from pathlib import Path

import pytest

from stencil_cad import compute
from stencil_cad.cli import main
from stencil_cad.config import io as cfg_io
from stencil_cad.pipeline import run as pipeline_run

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from benchmarks.compare_outputs import manifest_content, manifest_differences  # noqa: E402


@pytest.mark.slow
def test_small_mural_on_two_workers_writes_the_in_process_bytes(tmp_path):
    cfg = tmp_path / "mural.yaml"
    cfg.write_text(
        "name: tiny_mural\n"
        "size: {width_mm: 240, height_mm: 160, px_per_mm: auto}\n"
        "bed: prusa_mk4\n"
        "decompose: {layers: 2}\n"
        "stipple: {process: fdm}\n"
    )
    outs = {}
    for workers in ("0", "2"):
        out = tmp_path / f"w{workers}"
        assert main(["run", str(cfg), "--out", str(out), "-q", "--workers", workers]) == 0
        outs[workers] = out
    man = {w: json.loads((o / "manifest.json").read_text()) for w, o in outs.items()}
    assert man["0"]["compute"]["kind"] == "in_process"
    assert (man["2"]["compute"]["kind"], man["2"]["compute"]["workers"]) == ("local", 2)
    tiles = man["2"]["mural"]["tiles"]
    assert len(tiles) >= 2
    # Every plate of every tile (two layers) and the one wall all tiles share was a task.
    assert man["2"]["compute"]["tasks"] >= len(tiles) * 2 + 1
    names = sorted(p.name for p in outs["0"].iterdir())
    assert names == sorted(p.name for p in outs["2"].iterdir())
    assert any(n.startswith("tile_A2_layer_02") for n in names)
    for name in names:
        if name != "manifest.json":
            assert (outs["0"] / name).read_bytes() == (outs["2"] / name).read_bytes(), name
    rows = {w: [(r["name"], r["sha256"]) for r in m["files"]] for w, m in man.items()}
    assert rows["0"] == rows["2"]
    # Every other figure of the manifest too, only the timings and the placement aside.
    content = {w: manifest_content(o / "manifest.json") for w, o in outs.items()}
    assert manifest_differences(content["0"], content["2"]) == []
    # A stage command runs its tasks where asked too (it ran them in this process before); the
    # plates it builds from the saved dots are the same bytes in this process and on 2 workers.
    rebuilt = {}
    for workers in ("0", "2"):
        rebuilt[workers] = tmp_path / f"build_w{workers}"
        args = ["build", str(cfg), "--from", str(outs["0"]), "--out", str(rebuilt[workers]), "-q"]
        assert main([*args, "--workers", workers]) == 0
    bman = json.loads((rebuilt["2"] / "manifest.json").read_text())
    assert (bman["compute"]["kind"], bman["compute"]["workers"]) == ("local", 2)
    assert bman["compute"]["tasks"] >= len(tiles) * 2 + 1
    plates = sorted(p.name for p in rebuilt["0"].glob("tile_*"))
    assert plates == sorted(p.name for p in rebuilt["2"].glob("tile_*"))
    assert any(n.endswith(".stl") for n in plates)
    for name in plates:
        assert (rebuilt["0"] / name).read_bytes() == (rebuilt["2"] / name).read_bytes(), name


class _Stop(Exception):
    pass


@pytest.mark.parametrize(
    ("size", "tiled"),
    [({"width_mm": 600, "height_mm": 400, "px_per_mm": "auto"}, True), ({"width_mm": 150}, False)],
)
def test_a_run_tells_the_executor_its_murals_planned_work(tmp_path, monkeypatch, size, tiled):
    seen = []

    def executor(cfg, picture_px, quiet=False, mural_seconds=None):
        seen.append(mural_seconds)
        raise _Stop

    monkeypatch.setattr(compute, "executor", executor)
    cfg = cfg_io.parse_config(
        {"size": size, "bed": "prusa_mk4", "stipple": {"process": "fdm"}}, source="test"
    )
    with pytest.raises(_Stop):
        pipeline_run.run_command("run", cfg, tmp_path / "out", quiet=True)
    if tiled:
        assert len(seen) == 1 and seen[0] > compute.MURAL_CLUSTER_SECONDS
    else:
        assert seen == [None]
