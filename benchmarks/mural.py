"""Murals: `stencil-cad run` on a 1 m² and a 4 m² mural (4 layers, FDM, bed prusa_mk4), in a child process.

Each case is a square mural (1 m × 1 m, 2 m × 2 m) from the bundled 512 px photo enlarged to
1024 px (an ordinary photo; the auto resolution needs one pixel per 3.2 mm hole pitch), with
``size.px_per_mm: auto``. Prints one JSON line per case: ``bench: "mural"``, ``area_m2``,
``workers`` (1: one process), ``seconds`` (wall clock of the whole command), ``peak_mb_all``
(the largest sum of the resident memory of the command and all its child processes, sampled
every 0.2 s, and never below the kernel's peak of the largest one), ``tiles``, ``holes``
and the stage times. The 4 m² row also gives ``ratio_to_1m2``.
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

CASES = {"1m2": 1000.0, "4m2": 2000.0}


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


def _run_case(side_mm: float, tmp: Path, image: Path) -> dict:
    cfg = {
        "name": f"mural_{side_mm / 1000:g}m",
        "image": str(image),
        "size": {"width_mm": side_mm, "height_mm": side_mm, "px_per_mm": "auto"},
        "bed": "prusa_mk4",
        "decompose": {"layers": 4},
        "stipple": {"process": "fdm"},
    }
    path = tmp / f"{cfg['name']}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = tmp / cfg["name"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "stencil_cad", "run", str(path), "--out", str(out), "-q"],
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
    kernel_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    row = {
        "bench": "mural",
        "case": f"{(side_mm / 1000) ** 2:g}m2",
        "area_m2": round((side_mm / 1000) ** 2, 3),
        "workers": 1,
        "seconds": round(seconds, 1),
        "peak_mb_all": round(max(peak[0], kernel_peak), 1),
    }
    if proc.returncode != 0:
        row["error"] = err.strip().splitlines()[-1] if err.strip() else f"exit {proc.returncode}"
        return row
    manifest = json.loads((out / "manifest.json").read_text())
    m = manifest.get("mural", {})
    row["tiles"] = len(m.get("tiles", [])) or 1
    row["holes"] = sum(r["dots"] for r in manifest.get("stipple", []))
    row["stage_seconds"] = manifest.get("seconds", {})
    sim = m.get("simulation", {})
    row["tiled_vs_global_max_abs"] = sim.get("tiled_vs_global_max_abs")
    return row


def run(cases=None):
    from PIL import Image

    from stencil_cad.imaging import example_image_path

    names = [c for c in CASES if not cases or c in cases]
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        image = tmp / "photo_1024.png"
        Image.open(example_image_path()).convert("RGB").resize((1024, 1024), Image.LANCZOS).save(image)
        first = None
        for name in names:
            row = _run_case(CASES[name], tmp, image)
            if first is None and "error" not in row:
                first = row
            elif first is not None and "error" not in row:
                row["ratio_to_1m2"] = round(row["seconds"] / first["seconds"], 2)
            yield row
