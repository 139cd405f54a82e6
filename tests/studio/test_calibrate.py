"""The studio's calibration wizard: the card for the page's plates, a synthetic photo of it fitted, the profile kept."""

import json

import numpy as np
import pytest
from starlette.testclient import TestClient

from stencil_cad import api
from stencil_cad.config.spray import CanConstants, SprayConfig
from stencil_cad.studio import Workspace, create_app
from stencil_cad.studio.settings import config_data
from stencil_cad.testcard import layout_from_description
from stencil_cad.testcard.synthetic import PhotoSettings, synthetic_photo

pytestmark = pytest.mark.slow

TRUTH = CanConstants(spread_k=0.1, bleed_sigma_mm=0.4, deposit_per_pass=0.55)


def test_the_wizard_fits_a_synthetic_photo_of_its_card_and_a_job_uses_the_profile(tmp_path):
    ws = Workspace(tmp_path / "ws")
    client = TestClient(create_app(ws))
    card = client.post("/api/card", json={})
    assert card.status_code == 200, card.text
    c = card.json()
    assert "card_sheet.pdf" in c["files"] and "card.json" in c["files"]
    sheet = client.get(f"/api/cards/{c['id']}/files/card_sheet.pdf")
    assert sheet.status_code == 200 and sheet.content.startswith(b"%PDF")
    layout = layout_from_description(json.loads(client.get(f"/api/cards/{c['id']}/files/card.json").text))
    # A photo that is not of the card: the calibrate command's message, no profile kept.
    bad = client.post("/api/calibrate", params={"card": c["id"], "name": "cat.png"}, content=b"meow")
    assert bad.status_code == 400 and "cat.png" in bad.json()["error"]
    assert list(ws.profiles.iterdir()) == [] and list(ws.tmp.iterdir()) == []
    data, suffix = synthetic_photo(
        layout,
        SprayConfig(model="physical", can=TRUTH),
        c["passes"],
        np.random.default_rng(0),
        PhotoSettings(),
    )
    r = client.post(
        "/api/calibrate", params={"card": c["id"], "paint": "test can", "name": f"card{suffix}"}, content=data
    )
    assert r.status_code == 200, r.text
    fit = r.json()
    for key in ("spread_k", "deposit_per_pass"):
        assert fit[key] == pytest.approx(getattr(TRUTH, key), rel=0.05), key
    assert all(m == 4 for m in fit["markers_found"]) and fit["residual_rms"] < 0.03
    kept = client.get("/api/profiles").json()
    assert [(p["paint"], p["key"]) for p in kept] == [("test can", "test can")]
    # The profile sprays the paint it was measured for: the can named "test can" in the job's can list.
    cfg = api.load_config(config_data({"profile": [fit["id"]]}, ws)[0])
    assert list(cfg.spray.profile) == ["test can"]
    assert cfg.spray.for_profile_key("test can").can.spread_k == pytest.approx(fit["spread_k"], rel=1e-3)
