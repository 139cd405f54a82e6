"""The studio's routes through Starlette's test client: uploads, paths, previews, settings."""

import json

import pytest
from starlette.testclient import TestClient

from stencil_cad import api
from stencil_cad.errors import ImageError
from stencil_cad.imaging import example_image_path
from stencil_cad.studio import Workspace, create_app

#: Small settings: a 40 mm picture in two layers previews in seconds.
SMALL = {"width_mm": 40.0, "layers": 2}


@pytest.fixture
def ws(tmp_path):
    return Workspace(tmp_path / "ws")


@pytest.fixture
def client(ws):
    return TestClient(create_app(ws))


def written(ws):
    """Every file in the workspace (the folders it makes at start aside)."""
    return sorted(p.relative_to(ws.root).as_posix() for p in ws.root.rglob("*") if p.is_file())


def events(client, settings):
    with client.stream("GET", "/api/preview", params={"settings": json.dumps(settings)}) as s:
        assert s.status_code == 200
        return [json.loads(line[6:]) for line in s.iter_lines() if line.startswith("data: ")]


def cli_message(path):
    with pytest.raises(ImageError) as err:
        api.check_image(path)
    return str(err.value)


def test_the_page_and_its_assets_are_served(client):
    page = client.get("/")
    assert page.status_code == 200 and "studio.js" in page.text
    for asset in ("studio.js", "studio.css"):
        assert client.get(f"/static/{asset}").status_code == 200
    opts = client.get("/api/options").json()
    assert opts["processes"] == ["fdm", "sla", "laser"] and opts["cans"][0]["hex"].startswith("#")


@pytest.mark.parametrize(
    "content",
    [b"not an image at all", example_image_path().read_bytes()[:2000], b""],
    ids=["text", "cut", "empty"],
)
def test_a_broken_upload_gets_the_command_lines_message_and_nothing_is_written(client, ws, tmp_path, content):
    same = tmp_path / "holiday.png"
    same.write_bytes(content)
    r = client.post("/api/upload", params={"name": "holiday.png"}, content=content)
    assert r.status_code == 400
    # The command line's words for the same file, with the file's name.
    assert r.json()["error"] == cli_message(same).replace(str(same), "holiday.png")
    assert written(ws) == []


def test_an_upload_is_kept_under_an_identifier_and_its_name_cannot_reach_out(client, ws):
    r = client.post(
        "/api/upload", params={"name": "../../evil.png"}, content=example_image_path().read_bytes()
    )
    assert r.status_code == 200
    j = r.json()
    assert j["name"] == "evil.png" and (j["width_px"], j["height_px"]) == (300, 300)
    assert written(ws) == [f"uploads/{j['id']}.png"]


@pytest.mark.parametrize(
    "url",
    [
        "/api/jobs/{job}/files/../../uploads/{up}.png",
        "/api/jobs/{job}/files/%2e%2e/%2e%2e/uploads/{up}.png",
        "/api/jobs/{job}/files//etc/passwd",
        "/api/jobs/..%2f..%2fuploads/files/{up}.png",
        "/api/jobs/{up}/files/{up}.png",
    ],
)
def test_no_path_from_the_page_reaches_outside_a_job(client, ws, url):
    up = client.post("/api/upload", content=example_image_path().read_bytes()).json()["id"]
    job = "0" * 32
    (ws.jobs / job / "output").mkdir(parents=True)
    (ws.jobs / job / "output" / "a.txt").write_text("inside")
    assert client.get(f"/api/jobs/{job}/files/output/a.txt").text == "inside"
    r = client.get(url.format(job=job, up=up))
    assert r.status_code == 404
    assert "RIFF" not in r.text and "PNG" not in r.text


def test_a_wrong_setting_gets_the_configs_message(client, ws):
    r = client.get("/api/preview", params={"settings": json.dumps({"layers": 0})})
    assert r.status_code == 400 and "decompose.layers" in r.json()["error"]
    r = client.get("/api/preview", params={"settings": json.dumps({"colour": "red"})})
    assert r.status_code == 400 and "unknown setting(s): colour" in r.json()["error"]
    r = client.post("/api/jobs", json={"image": "f" * 32})
    assert r.status_code == 400 and "upload it again" in r.json()["error"]
    assert written(ws) == []


def test_the_preview_improves_level_by_level_and_says_what_making_costs(client, ws):
    up = client.post("/api/upload", content=example_image_path().read_bytes()).json()["id"]
    got = events(client, {**SMALL, "image": up})
    assert [e["level"] for e in got] == ["coarse", "stippled", "refined", "designed"]
    assert [e["final"] for e in got] == [False, False, False, True]
    last = got[-1]
    # Two paints, each through a light and a dark plate: figures per plate, in spray order.
    assert len(set(last["paints"])) == 2 and len(last["passes"]) == len(last["paints"]) == last["plates"]
    assert all(n > 0 for n in last["holes"])
    assert (last["plates"], last["walls"], last["tiles"]) == (4, 1, 1)
    assert last["cost"]["printer_hours"] > 0 and last["cost"]["paint"]
    assert 0 < last["scielab_2x"] < last["scielab"]
    assert last["sprayed"].startswith("data:image/png;base64,")
    assert written(ws) == [f"uploads/{up}.png"]


def test_a_newer_preview_cancels_the_older_ones_work(client):
    studio = client.app.state.studio
    first = studio.previews.start()
    second = studio.previews.start()
    assert first.cancelled and not second.cancelled
    assert list(studio.previews.events(api.load_config(None), first)) == [{"level": "cancelled"}]


def test_a_preview_left_mid_level_does_not_hold_up_the_next(ws):
    """A page that asks for a newer preview while a level is computed leaves the older stream unread.

    Its generator then stays at its next event for good; the next preview must still run (it waited
    for ever when the lock was held across the event).
    """
    import threading

    from stencil_cad.studio.app import Previews
    from stencil_cad.studio.settings import config_data

    previews = Previews()
    cfg = api.load_config(config_data(SMALL, ws)[0])
    older = previews.events(cfg, previews.start())
    assert next(older)["level"] == "coarse"  # left here: the page went on to newer settings
    newer = previews.events(api.load_config(config_data({**SMALL, "layers": 3}, ws)[0]), previews.start())
    got: list = []
    reader = threading.Thread(target=lambda: got.append(next(newer)), daemon=True)
    reader.start()
    reader.join(timeout=120)
    assert got and got[0]["level"] == "coarse"
    # The older preview was cancelled by the newer one: read again, it says so and stops.
    assert next(older)["level"] == "cancelled"
