"""Refinement cost at scale: 100,000 holes on a 2048 x 2048 grid.

One layer of dark paint on a white primer, the target is scikit-image's chelsea scaled to
2048 x 2048 px at 0.25 mm per px (512 mm square). The holes start on a jittered hexagonal
lattice (SLA rules: r = 0.5 mm, web 0.5 mm) thinned to 100,000, repaired by the design
rules, and are refined with the default settings (``refine`` config section) under the physical
spray model (2 passes, a 10 mm wall, a 1.2 mm plate). Prints the
refinement's seconds (wall clock and CPU), the objective before and after, and whether every refined hole
passes the rules.

Run: ``python -m benchmarks refine``.
"""

from __future__ import annotations

import math
import time

import numpy as np

N_HOLES = 100_000
SIDE_PX = 2048
PITCH_MM = 0.25
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "holes_in",
    "holes_out",
    "objective_start",
    "objective_end",
    "rules_pass",
    "seconds",
    "cpu_seconds",
)


def smoke():
    """1,500 holes on 256 x 256 px (64 mm), the same code."""
    yield from run(n_holes=1500, side_px=256, case="smoke-1500")


def run(cases=None, n_holes: int = N_HOLES, side_px: int = SIDE_PX, case: str = "100k"):
    if cases and "100k" not in cases:
        return
    from skimage import data
    from skimage.color import rgb2gray
    from skimage.transform import resize

    from stencil_cad.config import JobConfig
    from stencil_cad.config.spray import SprayConfig
    from stencil_cad.model import DotSet
    from stencil_cad.simulate.physical import SprayGeometry
    from stencil_cad.simulate.scielab import smallest_sigma_mm
    from stencil_cad.simulate.spray import hole_kernels
    from stencil_cad.stipple.refine import RefineSettings, refine_dots
    from stencil_cad.stipple.rules import DesignRules, check_rules, enforce_rules

    side_mm = side_px * PITCH_MM
    grey = resize(rgb2gray(data.chelsea()), (side_px, side_px), anti_aliasing=True)
    ink = np.array([[0.12, 0.1, 0.1]])
    alpha = np.clip(1.0 - grey, 0.0, 1.0)[..., None]
    target = (1.0 - alpha) + alpha * ink[0]
    rules = DesignRules(
        hole_min_r_mm=0.5, web_mm=0.5, edge_margin_mm=2.0, width_mm=side_mm, height_mm=side_mm
    )
    rng = np.random.default_rng(0)
    spacing = 1.6
    dy = spacing * math.sqrt(3.0) / 2.0
    j, i = np.meshgrid(np.arange(int(side_mm / dy)), np.arange(int(side_mm / spacing)), indexing="ij")
    xy = np.column_stack([(i * spacing + (j % 2) * spacing / 2.0).ravel(), (j * dy).ravel()])
    xy += rng.normal(0.0, 0.05 * spacing, xy.shape)
    xy = xy[rng.permutation(len(xy))[: int(n_holes * 1.02)]]
    xy, r, _ = enforce_rules(xy, np.full(len(xy), 0.5), rules)
    xy, r = xy[:n_holes], r[:n_holes]
    cfg = JobConfig()
    # The physical spray model (the default) needs the plate's geometry: a 10 mm wall, a 1.2 mm plate.
    spray = SprayConfig(passes=2.0)
    geometry = SprayGeometry(10.0, 1.2)
    settings = RefineSettings(
        iterations=cfg.refine.iterations,
        step_mm=cfg.refine.step_mm,
        radius_step_mm=cfg.refine.radius_step_mm,
        max_radius_mm=cfg.refine.max_radius_factor * 0.5,
        add_remove_every=cfg.refine.add_remove_every,
        eye_sigma_mm=smallest_sigma_mm(cfg.view.distance_m),
    )
    t0 = time.perf_counter()
    c0 = time.process_time()
    out, rep = refine_dots(
        target,
        PITCH_MM,
        np.ones(3),
        ink,
        [DotSet(xy_mm=xy, r_mm=r)],
        [rules],
        lambda rr, a: hole_kernels(rr, spray, a, geometry=geometry),
        [2.0],
        settings,
    )
    seconds = time.perf_counter() - t0
    cpu = time.process_time() - c0
    check_rules(out[0].xy_mm, out[0].r_mm, rules)
    yield {
        "bench": "refine",
        "case": case,
        "holes_in": int(len(r)),
        "holes_out": len(out[0]),
        "grid_px": [side_px, side_px],
        "iterations": settings.iterations,
        "model": "physical",
        "objective_start": round(rep["objective_start"], 5),
        "objective_end": round(rep["objective_end"], 5),
        "rules_pass": True,
        "seconds": round(seconds, 2),
        # CPU seconds of all threads (two cores: up to twice the wall clock when nothing else runs).
        "cpu_seconds": round(cpu, 2),
    }
