"""Print time, filament and the holes as printed, from PrusaSlicer's own G-code (issue 35).

`python -m benchmarks printed` prints one JSON line per case:

* ``radius_<r>`` — a small test plate with holes of r = 0.5, 0.75, 1.0 and 1.5 mm at the FDM
  preset's web (0.6 mm), sliced with the shipped ``prusa_fdm`` profile twice: holes drawn as
  asked and drawn larger by the FDM ``stipple.hole_offset_mm``. Per radius the asked open area
  (``open_area_model``, mm² per hole), the mean open area drawn from layer 3 of the compensated
  plate's G-code at its extrusion widths (``open_area_gcode``), ``open_area_error``
  (gcode / model − 1) and its worst hole, the same for the uncompensated plate
  (``*_uncompensated``) and for the compensated plate's first layer (``*_first_layer``: all of a
  one-layer plate, in the profile's wider first-layer lines), with the plate's ``print_hours`` and
  ``filament_m``;
* ``web_<w>`` — the same plate at webs of 0.4, 0.5, 0.6, 0.7 and 0.8 mm: per radius the least plastic
  the G-code lays on a web (``web_min_mm_r<r>``) and the webs with under half their width laid
  (``webs_broken_r<r>``), on layer 3 and on the first layer (``*_first_layer``); the FDM preset's
  web is the thinnest with none broken on layer 3, its one-layer web the thinnest on the first;
* ``example_layer_NN`` / ``example_wall`` — the bundled example's parts sliced as
  ``stencil-cad slice`` slices them (walls sparse, :data:`stencil_cad.slicing.WALL_SETTINGS`):
  ``print_hours``, ``filament_m``, the plates' open areas (every hole of layer 3), and the job's
  S-CIELAB at 1 m with the holes compensated (``scielab_after``, the example as shipped) and
  drawn as asked (``scielab_before``, ``stipple.compensate: false``; both simulations spray the
  holes as made). The two jobs run into a temporary folder unless ``STENCIL_BENCH_PRINTED_DIR``
  and ``STENCIL_BENCH_PRINTED_BEFORE_DIR`` name folders that ``stencil-cad run`` wrote.

* ``cost_<job>_<part>`` / ``cost_<job>_total`` — the cost model's estimate against the slicer's,
  per part and in total, for the example and a small mural (:mod:`benchmarks.printed_cost`); the
  mural rows also give each part's and the total's slicer hours and grams per m² of picture and the
  job's S-CIELAB at its viewing distance (``--case mural600``: the same for the 600 x 400 mm mural;
  ``--case mural1m``: for a 1,225 x 817 mm one, 1 m²).

Every slice is killed after ``STENCIL_BENCH_PRINTED_TIMEOUT`` seconds (default 900).
"""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from stencil_cad import slicing as sl
from stencil_cad.config.process import Process
from stencil_cad.exchange.mesh import plate_mesh, read_stl, stl_bytes
from stencil_cad.model import PlateGeometry
from stencil_cad.slicing import gcode
from stencil_cad.stipple.made import drawn_radii

RADII = (0.5, 0.75, 1.0, 1.5)
#: The test plate's web: the FDM preset's, every pair of neighbours at it.
WEB_MM = Process.fdm.record.web_mm
#: Webs the ``web_<w>`` cases print, to find the thinnest the shipped profile lays whole.
WEBS_MM = (0.4, 0.5, 0.6, 0.7, 0.8)
PX_MM = 0.025
LAYER = 2  # layer 3, an inner layer (the first carries the elephant-foot compensation)
#: The first layer: all of a one-layer plate (a soft FDM mural's), laid in the profile's wider
#: first-layer lines and shrunk by its elephant-foot compensation.
FIRST = 0


def _timeout() -> float:
    return float(os.environ.get("STENCIL_BENCH_PRINTED_TIMEOUT", "900"))


def radius_holes(web_mm: float = WEB_MM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three hex rows of six holes per radius; returns centres, radii and the plate's (W, H)."""
    xy, rr, y0 = [], [], 3.0
    for r in RADII:
        pitch = 2 * r + web_mm
        for row in range(3):
            for i in range(6):
                xy.append(
                    (3 + r + i * pitch + (row % 2) * pitch / 2, y0 + r + row * pitch * math.sqrt(3) / 2)
                )
                rr.append(r)
        y0 += 2 * r + 2 * pitch * math.sqrt(3) / 2 + 3
    holes = np.array(xy)
    return holes, np.array(rr), np.array([float(holes[:, 0].max() + 4.5), y0])


def write_radius_plate(path: Path, xy: np.ndarray, r: np.ndarray, size: np.ndarray) -> None:
    """Write the test plate with holes drawn at radii ``r``."""
    width, height = (float(v) for v in size)
    outline = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    geom = PlateGeometry(
        width_mm=width, height_mm=height, thickness_mm=1.2, outline=outline, circles_xy=xy, circles_r=r
    )
    path.write_bytes(stl_bytes(plate_mesh(geom)))


def measured_areas(
    gcode_path: Path, xy: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray, layer_index: int = LAYER
) -> np.ndarray:
    """Open area (mm²) of every hole on layer 3 (or ``layer_index``) of the G-code; holes in the plate's own frame."""
    layer = gcode.layer_paths(gcode_path, layer_index)
    shift = gcode.align_shift(layer, lo, hi)
    covered = gcode.rasterise(layer, lo + shift, tuple(hi - lo), PX_MM)
    return gcode.hole_open_areas(covered, lo + shift, PX_MM, xy + shift, r)


def web_material(
    gcode_path: Path,
    xy: np.ndarray,
    r: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    web_mm: float,
    layer_index: int = LAYER,
) -> np.ndarray:
    """Plastic (mm) laid on layer 3 (or ``layer_index``) along the centre line between each hole and its right-hand neighbour.

    The neighbours are the holes of one hex row at the pitch ``2 r + web_mm``: the segment from one
    designed edge to the next is the web as asked; the plastic on it is what the printer made.
    """
    layer = gcode.layer_paths(gcode_path, layer_index)
    shift = gcode.align_shift(layer, lo, hi)
    covered = gcode.rasterise(layer, lo + shift, tuple(hi - lo), PX_MM)
    h_px = covered.shape[0]
    out = []
    for i in range(len(xy) - 1):
        gap = xy[i + 1] - xy[i]
        if abs(gap[1]) > 1e-6 or abs(np.hypot(*gap) - (r[i] + r[i + 1] + web_mm)) > 1e-6:
            continue  # not neighbours in a row
        t = np.linspace(r[i], r[i] + web_mm, max(2, int(web_mm / PX_MM)))
        x = (xy[i, 0] + t) / PX_MM
        y = h_px - xy[i, 1] / PX_MM
        on = covered[np.clip(int(y), 0, h_px - 1), np.clip(x.astype(int), 0, covered.shape[1] - 1)]
        out.append(float(on.mean()) * web_mm)
    return np.array(out)


def web_cases(tmp: Path):
    """Per web of :data:`WEBS_MM`: the plastic the G-code lays on every web, per hole radius.

    Holes drawn larger by the FDM offset with the web rule kept as made (as the job draws them).
    A web the printer leaves out shows here (``webs_broken``: under half its width laid), not as a
    larger hole: the open-area count stops at the designed circle.
    """
    offset = Process.fdm.record.hole_offset_mm
    for web in WEBS_MM:
        xy, asked, size = radius_holes(web)
        stl, out = tmp / f"web_{web:g}.stl", tmp / f"web_{web:g}.gcode"
        write_radius_plate(stl, xy, drawn_radii(xy, asked, offset, web - 2 * offset), size)
        common, _ = _slice(stl, out)
        row: dict = {"bench": "printed", "case": f"web_{web:g}", **common, "web_mm": web}
        if common["ok"]:
            for radius in RADII:
                m = asked == radius
                for suffix, index in (("", LAYER), ("_first_layer", FIRST)):
                    laid = web_material(out, xy[m], asked[m], np.zeros(2), size, web, index)
                    row[f"web_min_mm_r{radius:g}{suffix}"] = round(float(laid.min()), 3)
                    row[f"webs_broken_r{radius:g}{suffix}"] = int((laid < 0.5 * web).sum())
        yield row


def _slice(stl: Path, out: Path) -> tuple[dict, float]:
    start = time.perf_counter()
    result = sl.slice_plate(
        stl, out, "prusa_fdm", timeout_s=_timeout(), overrides=sl.part_settings("prusa_fdm", stl)
    )
    row: dict = {"ok": result.ok, "slice_seconds": round(time.perf_counter() - start, 1)}
    if result.ok:
        est = gcode.read_estimate(out)
        row["print_hours"] = None if est.print_hours is None else round(est.print_hours, 3)
        row["filament_m"] = None if est.filament_m is None else round(est.filament_m, 2)
    else:
        row["errors"] = list(result.errors)[:2]
    return row, start


def radius_cases(tmp: Path):
    """Per radius: open area drawn as asked (uncompensated) and drawn larger by the FDM offset.

    The compensated plate keeps the web rule as made (:func:`stencil_cad.stipple.made.drawn_dots`):
    its drawn webs are 2 x the offset under the preset's web.
    """
    xy, asked, size = radius_holes()
    offset = Process.fdm.record.hole_offset_mm
    measured = {}
    for name, drawn in (
        ("asked", asked),
        ("compensated", drawn_radii(xy, asked, offset, WEB_MM - 2 * offset)),
    ):
        stl, out = tmp / f"radii_{name}.stl", tmp / f"radii_{name}.gcode"
        write_radius_plate(stl, xy, drawn, size)
        common, _ = _slice(stl, out)
        if not common["ok"]:
            yield {"bench": "printed", "case": f"radius_plate_{name}", **common}
            return
        measured[name] = (
            common,
            measured_areas(out, xy, drawn, np.zeros(2), size),
            measured_areas(out, xy, drawn, np.zeros(2), size, FIRST),
        )
    common, area, first = measured["compensated"]
    before = measured["asked"][1]
    for radius in RADII:
        m = asked == radius
        model = math.pi * radius**2
        yield {
            "bench": "printed",
            "case": f"radius_{radius:g}",
            **common,
            "holes": int(m.sum()),
            "hole_offset_mm": offset,
            "open_area_model": round(model, 4),
            "open_area_gcode": round(float(area[m].mean()), 4),
            "open_area_error": round(float(area[m].mean()) / model - 1, 4),
            "open_area_error_worst": round(float((area[m] / model - 1).min()), 4),
            "open_area_gcode_uncompensated": round(float(before[m].mean()), 4),
            "open_area_error_uncompensated": round(float(before[m].mean()) / model - 1, 4),
            "open_area_gcode_first_layer": round(float(first[m].mean()), 4),
            "open_area_error_first_layer": round(float(first[m].mean()) / model - 1, 4),
        }


def _example_dirs(tmp: Path) -> tuple[Path, Path]:
    """The example as shipped (holes compensated) and with ``stipple.compensate: false``."""
    given = os.environ.get("STENCIL_BENCH_PRINTED_DIR")
    before = os.environ.get("STENCIL_BENCH_PRINTED_BEFORE_DIR")
    if given and before:
        return Path(given), Path(before)
    after_dir, before_dir = tmp / "example", tmp / "uncompensated"
    subprocess.run([sys.executable, "-m", "stencil_cad", "run", "--out", str(after_dir), "-q"], check=True)
    cfg = yaml.safe_load((after_dir / "config.yaml").read_text())
    cfg["stipple"]["compensate"] = False
    (tmp / "uncompensated.yaml").write_text(yaml.safe_dump(cfg))
    cmd = [
        sys.executable,
        "-m",
        "stencil_cad",
        "run",
        str(tmp / "uncompensated.yaml"),
        "--out",
        str(before_dir),
        "-q",
    ]
    subprocess.run(cmd, check=True)
    return after_dir, before_dir


def _dots(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with path.open() as fh:
        rows = [(float(d["x_mm"]), float(d["y_mm"]), float(d["r_mm"])) for d in csv.DictReader(fh)]
    arr = np.array(rows)
    return arr[:, :2], arr[:, 2]


def example_cases(tmp: Path):
    folder, before_dir = _example_dirs(tmp)
    scielab = json.loads((folder / "manifest.json").read_text()).get("simulate", {}).get("scielab")
    before = json.loads((before_dir / "manifest.json").read_text()).get("simulate", {}).get("scielab")
    parts = sorted(folder.glob("layer_[0-9][0-9].stl")) + sorted(folder.glob("wall*.stl"))
    hours = metres = 0.0
    for stl in parts:
        out = tmp / (stl.stem + ".gcode")
        row, _ = _slice(stl, out)
        row = {"bench": "printed", "case": f"example_{stl.stem}", **row}
        row.update(scielab_before=before, scielab_after=scielab)
        hours += row.get("print_hours") or 0.0
        metres += row.get("filament_m") or 0.0
        dots = folder / f"{stl.stem}_dots.csv"
        if row["ok"] and dots.is_file():
            xy, r = _dots(dots)
            pts = read_stl(stl).reshape(-1, 3)[:, :2]
            area = measured_areas(out, xy, r, pts.min(axis=0), pts.max(axis=0))
            model = float((math.pi * r**2).sum())
            row.update(
                holes=len(r),
                open_area_model=round(model, 2),
                open_area_gcode=round(float(area.sum()), 2),
                open_area_error=round(float(area.sum()) / model - 1, 4),
                holes_closed=int((area == 0).sum()),
            )
        out.unlink(missing_ok=True)
        yield row
    yield {
        "bench": "printed",
        "case": "example_total",
        "print_hours": round(hours, 3),
        "filament_m": round(metres, 2),
        "scielab_before": before,
        "scielab_after": scielab,
    }


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("open_area_model", "open_area_gcode", "open_area_error", "print_hours", "filament_m")


def smoke():
    """The radius test plate (every radius, compensated and not), sliced with the shipped FDM profile."""
    yield from run(["radius"])


def run(cases: list[str] | None = None):
    """Yield the rows; ``cases`` picks ``radius``, ``web``, ``example``, ``cost``, ``mural600`` and/or ``mural1m`` (the first four by default)."""
    if sl.find_slicer(sl.Slicer.PRUSA) is None:
        yield {"bench": "printed", "case": "all", "skipped": "prusa-slicer not installed"}
        return
    wanted = cases or ["radius", "web", "example", "cost"]
    with tempfile.TemporaryDirectory(prefix="stencil_printed_") as tmp:
        if "radius" in wanted:
            yield from radius_cases(Path(tmp))
        if "web" in wanted:
            yield from web_cases(Path(tmp))
        if "example" in wanted:
            yield from example_cases(Path(tmp))
        if {"cost", "mural600", "mural1m"} & set(wanted):
            from .printed_cost import cost_cases

            jobs = (("example", "mural") if "cost" in wanted else ()) + tuple(
                j for j in ("mural600", "mural1m") if j in wanted
            )
            yield from cost_cases(Path(tmp), jobs)
