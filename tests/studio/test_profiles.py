"""Spray profiles keyed per paint: the wizard records the paint, the page's choice becomes ``spray.profile``'s mapping."""

import json

import pytest
import yaml
from starlette.testclient import TestClient

from stencil_cad import api
from stencil_cad.errors import UserError
from stencil_cad.studio import Workspace, create_app
from stencil_cad.studio.jobs import write_reproducible
from stencil_cad.studio.settings import config_data
from stencil_cad.studio.workspace import new_id


def _kept(ws, key, spread_k):
    """A profile as the wizard keeps it: the constants' file and what the fit found, with its paint key."""
    ident = new_id()
    (ws.profiles / f"{ident}.yaml").write_text(
        f"spread_k: {spread_k}\nbleed_sigma_mm: 0.3\ndeposit_per_pass: 0.5\n", encoding="utf-8"
    )
    (ws.profiles / f"{ident}.json").write_text(json.dumps({"key": key, "paint": key}), encoding="utf-8")
    return ident


def test_chosen_profiles_become_a_mapping_per_paint(tmp_path):
    ws = Workspace(tmp_path / "ws")
    orange, second, every = _kept(ws, "#ff6900", 0.1), _kept(ws, "2", 0.15), _kept(ws, "default", 0.2)
    data, _ = config_data({"profile": [orange, second, every]}, ws)
    cfg = api.load_config(data)
    assert set(cfg.spray.profile) == {"#ff6900", "2", "default"}
    assert cfg.spray.for_profile_key("#ff6900").can.spread_k == pytest.approx(0.1)
    assert cfg.spray.for_profile_key("2").can.spread_k == pytest.approx(0.15)
    # The default key sprays every layer no other key names; a layer 1 of another paint takes it.
    assert cfg.layer_profile_key(1, "#000000") == "default"
    assert cfg.layer_profile_key(2, "#000000") == "2"
    # One id alone (as older pages sent it) is a mapping of one key.
    one, _ = config_data({"profile": orange}, ws)
    assert list(one["spray"]["profile"]) == ["#ff6900"]


def test_two_profiles_for_one_paint_or_a_gone_profile_are_refused(tmp_path):
    ws = Workspace(tmp_path / "ws")
    a, b = _kept(ws, "#ff6900", 0.1), _kept(ws, "#ff6900", 0.12)
    with pytest.raises(UserError, match="same paint"):
        config_data({"profile": [a, b]}, ws)
    with pytest.raises(UserError, match="calibrate again"):
        config_data({"profile": [new_id()]}, ws)
    with pytest.raises(UserError, match="list of ids"):
        config_data({"profile": [3]}, ws)


def test_a_key_naming_no_layer_stops_the_preview_with_the_configs_message(tmp_path):
    ws = Workspace(tmp_path / "ws")
    data, _ = config_data({"width_mm": 30.0, "layers": 2, "profile": [_kept(ws, "#123456", 0.1)]}, ws)
    with pytest.raises(UserError, match="names no layer"):
        list(api.previews(api.load_config(data)))


def test_the_wizard_refuses_a_paint_that_is_no_key_and_writes_nothing(tmp_path):
    ws = Workspace(tmp_path / "ws")
    card = new_id()
    (ws.cards / card).mkdir()
    client = TestClient(create_app(ws))
    r = client.post("/api/calibrate", params={"card": card, "paint": "#12", "name": "p.png"}, content=b"x")
    assert r.status_code == 400 and "#rrggbb" in r.json()["error"]
    assert list(ws.profiles.iterdir()) == [] and list(ws.tmp.iterdir()) == []


def test_the_job_folder_carries_each_paints_profile(tmp_path):
    ws = Workspace(tmp_path / "ws")
    data, _ = config_data({"profile": [_kept(ws, "#ff6900", 0.1), _kept(ws, "2", 0.15)]}, ws)
    folder = tmp_path / "job"
    (folder / "output").mkdir(parents=True)
    write_reproducible(folder, data, None, [])
    job = yaml.safe_load((folder / "job.yaml").read_text(encoding="utf-8"))
    assert job["spray"]["profile"] == {"#ff6900": "spray_profile_1.yaml", "2": "spray_profile_2.yaml"}
    assert "spread_k: 0.15" in (folder / "spray_profile_2.yaml").read_text(encoding="utf-8")
    # The unzipped folder runs anywhere: job.yaml's keys name the copies beside it.
    again = api.load_config(folder / "job.yaml")
    assert again.spray.for_profile_key("2").can.spread_k == pytest.approx(0.15)
