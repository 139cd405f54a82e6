"""A maker's 600 mm mural, part by part: every tile plate and wall sliced on the bed it was sized for.

`python -m benchmarks mural_parts` runs the mural of issue 36 (scikit-image's ``coffee`` photo,
600 mm wide, 3 layers, FDM, ``bed: prusa_mk4``: 10 tiles, 30 plates, 10 walls), then
``stencil-cad slice --bed prusa_mk4`` on every tile plate and wall STL, one at a time, and
checks the files a maker needs: one SVG and one DXF per plate with the label on its score layer.
Prints one JSON line for the job (``seconds``, ``plates``, ``walls``, ``svgs``, ``labelled``)
and one per sliced part (``part``, ``size_mm``, ``turned``, ``exit``, ``seconds``, ``gcode_bytes``,
``print_time``), then a summary row (``sliced_ok`` of ``parts``).

Cases (``--case``): ``all`` (default, every part; about 40 slicer runs) or ``sample`` (the first
tile's plates and wall plus one plate of the last tile).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

MURAL = {
    "name": "coffee mural",
    "size": {"width_mm": 600, "px_per_mm": "auto"},
    "bed": "prusa_mk4",
    "decompose": {"layers": 3},
    "stipple": {"process": "fdm"},
}


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds",)
#: The smoke case's mural: 170 mm wide in two layers on a 180 mm bed.
SMOKE_MURAL = {
    **MURAL,
    "name": "small mural",
    "size": {"width_mm": 200, "px_per_mm": "auto"},
    "bed": "prusa_mini",
}
SMOKE_MURAL["decompose"] = {"layers": 2}


def _job(tmp: Path, mural: dict = MURAL) -> tuple[dict, Path]:
    from PIL import Image
    from skimage import data

    image = tmp / "coffee.png"
    Image.fromarray(data.coffee()).save(image)
    cfg = tmp / "mural.yaml"
    cfg.write_text(yaml.safe_dump({**mural, "image": str(image)}))
    out = tmp / "out"
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "stencil_cad", "run", str(cfg), "--out", str(out), "-q", "--workers", "0"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        raise RuntimeError(f"the mural job failed (exit {r.returncode}): {r.stderr[-500:]}")
    seconds = time.perf_counter() - t0
    return _files_row(out, seconds), out


def _files_row(out: Path, seconds: float) -> dict:
    import ezdxf

    m = json.loads((out / "manifest.json").read_text())
    plates = m["build"]["plates"]
    labelled = 0
    for p in plates:
        doc = ezdxf.readfile(out / f"{p['file']}.dxf")
        score = doc.modelspace().query(f'LWPOLYLINE[layer=="{p["file"].upper()}_SCORE"]')
        svg = (out / f"{p['file']}.svg").read_text()
        labelled += int(len(score) > 0 and 'id="score"' in svg)
    return {
        "bench": "mural_parts",
        "case": "job",
        "seconds": round(seconds, 1),
        "tiles": len(m["mural"]["tiles"]),
        "plates": len(plates),
        "walls": len(m["build"]["walls"]),
        "svgs": sum(1 for p in plates if (out / f"{p['file']}.svg").is_file()),
        "labelled": labelled,
    }


def _parts(out: Path, sample: bool) -> list[Path]:
    m = json.loads((out / "manifest.json").read_text())
    plates = [out / f"{p['file']}.stl" for p in m["build"]["plates"]]
    walls = [out / w["file"].replace(".step", ".stl") for w in m["build"]["walls"]]
    if sample:
        first = m["mural"]["tiles"][0]["tile"]
        return [p for p in plates + walls if f"tile_{first}_" in p.name] + [plates[-1]]
    return plates + walls


def _slice(stl: Path, bed: str = "prusa_mk4") -> dict:
    from stencil_cad import slicing

    size = slicing.stl_footprint(stl)
    t0 = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "stencil_cad", "slice", "--bed", bed, "--force", str(stl)],
        capture_output=True,
        text=True,
    )
    gcode = stl.with_suffix(".gcode")
    row = {
        "bench": "mural_parts",
        "case": "slice",
        "part": stl.name,
        "size_mm": [round(v, 1) for v in size],
        "turned": "turned 90°" in r.stdout,
        "exit": r.returncode,
        "seconds": round(time.perf_counter() - t0, 1),
        "gcode_bytes": gcode.stat().st_size if gcode.is_file() else 0,
    }
    if gcode.is_file():
        row["print_time"] = slicing.gcode_summary(gcode).get("print_time")
        gcode.unlink()
    if r.returncode:
        row["error"] = r.stderr[-300:]
    return row


def run(cases=None):
    sample = bool(cases) and "sample" in cases and "all" not in cases
    with tempfile.TemporaryDirectory(prefix="bench_mural_parts_") as tmp:
        job, out = _job(Path(tmp))
        yield job
        rows = []
        for stl in _parts(out, sample):
            rows.append(_slice(stl))
            yield rows[-1]
        yield {
            "bench": "mural_parts",
            "case": "sample" if sample else "all",
            "seconds": round(sum(r["seconds"] for r in rows), 1),
            "parts": len(rows),
            "sliced_ok": sum(1 for r in rows if r["exit"] == 0),
            "turned": sum(1 for r in rows if r["turned"]),
        }


def smoke():
    """A 170 mm mural on a 180 mm bed; its first tile's first plate and its wall sliced on that bed."""
    with tempfile.TemporaryDirectory(prefix="bench_mural_parts_") as tmp:
        job, out = _job(Path(tmp), SMOKE_MURAL)
        yield {**job, "case": "smoke-job"}
        parts = _parts(out, sample=True)
        for stl in [parts[0], next(p for p in parts if "wall" in p.name)]:
            yield {**_slice(stl, SMOKE_MURAL["bed"]), "case": "smoke-slice"}
