"""One spray profile per paint through a whole job: the layer keyed to a profile changes, the others do not."""

from __future__ import annotations

import json

import pytest
import yaml

from stencil_cad.cli import main

JOB = """\
name: profiles
size: {width_mm: 30, px_per_mm: 2}
decompose: {layers: 2}
stipple: {process: sla}
refine: {enabled: false}
export: {instructions: true}
# The wall fixed: a measured can's spread adds a stand-off to the plate-design trials, which may
# then choose another wall for every layer (test_standoff covers that).
wall: {standoff_mm: [10]}
"""


def _profile(path):
    path.write_text(
        yaml.safe_dump(
            {
                "spread_k": 0.05,
                "bleed_sigma_mm": 0.15,
                "deposit_per_pass": 0.5,
                "paint": "thin test",
                "fit": {"r": 1},
            }
        )
    )


def _run(tmp_path, name, extra, capsys, quiet=True):
    cfg = tmp_path / f"{name}.yaml"
    cfg.write_text(JOB + extra)
    code = main(["run", str(cfg), "--out", str(tmp_path / name), *(["-q"] if quiet else [])])
    return code, capsys.readouterr()


def _read(out, name):
    return (out / name).read_text()


@pytest.mark.slow
def test_a_layer_keyed_to_its_profile_sprays_with_it_and_the_others_do_not(tmp_path, capsys):
    _profile(tmp_path / "thin.yaml")
    # Room for more passes than the light paint's prior asks for (8, spray.max_passes' default).
    code, _ = _run(tmp_path, "plain", "spray: {max_passes: 14}\n", capsys)
    assert code == 0
    keyed = "spray: {max_passes: 14, profile: {2: thin.yaml}}\n"
    code, cap = _run(tmp_path, "keyed", keyed, capsys, quiet=False)
    assert code == 0, cap.err
    plain, keyed = tmp_path / "plain", tmp_path / "keyed"
    # Each paint is a light and a dark plate (plates 1-2 paint 1, plates 3-4 paint 2), and both plates
    # of paint 2 spray with its thin can.
    assert json.loads(_read(keyed, "manifest.json"))["decompose"]["plates"] == 4
    # Paint 1 is stippled and sprayed as before; paint 2's thin can asks for more passes and holes.
    for plate in (1, 2):
        assert _read(plain, f"layer_{plate:02d}_dots.csv") == _read(keyed, f"layer_{plate:02d}_dots.csv")
    assert _read(plain, "layer_04_dots.csv") != _read(keyed, "layer_04_dots.csv")
    before, after = (json.loads(_read(o, "spray.json"))["order"] for o in (plain, keyed))
    assert before[0]["passes"] == after[0]["passes"] and after[3]["passes"] > before[3]["passes"]
    m = json.loads(_read(keyed, "manifest.json"))
    rows = m["spray_profiles"]
    assert [r["profile"] for r in rows] == [None, None, "thin.yaml", "thin.yaml"]
    assert [r["measured"] for r in rows] == [False, False, True, True]
    assert rows[2]["key"] == rows[3]["key"] == "2" and rows[3]["deposit_per_pass"] == 0.5
    # Layer 1's can is still unmeasured: it alone gets the prior of cans.
    assert len(m["simulate"]["scielab_by_can"]) > 2
    html = _read(keyed, "instructions.html")
    assert "thin.yaml" in html and "Layers 1, 2 spray with can constants nobody measured" in html
    assert "the passes are a guess for that paint" in html
    assert "layer 3 profile thin.yaml (measured: thin test)" in cap.out


def test_a_key_for_a_layer_the_job_does_not_have_stops_it_with_exit_code_2(tmp_path, capsys):
    _profile(tmp_path / "thin.yaml")
    code, cap = _run(tmp_path, "three", "spray: {profile: {3: thin.yaml}}\n", capsys)
    assert code == 2
    assert "spray.profile: key 3 names layer 3, but the job has decompose.layers 2" in cap.err
    assert not (tmp_path / "three").exists()


@pytest.mark.slow
def test_a_hex_key_naming_no_paint_stops_the_job_with_the_layers(tmp_path, capsys):
    _profile(tmp_path / "thin.yaml")
    code, cap = _run(tmp_path, "hex", "spray: {profile: {'#010203': thin.yaml}}\n", capsys)
    assert code == 2
    assert "spray.profile: key '#010203' names no layer of this job (its layers: 1 #" in cap.err
    assert not (tmp_path / "hex" / "manifest.json").exists()
