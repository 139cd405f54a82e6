"""The physical spray model: exactness of the fast path, stand-off, shading, per-hole kernels, profiles."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from stencil_cad import simulate as sim
from stencil_cad.config import JobConfig
from stencil_cad.config.io import load_config
from stencil_cad.config.spray import SprayConfig
from stencil_cad.errors import ConfigError
from stencil_cad.frames import mm_to_px
from stencil_cad.simulate import physical as phys
from stencil_cad.simulate.kept import Kept

PHYS = SprayConfig(model="physical")
GEOM = phys.SprayGeometry(standoff_mm=10.0, plate_thickness_mm=1.2)


def _holes(n=60, size=30.0, seed=1):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, size, (n, 2)), rng.uniform(0.5, 1.2, n)


@pytest.mark.parametrize("mm_per_px", [0.25, 0.1])
def test_fast_path_matches_exact_profile(mm_per_px):
    xy, r = _holes(25, 15.0)
    n = int(round(15.0 / mm_per_px))
    fast = sim.spray_opacity(xy, r, (n, n), mm_per_px, PHYS, geometry=GEOM)
    exact = sim.spray_opacity(xy, r, (n, n), mm_per_px, PHYS, geometry=GEOM, exact=True)
    assert np.abs(fast - exact).max() < 2e-3
    crop = (10, n // 2, 5, n // 3)
    part = sim.spray_opacity(xy, r, (n, n), mm_per_px, PHYS, geometry=GEOM, crop=crop)
    assert np.abs(part - fast[crop[0] : crop[1], crop[2] : crop[3]]).max() < 1e-9


def test_open_window_gives_full_dose_and_half_dose_edge():
    cfg = PHYS.model_copy(update={"passes": 3.0})
    r = 15.0
    s = 0.2
    n = int(40 / s)
    op = sim.spray_opacity([[20.0, 20.0]], r, (n, n), s, cfg, geometry=GEOM)
    depth = 3.0 * phys.dose_per_pass(cfg) * float(phys.plate_transmission(r, 1.2, cfg.can.spread_k))
    centre = op[n // 2, n // 2]
    assert centre == pytest.approx(-math.expm1(-depth), abs=1e-3)
    # On the window's edge half the dose arrives (a straight edge blurred by a Gaussian).
    row = n // 2
    col = int(round((20.0 + r) / s - 0.5))
    edge = op[row, col]
    assert edge == pytest.approx(-math.expm1(-depth * 0.5), abs=0.02)


def test_standoff_blurs_whatever_the_radius():
    assert phys.spread_sigma_mm(PHYS, 0.0) == pytest.approx(PHYS.can.bleed_sigma_mm)
    s10, s20 = phys.spread_sigma_mm(PHYS, 10.0), phys.spread_sigma_mm(PHYS, 20.0)
    assert s20 > s10 > PHYS.can.bleed_sigma_mm
    assert s20**2 - s10**2 == pytest.approx(PHYS.can.spread_k**2 * 300.0)
    xy, r = _holes(200, 40.0, seed=2)
    tex = []
    for g in (4.0, 8.0, 16.0):
        op = sim.spray_opacity(xy, r, (160, 160), 0.25, PHYS, geometry=phys.SprayGeometry(g, 1.2))
        tex.append(float(op[20:-20, 20:-20].std()))
    assert tex[0] > tex[1] > tex[2]


def test_plate_transmission_against_monte_carlo():
    rng = np.random.default_rng(0)
    k, t = 0.15, 1.2
    for r in (0.5, 1.0):
        slopes = rng.normal(0.0, k, (200_000, 2))
        entry = rng.uniform(-1, 1, (400_000, 2))
        entry = entry[(entry**2).sum(1) <= 1][:200_000] * r
        exit_ = entry + slopes[: len(entry)] * t
        mc = float(((exit_**2).sum(1) <= r * r).mean())
        assert float(phys.plate_transmission(r, t, k)) == pytest.approx(mc, abs=0.005)
    assert float(phys.plate_transmission(0.5, 1.2, 0.15)) == pytest.approx(0.72, abs=0.01)
    assert float(phys.plate_transmission(1.0, 0.0, 0.15)) == 1.0
    tr = phys.plate_transmission(np.array([0.5, 1.0, 2.0]), 1.2, 0.15)
    assert np.all(np.diff(tr) > 0)


def test_dose_scales_with_distance_and_speed():
    base = phys.dose_per_pass(PHYS)
    assert base == pytest.approx(PHYS.can.deposit_per_pass)
    far = PHYS.model_copy(update={"can_distance_mm": 400.0})
    slow = PHYS.model_copy(update={"pass_speed_m_s": 0.25})
    assert phys.dose_per_pass(far) == pytest.approx(base / 2)
    assert phys.dose_per_pass(slow) == pytest.approx(base * 2)


def test_hole_kernels_paper_contract():
    cfg = SprayConfig(model="paper", nozzle_height=7.0)
    r = np.array([0.5, 1.0])
    sigma, peak, ds, dp, combine = sim.hole_kernels(r, cfg, 0.7)
    assert combine == "product"
    assert np.allclose(sigma, sim.dot_sigma_mm(r, 7.0))
    assert np.allclose(peak, 0.7) and np.allclose(dp, 0.0)
    assert np.allclose(ds, math.sqrt(8.0) / 2.0)


def test_hole_kernels_physical_contract():
    r = np.array([0.5, 0.8, 1.2])
    sigma, peak, ds, dp, combine = sim.hole_kernels(r, PHYS, 3.0, geometry=GEOM)
    assert combine == "exp"
    s = phys.spread_sigma_mm(PHYS, 10.0)
    assert np.allclose(sigma**2, r**2 / 4 + s**2)
    # Matched integral: the Gaussian carries the hole's whole dose.
    dose = (
        3.0 * phys.dose_per_pass(PHYS) * phys.plate_transmission(r, 1.2, PHYS.can.spread_k) * math.pi * r**2
    )
    assert np.allclose(2 * math.pi * sigma**2 * peak, dose)
    eps = 1e-5
    s_p, p_p, *_ = sim.hole_kernels(r + eps, PHYS, 3.0, geometry=GEOM)
    s_m, p_m, *_ = sim.hole_kernels(r - eps, PHYS, 3.0, geometry=GEOM)
    assert np.allclose(ds, (s_p - s_m) / (2 * eps), rtol=1e-5)
    assert np.allclose(dp, (p_p - p_m) / (2 * eps), rtol=1e-4)
    with pytest.raises(ValueError, match="geometry"):
        sim.hole_kernels(r, PHYS, 3.0)


def test_gaussian_kernel_error_as_documented():
    # The figures quoted in physical_hole_kernels' docstring.
    for q, err in ((0.5, 0.001), (1.0, 0.017), (1.5, 0.066), (2.0, 0.16), (3.0, 0.40)):
        assert phys.gaussian_kernel_error(q) == pytest.approx(err, rel=0.05, abs=0.001)
    # And the Gaussian opacity of sparse small holes agrees with the exact model to that order.
    xy, r = _holes(15, 30.0, seed=4)
    r = np.full(len(r), 0.6)
    sigma, peak, *_ = sim.hole_kernels(r, PHYS, 2.0, geometry=GEOM)
    n, s = 120, 0.25
    rows, cols = np.mgrid[0:n, 0:n]
    rc = mm_to_px(xy, n, s)
    tot = np.zeros((n, n))
    for i in range(len(r)):
        d2 = ((rows - rc[i, 0]) ** 2 + (cols - rc[i, 1]) ** 2) * s * s
        tot += peak[i] * np.exp(-d2 / (2 * sigma[i] ** 2))
    gauss = -np.expm1(-tot)
    exact = sim.spray_opacity(xy, r, (n, n), s, PHYS, geometry=GEOM, exact=True)
    assert np.abs(gauss - exact).max() < 0.01 * exact.max() + 1e-4


@pytest.mark.slow
def test_physical_tone_calibration_chooses_a_dose_the_hand_sprays():
    from stencil_cad.config.spray import SWEEP_PACE
    from stencil_cad.simulate import response_tone_for

    job = JobConfig(spray={"model": "physical"}, stipple={"process": "sla", "tone": "response"})
    alpha = np.linspace(0.0, 0.8, 40 * 40).reshape(40, 40)
    choice = response_tone_for(alpha, 0.5, job)
    sp = job.spray
    # A dose on the spray.dose_step grid, sprayed as whole passes at a pace the hand keeps.
    assert choice.spray_time in sp.doses() and 0.75 <= choice.spray_time <= sp.max_passes
    # Under one pass: one quicker pass, within the hand's pace (0.5 would ask for twice the pace).
    assert sp.doses()[:2] == [0.75, 1.0] and sp.hand(0.75) == (1, pytest.approx(sp.pass_speed_m_s / 0.75))
    n, speed = sp.hand(choice.spray_time)
    assert n * sp.pass_speed_m_s / speed == pytest.approx(choice.spray_time)
    assert SWEEP_PACE[0] <= speed / sp.pass_speed_m_s <= SWEEP_PACE[1]
    assert choice.predicted_rmse <= choice.predicted_rmse_linear + 1e-12
    # dose_step 1 keeps whole passes at the usual pace.
    whole = job.spray.model_copy(update={"dose_step": 1.0})
    assert whole.doses() == [float(n) for n in range(1, whole.max_passes + 1)]
    assert all(whole.hand(d) == (int(d), whole.pass_speed_m_s) for d in whole.doses())


def test_a_dose_between_passes_is_sprayed_at_another_pace():
    sp = JobConfig(spray={"model": "physical"}).spray
    # Between two whole passes equally near, the lighter passes: three at 0.6 m/s, not two at 0.4.
    assert sp.hand(2.5) == (3, pytest.approx(0.6))
    n, speed = sp.hand(2.75)
    assert n == 3 and speed == pytest.approx(0.5 * 3 / 2.75)
    n, speed = sp.hand(1.25)
    assert n == 1 and speed == pytest.approx(0.4)


def test_mask_spray_physical():
    m = np.zeros((100, 100), bool)
    m[20:80, 20:80] = True
    op = sim.spray_mask(m, 0.25, PHYS, geometry=GEOM, spray_time=2.0)
    assert op[50, 50] == pytest.approx(-math.expm1(-2.0 * phys.dose_per_pass(PHYS)), abs=1e-4)
    assert op[50, 5] < 0.01


def _write_profile(path, **over):
    data = {"spread_k": 0.08, "bleed_sigma_mm": 0.4, "deposit_per_pass": 1.1, "standoff_mm": 10.0}
    data.update(over)
    path.write_text(yaml.safe_dump(data))


def test_job_references_a_profile(tmp_path):
    _write_profile(tmp_path / "can.yaml")
    (tmp_path / "job.yaml").write_text("spray:\n  model: physical\n  profile: can.yaml\n")
    cfg = load_config(tmp_path / "job.yaml")
    assert cfg.spray.can.spread_k == 0.08 and cfg.spray.can.deposit_per_pass == 1.1
    assert cfg.spray.profile == tmp_path / "can.yaml"
    (tmp_path / "bad.yaml").write_text("spray:\n  profile: can.yaml\n  can:\n    spread_k: 0.2\n")
    with pytest.raises(ConfigError, match="differ"):
        load_config(tmp_path / "bad.yaml")
    (tmp_path / "gone.yaml").write_text("spray:\n  profile: nothere.yaml\n")
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "gone.yaml")
    _write_profile(tmp_path / "wrong.yaml", spread_k=-1)
    (tmp_path / "w.yaml").write_text("spray:\n  profile: wrong.yaml\n")
    with pytest.raises(ConfigError, match="spread_k"):
        load_config(tmp_path / "w.yaml")


@pytest.mark.slow
def test_job_in_the_makers_units_scores_every_wall(tmp_path, capsys):
    from stencil_cad.cli import main

    cfg = tmp_path / "job.yaml"
    cfg.write_text(
        "name: walls\nsize:\n  width_mm: 40\n  px_per_mm: 2\ndecompose:\n  layers: 2\n"
        "stipple:\n  process: sla\n  tone: response\nwall:\n  standoff_mm: [4, 16]\n"
        "spray:\n  model: physical\n  can_distance_mm: 250\n"
    )
    out = tmp_path / "out"
    assert main(["run", str(cfg), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "from 25 cm" in text and " m/s" in text
    man = json.loads((out / "manifest.json").read_text())
    walls = man["simulate"]["walls"]
    assert [w["standoff_mm"] for w in walls] == [4.0, 16.0]
    assert walls[0]["de2000_mean"] != walls[1]["de2000_mean"]
    assert walls[0]["blur_sigma_mm"][0] < walls[1]["blur_sigma_mm"][0]
    assert (out / "simulated_wall_4mm.png").is_file() and (out / "simulated_wall_16mm.png").is_file()
    steps = man["spraying"]
    assert all(isinstance(s["passes"], int) and s["can_distance_cm"] == 25 for s in steps)
    # Whole passes at the pace that sprays each layer's dose.
    for s in steps:
        assert s["passes"] * 0.5 / s["pass_speed_m_s"] == pytest.approx(s["dose_passes"], rel=0.01)
    assert json.loads((out / "spray.json").read_text())["unit"] == "passes"


def test_a_layer_with_its_own_can_changes_only_its_own_simulation():
    from stencil_cad.model import DotSet, Layers
    from stencil_cad.simulate.cans import layer_can_prior

    rng = np.random.default_rng(5)
    alphas = rng.uniform(0.2, 0.8, (3, 40, 40))
    layers = Layers(
        primer=np.ones(3),
        colours=np.array([[0.1, 0.1, 0.1], [0.9, 0.4, 0.0], [0.0, 0.2, 0.8]]),
        alphas=alphas,
        mm_per_px=0.5,
    )
    dots = [DotSet(xy_mm=rng.uniform(3, 17, (30, 2)), r_mm=np.full(30, 0.7), report={}) for _ in range(3)]
    measured = PHYS.model_copy(
        update={
            "can": PHYS.can.model_copy(update={"deposit_per_pass": 0.6, "spread_k": 0.05, "fit": {"r": 1}})
        }
    )
    base = sim.simulate(layers, dots, PHYS, 0.25, geometry=GEOM)
    same = sim.simulate(layers, dots, PHYS, 0.25, geometry=GEOM, layer_sprays=[PHYS] * 3)
    own = sim.simulate(layers, dots, PHYS, 0.25, geometry=GEOM, layer_sprays=[PHYS, measured, PHYS])
    assert np.array_equal(base.alphas, same.alphas)
    assert np.array_equal(own.alphas[[0, 2]], base.alphas[[0, 2]])
    assert np.max(np.abs(own.alphas[1] - base.alphas[1])) > 0.05
    with pytest.raises(ValueError, match="one spray setting per layer"):
        sim.simulate(layers, dots, PHYS, 0.25, geometry=GEOM, layer_sprays=[PHYS])
    # The prior of cans varies the unmeasured layers and keeps the measured one's can.
    prior = layer_can_prior([PHYS, measured, PHYS])
    assert len(prior) > 2 and prior[0][0] == "nominal"
    assert all(per[1] is measured for _, per in prior)
    assert len({per[0].can.spread_k for _, per in prior}) > 1
    assert layer_can_prior([measured]) == [("nominal", [measured])]


def test_kept_results_stay_within_their_count_and_bytes():
    kept = Kept(4, max_bytes=3 * 800)
    for i in range(4):
        kept.get(i, lambda: np.zeros(100))  # 800 bytes each
    assert len(kept) == 3  # the bytes bound first
    assert kept.get(3, lambda: None) is not None  # the most recent kept
    kept.get("big", lambda: np.zeros(1000))
    assert len(kept) == 1  # the newest stays, however large
    plain = Kept(2)
    for i in range(3):
        plain.get(i, lambda: np.zeros(1000))
    assert len(plain) == 2


def test_a_dose_is_computed_once_for_the_same_holes_at_any_passes(monkeypatch):
    doses = []
    real = phys.physical_dose

    def counted(*args, **kwargs):
        doses.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(phys, "physical_dose", counted)
    monkeypatch.setattr(phys, "_DOSE_CACHE", Kept(6))
    xy, r = _holes()
    shape = (120, 120)
    want = [real(xy, r, shape, 0.25, PHYS, GEOM), real(xy, r, shape, 0.25, PHYS, GEOM)]
    ones = phys.physical_opacity(xy, r, shape, 0.25, PHYS, GEOM, 1.0)
    twos = phys.physical_opacity(xy.copy(), r.copy(), shape, 0.25, PHYS, GEOM, 2.0)
    assert len(doses) == 1
    depth = phys.dose_per_pass(PHYS)
    np.testing.assert_array_equal(ones, phys.opacity_of_dose(want[0], depth))
    np.testing.assert_array_equal(twos, phys.opacity_of_dose(want[1], 2.0 * depth))
    # Other holes, another spread or plate, another raster: a dose of their own.
    moved = xy + np.array([0.5, 0.0])
    assert not np.array_equal(phys.physical_opacity(moved, r, shape, 0.25, PHYS, GEOM, 1.0), ones)
    wide = SprayConfig(model="physical", can={"spread_k": 0.3})
    assert not np.array_equal(phys.physical_opacity(xy, r, shape, 0.25, wide, GEOM, 1.0), ones)
    thick = phys.SprayGeometry(standoff_mm=10.0, plate_thickness_mm=2.0)
    assert not np.array_equal(phys.physical_opacity(xy, r, shape, 0.25, PHYS, thick, 1.0), ones)
    assert phys.physical_opacity(xy, r, (100, 120), 0.25, PHYS, GEOM, 1.0).shape == (100, 120)
    assert len(doses) == 5


@pytest.mark.parametrize(("t", "k"), [(0.9, 0.15), (3.0, 0.3), (0.5, 0.05), (1.2, 0.15)])
def test_the_transmission_table_gives_the_quadrature_and_its_slope(t, k):
    """The table's values are the quadrature's, its slopes the derivative of it, inside the table and past it."""
    r = np.exp(np.random.default_rng(5).uniform(math.log(0.005), math.log(8.0), 5000))
    share, slope = phys.transmission_and_slope(r, t, k)
    np.testing.assert_allclose(share, phys.plate_transmission(r, t, k), rtol=0.0, atol=1e-11)
    eps = 1e-5 * r
    central = (phys.plate_transmission(r + eps, t, k) - phys.plate_transmission(r - eps, t, k)) / (2.0 * eps)
    np.testing.assert_allclose(slope, central, rtol=1e-6, atol=1e-6)
    assert phys.transmission_and_slope(np.array([0.5]), 0.0, 0.15)[0][0] == 1.0
