"""Murals: `stencil-cad run` on a 1 m² and a 4 m² mural (4 layers, FDM, bed prusa_mk4), in a child process.

Each case is a mural (1 m × 1 m, 2 m × 2 m, 4 m × 2.5 m) from the bundled 512 px photo enlarged
to 1024 px, or 1600 px for the 4 m wide one (an ordinary photo; the auto resolution needs one
pixel per 3.2 mm hole pitch along the picture's width), with ``size.px_per_mm: auto``. Prints one JSON line per case: ``bench: "mural"``, ``area_m2``,
``workers`` (1: one process), ``seconds`` (wall clock of the whole command), ``peak_mb_all``
(the largest sum of the resident memory of the command and all its child processes, sampled
every 0.2 s, and never below the kernel's peak of the largest one), ``tiles``, ``holes``
and the stage times, and ``cpu_seconds`` (the command and every process it waited for). The
4 m² row also gives ``ratio_to_1m2`` (wall clocks) and ``cpu_ratio_to_1m2``.

The Dask rows (cases ``4m2-w2``, ``10m2-w2``; ``10m2-w1`` on request) run the same command with
``--workers N`` (a local cluster of N worker processes; the one-process rows run with
``--workers 0``). ``10m2`` is 4 m × 2.5 m. ``identical`` is true when every output file but
``manifest.json`` (timings, where it ran) is byte-identical to the one-process run of the same
size in this invocation, and null when there was none; ``speedup_vs_1`` is the one-process
run's seconds over this one's. ``peak_mb_all`` sums the command and its worker processes.
Run ``python -m benchmarks mural --case 4m2 --case 4m2-w2`` several times on a quiet machine
and quote the medians: the speed-up is a ratio of wall clocks.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import yaml

#: Case name: (width mm, height mm, workers; 0 = one process).
CASES = {
    "1m2": (1000.0, 1000.0, 0),
    "4m2": (2000.0, 2000.0, 0),
    "4m2-w2": (2000.0, 2000.0, 2),
    "10m2-w2": (4000.0, 2500.0, 2),
}
#: The smoke case: a 240 x 120 mm mural in two layers on a 180 mm bed (two or more tiles).
SMOKE = {"smoke": (240.0, 120.0, 0)}
SMOKE_JOB = {"bed": "prusa_mini", "decompose": {"layers": 2}}
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "area_m2",
    "workers",
    "seconds",
    "peak_mb_all",
    "cpu_seconds",
    "tiles",
    "holes",
    "stage_seconds",
)
#: Cases run only when asked for by name.
ON_REQUEST = {"10m2-w1": (4000.0, 2500.0, 0), "1m2-w2": (1000.0, 1000.0, 2)}


def _tree_rss_mb(pid: int) -> float:
    import psutil

    try:
        p = psutil.Process(pid)
        procs = [p, *p.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0.0
    total = 0
    for q in procs:
        try:
            total += q.memory_info().rss
        except psutil.NoSuchProcess:
            pass
    return total / 2**20


def _photo(tmp: Path, width_mm: float) -> Path:
    """The bundled photo enlarged to 1024 px, or more when the picture is wider than 3.2 m."""
    from PIL import Image

    from stencil_cad.imaging import example_image_path

    side = 1600 if width_mm > 3200 else 1024
    image = tmp / f"photo_{side}.png"
    if not image.exists():
        Image.open(example_image_path()).convert("RGB").resize((side, side), Image.LANCZOS).save(image)
    return image


def _run_case(
    name: str, case: tuple[float, float, int], tmp: Path, job: dict | None = None
) -> tuple[dict, Path]:
    width_mm, height_mm, workers = case
    image = _photo(tmp, width_mm)
    area = width_mm * height_mm / 1e6
    cfg = {
        "name": f"mural_{area:g}m2",
        "image": str(image),
        "size": {"width_mm": width_mm, "height_mm": height_mm, "px_per_mm": "auto"},
        "bed": "prusa_mk4",
        "decompose": {"layers": 4},
        "stipple": {"process": "fdm"},
        **(job or {}),
    }
    path = tmp / f"{cfg['name']}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = tmp / name
    t0 = time.perf_counter()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "stencil_cad",
            "run",
            str(path),
            "--out",
            str(out),
            "-q",
            "--workers",
            str(workers),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    peak = [0.0]

    def sample() -> None:
        while proc.poll() is None:
            peak[0] = max(peak[0], _tree_rss_mb(proc.pid))
            time.sleep(0.2)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    _, err = proc.communicate()
    th.join()
    seconds = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    kernel_peak = c1.ru_maxrss / 1024.0
    row = {
        "bench": "mural",
        "case": name,
        "area_m2": round(area, 3),
        "workers": max(workers, 1),
        "seconds": round(seconds, 1),
        "peak_mb_all": round(max(peak[0], kernel_peak), 1),
        # CPU of the command and every process it waited for (a local cluster's workers too):
        # the figure to compare when the machine is shared.
        "cpu_seconds": round(c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, 1),
    }
    if proc.returncode != 0:
        row["error"] = err.strip().splitlines()[-1] if err.strip() else f"exit {proc.returncode}"
        return row, out
    manifest = json.loads((out / "manifest.json").read_text())
    m = manifest.get("mural", {})
    row["tiles"] = len(m.get("tiles", [])) or 1
    row["holes"] = sum(r["dots"] for r in manifest.get("stipple", []))
    row["stage_seconds"] = manifest.get("seconds", {})
    sim = m.get("simulation", {})
    row["tiled_vs_global_max_abs"] = sim.get("tiled_vs_global_max_abs")
    return row, out


def _identical(a: Path, b: Path) -> bool:
    """Every file but the manifest byte-identical, and the same set of files."""
    names = sorted(p.name for p in a.iterdir())
    if names != sorted(p.name for p in b.iterdir()):
        return False
    return all((a / n).read_bytes() == (b / n).read_bytes() for n in names if n != "manifest.json")


def run(cases=None):
    every = {**CASES, **ON_REQUEST}
    names = [c for c in every if (c in cases if cases else c in CASES)]
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        first = None
        one_process: dict[float, tuple[dict, Path]] = {}
        for name in names:
            row, out = _run_case(name, every[name], tmp)
            ok = "error" not in row
            if ok and every[name][2] == 0:
                one_process[row["area_m2"]] = (row, out)
                if first is None:
                    first = row
                else:
                    row["ratio_to_1m2"] = round(row["seconds"] / first["seconds"], 2)
                    row["cpu_ratio_to_1m2"] = round(row["cpu_seconds"] / first["cpu_seconds"], 2)
            elif ok:
                base = one_process.get(row["area_m2"])
                row["identical"] = None if base is None else _identical(base[1], out)
                if base is not None:
                    row["speedup_vs_1"] = round(base[0]["seconds"] / row["seconds"], 2)
                if first is not None:
                    row["ratio_to_1m2"] = round(row["seconds"] / first["seconds"], 2)
            yield row


def smoke():
    """A 240 x 120 mm mural in two layers on a 180 mm bed, in one process."""
    with tempfile.TemporaryDirectory() as tmp:
        row, _ = _run_case("smoke", SMOKE["smoke"], Path(tmp), SMOKE_JOB)
        yield row
