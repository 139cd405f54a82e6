"""Soft vs hard stencils: mean CIEDE2000 of the simulated spray against the input.

The comparison the paper makes: on scikit-image's astronaut, coffee and chelsea,
with the same number of paint layers, the soft pipeline (decompose, stipple,
simulate) and the hard one (flat-colour segmentation + bridged cut-outs, sprayed
with the same spray model) are scored against the same reference on the same grid,
both measured in the same run, whatever the numbers show.

Each image is run under two settings, applied to BOTH modes (the same process, hence
the same minimum feature and bridge width, and the same spray config):

* ``fdm-linear``: the default job config: FDM holes (1 mm minimum radius, 0.8 mm web),
  the paper's linear tone, nozzle height 7.
* ``sla-calibrated``: the ``stipple`` and ``spray`` sections of the bundled example job
  (``stencil_cad/data/example.yaml``: SLA holes, calibrated tone, nozzle height 15,
  a spray time chosen per layer). The spray-time choice only exists for stippled
  layers; hard cut-outs are sprayed at ``spray.spray_time`` as the hard pipeline does.
* ``sla-calibrated-h7``: the same at nozzle height 7, where hard stencils keep sharper edges.

Case names are ``<image>-<settings>``; ``--case astronaut`` runs every setting of one image.
The soft side runs the pipeline's own stage functions (:func:`stencil_cad.pipeline.stage_decompose`,
:func:`~stencil_cad.pipeline.stage_stipple`) with an output that writes nothing; the
hard side calls the same functions as ``pipeline.run_hard`` without the CAD.

Run: ``python -m benchmarks quality [--case coffee] [--case chelsea-sla-calibrated]``.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

import numpy as np

IMAGES = ("astronaut", "coffee", "chelsea")
SETTINGS = ("fdm-linear", "sla-calibrated", "sla-calibrated-h7")
CASES = tuple(f"{image}-{s}" for image in IMAGES for s in SETTINGS)


def _require() -> dict:
    """The stages the benchmark needs, or a clear error naming the missing ones."""
    wanted = {
        "pipeline": ("stencil_cad.pipeline", None),
        "simulate": ("stencil_cad.simulate", "simulate"),
        "spray_mask": ("stencil_cad.simulate", "spray_mask"),
        "score": ("stencil_cad.simulate", "score"),
        "fit_to_size": ("stencil_cad.imaging", "fit_to_size"),
        "make_hard_stencils": ("stencil_cad.hardstencil", "make_hard_stencils"),
        "simulate_hard": ("stencil_cad.hardstencil", "simulate_hard"),
        "render_ideal": ("stencil_cad.hardstencil", "render_ideal"),
    }
    found, missing = {}, []
    for key, (mod, name) in wanted.items():
        try:
            module = importlib.import_module(mod)
            found[key] = module if name is None else getattr(module, name)
        except (ImportError, AttributeError) as exc:
            missing.append(f"{mod}{'.' + name if name else ''} ({exc})")
    if missing:
        raise RuntimeError(
            "the quality benchmark needs the soft pipeline, the hard stencils and the simulator; missing: "
            + "; ".join(missing)
            + ". No numbers are reported without them."
        )
    return found


class _NullOut:
    """An output folder that writes nothing, so the pipeline's stage functions run as in a job."""

    def __getattr__(self, name):
        def discard(*args, **kwargs) -> None:
            return None

        return discard


def _configs() -> dict:
    """The job config of each setting, validated like a user's config."""
    import yaml

    from stencil_cad.config.io import parse_config

    example = yaml.safe_load(
        (Path(__file__).resolve().parents[1] / "stencil_cad/data/example.yaml").read_text()
    )
    return {
        # The defaults, spelled out so the case name stays true if a default changes.
        "fdm-linear": parse_config(
            {"stipple": {"process": "fdm", "tone": "linear"}, "spray": {"nozzle_height": 7.0}},
            source="quality fdm-linear",
        ),
        "sla-calibrated": parse_config(
            {"stipple": dict(example["stipple"]), "spray": dict(example["spray"])},
            source="quality sla-calibrated (stencil_cad/data/example.yaml)",
        ),
        # The nozzle height decides the comparison: the example's h = 15 blends the dots but
        # blurs the hard cut-outs' edges, so this case sprays both from h = 7.
        "sla-calibrated-h7": parse_config(
            {"stipple": dict(example["stipple"]), "spray": {**example["spray"], "nozzle_height": 7.0}},
            source="quality sla-calibrated-h7",
        ),
    }


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


def _select(cases) -> list[tuple[str, str]]:
    """(image, settings) pairs for ``cases``: full case names or image names (both settings)."""
    if not cases:
        return [(i, s) for i in IMAGES for s in SETTINGS]
    unknown = [c for c in cases if c not in CASES and c not in IMAGES]
    if unknown:
        raise ValueError(
            f"unknown quality case(s) {unknown}; choose from {list(CASES)} or an image name {list(IMAGES)}"
        )
    return [(i, s) for i in IMAGES for s in SETTINGS if f"{i}-{s}" in cases or i in cases]


def _settings_fields(cfg) -> dict:
    st, sp = cfg.stipple, cfg.spray
    return {
        "process": st.process.value,
        "tone": st.tone.value,
        "nozzle_height": sp.nozzle_height,
        "calibrate": sp.calibrate.value if st.tone.value == "calibrated" else "n/a (linear tone)",
        "spray_time": sp.spray_time,
        "hole_min_r_mm": st.resolved_hole_min_r_mm,
        "web_mm": st.resolved_web_mm,
    }


def run(cases=None):
    """Yield one dict per image and settings: soft and hard mean CIEDE2000 and their details."""
    from stencil_cad.model import composite

    f = _require()
    pipeline = f["pipeline"]
    pairs = _select(cases)
    configs = _configs()
    for image in dict.fromkeys(i for i, _ in pairs):
        # The decomposition depends only on the picture, the decompose section and the seed,
        # which both settings share: decompose once per image.
        base = configs[SETTINGS[0]]
        pic = _load(image, base, f["fit_to_size"])
        t0 = time.perf_counter()
        layers = pipeline.stage_decompose(pipeline.Run(cfg=base, out=_NullOut(), quiet=True), pic)
        t_decompose = time.perf_counter() - t0
        soft_ideal = f["score"](pic.rgb, np.clip(layers.composite(), 0, 1))
        for settings in [s for i, s in pairs if i == image]:
            cfg = configs[settings]
            assert cfg.decompose == base.decompose and cfg.seed == base.seed and cfg.size == base.size
            run_ = pipeline.Run(cfg=cfg, out=_NullOut(), quiet=True)
            size = (pic.width_mm, pic.height_mm)

            t0 = time.perf_counter()
            dotsets = pipeline.stage_stipple(run_, layers, size)
            t_stipple = time.perf_counter() - t0
            sim = f["simulate"](layers, dotsets, cfg.spray)
            soft = f["score"](pic.rgb, sim.composite)
            t_soft_sim = time.perf_counter() - t0 - t_stipple

            t0 = time.perf_counter()
            rules = pipeline._process_rules(cfg)
            hard_cfg = cfg.hard.model_copy(update={"colours": layers.count + 1})
            res = f["make_hard_stencils"](
                pic, hard_cfg, rules["min_feature_mm"], rules["bridge_min_mm"], run_.rng_for("hard")
            )
            t_segment = time.perf_counter() - t0
            # Sprayed on the soft simulation's grid, so both are scored on the same pixels.
            shape = sim.composite.shape[:2]
            alphas = np.zeros((res.count, *shape))
            for k, m in enumerate(res.cut_masks):
                alphas[k] = f["spray_mask"](_nearest_resize(m, shape), sim.mm_per_px, cfg.spray)
            hard_comp = np.clip(composite(res.primer, res.colours, alphas), 0.0, 1.0)
            hard = f["score"](pic.rgb, hard_comp)
            t_hard = time.perf_counter() - t0
            # What `stencil-cad hard` itself reports: sprayed and scored on the picture grid.
            _, pipe_comp = f["simulate_hard"](res, cfg.spray)
            hard_pipeline = f["score"](pic.rgb, pipe_comp)
            hard_ideal = f["score"](pic.rgb, f["render_ideal"](res))

            rep = res.report
            yield {
                "bench": "quality",
                "case": f"{image}-{settings}",
                "image": image,
                "settings": {"name": settings, **_settings_fields(cfg)},
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
                "hard_pipeline_de2000": round(hard_pipeline["de2000_mean"], 3),
                "holes": int(sum(len(d) for d in dotsets)),
                "soft_spray_times": [round(float(d.report["spray_time"]), 4) for d in dotsets],
                "hard_min_feature_mm": rules["min_feature_mm"],
                "hard_bridge_min_mm": rules["bridge_min_mm"],
                "bridges": rep["bridges"],
                "islands_bridged": rep["islands_bridged"],
                "regions_merged": rep["regions_merged"],
                "hard_warnings": len(rep["warnings"]),
                "picture_px": list(pic.shape),
                "sim_px": list(shape),
                # Shared by the image's cases (decomposed once), not counted in `seconds`.
                "decompose_seconds": round(t_decompose, 3),
                "stipple_seconds": round(t_stipple, 3),
                "soft_simulate_seconds": round(t_soft_sim, 3),
                "hard_segment_seconds": round(t_segment, 3),
                "hard_seconds": round(t_hard, 3),
                "seconds": round(t_stipple + t_soft_sim + t_hard, 3),
            }
