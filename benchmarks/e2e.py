"""End to end: `stencil-cad run` on the bundled example, in a child process.

Prints seconds (wall clock of the whole command, imports included), the child's peak
resident memory, and the stage times and figures from the manifest it wrote.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(cases=None):
    if cases and "example" not in cases:
        return
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "example"
        t0 = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "stencil_cad", "run", "--out", str(out), "-q"],
            capture_output=True,
            text=True,
        )
        seconds = time.perf_counter() - t0
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
        row = {"bench": "e2e", "case": "example", "seconds": round(seconds, 2), "peak_mb": round(peak_mb, 1)}
        if proc.returncode != 0:
            row["error"] = (
                proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit {proc.returncode}"
            )
            yield row
            return
        manifest = json.loads((out / "manifest.json").read_text())
        row["stage_seconds"] = manifest.get("seconds", {})
        row["dots"] = [r["dots"] for r in manifest.get("stipple", [])]
        row["files"] = len(manifest.get("files", []))
        sim = manifest.get("simulate", {})
        for k in ("de2000_mean", "de2000_p95", "psnr", "ssim"):
            if k in sim:
                row[k] = sim[k]
        yield row
