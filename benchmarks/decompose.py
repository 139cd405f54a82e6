"""Soft layer decomposition: time, reconstruction RMSE and peak memory.

Cases (scikit-image's astronaut, resized):

- ``astronaut-256-L4``: target RMSE <= 3 (0-255 units) in <= 10 s.
- ``astronaut-256-L6``: target RMSE <= 1.5.
- ``astronaut-1024-L6``: target <= 60 s and peak memory <= 2 GB.
- ``astronaut-256-L4-kmeans-fixed``: baseline, measured in the same run: the
  K-means palette (and primer) held fixed, only the opacities solved. Shows
  what letting the colours move buys.

Each case runs in its own Python process so that ``peak_mb`` (the process's
peak resident set, ``ru_maxrss``) belongs to that case alone; ``base_mb`` is
the same figure just before the decomposition (interpreter, numpy, numba).
The compiled kernels are warmed up on a tiny image first, so ``seconds`` is the
decomposition alone (default config apart from ``layers``).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

CASES = {
    "astronaut-256-L4": {"size": 256, "layers": 4, "targets": {"rmse": 3.0, "seconds": 10.0}},
    "astronaut-256-L6": {"size": 256, "layers": 6, "targets": {"rmse": 1.5}},
    "astronaut-1024-L6": {"size": 1024, "layers": 6, "targets": {"seconds": 60.0, "peak_mb": 2048.0}},
    "astronaut-256-L4-kmeans-fixed": {"size": 256, "layers": 4, "fixed_kmeans": True, "targets": {}},
}
#: The tiny case CI runs (``smoke()``).
SMOKE_CASES = {"astronaut-64-L2": {"size": 64, "layers": 2, "targets": {}}}
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds", "cpu_seconds", "rmse", "peak_mb", "layers", "meets_targets")


def _astronaut(size: int):
    import numpy as np
    from skimage import data
    from skimage.transform import resize

    img = data.astronaut().astype(np.float64) / 255.0
    return np.clip(resize(img, (size, size), order=1, anti_aliasing=size < img.shape[0]), 0.0, 1.0)


def _child(name: str) -> None:
    """Run one case in this process and print its JSON row."""
    import resource
    import time

    import numpy as np

    from stencil_cad.colour import kmeans
    from stencil_cad.config.decompose import DecomposeConfig
    from stencil_cad.decompose import decompose, palette
    from stencil_cad.model import Picture

    spec = {**CASES, **SMOKE_CASES}[name]
    warm = Picture(rgb=np.random.default_rng(1).random((24, 24, 3)), mm_per_px=1.0)
    decompose(warm, DecomposeConfig(layers=2, max_iterations=2), np.random.default_rng(0))
    img = _astronaut(spec["size"])
    cfg = DecomposeConfig(layers=spec["layers"])
    if spec.get("fixed_kmeans"):
        # The K-means start of the automatic palette, held fixed.
        centres, _ = kmeans(img.reshape(-1, 3), spec["layers"] + 1, np.random.default_rng(0))
        centres = centres[np.argsort(-palette.luminance(centres))]
        hexes = ["#{:02x}{:02x}{:02x}".format(*np.rint(c * 255).astype(int)) for c in centres]
        cfg = DecomposeConfig(layers=spec["layers"], primer=hexes[0], palette=hexes[1:], order="given")
    base_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    pic = Picture(rgb=img, mm_per_px=0.5)
    t0 = time.perf_counter()
    c0 = time.process_time()
    layers = decompose(pic, cfg, np.random.default_rng(0))
    seconds = time.perf_counter() - t0
    cpu = time.process_time() - c0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    row = {
        "bench": "decompose",
        "case": name,
        "seconds": round(seconds, 3),
        "cpu_seconds": round(cpu, 3),
        "rmse": round(layers.info["rmse"], 3),
        "rmse_channels": [round(v, 3) for v in layers.info["rmse_channels"]],
        "iterations": layers.iterations,
        "peak_mb": round(peak_mb, 1),
        "base_mb": round(base_mb, 1),
        "layers": layers.count,
        "levels": [[lv["shape"][0], lv["iterations"]] for lv in layers.info.get("levels", [])],
        "targets": spec["targets"],
    }
    checks = {"rmse": row["rmse"], "seconds": seconds, "peak_mb": peak_mb}
    row["meets_targets"] = all(checks[k] <= v for k, v in spec["targets"].items())
    print(json.dumps(row), flush=True)


def run(cases=None):
    """Yield one dict per case (all cases when ``cases`` is None)."""
    names = list(CASES) if not cases else list(cases)
    root = Path(__file__).resolve().parent.parent
    for name in names:
        if name not in CASES and name not in SMOKE_CASES:
            raise ValueError(f"unknown decompose case {name!r}; choose from {', '.join(CASES)}")
        proc = subprocess.run(
            [sys.executable, "-c", f"from benchmarks.decompose import _child; _child({name!r})"],
            cwd=root,
            capture_output=True,
            text=True,
            check=False,
        )
        lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
        if proc.returncode != 0 or not lines:
            yield {"bench": "decompose", "case": name, "seconds": None, "error": proc.stderr.strip()[-2000:]}
            continue
        yield json.loads(lines[-1])


def smoke():
    """A 64 px astronaut in two layers, in its own process as every case."""
    yield from run(list(SMOKE_CASES))
