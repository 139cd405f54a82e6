import json

import pytest

from stencil_cad.errors import OutputError
from stencil_cad.output import OutputDir


def test_files_appear_only_on_commit(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "hello")
    assert not (tmp_path / "o" / "a.txt").exists()
    out.commit()
    assert (tmp_path / "o" / "a.txt").read_text() == "hello"
    assert [p.name for p in tmp_path.iterdir()] == ["o"]


def test_abort_leaves_nothing(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "hello")
    with pytest.raises(RuntimeError):
        with out.open_path("b.bin") as p:
            p.write_bytes(b"half")
            raise RuntimeError("interrupted")
    out.abort()
    assert list(tmp_path.iterdir()) == []


def test_non_empty_folder_needs_force(tmp_path):
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "mine.txt").write_text("user file")
    with pytest.raises(OutputError, match="--force"):
        OutputDir(tmp_path / "o")


def test_existing_file_is_not_replaced_without_force(tmp_path):
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / "a.txt").write_text("user file")
    out = OutputDir(tmp_path / "o", allow_existing=True)
    with pytest.raises(OutputError, match="already exists"):
        out.write_text("a.txt", "new")


def test_force_replaces_and_removes_stale_listed_files(tmp_path):
    o = tmp_path / "o"
    first = OutputDir(o)
    first.write_text("layer_05.stl", "old")
    first.write_json("manifest.json", {"files": [{"name": "layer_05.stl"}]})
    first.commit()
    (o / "notes.txt").write_text("user notes")
    second = OutputDir(o, force=True)
    second.write_json("manifest.json", {"files": []})
    second.commit()
    assert not (o / "layer_05.stl").exists()
    assert (o / "notes.txt").read_text() == "user notes"
    assert json.loads((o / "manifest.json").read_text()) == {"files": []}


def test_file_table_has_size_and_sha(tmp_path):
    out = OutputDir(tmp_path / "o")
    out.write_text("a.txt", "abc")
    (row,) = out.file_table()
    assert row["bytes"] == 3
    assert row["sha256"] == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
