"""A job's plates and walls are built, checked and written with OCP alone: no build123d import."""

import subprocess
import sys

import pytest

SCRIPT = """
import sys, tempfile
from pathlib import Path
import numpy as np
from stencil_cad import cad
from stencil_cad.cad import wall
from stencil_cad.config import JobConfig
from stencil_cad.model import DotSet

cfg = JobConfig()
xs = np.arange(3.0, 57.0, 4.0)
xy = np.stack(np.meshgrid(xs, xs[:10]), -1).reshape(-1, 2)
dots = DotSet(xy_mm=xy, r_mm=np.full(len(xy), 1.0))
label = cad.LabelInfo(layer=2, layers=3, colour="#1A2B3C", job="kernel")
model = cad.build_plate(dots, 60.0, 44.0, cfg.plate.model_copy(update={"thickness_mm": 1.2}), label)
cad.check_plate(model, dots)
out = Path(tempfile.mkdtemp())
cad.write_step(model, out / "p.step")
cad.write_stl(model, out / "p.stl")
w = wall.build_wall(60.0, 44.0, cfg.plate.outline, cfg.wall, 1.2, 10.0)
wall.check_wall(w)
wall.wall_step(w, out / "w.step")
wall.wall_stl(w, out / "w.stl")
print(sorted(m for m in ("build123d", "sklearn", "IPython") if m in sys.modules))
print(type(model.part).__name__, "build123d" in sys.modules)
"""


def test_a_jobs_plate_and_wall_need_no_build123d():
    # build123d's import (with scikit-learn and IPython under it) cost the example's job about a
    # second of CPU; a template that asks for plate.part still gets a build123d Part.
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[:2] == ["[]", "Part True"]


CADQUERY = """
import sys

import pytest
import numpy as np
from stencil_cad import cad
from stencil_cad.cad.template import builtin_template
from stencil_cad.config import JobConfig
from stencil_cad.model import DotSet

xy = np.stack(np.meshgrid(np.arange(3.0, 40.0, 4.0), np.arange(3.0, 30.0, 4.0)), -1).reshape(-1, 2)
dots = DotSet(xy_mm=xy, r_mm=np.full(len(xy), 1.0))
plate = JobConfig().plate.model_copy(update={"thickness_mm": 1.2, "template": builtin_template("plate_cadquery.py")})
model = cad.build_plate(dots, 44.0, 34.0, plate, cad.LabelInfo(layer=1, layers=2, colour="#102030", job="cq"))
print(model.geometry is not None, "build123d" in sys.modules)
"""


@pytest.mark.slow
def test_the_cadquery_template_needs_no_build123d():
    # It hands CadQuery the plate's OCCT shape (plate.shape), not a build123d Part's.
    pytest.importorskip("cadquery")
    out = subprocess.run([sys.executable, "-c", CADQUERY], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[0] == "True False"


JOB = """
import sys
from stencil_cad.cli import main

code = main(["run", sys.argv[1], "--out", sys.argv[2], "-q", "--force"])
print(code, sorted(m for m in ("OCP", "build123d") if m in sys.modules))
"""


@pytest.mark.slow
def test_a_job_imports_no_ocp(tmp_path):
    # Its plates' letters come from fontTools, its plates' and walls' files from our writers and
    # mesher, each checked from its written STEP text: OCP's import (0.6-1.0 CPU-s) is not made.
    from jobs import small_soft

    cfg = tmp_path / "job.yaml"
    cfg.write_text(small_soft("no kernel"), encoding="utf-8")
    out = subprocess.run(
        [sys.executable, "-c", JOB, str(cfg), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip().splitlines()[-1] == "0 []"
    assert (tmp_path / "out" / "wall.step").read_text(encoding="ascii").startswith("ISO-10303-21;")
