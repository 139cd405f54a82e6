"""Config friction read as the user meant, and broken meshes named by `slice`.

YAML reads an unquoted ``#e64110:`` key as a comment and ``off`` as false; a single number
where a list is asked was refused; an STL with NaN corners was "nan × 53.0 mm" too large for
the bed, and one with open edges sliced without a word.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
from cli_checks import box_triangles
from cli_checks import one_line_error as _one_line_error
from cli_checks import run_cli as _run

from stencil_cad.config import io as cfg_io
from stencil_cad.errors import ConfigError

# --------------------------------------------------------------------------- config


def test_an_unquoted_hex_key_that_empties_the_profile_is_named(tmp_path):
    (tmp_path / "orange.yaml").write_text("x: 1\n")
    cfg = tmp_path / "job.yaml"
    cfg.write_text("spray:\n  profile:\n    #e64110: orange.yaml\n")
    with pytest.raises(ConfigError) as info:
        cfg_io.load_config(cfg)
    msg = str(info.value)
    assert "spray.profile" in msg and "line 3" in msg and "YAML comment" in msg, msg
    assert '"#e64110": orange.yaml' in msg, msg


def test_an_unquoted_hex_key_beside_others_is_warned_about(tmp_path, caplog):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("name: x\n#ff6900: orange.yaml\n")
    cfg_io.load_config(cfg)
    assert "line 2" in caplog.text and '"#ff6900"' in caplog.text, caplog.text


def test_a_quoted_hex_key_and_a_plain_comment_say_nothing(tmp_path, caplog):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("# my job\nname: x\n# e64110 is the orange\n")
    cfg_io.load_config(cfg)
    assert "YAML comment" not in caplog.text


@pytest.mark.parametrize("word", ["off", "false", "no", "Off"])
def test_yaml_off_for_windows_is_off(tmp_path, word):
    from stencil_cad.config.stipple import Windows

    cfg = tmp_path / "job.yaml"
    cfg.write_text(f"stipple: {{windows: {word}}}\n")
    assert cfg_io.load_config(cfg).stipple.windows is Windows.off


def test_windows_true_is_still_refused(tmp_path):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("stipple: {windows: yes}\n")
    with pytest.raises(ConfigError, match="stipple.windows"):
        cfg_io.load_config(cfg)


@pytest.mark.parametrize("value", ["15.0", "15"])
def test_one_standoff_number_is_a_list_of_one(tmp_path, value):
    cfg = tmp_path / "job.yaml"
    cfg.write_text(f"wall: {{standoff_mm: {value}}}\n")
    assert cfg_io.load_config(cfg).wall.standoff_mm == [15.0]


def test_a_standoff_out_of_range_still_names_the_range(tmp_path):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("wall: {standoff_mm: 0.1}\n")
    with pytest.raises(ConfigError, match="wall.standoff_mm"):
        cfg_io.load_config(cfg)


# --------------------------------------------------------------------------- slice


def _write(path: Path, tri: np.ndarray) -> Path:
    """A binary STL of the triangles as given (no merging, NaN kept)."""
    out = bytearray(b"\0" * 80)
    out += np.uint32(len(tri)).tobytes()
    for t in tri:
        out += np.zeros(3, "<f4").tobytes() + t.astype("<f4").tobytes() + b"\0\0"
    path.write_bytes(bytes(out))
    return path


def _fake_slicer(tmp_path: Path) -> Path:
    exe = tmp_path / "prusa-slicer"
    exe.write_text(
        "#!/bin/sh\n"
        + textwrap.dedent(
            """\
            out=""; while [ $# -gt 0 ]; do if [ "$1" = "--output" ]; then out="$2"; fi; shift; done
            printf "G1 X1 Y1 E1\\n; prusaslicer_config = begin\\n; prusaslicer_config = end\\n" > "$out"
            exit 0
            """
        )
    )
    exe.chmod(0o755)
    return exe


def test_slice_refuses_an_stl_with_nan_corners(tmp_path, capsys):
    tri = box_triangles(53, 53)
    tri[3, 1, 0] = np.nan
    stl = _write(tmp_path / "layer_01.stl", tri)
    code, _, err = _run(["slice", stl], capsys)
    line = _one_line_error(code, err, str(stl), "NaN or infinite", "export it again")
    assert "nan ×" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["layer_01.stl"]


def test_slice_warns_of_open_edges(tmp_path, capsys, caplog, monkeypatch):
    monkeypatch.setenv("STENCIL_CAD_PRUSA_SLICER", str(_fake_slicer(tmp_path)))
    stl = _write(tmp_path / "layer_01.stl", box_triangles(50, 50)[2:])  # the top is missing
    code, _, err = _run(["slice", stl], capsys)
    assert code == 0, err
    said = err + caplog.text
    assert f"{stl} has 4 open edge(s)" in said and "not closed" in said, said


def test_a_closed_stl_slices_without_a_mesh_warning(tmp_path, capsys, caplog, monkeypatch):
    monkeypatch.setenv("STENCIL_CAD_PRUSA_SLICER", str(_fake_slicer(tmp_path)))
    stl = _write(tmp_path / "layer_01.stl", box_triangles(50, 50))
    code, _, err = _run(["slice", stl], capsys)
    assert code == 0, err
    assert "open edge" not in err + caplog.text
