"""How much of the error under another can is tone, and how much is the holes' pattern.

Runs the bundled example once (``stencil-cad run``, as shipped), then sprays its plates in
simulation with every can of the prior (:mod:`stencil_cad.simulate.cans`) and with cans that
change one constant alone: the deposit per pass 15 % lighter or heavier at the nominal spread,
and a skinny or fat cap at the nominal deposit. One JSON line per can:

- ``scielab_1m``: S-CIELAB at 1 m against the source image on the simulated grid, as the
  manifest's ``simulate.scielab_by_can`` gives it;
- ``scielab_tone``: the same after a 6 mm Gaussian blur of both pictures, so only the tone of
  areas wider than the holes' pattern is compared (the part no placement of holes can change,
  given how dark the can sprays);
- ``vs_nominal``: S-CIELAB at 1 m between this can's sprayed picture and the nominal can's;
- ``layer_opacity``: each layer's mean sprayed opacity.

Cases: ``prior`` (the five cans of the prior) and ``one-constant`` (the four one-constant cans);
the nominal can's row comes first in each.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASES = ("prior", "one-constant")
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "can",
    "spread_k",
    "deposit_per_pass",
    "scielab_1m",
    "scielab_tone",
    "vs_nominal",
    "layer_opacity",
)

#: ``(name, spread k or None for the nominal, deposit factor, bleed factor)`` of the one-constant cans.
ONE_CONSTANT = (
    ("nominal", None, 1.0, 1.0),
    ("lighter coat", None, 0.85, 1.0),
    ("heavier coat", None, 1.15, 1.0),
    ("skinny cap", 0.08, 1.0, 0.8),
    ("fat cap", 0.16, 1.0, 1.25),
)

TONE_BLUR_MM = 6.0


def _example(out: Path, config: Path | None = None) -> None:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "stencil_cad",
            "run",
            *([str(config)] if config else []),
            "--out",
            str(out),
            "-q",
        ],
        check=True,
        capture_output=True,
    )


def _job(folder: Path):
    """The saved job: config, layers, the holes as made, each layer's spray settings, the reference."""
    from stencil_cad.config.io import load_config
    from stencil_cad.decompose.light import light_plates
    from stencil_cad.imaging import load_picture
    from stencil_cad.model import DotSet
    from stencil_cad.mural import light_plates_on
    from stencil_cad.pipeline.saved import read_dots, read_layers
    from stencil_cad.stipple.made import made_dots

    cfg = load_config(folder / "config.yaml")
    # The plates the one-plate job stippled from its saved layers (a light and a dark plate per paint).
    layers = read_layers(folder)
    if light_plates_on(cfg, False):
        layers = light_plates(layers)
    size_mm = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
    dots = read_dots(folder, layers.count, max_time=8.0 * cfg.spray.amount_cap)
    dots = [made_dots(d, cfg.stipple, size_mm) if isinstance(d, DotSet) else d for d in dots]
    image = cfg.image  # None: the bundled example
    return (
        cfg,
        layers,
        dots,
        lambda shape, mm: (
            load_picture(image, shape[1] * mm, shape[0] * mm, 1.0 / mm, max_upscale=math.inf).rgb
        ),
    )


def _cans(cfg, case: str) -> list[tuple[str, object]]:
    from stencil_cad.simulate.cans import PriorCan, can_prior

    if case == "prior":
        return can_prior(cfg.spray)
    return can_prior(cfg.spray, tuple(PriorCan(*c) for c in ONE_CONSTANT))


def _rows(folder: Path, case: str):
    from scipy.ndimage import gaussian_filter
    from skimage.transform import resize

    from stencil_cad import resolution, simulate
    from stencil_cad.simulate import scielab
    from stencil_cad.simulate.physical import SprayGeometry

    cfg, layers, dots, reference = _job(folder)
    geometry = SprayGeometry.for_job(cfg)
    grid = resolution.sim_mm_per_px(cfg)
    distance = cfg.view.distance_m
    nominal = ref = None
    for name, spray in _cans(cfg, case):
        t0 = time.perf_counter()
        sim = simulate.simulate(
            layers, dots, spray, grid, geometry=geometry, layer_sprays=[spray] * layers.count
        )
        mm = sim.mm_per_px
        if ref is None:
            shape = sim.composite.shape[:2]
            ref = resize(reference(shape, mm), shape, anti_aliasing=True)
        if nominal is None:
            nominal = sim.composite

        def blur(img, mm=mm):
            return gaussian_filter(img, (TONE_BLUR_MM / mm, TONE_BLUR_MM / mm, 0.0))

        yield {
            "bench": "cans",
            "case": case,
            "can": name,
            "spread_k": spray.can.spread_k,
            "deposit_per_pass": round(spray.can.deposit_per_pass, 4),
            "bleed_sigma_mm": round(spray.can.bleed_sigma_mm, 4),
            "scielab_1m": round(scielab.scielab(ref, sim.composite, mm, distance), 3),
            "scielab_tone": round(scielab.scielab(blur(ref), blur(sim.composite), mm, distance), 3),
            "vs_nominal": round(scielab.scielab(nominal, sim.composite, mm, distance), 3),
            "layer_opacity": [round(float(a.mean()), 4) for a in sim.alphas],
            "seconds": round(time.perf_counter() - t0, 2),
        }


def run(cases=None):
    wanted = [c for c in CASES if not cases or c in cases]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "example"
        _example(folder)
        for case in wanted:
            yield from _rows(folder, case)


def smoke():
    """The one-constant cans on the bundled example at 40 mm in two layers."""
    from benchmarks.e2e import SMOKE_JOB, _config

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "example"
        _example(folder, _config(Path(tmp), "example", SMOKE_JOB))
        yield from _rows(folder, "one-constant")
