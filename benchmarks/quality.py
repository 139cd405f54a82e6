"""Soft vs hard stencils, as a viewer sees them: S-CIELAB at 1 m and 2 m, and pixel CIEDE2000.

The comparison the paper makes, scored the way a viewer sees it: on twelve pictures of the
kinds a maker brings (:data:`KINDS` names each, its source and licence: skin, photos, a large
dark background, high-key, fine texture, line art and text, low contrast, saturated graphics,
flat-colour art), with the same number of paint layers, the soft pipeline (decompose, stipple,
refine, simulate) and the hard one (flat-colour segmentation + bridged cut-outs, sprayed
with the same spray model) are scored against the same reference on the same grid, both
measured in the same run, whatever the numbers show.

Each image runs under two process settings, applied to BOTH modes (the same minimum
feature and bridge width, the same spray model):

* ``fdm``: the default job config (FDM holes, r >= 0.5 mm, web 0.6 mm, and the defaults of
  tone, refinement and spray time);
* ``sla``: the ``stipple`` and ``spray`` sections of the bundled example job
  (``stencil_cad/data/example.yaml``: calibrated tone, a spray time per layer) with SLA holes
  (r >= 0.5 mm, web 0.5 mm).

Each mode is sprayed at every nozzle height of :data:`SOFT_HEIGHTS` / :data:`HARD_HEIGHTS` and reported at the
one that scores best (lowest S-CIELAB at 1 m): the soft stencil's dots blend better from
high up, the hard cut-outs' edges stay sharper from low down. ``soft_*`` is the shipped
pipeline (refinement on), ``soft_norefine_*`` the same without the refinement (at its
own best height), so the refinement's gain and cost (``refine_seconds`` beside
``stipple_seconds``) are measured in the same run.

Two pictures are generated here: ``dark_sky`` (black, with small bright sources of several sizes
and colours) and ``logo`` (flat colours). Each row reports ``soft_*`` (holes only,
``stipple.windows: off``, at its best stand-off of the sweep), ``hybrid_*`` (windows where a layer is
solid, at its best of the stand-offs the job tried them at), ``default_*`` (what the job does by
default: the plate design it chooses for the picture, windows on or off and the stand-off, refined;
``default_trials`` and ``default_reason`` say how: see ``stencil_cad.pipeline.standoff``), ``hard_*``,
``default_over_hard_1m`` (the issue's must-show, on the default product), ``best_over_hard_1m`` (the
better of the soft and hybrid sweeps over hard, at 1 m) and ``floor_*`` (the decomposition's own
layers composited ideally: what no stencil can beat).

Each setting decomposes the picture itself, as its job would: the start is chosen by what that
setting's plates can spray.

Case names are ``<image>-<settings>``; ``--case astronaut`` runs both settings of one image.
The soft side runs the pipeline's own stage functions with an output that writes nothing;
the hard side calls the same functions as ``pipeline.run.run_hard`` without the CAD.

Run: ``python -m benchmarks quality [--case coffee] [--case chelsea-sla]``.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

import numpy as np

IMAGES = (
    "astronaut",
    "coffee",
    "chelsea",
    "rocket",
    "dark_sky",
    "logo",
    "hubble_deep_field",
    "immunohistochemistry",
    "grass",
    "text",
    "low_contrast",
    "saturated",
)
#: Pictures made by code here (no download): see :func:`dark_sky`, :func:`logo`, :func:`low_contrast`
#: and :func:`saturated`.
GENERATED = ("dark_sky", "logo", "low_contrast", "saturated")
#: What each picture stands for, and its source and licence (every one ships with scikit-image's
#: wheel or is made here; none is downloaded).
KINDS = {
    "astronaut": "skin, a portrait (NASA, public domain)",
    "coffee": "a photo, warm tones (Rachel Michetti, CC0)",
    "chelsea": "fur, fine texture (Stefan van der Walt, CC0)",
    "rocket": "large flat sky and fine structure (NASA, public domain)",
    "dark_sky": "black with small bright sources (made here)",
    "logo": "flat-colour art (made here)",
    "hubble_deep_field": "a photo with a large dark background (NASA / ESA, public domain)",
    "immunohistochemistry": "high-key: light ground, small stained detail (public domain)",
    "grass": "fine texture, grey (CC0)",
    "text": "line art and text, grey (public domain)",
    "low_contrast": "low contrast: chelsea at 35 % of its contrast (made here from a CC0 photo)",
    "saturated": "saturated graphics: hue gradients and shapes at full chroma (made here)",
}
SETTINGS = ("fdm", "sla")
#: Nozzle heights h each mode is sprayed at; each reports its best. Soft stencils only gain
#: from higher nozzles (their dots blend), hard ones from lower (their edges stay sharp), so
#: the soft side skips the low ones, where every stipple and refinement would run once more:
#: 30 is every process's default (spray.nozzle_height), 22 where chelsea scores best, 60 where rocket does.
SOFT_HEIGHTS = (22.0, 30.0, 60.0)
HARD_HEIGHTS = (3.0, 5.0, 7.0, 15.0)
#: Under the physical spray model (the default) the height swept is the wall's stand-off in mm
#: (wall.standoff_mm), which sets every hole's blur: soft stencils at 10 (SLA and laser's default,
#: where the example scores best: 6.66 / 6.42 / 6.51 at 8 / 10 / 12 mm), 15 and 20 mm (FDM's
#: larger holes want more blur), hard ones from 1 mm (a cut stencil held almost flat) up.
SOFT_STANDOFFS = (10.0, 15.0, 20.0)
HARD_STANDOFFS = (1.0, 3.0, 10.0)
#: Viewing distances of the scores, m.
DISTANCES_M = (1.0, 2.0)
CASES = tuple(f"{image}-{s}" for image in IMAGES for s in SETTINGS)
#: The paper's spray model with the SLA settings: run only when named (``--case astronaut-sla-paper``).
PAPER_CASES = tuple(f"{image}-sla-paper" for image in IMAGES)


def _require() -> dict:
    """The stages the benchmark needs, or a clear error naming the missing ones."""
    wanted = {
        "pipeline": ("stencil_cad.pipeline", None),
        "simulate": ("stencil_cad.simulate", "simulate"),
        "spray_mask": ("stencil_cad.simulate", "spray_mask"),
        "score": ("stencil_cad.simulate", "score"),
        "resample": ("stencil_cad.simulate", "resample"),
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


def _configs(size: dict | None = None, image: Path | None = None) -> dict:
    """The job config of each setting, validated like a user's config.

    ``size``: another picture size; ``image``: the picture's file (the config's ``image``).
    """
    import yaml

    from stencil_cad.config.io import parse_config

    example = yaml.safe_load(
        (Path(__file__).resolve().parents[1] / "stencil_cad/data/example.yaml").read_text()
    )
    sized = {"size": size} if size else {}
    if image is not None:
        sized["image"] = str(image)
    return {
        "fdm": parse_config({**sized}, source="quality fdm (defaults)"),
        "sla": parse_config(
            {"stipple": {**example["stipple"], "process": "sla"}, "spray": dict(example["spray"]), **sized},
            source="quality sla (stencil_cad/data/example.yaml)",
        ),
        "sla-paper": parse_config(
            {
                "stipple": {**example["stipple"], "process": "sla"},
                "spray": {**example["spray"], "model": "paper"},
                **sized,
            },
            source="quality sla-paper (the example's settings, the paper's spray model)",
        ),
    }


def _heights(cfg, hard: bool) -> tuple[float, ...]:
    """Stand-offs (physical model) or nozzle heights (paper model) a mode is sprayed at."""
    if cfg.spray.is_physical:
        return HARD_STANDOFFS if hard else SOFT_STANDOFFS
    return HARD_HEIGHTS if hard else SOFT_HEIGHTS


def _at_height(cfg, h: float, refine: bool, windows: str = "off"):
    from stencil_cad.config.io import parse_config

    data = cfg.model_dump(mode="json")
    data["stipple"]["windows"] = windows
    if cfg.spray.is_physical:
        data["wall"]["standoff_mm"] = [h]
    else:
        data["spray"]["nozzle_height"] = h
    data["refine"]["enabled"] = refine
    return parse_config(data, source=f"quality h={h}")


def _geometry(cfg):
    """The spray geometry the physical model needs (None for the paper's)."""
    from stencil_cad.simulate.physical import SprayGeometry

    return SprayGeometry.of_job(cfg) if cfg.spray.is_physical else None


def _sprays(pipeline, cfg, colours) -> list:
    """Each layer's spray settings as the job's stages take them (its paint's profile and deposit prior)."""
    from stencil_cad.plan.profiles import layer_sprays

    return layer_sprays(cfg, colours)[0]


def _by_can(f, cfg, layers, dotsets, ref, sprays) -> dict:
    """S-CIELAB at 1 m of the same holes sprayed with each can of the prior (nominal first)."""
    from stencil_cad.simulate.cans import layer_can_prior
    from stencil_cad.simulate.scielab import scielab

    out = {}
    for name, per_layer in layer_can_prior(sprays):
        sim = f["simulate"](layers, dotsets, cfg.spray, geometry=_geometry(cfg), layer_sprays=per_layer)
        out[name] = round(scielab(ref, sim.composite, sim.mm_per_px, DISTANCES_M[0]), 3)
    return out


def dark_sky(size: int = 512) -> np.ndarray:
    """A night sky: near-black with bright sources of several sizes and colours, ``(size, size, 3)`` in [0, 1]."""
    rng = np.random.default_rng(34)
    rgb = np.full((size, size, 3), 0.02)
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64)
    colours = np.array(
        [[1.0, 1.0, 1.0], [1.0, 0.85, 0.45], [0.55, 0.7, 1.0], [1.0, 0.4, 0.3], [0.6, 1.0, 0.7]]
    )
    # Many pin-points, fewer mid-sized stars, a few large glows (a moon, a planet, a nebula core).
    for count, (lo, hi) in ((60, (1.0, 2.5)), (14, (3.0, 7.0)), (3, (12.0, 28.0))):
        for _ in range(count):
            cy, cx = rng.uniform(0, size, 2)
            rad = rng.uniform(lo, hi)
            c = colours[rng.integers(len(colours))]
            d2 = (yy - cy) ** 2 + (xx - cx) ** 2
            glow = np.exp(-d2 / (2.0 * (0.6 * rad) ** 2))
            disc = np.clip(rad - np.sqrt(d2) + 0.5, 0.0, 1.0)
            a = np.maximum(disc, 0.7 * glow)[..., None]
            rgb = rgb * (1.0 - a) + a * c
    return np.clip(rgb, 0.0, 1.0)


def logo(size: int = 512) -> np.ndarray:
    """A flat-colour logo on white: a ring, a bar, a triangle and a square, ``(size, size, 3)`` in [0, 1]."""
    rgb = np.ones((size, size, 3))
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64) / size
    rho = np.hypot(yy - 0.4, xx - 0.4)
    rgb[(rho < 0.3) & (rho > 0.18)] = (0.85, 0.1, 0.12)  # red ring
    rgb[(yy > 0.75) & (yy < 0.88) & (xx > 0.08) & (xx < 0.92)] = (0.05, 0.2, 0.6)  # blue bar
    tri = (
        (yy > 0.1)
        & (yy < 0.6)
        & (xx > 0.6 + 0.3 * (0.6 - yy) / 0.5 * 0.5)
        & (xx < 0.95 - 0.3 * (0.6 - yy) / 0.5 * 0.5)
    )
    rgb[tri] = (0.98, 0.78, 0.1)  # yellow triangle
    rgb[(np.abs(yy - 0.4) < 0.06) & (np.abs(xx - 0.4) < 0.06)] = (
        0.08,
        0.08,
        0.08,
    )  # black square in the ring
    return rgb


def low_contrast() -> np.ndarray:
    """Chelsea at 35 % of its contrast about its mean colour, ``(H, W, 3)`` in [0, 1]."""
    from skimage import data

    rgb = data.chelsea().astype(np.float64) / 255.0
    return np.clip(rgb.mean(axis=(0, 1)) + 0.35 * (rgb - rgb.mean(axis=(0, 1))), 0.0, 1.0)


def saturated(size: int = 512) -> np.ndarray:
    """Saturated graphics: a full-chroma hue sweep behind a magenta disc, a cyan bar and a green ring."""
    from skimage.color import hsv2rgb

    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64) / size
    hsv = np.stack([xx, np.full_like(xx, 1.0), 0.6 + 0.4 * yy], axis=-1)
    rgb = hsv2rgb(hsv)
    rgb[np.hypot(yy - 0.35, xx - 0.3) < 0.18] = (0.9, 0.0, 0.75)
    rgb[(yy > 0.7) & (yy < 0.8) & (xx > 0.1) & (xx < 0.9)] = (0.0, 0.8, 0.9)
    rho = np.hypot(yy - 0.4, xx - 0.72)
    rgb[(rho > 0.12) & (rho < 0.18)] = (0.1, 0.75, 0.1)
    return np.clip(rgb, 0.0, 1.0)


def _picture_rgb(name: str) -> np.ndarray:
    """The picture ``name``: one of scikit-image's photos, or one generated here (grey ones as RGB)."""
    if name in GENERATED:
        return {"dark_sky": dark_sky, "logo": logo, "low_contrast": low_contrast, "saturated": saturated}[
            name
        ]()
    from skimage import data

    img = getattr(data, name)()
    if img.ndim == 2:
        img = np.stack([img] * 3, axis=-1)
    return img[..., :3].astype(np.float64) / 255.0


def picture_file(name: str, folder: Path) -> Path:
    """The picture ``name`` saved as a PNG in ``folder``, as a maker would hand it to ``--image``.

    A photo of scikit-image is saved with its own pixels (a grey one with one channel, as its file
    has), a generated one as 8-bit RGB.
    """
    from PIL import Image

    path = Path(folder) / f"{name}.png"
    if name in GENERATED:
        pixels = np.round(np.clip(_picture_rgb(name), 0.0, 1.0) * 255.0).astype(np.uint8)
    else:
        from skimage import data

        pixels = np.asarray(getattr(data, name)())
        pixels = pixels if pixels.ndim == 2 else pixels[..., :3]
    Image.fromarray(pixels).save(path)
    return path


def _source_on_grid(name: str, cfg, shape, fit_to_size) -> np.ndarray:
    """The source photo resized to the simulated grid: the reference every score is taken against."""
    from skimage.transform import resize

    rgb = _picture_rgb(name)
    px = shape[1] / cfg.size.width_mm
    rgb, _, _, _ = fit_to_size(rgb, None, cfg.size.width_mm, cfg.size.height_mm, px, max_upscale=np.inf)
    if rgb.shape[:2] != tuple(shape):
        rgb = resize(rgb, (*shape, 3), order=1, anti_aliasing=True)
    return np.clip(rgb, 0.0, 1.0)


def _nearest_resize(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resampling of a bool raster (pixel centres mapped, no blur)."""
    h, w = mask.shape
    rows = np.minimum(((np.arange(shape[0]) + 0.5) * h / shape[0]).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(shape[1]) + 0.5) * w / shape[1]).astype(np.int64), w - 1)
    return mask[rows][:, cols]


def _load(name: str, cfg, fit_to_size):
    from stencil_cad.model import Picture

    rgb = _picture_rgb(name)
    rgb, alpha, mm_per_px, _ = fit_to_size(
        rgb, None, cfg.size.width_mm, cfg.size.height_mm, cfg.size.px_per_mm
    )
    return Picture(
        rgb=rgb,
        mm_per_px=mm_per_px,
        alpha=alpha,
        source=name if name in GENERATED else f"skimage.data.{name}",
    )


def _select(cases) -> list[tuple[str, str]]:
    """(image, settings) pairs for ``cases``: full case names or image names (both settings)."""
    if not cases:
        return [(i, s) for i in IMAGES for s in SETTINGS]
    unknown = [c for c in cases if c not in CASES + PAPER_CASES and c not in IMAGES]
    if unknown:
        raise ValueError(
            f"unknown quality case(s) {unknown}; choose from {list(CASES + PAPER_CASES)} or an image name "
            f"{list(IMAGES)}"
        )
    pairs = [(i, s) for i in IMAGES for s in SETTINGS if f"{i}-{s}" in cases or i in cases]
    return pairs + [(i, "sla-paper") for i in IMAGES if f"{i}-sla-paper" in cases]


def _settings_fields(cfg) -> dict:
    st, sp = cfg.stipple, cfg.spray
    return {
        "process": st.process.value,
        "tone": st.tone.value,
        "calibrate": sp.calibrate.value if st.tone.value == "response" else "n/a (linear tone)",
        "spray_model": sp.model.value,
        "spray_time": sp.spray_time,
        "hole_min_r_mm": st.hole_floor_mm,
        "web_mm": st.sizes.web_mm,
        "refine_iterations": cfg.refine.iterations,
    }


def _scores(f, ref, rgb, mm_per_px) -> dict:
    from stencil_cad.simulate.scielab import scielab

    out = {"de2000": round(f["score"](ref, rgb)["de2000_mean"], 3)}
    for d in DISTANCES_M:
        out[f"scielab_{d:g}m"] = round(scielab(ref, rgb, mm_per_px, d), 3)
    return out


def _best(by_height: dict) -> tuple[float, dict]:
    key = f"scielab_{DISTANCES_M[0]:g}m"
    h = min(by_height, key=lambda k: by_height[k][key])
    return h, by_height[h]


def _job_choice(pipeline, cfg0, layers, pic):
    """The plate design a job with these settings chooses for the picture: ``(windows, height, figures)``.

    Under the physical model the height is the wall's stand-off (left to the job,
    ``wall.standoff_mm: null``), under the paper's the nozzle height the settings give.
    """
    from stencil_cad.pipeline.standoff import stage_standoff
    from stencil_cad.plan.plan import capped, painted, whole

    run_ = pipeline.Run(cfg=cfg0, out=_NullOut(), quiet=True)
    plan = painted(capped(whole(cfg0, (pic.width_mm, pic.height_mm))), layers.colours)
    done = stage_standoff(run_, plan, layers, pic)
    cfg = done.plan.cfg
    h = cfg.standoff.design_mm if cfg.spray.is_physical else float(cfg.spray.nozzle_height)
    return cfg.stipple.windows.value, h, done.figures


def _soft(f, pipeline, cfg0, layers, pic, image: str, windows: str, by_can: bool = True, heights=None):
    """The soft stencil at each stand-off: ``(refined, stippled, timing, last simulation, reference, run)``."""
    from stencil_cad.plan import holes
    from stencil_cad.plan.plan import capped, painted, whole
    from stencil_cad.plan.refinement import refine_holes

    size = (pic.width_mm, pic.height_mm)
    soft, plain, timing = {}, {}, {}
    for h in heights or _heights(cfg0, hard=False):
        cfg = _at_height(cfg0, h, refine=False, windows=windows)
        run_ = pipeline.Run(cfg=cfg, out=_NullOut(), quiet=True)
        t0 = time.perf_counter()
        plan = painted(capped(whole(cfg, size)), layers.colours)
        stippled = holes.refined(run_, plan, layers, holes.stippled(run_, plan, layers)[0], pic)[0].sets
        t_stipple = time.perf_counter() - t0
        run_r = pipeline.Run(
            cfg=_at_height(cfg0, h, refine=True, windows=windows), out=_NullOut(), quiet=True
        )
        t0 = time.perf_counter()
        refined = refine_holes(run_r, painted(whole(run_r.cfg, size), layers.colours), layers, stippled, pic)[
            0
        ]
        t_refine = time.perf_counter() - t0
        # Every layer sprays as the job sprays it: its paint's deposit prior (or measured profile).
        sprays = _sprays(pipeline, cfg, layers.colours)
        sim0 = f["simulate"](layers, stippled, cfg.spray, geometry=_geometry(cfg), layer_sprays=sprays)
        sim1 = f["simulate"](layers, refined, cfg.spray, geometry=_geometry(cfg), layer_sprays=sprays)
        ref = _source_on_grid(image, cfg, sim1.composite.shape[:2], f["fit_to_size"])
        plain[h] = {
            **_scores(f, ref, sim0.composite, sim0.mm_per_px),
            "holes": sum(map(len, stippled)),
        }
        soft[h] = {
            **_scores(f, ref, sim1.composite, sim1.mm_per_px),
            "holes": sum(map(len, refined)),
            "layer_tone_rmse_stippled": sim0.info["layer_tone_rmse"],
            "layer_tone_rmse_refined": sim1.info["layer_tone_rmse"],
            "spray_times": [round(d.amount(cfg.spray.amount), 4) for d in refined],
            "scielab_1m_by_can": _by_can(f, cfg, layers, refined, ref, sprays) if by_can else {},
            "windows": [len(d.windows) for d in refined],
        }
        timing[h] = {"stipple_seconds": round(t_stipple, 3), "refine_seconds": round(t_refine, 3)}
    return soft, plain, timing, sim1, ref, run_


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "soft_scielab_1m",
    "hybrid_scielab_1m",
    "default_scielab_1m",
    "hard_scielab_1m",
    "floor_scielab_1m",
    "default_over_hard_1m",
    "best_over_hard_1m",
    "default_trials",
    "seconds",
)


def smoke():
    """The generated logo at 40 mm with the example's SLA settings: every sweep, the hard stencil, the floor."""
    yield from run(["logo-sla"], size={"width_mm": 40.0})


def _hard(f, pipeline, cfg0, layers, pic, run_, ref, shape, mm_per_px):
    """The best hard stencil of the same job at each stand-off: ``(scores by height, seconds, stencils)``.

    As many colours as the soft job's paints and primer (with light plates, two of the soft job's
    plates share a paint: the maker buys the same cans for both), the process's feature and bridge
    rules, each cut-out sprayed (full cover of its paint) on the soft simulation's grid, so both are
    scored on the same pixels.
    """
    from stencil_cad.decompose.light import paint_of_plates
    from stencil_cad.model import composite
    from stencil_cad.pipeline.hard import process_rules

    t0 = time.perf_counter()
    rules = process_rules(cfg0)
    paints = len(set(paint_of_plates(layers.colours)))
    hard_cfg = cfg0.hard.model_copy(update={"colours": paints + 1})
    res = f["make_hard_stencils"](
        pic, hard_cfg, rules["min_feature_mm"], rules["bridge_min_mm"], run_.rng_for("hard")
    )
    t_segment = time.perf_counter() - t0
    hard = {}
    for h in _heights(cfg0, hard=True):
        hcfg = _at_height(cfg0, h, refine=False)
        alphas = np.zeros((res.count, *shape))
        for k, (m, sp) in enumerate(zip(res.cut_masks, _sprays(pipeline, hcfg, res.colours), strict=True)):
            alphas[k] = f["spray_mask"](
                _nearest_resize(m, shape),
                mm_per_px,
                sp,
                geometry=_geometry(hcfg),
                # As pipeline.run.run_hard sprays them: full cover (of each paint) under the physical model.
                spray_time=float(sp.full_cover_passes()) if sp.is_physical else None,
            )
        hard_comp = np.clip(composite(res.primer, res.colours, alphas), 0.0, 1.0)
        hard[h] = _scores(f, ref, hard_comp, mm_per_px)
    return hard, t_segment, res


def run(cases=None, size: dict | None = None):
    """Yield one dict per image and settings: soft and hard scores at each mode's best nozzle height."""
    f = _require()
    pipeline = f["pipeline"]
    pairs = _select(cases)
    configs = _configs(size)
    for image in dict.fromkeys(i for i, _ in pairs):
        for settings in [s for i, s in pairs if i == image]:
            # Decomposed as the job would: the start is chosen by what this setting's plates spray.
            cfg0 = configs[settings]
            pic = _load(image, cfg0, f["fit_to_size"])
            t0 = time.perf_counter()
            from stencil_cad.decompose.light import paint_of_plates
            from stencil_cad.pipeline.decompose import plates_of

            run0 = pipeline.Run(cfg=cfg0, out=_NullOut(), quiet=True)
            # The plates a one-plate job stipples (two per paint with light plates).
            from stencil_cad.plan.plan import primed, whole

            plan0 = primed(whole(cfg0, (pic.width_mm, pic.height_mm)), pic)
            layers = plates_of(plan0, pipeline.stage_decompose(run0, plan0, pic).layers)
            t_decompose = time.perf_counter() - t0
            soft, plain, timing, sim1, ref, run_ = _soft(f, pipeline, cfg0, layers, pic, image, "off")
            # What the job does by default: the plate design it chooses for the picture (windows on
            # or off, the stand-off), refined. The hybrid plates (windows on) run at every stand-off
            # the job tried them at; the default is one of the two sweeps' runs.
            chosen_windows, chosen, design = _job_choice(pipeline, cfg0, layers, pic)
            trials = design.trials if design is not None and cfg0.spray.is_physical else ()
            hybrid_heights = sorted({t.standoff_mm for t in trials if t.windows == "auto"})
            if chosen_windows == "auto" and chosen not in hybrid_heights:
                hybrid_heights.append(chosen)
            hybrid, _, htiming, _, _, _ = _soft(
                f,
                pipeline,
                cfg0,
                layers,
                pic,
                image,
                "auto",
                by_can=False,
                heights=tuple(hybrid_heights) or None,
            )
            if chosen_windows == "off" and chosen not in soft:
                extra, _, _, _, _, _ = _soft(
                    f, pipeline, cfg0, layers, pic, image, "off", by_can=False, heights=(chosen,)
                )
                soft_default = extra[chosen]
            else:
                soft_default = soft.get(chosen)
            default = hybrid[chosen] if chosen_windows == "auto" else soft_default
            shape = sim1.composite.shape[:2]
            mm_per_px = sim1.mm_per_px

            hard, t_segment, res = _hard(f, pipeline, cfg0, layers, pic, run_, ref, shape, mm_per_px)

            hy, best_hybrid = _best(hybrid)
            floor_rgb = np.clip(f["resample"](layers.composite(), shape), 0.0, 1.0)
            floor = _scores(f, ref, floor_rgb, mm_per_px)
            hs, best_soft = _best(soft)
            hp, best_plain = _best(plain)
            hh, best_hard = _best(hard)
            row = {
                "bench": "quality",
                "case": f"{image}-{settings}",
                "image": image,
                "kind": KINDS[image],
                "settings": {"name": settings, **_settings_fields(cfg0)},
                "layers": len(set(paint_of_plates(layers.colours))),
                "plates": int(layers.count),
                "hard_layers": int(res.count),
                "soft_nozzle_height": hs,
                "hard_nozzle_height": hh,
                "soft_norefine_nozzle_height": hp,
            }
            for prefix, best in (("soft", best_soft), ("hard", best_hard), ("soft_norefine", best_plain)):
                for key in ("scielab_1m", "scielab_2m", "de2000"):
                    row[f"{prefix}_{key}"] = best[key]
            for key in ("scielab_1m", "scielab_2m", "de2000"):
                row[f"hybrid_{key}"] = best_hybrid[key]
                row[f"floor_{key}"] = floor[key]
            row["hybrid_nozzle_height"] = hy
            row["hybrid_windows"] = best_hybrid["windows"]
            # Beside default_trials: the refined score of every design the job tried (its ranking check).
            row["hybrid_scielab_1m_by_height"] = {f"{h:g}": v["scielab_1m"] for h, v in hybrid.items()}
            for key in ("scielab_1m", "scielab_2m", "de2000"):
                row[f"default_{key}"] = default[key]
            row["default_windows"] = chosen_windows
            row["default_nozzle_height"] = chosen
            row["default_trials"] = design.to_json()["trials"] if design is not None else []
            row["default_reason"] = design.reason if design is not None else "nothing left to the job"
            row["default_design_seconds"] = design.seconds if design is not None else 0.0
            # The must-show, on what the job does by default ...
            row["default_over_hard_1m"] = round(default["scielab_1m"] / best_hard["scielab_1m"], 3)
            # ... and on the best of both sweeps (what the best choice could give).
            row["best_over_hard_1m"] = round(
                min(best_soft["scielab_1m"], best_hybrid["scielab_1m"]) / best_hard["scielab_1m"], 3
            )
            row["soft_over_hard_1m"] = round(best_soft["scielab_1m"] / best_hard["scielab_1m"], 3)
            row["hybrid_seconds"] = round(
                sum(t["stipple_seconds"] + t["refine_seconds"] for t in htiming.values()), 3
            )
            row["soft_minus_hard_scielab_1m"] = round(best_hard["scielab_1m"] - best_soft["scielab_1m"], 3)
            row["soft_minus_hard_scielab_2m"] = round(best_hard["scielab_2m"] - best_soft["scielab_2m"], 3)
            row["soft_holes"] = best_soft["holes"]
            row["soft_spray_times"] = best_soft["spray_times"]
            row["soft_scielab_1m_by_can"] = best_soft["scielab_1m_by_can"]
            row["soft_scielab_1m_worst"] = max(best_soft["scielab_1m_by_can"].values())
            row["soft_max_passes_used"] = (
                int(max(best_soft["spray_times"])) if cfg0.spray.is_physical else None
            )
            row["layer_tone_rmse_stippled"] = best_soft["layer_tone_rmse_stippled"]
            row["layer_tone_rmse_refined"] = best_soft["layer_tone_rmse_refined"]
            row.update(timing[hs])
            row["by_nozzle_height"] = {
                f"{h:g}": {
                    **({"hard": hard[h]} if h in hard else {}),
                    **({"soft": soft[h], "soft_norefine": plain[h], **timing[h]} if h in soft else {}),
                }
                for h in sorted({*hard, *soft})
            }
            row["picture_px"] = list(pic.shape)
            row["sim_px"] = list(shape)
            row["decompose_seconds"] = round(t_decompose, 3)
            row["hard_segment_seconds"] = round(t_segment, 3)
            row["seconds"] = round(
                sum(t["stipple_seconds"] + t["refine_seconds"] for t in timing.values()), 3
            )
            yield row
