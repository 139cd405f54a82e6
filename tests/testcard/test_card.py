"""The calibration card: layout, sheet, export, and the photo fit on synthetic photos with a known truth."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import yaml

from stencil_cad.cli import main
from stencil_cad.config import JobConfig
from stencil_cad.config.spray import CanConstants, SprayConfig
from stencil_cad.stipple import check_rules
from stencil_cad.testcard import card_description, card_layout, layout_from_description
from stencil_cad.testcard.fit import fit_card
from stencil_cad.testcard.printout import aruco_dictionary, printout_reflectance
from stencil_cad.testcard.synthetic import PhotoSettings, card_opacity, synthetic_photo

TRUTH = CanConstants(spread_k=0.1, bleed_sigma_mm=0.4, deposit_per_pass=0.55)
PASSES = 4


@pytest.fixture(scope="module")
def layout():
    return card_layout(JobConfig(), [3.0, 12.0])


def test_layout_holds_the_jobs_holes_and_fits_every_bed(layout):
    job = JobConfig()
    st = job.stipple
    kinds = [f.kind for f in layout.features]
    assert kinds.count("window") == 1 and kinds.count("patch") == 5
    singles = sorted(f.r_mm for f in layout.features if f.kind == "single")
    assert singles[0] == pytest.approx(st.sizes.radius_mm) and singles[-1] == pytest.approx(
        st.sizes.max_radius_mm
    )
    fractions = [f.open_fraction for f in layout.features if f.kind == "patch"]
    assert all(np.diff(fractions) > 0) and fractions[0] > 0.02
    rules = st.design_rules(layout.width_mm, layout.height_mm)
    window = layout.features[0].index[0]
    keep = np.ones(len(layout.dots), bool)
    keep[window] = False
    check_rules(layout.dots.xy_mm[keep], layout.dots.r_mm[keep], rules)
    for fp in layout.footprints:
        size = fp.outer_ring.max(axis=0) - fp.outer_ring.min(axis=0)
        assert size[0] <= 127.0 and size[1] <= 80.0  # the wall fits an SL1S (127 x 80)
    again = layout_from_description(json.loads(json.dumps(card_description(layout))))
    assert np.allclose(again.dots.xy_mm, layout.dots.xy_mm, atol=1e-4)
    assert [(f.kind, f.index) for f in again.features] == [(f.kind, f.index) for f in layout.features]
    with pytest.raises(ValueError, match="not a calibration card"):
        layout_from_description({"kind": "something else"})


def test_sheet_markers_are_readable(layout):
    img = (printout_reflectance(layout, 8.0) * 255).astype(np.uint8)
    det = cv2.aruco.ArucoDetector(aruco_dictionary(), cv2.aruco.DetectorParameters())
    _, ids, _ = det.detectMarkers(img)
    want = {i for fp in layout.footprints for i in fp.marker_ids}
    assert set(ids.ravel().tolist()) == want


def _photo(layout, tmp_path, cfg=None, settings=None, seed=0):
    cfg = cfg or SprayConfig(model="physical", can=TRUTH)
    data, suffix = synthetic_photo(layout, cfg, PASSES, np.random.default_rng(seed), settings)
    path = tmp_path / f"photo{suffix}"
    path.write_bytes(data)
    return path


@pytest.mark.slow
def test_fit_recovers_the_constants_from_a_realistic_photo(layout, tmp_path):
    settings = PhotoSettings(shift_mm=((0.4, -0.3), (-0.25, 0.5)))
    path = _photo(layout, tmp_path, settings=settings)
    rgb = cv2.imread(str(path))[..., ::-1].copy()
    fit = fit_card(rgb, layout, PASSES)
    for key in ("spread_k", "bleed_sigma_mm", "deposit_per_pass"):
        assert getattr(fit.can, key) == pytest.approx(getattr(TRUTH, key), rel=0.05), key
    assert fit.contrast == pytest.approx(settings.paint_contrast[fit.channel], abs=0.02)
    for got, want in zip(fit.shifts_mm, settings.shift_mm, strict=True):
        assert np.allclose(got, want, atol=0.1)
    # Tone: every dose-ladder patch sprayed with the fitted constants vs the true ones.
    true_cfg = SprayConfig(model="physical", can=TRUTH)
    fit_cfg = SprayConfig(model="physical", can=fit.can)
    for fp in layout.footprints:
        a_true = card_opacity(layout, fp, true_cfg, PASSES, 8.0)
        a_fit = card_opacity(layout, fp, fit_cfg, PASSES, 8.0)
        for f in layout.features:
            x0, y0, x1, y1 = (int(round(v * 8.0)) for v in f.box)
            h = a_true.shape[0]
            sl = np.s_[h - y1 : h - y0, x0:x1]
            assert abs(a_true[sl].mean() - a_fit[sl].mean()) < 0.02
    assert fit.residual_rms < 0.03


@pytest.mark.slow
def test_calibrate_command_writes_a_profile_a_job_can_use(layout, tmp_path, capsys):
    card = tmp_path / "card.json"
    card.write_text(json.dumps(card_description(layout)))
    photo = _photo(layout, tmp_path, settings=PhotoSettings(jpeg_quality=None, tilt=0.05))
    prof = tmp_path / "can.yaml"
    assert (
        main(
            [
                "calibrate",
                str(photo),
                "--card",
                str(card),
                "--passes",
                "4",
                "--paint",
                "test can",
                "--out",
                str(prof),
            ]
        )
        == 0
    )
    assert "residual RMS" in capsys.readouterr().out
    data = yaml.safe_load(prof.read_text())
    assert data["paint"] == "test can" and data["fit"]["passes"] == 4
    assert data["spread_k"] == pytest.approx(TRUTH.spread_k, rel=0.05)
    job = tmp_path / "job.yaml"
    job.write_text("spray:\n  model: physical\n  profile: can.yaml\n")
    from stencil_cad.config.io import load_config

    assert load_config(job).spray.can.deposit_per_pass == pytest.approx(TRUTH.deposit_per_pass, rel=0.05)
    # An existing profile is not overwritten.
    assert main(["calibrate", str(photo), "--card", str(card), "--out", str(prof)]) == 2


def _refused(tmp_path, card, image, capsys, words):
    path = tmp_path / "bad.png"
    cv2.imwrite(str(path), image)
    assert main(["calibrate", str(path), "--card", str(card), "--out", str(tmp_path / "p.yaml")]) == 2
    err = capsys.readouterr().err
    assert words in err and not (tmp_path / "p.yaml").exists()


def test_unreadable_photos_are_refused_with_the_reason(layout, tmp_path, capsys):
    card = tmp_path / "card.json"
    card.write_text(json.dumps(card_description(layout)))
    _refused(tmp_path, card, np.full((2000, 3000, 3), 180, np.uint8), capsys, "fiducials not found")
    _refused(tmp_path, card, np.full((300, 400, 3), 180, np.uint8), capsys, "too small")
    (tmp_path / "junk.jpg").write_bytes(b"not an image")
    assert (
        main(
            ["calibrate", str(tmp_path / "junk.jpg"), "--card", str(card), "--out", str(tmp_path / "p.yaml")]
        )
        == 2
    )
    assert "not a readable image" in capsys.readouterr().err


@pytest.mark.slow
def test_overexposed_and_distant_photos_are_refused_with_the_reason(layout, tmp_path, capsys):
    card = tmp_path / "card.json"
    card.write_text(json.dumps(card_description(layout)))
    bright = _photo(layout, tmp_path, settings=PhotoSettings(exposure=1.6, noise=0.0, jpeg_quality=None))
    _refused(tmp_path, card, cv2.imread(str(bright)), capsys, "overexposed")
    small = _photo(layout, tmp_path, settings=PhotoSettings(size_px=(1200, 900), jpeg_quality=None))
    _refused(tmp_path, card, cv2.imread(str(small)), capsys, "too small")


@pytest.mark.slow
def test_card_command_exports_checked_plate_walls_and_sheet(tmp_path):
    out = tmp_path / "card"
    assert main(["card", "--out", str(out), "--standoff", "6", "--standoff", "12", "-q"]) == 0
    names = {p.name for p in out.iterdir()}
    for n in (
        "card_plate.step",
        "card_plate.stl",
        "card_plate.dxf",
        "card_sheet.pdf",
        "card_sheet.png",
        "card.json",
    ):
        assert n in names
    assert {"card_wall_6mm.step", "card_wall_12mm.stl"} <= names
    man = json.loads((out / "manifest.json").read_text())
    c = man["card"]
    assert c["plate"]["valid"] and all(w["valid"] for w in c["walls"])
    assert c["plate_mm"][0] <= 120 and c["plate_mm"][1] <= 80
    desc = json.loads((out / "card.json").read_text())
    assert len(desc["holes"]["r_mm"]) == c["holes"] == c["plate"]["hole_count"]
    import trimesh

    mesh = trimesh.load(out / "card_plate.stl")
    assert mesh.is_watertight
    # The card's cut file carries its label on the score layer, apart from the cuts.
    import ezdxf

    doc = ezdxf.readfile(out / "card_plate.dxf")
    assert doc.layers.get("CARD_SCORE").color != doc.layers.get("CARD").color
    assert len(doc.modelspace().query('LWPOLYLINE[layer=="CARD_SCORE"]')) > 3
    assert main(["card", "--out", str(out), "-q"]) == 2  # not empty: no --force


@pytest.mark.slow
def test_a_photo_of_another_card_is_refused(layout, tmp_path, capsys):
    """A photo of another job's card (2 mm holes at 0.8 mm webs) measured with the default card's card.json: exit 2."""
    from stencil_cad.config.io import parse_config

    coarse = {"stipple": {"hole_min_r_mm": 1.0, "web_mm": 0.8}}
    other = card_layout(parse_config(coarse, "coarse holes"), [3.0, 12.0])
    card = tmp_path / "card.json"
    card.write_text(json.dumps(card_description(layout)))
    photo = _photo(other, tmp_path, settings=PhotoSettings(jpeg_quality=None))
    out = tmp_path / "p.yaml"
    code = main(["calibrate", str(photo), "--card", str(card), "--out", str(out)])
    cap = capsys.readouterr()
    err = cap.err + cap.out
    assert code == 2, err
    assert "does not match the card description" in err and "times the photo's noise" in err, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["card.json", photo.name]
    )


def test_card_standoff_out_of_the_walls_range_is_refused_by_the_wall_rule(tmp_path, capsys):
    out = tmp_path / "card"
    assert main(["card", "--out", str(out), "--standoff", "400", "-q"]) == 2
    assert "--standoff" in capsys.readouterr().err
    assert not out.exists()
