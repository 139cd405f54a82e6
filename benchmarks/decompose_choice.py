"""Does the decomposition's fast proxy rank candidate starts as the full pipeline does?

For each picture, every candidate start the decomposition considers (primer, palette, spray
order: ``decompose.order: auto``) is forced in turn and run through the whole soft pipeline
(decompose, stipple with windows, refine, simulate) under the bundled example's settings; the
sprayed result is scored with S-CIELAB at 1 m against the source on the simulated grid. The row
gives, per candidate, that score, the proxy's predicted error
(:class:`stencil_cad.decompose.sprayed.PlateReach`, ``trial_sprayed_de``: a mean ΔE) and the ideal trial
fit (``trial_rmse``, what the choice used before), and which candidate each ranking picks
(``proxy_pick``: the decomposition's own choice with the reach, ties included):
``proxy_pick == full_pick`` is the check, and ``proxy_regret`` what the proxy's pick loses at
1 m against the best.

Run: ``python -m benchmarks decompose_choice [--case dark_sky]``.
"""

from __future__ import annotations

import time

import numpy as np

CASES = ("example", "astronaut", "coffee", "dark_sky", "logo")
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "candidates",
    "full_scielab_1m",
    "proxy_sprayed_de",
    "full_pick",
    "proxy_pick",
    "proxy_regret",
    "seconds",
)


class _Forced:
    """A stand-in for the plate reach that makes the decomposition take candidate ``k``."""

    def __init__(self, reach, k: int):
        self.reach, self.k, self.calls, self.errors = reach, k, 0, []

    def error(self, target, primer, colours, alphas) -> float:
        self.errors.append(self.reach.error(target, primer, colours, alphas))
        self.calls += 1
        return 0.0 if self.calls - 1 == self.k else 1.0


def _job(case: str, size: dict | None = None):
    """The job config and picture of a case: the bundled example as shipped, or a picture under its settings."""
    from benchmarks.quality import _configs, _load
    from stencil_cad.imaging import fit_to_size
    from stencil_cad.plan.picture import load_picture

    if case == "example":
        from pathlib import Path

        import yaml

        from stencil_cad.config.io import parse_config

        data_dir = Path(__file__).resolve().parents[1] / "stencil_cad" / "data"
        raw = yaml.safe_load((data_dir / "example.yaml").read_text())
        raw["image"] = str(data_dir / raw["image"])
        cfg = parse_config(raw, source="example")
        return cfg, load_picture(cfg)
    cfg = _configs(size)["sla"]
    return cfg, _load(case, cfg, fit_to_size)


def _score(cfg, pic, layers) -> float:
    from benchmarks.quality import _NullOut
    from stencil_cad import pipeline
    from stencil_cad.plan import holes
    from stencil_cad.plan.plan import capped, painted, whole
    from stencil_cad.simulate import simulate
    from stencil_cad.simulate.physical import SprayGeometry
    from stencil_cad.simulate.scielab import scielab

    size = (pic.width_mm, pic.height_mm)
    run_ = pipeline.Run(cfg=cfg, out=_NullOut(), quiet=True)
    # Stippled and refined as the job makes them, nothing written.
    # Each paint's deposit, as the job sprays it.
    plan = painted(capped(whole(cfg, size)), layers.colours)
    sets = holes.refined(run_, plan, layers, holes.stippled(run_, plan, layers)[0], pic)[0].sets
    sim = simulate(layers, sets, cfg.spray, geometry=SprayGeometry.for_job(cfg), layer_sprays=plan.sprays)
    ref = np.clip(_reference(cfg, pic, sim.composite.shape[:2]), 0.0, 1.0)
    return float(scielab(ref, sim.composite, sim.mm_per_px, 1.0))


def _reference(cfg, pic, shape):
    from stencil_cad.simulate import resample

    return resample(pic.rgb, shape)


def smoke():
    """The generated dark sky at 40 mm: every candidate start through the whole pipeline."""
    yield from run(["dark_sky"], size={"width_mm": 40.0})


def run(cases=None, size: dict | None = None):
    """One row per picture: each candidate's full-pipeline score, proxy error and ideal fit."""
    from stencil_cad import decompose as dec
    from stencil_cad.pipeline.decompose import plate_reach

    for case in cases or CASES:
        cfg, pic = _job(case, size)
        reach = plate_reach(cfg)
        before = dec.decompose(pic, cfg.decompose, np.random.default_rng(cfg.seed)).info["order"]
        probe = _Forced(reach, 0)
        dec.decompose(pic, cfg.decompose, np.random.default_rng(cfg.seed), reach=probe)
        n = probe.calls
        t0 = time.perf_counter()
        full, proxy, orders = [], list(probe.errors), []
        for k in range(max(n, 1)):
            layers = dec.decompose(
                pic, cfg.decompose, np.random.default_rng(cfg.seed), reach=_Forced(reach, k)
            )
            orders.append(list(layers.info["order"]))
            full.append(round(_score(cfg, pic, layers), 3))
        best = int(np.argmin(full))
        # The decomposition's own pick with the plates' reach (its ranking and its tie rule).
        chosen = list(
            dec.decompose(pic, cfg.decompose, np.random.default_rng(cfg.seed), reach=reach).info["order"]
        )
        pick = orders.index(chosen) if chosen in orders else int(np.argmin(proxy))
        yield {
            "bench": "decompose_choice",
            "case": case,
            "candidates": n,
            "full_scielab_1m": full,
            "proxy_sprayed_de": [round(float(e), 3) for e in proxy],
            "orders": orders,
            "full_pick": best,
            "proxy_pick": pick,
            "ideal_pick": orders.index(list(before)) if list(before) in orders else None,
            "proxy_regret": round(full[pick] - full[best], 3),
            "seconds": round(time.perf_counter() - t0, 3),
        }
