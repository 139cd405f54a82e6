import json
import os
import stat

import pytest

from stencil_cad.errors import OutputError
from stencil_cad.output import LOCK, STAGING_PREFIX, OutputDir, manifest_header


def _run(path, files, force=False, **kw):
    """One tool run writing ``files`` (name -> text) and a manifest of its own."""
    out = OutputDir(path, force=force, **kw)
    for name, text in files.items():
        out.write_text(name, text)
    out.write_json("manifest.json", {**manifest_header(), "files": out.file_table()})
    out.commit()
    return out


def test_files_appear_only_on_commit(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "hello")
    assert not (tmp_path / "o" / "a.txt").exists()
    out.commit()
    assert (tmp_path / "o" / "a.txt").read_text() == "hello"
    assert [p.name for p in tmp_path.iterdir()] == ["o"]
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["a.txt"]


def test_abort_leaves_nothing(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "hello")
    with pytest.raises(RuntimeError):
        with out.open_path("b.bin") as p:
            p.write_bytes(b"half")
            raise RuntimeError("interrupted")
    out.abort()
    assert list(tmp_path.iterdir()) == []


def test_staging_is_inside_the_output_folder(tmp_path):
    out = OutputDir(tmp_path / "o")
    assert out.stage.parent == tmp_path / "o" and out.stage.name.startswith(STAGING_PREFIX)
    out.abort()


def test_non_empty_folder_needs_force(tmp_path):
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "mine.txt").write_text("user file")
    with pytest.raises(OutputError, match="--force"):
        OutputDir(tmp_path / "o")
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["mine.txt"]


def test_existing_file_is_not_replaced_without_force(tmp_path):
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "a.txt").write_text("user file")
    out = OutputDir(tmp_path / "o", allow_existing=True)
    with pytest.raises(OutputError, match="already exists"):
        out.write_text("a.txt", "new")
    out.abort()


def test_force_replaces_own_files_and_removes_own_stale_ones(tmp_path):
    o = tmp_path / "o"
    _run(o, {"layer_05.stl": "old", "a.txt": "old a"})
    (o / "notes.txt").write_text("user notes")
    second = _run(o, {"a.txt": "new a"}, force=True)
    assert not (o / "layer_05.stl").exists()
    assert (o / "a.txt").read_text() == "new a"
    assert (o / "notes.txt").read_text() == "user notes"
    assert second.kept == ["notes.txt"] and second.removed == ["layer_05.stl"]


def test_force_keeps_a_changed_file_and_refuses_to_replace_it(tmp_path):
    o = tmp_path / "o"
    _run(o, {"a.txt": "old", "b.txt": "old b"})
    (o / "b.txt").write_text("edited by hand")
    out = OutputDir(o, force=True)
    with pytest.raises(OutputError, match="changed since"):
        out.check_free(["b.txt"])
    out.write_text("a.txt", "new")
    out.write_json("manifest.json", {**manifest_header(), "files": out.file_table()})
    out.commit()
    assert (o / "b.txt").read_text() == "edited by hand" and out.kept == ["b.txt"]


def test_force_does_not_trust_a_hand_written_manifest(tmp_path):
    o = tmp_path / "site"
    o.mkdir()
    (o / "index.html").write_text("<html>")
    (o / "style.css").write_text("body{}")
    (o / "manifest.json").write_text(json.dumps({"files": [{"name": "index.html"}, {"name": "style.css"}]}))
    out = OutputDir(o, force=True)
    with pytest.raises(OutputError, match="not written by stencil-cad"):
        out.write_json("manifest.json", {})
    out.write_text("x.txt", "mine")
    out.commit()
    assert sorted(p.name for p in o.iterdir()) == ["index.html", "manifest.json", "style.css", "x.txt"]
    assert out.kept == ["index.html", "manifest.json", "style.css"]


def test_stage_command_replaces_only_its_own_outputs(tmp_path):
    o = tmp_path / "o"
    _run(o, {"layers.npz": "L", "layer_01_dots.csv": "D", "layer_01.stl": "old stl"})
    out = OutputDir(o, force=True, allow_existing=True)
    out.write_text("layer_01.stl", "new stl")
    out.write_json("manifest.json", {**manifest_header(), "files": out.file_table()})
    out.commit()
    assert (o / "layers.npz").read_text() == "L" and (o / "layer_01_dots.csv").read_text() == "D"
    assert (o / "layer_01.stl").read_text() == "new stl"


def test_commit_rolls_back_when_a_move_fails(tmp_path, monkeypatch):
    o = tmp_path / "o"
    _run(o, {f"f{i}.txt": f"old {i}" for i in range(6)})
    before = {p.name: p.read_bytes() for p in o.iterdir()}
    out = OutputDir(o, force=True)
    for i in range(6):
        out.write_text(f"f{i}.txt", f"new {i}")
    out.write_json("manifest.json", {**manifest_header(), "files": out.file_table()})
    real, calls = os.replace, []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 10:  # 7 set aside, then the third new file fails
            raise OSError(28, "No space left on device", str(dst))
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(OutputError, match="disk is full.*left as it was"):
        out.commit()
    monkeypatch.setattr(os, "replace", real)
    out.abort()
    assert {p.name: p.read_bytes() for p in o.iterdir()} == before


def test_lock_refuses_a_second_writer(tmp_path):
    first = OutputDir(tmp_path / "o")
    with pytest.raises(OutputError, match="another stencil-cad run.*is writing"):
        OutputDir(tmp_path / "o", allow_existing=True)
    first.abort()
    OutputDir(tmp_path / "o").abort()


def test_stale_staging_is_swept_with_a_warning(tmp_path, caplog):
    o = tmp_path / "o"
    _run(o, {"a.txt": "old"})
    stale = o / f"{STAGING_PREFIX}dead"
    (stale / "set-aside").mkdir(parents=True)
    (stale / "half.stl").write_text("half")
    os.replace(o / "a.txt", stale / "set-aside" / "a.txt")  # killed mid-commit
    out = OutputDir(o, allow_existing=True)
    assert "interrupted earlier run" in caplog.text and "restored a.txt" in caplog.text
    assert not stale.exists() and (o / "a.txt").read_text() == "old"
    out.abort()
    assert sorted(p.name for p in o.iterdir()) == ["a.txt", "manifest.json"]


def test_files_follow_the_umask(tmp_path):
    old = os.umask(0o027)
    try:
        _run(tmp_path / "o", {"a.txt": "x"})
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "o" / "a.txt").stat().st_mode) == 0o640
    assert not (tmp_path / "o" / LOCK).exists()


def test_file_table_has_size_and_sha(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "abc")
    (row,) = out.file_table()
    assert row["bytes"] == 3
    assert row["sha256"] == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    out.abort()


def test_file_table_hashes_each_file_once(tmp_path, monkeypatch):
    import stencil_cad.output as output

    read = []
    real = output.sha256_file
    monkeypatch.setattr(output, "sha256_file", lambda p: read.append(p.name) or real(p))
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "abc")
    first = out.file_table()
    out.write_text("b.txt", "def")
    assert out.sha256("a.txt") == first[0]["sha256"]
    assert out.file_table()[0] == first[0] and read == ["a.txt", "b.txt"]
    out.abort()
