"""Read PrusaSlicer G-code back: the slicer's estimates and the holes as they will print (kernel-free).

A plate's holes print smaller than drawn: the outer wall's width and the slicer's
polygon approximation of each circle eat into them. This module reads the G-code a
slicer wrote (``G1`` moves with ``E``, the ``;LAYER_CHANGE``, ``;TYPE:``, ``;WIDTH:`` and
``;HEIGHT:`` comments, the ``; estimated printing time (normal mode) = ...`` and
``; filament used [mm] = ...`` lines), draws the extrusions of one layer at their width
on a raster and measures how much of each designed hole stays open.

Frames: G-code coordinates are bed millimetres; the slicer centres the plate on the bed,
so :func:`align_shift` maps the plate's own frame onto the layer by the centre of the
extrusions' bounding box (the outer wall is inset by half its width on every side, which
keeps the centre).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "GcodeEstimate",
    "LayerPaths",
    "align_shift",
    "hole_open_areas",
    "layer_paths",
    "parse_duration",
    "rasterise",
    "read_estimate",
    "read_sl1_estimate",
]

_NUM = re.compile(r"([XYZEF])(-?\d*\.?\d+)")
_DURATION = re.compile(r"(\d+)\s*([dhms])")
_UNIT_S = {"d": 86400, "h": 3600, "m": 60, "s": 1}
#: Extrusion roles left out of a plate's layer: they are not part of the plate.
SKIPPED_ROLES = ("skirt", "skirt/brim", "brim", "custom", "wipe tower")


def parse_duration(text: str) -> float:
    """Seconds in a PrusaSlicer duration such as ``"1d 2h 47m 10s"`` or ``"36m 5s"``.

    Raises:
        ValueError: The text holds no ``<number><d|h|m|s>`` part.
    """
    parts = _DURATION.findall(text)
    if not parts:
        raise ValueError(f"not a duration: {text!r}")
    return float(sum(int(n) * _UNIT_S[u] for n, u in parts))


@dataclass(frozen=True)
class GcodeEstimate:
    """The slicer's own figures from a G-code file's header and footer.

    Attributes:
        print_s: Estimated printing time in seconds (normal mode), None when absent.
        filament_mm: Filament length in mm, None when absent.
        filament_g: Filament mass in grams, None when absent.
        layers: Number of ``;LAYER_CHANGE`` (or CuraEngine ``;LAYER:``) markers (SLA: layer images).
        resin_ml: Resin volume in ml (an SLA ``.sl1``), None for filament.
    """

    print_s: float | None
    filament_mm: float | None
    filament_g: float | None
    layers: int
    resin_ml: float | None = None

    @property
    def print_hours(self) -> float | None:
        """Estimated printing time in hours, None when the file has no estimate."""
        return None if self.print_s is None else self.print_s / 3600.0

    @property
    def filament_m(self) -> float | None:
        """Filament length in metres, None when the file does not say."""
        return None if self.filament_mm is None else self.filament_mm / 1000.0


def _first_number(value: str) -> float:
    # Multi-extruder files list one value per extruder: "1234.5, 0.0".
    return sum(float(v) for v in value.split(",") if v.strip())


def read_estimate(gcode: str | os.PathLike) -> GcodeEstimate:
    """The estimated printing time and filament a slicer wrote into ``gcode``.

    Reads PrusaSlicer's ``; estimated printing time (normal mode) = 4h 47m 10s``,
    ``; filament used [mm] = ...`` and ``; filament used [g] = ...`` lines, and
    CuraEngine's last ``;TIME_ELAPSED:`` and ``;Filament used: 1.23m``.

    Raises:
        OSError: The file cannot be read.
    """
    print_s = filament_mm = filament_g = elapsed = None
    layers = 0
    with Path(gcode).open(errors="replace") as fh:
        for line in fh:
            if line[0] != ";":
                continue
            if line.startswith((";LAYER_CHANGE", ";LAYER:")):
                layers += 1
            elif line.startswith("; estimated printing time (normal mode)"):
                print_s = parse_duration(line.split("=", 1)[1])
            elif line.startswith("; filament used [mm]"):
                filament_mm = _first_number(line.split("=", 1)[1])
            elif line.startswith("; filament used [g]"):
                filament_g = _first_number(line.split("=", 1)[1])
            elif line.startswith(";TIME_ELAPSED:"):
                elapsed = float(line[14:])
            elif line.startswith(";Filament used:") and filament_mm is None:
                filament_mm = 1000.0 * _first_number(line[15:].strip().rstrip("m"))
    if print_s is None and elapsed is not None:
        print_s = elapsed
    return GcodeEstimate(print_s=print_s, filament_mm=filament_mm, filament_g=filament_g, layers=layers)


def read_sl1_estimate(sl1: str | os.PathLike) -> GcodeEstimate:
    """The print time and resin PrusaSlicer wrote into an SLA ``.sl1`` archive's ``config.ini``.

    Raises:
        OSError: The file cannot be read.
        zipfile.BadZipFile: It is not a ``.sl1`` archive.
    """
    import zipfile

    with zipfile.ZipFile(sl1) as zf:
        text = zf.read("config.ini").decode("utf-8", errors="replace")
        layers = sum(1 for n in zf.namelist() if n.lower().endswith(".png") and "thumbnail" not in n.lower())
    values = {k.strip(): v.strip() for k, _, v in (line.partition("=") for line in text.splitlines())}

    def number(key: str) -> float | None:
        try:
            return float(values[key])
        except (KeyError, ValueError):
            return None

    return GcodeEstimate(number("printTime"), None, None, layers, resin_ml=number("usedMaterial"))


@dataclass(frozen=True)
class LayerPaths:
    """The extrusions of one layer.

    Attributes:
        z_mm: The layer's print height, None when the file does not say.
        paths: ``(points (K, 2) ndarray of float, mm; width mm; role)`` per continuous
            extrusion, in bed millimetres, in print order.
    """

    z_mm: float | None
    paths: tuple[tuple[np.ndarray, float, str], ...]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lowest and highest ``(x, y)`` of every extrusion point, mm."""
        pts = np.concatenate([p for p, _, _ in self.paths])
        return pts.min(axis=0), pts.max(axis=0)


class _State:
    """Position and mode of the G-code reader."""

    def __init__(self) -> None:
        self.x = self.y = self.z = self.e = 0.0
        self.relative_e = False
        self.width = 0.45
        self.role = ""


def _move(state: _State, line: str) -> tuple[float, float, bool]:
    """Apply one G0/G1 move; return the start point and whether it extruded in the plane."""
    vals = dict(_NUM.findall(line.split(";", 1)[0]))
    x0, y0 = state.x, state.y
    state.x = float(vals.get("X", state.x))
    state.y = float(vals.get("Y", state.y))
    state.z = float(vals.get("Z", state.z))
    extruded = False
    if "E" in vals:
        e = float(vals["E"])
        de = e if state.relative_e else e - state.e
        state.e = state.e if state.relative_e else e
        extruded = de > 0 and ("X" in vals or "Y" in vals)
    return x0, y0, extruded


def layer_paths(gcode: str | os.PathLike, layer_index: int) -> LayerPaths:
    """The extrusions of layer ``layer_index`` (0-based), skirt, brim and custom code left out.

    Reads PrusaSlicer (``;LAYER_CHANGE``, ``;Z:``, ``;TYPE:``, ``;WIDTH:``) and CuraEngine
    (``;LAYER:``, ``;TYPE:``; width 0.4 mm) G-code, with relative (``M83``) or absolute
    (``M82``) extrusion.

    Raises:
        ValueError: The file has no layer ``layer_index`` or no extrusion in it.
        OSError: The file cannot be read.
    """
    st = _State()
    layer, z = -1, None
    paths: list[tuple[list[tuple[float, float]], float, str]] = []
    current: list[tuple[float, float]] | None = None
    with Path(gcode).open(errors="replace") as fh:
        for line in fh:
            if line.startswith(("G1 ", "G0 ")):
                x0, y0, extruded = _move(st, line)
                if extruded and layer == layer_index and not st.role.startswith(SKIPPED_ROLES):
                    if current is None:
                        current = [(x0, y0)]
                        paths.append((current, st.width, st.role))
                    current.append((st.x, st.y))
                else:
                    current = None
            elif line.startswith((";LAYER_CHANGE", ";LAYER:")):
                layer, current = layer + 1, None
                if layer > layer_index:
                    break
            elif line.startswith(";Z:") and layer == layer_index:
                z = float(line[3:])
            elif line.startswith(";WIDTH:"):
                st.width, current = float(line[7:]), None
            elif line.startswith(";TYPE:"):
                st.role, current = line[6:].strip().lower(), None
            elif line.startswith("M83"):
                st.relative_e = True
            elif line.startswith("M82"):
                st.relative_e = False
            elif line.startswith("G92"):
                m = re.search(r"E(-?\d*\.?\d+)", line)
                st.e = float(m.group(1)) if m else st.e
    if not paths:
        raise ValueError(f"{gcode}: no extrusion on layer {layer_index + 1} (of {layer + 1} read)")
    return LayerPaths(z, tuple((np.asarray(p, dtype=float), w, r) for p, w, r in paths))


def align_shift(layer: LayerPaths, plate_min: np.ndarray, plate_max: np.ndarray) -> np.ndarray:
    """The ``(dx, dy)`` mm that moves the plate's frame onto the G-code's bed frame.

    Args:
        layer: A layer of the plate's G-code.
        plate_min: Lowest ``(x, y)`` of the plate's outline in its own frame, mm.
        plate_max: Highest ``(x, y)`` of the plate's outline, mm.
    """
    lo, hi = layer.bounds()
    return (lo + hi) / 2 - (np.asarray(plate_min, float) + np.asarray(plate_max, float)) / 2


def rasterise(
    layer: LayerPaths, origin: np.ndarray, size_mm: tuple[float, float], px_mm: float = 0.025
) -> np.ndarray:
    """Draw a layer's extrusions at their width.

    Args:
        layer: The extrusions (bed mm).
        origin: Bed ``(x, y)`` mm of the raster's bottom-left corner.
        size_mm: ``(width, height)`` of the raster in mm.
        px_mm: Pixel size in mm. Defaults to 0.025 mm.

    Returns:
        ``covered ((H, W) ndarray of bool)``, row 0 at the top (highest y), True where
        plastic is laid.
    """
    from PIL import Image, ImageDraw

    w_px, h_px = int(np.ceil(size_mm[0] / px_mm)), int(np.ceil(size_mm[1] / px_mm))
    img = Image.new("1", (w_px, h_px), 0)
    draw = ImageDraw.Draw(img)
    org = np.asarray(origin, dtype=float)
    for pts, width, _ in layer.paths:
        q = (pts - org) / px_mm
        q[:, 1] = h_px - q[:, 1]
        lw = max(1, int(round(width / px_mm)))
        coords = list(map(tuple, q.tolist()))
        if len(coords) > 1:
            draw.line(coords, fill=1, width=lw, joint="curve")
        half = width / px_mm / 2
        for cx, cy in (coords[0], coords[-1]):
            draw.ellipse([cx - half, cy - half, cx + half, cy + half], fill=1)
    return np.asarray(img, dtype=bool)


def hole_open_areas(
    covered: np.ndarray,
    origin: np.ndarray,
    px_mm: float,
    xy_mm: np.ndarray,
    r_mm: np.ndarray,
    reach_mm: float = 0.2,
) -> np.ndarray:
    """Open area in mm² of each hole as printed.

    A hole's open area is the uncovered region that holds its centre, counted inside
    its designed circle grown by ``reach_mm`` (so a pin hole in a neighbouring web that
    happens to touch it is not counted). A hole whose centre is covered is closed: 0.

    Args:
        covered: Raster from :func:`rasterise` (row 0 at the top).
        origin: Bed ``(x, y)`` mm of the raster's bottom-left corner.
        px_mm: Pixel size in mm.
        xy_mm: ``(N, 2)`` hole centres in bed mm.
        r_mm: ``(N,)`` designed radii in mm.
        reach_mm: How far past the designed circle the open region is counted. Defaults to 0.2 mm.

    Returns:
        ``(N,)`` ndarray of float, mm².
    """
    from scipy import ndimage

    h_px, w_px = covered.shape
    org = np.asarray(origin, dtype=float)
    areas = np.zeros(len(xy_mm))
    for i, ((x, y), r) in enumerate(zip(np.asarray(xy_mm, float), np.asarray(r_mm, float), strict=True)):
        reach = (r + reach_mm) / px_mm
        cx, cy = (x - org[0]) / px_mm, h_px - (y - org[1]) / px_mm
        c0, c1 = max(0, int(cx - reach) - 1), min(w_px, int(cx + reach) + 2)
        r0, r1 = max(0, int(cy - reach) - 1), min(h_px, int(cy + reach) + 2)
        if c0 >= c1 or r0 >= r1:
            continue
        rows, cols = np.mgrid[r0:r1, c0:c1]
        inside = (cols + 0.5 - cx) ** 2 + (rows + 0.5 - cy) ** 2 <= reach**2
        open_px = inside & ~covered[r0:r1, c0:c1]
        labels, _ = ndimage.label(open_px)
        ci, cj = int(cy) - r0, int(cx) - c0
        if not (0 <= ci < labels.shape[0] and 0 <= cj < labels.shape[1]) or labels[ci, cj] == 0:
            continue
        areas[i] = float((labels == labels[ci, cj]).sum()) * px_mm * px_mm
    return areas
