"""Plate outline with its asymmetric lock-and-key, and the fit geometry of the wall's pocket.

Kernel-free (numpy only): the plate solid, the wall, the DXF writer and the fit tests all
take their rings from here, so the plate and the wall's pocket are offsets of one path.

The outline lives in the picture frame: the picture area is ``[0, w] x [0, h]`` mm, y up.
It is a rectangle grown by ``margin_mm`` on every side, with rounded corners, plus one
rectangular tab per key (rounded outer corners, sharp inner ones). The pocket of the wall
is the same path offset outward by the clearance: an outward offset of a union of convex
pieces is the union of their offsets, so the offset path is built exactly, with corner
radii grown by the offset, instead of offsetting a polygon.

Rings are ``(M, 2)`` ndarrays of (x, y) mm, counter-clockwise, without the closing vertex
repeated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config.outline import OutlineConfig, Side
from .geometry import point_ring_distance, points_in_ring, polygon_area, rings_cross

__all__ = [
    "Segment",
    "check_key",
    "fits",
    "label_region",
    "min_clearance",
    "offset_outline",
    "outline_area",
    "outline_path",
    "path_area",
    "path_ring",
    "plate_outline",
    "pocket_outline",
    "symmetries",
    "transform_ring",
]

# Side frames, counter-clockwise: the side is walked from its start corner along ``u``;
# the outward normal is ``u`` turned -90 degrees; ``rot`` is the frame's angle in degrees.
_SIDE_ORDER = (Side.bottom, Side.right, Side.top, Side.left)


@dataclass(frozen=True)
class Segment:
    """One piece of an outline path: a straight line, or a counter-clockwise circular arc.

    Attributes:
        start: ``(2,)`` start point in mm.
        end: ``(2,)`` end point in mm.
        centre: ``(2,)`` arc centre in mm, or None for a line.
        radius: Arc radius in mm (0 for a line).
        angle0: Arc start angle in radians.
        sweep: Arc sweep in radians, > 0 (counter-clockwise).
    """

    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float] | None = None
    radius: float = 0.0
    angle0: float = 0.0
    sweep: float = 0.0

    @property
    def is_arc(self) -> bool:
        """True for an arc."""
        return self.centre is not None

    def midpoint(self) -> tuple[float, float]:
        """A point halfway along the segment, in mm."""
        if self.centre is None:
            return (0.5 * (self.start[0] + self.end[0]), 0.5 * (self.start[1] + self.end[1]))
        a = self.angle0 + 0.5 * self.sweep
        return (self.centre[0] + self.radius * math.cos(a), self.centre[1] + self.radius * math.sin(a))


def _pt(p: np.ndarray) -> tuple[float, float]:
    """A point as a pair of Python floats."""
    return float(p[0]), float(p[1])


def _side_geometry(side: Side, x0: float, y0: float, x1: float, y1: float):
    """Start corner, unit direction, outward normal and angle (rad) of a side of a box."""
    if side is Side.bottom:
        return np.array([x0, y0]), np.array([1.0, 0.0]), np.array([0.0, -1.0]), 0.0, x1 - x0
    if side is Side.right:
        return np.array([x1, y0]), np.array([0.0, 1.0]), np.array([1.0, 0.0]), 0.5 * math.pi, y1 - y0
    if side is Side.top:
        return np.array([x1, y1]), np.array([-1.0, 0.0]), np.array([0.0, 1.0]), math.pi, x1 - x0
    return np.array([x0, y1]), np.array([0.0, -1.0]), np.array([-1.0, 0.0]), 1.5 * math.pi, y1 - y0


def _tab_centre_along(side: Side, position: float, width_mm: float, height_mm: float, margin: float) -> float:
    """Distance of a tab's centre from the start corner of its side (box grown by ``margin``)."""
    if side is Side.bottom:
        return margin + position * width_mm
    if side is Side.right:
        return margin + position * height_mm
    if side is Side.top:
        return margin + (1.0 - position) * width_mm
    return margin + (1.0 - position) * height_mm


def outline_path(
    width_mm: float, height_mm: float, cfg: OutlineConfig, offset_mm: float = 0.0
) -> list[Segment]:
    """The plate outline, or its outward offset, as exact lines and arcs.

    Args:
        width_mm: Picture width w in mm.
        height_mm: Picture height h in mm.
        cfg: Outline config.
        offset_mm: Outward offset in mm (≥ 0): 0 gives the plate, the clearance gives the
            wall's pocket. Corner radii grow by the offset; the inner corners of the tabs stay
            sharp, which is what an exact offset does.

    Returns:
        Segments in counter-clockwise order, each starting where the previous one ends.

    Raises:
        ValueError: If a tab (grown by the offset) reaches a rounded corner, or two tabs on
            one side touch.
    """
    if offset_mm < 0:
        raise ValueError(f"offset_mm must be ≥ 0, got {offset_mm}")
    m, d = cfg.border_mm, offset_mm
    x0, y0, x1, y1 = -m - d, -m - d, width_mm + m + d, height_mm + m + d
    rc = cfg.corner_radius_mm + d
    rk = cfg.key_corner_radius_mm + d
    segs: list[Segment] = []
    for side in _SIDE_ORDER:
        s0, u, n, rot, length = _side_geometry(side, x0, y0, x1, y1)
        inward = -n

        def at(s, t, s0=s0, u=u, n=n):
            return s0 + s * u + t * n

        # Corner at the start of this side: the arc ends on the side at distance rc from the corner.
        _add_arc(segs, at(rc, 0.0) + rc * inward, rc, rot - math.pi, 0.5 * math.pi)
        cursor = rc
        tabs = sorted(
            (
                (_tab_centre_along(side, k.position, width_mm, height_mm, m) + d, k, i)
                for i, k in enumerate(cfg.keys)
                if k.side is side
            ),
            key=lambda t: t[0],
        )
        for centre, k, i in tabs:
            cursor = _add_tab(segs, at, side, centre, k, i, d, rk, rot, cursor, rc, length)
        _add_line(segs, at(cursor, 0.0), at(length - rc, 0.0))
    return segs


def _add_line(segs: list[Segment], p, q) -> None:
    """Append the line from ``p`` to ``q`` unless it has no length."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    if np.hypot(*(q - p)) > 1e-12:
        segs.append(Segment(_pt(p), _pt(q)))


def _add_arc(segs: list[Segment], c, r: float, a0: float, sweep: float) -> None:
    """Append the arc about ``c`` of radius ``r`` from angle ``a0`` through ``sweep`` (none for r = 0)."""
    if r <= 1e-12:
        return
    c = np.asarray(c, float)
    p = c + r * np.array([math.cos(a0), math.sin(a0)])
    q = c + r * np.array([math.cos(a0 + sweep), math.sin(a0 + sweep)])
    segs.append(Segment(_pt(p), _pt(q), _pt(c), float(r), a0, sweep))


def _add_tab(segs, at, side, centre, k, i, d, rk, rot, cursor, rc, length) -> float:
    """Append the side up to key ``k``'s tab and the tab itself; where the side goes on from.

    ``at(s, t)`` maps a distance along the side and a depth into the plate to a point.

    Raises:
        ValueError: If the tab reaches a rounded corner or the tab before it.
    """
    depth = k.depth_mm
    a, b = centre - 0.5 * k.width_mm - d, centre + 0.5 * k.width_mm + d
    # When the grown tip radius exceeds the depth, the tip arcs meet the side's edge
    # directly (at a sharp inner corner) and the tab's straight sides vanish.
    tc = depth - rk
    cut = min(tc, 0.0)
    reach = rk - math.sqrt(max(rk * rk - cut * cut, 0.0))
    phi = -math.asin(cut / rk) if rk > 0 else 0.0
    a_edge, b_edge = a + reach, b - reach
    grown = f" when grown by {d:g} mm" if d > 0 else ""
    if a_edge < cursor - 1e-9:
        what = "a rounded corner" if cursor == rc else "another tab"
        raise ValueError(
            f"keys[{i}] ({side.value} side, position {k.position}, width {k.width_mm} mm) reaches "
            f"{what}{grown}"
        )
    if b_edge > length - rc + 1e-9:
        raise ValueError(
            f"keys[{i}] ({side.value} side, position {k.position}, width {k.width_mm} mm) reaches "
            f"a rounded corner{grown}"
        )
    _add_line(segs, at(cursor, 0.0), at(a_edge, 0.0))
    if tc > 0:
        _add_line(segs, at(a, 0.0), at(a, tc))
    _add_arc(segs, at(a + rk, tc), rk, rot + math.pi + phi, 0.5 * math.pi - phi)
    _add_line(segs, at(a + rk, depth), at(b - rk, depth))
    _add_arc(segs, at(b - rk, tc), rk, rot + 1.5 * math.pi, 0.5 * math.pi - phi)
    if tc > 0:
        _add_line(segs, at(b, tc), at(b, 0.0))
    return b_edge


def _arc_steps(radius: float, sweep: float, chord_tol_mm: float) -> int:
    if radius <= chord_tol_mm:
        return 1
    step = 2.0 * math.acos(1.0 - chord_tol_mm / radius)
    return max(1, math.ceil(sweep / step - 1e-9))


def path_ring(path: list[Segment], chord_tol_mm: float) -> np.ndarray:
    """Sample a path into a polygon ring.

    Arc vertices lie on the arc, so the ring is inside the exact shape by at most
    ``chord_tol_mm`` (the chord's sagitta).

    Args:
        path: Segments from :func:`outline_path`.
        chord_tol_mm: Largest sagitta in mm.

    Returns:
        ``(M, 2)`` ndarray ring, counter-clockwise, closing vertex not repeated.
    """
    pts: list[np.ndarray] = []
    for s in path:
        if s.centre is not None:
            k = _arc_steps(s.radius, s.sweep, chord_tol_mm)
            a = s.angle0 + s.sweep * np.arange(k) / k
            pts.append(
                np.stack([s.centre[0] + s.radius * np.cos(a), s.centre[1] + s.radius * np.sin(a)], axis=1)
            )
        else:
            pts.append(np.asarray([s.start], dtype=np.float64))
    ring = np.concatenate(pts, axis=0)
    keep = np.hypot(*(ring - np.roll(ring, 1, axis=0)).T) > 1e-12
    return np.ascontiguousarray(ring[keep])


def path_area(path: list[Segment]) -> float:
    """Exact area in mm² enclosed by a path of lines and arcs (Green's theorem)."""
    total = 0.0
    for s in path:
        if s.centre is not None:
            cx, cy = s.centre
            r, a0, a1 = s.radius, s.angle0, s.angle0 + s.sweep
            total += r * r * s.sweep + r * (
                cx * (math.sin(a1) - math.sin(a0)) - cy * (math.cos(a1) - math.cos(a0))
            )
        else:
            total += s.start[0] * s.end[1] - s.end[0] * s.start[1]
    return 0.5 * total


def offset_outline(width_mm: float, height_mm: float, cfg: OutlineConfig, offset_mm: float) -> np.ndarray:
    """The outline offset outward by ``offset_mm``, sampled with ``cfg.chord_tol_mm``.

    Returns:
        ``(M, 2)`` ndarray ring, counter-clockwise, in the picture frame (mm).
    """
    return path_ring(outline_path(width_mm, height_mm, cfg, offset_mm), cfg.chord_tol_mm)


def plate_outline(width_mm: float, height_mm: float, cfg: OutlineConfig) -> np.ndarray:
    """The plate's outline ring: picture area grown by the margin, rounded corners, key tabs.

    Args:
        width_mm: Picture width w in mm; the picture area is ``[0, w] x [0, h]``.
        height_mm: Picture height h in mm.
        cfg: Outline config.

    Returns:
        ``(M, 2)`` ndarray ring of (x, y) mm, counter-clockwise, closing vertex not repeated.
        Arc vertices lie on the exact arcs (chord error ≤ ``cfg.chord_tol_mm``).
    """
    return offset_outline(width_mm, height_mm, cfg, 0.0)


def pocket_outline(width_mm: float, height_mm: float, cfg: OutlineConfig, clearance_mm: float) -> np.ndarray:
    """The wall pocket's ring: the plate outline offset outward by the clearance."""
    return offset_outline(width_mm, height_mm, cfg, clearance_mm)


def outline_area(
    width_mm: float, height_mm: float, cfg: OutlineConfig, offset_mm: float = 0.0, exact: bool = False
) -> float:
    """Area in mm² of the plate outline (or its offset).

    Args:
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        cfg: Outline config.
        offset_mm: Outward offset in mm. Defaults to 0 (the plate).
        exact: False (default) gives the area of the polygon ring that :func:`plate_outline`
            returns, the oracle for a solid extruded from that ring; True gives the area of
            the exact shape with true arcs (larger by at most chord_tol_mm × arc length).
    """
    path = outline_path(width_mm, height_mm, cfg, offset_mm)
    return path_area(path) if exact else polygon_area(path_ring(path, cfg.chord_tol_mm))


def label_region(
    width_mm: float, height_mm: float, cfg: OutlineConfig, solid_mm: float = 0.0
) -> tuple[float, float, float, float]:
    """A rectangle in the bottom border for the label, clear of the picture and the plate edge.

    Its x range is the picture's, inset by ``cfg.label_gap_mm``, so it also keeps clear of the
    rounded corners; its y range is the bottom border minus the gap on both sides.

    Args:
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        cfg: Outline config.
        solid_mm: How far above the picture area's bottom edge the plate is solid all along (a mural
            tile's band below its lowest hole, :data:`stencil_cad.config.outline.TILE_MARGIN_MM`);
            the label rises into it. Defaults to 0 (the border alone).

    Returns:
        ``(x0, y0, x1, y1)`` in mm, picture frame; ``y1 < 0`` unless ``solid_mm`` lets it rise.
    """
    g, m = cfg.label_gap_mm, cfg.border_mm
    return (g, -m + g, width_mm - g, max(float(solid_mm), 0.0) - g)


# ---------------------------------------------------------------- fit geometry


def min_clearance(plate_ring: np.ndarray, pocket_ring: np.ndarray) -> float:
    """Smallest gap in mm between a plate and the pocket it sits in.

    For two polygons whose boundaries do not cross, the smallest distance between the
    boundaries is reached at a vertex of one of them, so vertex-to-edge distances both ways
    give it exactly.

    Returns:
        The gap (≥ 0) if the plate lies inside the pocket; otherwise minus the deepest
        overlap found (distance of the worst plate vertex outside the pocket, or of a pocket
        vertex inside the plate), and at most -1e-12 when only edges cross.
    """
    plate = np.asarray(plate_ring, dtype=np.float64)
    pocket = np.asarray(pocket_ring, dtype=np.float64)
    out_plate = ~points_in_ring(plate, pocket)
    in_pocket = points_in_ring(pocket, plate)
    crossing = rings_cross([plate, pocket], touching=False, within=False)
    if out_plate.any() or in_pocket.any() or crossing:
        worst = 1e-12
        if out_plate.any():
            worst = max(worst, float(point_ring_distance(plate[out_plate], pocket).max()))
        if in_pocket.any():
            worst = max(worst, float(point_ring_distance(pocket[in_pocket], plate).max()))
        return -worst
    return float(min(point_ring_distance(plate, pocket).min(), point_ring_distance(pocket, plate).min()))


def fits(
    plate_ring: np.ndarray, pocket_ring: np.ndarray, clearance_mm: float = 0.0, tol_mm: float = 1e-9
) -> bool:
    """True if the plate lies inside the pocket with at least ``clearance_mm - tol_mm`` all round."""
    return min_clearance(plate_ring, pocket_ring) >= clearance_mm - tol_mm


def transform_ring(ring: np.ndarray, matrix: np.ndarray, centre: tuple[float, float]) -> np.ndarray:
    """Apply a 2x2 linear map about ``centre``; mirrors are re-ordered to stay counter-clockwise."""
    c = np.asarray(centre, dtype=np.float64)
    out = (np.asarray(ring, dtype=np.float64) - c) @ np.asarray(matrix, dtype=np.float64).T + c
    if np.linalg.det(matrix) < 0:
        out = out[::-1]
    return np.ascontiguousarray(out)


def symmetries() -> dict[str, np.ndarray]:
    """The seven non-identity symmetries of a square: ways a plate can be put in wrongly.

    Rotations by 90, 180 and 270 degrees (turned round) and the four mirrors (turned over,
    i.e. flipped about its x axis, y axis or a diagonal). A non-square plate can only go in
    with the rotation by 180 degrees and the x and y mirrors; the others are kept because
    they cost nothing and cover the square case.
    """
    return {
        "rot90": np.array([[0.0, -1.0], [1.0, 0.0]]),
        "rot180": np.array([[-1.0, 0.0], [0.0, -1.0]]),
        "rot270": np.array([[0.0, 1.0], [-1.0, 0.0]]),
        "flip_x": np.array([[-1.0, 0.0], [0.0, 1.0]]),
        "flip_y": np.array([[1.0, 0.0], [0.0, -1.0]]),
        "flip_diag": np.array([[0.0, 1.0], [1.0, 0.0]]),
        "flip_antidiag": np.array([[0.0, -1.0], [-1.0, 0.0]]),
    }


def check_key(
    width_mm: float, height_mm: float, cfg: OutlineConfig, clearance_mm: float, steps: int = 5
) -> None:
    """Check that the key lets the plate into the pocket the right way only.

    Each wrong placement (every symmetry of :func:`symmetries`) is tried at the picture's
    centre and shifted on a ``steps x steps`` grid over the play the clearance allows
    (±2 clearance + the chord tolerance in x and y).

    Raises:
        ValueError: If the right placement does not fit with the clearance, or some wrong
            placement fits; the message names it.
    """
    plate = plate_outline(width_mm, height_mm, cfg)
    pocket = pocket_outline(width_mm, height_mm, cfg, clearance_mm)
    for k in cfg.keys:
        if k.depth_mm <= 2.0 * clearance_mm:
            raise ValueError(
                f"key tab depth_mm ({k.depth_mm} mm) must exceed twice the clearance ({2 * clearance_mm:g} mm), "
                "or a turned plate could slip in"
            )
    if not fits(plate, pocket, clearance_mm, tol_mm=2.0 * cfg.chord_tol_mm):
        raise ValueError(f"the plate does not fit its own pocket with clearance {clearance_mm} mm")
    centre = (0.5 * width_mm, 0.5 * height_mm)
    play = 2.0 * clearance_mm + cfg.chord_tol_mm
    shifts = np.linspace(-play, play, steps) if steps > 1 else np.zeros(1)
    for name, mat in symmetries().items():
        moved = transform_ring(plate, mat, centre)
        # A vertex deeper than the largest shift on the wrong side stays there whatever the
        # shift, so the grid is only needed for near misses.
        if -min_clearance(moved, pocket) > math.sqrt(2.0) * play + 1e-9:
            continue
        for dx in shifts:
            for dy in shifts:
                if fits(moved + (dx, dy), pocket, 0.0):
                    raise ValueError(
                        f"the key does not stop a wrong placement: the plate fits the pocket {name} "
                        f"(shifted {dx:+.3f}, {dy:+.3f} mm); move a key tab off-centre or make the tabs differ"
                    )
