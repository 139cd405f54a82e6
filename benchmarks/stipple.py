"""Stippling speed and quality: `python -m benchmarks stipple [--case NAME]`.

Cases:

* ``512-14k`` — 14,000 seeds on the 512 x 512 bundled example (Lloyd weight
  ``(0.02 + 0.98 darkness)^2``, strictly positive so the baseline's centroid
  code never divides by zero). Our Lloyd iteration (over-relaxed with the
  stage's ``OMEGA``, last step plain) is timed over 50 iterations; the public pure-Python stippler (PyPI ``stippler`` 0.2.1.1,
  BSD-3-Clause, used unmodified as a comparison tool) runs
  ``BASELINE_ITERATIONS`` iterations side by side from the *same* start points,
  and both CVT energies are evaluated by the same exact pixel-grid evaluator
  after that many iterations. ``e_norm`` is ours after 50 iterations.
* ``1024-14k`` — the same density bilinearly upsampled to 1024 x 1024.
* ``2048-100k`` — the whole stage (``stipple_layer``: sampling, up to 50
  Lloyd iterations, design rules) for 100,000 dots on 2048 x 2048.
* ``example-4layers`` — the bundled example as the lead's pipeline sees it
  (300 x 300 px at 0.5 mm/px, default config), four layers (darkness and the
  three inverted channels), total seconds.

The baseline is skipped with ``baseline_error`` when ``stippler`` is not
importable (install it with ``pip install stippler==0.2.1.1``).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

from stencil_cad.config import StippleConfig
from stencil_cad.stipple import (
    OMEGA,
    cvt_energy,
    cvt_optimum,
    importance_sample,
    lloyd,
    stipple_layer,
    voronoi_pass,
)

CASES = ["512-14k", "1024-14k", "2048-100k", "example-4layers"]
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds", "seconds_per_iter", "e_norm", "dots", "speedup")
BASELINE_ITERATIONS = 3
ITERATIONS = 50
EXAMPLE = Path(__file__).resolve().parent.parent / "stencil_cad" / "data" / "example.png"


def _darkness(size: int | None = None) -> np.ndarray:
    grey = np.asarray(Image.open(EXAMPLE).convert("L"), dtype=np.float64) / 255.0
    dark = 1.0 - grey
    if size is not None and dark.shape != (size, size):
        dark = ndimage.zoom(dark, size / dark.shape[0], order=1, grid_mode=True, mode="nearest")
    return np.clip(dark, 0.0, 1.0)


def _timed_lloyd(weight: np.ndarray, seeds: np.ndarray, iterations: int) -> tuple[np.ndarray, list[float]]:
    """Run the stage's Lloyd loop (over-relaxed, warm-started), timing each iteration."""
    stamps = [time.perf_counter()]
    seeds, _ = lloyd(weight, seeds, iterations, 0.0, lambda i, n: stamps.append(time.perf_counter()), OMEGA)
    return seeds, list(np.diff(stamps))


def _baseline(weight: np.ndarray, seeds_rc: np.ndarray, iterations: int) -> tuple[np.ndarray, list[float]]:
    """Run the public ``stippler`` Lloyd step (its own weighted-centroid code) side by side."""
    from stippler import voronoi as sv  # noqa: PLC0415 - optional comparison tool

    density = weight
    density_p = density.cumsum(axis=1)
    density_q = density_p.cumsum(axis=1)
    points = seeds_rc[:, ::-1].copy()  # stippler works in (x, y) = (col, row)
    times = []
    for _ in range(iterations):
        t0 = time.perf_counter()
        _, points = sv.centroids(points, density, density_p, density_q)
        times.append(time.perf_counter() - t0)
    return np.asarray(points)[:, ::-1], times


def _case_lloyd(name: str, size: int, n: int, with_baseline: bool) -> dict:
    t_case = time.perf_counter()
    dark = _darkness(size)
    weight = (0.02 + 0.98 * dark) ** 2
    start = importance_sample(np.sqrt(weight), n, np.random.default_rng(0))
    voronoi_pass(weight, start[:10])  # compile outside the timing
    row: dict = {"bench": "stipple", "case": name, "grid": f"{size}x{size}", "dots": n, "omega": OMEGA}

    k = BASELINE_ITERATIONS
    mine_k, _ = _timed_lloyd(weight, start.copy(), k)
    row["iterations_compared"] = k
    row["cvt_energy"] = cvt_energy(weight, mine_k)

    seeds, times = _timed_lloyd(weight, start.copy(), ITERATIONS)
    row["iterations"] = ITERATIONS
    row["seconds_per_iter"] = float(np.median(times))
    row["e_norm"] = cvt_energy(weight, seeds) / cvt_optimum(weight, n)

    row["baseline"] = "stippler 0.2.1.1 (PyPI, pure Python + scipy.spatial.Voronoi)"
    row["baseline_seconds_per_iter"] = None
    row["baseline_cvt_energy"] = None
    row["speedup"] = None
    if with_baseline:
        try:
            base_pts, base_times = _baseline(weight, start.copy(), k)
        except ImportError as exc:
            row["baseline_error"] = f"stippler not installed ({exc}); pip install stippler==0.2.1.1"
        except Exception as exc:  # noqa: BLE001 - report, do not crash the benchmark run
            row["baseline_error"] = f"stippler failed: {type(exc).__name__}: {exc}"
        else:
            row["baseline_seconds_per_iter"] = float(np.median(base_times))
            row["baseline_cvt_energy"] = cvt_energy(weight, base_pts)
            row["baseline_dots_out"] = len(base_pts)
            row["speedup"] = row["baseline_seconds_per_iter"] / row["seconds_per_iter"]
    else:
        row["baseline_error"] = "baseline run only in case 512-14k (about 5 s per iteration)"
    row["seconds"] = time.perf_counter() - t_case
    return row


def _case_100k() -> dict:
    dark = _darkness(2048)
    cfg = StippleConfig(process="sla", edge_margin_mm=1.0, tone="linear")
    stipple_layer(dark[:64, :64], 0.4, cfg, np.random.default_rng(0), n_dots=50)  # compile
    t0 = time.perf_counter()
    ds = stipple_layer(dark, 0.4, cfg, np.random.default_rng(0), n_dots=100_000)
    seconds = time.perf_counter() - t0
    rep = ds.report
    return {
        "bench": "stipple",
        "case": "2048-100k",
        "grid": "2048x2048",
        "dots": 100_000,
        "seconds": seconds,
        "seconds_per_iter": None,
        "n_final": rep["n_final"],
        "iterations": rep["iterations"],
        "refine": rep["refine"],
        "e_norm": rep["e_norm"],
        "removed": rep["removed"],
        "nudged": rep["nudged"],
        "min_web_mm": rep["min_web_mm"],
    }


def _case_example() -> dict:
    rgb = (
        np.asarray(Image.open(EXAMPLE).convert("RGB").resize((300, 300), Image.LANCZOS), dtype=np.float64)
        / 255
    )
    layers = [1.0 - rgb.mean(axis=2)] + [1.0 - rgb[..., c] for c in range(3)]
    cfg = StippleConfig(tone="linear")
    stipple_layer(layers[0][:40, :40], 0.5, cfg, np.random.default_rng(0))  # compile
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    sets = [stipple_layer(a, 0.5, cfg, rng) for a in layers]
    seconds = time.perf_counter() - t0
    return {
        "bench": "stipple",
        "case": "example-4layers",
        "grid": "300x300 @ 0.5 mm/px",
        "seconds": seconds,
        "seconds_per_iter": None,
        "dots": [len(s) for s in sets],
        "iterations": [s.report["iterations"] for s in sets],
        "e_norm": [round(s.report["e_norm"], 4) for s in sets],
        "removed": [s.report["removed"] for s in sets],
        "min_web_mm": min(s.report["min_web_mm"] for s in sets),
    }


def run(cases=None):
    """Yield one result dict per case (all by default)."""
    for name in cases or CASES:
        if name not in CASES:
            raise ValueError(f"unknown stipple case {name!r}; choose from {', '.join(CASES)}")
        if name == "512-14k":
            yield _case_lloyd(name, 512, 14_000, with_baseline=True)
        elif name == "1024-14k":
            yield _case_lloyd(name, 1024, 14_000, with_baseline=False)
        elif name == "2048-100k":
            yield _case_100k()
        else:
            yield _case_example()


if __name__ == "__main__":  # pragma: no cover
    import json

    for result in run():
        print(json.dumps(result, default=lambda v: None if isinstance(v, float) and math.isinf(v) else v))


def smoke():
    """500 seeds on 128 x 128 px, the baseline beside them when it is installed."""
    yield _case_lloyd("smoke-128-500", 128, 500, with_baseline=True)
