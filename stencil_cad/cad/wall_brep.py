"""The wall's faces, drawn by hand from its outlines, for its STEP file and mesh without the CAD kernel.

The wall is three prisms and a box (:mod:`.wall`): its outside from the surface to the top, less
the opening through it, the pocket from the stand-off up, and the finger slot. Its faces follow
from the outlines, so they are written out here rather than cut by OCCT:

- the bottom (the outside, the opening a hole in it), the ledge at the stand-off (the pocket, the
  opening a hole, the slot a notch in its top side) and the top (the outside, the pocket a hole;
  with the slot, one C-shaped bound);
- a side face per segment of each outline over its height (a plane for a line, a cylinder for an
  arc): the outside from 0 to the top, the opening from 0 to the stand-off, the pocket from the
  stand-off to the top; the slot splits the pocket's top side in two and cuts a U into the
  outside's;
- the slot's floor, its back under the plate and its two sides.

These are the faces OCCT's cut and unify gave the same wall (``tests/cad/test_wall.py`` reads the
file back with OCCT: one valid solid of the same volume, box and face count). The slot must lie on
one straight segment of the outside's and the pocket's top sides, reach under the plate and out
through the rim, as :func:`.wall._finger_slot` makes it (through the rim's full thickness, also
where the rim is a plain rounded rectangle round tabs too close together); :func:`wall_brep`
returns None otherwise, and the wall is cut by OCCT.
"""

from __future__ import annotations

import numpy as np

from ..exchange.brep import Brep, Face
from ..outline import Segment

__all__ = ["Slot", "wall_brep"]

#: A piece of a bound in plan: start, end, arc centre (None for a line), counter-clockwise.
Piece = tuple[tuple[float, float], tuple[float, float], tuple[float, float] | None, bool]
#: The finger slot: x0, x1, the y of its back under the plate, the y it reaches outside, the z of its floor.
Slot = tuple[float, float, float, float, float]


def _pieces(path: list[Segment]) -> list[Piece]:
    return [(s.start, s.end, s.centre, True) for s in path]


def _rev(pieces: list[Piece]) -> list[Piece]:
    return [(q, p, c, not ccw) for p, q, c, ccw in reversed(pieces)]


def _use(b: Brep, piece: Piece, z: float):
    (p, q, c, ccw) = piece
    if c is None:
        return b.line((*p, z), (*q, z))
    return b.arc((*p, z), (*q, z), (*c, z), ccw)


def _flat(b: Brep, z: float, up: bool, loops: list[list[Piece]]) -> None:
    """A horizontal face; ``loops`` run counter-clockwise seen from above (holes clockwise)."""
    if not up:
        loops = [_rev(lp) for lp in loops]
    b.faces.append(
        Face([[_use(b, p, z) for p in lp] for lp in loops], normal=(0.0, 0.0, 1.0 if up else -1.0))
    )


def _sides(b: Brep, pieces: list[Piece], z0: float, z1: float) -> None:
    """One side face per piece from ``z0`` to ``z1``, the material on the pieces' left."""
    for piece in pieces:
        p, q, c, ccw = piece
        loop = [
            _use(b, piece, z0),
            b.line((*q, z0), (*q, z1)),
            _use(b, (q, p, c, not ccw), z1),
            b.line((*p, z1), (*p, z0)),
        ]
        if c is None:
            d = np.subtract(q, p) / np.hypot(*np.subtract(q, p))
            b.faces.append(Face([loop], normal=(float(d[1]), float(-d[0]), 0.0)))
        else:
            r = float(np.hypot(p[0] - c[0], p[1] - c[1]))
            b.faces.append(Face([loop], centre=(*c, z0), radius=r, outward=ccw))


def _polygon(b: Brep, pts: list[tuple[float, float, float]], normal: tuple[float, float, float]) -> None:
    """A planar face of straight edges through ``pts``, turned to run counter-clockwise about ``normal``."""
    p = np.array(pts)
    newell = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
    if float(newell @ np.array(normal)) < 0:
        pts = pts[::-1]
    b.faces.append(Face([[b.line(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]], normal=normal))


def _top_side(pieces: list[Piece], x0: float, x1: float) -> int | None:
    """The index of the straight piece of a counter-clockwise outline's top side that spans ``[x0, x1]``.

    A counter-clockwise outline runs its top side towards -x; of its horizontal pieces that span the
    slot that way, the highest (a tab's, were one to span it, is not: the slot is kept clear of tabs).
    """
    spans = [
        i for i, (p, q, c, _) in enumerate(pieces) if c is None and p[1] == q[1] and p[0] > x1 and q[0] < x0
    ]
    return max(spans, key=lambda i: pieces[i][0][1], default=None)


def _split(pieces: list[Piece], i: int, x0: float, x1: float) -> tuple[Piece, list[Piece], Piece]:
    """The top side ``i`` cut at the slot: its part right of the slot, the rest in order, its part left."""
    (xa, y), (xb, _), _, _ = pieces[i]
    rest = pieces[i + 1 :] + pieces[:i]  # from the top side's left end round to its right end
    return ((xa, y), (x1, y), None, True), rest, ((x0, y), (xb, y), None, True)


def wall_brep(rings, standoff_mm: float, top_mm: float, slot: Slot | None) -> Brep | None:
    """The wall's faces from its outlines (:class:`~stencil_cad.cad.wall.WallRings`), or None.

    Args:
        rings: The outside, pocket and opening paths (counter-clockwise).
        standoff_mm: The ledge's height (the plate's underside).
        top_mm: The wall's height.
        slot: The finger slot, or None.

    Returns:
        The solid, or None when the slot is not where these faces assume it.
    """
    b = Brep()
    s, h = float(standoff_mm), float(top_mm)
    outer, pocket, opening = _pieces(rings.outer), _pieces(rings.pocket), _pieces(rings.opening)
    _flat(b, 0.0, False, [outer, _rev(opening)])
    _sides(b, _rev(opening), 0.0, s)
    if slot is None:
        _sides(b, outer, 0.0, h)
        _sides(b, _rev(pocket), s, h)
        _flat(b, s, True, [pocket, _rev(opening)])
        _flat(b, h, True, [outer, _rev(pocket)])
        return b
    x0, x1, ys, y_out, z0 = slot
    i, j = _top_side(outer, x0, x1), _top_side(pocket, x0, x1)
    if i is None or j is None or not (z0 < s and ys < pocket[j][0][1] < outer[i][0][1] < y_out and x0 < x1):
        return None
    yo, yp = outer[i][0][1], pocket[j][0][1]
    o_right, o_rest, o_left = _split(outer, i, x0, x1)
    p_right, p_rest, p_left = _split(pocket, j, x0, x1)
    (xa, _), (xb, _) = outer[i][0], outer[i][1]
    _sides(b, o_rest, 0.0, h)
    _polygon(
        b,
        [
            (xa, yo, 0.0),
            (xb, yo, 0.0),
            (xb, yo, h),
            (x0, yo, h),
            (x0, yo, z0),
            (x1, yo, z0),
            (x1, yo, h),
            (xa, yo, h),
        ],
        (0.0, 1.0, 0.0),
    )
    pocket_ccw = [p_left, *p_rest, p_right]  # the pocket from the slot's left side round to its right
    _sides(b, _rev(pocket_ccw), s, h)
    notch: list[Piece] = [((x1, yp), (x1, ys), None, True), ((x1, ys), (x0, ys), None, True)]
    notch.append(((x0, ys), (x0, yp), None, True))
    _flat(b, s, True, [pocket_ccw + notch, _rev(opening)])
    rim = [
        o_left,
        *o_rest,
        o_right,
        ((x1, yo), (x1, yp), None, True),
        *_rev(pocket_ccw),
        ((x0, yp), (x0, yo), None, True),
    ]
    _flat(b, h, True, [rim])
    _polygon(b, [(x0, ys, z0), (x1, ys, z0), (x1, yo, z0), (x0, yo, z0)], (0.0, 0.0, 1.0))
    _polygon(b, [(x0, ys, z0), (x1, ys, z0), (x1, ys, s), (x0, ys, s)], (0.0, 1.0, 0.0))
    for x, n in ((x0, 1.0), (x1, -1.0)):
        _polygon(b, [(x, ys, z0), (x, yo, z0), (x, yo, h), (x, yp, h), (x, yp, s), (x, ys, s)], (n, 0.0, 0.0))
    return b
