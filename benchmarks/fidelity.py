"""What the job does by default against the best hard stencil of the same job, per picture and process.

The must-show rows of :mod:`benchmarks.quality` without its sweeps: each picture of the quality
benchmark (:data:`benchmarks.quality.KINDS`: its kind, source and licence) on FDM (the default
config) and SLA (the bundled example's settings with SLA holes) is decomposed, its plate design
chosen and refined exactly as ``stencil-cad run`` does (:func:`stencil_cad.pipeline.standoff.choose_plates`,
with the thickness its wall asks for), sprayed, and scored with S-CIELAB at 1 m and 2 m against the
source resized to the simulated grid; the hard stencil of the same job (as many colours as layers
and primer, the process's feature and bridge rules) is sprayed at each of the quality benchmark's
hard stand-offs and the best one at each distance is the reference. Each row gives both scores,
the ratios at 1 m and 2 m, the worst can of the prior (``default_scielab_1m_worst``) and each
layer's dose; after the rows of a process, a ``median-<process>`` row gives the median ratios.
The full sweeps (holes only and windows at every stand-off, unrefined) stay in
``python -m benchmarks quality``: this one runs in about a third of its time.

Run: ``python -m benchmarks fidelity [--case coffee-fdm] [--case grass]``.
"""

from __future__ import annotations

import statistics
import time

from benchmarks import quality as q

#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "default_scielab_1m",
    "default_scielab_2m",
    "hard_scielab_1m",
    "hard_scielab_2m",
    "default_over_hard_1m",
    "default_over_hard_2m",
    "default_scielab_1m_worst",
    "seconds",
)


def _default(f, pipeline, cfg0, layers, pic, image: str):
    """The job's own design, refined and sprayed: ``(scores, figures of the design, simulation, reference)``."""
    from stencil_cad.pipeline.standoff import choose_plates

    size = (pic.width_mm, pic.height_mm)
    run_ = pipeline.Run(cfg=cfg0, out=q._NullOut(), quiet=True)
    cfg = choose_plates(run_, layers, size, pic)
    design = run_.figures.standoff
    run_ = pipeline.Run(cfg=cfg, out=q._NullOut(), quiet=True)
    stippled = pipeline.stage_stipple(run_, layers, size, pic)
    refined = pipeline.stage_refine(run_, layers, stippled, size, pic)
    sprays = q._sprays(pipeline, cfg, layers.colours)
    sim = f["simulate"](layers, refined, cfg.spray, geometry=q._geometry(cfg), layer_sprays=sprays)
    ref = q._source_on_grid(image, cfg, sim.composite.shape[:2], f["fit_to_size"])
    scores = {
        **q._scores(f, ref, sim.composite, sim.mm_per_px),
        "holes": sum(map(len, refined)),
        "doses": [round(d.amount(cfg.spray.amount), 4) for d in refined],
        "by_can": q._by_can(f, cfg, layers, refined, ref, sprays),
        "windows": cfg.stipple.windows.value,
        "standoff_mm": float(cfg.wall.standoff_mm[0]),
        "thickness_mm": float(cfg.plate.thickness_mm),
    }
    return scores, design, sim, ref, run_


def _row(f, pipeline, image: str, settings: str, cfg0) -> dict:
    t0 = time.perf_counter()
    pic = q._load(image, cfg0, f["fit_to_size"])
    layers = pipeline.stage_decompose(pipeline.Run(cfg=cfg0, out=q._NullOut(), quiet=True), pic)
    default, design, sim, ref, run_ = _default(f, pipeline, cfg0, layers, pic, image)
    shape, mm_per_px = sim.composite.shape[:2], sim.mm_per_px
    hard, _, res = q._hard(f, pipeline, cfg0, layers, pic, run_, ref, shape, mm_per_px)
    row = {
        "bench": "fidelity",
        "case": f"{image}-{settings}",
        "image": image,
        "kind": q.KINDS[image],
        "process": settings,
        "layers": int(layers.count),
        "hard_layers": int(res.count),
    }
    for d in q.DISTANCES_M:
        key = f"scielab_{d:g}m"
        best = min(hard, key=lambda h, key=key: hard[h][key])
        row[f"default_{key}"] = default[key]
        row[f"hard_{key}"] = hard[best][key]
        row[f"hard_standoff_{d:g}m"] = best
        row[f"default_over_hard_{d:g}m"] = round(default[key] / hard[best][key], 3)
    row["default_scielab_1m_worst"] = max(default["by_can"].values())
    row["default_scielab_1m_by_can"] = default["by_can"]
    row["default_de2000"] = default["de2000"]
    row["default_windows"] = default["windows"]
    row["default_standoff_mm"] = default["standoff_mm"]
    row["default_thickness_mm"] = default["thickness_mm"]
    row["default_doses"] = default["doses"]
    row["default_holes"] = default["holes"]
    row["default_reason"] = design.reason if design is not None else "nothing left to the job"
    row["hard_by_standoff"] = {f"{h:g}": v for h, v in hard.items()}
    row["seconds"] = round(time.perf_counter() - t0, 2)
    return row


def run(cases=None, size: dict | None = None):
    """One row per picture and process, then a ``median-<process>`` row per process run."""
    f = q._require()
    pipeline = f["pipeline"]
    configs = q._configs(size)
    ratios: dict[str, list[tuple[float, float]]] = {}
    for image, settings in q._select(cases):
        row = _row(f, pipeline, image, settings, configs[settings])
        ratios.setdefault(settings, []).append((row["default_over_hard_1m"], row["default_over_hard_2m"]))
        yield row
    for settings, got in ratios.items():
        if len(got) > 1:
            yield {
                "bench": "fidelity",
                "case": f"median-{settings}",
                "pictures": len(got),
                "median_over_hard_1m": round(statistics.median(r for r, _ in got), 3),
                "median_over_hard_2m": round(statistics.median(r for _, r in got), 3),
                "worst_over_hard_1m": max(r for r, _ in got),
                "worst_over_hard_2m": max(r for _, r in got),
                "seconds": 0.0,
            }


def smoke():
    """The generated logo at 40 mm with the example's SLA settings: the design, the refined holes, the hard stencil."""
    yield from run(["logo-sla"], size={"width_mm": 40.0})
