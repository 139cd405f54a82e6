"""What the job does by default against the best hard stencil of the same job, per picture and process.

The must-show rows of :mod:`benchmarks.quality` without its sweeps: each picture of the quality
benchmark (:data:`benchmarks.quality.KINDS`: its kind, source and licence) on FDM (the default
config) and SLA (the bundled example's settings with SLA holes). The default is what
``stencil-cad run`` makes of that config with the picture as its image (:func:`job_default`): the
picture is saved as a PNG and the job's own steps run on it, loaded, decomposed, its plate design
chosen, stippled and refined once (the holes the plate-design trials made reused), sprayed with the
holes as the process makes them and scored by the simulate stage, S-CIELAB at 1 m and 2 m against
the source resized to the simulated grid (the manifest's ``simulate.scielab`` and ``scielab_2x``);
only the CAD, which no score reads, is left out. The hard stencil of the same job (as many colours
as layers and primer, the process's feature and bridge rules) is sprayed at each of the quality
benchmark's hard stand-offs, scored against the same reference on the same grid, and the best one
at each distance is the reference. Each row gives both scores, the ratios at 1 m and 2 m, the worst
can of the prior (``default_scielab_1m_worst``) and each layer's dose, and the spray's blur floor
(``blur_floor_1m``, ``blur_floor_2m``: :func:`blur_floor`, what the wall's blur alone costs the
default's design, dots aside); after the rows of a process,
a ``median-<process>`` row gives the median ratios. The full sweeps (holes only and windows at every
stand-off, unrefined) stay in ``python -m benchmarks quality``.

Run: ``python -m benchmarks fidelity [--case coffee-fdm] [--case grass]``.
"""

from __future__ import annotations

import statistics
import tempfile
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
    "blur_floor_1m",
    "blur_floor_2m",
    "seconds",
)


def job_default(cfg):
    """What ``stencil-cad run`` makes of ``cfg`` (its ``image``, or the bundled example).

    Returns ``(run, plan, picture, layers, holes, simulation, reference)``: ``plan`` is the job's plan
    with its design (:class:`stencil_cad.plan.plan.Plan`; its ``cfg`` is the config as the job resolved it).

    The job's own steps, in its order: the picture loaded as the job loads it, the plate sized, the
    soft plates made (:func:`stencil_cad.pipeline.run.soft_plates`: decomposed, the plate design chosen,
    stippled and refined once, the trials' holes reused) and simulated and scored by
    :func:`stencil_cad.pipeline.simulate.stage_simulate` (the holes as the process makes them). Only
    the CAD is left out, which no score reads. The run's ``figures.simulate`` holds the manifest's
    ``simulate`` section.
    """
    from stencil_cad import pipeline
    from stencil_cad.pipeline.run import computing, plan_job, soft_plates

    run_ = pipeline.Run(cfg=cfg, out=q._NullOut(), quiet=True)
    pic = pipeline.load_picture(cfg)
    size = (pic.width_mm, pic.height_mm)
    with computing(run_, pic.shape[0] * pic.shape[1]):
        plan = plan_job(run_, size, pic.shape)
        plan, layers, dotsets = soft_plates(run_, plan, pic)
        done = pipeline.stage_simulate(run_, plan, pic, layers, dotsets, keep=True)
        pipeline.record_simulate(run_, done)
        sim, ref = done.sim, done.reference
    return run_, plan, pic, layers, dotsets, sim, ref


def job_config(image: str, settings: str, folder, size: dict | None = None):
    """The config of a job on the picture ``image`` saved in ``folder``: the setting's, with that file as ``image``.

    Parsed as a user's config is (a config dumped and parsed again would give as chosen what the
    config leaves to the job: the wall's stand-off, the plate's thickness).
    """
    return q._configs(size, image=q.picture_file(image, folder))[settings]


def _default(cfg):
    """The job's own design on the picture's file: ``(scores and figures of the design, the job's state)``."""
    run_, plan, pic, layers, dotsets, sim, ref = job_default(cfg)
    seen = run_.figures.simulate
    cfg = plan.cfg
    scores = {
        # The job's own scores (the manifest's simulate.scielab and scielab_2x) at 1 m and 2 m.
        f"scielab_{q.DISTANCES_M[0]:g}m": round(float(seen.scores["scielab"]), 3),
        f"scielab_{q.DISTANCES_M[1]:g}m": round(float(seen.scores["scielab_2x"]), 3),
        "de2000": round(float(seen.scores["de2000_mean"]), 3),
        "holes": sum(map(len, dotsets)),
        "doses": [round(d.amount(cfg.spray.amount), 4) for d in dotsets],
        "by_can": {k: round(float(v), 3) for k, v in (seen.scielab_by_can or {}).items()},
        "windows": cfg.stipple.windows.value,
        "standoff_mm": cfg.standoff.design_mm,
        "thickness_mm": cfg.plate.planned_thickness_mm,
    }
    return scores, (run_, cfg, pic, layers, sim, ref)


def blur_floor(f, cfg, layers, ref, mm_per_px: float) -> dict:
    """The score of the ideal layers blurred as every hole's image is at the job's wall, with no dots.

    The decomposition's opacities (resized to the simulated grid) each blurred by the Gaussian the
    physical model gives a hole's image at the chosen stand-off (:func:`~stencil_cad.simulate.physical.spread_sigma_mm`),
    composited and scored as the default is. No plate of that wall can spray sharper than this;
    the default's score above it is what its dots cost. On the bundled example the floor at 8 mm
    (sigma 0.99 mm) scores about as the refined holes do, so there the error is the blur the dots
    need to blend, not the dots: a lower wall sharpens the floor but lets the 1 mm holes show.

    Returns:
        ``{"blur_sigma_mm", "blur_floor_1m", "blur_floor_2m"}``; empty under the paper's spray model.
    """
    from stencil_cad.simulate import blurred_composite
    from stencil_cad.simulate.physical import spread_sigma_mm

    if not cfg.spray.is_physical:
        return {}
    sigma = spread_sigma_mm(cfg.spray, cfg.standoff.design_mm)
    sprayed = blurred_composite(layers, sigma, mm_per_px)
    if sprayed.shape != ref.shape:
        raise ValueError(f"the blur floor's grid {sprayed.shape[:2]} is not the simulation's {ref.shape[:2]}")
    scores = q._scores(f, ref, sprayed, mm_per_px)
    return {"blur_sigma_mm": round(sigma, 3)} | {
        f"blur_floor_{d:g}m": scores[f"scielab_{d:g}m"] for d in q.DISTANCES_M
    }


def _row(f, pipeline, image: str, settings: str, folder, size: dict | None) -> dict:
    from stencil_cad.decompose.light import paint_of_plates

    t0 = time.perf_counter()
    cfg0 = job_config(image, settings, folder, size)
    # The rows are the job's only at the distances the job scores: the viewing distance and twice it.
    assert cfg0.view.distance_m == q.DISTANCES_M[0] and q.DISTANCES_M[1] == 2 * q.DISTANCES_M[0]
    default, (run_, job_cfg, pic, layers, sim, ref) = _default(cfg0)
    design = run_.figures.standoff
    shape, mm_per_px = sim.composite.shape[:2], sim.mm_per_px
    hard, _, res = q._hard(f, pipeline, cfg0, layers, pic, run_, ref, shape, mm_per_px)
    row = {
        "bench": "fidelity",
        "case": f"{image}-{settings}",
        "image": image,
        "kind": q.KINDS[image],
        "process": settings,
        "layers": len(set(paint_of_plates(layers.colours))),
        "plates": int(layers.count),
        "hard_layers": int(res.count),
    }
    for d in q.DISTANCES_M:
        key = f"scielab_{d:g}m"
        best = min(hard, key=lambda h, key=key: hard[h][key])
        row[f"default_{key}"] = default[key]
        row[f"hard_{key}"] = hard[best][key]
        row[f"hard_standoff_{d:g}m"] = best
        row[f"default_over_hard_{d:g}m"] = round(default[key] / hard[best][key], 3)
    row["default_scielab_1m_worst"] = max(default["by_can"].values(), default=default["scielab_1m"])
    row["default_scielab_1m_by_can"] = default["by_can"]
    row["default_de2000"] = default["de2000"]
    row["default_windows"] = default["windows"]
    row["default_standoff_mm"] = default["standoff_mm"]
    row["default_thickness_mm"] = default["thickness_mm"]
    row["default_doses"] = default["doses"]
    row["default_holes"] = default["holes"]
    row["default_reason"] = design.reason if design is not None else "nothing left to the job"
    row |= blur_floor(f, job_cfg, layers, ref, mm_per_px)
    row["hard_by_standoff"] = {f"{h:g}": v for h, v in hard.items()}
    row["seconds"] = round(time.perf_counter() - t0, 2)
    return row


def run(cases=None, size: dict | None = None):
    """One row per picture and process, then a ``median-<process>`` row per process run."""
    f = q._require()
    pipeline = f["pipeline"]
    ratios: dict[str, list[tuple[float, float]]] = {}
    with tempfile.TemporaryDirectory(prefix="fidelity-") as folder:
        for image, settings in q._select(cases):
            row = _row(f, pipeline, image, settings, folder, size)
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
