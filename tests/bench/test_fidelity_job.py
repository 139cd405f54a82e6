"""The fidelity benchmark's default rows are what ``stencil-cad run`` makes of the same config and picture."""

from __future__ import annotations

import json

import pytest

from benchmarks import fidelity
from stencil_cad import api
from stencil_cad.pipeline.run import run_command


@pytest.mark.slow
def test_the_benchmarks_default_scores_as_the_job_does(tmp_path):
    # The bundled example job (the config of `stencil-cad run` without one), made small; the CAD
    # files no score reads are left out.
    files = {"step": False, "dxf": False, "svg": False, "instructions": False}
    cfg = api.load_config(None, overrides={"size": {"width_mm": 30.0}, "export": files})
    run_command("run", cfg, tmp_path / "job", quiet=True)
    job = json.loads((tmp_path / "job" / "manifest.json").read_text())

    bench, *_ = fidelity.job_default(cfg)
    seen = bench.figures.simulate

    assert seen.scores["scielab"] == job["simulate"]["scielab"]
    assert seen.scores["scielab_2x"] == job["simulate"]["scielab_2x"]
    assert dict(seen.scielab_by_can or {}) == job["simulate"]["scielab_by_can"]
    design = {k: v for k, v in bench.figures.standoff.to_json().items() if k != "seconds"}
    assert design == {k: v for k, v in job["standoff"].items() if k != "seconds"}
    assert [s.dots for s in bench.figures.stipple] == [s["dots"] for s in job["stipple"]]


def test_the_benchmarks_fdm_config_is_the_one_an_image_job_runs_with(tmp_path):
    # What the job leaves to itself (the wall's stand-off, the plate's thickness) stays left to it.
    cfg = fidelity.job_config("logo", "fdm", tmp_path)
    # `stencil-cad run --image logo.png`: no config file, the defaults.
    job = api.load_config({}, image=tmp_path / "logo.png")

    assert cfg.chooses_standoff and job.chooses_standoff
    assert cfg.plate.thickness_mm is None and job.plate.thickness_mm is None
    assert cfg.model_dump(exclude={"name"}) == job.model_dump(exclude={"name"})
