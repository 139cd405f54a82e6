"""The fault catalogue: each case asserts the exit code, the message and what is left on disk.

Nothing lost (``--force`` and stage commands keep what the tool did not write), nothing
half-written (commits roll back, signals clean up, stale staging is swept), no false alarms
(slicer log lines, template edits), and every problem a user can fix is exit 2 with one line.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import signal
import stat
import struct
import subprocess
import sys
import textwrap
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from cli_checks import SMALL, box_triangles
from cli_checks import no_leftovers as _no_leftovers
from cli_checks import one_line_error as _one_line_error
from cli_checks import run_cli as _run
from cli_checks import snapshot as _snapshot
from PIL import Image

from stencil_cad import output
from stencil_cad.cli import main
from stencil_cad.output import LOCK, STAGING_PREFIX, OutputDir


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    """A finished small run: (config, output folder) to copy from."""
    root = tmp_path_factory.mktemp("faults")
    cfg = root / "small.yaml"
    cfg.write_text(SMALL)
    out = root / "out"
    old = os.umask(0o022)
    try:
        assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    finally:
        os.umask(old)
    return cfg, out


@pytest.fixture
def run_copy(job, tmp_path):
    cfg, out = job
    dst = tmp_path / "out"
    shutil.copytree(out, dst)
    return cfg, dst


# --------------------------------------------------------------------------- data loss


@pytest.mark.slow
@pytest.mark.parametrize("command", ["decompose", "build", "stipple", "simulate"])
def test_stage_command_with_force_keeps_the_other_stages_files(run_copy, capsys, command):
    cfg, out = run_copy
    before = _snapshot(out)
    code, _, err = _run([command, "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    after = _snapshot(out)
    assert set(after) == set(before)
    own = {
        "decompose": (
            "layers.npz",
            "plan.json",
            "_opacity.png",
            "composite.png",
            "energy.csv",
            "config.yaml",
        ),
        "build": (".step", ".stl", ".dxf", ".svg", ".3mf"),
        "stipple": ("_dots.csv", "_dots.png", "spray.json", "plan.json"),
        "simulate": ("simulated.png", "preview.png", "sweep.png", "_after.png"),
    }[command]
    for name, sha in before.items():
        if name == "manifest.json" or name.endswith(own):
            continue
        assert after[name] == sha, f"{command} --force changed {name}"
    _no_leftovers(out)


def test_force_does_not_trust_a_hand_written_manifest(tmp_path, capsys):
    site = tmp_path / "site"
    site.mkdir()
    (site / "index.html").write_text("<html></html>")
    (site / "style.css").write_text("body {}")
    (site / "manifest.json").write_text(
        json.dumps({"files": [{"name": "index.html", "sha256": "0" * 64}, {"name": "style.css"}]})
    )
    before = _snapshot(site)
    code, _, err = _run(["run", "--image", tmp_path / "none.png", "--out", site, "--force"], capsys)
    # The image is checked after the folder: make it exist so the folder check is what fails.
    assert code == 2
    img = tmp_path / "a.png"
    Image.fromarray((np.indices((60, 80)).sum(0) % 255).astype(np.uint8)).convert("RGB").save(img)
    code, _, err = _run(["run", "--image", img, "--out", site, "--force"], capsys)
    _one_line_error(code, err, "manifest.json", "not written by stencil-cad")
    assert _snapshot(site) == before
    _no_leftovers(site)


@pytest.mark.slow
def test_force_keeps_and_names_files_the_tool_did_not_write(run_copy, capsys):
    cfg, out = run_copy
    (out / "notes.txt").write_text("my notes")
    (out / "layer_01_dots.csv").write_text((out / "layer_01_dots.csv").read_text() + "\n")
    code, stdout, err = _run(["build", "--out", out, "--force"], capsys)
    assert code == 0, err
    assert "kept" in stdout and "notes.txt" in stdout and "layer_01_dots.csv" in stdout
    assert (out / "notes.txt").read_text() == "my notes"


@pytest.mark.slow
def test_run_force_refuses_to_replace_a_changed_file(run_copy, capsys):
    cfg, out = run_copy
    (out / "layer_01_dots.csv").write_text((out / "layer_01_dots.csv").read_text() + "# edited\n")
    before = _snapshot(out)
    code, _, err = _run(["run", cfg, "--out", out, "--force"], capsys)
    _one_line_error(code, err, "layer_01_dots.csv", "changed since")
    assert _snapshot(out) == before
    _no_leftovers(out)


@pytest.mark.slow
def test_a_failed_move_rolls_the_commit_back(run_copy, capsys, monkeypatch):
    cfg, out = run_copy
    before = _snapshot(out)
    real, placed = os.replace, []

    def flaky(src, dst):
        if Path(src).parent.name.startswith(STAGING_PREFIX) and Path(dst).parent == out:
            placed.append(dst)
            if len(placed) == 3:  # every old file set aside, two new ones in place
                raise OSError(errno.EISDIR, "Is a directory", str(dst))
        return real(src, dst)

    monkeypatch.setattr(output.os, "replace", flaky)
    code, _, err = _run(["build", "--out", out, "--force"], capsys)
    line = _one_line_error(code, err, "left as it was")
    assert "no partial outputs" not in line
    monkeypatch.setattr(output.os, "replace", real)
    assert _snapshot(out) == before
    _no_leftovers(out)


@pytest.mark.slow
def test_a_folder_where_a_file_goes_is_refused_before_any_work(run_copy, capsys):
    cfg, out = run_copy
    (out / "layer_02.stl").unlink()
    (out / "layer_02.stl").mkdir()
    before = _snapshot(out)
    t0 = time.perf_counter()
    code, _, err = _run(["build", "--out", out, "--force"], capsys)
    _one_line_error(code, err, "layer_02.stl", "is a folder")
    assert time.perf_counter() - t0 < 20
    assert _snapshot(out) == before


# --------------------------------------------------------------------------- leftovers, permissions


def _cli(*args, **kw):
    return subprocess.Popen(
        [sys.executable, "-m", "stencil_cad", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def _wait_for_staging(out: Path, timeout: float = 60.0) -> None:
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        if out.is_dir() and any(p.name.startswith(STAGING_PREFIX) for p in out.iterdir()):
            return
        time.sleep(0.05)
    raise AssertionError("the run never started staging")


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_signals_clean_up_like_ctrl_c(tmp_path, sig):
    cfg = tmp_path / "small.yaml"
    cfg.write_text(SMALL)
    out = tmp_path / "out"
    proc = _cli("run", cfg, "--out", out, "-q")
    _wait_for_staging(out)
    time.sleep(1.0)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err
    assert f"interrupted ({signal.Signals(sig).name}); no partial outputs were kept" in err
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["small.yaml"]


@pytest.mark.slow
def test_a_killed_runs_staging_is_swept_with_a_line(run_copy, capsys, caplog):
    cfg, out = run_copy
    before = _snapshot(out)
    proc = _cli("build", "--out", out, "--force", "-q")
    _wait_for_staging(out)
    proc.kill()
    proc.communicate(timeout=30)
    assert any(p.name.startswith(STAGING_PREFIX) for p in out.iterdir())
    code, _, err = _run(["simulate", "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    assert "staging folder of an interrupted earlier run" in err + caplog.text
    _no_leftovers(out)
    assert set(_snapshot(out)) == set(before)


@pytest.mark.slow
def test_a_second_concurrent_run_fails_at_once(run_copy, capsys):
    cfg, out = run_copy
    holder = OutputDir(out, allow_existing=True)
    try:
        t0 = time.perf_counter()
        code, _, err = _run(["build", "--out", out, "--force"], capsys)
        _one_line_error(code, err, "another stencil-cad run", str(out))
        assert time.perf_counter() - t0 < 5
    finally:
        holder.abort()
    _no_leftovers(out)


@pytest.mark.slow
def test_files_are_written_with_the_umask(job):
    _, out = job
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in out.iterdir()}
    assert set(modes.values()) == {0o644}, modes


# --------------------------------------------------------------------------- bounds


@pytest.mark.slow
@pytest.mark.parametrize("dots", [2_000_000, 20_000])
def test_too_many_dots_are_capped_at_what_fits(run_copy, capsys, caplog, tmp_path, dots):
    cfg, out = run_copy
    text = (out / "config.yaml").read_text().replace("dots: null", f"dots: {dots}")
    assert f"dots: {dots}" in text
    big = tmp_path / "big.yaml"
    big.write_text(text)
    t0 = time.perf_counter()
    code, _, err = _run(["stipple", big, "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    assert time.perf_counter() - t0 < 60
    err += caplog.text
    assert f"stipple.dots {dots} cannot fit: at most" in err
    most = int(err.split("at most ")[1].split()[0])
    assert f"set stipple.dots ≤ {most}" in err
    for csv in sorted(out.glob("layer_*_dots.csv")):
        assert len(csv.read_text().splitlines()) - 1 <= most


def _png_header_only(path: Path, w: int, h: int) -> None:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b""))


def test_a_giant_image_gets_our_own_pixel_limit_message(tmp_path, capsys):
    img = tmp_path / "huge.png"
    _png_header_only(img, 40000, 30000)
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", img, "--out", out], capsys)
    line = _one_line_error(code, err, "image too large", "1200 MP", "downscale it")
    assert "DecompressionBomb" not in err and "Warning" not in err
    assert "about 300 × 225 px" in line  # what the job needs: 150 mm at 2 px/mm
    assert not out.exists()


def test_large_images_are_decoded_at_reduced_size(tmp_path, monkeypatch):
    from stencil_cad import imaging
    from stencil_cad.imaging import read_image

    # The streaming threshold lowered so a 1500 x 1800 picture takes the path a huge one takes.
    monkeypatch.setattr(imaging, "STREAM_BYTES", 1024 * 1024)
    streamed = []
    real = imaging._read_streamed
    monkeypatch.setattr(imaging, "_read_streamed", lambda *a: streamed.append(a[1:]) or real(*a))
    png = tmp_path / "big.png"
    a = (np.indices((1500, 1800)).sum(0) % 256).astype(np.uint8)
    Image.fromarray(np.stack([a, a[::-1], a], -1)).save(png, compress_level=1)
    rgb, _, _ = read_image(png, min_size=(80, 60))
    assert streamed == [((1800, 1500), 9)]  # streamed through libvips, shrunk by 9
    assert rgb.shape[0] < 1500 // 8 and rgb.shape[1] < 1800 // 8
    jpg = tmp_path / "photo.jpg"
    Image.fromarray(np.stack([a, a, a], -1)).save(jpg, quality=90)
    rgb, _, _ = read_image(jpg, min_size=(80, 60))
    assert len(streamed) == 1  # a JPEG is not streamed, but
    assert rgb.shape[0] <= 1500 // 8 + 1  # DCT-scaled (draft) then reduced
    assert rgb.shape[0] >= 120 and rgb.shape[1] >= 160


def _alias_bomb(path: Path, levels: int) -> Path:
    """Each level is a list of nine aliases of the one before: 9 ** levels strings."""
    names = "abcdefghij"[:levels]
    lines = ['    A: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for prev, name in zip(names, names[1:], strict=False):
        lines.append(f"    {name.upper()}: &{name} [" + ",".join([f"*{prev}"] * 9) + "]")
    path.write_text("plate:\n  template_params:\n" + "\n".join(lines) + "\n")
    return path


def test_a_yaml_alias_bomb_fails_fast_with_a_short_message(tmp_path, capsys):
    cfg = _alias_bomb(tmp_path / "bomb.yaml", 9)
    t0 = time.perf_counter()
    code, _, err = _run(["run", cfg, "--out", tmp_path / "out"], capsys)
    line = _one_line_error(code, err, "expands to more than")
    assert time.perf_counter() - t0 < 5 and len(line) < 400
    assert not (tmp_path / "out").exists()


def test_a_bad_value_is_quoted_briefly(tmp_path, capsys):
    cfg = _alias_bomb(tmp_path / "long.yaml", 4)
    code, _, err = _run(["run", cfg, "--out", tmp_path / "out"], capsys)
    line = _one_line_error(code, err, "plate.template_params.A", "(and 3 more")
    assert len(line) < 400 + len(str(cfg)), line


def test_duplicate_yaml_keys_are_refused(tmp_path, capsys):
    cfg = tmp_path / "dup.yaml"
    cfg.write_text("name: a\nsize:\n  width_mm: 40\nname: b\n")
    code, _, err = _run(["run", cfg, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, "duplicate key 'name'", "line 4", "first at line 1")


def test_python_tags_are_named_as_unsupported_tags(tmp_path, capsys):
    cfg = tmp_path / "tag.yaml"
    cfg.write_text('name: !!python/object/apply:os.system ["touch pwned"]\n')
    code, _, err = _run(["run", cfg, "--out", tmp_path / "out"], capsys)
    line = _one_line_error(code, err, "unsupported tag !!python/object/apply:os.system", "line 1")
    assert "indentation" not in line and "syntax" not in line
    assert not (tmp_path / "pwned").exists() and not Path("pwned").exists()


# --------------------------------------------------------------------------- OS conditions


def _mount_tmpfs(path: Path, options: str) -> None:
    path.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)], capture_output=True)
    if r.returncode != 0:
        if os.environ.get("CI"):
            pytest.fail(f"cannot mount a tmpfs for the file-system cases: {r.stderr.decode()}")
        pytest.skip("mounting a tmpfs needs root")


@pytest.fixture
def mounts(tmp_path):
    done: list[Path] = []

    def mount(path: Path, options: str) -> Path:
        _mount_tmpfs(path, options)
        done.append(path)
        return path

    yield mount
    for path in reversed(done):
        subprocess.run(["umount", "-l", str(path)], check=False)


@pytest.fixture
def tiny_image(tmp_path):
    img = tmp_path / "pic.png"
    a = np.zeros((60, 80, 3), np.uint8)
    a[:, :40] = (200, 30, 30)
    a[20:, 40:] = (20, 20, 160)
    Image.fromarray(a).save(img)
    return img


@pytest.mark.slow
def test_out_on_a_mount_point_under_a_read_only_parent(tmp_path, mounts, job, capsys):
    cfg, _ = job
    parent = mounts(tmp_path / "ro", "size=1m")
    (parent / "stick").mkdir()
    subprocess.run(["mount", "-o", "remount,ro", str(parent)], check=True)
    stick = mounts(parent / "stick", "size=64m")
    code, _, err = _run(["run", cfg, "--out", stick, "-q"], capsys)
    assert code == 0, err
    assert (stick / "manifest.json").is_file()
    _no_leftovers(stick)


@pytest.mark.slow
def test_read_only_file_system_fails_before_the_first_stage(tmp_path, mounts, job, capsys):
    cfg, _ = job
    ro = mounts(tmp_path / "ro", "size=1m,ro")
    t0 = time.perf_counter()
    code, _, err = _run(["run", cfg, "--out", ro / "out"], capsys)
    _one_line_error(code, err, str(ro / "out"), "read-only", "choose another --out")
    assert time.perf_counter() - t0 < 15  # before decompose
    assert list(ro.iterdir()) == []


@pytest.mark.slow
def test_disk_full_is_exit_2_and_leaves_nothing(tmp_path, mounts, job, capsys):
    cfg, _ = job
    small = mounts(tmp_path / "full", "size=400k")
    code, _, err = _run(["run", cfg, "--out", small / "out", "-q"], capsys)
    _one_line_error(code, err, "disk is full", "no files were changed")
    assert list(small.iterdir()) == []


def test_out_below_a_file(tmp_path, capsys, tiny_image):
    (tmp_path / "file.txt").write_text("x")
    code, _, err = _run(["run", "--image", tiny_image, "--out", tmp_path / "file.txt" / "out"], capsys)
    _one_line_error(code, err, "file.txt", "is a file")
    assert (tmp_path / "file.txt").read_text() == "x"


def test_output_folder_writability_is_probed_before_the_first_stage(
    tmp_path, capsys, monkeypatch, tiny_image
):
    import stencil_cad.pipeline.run as pipeline

    calls = []
    monkeypatch.setattr(pipeline, "stage_decompose", lambda *a, **k: calls.append(a))
    real_open = os.open

    def deny(path, flags, *a):
        if str(path).endswith(LOCK):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *a)

    monkeypatch.setattr(output.os, "open", deny)
    out = tmp_path / "out"
    code, _, err = _run(["run", "--image", tiny_image, "--out", out], capsys)
    _one_line_error(code, err, "permission denied", str(out))
    assert calls == [] and not out.exists()


def test_unreadable_config(tmp_path, capsys, monkeypatch):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL)
    real = os.open

    def deny(path, *a, **k):
        if Path(path) == cfg:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(path, *a, **k)

    monkeypatch.setattr(os, "open", deny)
    code, _, err = _run(["run", cfg, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, str(cfg), "permission denied")


def test_template_naming_a_png(tmp_path, capsys, tiny_image):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(f"plate:\n  template: {tiny_image.name}\n")
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, "plate.template", "not a Python file")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "content", ["not json at all", '{"spray_times": [NaN, 1.0]}', '{"spray_times": "x"}']
)
@pytest.mark.slow
def test_bad_spray_json(run_copy, capsys, content):
    cfg, out = run_copy
    (out / "spray.json").write_text(content)
    before = _snapshot(out)
    code, _, err = _run(["simulate", "--out", out, "--force"], capsys)
    _one_line_error(code, err, "spray.json", "not a valid spray-time file")
    assert _snapshot(out) == before


def test_slice_refuses_non_stl_and_a_bad_timeout(tmp_path, capsys):
    bad = tmp_path / "layer_01.stl"
    bad.write_text("hello, not a mesh")
    code, _, err = _run(["slice", bad], capsys)
    _one_line_error(code, err, str(bad), "is not an STL file")
    code, _, err = _run(["slice", bad, "--timeout", "nan"], capsys)
    _one_line_error(code, err, "--timeout must be a positive number")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layer_01.stl"]


# --------------------------------------------------------------------------- messages


def test_float_tiff_with_nans(tmp_path, capsys):
    img = tmp_path / "nan.tif"
    a = np.linspace(0, 1, 60 * 80, dtype=np.float32).reshape(60, 80)
    a[10:20, 10:20] = np.nan
    Image.fromarray(a, mode="F").save(img)
    code, _, err = _run(["run", "--image", img, "--out", tmp_path / "out"], capsys)
    line = _one_line_error(code, err, "NaN")
    assert "flat colour" not in line


def test_permission_denied_image(tmp_path, capsys, monkeypatch, tiny_image):
    real = os.open

    def deny(path, *a, **k):
        if Path(path) == tiny_image:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(path, *a, **k)

    monkeypatch.setattr(os, "open", deny)
    code, _, err = _run(["run", "--image", tiny_image, "--out", tmp_path / "out"], capsys)
    line = _one_line_error(code, err, "permission denied", str(tiny_image))
    assert "truncated" not in line


def _template(tmp_path, body: str) -> Path:
    from stencil_cad.cad.template import builtin_template

    text = builtin_template().read_text()
    path = tmp_path / "my_plate.py"
    path.write_text(text.replace("    return plate\n", body))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("where", ["load", "build"])
def test_template_calling_sys_exit(run_copy, capsys, tmp_path, where):
    cfg, out = run_copy
    body = (
        "    import sys\n    sys.exit(3)\n"
        if where == "build"
        else "    return plate\nimport sys\nsys.exit(3)\n"
    )
    tpl = _template(tmp_path, body)
    job = tmp_path / "job.yaml"
    job.write_text((out / "config.yaml").read_text().replace("template: null", f"template: {tpl}"))
    before = _snapshot(out)
    code, _, err = _run(["build", job, "--out", out, "--force"], capsys)
    _one_line_error(code, err, "sys.exit(3)", str(tpl))
    assert _snapshot(out) == before


def test_template_problems_surface_before_the_first_stage(tmp_path, capsys, monkeypatch, tiny_image):
    import stencil_cad.pipeline.run as pipeline

    calls = []
    monkeypatch.setattr(pipeline, "stage_decompose", lambda *a, **k: calls.append(a))
    broken = tmp_path / "broken.py"
    broken.write_text("def build(:\n")
    cfg = tmp_path / "job.yaml"
    cfg.write_text(f"plate:\n  template: {broken}\n")
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, "failed to load")
    cfg.write_text("plate:\n  template_params:\n    NO_SUCH: 1\n")
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, "unknown parameter(s) NO_SUCH")
    assert calls == [] and not (tmp_path / "out").exists()


@pytest.mark.slow
def test_header_only_dots_csv_is_named(run_copy, capsys, caplog):
    cfg, out = run_copy
    csv = out / "layer_02_dots.csv"
    csv.write_text(csv.read_text().splitlines()[0] + "\n")
    code, _, err = _run(["build", "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    assert "layer_02_dots.csv has no holes" in err + caplog.text


@pytest.mark.slow
def test_manifest_names_the_template_and_its_hash(run_copy, capsys, tmp_path):
    cfg, out = run_copy
    tpl = _template(tmp_path, "    return plate\n")
    job = tmp_path / "job.yaml"
    job.write_text((out / "config.yaml").read_text().replace("template: null", f"template: {tpl}"))
    code, _, err = _run(["build", job, "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    man = json.loads((out / "manifest.json").read_text())
    assert man["generator"] == "stencil-cad"
    assert man["template"]["path"] == str(tpl.resolve())
    assert man["template"]["sha256"] == hashlib.sha256(tpl.read_bytes()).hexdigest()


# --------------------------------------------------------------------------- false alarms


def _fake_slicer(tmp_path: Path, body: str) -> Path:
    exe = tmp_path / "prusa-slicer"
    exe.write_text("#!/bin/sh\n" + textwrap.dedent(body))
    exe.chmod(0o755)
    return exe


def _plate_stl(path: Path, w: float, h: float) -> Path:
    from stencil_cad.exchange.mesh import write_triangles_stl

    write_triangles_stl(path, box_triangles(w, h))
    return path


OUTPUT_ARG = 'out=""; while [ $# -gt 0 ]; do if [ "$1" = "--output" ]; then out="$2"; fi; shift; done\n'


def test_slicer_error_log_lines_on_a_good_slice_are_warnings(tmp_path, capsys, monkeypatch):
    exe = _fake_slicer(
        tmp_path,
        OUTPUT_ARG
        + 'printf "G1 X1 Y1 E1\\n; prusaslicer_config = begin\\n; prusaslicer_config = end\\n" > "$out"\n'
        + 'echo "[2026-01-01 00:00:00.000000] [0x1] [error]   wall direction is weird"\nexit 0\n',
    )
    monkeypatch.setenv("STENCIL_CAD_PRUSA_SLICER", str(exe))
    stl = _plate_stl(tmp_path / "layer_01.stl", 173, 173)
    code, stdout, err = _run(["slice", stl], capsys)
    assert code == 0, err
    assert "warning" in stdout and "wall direction is weird" in stdout
    assert (tmp_path / "layer_01.gcode").is_file()


def test_a_cut_short_gcode_is_a_failure_and_is_removed(tmp_path, capsys, monkeypatch):
    exe = _fake_slicer(tmp_path, OUTPUT_ARG + 'printf "G1 X1 Y1 E1\\n" > "$out"\nexit 0\n')
    monkeypatch.setenv("STENCIL_CAD_PRUSA_SLICER", str(exe))
    stl = _plate_stl(tmp_path / "layer_01.stl", 50, 50)
    code, _, err = _run(["slice", stl], capsys)
    assert code == 1 and "cut short" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layer_01.stl", "prusa-slicer"]


def test_a_plate_larger_than_the_bed_is_refused_naming_both_sizes(tmp_path, capsys):
    stl = _plate_stl(tmp_path / "layer_01.stl", 173, 173)
    code, _, err = _run(["slice", "--profile", "prusa_sla", stl], capsys)
    _one_line_error(
        code,
        err,
        "173.0 × 173.0 mm",
        "prusa_sla bed is 127 × 80 mm",
        "smaller picture",
        "--profile prusa_fdm",
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layer_01.stl"]


@pytest.mark.slow
def test_dxf_is_byte_reproducible(run_copy, capsys, tmp_path):
    cfg, out = run_copy
    runs = []
    for seed in ("0", "1"):  # separate processes with different string hashing
        r = subprocess.run(
            [sys.executable, "-m", "stencil_cad", "build", "--out", str(out), "--force", "-q"],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONHASHSEED": seed},
        )
        assert r.returncode == 0, r.stderr
        runs.append({p.name: p.read_bytes() for p in out.glob("*.dxf")})
    assert runs[0] and runs[0] == runs[1]
