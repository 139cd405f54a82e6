"""Crop on the page (a new picture in the workspace, cropped server-side) and a mural's tiles over the picture."""

import json

import pytest
from PIL import Image
from starlette.testclient import TestClient

from stencil_cad import api
from stencil_cad.errors import UserError
from stencil_cad.imaging import example_image_path
from stencil_cad.plan import tiles
from stencil_cad.studio import Workspace, create_app
from stencil_cad.studio.settings import config_data, crop_box


@pytest.fixture
def ws(tmp_path):
    return Workspace(tmp_path / "ws")


def test_a_crop_in_percent_is_a_box_of_pixels_inside_the_picture():
    assert crop_box([10, 20, 50, 50], 200, 100) == (20, 20, 120, 70)
    assert crop_box([0, 0, 100, 100], 200, 100) == (0, 0, 200, 100)
    with pytest.raises(UserError, match="outside the picture"):
        crop_box([60, 0, 50, 100], 200, 100)
    with pytest.raises(UserError, match="at least 8"):
        crop_box([0, 0, 2, 100], 200, 100)
    for bad in ([0, 0, 100], "all", [0, 0, "a", 1], [0, 0, True, 1]):
        with pytest.raises(UserError, match=r"\[x, y, width, height\]"):
            crop_box(bad, 200, 100)


def test_the_cropped_picture_is_a_workspace_file_the_job_reads(ws):
    with Image.open(example_image_path()) as im:
        w, h = im.size
    data, picture = config_data({"crop": [25, 25, 50, 50]}, ws)
    assert picture is not None and picture.parent == ws.uploads and data["image"] == str(picture)
    with Image.open(picture) as im:
        assert im.size == (round(0.75 * w) - round(0.25 * w), round(0.75 * h) - round(0.25 * h))
    # The same crop again is the same file; nothing is left in the making.
    assert config_data({"crop": [25, 25, 50, 50]}, ws)[1] == picture
    assert list(ws.tmp.iterdir()) == [] and len(list(ws.uploads.iterdir())) == 1
    cfg = api.load_config(data)
    assert cfg.image == picture


def test_a_bad_crop_is_refused_on_the_page_and_writes_nothing(ws):
    client = TestClient(create_app(ws))
    r = client.get("/api/preview", params={"settings": json.dumps({"crop": [50, 50, 60, 10]})})
    assert r.status_code == 400 and "outside the picture" in r.json()["error"]
    r = client.post("/api/jobs", json={"crop": [0, 0, 1, 1]})
    assert r.status_code == 400 and "at least 8" in r.json()["error"]
    assert [p for p in ws.root.rglob("*") if p.is_file()] == []
    assert client.get("/api/pictures/example").status_code == 200
    assert client.get("/api/pictures/0123").status_code == 404


def test_a_murals_tiles_come_from_the_jobs_tiling(ws):
    data, _ = config_data({"width_mm": 400.0, "layers": 2, "bed": "prusa_mini", "standoff_mm": 10.0}, ws)
    cfg = api.load_config(data)
    first = next(iter(api.previews(cfg)))
    assert first.tiles > 1 and len(first.tile_cores) == first.tiles
    grid, _ = tiles.plan(cfg, *first.size_mm, first.sprayed.shape[0] * first.sprayed.shape[1])
    assert [t[0] for t in first.tile_cores] == [t.name for t in grid.tiles]
    assert first.tile_cores[0][1:] == pytest.approx(grid.tiles[0].core)
    shown = first.figures()["tiles_mm"]
    assert shown[0]["name"] == "A1" and max(t["x1"] for t in shown) == pytest.approx(
        first.size_mm[0], abs=1e-3
    )
