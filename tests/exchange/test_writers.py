"""The registry of a part's writers by extension: every format the export config turns on has one."""

from __future__ import annotations

import numpy as np

from stencil_cad.config import ExportConfig
from stencil_cad.exchange.dxf import DxfStencil
from stencil_cad.exchange.writers import (
    ONE_PLATE_ORDER,
    TILE_ORDER,
    WRITERS,
    PartFiles,
    part_figures,
    wanted,
    write_part,
)


class _Folder:
    def __init__(self, root):
        self.root = root
        self.names = []

    def open_path(self, name):
        import contextlib

        @contextlib.contextmanager
        def cm():
            self.names.append(name)
            yield self.root / name

        return cm()


def _square() -> DxfStencil:
    ring = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 30.0], [0.0, 30.0]])
    circles = np.array([[10.0, 10.0, 2.0], [25.0, 15.0, 3.0]])
    return DxfStencil(outline_ring=ring, circles_xy_r=circles, layer_name="L1", label="L1")


def test_every_format_the_config_turns_on_has_a_writer():
    every = ExportConfig(step=True, stl=True, dxf=True, svg=True, three_mf=True)
    assert wanted(every) == list(WRITERS) and set(WRITERS) == set(ONE_PLATE_ORDER) == set(TILE_ORDER)
    # Each writer's flag is a yes/no setting of the export config: the maker's key for the format.
    for ext, writer in WRITERS.items():
        assert ExportConfig.model_fields[writer.flag].annotation is bool, ext
    assert wanted(ExportConfig(step=False, stl=False, dxf=False, svg=False, three_mf=False)) == []


def test_a_new_format_is_one_entry_of_the_registry(monkeypatch):
    from stencil_cad.exchange import writers

    # A toy format turned on by an existing setting: one entry, and every order and choice has it.
    toy = writers.Writer(lambda part, path, export: path.write_text(part.name), writers._none, "stl")
    monkeypatch.setitem(writers.WRITERS, ".toy", toy)
    exp = ExportConfig(step=False, stl=True, dxf=False, svg=False, three_mf=False)
    assert writers.wanted(exp, tuple(writers.WRITERS)) == [".stl", ".toy"]
    assert writers._tile_order(tuple(writers.WRITERS))[-3:] == (".svg", ".dxf", ".toy")


def test_wanted_keeps_the_callers_order():
    exp = ExportConfig(step=True, stl=False, dxf=True, svg=True, three_mf=False)
    assert wanted(exp, ONE_PLATE_ORDER) == [".step", ".dxf", ".svg"]
    assert wanted(exp, TILE_ORDER) == [".step", ".svg", ".dxf"]


def test_write_part_names_files_and_gives_their_figures(tmp_path):
    folder = _Folder(tmp_path)
    part = PartFiles(name="p", drawing=_square(), title="job p")
    written = write_part(folder, "layer_01", part, (".svg", ".dxf"), ExportConfig())
    assert folder.names == ["layer_01.svg", "layer_01.dxf"]
    assert (tmp_path / "layer_01.dxf").stat().st_size > 0
    assert "<title>job p</title>" in (tmp_path / "layer_01.svg").read_text(encoding="utf-8")
    assert list(part_figures(written)) == ["svg_offset_mm", "svg_circles", "dxf_offset_mm"]
    assert part_figures(written)["svg_circles"] == 2


def test_a_part_without_a_mesh_is_not_meshed(tmp_path):
    import pytest

    with pytest.raises(ValueError, match="no mesh"):
        write_part(_Folder(tmp_path), "x", PartFiles(name="x"), (".stl",), ExportConfig())
