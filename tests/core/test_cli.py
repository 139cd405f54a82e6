"""Command-line behaviour on bad input: one line, exit code 2, no output files."""

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from stencil_cad.cli import main


def _run(argv, capsys):
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _assert_clean_failure(code, err, tmp_path, out_dir, *needles):
    assert code == 2, err
    assert err.startswith("stencil-cad: error: "), err
    assert "Traceback" not in err
    for n in needles:
        assert n in err, err
    assert not out_dir.exists()
    assert not any(p.name.startswith(".") and "partial" in p.name for p in tmp_path.iterdir())


@pytest.fixture
def cfg_file(tmp_path):
    def make(text):
        p = tmp_path / "job.yaml"
        p.write_text(text)
        return p

    return make


def test_missing_image(tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", str(tmp_path / "nope.png"), "--out", str(out), "-q"], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "not found")


def test_not_an_image(tmp_path, capsys):
    bad = tmp_path / "notes.png"
    bad.write_text("not a picture")
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", str(bad), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "not an image")


def test_truncated_image(tmp_path, capsys):
    a = (np.random.default_rng(0).random((300, 300, 3)) * 255).astype(np.uint8)
    p = tmp_path / "t.png"
    Image.fromarray(a).save(p)
    p.write_bytes(p.read_bytes()[:5000])
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", str(p), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "truncated")


def test_image_too_small(tmp_path, capsys):
    p = tmp_path / "small.png"
    Image.fromarray(np.zeros((20, 20, 3), np.uint8)).save(p)
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", str(p), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "too small")


def test_empty_config(tmp_path, capsys, cfg_file):
    out = tmp_path / "out"
    code, _, err = _run(["run", str(cfg_file("")), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "empty", "stencil-cad init")


def test_yaml_syntax_error(tmp_path, capsys, cfg_file):
    out = tmp_path / "out"
    code, _, err = _run(["run", str(cfg_file("size: {width_mm: 100\n")), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "YAML syntax error", "line")


def test_unknown_key(tmp_path, capsys, cfg_file):
    out = tmp_path / "out"
    code, _, err = _run(["run", str(cfg_file("colour_count: 4\n")), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "colour_count", "unknown key")


def test_bad_range(tmp_path, capsys, cfg_file):
    out = tmp_path / "out"
    code, _, err = _run(["run", str(cfg_file("size:\n  width_mm: 0\n")), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "size.width_mm", "got 0")


def test_missing_config(tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = _run(["run", str(tmp_path / "none.yaml"), "--out", str(out)], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "not found")


def test_non_empty_output_needs_force(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    code, _, err = _run(["run", "--out", str(out), "-q"], capsys)
    assert code == 2 and "--force" in err
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_init_writes_and_refuses_to_overwrite(tmp_path, capsys):
    p = tmp_path / "c.yaml"
    assert main(["init", str(p)]) == 0
    text = p.read_text()
    assert text.startswith("# stencil_cad job config")
    code, _, err = _run(["init", str(p)], capsys)
    assert code == 2 and "already exists" in err
    assert p.read_text() == text


def test_schema_is_json(capsys):
    import json

    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["title"] == "stencil_cad job config"


def test_no_traceback_without_verbose(tmp_path, capsys):
    bad = tmp_path / "b.yaml"
    bad.write_text("seed: -1\n")
    code, _, err = _run(["run", str(bad), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "Traceback" not in err and "seed" in err


@pytest.mark.slow
def test_verbose_prints_the_traceback(tmp_path):
    # A fresh process: -v sends the traceback to stderr through logging, which pytest captures in-process.
    bad = tmp_path / "b.yaml"
    bad.write_text("seed: -1\n")
    r = subprocess.run(
        [sys.executable, "-m", "stencil_cad", "run", str(bad), "--out", str(tmp_path / "o"), "-v"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "Traceback" in r.stderr


def test_init_into_a_folder_is_refused_cleanly(tmp_path, capsys):
    d = tmp_path / "folder"
    d.mkdir()
    code, _, err = _run(["init", str(d), "--force"], capsys)
    assert code == 2 and "is a folder" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]


def test_hard_mode_on_a_flat_image_is_a_clear_error(tmp_path, capsys):
    p = tmp_path / "flat.png"
    Image.fromarray(np.full((320, 320, 3), (30, 120, 200), np.uint8)).save(p)
    out = tmp_path / "out"
    code, _, err = _run(["hard", "--image", str(p), "--out", str(out), "-q"], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "single flat colour")


def test_alpha_source_on_rgb_image_is_a_user_error(tmp_path, capsys, cfg_file):
    p = tmp_path / "rgb.png"
    Image.fromarray(np.full((120, 120, 3), 100, np.uint8)).save(p)
    cfg = cfg_file(f"image: {p}\nsize: {{width_mm: 60}}\ndecompose: {{opacity_source: alpha}}\n")
    out = tmp_path / "out"
    code, _, err = _run(["decompose", str(cfg), "--out", str(out), "-q"], capsys)
    _assert_clean_failure(code, err, tmp_path, out, "alpha")


def test_alpha_source_keeps_the_image_colour(tmp_path, capsys, cfg_file):
    from stencil_cad.config.io import load_config
    from stencil_cad.pipeline import load_picture

    a = np.zeros((120, 120, 4), np.uint8)
    a[..., 0] = 200
    a[..., 3] = np.linspace(0, 255, 120).astype(np.uint8)[None, :]
    p = tmp_path / "rgba.png"
    Image.fromarray(a, "RGBA").save(p)
    pic = load_picture(
        load_config(cfg_file(f"image: {p}\nsize: {{width_mm: 60}}\ndecompose: {{opacity_source: alpha}}\n"))
    )
    assert np.allclose(pic.rgb[..., 0], 200 / 255, atol=1e-6) and np.allclose(pic.rgb[..., 1], 0, atol=1e-6)
    flat = load_picture(load_config(cfg_file(f"image: {p}\nsize: {{width_mm: 60}}\n")))
    assert flat.rgb[60, 0, 1] > 0.95  # transparent → white surface
