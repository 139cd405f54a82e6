"""Wall build/export and laser-DXF write timings.

Cases:
    dxf_14000: write 14,000 circles + outline with :func:`stencil_cad.exchange.dxf.write_dxf`; the
        baseline, measured in the same run, adds every circle through ezdxf (``add_circle``
        + ``saveas``), which is what the writer avoids.
    wall_150: build the default wall for a 150 x 150 mm picture, export STEP and STL,
        compare B-rep and analytic volumes.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

CASES = ["dxf_14000", "wall_150"]
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds",)


def _dxf_case(tmp: Path, n: int = 14_000) -> dict:
    import ezdxf

    from stencil_cad.config.outline import OutlineConfig
    from stencil_cad.exchange.dxf import write_dxf
    from stencil_cad.outline import plate_outline

    rng = np.random.default_rng(0)
    c = np.column_stack([rng.uniform(1, 149, n), rng.uniform(1, 149, n), rng.uniform(0.5, 0.9, n)])
    ring = plate_outline(150.0, 150.0, OutlineConfig())
    t0 = time.perf_counter()
    write_dxf(tmp / "fast.dxf", ring, c, kerf_mm=0.1)
    seconds = time.perf_counter() - t0

    t0 = time.perf_counter()
    doc = ezdxf.new("R2010", setup=False, units=4)
    msp = doc.modelspace()
    for x, y, r in c.tolist():
        msp.add_circle((x, y), r)
    msp.add_lwpolyline(ring.tolist(), close=True)
    doc.saveas(tmp / "naive.dxf")
    baseline = time.perf_counter() - t0

    t0 = time.perf_counter()
    back = ezdxf.readfile(tmp / "fast.dxf")
    errors = len(back.audit().errors)
    read_seconds = time.perf_counter() - t0
    return {
        "bench": "wall_dxf",
        "case": f"dxf_{n}",
        "seconds": round(seconds, 4),
        "baseline_ezdxf_seconds": round(baseline, 4),
        "speedup": round(baseline / seconds, 1),
        "circles_read_back": len(back.modelspace().query("CIRCLE")),
        "audit_errors": errors,
        "read_audit_seconds": round(read_seconds, 3),
        "bytes": (tmp / "fast.dxf").stat().st_size,
    }


def _wall_case(tmp: Path) -> dict:
    t0 = time.perf_counter()
    from stencil_cad.cad.wall import build_wall, wall_step, wall_stl
    from stencil_cad.config.cad import WallConfig
    from stencil_cad.config.outline import OutlineConfig

    import_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    m = build_wall(150.0, 150.0, OutlineConfig(), WallConfig(), 1.2, 10.0)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    wall_step(m, tmp / "wall.step")
    step = time.perf_counter() - t0
    t0 = time.perf_counter()
    wall_stl(m, tmp / "wall.stl")
    stl = time.perf_counter() - t0
    vol = m.part.volume
    return {
        "bench": "wall_dxf",
        "case": "wall_150",
        "seconds": round(build + step + stl, 3),
        "build_seconds": round(build, 3),
        "step_seconds": round(step, 3),
        "stl_seconds": round(stl, 3),
        "import_wall_seconds": round(import_seconds, 2),  # the wall module (OCP, no build123d)
        "faces": len(m.part.faces()),
        "solids": len(m.part.solids()),
        "volume_mm3": round(vol, 3),
        "volume_rel_err": abs(vol - m.volume_mm3) / m.volume_mm3,
        "stl_bytes": (tmp / "wall.stl").stat().st_size,
    }


def run(cases=None):
    """Yield one dict per case (see the module docstring)."""
    chosen = CASES if cases is None else [c for c in CASES if c in cases]
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for case in chosen:
            yield _dxf_case(tmp) if case == "dxf_14000" else _wall_case(tmp)


if __name__ == "__main__":
    import json

    for row in run():
        print(json.dumps(row))


def smoke():
    """1,000 circles, and the 150 mm wall (one build, its STEP and STL)."""
    with tempfile.TemporaryDirectory() as d:
        yield _dxf_case(Path(d), n=1000)
        yield _wall_case(Path(d))
