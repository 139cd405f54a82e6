"""The kernel-free check of the written STEP agrees with OCCT's, and a job builds no OCCT solid for its plates."""

import json

import numpy as np
import pytest
from jobs import HARD_CANS, small_hard

from stencil_cad import cad
from stencil_cad.cad.validate import PlateCheckError, brep_valid, topology_checks
from stencil_cad.cli import main
from stencil_cad.config import PlateConfig
from stencil_cad.config.cad import LabelMode
from stencil_cad.exchange.step import step_text
from stencil_cad.exchange.step_check import check_step_text
from stencil_cad.model import CutLayer, DotSet, PlateGeometry
from stencil_cad.mural import PLATE_NOTCH_MM, notched_ring
from stencil_cad.outline import plate_outline

W, H = 40.0, 30.0
LABEL = cad.LabelInfo(layer=1, layers=2, colour="#224466", job="check")


def read_step(path):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    return reader.OneShape()


def _faulty(xy, r, polygons=()):
    """A 20 mm plate description as given, checked by no rule (the checks must catch what is wrong)."""
    return PlateGeometry(
        width_mm=20.0,
        height_mm=20.0,
        thickness_mm=1.2,
        outline=np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 20.0], [0.0, 20.0]]),
        circles_xy=np.array(xy, dtype=np.float64).reshape(-1, 2),
        circles_r=np.array(r, dtype=np.float64),
        polygons=tuple(np.array(p, dtype=np.float64) for p in polygons),
    )


def grid(pitch=3.0, w=W, h=H, seed=5, keep=lambda xy: np.ones(len(xy), bool)):
    rng = np.random.default_rng(seed)
    xs = np.arange(pitch / 2 + 0.5, w - pitch / 2, pitch)
    ys = np.arange(pitch / 2 + 0.5, h - pitch / 2, pitch)
    xy = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2) + rng.uniform(-0.2, 0.2, (len(xs) * len(ys), 2))
    xy = xy[keep(xy)]
    return DotSet(xy, rng.uniform(0.5, 0.9, len(xy)))


def _window_free(xy):
    return ~((xy[:, 0] > 8) & (xy[:, 0] < 22) & (xy[:, 1] > 8) & (xy[:, 1] < 20))


WINDOW = np.array([[11.0, 11.0], [19.0, 11.0], [19.0, 17.0], [11.0, 17.0]])


def _plates():
    """(name, holes, config, outline ring or None): the kinds of plate a job builds."""
    hybrid = grid(keep=_window_free)
    hybrid = DotSet(hybrid.xy_mm, hybrid.r_mm, windows=((WINDOW, ()),))
    square = np.array([[5.0, 5.0], [12.0, 5.0], [12.0, 12.0], [5.0, 12.0]])
    tri = np.array([[20.0, 5.0], [30.0, 8.0], [22.0, 15.0]])
    cut = CutLayer([(square, []), (tri, [])], np.array([0.2, 0.3, 0.4]))
    ring = plate_outline(W, H, PlateConfig().outline)
    notched, n = notched_ring(ring, ([W / 2], [H / 2]), PLATE_NOTCH_MM)
    assert n > 0
    return [
        ("round, no label", grid(), PlateConfig(label=LabelMode.none), None),
        ("round, engraved", grid(), PlateConfig(label=LabelMode.engrave, thickness_mm=1.2), None),
        ("round, embossed", grid(), PlateConfig(label=LabelMode.emboss), None),
        ("hybrid windows", hybrid, PlateConfig(label=LabelMode.engrave, thickness_mm=1.2), None),
        ("hard cut-outs", cut, PlateConfig(label=LabelMode.engrave, thickness_mm=1.2), None),
        ("notched tile", grid(), PlateConfig(label=LabelMode.emboss), notched),
    ]


@pytest.fixture(scope="module", params=_plates(), ids=lambda p: p[0])
def built(request):
    _, holes, plate_cfg, ring = request.param
    return holes, cad.build_plate(holes, W, H, plate_cfg, LABEL, outline_ring=ring)


def test_the_file_check_passes_and_agrees_with_occt(built, tmp_path):
    holes, model = built
    step = cad.plate_step_text(model)
    mine = cad.check_plate_file(model, step, holes)
    assert mine["valid"] and mine["valid_method"].startswith("kernel-free") and mine["tiles"] == []
    # OCCT reads the same text back: one valid solid, the same faces, cylinders and volume.
    (tmp_path / "p.step").write_text(step, encoding="ascii")
    back = read_step(tmp_path / "p.step")
    topo = topology_checks(back)
    assert topo["solids"] == 1 and topo["edges_not_two_faces"] == 0 and topo["edges_misoriented"] == 0
    assert brep_valid(back)
    rep = check_step_text(step, model.geometry)
    assert (rep["faces"], rep["cylinders"]) == (topo["faces"], topo["cylinders"])
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(back, props)
    assert mine["volume"] == pytest.approx(props.Mass(), rel=1e-9)
    # And OCCT's own check of the solid built in memory says the same.
    theirs = cad.check_plate(model, holes)
    assert theirs["valid"] and theirs["faces"] == mine["faces"]
    assert mine["volume"] == pytest.approx(theirs["volume"], rel=1e-9)
    np.testing.assert_allclose(mine["bbox"], theirs["bbox"], atol=1e-6)
    assert mine["mesh"]["genus"] == theirs["mesh"]["genus"] == model.geometry.hole_count


@pytest.mark.parametrize(
    "xy, r, polygons",
    [
        ([[5, 5], [10, 10]], [1, 1], ()),
        ([[5, 5], [6, 5]], [1, 1], ()),  # overlapping holes
        ([[5, 5], [7, 5]], [1, 1], ()),  # tangent holes
        ([[0.5, 5]], [1], ()),  # a hole across the edge
        ([[5, 5], [5, 5.1]], [2, 0.5], ()),  # a hole inside a hole
        ([[5, 5]], [1], ([[4, 14], [8, 14], [8, 18], [4, 18]],)),
        ([[5, 5]], [1], ([[4, 4], [8, 4], [8, 8], [4, 8]],)),  # a cut-out across a hole
        ([[6, 6]], [0.5], ([[4, 4], [8, 4], [8, 8], [4, 8]],)),  # a hole inside a cut-out
        ([], [], ([[4, 4], [8, 8], [8, 4], [4, 8]],)),  # a self-crossing cut-out
        ([], [], ([[4, 4], [8, 4], [8, 8], [4, 8]], [[8, 6], [10, 6], [10, 9]])),  # cut-outs touching
        ([], [], ([[2, 2], [10, 2], [10, 10], [2, 10]], [[4, 4], [6, 4], [6, 6], [4, 6]])),  # one in another
        ([], [], ([[22, 2], [30, 2], [30, 10], [22, 10]],)),  # a cut-out off the plate
    ],
)
def test_the_file_check_gives_occts_verdict_on_faulty_plates(xy, r, polygons):
    from stencil_cad.cad.solid import make_solid

    # OCCT's verdict on the solid of the same description (OCCT's analyzer passes the read-back
    # STEP of a hole across the outline: the file check is the stricter there).
    geom = _faulty(xy, r, polygons)
    occt_says = brep_valid(make_solid(geom))
    fails = check_step_text(step_text(geom), geom)["fails"]
    assert (fails == []) is occt_says, fails


def test_a_cut_out_folded_flat_fails_the_file_check_as_occt_fails_its_file(tmp_path):
    # OCCT's analyzer passes the solid built in memory, not the file read back; nor does the file check.
    geom = _faulty([], [], ([[4, 4], [8, 4], [6, 4]],))
    step = step_text(geom)
    (tmp_path / "p.step").write_text(step, encoding="ascii")
    assert not brep_valid(read_step(tmp_path / "p.step"))
    assert "enclose no area" in "; ".join(check_step_text(step, geom)["fails"])


def test_the_file_check_raises_naming_the_failure(built):
    holes, model = built
    step = cad.plate_step_text(model)
    with pytest.raises(PlateCheckError, match="MANIFOLD_SOLID_BREP"):
        cad.check_plate_file(model, step.replace("MANIFOLD_SOLID_BREP", "MANIFOLD_SOLID_BRAP"), holes)


# ----------------------------------------------------------------------------- the job


def _hard_job(root, extra=""):
    (root / "cans.csv").write_text(HARD_CANS)
    cfg = root / "job.yaml"
    cfg.write_text(small_hard("step check", extra))
    out = root / "out"
    assert main(["hard", str(cfg), "--out", str(out), "-q", "--workers", "0"]) == 0
    return json.loads((out / "manifest.json").read_text())["build"]["plates"]


def test_a_job_checks_its_plates_by_their_files_and_builds_no_solid(tmp_path, monkeypatch):
    def refuse(geom):
        raise AssertionError("a job built an OCCT solid for a plate with a description")

    monkeypatch.setattr("stencil_cad.cad.plate.make_solid", refuse)
    monkeypatch.setattr("stencil_cad.cad.solid.make_solid", refuse)
    plates = _hard_job(tmp_path)
    assert plates and all(p["valid"] and p["n_solids"] == 1 for p in plates)
    assert all(p["valid_method"].startswith("kernel-free check of the written STEP") for p in plates)
    assert all(p["volume_method"].startswith("divergence theorem over the written STEP") for p in plates)
    assert all(p["rel_error"] < 1e-9 and p["tiles"] == [] for p in plates)


def test_plate_check_kernel_runs_occts_check(tmp_path, monkeypatch):
    from stencil_cad.cad import plate, solid

    calls = []

    def counted(geom):
        calls.append(geom.hole_count)
        return solid.make_solid(geom)

    monkeypatch.setattr(plate, "make_solid", counted)
    plates = _hard_job(tmp_path, "plate:\n  check: kernel\n")
    assert len(calls) == len(plates) > 0
    assert all(p["valid"] and "BRepCheck_Analyzer" in p["valid_method"] for p in plates)
