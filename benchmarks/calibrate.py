"""Photo fit of the calibration card: time and how well it recovers known constants.

Each case renders a synthetic photo of the sprayed card with the physical spray model from
known constants (``spread_k``, ``bleed_sigma_mm``, ``deposit_per_pass``), seen through a
tilted, rotated camera, with a light gradient, defocus blur, sensor noise and JPEG
compression (:mod:`stencil_cad.testcard.synthetic`), then fits it
(:func:`stencil_cad.testcard.fit.fit_card`). ``seconds`` is the fit's time (marker detection,
rectification, flat field and least squares); ``*_error`` are relative errors of the constants
and, for ``tone_error``, the largest difference in mean opacity of any card feature (window,
single-hole rows, dose-ladder patches, every stand-off) sprayed with the fitted constants
against the true ones, in opacity units.

Cases:

* ``fine-cap``: k = 0.10, bleed 0.4 mm, 0.55 per pass, walls at 3 and 12 mm, 4 passes.
* ``fat-cap``: k = 0.18, bleed 0.3 mm, 0.9 per pass, walls at 4 and 10 mm, 3 passes, a dimmer
  and steeper light gradient, more noise, JPEG quality 70.
* ``one-standoff``: one wall (10 mm); the bleed keeps its prior (0.25 mm, the truth here) and
  k and the deposit are fitted.
* ``defaults``: the card ``stencil-cad card`` writes for the default job (its 10 mm wall and the
  card's 3 mm one) sprayed with the default can's constants, 4 passes.
* ``lighter-wider``: the same card sprayed with a can 25 % lighter (deposit 1.125 per pass) and a
  cap 50 % wider (k = 0.18) than the prior's nominal can.
* ``designs-the-job``: that card's fitted profile (``spray.profile``) designs the bundled example,
  scored (S-CIELAB at 1 m and 2 m, passes, stand-off) beside the example on the nominal can;
  ``scielab_1m_difference`` is measured minus nominal (``ok``: within 0.3).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import yaml

from stencil_cad.config import JobConfig
from stencil_cad.config.spray import CanConstants, SprayConfig
from stencil_cad.testcard import card_layout
from stencil_cad.testcard.fit import FIT_PX_PER_MM, fit_card, profile_yaml
from stencil_cad.testcard.synthetic import PhotoSettings, card_opacity, synthetic_photo

CASES = {
    "fine-cap": (
        CanConstants(spread_k=0.10, bleed_sigma_mm=0.4, deposit_per_pass=0.55),
        [3.0, 12.0],
        4,
        PhotoSettings(shift_mm=((0.4, -0.3), (-0.25, 0.5))),
    ),
    "fat-cap": (
        CanConstants(spread_k=0.18, bleed_sigma_mm=0.3, deposit_per_pass=0.9),
        [4.0, 10.0],
        3,
        PhotoSettings(
            gradient=(0.5, 1.0),
            exposure=0.75,
            noise=0.015,
            jpeg_quality=70,
            tilt=0.18,
            rotation_deg=-7.0,
            shift_mm=((-0.6, 0.2), (0.3, 0.3)),
        ),
    ),
    "one-standoff": (
        CanConstants(spread_k=0.12, bleed_sigma_mm=0.25, deposit_per_pass=0.7),
        [10.0],
        4,
        PhotoSettings(shift_mm=((0.2, 0.2),)),
    ),
    "defaults": (CanConstants(), None, 4, PhotoSettings(shift_mm=((0.3, -0.2), (-0.2, 0.3)))),
    # The prior's can 25 % lighter with a cap 50 % wider, on the default job's card.
    "lighter-wider": (
        CanConstants(spread_k=0.18, bleed_sigma_mm=0.25, deposit_per_pass=1.125),
        None,
        4,
        PhotoSettings(shift_mm=((0.3, -0.2), (-0.2, 0.3))),
    ),
}
#: ``designs-the-job``: the ``lighter-wider`` card's fitted profile designs the bundled example,
#: scored beside the example designed for and sprayed with the prior's nominal can.
JOB_CASE = "designs-the-job"


def _fit(name: str):
    """The card, the true and fitted constants, and the fit's time for case ``name``."""
    truth, standoffs, passes, settings = CASES[name]
    layout = card_layout(JobConfig(), standoffs)
    cfg = SprayConfig(model="physical", can=truth)
    t0 = time.perf_counter()
    data, _ = synthetic_photo(layout, cfg, passes, np.random.default_rng(14), settings)
    render_s = time.perf_counter() - t0
    rgb = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)[..., ::-1].copy()
    t0, c0 = time.perf_counter(), time.process_time()
    fit = fit_card(rgb, layout, passes)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    return layout, cfg, fit, seconds, cpu, render_s


def _case(name: str) -> dict:
    truth, standoffs, passes, settings = CASES[name]
    layout, cfg, fit, seconds, cpu, render_s = _fit(name)
    standoffs = [fp.standoff_mm for fp in layout.footprints]
    fit_cfg = SprayConfig(model="physical", can=fit.can)
    tone = 0.0
    for fp in layout.footprints:
        a_true = card_opacity(layout, fp, cfg, passes, FIT_PX_PER_MM)
        a_fit = card_opacity(layout, fp, fit_cfg, passes, FIT_PX_PER_MM)
        h = a_true.shape[0]
        for f in layout.features:
            x0, y0, x1, y1 = (int(round(v * FIT_PX_PER_MM)) for v in f.box)
            sl = np.s_[h - y1 : h - y0, x0:x1]
            tone = max(tone, abs(float(a_true[sl].mean() - a_fit[sl].mean())))
    shift_err = max(
        float(np.hypot(*(np.subtract(got, want))))
        for got, want in zip(fit.shifts_mm, settings.shift_mm, strict=True)
    )
    row = {
        "bench": "calibrate",
        "case": name,
        "seconds": round(seconds, 2),
        "cpu_seconds": round(cpu, 2),
        "render_seconds": round(render_s, 2),
        "photo_px": list(settings.size_px),
        "standoffs_mm": standoffs,
        "passes": passes,
        "truth": {k: getattr(truth, k) for k in ("spread_k", "bleed_sigma_mm", "deposit_per_pass")},
        "fitted": {
            k: round(getattr(fit.can, k), 5) for k in ("spread_k", "bleed_sigma_mm", "deposit_per_pass")
        },
    }
    for k in ("spread_k", "bleed_sigma_mm", "deposit_per_pass"):
        row[f"{k}_error"] = round(abs(getattr(fit.can, k) / getattr(truth, k) - 1.0), 5)
    row["contrast_error"] = round(abs(fit.contrast - settings.paint_contrast[fit.channel]), 5)
    row["tone_error"] = round(tone, 5)
    row["shift_error_mm"] = round(shift_err, 4)
    row["residual_rms"] = round(fit.residual_rms, 5)
    row["bleed_fitted"] = fit.info["bleed_fitted"]
    row["ok"] = bool(
        max(row["spread_k_error"], row["bleed_sigma_mm_error"], row["deposit_per_pass_error"]) <= 0.05
        and row["tone_error"] <= 0.02
    )
    return row


def _job_scores(folder: Path) -> dict:
    sim = json.loads((folder / "manifest.json").read_text())["simulate"]
    design = json.loads((folder / "manifest.json").read_text()).get("standoff") or {}
    return {
        "scielab_1m": round(sim["scielab"], 3),
        "scielab_2m": round(sim["scielab_2x"], 3),
        # As the hand sprays each plate's dose (spray.json): whole passes at a pace, one for a dose
        # under a pass.
        "passes": [int(o["passes"]) for o in json.loads((folder / "spray.json").read_text())["order"]],
        "doses": [round(float(t), 4) for t in sim["spray_time"]],
        "standoff_mm": sim.get("standoff_mm"),
        "design": design.get("reason"),
    }


def _designs_the_job() -> dict:
    """The example designed for the fitted lighter-wider profile against the example on the nominal can."""
    _, _, fit, _, _, _ = _fit("lighter-wider")
    example = Path(__file__).resolve().parents[1] / "stencil_cad/data"
    with tempfile.TemporaryDirectory(prefix="stencil_calibrate_job_") as tmp:
        tmp_path = Path(tmp)
        (tmp_path / "profile.yaml").write_text(profile_yaml(fit, "lighter-wider", "synthetic.jpg", 4))
        cfg = yaml.safe_load((example / "example.yaml").read_text())
        cfg["image"] = str(example / "example.png")
        (tmp_path / "nominal.yaml").write_text(yaml.safe_dump(cfg))
        cfg["spray"] = {**cfg["spray"], "profile": str(tmp_path / "profile.yaml")}
        (tmp_path / "measured.yaml").write_text(yaml.safe_dump(cfg))
        rows = {}
        for name in ("nominal", "measured"):
            cmd = [sys.executable, "-m", "stencil_cad", "run", str(tmp_path / f"{name}.yaml")]
            subprocess.run([*cmd, "--out", str(tmp_path / name), "-q"], check=True)
            rows[name] = _job_scores(tmp_path / name)
    return {
        "bench": "calibrate",
        "case": JOB_CASE,
        "fitted": {
            k: round(getattr(fit.can, k), 5) for k in ("spread_k", "bleed_sigma_mm", "deposit_per_pass")
        },
        "nominal": rows["nominal"],
        "measured": rows["measured"],
        "scielab_1m_difference": round(rows["measured"]["scielab_1m"] - rows["nominal"]["scielab_1m"], 3),
        "ok": abs(rows["measured"]["scielab_1m"] - rows["nominal"]["scielab_1m"]) <= 0.3,
    }


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds", "spread_k_error", "deposit_per_pass_error", "bleed_sigma_mm_error", "tone_error")


def smoke():
    """One synthetic photo of a one-wall card, fitted."""
    yield _case("one-standoff")


def run(cases=None):
    want = [*CASES, JOB_CASE] if not cases else cases
    for name in want:
        if name not in CASES and name != JOB_CASE:
            raise ValueError(f"unknown case {name!r}; choose from {', '.join([*CASES, JOB_CASE])}")
    for name in want:
        yield _designs_the_job() if name == JOB_CASE else _case(name)
