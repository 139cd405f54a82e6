"""Check a mural's output folder from its files, independently of the run that wrote it.

Usage: ``python -m benchmarks.mural_check OUT [--bed X Y]``. Prints one JSON object:

* ``tiles``, ``plates``, ``walls``; the largest plate and wall bounding box (mm, from the
  manifest's solid checks) and whether each fits the bed (either way round);
  ``all_valid`` (every plate and wall one valid solid);
* ``holes_dxf``: the holes read back from every tile's DXF with ezdxf, and ``holes_csv``
  from the mural's ``layer_NN_dots.csv``; ``same_holes``: the DXFs' holes, moved from each
  tile's part frame to mural coordinates (each post's pin hole left out), are the CSV's holes one to one as the plates draw
  them (:func:`stencil_cad.stipple.made.drawn_dots`, compensated for the process; to 0.001 mm:
  the CSV keeps four decimals);
* ``union_rules``: :func:`stencil_cad.stipple.rules.check_rules` on the DXFs' holes of each
  layer in mural coordinates as the process makes them (each radius less
  ``stipple.hole_offset_mm``; the web at its minimum, no hole under the 0.5 mm floor by more than
  the offset) (``"passed"``
  or the error);
* ``seam_ratio_flank`` / ``seam_ratio_global``: the range of the hole density within 5 mm
  of each seam over the strips beside it, and over the whole mural;
* the scores in register (the global simulation's: the tiled one equals it, as the tests check)
  and the registration-cost rows from the manifest.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def _dxf_holes(path: Path) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    import ezdxf

    doc = ezdxf.readfile(str(path))
    custom = dict(doc.header.custom_vars)
    offset = (float(custom["STENCIL_OFFSET_X_MM"]), float(custom["STENCIL_OFFSET_Y_MM"]))
    circles = [(e.dxf.center.x, e.dxf.center.y, e.dxf.radius) for e in doc.modelspace().query("CIRCLE")]
    arr = np.array(circles, dtype=np.float64).reshape(-1, 3)
    return arr[:, :2], arr[:, 2], offset


def _same_holes(
    xy: np.ndarray, r: np.ndarray, xy_ref: np.ndarray, r_ref: np.ndarray, tol: float = 1e-3
) -> bool:
    """One-to-one the same holes to ``tol`` mm (the dots CSV keeps four decimals)."""
    from scipy.spatial import cKDTree

    if len(xy) != len(xy_ref):
        return False
    if len(xy) == 0:
        return True
    d, i = cKDTree(xy_ref).query(xy)
    return bool(d.max() <= tol and np.abs(r - r_ref[i]).max() <= tol and len(np.unique(i)) == len(i))


def check(out: Path, bed: tuple[float, float] | None = None) -> dict:
    from dataclasses import replace

    from stencil_cad.config import io as cfg_io
    from stencil_cad.config.stipple import HOLE_FLOOR_MM
    from stencil_cad.exchange.dots_csv import dots_from_csv
    from stencil_cad.stipple.made import drawn_dots
    from stencil_cad.stipple.rules import CHECK_TOL_MM, check_rules

    m = json.loads((out / "manifest.json").read_text())
    mural = m["mural"]
    if bed is None:
        bed = (mural["bed"]["x_mm"], mural["bed"]["y_mm"])
    plates, walls = m["build"]["plates"], m["build"]["walls"]

    def fits(w: float, h: float) -> bool:
        return (w <= bed[0] and h <= bed[1]) or (h <= bed[0] and w <= bed[1])

    pb = [p["bbox_mm"] for p in plates]
    wb = []
    for w in walls:
        b = w["bbox"]
        wb.append([b[3] - b[0], b[4] - b[1]])
    # The plates are drawn in their part frame (older manifests: the sheet's).
    sheets = {t["tile"]: t.get("part_mm") or t["sheet_mm"] for t in mural["tiles"]}
    sites = (mural.get("posts") or {}).get("sites_mm") or {}
    cfg = cfg_io.parse_config(m["config"], source="manifest")
    layers = len(m["stipple"])
    width, height = m["picture"]["width_mm"], m["picture"]["height_mm"]
    design = cfg.stipple.design_rules(width, height)
    rules = replace(design, hole_min_r_mm=min(design.hole_min_r_mm, HOLE_FLOOR_MM))
    offset = cfg.stipple.sizes.hole_offset_mm
    same, union_rules, n_dxf, n_csv = True, "passed", 0, 0
    for i in range(layers):
        xy_all, r_all = [], []
        for tile, sheet in sheets.items():
            path = out / f"tile_{tile}_layer_{i + 1:02d}.dxf"
            xy, r, off = _dxf_holes(path)
            xy = xy - np.array(off) + np.array(sheet[:2])
            # A post's pin hole is no spray hole: drop the hole drawn at each post's site.
            for site in sites.get(f"{tile} {i + 1}", []):
                keep = np.hypot(*(xy - np.array(site)).T) > 0.01
                xy, r = xy[keep], r[keep]
            xy_all.append(xy)
            r_all.append(r)
        xy = np.concatenate(xy_all)
        r = np.concatenate(r_all)
        n_dxf += len(r)
        ref = dots_from_csv((out / f"layer_{i + 1:02d}_dots.csv").read_text())
        n_csv += len(ref)
        drawn = drawn_dots(ref, cfg.stipple, (width, height))
        same &= _same_holes(xy, r, drawn.xy_mm, drawn.r_mm)
        try:
            # A hole the picture's edge keeps from growing is made up to the offset under the floor.
            check_rules(xy, np.maximum(r - offset, 0.0), rules, CHECK_TOL_MM + max(offset, 0.0))
        except ValueError as exc:
            union_rules = f"layer {i + 1}: {exc}"
    seams = mural.get("seam_density", [])
    sim = mural.get("simulation", {})
    return {
        "tiles": len(sheets),
        "plates": len(plates),
        "walls": len(walls),
        "bed_mm": list(bed),
        "largest_plate_mm": [round(max(b[0] for b in pb), 2), round(max(b[1] for b in pb), 2)],
        "largest_wall_mm": [round(max(b[0] for b in wb), 2), round(max(b[1] for b in wb), 2)],
        "plates_fit": all(fits(*b) for b in pb),
        "walls_fit": all(fits(*b) for b in wb),
        "all_valid": all(p.get("valid") and p.get("n_solids") == 1 for p in plates)
        and all(w.get("valid") and w.get("n_solids", 1) == 1 for w in walls),
        "holes_dxf": n_dxf,
        "holes_csv": n_csv,
        "same_holes": bool(same),
        "union_rules": union_rules,
        "seam_ratio_flank": [min(s["ratio_flank"] for s in seams), max(s["ratio_flank"] for s in seams)]
        if seams
        else None,
        "seam_ratio_global": [min(s["ratio_global"] for s in seams), max(s["ratio_global"] for s in seams)]
        if seams
        else None,
        "zero_error_scores": sim.get("zero_error_scores"),
        "registration_cost": sim.get("registration_cost"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.mural_check", description=__doc__)
    parser.add_argument("out", type=Path, help="a mural's output folder")
    parser.add_argument(
        "--bed", type=float, nargs=2, metavar=("X", "Y"), help="bed in mm (default: the job's)"
    )
    args = parser.parse_args(argv)
    print(json.dumps(check(args.out, tuple(args.bed) if args.bed else None)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
