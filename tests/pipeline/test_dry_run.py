"""``stencil-cad run --dry-run``: the plan and what making it costs, in seconds, and nothing written."""

from __future__ import annotations

import time

from stencil_cad.cli import main


def test_dry_run_prints_the_plan_and_cost_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    assert main(["run", "--dry-run", "--out", str(out)]) == 0
    assert time.perf_counter() - t0 < 30
    text = capsys.readouterr().out
    lines = text.splitlines()
    assert lines[0].startswith("stencil-cad: plan: 1 tile(s)") and "printer-hours" in lines[0]
    assert any(line.startswith("  plate 04: ") for line in lines)
    assert any(line.startswith("  wall: ") for line in lines)
    assert "per m² of picture" in text and "paint, layer 01" in text
    assert not out.exists()


def test_dry_run_of_a_mural_names_every_tile(tmp_path, capsys):
    from stencil_cad.imaging import example_config_path

    image = example_config_path().parent / "example.png"  # 512 x 341 px: 600 x 400 mm at 0.5 px/mm
    cfg = tmp_path / "mural.yaml"
    cfg.write_text(
        f"name: dry mural\nimage: {image}\nsize: {{width_mm: 600, px_per_mm: 0.5}}\n"
        "decompose: {layers: 3}\nstipple: {process: fdm}\n"
    )
    assert main(["run", str(cfg), "--bed", "prusa_mk4", "--dry-run", "--out", str(tmp_path / "o")]) == 0
    text = capsys.readouterr().out
    import re

    tiles, plates, walls = (
        int(v) for v in re.search(r"(\d+) tile\(s\).*?(\d+) plates, (\d+) wall", text).groups()
    )
    # One wall serves every tile of a mural; its thin plates stand on posts printed together.
    assert tiles > 1 and plates == 3 * tiles and walls == 1
    assert re.search(r"^  posts × \d+ \(printed together\): ", text, re.M)
    assert len(re.findall(r"^  [A-Z]\d+ plate 0[123]: ", text, re.M)) == plates
    assert len(re.findall(r"^  [A-Z]\d+ wall: ", text, re.M)) == walls
    assert not (tmp_path / "o").exists()


def test_dry_run_of_a_missing_image_exits_2(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(f"name: gone\nimage: {tmp_path / 'nope.png'}\nsize: {{width_mm: 100}}\n")
    assert main(["run", str(cfg), "--dry-run", "--out", str(tmp_path / "o")]) == 2
    assert "nope.png" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
