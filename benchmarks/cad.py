"""CAD benchmark: build, check and write stencil plates (`python -m benchmarks cad`).

Cases (each runs in a fresh Python process so that ``peak_mb`` is its own):

* ``plate-14k``: a 200 x 200 mm picture with 14,000 holes, built, checked and
  written as STEP + STL + DXF + SVG (DXF through ``stencil_cad.exchange.dxf`` when present).
  ``steps.check_file`` is a job's check (its STEP text read back and its mesh, no OCCT solid);
  ``steps.check`` is ``plate.check: kernel``'s, which builds the OCCT solid (``build`` does not).
  Target: ≤ 15 s in all (``target_seconds``). One-off costs a job pays once
  (imports of build123d/OCP, numba's cache, font loading, by building a
  900-hole plate) are reported apart (``warmup_seconds``).
* ``stl-2k``: the STL of a 2,000-hole plate, ours against build123d's
  ``export_stl`` at its defaults on the same Part, side by side (the baseline
  takes minutes). Target: speedup ≥ 100.
* ``plate-50k``: 50,000 holes at the same density (a 375 x 375 mm picture).
  Targets: ≤ 4x the plate-14k time of the same run, peak memory ≤ 4 GB.

Each row: ``bench``, ``case``, ``seconds`` (wall), ``cpu_seconds`` (this
process; the machine is shared, so wall time is noisy), ``baseline_seconds``,
``speedup``, ``peak_mb``, ``steps`` (per-step wall seconds) and the checks.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CASES = ["plate-14k", "stl-2k", "plate-50k"]
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds", "cpu_seconds", "holes", "steps", "valid", "rel_error", "mesh_genus", "peak_mb")
ROOT = Path(__file__).resolve().parents[1]


def jittered_dots(n: int, pitch: float = 1.68, seed: int = 0):
    """``n`` holes on a jittered grid: radii 0.5-0.6 mm, webs ≥ 0.1 mm; picture side in mm."""
    from stencil_cad.model import DotSet

    rng = np.random.default_rng(seed)
    k = int(np.ceil(np.sqrt(n)))
    edge = 0.3  # mm of sheet between the outermost holes and the picture's edge
    side = k * pitch + 2 * edge
    ij = np.stack(np.meshgrid(np.arange(k), np.arange(k)), -1).reshape(-1, 2)[:n]
    xy = edge + (ij + 0.5) * pitch + rng.uniform(-0.1, 0.1, (n, 2)) * pitch
    r = rng.uniform(0.5, 0.6, n)
    return DotSet(xy, r), side


def _plate_case(n: int, name: str) -> dict:
    t_imp = time.perf_counter()
    import build123d  # noqa: F401

    from stencil_cad import cad
    from stencil_cad.config import JobConfig

    cfg = JobConfig()
    # One-off costs a job pays once, not per plate: imports, numba's cache, the font.
    small, small_side = jittered_dots(900)
    warm = cad.build_plate(small, small_side, small_side, cfg.plate, cad.LabelInfo(1, 1, "red", "warm"))
    cad.check_plate(warm, small)
    import_s = time.perf_counter() - t_imp
    dots, side = jittered_dots(n)
    steps, cpu = {}, {}
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    label = cad.LabelInfo(layer=1, layers=4, colour="#1A2B3C", job="bench")
    model = cad.build_plate(dots, side, side, cfg.plate, label)
    steps["build"] = time.perf_counter() - t0
    cpu["build"] = time.process_time() - cpu0
    # What a job runs (plate.check: file): the STEP text read back, and the mesh; no OCCT solid.
    t, c = time.perf_counter(), time.process_time()
    step = cad.plate_step_text(model)
    file_report = cad.check_plate_file(model, step, dots, tolerance_mm=cfg.export.stl_tolerance_mm)
    steps["check_file"] = time.perf_counter() - t
    cpu["check_file"] = time.process_time() - c
    # plate.check: kernel: the OCCT solid is built here, on first use, then checked.
    t, c = time.perf_counter(), time.process_time()
    report = cad.check_plate(model, dots, tolerance_mm=cfg.export.stl_tolerance_mm)
    steps["check"] = time.perf_counter() - t
    cpu["check"] = time.process_time() - c
    with tempfile.TemporaryDirectory() as tmp:
        t, c = time.perf_counter(), time.process_time()
        cad.write_step(model, Path(tmp) / "p.step")
        steps["step"] = time.perf_counter() - t
        cpu["step"] = time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        cad.write_stl(model, Path(tmp) / "p.stl", cfg.export.stl_tolerance_mm)
        steps["stl"] = time.perf_counter() - t
        cpu["stl"] = time.process_time() - c
        try:
            from stencil_cad import outline
            from stencil_cad.exchange import dxf

            t, c = time.perf_counter(), time.process_time()
            ring = outline.plate_outline(side, side, cfg.plate.outline)
            dxf.write_dxf(Path(tmp) / "p.dxf", ring, circles_xy_r=np.column_stack([dots.xy_mm, dots.r_mm]))
            steps["dxf"] = time.perf_counter() - t
            cpu["dxf"] = time.process_time() - c
            from stencil_cad.exchange import svg

            t, c = time.perf_counter(), time.process_time()
            drawing = dxf.DxfStencil(outline_ring=ring, circles_xy_r=(dots.xy_mm, dots.r_mm))
            svg.write_svg(Path(tmp) / "p.svg", drawing)
            steps["svg"] = time.perf_counter() - t
            cpu["svg"] = time.process_time() - c
        except ImportError:
            steps["dxf"] = None
        sizes = {p.suffix[1:]: p.stat().st_size for p in Path(tmp).iterdir()}
    seconds = time.perf_counter() - t0
    return {
        "bench": "cad",
        "case": name,
        "holes": n,
        "picture_mm": round(side, 2),
        "seconds": round(seconds, 3),
        "cpu_seconds": round(time.process_time() - cpu0, 3),
        "baseline_seconds": None,
        "speedup": None,
        "target_seconds": 15.0 if name == "plate-14k" else None,
        "warmup_seconds": round(import_s, 3),
        "steps": {k: (None if v is None else round(v, 3)) for k, v in steps.items()},
        "steps_cpu": {k: round(v, 3) for k, v in cpu.items()},
        "check_steps": report["seconds"],
        "check_file_steps": file_report["seconds"],
        "valid": report["valid"] and file_report["valid"],
        "valid_method": report["valid_method"],
        "rel_error": report["rel_error"],
        "mesh_rel_error": report["mesh"]["rel_error"],
        "mesh_genus": report["mesh"]["genus"],
        "triangles": report["mesh"]["triangles"],
        "file_bytes": sizes,
        "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    }


def _stl_case():
    """Yield our STL figures, then the baseline's (which may run out of time or memory)."""
    from build123d import export_stl

    from stencil_cad import cad
    from stencil_cad.config import JobConfig
    from stencil_cad.config.cad import LabelMode

    dots, side = jittered_dots(2000, pitch=4.4)
    dots = type(dots)(dots.xy_mm, np.random.default_rng(1).uniform(0.5, 0.8, len(dots)))
    cfg = JobConfig()
    # A plain perforated plate (no label), as in the measurement the issue quotes.
    plate_cfg = cfg.plate.model_copy(update={"label": LabelMode.none})
    model = cad.build_plate(dots, side, side, plate_cfg, None)
    with tempfile.TemporaryDirectory() as tmp:
        cpu0 = time.process_time()
        t = time.perf_counter()
        cad.write_stl(model, Path(tmp) / "ours.stl", cfg.export.stl_tolerance_mm)
        ours = time.perf_counter() - t
        ours_cpu = time.process_time() - cpu0
        yield {
            "part": "ours",
            "holes": len(dots),
            "picture_mm": round(side, 2),
            "seconds": round(ours, 3),
            "cpu_seconds": round(ours_cpu, 3),
            "triangles": int(model.mesh(cfg.export.stl_tolerance_mm).faces.shape[0]),
            "peak_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        }
        # build123d's defaults mesh very finely and, here, grew past 19 GB: cap the address space.
        limit = int(BASELINE_MAX_GB * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        cpu0 = time.process_time()
        t = time.perf_counter()
        export_stl(model.part, str(Path(tmp) / "base.stl"))
        yield {
            "part": "baseline",
            "seconds": round(time.perf_counter() - t, 3),
            "cpu_seconds": round(time.process_time() - cpu0, 3),
            "bytes": (Path(tmp) / "base.stl").stat().st_size,
        }


#: Limits of the stl-2k baseline (build123d export_stl at its defaults).
BASELINE_MAX_GB = 8.0
BASELINE_TIMEOUT_S = 1200


def _merge_stl(lines: list[dict], elapsed: float, error: str | None) -> dict:
    ours = next((r for r in lines if r.get("part") == "ours"), None)
    base = next((r for r in lines if r.get("part") == "baseline"), None)
    row = {"bench": "cad", "case": "stl-2k", "target_speedup": 100.0}
    if ours is None:
        return {**row, "seconds": None, "error": error}
    row.update({k: v for k, v in ours.items() if k != "part"})
    if base is not None:
        row["baseline_seconds"] = base["seconds"]
        row["baseline_cpu_seconds"] = base["cpu_seconds"]
        row["speedup"] = round(base["seconds"] / ours["seconds"], 1)
        row["cpu_speedup"] = round(base["cpu_seconds"] / ours["cpu_seconds"], 1)
    else:
        # The baseline did not finish (time or memory limit): the speedup is at least this.
        row["baseline_seconds"] = None
        row["baseline_gave_up_after_seconds"] = round(elapsed, 1)
        row["speedup_at_least"] = round(elapsed / ours["seconds"], 1)
        row["baseline_error"] = (error or "")[-500:]
    row["steps"] = {"ours_stl": ours["seconds"], "build123d_export_stl": row.get("baseline_seconds")}
    return row


def _one(case: str) -> dict:
    if case == "plate-14k":
        return _plate_case(14000, case)
    if case == "plate-50k":
        return _plate_case(50000, case)
    if case == "smoke-plate-300":
        return _plate_case(300, case)
    if case == "stl-2k":
        raise ValueError("stl-2k yields several lines; use _stl_case()")
    raise ValueError(f"unknown case {case!r}; choose from {', '.join(CASES)}")


def run(cases=None):
    """Yield one result dict per case, each measured in a fresh process."""
    todo = CASES if not cases else [c for c in CASES if c in cases]
    done = {}
    for case in todo:
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        args = [sys.executable, "-m", "benchmarks.cad", case]
        t0 = time.perf_counter()
        try:
            res = subprocess.run(
                args, capture_output=True, text=True, cwd=ROOT, env=env, timeout=BASELINE_TIMEOUT_S
            )
            out, err, code = res.stdout, res.stderr, res.returncode
        except subprocess.TimeoutExpired as exc:
            out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
            err, code = "timeout", -1
        elapsed = time.perf_counter() - t0
        lines = [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")]
        if case == "stl-2k":
            first = next((r for r in lines if r.get("part") == "ours"), None)
            base_time = elapsed - (first["seconds"] if first else 0.0)
            yield _merge_stl(lines, base_time, None if code == 0 else f"exit code {code}: {err[-1500:]}")
            continue
        if code != 0 or not lines:
            yield {"bench": "cad", "case": case, "seconds": None, "error": (err or out)[-2000:]}
            continue
        row = lines[-1]
        if case == "plate-50k" and "plate-14k" in done and done["plate-14k"]["seconds"]:
            row["baseline_seconds"] = done["plate-14k"]["seconds"]
            row["ratio_to_14k"] = round(row["seconds"] / done["plate-14k"]["seconds"], 2)
            row["target_ratio"] = 4.0
        if case == "plate-50k":
            row["target_peak_mb"] = 4096
        done[case] = row
        yield row


if __name__ == "__main__":
    if sys.argv[1] == "stl-2k":
        for part in _stl_case():
            print(json.dumps(part), flush=True)
    else:
        print(json.dumps(_one(sys.argv[1])), flush=True)


def smoke():
    """A 300-hole plate built, checked and written, in its own process as every case."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run(
        [sys.executable, "-m", "benchmarks.cad", "smoke-plate-300"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
    )
    lines = [json.loads(ln) for ln in res.stdout.splitlines() if ln.startswith("{")]
    if res.returncode != 0 or not lines:
        yield {"bench": "cad", "case": "smoke-plate-300", "error": (res.stderr or res.stdout)[-2000:]}
    else:
        yield lines[-1]
