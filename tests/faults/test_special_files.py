"""Special files and hostile inputs: FIFOs, devices, folders, alias bombs, edited tool files.

Every input is a regular file under a size limit, checked before it is opened (a FIFO would
block for ever, ``/dev/zero`` read without end); every file written outside the output folder
replaces a regular file or nothing. Each case exits 2 with one line and leaves the path as it was.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import signal
import stat
from pathlib import Path

import numpy as np
import pytest
from cli_checks import SMALL

from stencil_cad import files
from stencil_cad.cli import main
from stencil_cad.errors import UserError


@contextlib.contextmanager
def _deadline(seconds: int = 20):
    """Fail (instead of hanging the test run) when the block blocks on a FIFO."""

    def boom(signum, frame):
        raise TimeoutError(f"blocked for {seconds} s")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _refused(capsys, argv, *needles) -> str:
    with _deadline():
        code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.startswith("stencil-cad: error: ")]
    assert len(lines) == 1 and "internal error" not in err, err
    for n in needles:
        assert n in lines[0], err
    return lines[0]


@pytest.fixture
def fifo(tmp_path) -> Path:
    p = tmp_path / "pipe"
    os.mkfifo(p)
    return p


def _char_device(tmp_path) -> Path:
    """A character device of our own (the null device's numbers), or /dev/null when we may not make one."""
    p = tmp_path / "chardev"
    try:
        os.mknod(p, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, OSError):
        return Path("/dev/null")
    return p


def _is(path: Path, test) -> bool:
    return test(os.stat(path).st_mode)


def test_init_force_refuses_a_fifo_and_a_character_device(tmp_path, fifo, capsys):
    _refused(capsys, ["init", fifo, "--force"], str(fifo), "FIFO")
    assert _is(fifo, stat.S_ISFIFO)
    dev = _char_device(tmp_path)
    _refused(capsys, ["init", dev, "--force"], str(dev), "character device")
    assert _is(dev, stat.S_ISCHR)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a temporary file was left"


def test_init_force_replaces_a_regular_file_and_follows_umask(tmp_path, capsys):
    p = tmp_path / "job.yaml"
    p.write_text("old")
    assert main(["init", str(p), "--force"]) == 0
    assert "stencil_cad job config" in p.read_text()
    assert sorted(x.name for x in tmp_path.iterdir()) == ["job.yaml"]


def test_fifo_or_device_as_config_image_or_profile_is_refused_at_once(tmp_path, fifo, capsys):
    _refused(capsys, ["run", fifo, "--out", tmp_path / "o1"], str(fifo), "FIFO", "regular file")
    _refused(capsys, ["run", "/dev/zero", "--out", tmp_path / "o2"], "/dev/zero", "character device")
    _refused(capsys, ["run", tmp_path, "--out", tmp_path / "o3"], "folder")
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL)
    _refused(capsys, ["run", cfg, "--image", fifo, "--out", tmp_path / "o4"], "image", "FIFO")
    cfg.write_text(SMALL + f"spray: {{model: physical, profile: {fifo}}}\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o5"], "spray profile", "FIFO")
    os.mkfifo(tmp_path / "cans.csv")
    cfg.write_text(SMALL.replace("{layers: 2}", "{layers: 2, palette: cans.csv}"))
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o6"], "can list", "FIFO")
    # Nothing was created: no output folder, no staging, no lock.
    assert not any((tmp_path / f"o{i}").exists() for i in range(1, 7))


def test_an_oversized_config_is_refused_before_it_is_read(tmp_path, capsys):
    big = tmp_path / "big.yaml"
    with open(big, "wb") as f:
        f.truncate(files.TEXT_LIMIT + 1)
    _refused(capsys, ["run", big, "--out", tmp_path / "o"], str(big), "MB")


BOMB = """\
a: &a ["x", "x", "x", "x", "x", "x", "x", "x", "x"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
spread_k: 0.1
fit: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
"""


def test_spray_profile_alias_bomb_duplicates_and_tags_are_refused(tmp_path, capsys):
    prof = tmp_path / "can.yaml"
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL + "spray: {model: physical, profile: can.yaml}\n")
    prof.write_text(BOMB)
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], str(prof), "more than")
    prof.write_text("spread_k: 0.1\nspread_k: 0.2\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], str(prof), "duplicate key")
    prof.write_text("spread_k: !!python/object:os.system 0.1\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], str(prof), "tag")
    prof.write_text("spread_k: 5.0\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], str(prof), "spread_k")


def test_deep_nesting_is_refused(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("name: " + "[" * 200 + "]" * 200 + "\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], "nested")
    cfg.write_text("name: " + "[" * 20000 + "]" * 20000 + "\n")
    _refused(capsys, ["run", cfg, "--out", tmp_path / "o"], "nested")


# ----------------------------------------------------------------------------- calibration


@pytest.fixture(scope="module")
def card_desc():
    from stencil_cad.config import JobConfig
    from stencil_cad.testcard import card_description, card_layout

    return card_description(card_layout(JobConfig(), [3.0, 12.0]))


def _photo(tmp_path) -> Path:
    from PIL import Image

    p = tmp_path / "photo.png"
    Image.fromarray(np.full((900, 1200, 3), 180, np.uint8)).save(p)
    return p


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda d: d.update(picture_mm=[1e6, 100.0]), "picture_mm"),
        (lambda d: d.update(sheet_mm=[float("nan"), 100.0]), "NaN"),
        (lambda d: d["holes"].update(r_mm=[-1.0] * len(d["holes"]["r_mm"])), "holes.r_mm"),
        (lambda d: d["footprints"][0].update(standoff_mm=1e308), "standoff_mm"),
    ],
)
def test_edited_card_description_is_refused(tmp_path, capsys, card_desc, edit, words):
    desc = json.loads(json.dumps(card_desc))
    edit(desc)
    card = tmp_path / "card.json"
    card.write_text(json.dumps(desc))
    out = tmp_path / "p.yaml"
    _refused(capsys, ["calibrate", _photo(tmp_path), "--card", card, "--out", out], str(card), words)
    assert not out.exists()


def test_card_json_duplicate_keys_and_special_files_are_refused(tmp_path, capsys, card_desc, fifo):
    card = tmp_path / "card.json"
    text = json.dumps(card_desc)
    card.write_text('{"kind": "x", ' + text[1:])
    _refused(capsys, ["calibrate", _photo(tmp_path), "--card", card], "duplicate key")
    _refused(capsys, ["calibrate", _photo(tmp_path), "--card", fifo], "FIFO")
    card.write_text(text)
    _refused(capsys, ["calibrate", fifo, "--card", card, "--out", tmp_path / "p.yaml"], "photo", "FIFO")


def test_calibrate_out_force_refuses_a_fifo_and_a_device(tmp_path, capsys, card_desc, fifo):
    card = tmp_path / "card.json"
    card.write_text(json.dumps(card_desc))
    _refused(capsys, ["calibrate", _photo(tmp_path), "--card", card, "--out", fifo, "--force"], "FIFO")
    assert _is(fifo, stat.S_ISFIFO)
    dev = _char_device(tmp_path)
    _refused(capsys, ["calibrate", _photo(tmp_path), "--card", card, "--out", dev, "--force"], "device")
    assert _is(dev, stat.S_ISCHR)


def test_a_failed_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    target = tmp_path / "profile.yaml"
    target.write_text("old\n")

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(UserError, match="disk is full"):
        files.write_text_over(target, "new\n", "spray profile", force=True)
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["profile.yaml"]


def test_big_non_jpeg_photos_are_refused_with_the_numbers(tmp_path, monkeypatch):
    from stencil_cad.testcard import photo

    monkeypatch.setattr(photo, "MAX_PHOTO_PIXELS", 1000 * 800)
    with pytest.raises(photo.PhotoError, match=r"1200 × 900 px"):
        photo.read_photo(_photo(tmp_path))


def test_big_jpeg_photos_are_decoded_at_reduced_size(tmp_path, monkeypatch):
    from PIL import Image

    from stencil_cad.testcard import photo

    p = tmp_path / "photo.jpg"
    Image.fromarray(np.full((1800, 2400, 3), 180, np.uint8)).save(p)
    monkeypatch.setattr(photo, "MAX_PHOTO_PIXELS", 1300 * 1000)
    assert photo.read_photo(p).shape == (900, 1200, 3)


# ----------------------------------------------------------------------------- spray.json


def test_spray_times_must_match_the_layers_and_the_range(tmp_path):
    from stencil_cad.pipeline import read_spray_times

    p = tmp_path / "spray.json"
    p.write_text(json.dumps({"spray_times": [1.0]}))
    with pytest.raises(UserError, match="1 values but there are 2 layers"):
        read_spray_times(p, 2, 800.0)
    p.write_text(json.dumps({"spray_times": [1.0, 1e308]}))
    with pytest.raises(UserError, match=r"spray_times\[1\] must be in \(0, 800\]"):
        read_spray_times(p, 2, 800.0)
    p.write_text('{"spray_times": [1.0, NaN]}')
    with pytest.raises(UserError, match="NaN"):
        read_spray_times(p, 2, 800.0)
    p.write_text('{"spray_times": [1.0, 2.0], "spray_times": [1.0, 2.0]}')
    with pytest.raises(UserError, match="duplicate key"):
        read_spray_times(p, 2, 800.0)
    p.write_text(json.dumps({"spray_times": [1.0, 2.5]}))
    assert read_spray_times(p, 2, 800.0) == [1.0, 2.5]


def test_stage_inputs_that_are_fifos_are_refused(tmp_path, capsys):
    from stencil_cad.pipeline import read_layers

    run = tmp_path / "run"
    run.mkdir()
    os.mkfifo(run / "layers.npz")
    with _deadline(), pytest.raises(UserError, match="FIFO"):
        read_layers(run)


def test_output_folder_entries_that_are_fifos_are_never_replaced(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL)
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "manifest.json")
    os.mkfifo(out / "layer_01.stl")
    _refused(capsys, ["run", cfg, "--out", out, "--force"], "FIFO", "replaces only regular files")
    assert _is(out / "manifest.json", stat.S_ISFIFO) and _is(out / "layer_01.stl", stat.S_ISFIFO)
    assert sorted(p.name for p in out.iterdir()) == ["layer_01.stl", "manifest.json"]
