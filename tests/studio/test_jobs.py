"""Making a job from the studio: the zip reproduces `stencil-cad run`, a cancelled job leaves nothing."""

import io
import json
import sys
import time
import zipfile
from pathlib import Path

import pytest
from starlette.testclient import TestClient

from stencil_cad.cli import main
from stencil_cad.imaging import example_image_path
from stencil_cad.studio import Workspace, create_app

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from benchmarks.compare_outputs import compare  # noqa: E402

pytestmark = pytest.mark.slow

SMALL = {"width_mm": 40.0, "layers": 2}


@pytest.fixture
def ws(tmp_path):
    return Workspace(tmp_path / "ws")


@pytest.fixture
def client(ws):
    return TestClient(create_app(ws))


def follow(client, job_id):
    """The job's events until it ends."""
    with client.stream("GET", f"/api/jobs/{job_id}/events") as s:
        return [json.loads(line[6:]) for line in s.iter_lines() if line.startswith("data: ")]


def test_the_zip_holds_what_stencil_cad_run_makes_from_its_job_yaml(client, ws, tmp_path):
    up = client.post("/api/upload", params={"name": "me.png"}, content=example_image_path().read_bytes())
    r = client.post("/api/jobs", json={**SMALL, "image": up.json()["id"]})
    assert r.status_code == 200
    job = r.json()["id"]
    assert client.post("/api/jobs", json=SMALL).status_code == 409  # one job at a time
    got = follow(client, job)
    assert got[-1]["event"] == "finished", got[-1]
    stages = [e["stage"] for e in got if e["event"] == "done"]
    assert stages[:3] == ["load", "decompose", "standoff"] and "simulate" in stages
    z = client.get(f"/api/jobs/{job}/files/job.zip")
    assert z.status_code == 200
    unzipped = tmp_path / "unzipped"
    zipfile.ZipFile(io.BytesIO(z.content)).extractall(unzipped)
    assert (unzipped / "job.yaml").is_file() and (unzipped / "output" / "instructions.html").is_file()
    sheet = client.get(f"/api/jobs/{job}/files/output/instructions.html")
    assert sheet.status_code == 200 and "<html" in sheet.text.lower()
    again = tmp_path / "again"
    assert main(["run", str(unzipped / "job.yaml"), "--out", str(again), "-q"]) == 0
    rows = compare(unzipped / "output", again)
    assert len(rows) > 20
    assert [r["file"] for r in rows if not r["same"]] == []
    assert [p.name for p in ws.jobs.iterdir()] == [job]


def test_a_cancelled_job_leaves_nothing(client, ws):
    job = client.post("/api/jobs", json=SMALL).json()["id"]
    made = client.app.state.studio.jobs.get(job)
    deadline = time.monotonic() + 120
    while {"event": "start", "stage": "decompose"} not in made.events and time.monotonic() < deadline:
        time.sleep(0.05)
    r = client.post(f"/api/jobs/{job}/cancel")
    assert r.status_code == 200 and r.json() == {"cancelled": True}
    assert follow(client, job)[-1]["event"] == "cancelled"
    assert list(ws.jobs.iterdir()) == []
    # The workspace takes the next job.
    assert client.post("/api/jobs", json=SMALL).status_code == 200
    client.app.state.studio.jobs.cancel(client.app.state.studio.jobs.current.id)


def test_a_killed_servers_half_made_job_is_swept_and_finished_ones_kept(tmp_path):
    ws = Workspace(tmp_path / "ws")
    done = ws.jobs / ("a" * 32)
    (done / "output").mkdir(parents=True)
    half = ws.making_dir("b" * 32)
    (half / "output").mkdir(parents=True)
    (ws.tmp / "c.upload").write_bytes(b"half an upload")
    create_app(Workspace(ws.root))
    assert sorted(p.name for p in ws.jobs.iterdir()) == ["a" * 32]
    assert list(ws.tmp.iterdir()) == []
