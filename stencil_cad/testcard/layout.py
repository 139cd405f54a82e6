"""The calibration card: a small stencil plate whose spray measures a can, and the sheet it is sprayed on.

The plate's picture area is ``CARD_W x CARD_H`` mm (frame as every plate: x right, y up,
origin at the picture's bottom-left). It holds, as round holes:

* an open window (one large hole): its edge gives the blur sigma, its centre the
  full-dose opacity;
* rows of single holes, one row per hole radius the job uses: single-dot profiles;
* hole patches at several open-area densities (a dose ladder in one spraying).

The plate is sprayed on a printed sheet. Per stand-off the sheet carries a footprint: the
wall's outline to set the wall on, and, in the band that the wall itself covers while
spraying (so no paint reaches it), four ArUco markers for registration and black, grey and
white patches for the flat field. Several stand-offs are laid side by side (stacked) on one
sheet, each footprint with its own marker ids, so one photo measures them all. The unpainted
primer inside the picture area (under the plate's solid parts) is the white reference too.

Everything is described in mm by :func:`card_description` (``card.json``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import DotSet
from ..names import CARD_JSON

if TYPE_CHECKING:
    from ..config.job import JobConfig
    from ..config.stipple import StippleConfig

__all__ = [
    "CARD_H",
    "CARD_W",
    "CardLayout",
    "Feature",
    "Footprint",
    "card_description",
    "card_layout",
    "layout_from_description",
]

#: Picture area of the card's plate, mm: with the default 10 mm margin and key the plate is about
#: 112 x 70 mm and its wall about 118 x 76 mm, within every common bed (the smallest, an SL1S, is 127 x 80).
CARD_W = 90.0
CARD_H = 48.0
#: Largest plate and wall outline the card accepts, mm (fits every common bed).
MAX_PLATE_MM = (120.0, 80.0)
#: Window radius and centre (mm).
WINDOW_R = 9.0
WINDOW_C = (12.5, 35.5)
#: Single-hole rows: x positions and row heights (mm).
SINGLE_X = tuple(31.0 + 8.5 * i for i in range(7))
SINGLE_Y = (42.5, 35.5, 28.5)
#: Dose-ladder patches: centres (mm), side (mm) and the open-area fractions asked for.
PATCH_SIDE = 14.0
PATCH_X = (10.0, 27.5, 45.0, 62.5, 80.0)
PATCH_Y = 11.0
PATCH_FRACTIONS = (0.04, 0.08, 0.15, 0.25, 0.40)
#: ArUco dictionary (OpenCV name) and marker side (mm) printed in the wall's band.
ARUCO_DICT = "DICT_4X4_50"
MARKER_MM = 8.0
#: Flat-field patches printed in the band: reflectance 0 (black), 0.5 (grey), 1 (white paper).
PATCH_LEVELS = (0.0, 0.5, 1.0)
FLAT_PATCH_MM = 7.0
#: Gap between stacked footprints on the sheet (mm) and the sheet's margin.
SHEET_GAP = 8.0
SHEET_MARGIN = 8.0
#: Passes the card's instructions ask for.
CARD_PASSES = 4
#: The card's low stand-off in mm, added to a job's single wall height (see ``_standoffs``).
CARD_LOW_STANDOFF_MM = 3.0


@dataclass(frozen=True)
class Feature:
    """One measured feature of the card.

    Attributes:
        kind: ``window``, ``single`` or ``patch``.
        index: Holes (indices into the card's DotSet) that make it.
        box: ``(x0, y0, x1, y1)`` in picture mm: where it is measured.
        r_mm: Hole radius of a single row or patch (the window's radius for the window).
        open_fraction: Open-area share of a patch (1 for the window, 0 for a single row).
    """

    kind: str
    index: tuple[int, ...]
    box: tuple[float, float, float, float]
    r_mm: float
    open_fraction: float


@dataclass(frozen=True)
class Footprint:
    """Where one stand-off's card is sprayed on the sheet.

    Attributes:
        standoff_mm: The wall's stand-off for this footprint.
        origin_mm: Sheet position (mm, sheet frame: x right, y up, origin bottom-left) of the
            card's picture-area origin.
        marker_ids: The four ArUco ids, bottom-left, bottom-right, top-right, top-left.
        markers: ``(4, 2)`` centres of the markers in picture mm.
        flat_patches: ``(level, x0, y0, x1, y1)`` in picture mm of the black, grey and white patches.
        outer_ring: ``(M, 2)`` wall outline in picture mm (where to set the wall).
    """

    standoff_mm: float
    origin_mm: tuple[float, float]
    marker_ids: tuple[int, int, int, int]
    markers: np.ndarray
    flat_patches: tuple[tuple[float, float, float, float, float], ...]
    outer_ring: np.ndarray

    def marker_corners(self, marker_mm: float = MARKER_MM) -> np.ndarray:
        """``(4, 4, 2)`` corners of each marker in picture mm, in ArUco's order (TL, TR, BR, BL as seen)."""
        h = marker_mm / 2.0
        # Image order is clockwise from the top-left as printed (y up in mm, so top = +h).
        offs = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
        return self.markers[:, None, :] + offs[None, :, :]


@dataclass(frozen=True)
class CardLayout:
    """The card: its holes, features, sheet footprints and the job's settings it was made for.

    Attributes:
        width_mm: Picture width (``CARD_W``).
        height_mm: Picture height (``CARD_H``).
        dots: Every hole of the plate.
        features: The measured features.
        footprints: One per stand-off.
        plate_thickness_mm: Plate thickness.
        sheet_mm: ``(width, height)`` of the printed sheet.
        passes: Passes the instructions ask for.
        band_mm: Inner and outer offset of the band the wall covers, from the picture area.
    """

    width_mm: float
    height_mm: float
    dots: DotSet
    features: tuple[Feature, ...]
    footprints: tuple[Footprint, ...]
    plate_thickness_mm: float
    sheet_mm: tuple[float, float]
    passes: int = CARD_PASSES
    band_mm: tuple[float, float] = (0.0, 13.2)


def _patch_holes(
    cx: float, cy: float, r: float, fraction: float, min_pitch: float
) -> tuple[np.ndarray, float]:
    """A hexagonal lattice of holes of radius r in a ``PATCH_SIDE`` square at about ``fraction`` open area."""
    pitch = max(math.sqrt(2.0 * math.pi * r * r / (math.sqrt(3.0) * fraction)), min_pitch)
    dy = pitch * math.sqrt(3.0) / 2.0
    half = PATCH_SIDE / 2.0 - r
    pts = []
    rows = int(math.floor(2 * half / dy)) + 1
    y0 = cy - (rows - 1) * dy / 2.0
    for j in range(rows):
        shift = (j % 2) * pitch / 2.0
        cols = int(math.floor((2 * half - shift) / pitch)) + 1
        x0 = cx - half + shift + (2 * half - shift - (cols - 1) * pitch) / 2.0
        for i in range(cols):
            pts.append((x0 + i * pitch, y0 + j * dy))
    xy = np.array(pts, dtype=np.float64)
    return xy, float(len(xy) * math.pi * r * r / PATCH_SIDE**2)


def _standoffs(job_cfg: JobConfig, standoffs_mm: list[float] | None) -> list[float]:
    """The stand-offs the card is made for, sorted (see :func:`card_layout`)."""
    heights = sorted(set(standoffs_mm)) if standoffs_mm else job_cfg.standoff.walls_mm
    if not standoffs_mm and len(heights) == 1:
        h = heights[0]
        # A low wall, where the bleed and the spread blur alike, beside the job's: two heights whose
        # blurs differ mostly by k g separate k from the bleed. With 10 and 20 mm walls (twice the
        # job's height, as before) a synthetic photo recovered the bleed 18 % low.
        heights = sorted(
            {CARD_LOW_STANDOFF_MM, h} if h >= 1.5 * CARD_LOW_STANDOFF_MM else {h, min(300.0, 4.0 * h)}
        )
    if len(heights) > 3:
        raise ValueError(f"the card takes at most 3 stand-offs on one sheet, got {len(heights)}")
    return heights


def _card_holes(st: StippleConfig) -> tuple[DotSet, list[Feature]]:
    """The plate's holes and the features they make: the window, the single rows, the dose ladder.

    Args:
        st: The job's stipple settings (hole radii, web, spacing).

    Raises:
        ValueError: The job's largest hole does not fit the single-hole rows.
    """
    sizes = st.sizes
    r0, r1 = sizes.radius_mm, sizes.max_radius_mm
    radii = sorted({round(r0, 3), round((r0 + r1) / 2.0, 3), round(r1, 3)})
    if r1 > 2.5:
        raise ValueError(f"the card's single-hole rows take radii up to 2.5 mm, the job uses {r1:g} mm")
    xy: list[np.ndarray] = [np.array([WINDOW_C])]
    rr: list[np.ndarray] = [np.array([WINDOW_R])]
    features = [
        Feature(
            "window",
            (0,),
            (WINDOW_C[0] - WINDOW_R, WINDOW_C[1] - WINDOW_R, WINDOW_C[0] + WINDOW_R, WINDOW_C[1] + WINDOW_R),
            WINDOW_R,
            1.0,
        )
    ]
    n = 1
    for row, r in zip(SINGLE_Y, radii, strict=False):
        pts = np.array([(x, row) for x in SINGLE_X])
        xy.append(pts)
        rr.append(np.full(len(pts), r))
        features.append(
            Feature(
                "single", tuple(range(n, n + len(pts))), (27.0, row - 3.5, CARD_W - 0.5, row + 3.5), r, 0.0
            )
        )
        n += len(pts)
    # The densest pattern the process allows, as the stippler packs it.
    min_pitch = st.densest_pitch_mm
    for cx, f in zip(PATCH_X, PATCH_FRACTIONS, strict=True):
        pts, real = _patch_holes(cx, PATCH_Y, r1, f, min_pitch)
        xy.append(pts)
        rr.append(np.full(len(pts), r1))
        h = PATCH_SIDE / 2.0
        features.append(
            Feature(
                "patch", tuple(range(n, n + len(pts))), (cx - h, PATCH_Y - h, cx + h, PATCH_Y + h), r1, real
            )
        )
        n += len(pts)
    dots = DotSet(xy_mm=np.concatenate(xy), r_mm=np.concatenate(rr), report={"source": "calibration card"})
    return dots, features


def _wall_band(job_cfg: JobConfig) -> tuple[np.ndarray, float, float]:
    """The wall's outline around the card and the band it covers on the sheet.

    Returns:
        The wall's outer ring (picture mm) and the band's inner and outer offset from the picture area (mm).

    Raises:
        ValueError: The plate or wall would not fit every bed, or the band cannot hold the markers.
    """
    from .. import outline as outline_mod

    oc, wc = job_cfg.plate.outline, job_cfg.wall
    outer = outline_mod.offset_outline(CARD_W, CARD_H, oc, wc.clearance_mm + wc.wall_thickness_mm)
    plate = outline_mod.plate_outline(CARD_W, CARD_H, oc)
    for name, ring in (("plate", plate), ("wall", outer)):
        size = ring.max(axis=0) - ring.min(axis=0)
        if size[0] > MAX_PLATE_MM[0] + (6.5 if name == "wall" else 0) or size[1] > MAX_PLATE_MM[1]:
            raise ValueError(
                f"the card's {name} would be {size[0]:.1f} x {size[1]:.1f} mm, over the "
                f"{MAX_PLATE_MM[0]:g} x {MAX_PLATE_MM[1]:g} mm that fits every bed: reduce plate.outline.margin_mm "
                "or wall.wall_thickness_mm"
            )
    # The band under the wall: from the opening (picture area + opening margin) to the outline.
    inner = wc.opening_margin_mm
    band_outer = oc.border_mm + wc.clearance_mm + wc.wall_thickness_mm
    if band_outer - inner < MARKER_MM + 2.0:
        raise ValueError(
            f"the wall's band ({band_outer - inner:.1f} mm) is too narrow for the card's {MARKER_MM:g} mm markers "
            "and their white border: use plate.outline.margin_mm ≥ 7"
        )
    return outer, inner, band_outer


def _footprints(
    heights: list[float], outer: np.ndarray, mid: float
) -> tuple[list[Footprint], tuple[float, float]]:
    """One footprint per stand-off, stacked on the sheet, and the sheet's size (mm).

    Args:
        heights: The stand-offs, thinnest first.
        outer: The wall's outer ring (picture mm).
        mid: Offset of the band's middle line from the picture area (mm): where the markers
            and flat-field patches sit.
    """
    lo, hi = outer.min(axis=0), outer.max(axis=0)
    block_h = float(hi[1] - lo[1])
    sheet_w = float(hi[0] - lo[0]) + 2 * SHEET_MARGIN
    sheet_h = len(heights) * block_h + (len(heights) - 1) * SHEET_GAP + 2 * SHEET_MARGIN
    markers = np.array(
        [
            [MARKER_MM / 2.0 + 2.0, -mid],
            [CARD_W - MARKER_MM / 2.0 - 2.0, -mid],
            [CARD_W - MARKER_MM / 2.0 - 2.0, CARD_H + mid],
            [MARKER_MM / 2.0 + 2.0, CARD_H + mid],
        ]
    )
    p = FLAT_PATCH_MM / 2.0
    flat = []
    for i, level in enumerate(PATCH_LEVELS):
        for cy in (-mid, CARD_H + mid):
            cx = CARD_W / 2.0 + (i - 1) * (FLAT_PATCH_MM + 6.0) + (8.0 if cy > 0 else -8.0)
            flat.append((float(level), cx - p, cy - p, cx + p, cy + p))
    foots = []
    for j, g in enumerate(heights):
        # Stacked from the top of the sheet down, thinnest stand-off first.
        top = sheet_h - SHEET_MARGIN - j * (block_h + SHEET_GAP)
        origin = (SHEET_MARGIN - float(lo[0]), top - float(hi[1]))
        foots.append(
            Footprint(
                standoff_mm=float(g),
                origin_mm=origin,
                marker_ids=(4 * j, 4 * j + 1, 4 * j + 2, 4 * j + 3),
                markers=markers.copy(),
                flat_patches=tuple(flat),
                outer_ring=outer,
            )
        )
    return foots, (sheet_w, sheet_h)


def card_layout(job_cfg: JobConfig, standoffs_mm: list[float] | None = None) -> CardLayout:
    """Lay out the card for a job: its hole radii and web, its plate, wall and stand-offs.

    Args:
        job_cfg: The :class:`~stencil_cad.config.JobConfig` the card measures the can for.
        standoffs_mm: Stand-offs to make footprints (and walls) for. Defaults to the job's
            ``wall.standoff_mm``; with a single height, a 3 mm wall is added (or four times a low height) so that
            the spread per mm of stand-off and the bleed floor separate.

    Returns:
        The layout.

    Raises:
        ValueError: More than three stand-offs, or hole radii/web that do not fit the card.
    """
    from ..config.job import filled

    # The card plans no tiling: its plate values as the config alone fills them in (the same config
    # when they are filled in already, :func:`stencil_cad.plan.plan.unplanned`).
    job_cfg = filled(job_cfg)[0]
    heights = _standoffs(job_cfg, standoffs_mm)
    dots, features = _card_holes(job_cfg.stipple)
    outer, inner, band_outer = _wall_band(job_cfg)
    foots, sheet = _footprints(heights, outer, (inner + band_outer) / 2.0)
    return CardLayout(
        width_mm=CARD_W,
        height_mm=CARD_H,
        dots=dots,
        features=tuple(features),
        footprints=tuple(foots),
        plate_thickness_mm=job_cfg.plate.planned_thickness_mm,
        sheet_mm=sheet,
        band_mm=(inner, band_outer),
    )


def card_description(layout: CardLayout, extra: dict | None = None) -> dict:
    """``card.json``: everything the photo fit needs, in mm.

    Args:
        layout: The card.
        extra: More keys to record (the job's spray settings, file names).

    Returns:
        A JSON-ready dict.
    """

    def r4(a):
        return np.round(np.asarray(a, dtype=np.float64), 4).tolist()

    return {
        "kind": "stencil_cad calibration card",
        "version": 1,
        "units": "mm; picture frame: x right, y up, origin at the card's picture bottom-left",
        "picture_mm": [layout.width_mm, layout.height_mm],
        "plate_thickness_mm": layout.plate_thickness_mm,
        "passes": layout.passes,
        "holes": {
            "x_mm": r4(layout.dots.xy_mm[:, 0]),
            "y_mm": r4(layout.dots.xy_mm[:, 1]),
            "r_mm": r4(layout.dots.r_mm),
        },
        "features": [
            {
                "kind": f.kind,
                "holes": [int(i) for i in f.index],
                "box_mm": r4(f.box),
                "r_mm": f.r_mm,
                "open_fraction": round(f.open_fraction, 5),
            }
            for f in layout.features
        ],
        "aruco": {"dictionary": ARUCO_DICT, "marker_mm": MARKER_MM},
        "band_mm": list(layout.band_mm),
        "sheet_mm": [round(v, 3) for v in layout.sheet_mm],
        "footprints": [
            {
                "standoff_mm": fp.standoff_mm,
                "origin_on_sheet_mm": r4(fp.origin_mm),
                "marker_ids": list(fp.marker_ids),
                "marker_centres_mm": r4(fp.markers),
                "flat_patches_mm": [r4(p) for p in fp.flat_patches],
                "wall_outline_mm": r4(fp.outer_ring),
            }
            for fp in layout.footprints
        ],
        **(extra or {}),
    }


def _ints4(values) -> tuple[int, int, int, int]:
    """Four ints from a card description's list (a wrong length is a ValueError)."""
    a, b, c, d = (int(v) for v in values)
    return a, b, c, d


def _floats2(values) -> tuple[float, float]:
    """Two floats from a card description's list (a wrong length is a ValueError)."""
    a, b = (float(v) for v in values)
    return a, b


def _floats5(values) -> tuple[float, float, float, float, float]:
    """Five floats from a card description's list (a wrong length is a ValueError)."""
    a, b, c, d, e = (float(v) for v in values)
    return a, b, c, d, e


def layout_from_description(desc: dict) -> CardLayout:
    """Read ``card.json`` back into a :class:`CardLayout`.

    Raises:
        ValueError: Not a card description, or a missing or malformed key (named).
    """
    if not isinstance(desc, dict) or desc.get("kind") != "stencil_cad calibration card":
        raise ValueError("not a calibration card description (write one with `stencil-cad card --out DIR`)")
    try:
        holes = desc["holes"]
        xy = np.column_stack([holes["x_mm"], holes["y_mm"]]).astype(np.float64)
        r = np.asarray(holes["r_mm"], dtype=np.float64)
        feats = tuple(
            Feature(
                f["kind"],
                tuple(int(i) for i in f["holes"]),
                tuple(f["box_mm"]),
                float(f["r_mm"]),
                float(f["open_fraction"]),
            )
            for f in desc["features"]
        )
        foots = tuple(
            Footprint(
                standoff_mm=float(fp["standoff_mm"]),
                origin_mm=tuple(fp["origin_on_sheet_mm"]),
                marker_ids=_ints4(fp["marker_ids"]),
                markers=np.asarray(fp["marker_centres_mm"], dtype=np.float64),
                flat_patches=tuple(_floats5(p) for p in fp["flat_patches_mm"]),
                outer_ring=np.asarray(fp["wall_outline_mm"], dtype=np.float64),
            )
            for fp in desc["footprints"]
        )
        w, h = (float(v) for v in desc["picture_mm"])
        layout = CardLayout(
            width_mm=w,
            height_mm=h,
            dots=DotSet(xy_mm=xy, r_mm=r, report={"source": CARD_JSON}),
            features=feats,
            footprints=foots,
            plate_thickness_mm=float(desc["plate_thickness_mm"]),
            sheet_mm=_floats2(desc["sheet_mm"]),
            passes=int(desc.get("passes", CARD_PASSES)),
            band_mm=_floats2(desc["band_mm"]),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(
            f"card description is malformed ({type(exc).__name__}: {exc}); write it again with `stencil-cad card`"
        ) from None
    _check_sizes(layout)
    return layout


#: Largest sheet side a card description may give, in mm (the card is an A4/A3 sheet).
MAX_SHEET_MM = 2000.0


def _check_sizes(layout: CardLayout) -> None:
    """Every size of a card description finite and within what a printed card can be.

    Raises:
        ValueError: Naming the first key out of range.
    """

    def check(name: str, values: Any, lo: float, hi: float) -> None:
        a = np.asarray(values, dtype=np.float64)
        if a.size and not (np.all(np.isfinite(a)) and a.min() >= lo and a.max() <= hi):
            bad = a[~(np.isfinite(a) & (a >= lo) & (a <= hi))].ravel()[0]
            raise ValueError(
                f"card description: {name} must be in [{lo:g}, {hi:g}], got {bad:g}; write it again with "
                "`stencil-cad card`"
            )

    side = MAX_SHEET_MM
    check("picture_mm", (layout.width_mm, layout.height_mm), 1.0, side)
    check("sheet_mm", layout.sheet_mm, 1.0, side)
    check("band_mm", layout.band_mm, 0.0, side)
    check("plate_thickness_mm", layout.plate_thickness_mm, 0.1, 50.0)
    check("passes", layout.passes, 1, 50)
    check("holes.x_mm / y_mm", layout.dots.xy_mm, -side, side)
    check("holes.r_mm", layout.dots.r_mm, 0.01, 100.0)
    for f in layout.features:
        check("features[].box_mm", f.box, -side, side)
        check("features[].r_mm", f.r_mm, 0.0, 100.0)
        check("features[].open_fraction", f.open_fraction, 0.0, 1.0)
        if f.index and not 0 <= min(f.index) <= max(f.index) < len(layout.dots.r_mm):
            raise ValueError("card description: features[].holes: a hole index outside holes; write it again")
    for fp in layout.footprints:
        check("footprints[].standoff_mm", fp.standoff_mm, 0.5, 300.0)
        for name, arr in (
            ("origin_on_sheet_mm", fp.origin_mm),
            ("marker_centres_mm", fp.markers),
            ("flat_patches_mm", fp.flat_patches),
            ("wall_outline_mm", fp.outer_ring),
        ):
            check(f"footprints[].{name}", arr, -side, side)
