"""The sheet names the can each layer sprayed with and warns about unmeasured ones."""

from __future__ import annotations

import copy

from stencil_cad import instructions
from stencil_cad.figures import LayerProfile
from stencil_cad.instructions.cans import layer_can, unmeasured_warning, uses_profiles

MEASURED = {
    "layer": 1,
    "hex": "#000000",
    "profile": "black.yaml",
    "key": "1",
    "measured": True,
    "paint": "Ink",
}
GUESSED = {
    "layer": 2,
    "hex": "#ff6900",
    "profile": None,
    "key": None,
    "measured": False,
    "paint": "unmeasured",
}

MANIFEST = {
    "config": {"name": "cans", "mode": "soft", "spray": {"model": "physical"}},
    "picture": {"width_mm": 100, "height_mm": 80},
    "spray_order": {
        "primer": {"hex": "#ffffff", "name": ""},
        "note": "n",
        "unit": "passes",
        "steps": [
            {"step": k, "plate": f"layer_0{k}", "hex": h, "name": "", "spray_time": 2.0}
            for k, h in ((1, "#000000"), (2, "#ff6900"))
        ],
    },
    "spraying": [
        {"layer": 1, "text": "spray layer 1 (#000000): 2 light passes"},
        {"layer": 2, "text": "spray layer 2 (#ff6900): 2 light passes"},
    ],
    "spray_profiles": [MEASURED, GUESSED],
    "files": [],
}


def test_words_for_each_layers_can():
    measured, guessed = LayerProfile.from_json(MEASURED), LayerProfile.from_json(GUESSED)
    assert layer_can(measured) == "profile black.yaml (measured: Ink)"
    assert layer_can(guessed) == "spray.can, not measured"
    assert uses_profiles([measured, guessed]) and not uses_profiles([guessed])
    warning = unmeasured_warning([measured, guessed])
    assert (
        warning is not None
        and warning.startswith("Layer 2 sprays with")
        and "stencil-cad calibrate" in warning
    )
    third = LayerProfile.from_json({**GUESSED, "layer": 3})
    assert (unmeasured_warning([guessed, third]) or "").startswith("Every layer")
    assert unmeasured_warning([measured]) is None


def test_the_sheet_names_each_layers_profile_and_warns():
    sheet = instructions.sheet_from_manifest(copy.deepcopy(MANIFEST))
    assert "can: profile black.yaml (measured: Ink)" in sheet.steps[0].how
    assert "can: spray.can, not measured" in sheet.steps[1].how
    assert any(w.startswith("Layer 2 sprays with can constants nobody measured") for w in sheet.warnings)
    html = instructions.render_html(sheet, {})
    assert "black.yaml" in html and "nobody measured" in html


def test_the_paper_model_has_no_can_to_name():
    manifest = copy.deepcopy(MANIFEST)
    manifest["config"]["spray"]["model"] = "paper"
    sheet = instructions.sheet_from_manifest(manifest)
    assert "black.yaml" not in sheet.steps[0].how
    assert not any("measured" in w for w in sheet.warnings)
