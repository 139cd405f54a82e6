"""Soft vs hard stencils: mean CIEDE2000 of the simulated spray against the input.

The comparison the paper makes: on scikit-image's astronaut, coffee and chelsea,
with the same number of paint layers, the soft pipeline (decompose, stipple,
simulate) and the hard one (flat-colour segmentation + bridged cut-outs, sprayed
with the same spray model) are scored against the same reference on the same grid.
Both are measured in the same run with the default job config (150 mm wide, the
default process preset and spray settings), whatever the numbers show.

Run: ``python -m benchmarks quality [--case coffee]``.
"""

from __future__ import annotations

import importlib
import time

import numpy as np

CASES = ("astronaut", "coffee", "chelsea")


def _require() -> dict:
    """The stages the benchmark needs, or a clear error naming the missing ones."""
    wanted = {
        "decompose": ("stencil_cad.decompose", "decompose"),
        "stipple_layer": ("stencil_cad.stipple", "stipple_layer"),
        "simulate": ("stencil_cad.simulate", "simulate"),
        "spray_mask": ("stencil_cad.simulate", "spray_mask"),
        "score": ("stencil_cad.simulate", "score"),
        "rules_from_config": ("stencil_cad.dots", "rules_from_config"),
        "fit_to_size": ("stencil_cad.imaging", "fit_to_size"),
    }
    found, missing = {}, []
    for key, (mod, name) in wanted.items():
        try:
            found[key] = getattr(importlib.import_module(mod), name)
        except (ImportError, AttributeError) as exc:
            missing.append(f"{mod}.{name} ({exc})")
    if missing:
        raise RuntimeError(
            "the quality benchmark needs the soft pipeline and the simulator; missing: "
            + "; ".join(missing)
            + ". No numbers are reported without them."
        )
    return found


def _nearest_resize(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resampling of a bool raster (pixel centres mapped, no blur)."""
    h, w = mask.shape
    rows = np.minimum(((np.arange(shape[0]) + 0.5) * h / shape[0]).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(shape[1]) + 0.5) * w / shape[1]).astype(np.int64), w - 1)
    return mask[rows][:, cols]


def _load(name: str, cfg, fit_to_size):
    from skimage import data

    from stencil_cad.model import Picture

    rgb = getattr(data, name)().astype(np.float64) / 255.0
    rgb, alpha, mm_per_px, _ = fit_to_size(
        rgb, None, cfg.size.width_mm, cfg.size.height_mm, cfg.size.px_per_mm
    )
    return Picture(rgb=rgb, mm_per_px=mm_per_px, alpha=alpha, source=f"skimage.data.{name}")


def run(cases=None):
    """Yield one dict per image: soft and hard mean CIEDE2000 and their details."""
    from stencil_cad.config import JobConfig
    from stencil_cad.hardstencil import make_hard_stencils, render_ideal
    from stencil_cad.model import composite

    f = _require()
    names = list(CASES) if not cases else [c for c in cases if c in CASES]
    unknown = [c for c in cases or [] if c not in CASES]
    if unknown:
        raise ValueError(f"unknown quality case(s) {unknown}; choose from {list(CASES)}")
    cfg = JobConfig()
    rules = f["rules_from_config"](cfg.stipple, cfg.size.width_mm, cfg.size.height_mm or cfg.size.width_mm)
    # The same process figures the pipeline's hard mode uses.
    min_feature_mm = 2.0 * rules.hole_min_r_mm
    bridge_min_mm = max(rules.web_mm, 1.0)
    tone = getattr(getattr(cfg.stipple, "tone", None), "value", None)
    for name in names:
        t_all = time.perf_counter()
        pic = _load(name, cfg, f["fit_to_size"])

        t0 = time.perf_counter()
        rng = np.random.default_rng(cfg.seed)
        layers = f["decompose"](pic, cfg.decompose, rng)
        t_decompose = time.perf_counter() - t0
        dotsets = []
        for alpha in layers.alphas:
            density = None
            if tone == "calibrated":
                from stencil_cad import simulate

                density = simulate.calibrated_density_for(alpha, layers.mm_per_px, cfg)
            dotsets.append(f["stipple_layer"](alpha, layers.mm_per_px, cfg.stipple, rng, density=density))
        t_stipple = time.perf_counter() - t0 - t_decompose
        sim = f["simulate"](layers, dotsets, cfg.spray)
        soft = f["score"](pic.rgb, sim.composite)
        soft_seconds = time.perf_counter() - t0

        t0 = time.perf_counter()
        hard_cfg = cfg.hard.model_copy(update={"colours": layers.count + 1})
        res = make_hard_stencils(
            pic, hard_cfg, min_feature_mm, bridge_min_mm, np.random.default_rng(cfg.seed)
        )
        shape = sim.composite.shape[:2]
        alphas = np.zeros((res.count, *shape))
        for i, m in enumerate(res.cut_masks):
            alphas[i] = f["spray_mask"](_nearest_resize(m, shape), sim.mm_per_px, cfg.spray)
        hard_comp = np.clip(composite(res.primer, res.colours, alphas), 0.0, 1.0)
        hard = f["score"](pic.rgb, hard_comp)
        hard_seconds = time.perf_counter() - t0

        soft_ideal = f["score"](pic.rgb, np.clip(layers.composite(), 0, 1))
        hard_ideal = f["score"](pic.rgb, render_ideal(res))
        rep = res.report
        yield {
            "bench": "quality",
            "case": name,
            "soft_de2000": round(soft["de2000_mean"], 3),
            "hard_de2000": round(hard["de2000_mean"], 3),
            "layers": int(layers.count),
            "hard_layers": int(res.count),
            "soft_de2000_p95": round(soft["de2000_p95"], 3),
            "hard_de2000_p95": round(hard["de2000_p95"], 3),
            "soft_psnr": round(soft["psnr"], 3),
            "hard_psnr": round(hard["psnr"], 3),
            "soft_ssim": round(soft["ssim"], 4),
            "hard_ssim": round(hard["ssim"], 4),
            # Without the spray: the decomposition's own composite and the flat segmentation.
            "soft_ideal_de2000": round(soft_ideal["de2000_mean"], 3),
            "hard_ideal_de2000": round(hard_ideal["de2000_mean"], 3),
            "holes": int(sum(len(d) for d in dotsets)),
            "bridges": rep["bridges"],
            "islands_bridged": rep["islands_bridged"],
            "regions_merged": rep["regions_merged"],
            "hard_warnings": len(rep["warnings"]),
            "picture_px": list(pic.shape),
            "sim_px": list(shape),
            "soft_seconds": round(soft_seconds, 3),
            "decompose_seconds": round(t_decompose, 3),
            "stipple_seconds": round(t_stipple, 3),
            "soft_simulate_seconds": round(soft_seconds - t_decompose - t_stipple, 3),
            "hard_seconds": round(hard_seconds, 3),
            "seconds": round(time.perf_counter() - t_all, 3),
        }
