"""Bounds before work: huge images and absurd dot counts cost little memory and time.

Image cases time the image load onto the working grid (``pipeline.load_picture``, the
process started, config read and imports included in ``seconds``, the load alone in
``load_seconds``); the dots case times the whole ``stencil-cad stipple`` command.

Each case runs the command line in a child process that reports its own peak resident
memory (``ru_maxrss``) and wall time, so the big test images (generated here at run time,
never committed) do not count. Targets: the 15000 × 15000 PNG and a 48 MP JPEG into a 40 mm
picture ≤ 600 MB and ≤ 10 s each; ``stipple.dots: 2000000`` on 40 × 30 mm capped in ≤ 5 s
and ≤ 500 MB. The baseline is the same command on a 400 × 300 px image, in the same run.
The hostile inputs (an alias bomb, /dev/zero, a FIFO, --workers 1000, the 15000² PNG at 2 m,
another card's photo) are :mod:`benchmarks.limits_hostile`'s cases.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks import limits_hostile

# dots_2000000 runs dots_null too; the hostile inputs are in benchmarks/limits_hostile.py.
CASES = ["baseline", "png_15000", "jpeg_48mp", "dots_2000000", *limits_hostile.CASES]

# Linux keeps a process's peak RSS across fork and exec, so every measured child is started
# from this small parent, and the images are generated in children of their own.
_CHILD = """
import json, resource, sys, time
t0 = time.perf_counter()
if sys.argv[1] == "load":
    from stencil_cad.config import io
    from stencil_cad.pipeline import load_picture
    cfg = io.load_config(sys.argv[2]).model_copy(update={"image": sys.argv[3]})
    t1 = time.perf_counter()
    pic = load_picture(cfg)
    extra = {"load_seconds": round(time.perf_counter() - t1, 2), "grid_px": list(pic.rgb.shape[:2])}
    code = 0
else:
    from stencil_cad.cli import main
    code, extra = main(sys.argv[1:]), {}
use = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"exit": code, "seconds": round(time.perf_counter() - t0, 2), **extra,
                  "cpu_seconds": round(use.ru_utime + use.ru_stime, 2),
                  "peak_mb": round(use.ru_maxrss / 1024.0, 1)}))
"""

_MAKE = """
import sys
import pyvips
path, w, h = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
# A smooth colour field, streamed to disk (a few MB of memory for 225 MP).
x = pyvips.Image.xyz(w, h)
r = (x[0] * (255.0 / w)).cast("uchar")
g = (x[1] * (255.0 / h)).cast("uchar")
b = ((x[0] + x[1]) * (127.0 / (w + h))).cast("uchar")
img = r.bandjoin([g, b])
if path.endswith(".png"):
    img.pngsave(path, compression=9)
else:
    img.jpegsave(path, Q=90)
"""

CONFIG = """\
name: limits
size:
  width_mm: 40
  px_per_mm: 2
decompose:
  layers: 2
"""


def _child(args: list[str]) -> dict:
    return limits_hostile.child_row(_CHILD, args)


def _make(path: Path, w: int, h: int) -> None:
    subprocess.run([sys.executable, "-c", _MAKE, str(path), str(w), str(h)], check=True)


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("exit", "seconds", "peak_mb")


def smoke():
    """The small image's load and three hostile inputs, each refused at once."""
    yield from run(["baseline", "profile_alias_bomb", "dev_zero_config", "fifo_image"])


def run(cases=None):
    cases = cases or CASES
    with tempfile.TemporaryDirectory(prefix="stencil_limits_") as tmp:
        tmp = Path(tmp)
        cfg = tmp / "limits.yaml"
        cfg.write_text(CONFIG)
        base = None
        if "baseline" in cases or "dots_2000000" in cases:
            small = tmp / "small.jpg"
            _make(small, 400, 300)
            base = _child(["load", str(cfg), str(small)])
            if "baseline" in cases:
                yield {"bench": "limits", "case": "baseline", "image_px": [400, 300], **base}
        for case, size in (("png_15000", (15000, 15000)), ("jpeg_48mp", (8000, 6000))):
            if case not in cases:
                continue
            img = tmp / (case + (".png" if case.startswith("png") else ".jpg"))
            _make(img, *size)
            row = _child(["load", str(cfg), str(img)])
            row.update(
                bench="limits", case=case, image_px=list(size), file_mb=round(img.stat().st_size / 1e6, 2)
            )
            row["targets"] = {"peak_mb": 600, "seconds": 10}
            row["met"] = (
                row.get("exit") == 0 and row.get("peak_mb", 1e9) <= 600 and row.get("seconds", 1e9) <= 10
            )
            if base:
                row["vs_baseline"] = {
                    "seconds": round(row.get("seconds", 0) / base["seconds"], 2),
                    "peak_mb": round(row.get("peak_mb", 0) / base["peak_mb"], 2),
                }
            img.unlink()
            yield row
        if "dots_2000000" in cases:
            src = tmp / "base"
            small = tmp / "small.jpg"
            _child(["decompose", str(cfg), "--image", str(small), "--out", str(src), "-q"])
            rows = {}
            for case, extra in (("dots_null", ""), ("dots_2000000", "stipple:\n  dots: 2000000\n")):
                job = tmp / f"{case}.yaml"
                job.write_text(
                    CONFIG.replace("  px_per_mm: 2\n", "  height_mm: 30\n  px_per_mm: 2\n") + extra
                )
                row = _child(["stipple", str(job), "--out", str(src), "--force", "-q"])
                man = json.loads((src / "manifest.json").read_text())
                row["stage_seconds"] = {
                    k: man["seconds"].get(k) for k in ("stipple", "refine") if k in man["seconds"]
                }
                row["dots"] = [r["dots"] for r in man.get("stipple", [])]
                row.update(bench="limits", case=case, picture_mm=[40, 30])
                rows[case] = row
            row = rows["dots_2000000"]
            row["capped"] = "cannot fit" in row.get("stderr", "")
            base = rows["dots_null"]
            row["vs_dots_null"] = {
                k: round(row[k] / base[k], 2) for k in ("seconds", "cpu_seconds", "peak_mb") if base.get(k)
            }
            row["targets"] = {"peak_mb": 500, "cpu_seconds": 5}
            row["met"] = (
                row.get("exit") in (0, 2)
                and row.get("peak_mb", 1e9) <= 500
                and row.get("cpu_seconds", 1e9) <= 5
            )
            yield base
            yield row
    yield from limits_hostile.run([c for c in cases if c in limits_hostile.CASES])
