"""The studio's workspace: identifiers, never paths; whole jobs only; the size cap."""

import os

from stencil_cad.studio import Workspace
from stencil_cad.studio.server import is_loopback


def test_only_identifiers_the_studio_made_name_files(tmp_path):
    ws = Workspace(tmp_path)
    (ws.uploads / ("a" * 32 + ".png")).write_bytes(b"x")
    assert ws.upload_path("a" * 32) == ws.uploads / ("a" * 32 + ".png")
    for bad in ("../uploads/" + "a" * 32, "a" * 31, "A" * 32, "*", ""):
        assert ws.upload_path(bad) is None
        assert ws.job_dir(bad) is None


def test_a_file_in_a_job_never_leaves_it(tmp_path):
    ws = Workspace(tmp_path)
    job = ws.jobs / ("d" * 32)
    (job / "output").mkdir(parents=True)
    (job / "output" / "a.png").write_bytes(b"x")
    (tmp_path / "secret").write_text("no")
    os.symlink(tmp_path / "secret", job / "output" / "link")
    assert ws.file_in(job, "output/a.png") == job / "output" / "a.png"
    for bad in ("../../secret", "/etc/passwd", "output/../../../secret", "output/link", "output", "a\\b", ""):
        assert ws.file_in(job, bad) is None, bad


def test_the_oldest_jobs_go_first_when_the_workspace_is_over_its_cap(tmp_path):
    ws = Workspace(tmp_path, cap_bytes=2500)
    ids = [c * 32 for c in "abc"]
    for k, ident in enumerate(ids):
        d = ws.jobs / ident
        d.mkdir()
        (d / "f").write_bytes(b"x" * 1000)
        os.utime(d, (1000 + k, 1000 + k))
    assert ws.evict(keep={ids[0]}) == [ids[1]]
    assert sorted(p.name for p in ws.jobs.iterdir()) == [ids[0], ids[2]]


def test_a_job_is_listed_only_once_it_is_whole(tmp_path):
    ws = Workspace(tmp_path)
    making = ws.making_dir("e" * 32)
    making.mkdir()
    assert ws.finished_jobs() == []
    ws.finish("e" * 32)
    assert [p.name for p in ws.finished_jobs()] == ["e" * 32]


def test_loopback_hosts():
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("::1")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.2")


def test_one_job_at_a_time_per_workspace_even_across_studios(tmp_path):
    import pytest

    from stencil_cad.studio.jobs import Busy, Jobs

    held = Jobs(Workspace(tmp_path))._workspace_lock()
    with pytest.raises(Busy, match="another studio"):
        Jobs(Workspace(tmp_path))._workspace_lock()
    held.close()
    Jobs(Workspace(tmp_path))._workspace_lock().close()


def test_the_job_folder_carries_its_picture_and_profile_by_name(tmp_path):
    import zipfile

    import yaml

    from stencil_cad.studio.jobs import write_reproducible

    folder = tmp_path / "job"
    (folder / "output").mkdir(parents=True)
    (folder / "output" / "manifest.json").write_text("{}")
    picture = tmp_path / ("f" * 32 + ".png")
    picture.write_bytes(b"png")
    profile = tmp_path / "measured.yaml"
    profile.write_text("spread_k: 0.1\n")
    cfg = {"image": str(picture), "spray": {"model": "physical", "profile": str(profile)}}
    write_reproducible(folder, cfg, picture, [])
    job = yaml.safe_load((folder / "job.yaml").read_text())
    assert job["image"] == picture.name and job["spray"]["profile"] == "spray_profile.yaml"
    assert (folder / "spray_profile.yaml").read_text() == "spread_k: 0.1\n"
    names = zipfile.ZipFile(folder / "job.zip").namelist()
    assert sorted(names) == sorted(["job.yaml", picture.name, "spray_profile.yaml", "output/manifest.json"])
