"""Slice perforated plates with every shipped profile and time the slicer (issue 8).

`python -m benchmarks slicer` prints one JSON line per case with ``bench``,
``case``, ``holes``, ``seconds`` (wall clock), ``cpu_seconds`` (the slicer's
user + system time, robust when other jobs share the machine), ``slicer``,
``profile``, ``tiles`` and whether the run finished cleanly.

Plates: ``W x H x 1.2 mm`` with ``N`` round holes (r = 1 mm) on a jittered hex
grid of 2.8 mm pitch (webs about 0.8 mm), so the plate area grows with ``N``.
They are meshed with the project's own mesher (``stencil_cad.exchange.mesh``); when
it cannot be imported, a manifold3d fallback (24-segment holes) is used and
every row says ``"mesher": "manifold3d-fallback"``.

Cases (``--case``): ``<profile>_<holes>`` for the shipped profiles and
``prusa_defaults_<holes>`` (PrusaSlicer's own defaults, the baseline of issue
8, measured in the same run), e.g. ``prusa_fdm_4000`` (the shipped path: plates
with more than 450 holes are split into tiles of about 300 holes, and
``seconds`` includes the split), ``prusa_fdm_whole_4000`` (the same profile on
the whole plate as one object), ``prusa_sla_1000``, ``cura_fdm_250``,
``laser_dxf_14000``. ``prusa_fdm_14000`` and ``prusa_sla_14000`` run only when
named with ``--case`` or when ``STENCIL_BENCH_SLICER_14000=1``. Every run is killed
after ``STENCIL_BENCH_SLICER_TIMEOUT`` seconds (default 600) and reported as
``timed_out``. Each row of a larger plate carries ``x_vs_250``: its CPU time
over the same profile's 250-hole CPU time from this run (the issue's bound is
≤ 20 at 4,000 holes).
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from stencil_cad import slicing as sl
from stencil_cad.exchange.mesh import write_triangles_stl

HOLES = (250, 1000, 4000, 14000)
PITCH_MM = 2.8
RADIUS_MM = 1.0
THICKNESS_MM = 1.2
MARGIN_MM = 3.0

# (case prefix, profile, tiles): tiles None = the shipped path (`slicer.slice_plate`, which tiles
# a PrusaSlicer FDM plate with many holes), False = the whole plate as one object.
# "laser_dxf" is the laser path (no slicer: the DXF is the toolpath).
PROFILE_CASES = (
    ("prusa_defaults", None, False),
    ("prusa_fdm", "prusa_fdm", None),
    ("prusa_fdm_whole", "prusa_fdm", False),
    ("prusa_sla", "prusa_sla", False),
    ("cura_fdm", "cura_fdm", False),
    ("laser_dxf", "laser_dxf", False),
)
# PrusaSlicer's defaults are the baseline: slow, so only the small plates run by default.
DEFAULT_HOLES = {
    "prusa_defaults": (250, 1000),
    "prusa_fdm": (250, 1000, 4000),
    "prusa_fdm_whole": (250, 1000),
    "prusa_sla": (250, 1000, 4000),
    "cura_fdm": (250, 1000),
    "laser_dxf": (250, 1000, 4000, 14000),
}
#: Paths that also run the 14,000-hole plate with STENCIL_BENCH_SLICER_14000=1 (the shipped,
#: linear-time ones; the others are known to take far longer than the timeout there).
BIG = ("prusa_fdm", "prusa_sla", "laser_dxf")
#: Cutting speed assumed for the laser time estimate, mm/s (3 mm plywood / acrylic on a 40-60 W CO2 laser).
LASER_SPEED_MM_S = 10.0


def hole_centres(n: int, seed: int = 0) -> tuple[np.ndarray, float, float]:
    """``n`` hole centres on a jittered hex grid and the plate size ``(W, H)`` in mm that holds them."""
    rng = np.random.default_rng(seed)
    cols = int(math.ceil(math.sqrt(n * 2 / math.sqrt(3))))
    rows = int(math.ceil(n / cols))
    jj, ii = np.meshgrid(np.arange(cols), np.arange(rows))
    x = jj * PITCH_MM + (ii % 2) * PITCH_MM / 2
    y = ii * PITCH_MM * math.sqrt(3) / 2
    xy = np.c_[x.ravel(), y.ravel()][:n].astype(float)
    xy += rng.uniform(-0.15, 0.15, xy.shape) * (PITCH_MM - 2 * RADIUS_MM - 0.5)
    xy += MARGIN_MM + RADIUS_MM
    width = float(xy[:, 0].max() + RADIUS_MM + MARGIN_MM)
    height = float(xy[:, 1].max() + RADIUS_MM + MARGIN_MM)
    return xy, width, height


def write_plate(n: int, path: Path) -> dict:
    """Write an ``n``-hole test plate as STL; return how it was made."""
    xy, width, height = hole_centres(n)
    start = time.perf_counter()
    try:
        from stencil_cad.exchange.mesh import plate_mesh, stl_bytes
        from stencil_cad.model import PlateGeometry

        outline = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
        geom = PlateGeometry(
            width_mm=width,
            height_mm=height,
            thickness_mm=THICKNESS_MM,
            outline=outline,
            circles_xy=xy,
            circles_r=np.full(n, RADIUS_MM),
        )
        mesh = plate_mesh(geom)
        path.write_bytes(stl_bytes(mesh))
        mesher, facets = "stencil_cad.exchange.mesh", int(len(mesh.faces))
    except ImportError:
        import manifold3d as m3d

        sheet = m3d.CrossSection.square([width, height])
        circle = m3d.CrossSection.circle(RADIUS_MM, 24)
        holes = m3d.CrossSection.compose([circle.translate([float(a), float(b)]) for a, b in xy])
        mesh = m3d.Manifold.extrude(sheet - holes, THICKNESS_MM).to_mesh()
        corners = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3][np.asarray(mesh.tri_verts)]
        write_triangles_stl(path, corners)
        mesher, facets = "manifold3d-fallback", int(len(mesh.tri_verts))
    return {
        "mesher": mesher,
        "facets": facets,
        "plate_mm": [round(width, 1), round(height, 1), THICKNESS_MM],
        "mesh_seconds": round(time.perf_counter() - start, 2),
    }


def _overrides(profile: str | None, width: float, height: float) -> dict:
    """Bed (and SLA display) big enough for the plate, keeping the profile's pixel size."""
    bed_w = max(250.0, math.ceil(width + 20))
    bed_h = max(210.0, math.ceil(height + 20))
    if profile == "prusa_sla":
        if width <= 126 and height <= 79:
            return {}
        # Keep the SL1S pixel pitch (0.05 mm): this times the slicer, not a real printer.
        w, h = math.ceil(width + 4), math.ceil(height + 4)
        return {
            "bed_shape": f"0x0,{w}x0,{w}x{h},0x{h}",
            "display_width": w,
            "display_height": h,
            "display_pixels_x": int(round(w / 0.05)),
            "display_pixels_y": int(round(h / 0.05)),
            "display_orientation": "landscape",
        }
    if profile == "cura_fdm":
        return {"machine_width": bed_w, "machine_depth": bed_h}
    if width <= 230 and height <= 190:
        return {}
    return {"bed_shape": f"0x0,{bed_w}x0,{bed_w}x{bed_h},0x{bed_h}"}


def _defaults_profile() -> sl.Profile:
    """PrusaSlicer's built-in defaults (an empty config file), the issue's baseline."""
    path = Path(tempfile.gettempdir()) / "stencil_cad_prusa_defaults.ini"
    path.write_text("# PrusaSlicer built-in defaults\n")
    return sl.Profile(
        "prusa_defaults", sl.Slicer.PRUSA, sl.Technology.FFF, str(path), ".gcode", 0.2, "defaults"
    )


def _case_list(cases: list[str] | None) -> list[tuple[str, str, str | None, bool, int]]:
    all_cases = []
    for prefix, profile, tiled in PROFILE_CASES:
        for n in HOLES:
            all_cases.append((f"{prefix}_{n}", prefix, profile, tiled, n))
    if cases:
        known = {c[0] for c in all_cases}
        unknown = [c for c in cases if c not in known]
        if unknown:
            raise SystemExit(f"unknown slicer case(s) {unknown}; choose from {sorted(known)}")
        return [c for c in all_cases if c[0] in cases]
    big = os.environ.get("STENCIL_BENCH_SLICER_14000") == "1"
    return [c for c in all_cases if c[4] in DEFAULT_HOLES[c[1]] or (big and c[4] == 14000 and c[1] in BIG)]


#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("holes", "seconds", "ok", "profile")


def smoke():
    """The 250-hole plate with every shipped profile and the laser path (a slicer not installed: skipped)."""
    yield from run(["prusa_fdm_250", "prusa_sla_250", "cura_fdm_250", "laser_dxf_250"])


def run(cases: list[str] | None = None):
    """Yield one dict per (profile, hole count) case; see the module docstring."""
    timeout_s = float(os.environ.get("STENCIL_BENCH_SLICER_TIMEOUT", "600"))
    selected = _case_list(cases)
    base_cpu: dict[str, float] = {}
    base_wall: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="stencil_slicer_bench_") as tmp:
        tmpdir = Path(tmp)
        plates: dict[int, tuple[Path, dict, float, float]] = {}
        for name, prefix, profile, tiled, n in selected:
            if profile == "laser_dxf":
                yield _laser_case(name, n, tmpdir)
                continue
            prof = _defaults_profile() if profile is None else sl.get_profile(profile)
            row = {
                "bench": "slicer",
                "case": name,
                "holes": n,
                "slicer": prof.slicer.value,
                "profile": prefix,
            }
            exe = sl.find_slicer(prof.slicer)
            if exe is None or (prof.slicer is sl.Slicer.CURA and sl.find_cura_definitions() is None):
                yield row | {"seconds": None, "ok": False, "skipped": f"{prof.slicer.value} not installed"}
                continue
            if n not in plates:
                path = tmpdir / f"plate_{n}.stl"
                info = write_plate(n, path)
                _, width, height = hole_centres(n)
                plates[n] = (path, info, width, height)
            path, info, width, height = plates[n]
            models: list[Path] = [path]
            split_seconds = 0.0
            auto = tiled is None and sl.find_slicer() is not None
            if (
                auto
                and prof.technology is sl.Technology.FFF
                and prof.slicer is sl.Slicer.PRUSA
                and n > 1.5 * sl.HOLES_PER_TILE
            ):
                # The shipped path (what `slicer.slice_plate` does), timed in two parts.
                tile_dir = tmpdir / f"tiles_{n}"
                tile_dir.mkdir(exist_ok=True)
                t0 = time.perf_counter()
                models = sl.split_into_tiles(path, tile_dir)
                split_seconds = time.perf_counter() - t0
            out = tmpdir / f"{name}{prof.suffix}"
            res = sl.slice_file(
                models, out, prof, timeout_s=timeout_s, overrides=_overrides(profile, width, height)
            )
            row |= {
                "seconds": round(res.seconds + split_seconds, 2),
                "slicer_seconds": round(res.seconds, 2),
                "cpu_seconds": None if res.cpu_seconds is None else round(res.cpu_seconds, 2),
                "ok": res.ok,
                "timed_out": res.timed_out,
                "tiles": len(models),
                "split_seconds": round(split_seconds, 2),
                "output_bytes": res.output_bytes,
                "errors": list(res.errors)[:3],
                "load_avg": round(os.getloadavg()[0], 1),
            } | info
            if res.ok and prof.technology is sl.Technology.FFF:
                row["gcode"] = sl.gcode_summary(out)
                xy, _, _ = hole_centres(n)
                row |= gcode_coverage(out, xy, width, height)
            elif res.ok:
                row["sla_layers"] = sl.sla_layer_count(out)
            if n == 250 and res.ok and res.cpu_seconds:
                base_cpu[prefix] = res.cpu_seconds
                base_wall[prefix] = row["seconds"]
            elif prefix in base_cpu and res.ok and res.cpu_seconds:
                row["x_vs_250"] = round(res.cpu_seconds / base_cpu[prefix], 1)
                row["x_vs_250_wall"] = round(row["seconds"] / base_wall[prefix], 1)
            out.unlink(missing_ok=True)
            yield row


def _laser_case(name: str, n: int, tmpdir: Path) -> dict:
    """Laser path: write the DXF with the project's writer and read it back with GDAL when present."""
    import shutil
    import subprocess

    xy, width, height = hole_centres(n)
    row = {
        "bench": "slicer",
        "case": name,
        "holes": n,
        "slicer": "none (DXF is the toolpath)",
        "profile": "laser_dxf",
    }
    try:
        from stencil_cad.exchange.dxf import write_dxf
    except ImportError as exc:
        return row | {"seconds": None, "ok": False, "skipped": f"stencil_cad.exchange.dxf: {exc}"}
    path = tmpdir / f"{name}.dxf"
    outline = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    circles = np.c_[xy, np.full(n, RADIUS_MM)]
    start = time.perf_counter()
    info = write_dxf(path, outline, circles_xy_r=circles)
    seconds = time.perf_counter() - start
    cut_mm = float(2 * math.pi * RADIUS_MM * n + 2 * (width + height))
    row |= {
        "seconds": round(seconds, 2),
        "ok": info.circles == [n],
        "output_bytes": path.stat().st_size,
        "cut_length_mm": round(cut_mm),
        "laser_minutes_at_10mm_s": round(cut_mm / LASER_SPEED_MM_S / 60, 1),
        "plate_mm": [round(width, 1), round(height, 1)],
    }
    ogr = shutil.which("ogr2ogr")
    if ogr:
        start = time.perf_counter()
        geojson = tmpdir / f"{name}.geojson"
        proc = subprocess.run(
            [ogr, "-f", "GeoJSON", str(geojson), str(path)],
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        row["reader_seconds"] = round(time.perf_counter() - start, 2)
        row["reader"] = "ogr2ogr"
        if proc.returncode != 0:
            row["ok"] = False
            row["errors"] = [proc.stderr.strip()[-300:]]
        else:
            features = geojson.read_text().count('"type": "Feature"')
            row["reader_features"] = features
            row["ok"] = row["ok"] and features == n + 1
    path.unlink(missing_ok=True)
    return row


def _layer_paths(gcode: Path, layer_index: int) -> list[tuple[np.ndarray, float]]:
    """Extrusion polylines ``(points (K, 2) mm, width mm)`` of one layer, skirt and custom code left out.

    Reads PrusaSlicer (``;LAYER_CHANGE``, ``;WIDTH:``, ``;TYPE:``) and CuraEngine
    (``;LAYER:``, ``;TYPE:``; width 0.4 mm) G-code, relative or absolute E.
    """
    import re

    num = re.compile(r"([XYE])(-?[\d.]+)")
    layer, width, skip, relative = -1, 0.4, False, False
    x = y = e_last = 0.0
    paths: list[tuple[list, float]] = []
    current = None
    with gcode.open(errors="replace") as fh:
        for line in fh:
            if line.startswith((";LAYER_CHANGE", ";LAYER:")):
                layer += 1
                current = None
                if layer > layer_index:
                    break
            elif line.startswith(";WIDTH:"):
                width, current = float(line[7:]), None
            elif line.startswith(";TYPE:"):
                kind = line[6:].strip().lower()
                skip, current = kind.startswith(("skirt", "custom")), None
            elif line.startswith("M83"):
                relative = True
            elif line.startswith("M82"):
                relative = False
            elif line.startswith("G92"):
                m = re.search(r"E(-?[\d.]+)", line)
                e_last = float(m.group(1)) if m else e_last
            elif line.startswith(("G1 ", "G0 ")):
                vals = dict(num.findall(line.split(";", 1)[0]))
                nx, ny = float(vals.get("X", x)), float(vals.get("Y", y))
                extruding = False
                if "E" in vals:
                    e = float(vals["E"])
                    extruding = (e if relative else e - e_last) > 0 and ("X" in vals or "Y" in vals)
                    e_last = e_last if relative else e
                if extruding and layer == layer_index and not skip:
                    if current is None:
                        current = ([(x, y)], width)
                        paths.append(current)
                    current[0].append((nx, ny))
                else:
                    current = None
                x, y = nx, ny
    return [(np.asarray(p, dtype=float), w) for p, w in paths]


def gcode_coverage(
    gcode: Path, xy: np.ndarray, width: float, height: float, layer_index: int = 2, px: float = 0.05
) -> dict:
    """How well one layer's extrusion covers the plate: the print-quality side of a profile.

    Draws every extrusion of layer ``layer_index`` (0-based; layer 3 by default, an
    inner solid layer) at its width on a ``px`` mm raster, and the plate's exact sheet
    (outline minus round holes). The G-code is aligned to the plate by the centre of
    its extrusions' bounding box (slicers centre the plate on the bed).

    Returns:
        ``coverage``: share of the sheet covered by extrusion; ``hole_spill``: share
        of the hole area covered (holes printed too small); ``voids``: uncovered
        sheet blobs larger than 0.04 mm² (pin holes paint could pass through).
    """
    from PIL import Image, ImageDraw
    from scipy import ndimage

    paths = _layer_paths(gcode, layer_index)
    if not paths:
        return {"coverage": None}
    pts = np.concatenate([p for p, _ in paths])
    shift = (pts.min(axis=0) + pts.max(axis=0)) / 2 - np.array([width / 2, height / 2])
    w_px, h_px = int(np.ceil(width / px)), int(np.ceil(height / px))

    def to_px(p: np.ndarray) -> list[tuple[float, float]]:
        q = p / px
        return list(zip(q[:, 0].tolist(), (h_px - q[:, 1]).tolist(), strict=True))

    ext = Image.new("1", (w_px, h_px), 0)
    draw = ImageDraw.Draw(ext)
    for p, w in paths:
        q = to_px(p - shift)
        lw = max(1, int(round(w / px)))
        draw.line(q, fill=1, width=lw, joint="curve")
        for cx, cy in (q[0], q[-1]):
            draw.ellipse([cx - lw / 2, cy - lw / 2, cx + lw / 2, cy + lw / 2], fill=1)
    holes = Image.new("1", (w_px, h_px), 0)
    draw = ImageDraw.Draw(holes)
    rr = RADIUS_MM / px
    for cx, cy in to_px(xy):
        draw.ellipse([cx - rr, cy - rr, cx + rr, cy + rr], fill=1)
    ext_a = np.asarray(ext, dtype=bool)
    hole_a = np.asarray(holes, dtype=bool)
    sheet = ~hole_a
    # The outline's own pixel rounding is not a defect: leave a 2-pixel frame out.
    sheet[:2] = sheet[-2:] = False
    sheet[:, :2] = sheet[:, -2:] = False
    labels, _ = ndimage.label(sheet & ~ext_a)
    areas = np.bincount(labels.ravel())[1:] * px * px
    return {
        "coverage": round(float((ext_a & sheet).sum() / sheet.sum()), 4),
        "hole_spill": round(float((ext_a & hole_a).sum() / max(1, hole_a.sum())), 4),
        "voids": int((areas > 0.04).sum()),
    }
