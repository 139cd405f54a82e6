"""A line of text as polygon rings, read from the font file by fontTools: the label's letters without a CAD kernel.

:func:`text_rings` lays a line out as OCCT's text builder did: each glyph's outline scaled so the
font's em is ``size`` mm, the pen moved by the glyph's advance and the font's kerning of the pair
(its ``kern`` table, which FreeType reads for OCCT), and the ink's low corner moved to the origin.
Its TrueType contours are quadratic curves, flattened here into chords: a quadratic Bézier's chord
over a parameter step ``h`` strays at most ``|P0 - 2 P1 + P2| h² / 4`` from it, so each curve is
cut into the fewest equal steps that keep that under the tolerance. A glyph's contours are grouped
into faces by nesting (a contour inside an odd number of others, by most of its vertices, is a
hole of the innermost one around it), each face an outer ring counter-clockwise and its holes
clockwise: for every character of the bundled font, the faces and holes OCCT gave, but for the 69
whose mark overlaps or touches its letter (the cedilla of Ç, the ogonek of ą, the horn of ư …):
OCCT's faces crossed there, which made a label refuse them, and here the glyph is filled by the
font's non-zero rule (manifold3d's ``CrossSection``) into faces that do not.

Until now the letters came from OCCT's font classes (``StdPrs_BRepTextBuilder``), which made every
job import OCP: ``tests/cad/test_label_order.py`` holds these rings to build123d's ``Text`` in the
same font (the faces OCCT gave): the same faces and holes, within 1.02 times the tolerance in
Hausdorff distance at 0.01, 0.001 and 0.0001 mm (so the same size, advances and kerning; two
flattenings of one curve each within the tolerance may differ by twice it) and within 0.22 % in
ink area at 0.01 mm (chords inside the curves, both ways); and to one order in every process and
thread. Setting a label of the example (``L3/8  SPRAY 3  #1A2B3C  example`` at 4 mm, 0.01 mm)
took 7.2 ms here against 24 ms through OCCT (``python -m timeit``), without importing OCP.
"""

from __future__ import annotations

import functools
import math
import threading
import unicodedata

import numpy as np

from ..geometry import as_ccw, as_cw, points_in_ring, polygon_area, rings_cross

__all__ = ["FONT_LOCK", "text_rings"]

#: A kernel's font manager is one per process and not thread-safe (:mod:`.label` sets other
#: fonts through build123d under it); fontTools' tables load lazily, so a font is read under it too.
FONT_LOCK = threading.Lock()

Glyph = tuple[np.ndarray, list[np.ndarray]]


class _Font:
    """What the layout reads from a font file: its em, character map, advances, kerning and contours (font units)."""

    def __init__(self, path: str) -> None:
        from fontTools.ttLib import TTFont

        tt = TTFont(path)
        self.em = float(tt["head"].unitsPerEm)
        self.cmap: dict[int, str] = dict(tt.getBestCmap())
        self.advance = {name: int(adv) for name, (adv, _) in tt["hmtx"].metrics.items()}
        self.kerning: dict[tuple[str, str], int] = {}
        if "kern" in tt:
            for table in tt["kern"].kernTables:
                self.kerning.update(getattr(table, "kernTable", {}))
        self._glyf = tt["glyf"]
        self._contours: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}

    def contours(self, name: str) -> list[tuple[np.ndarray, np.ndarray]]:
        """A glyph's contours, ``(points (N, 2), on-curve flags (N,))`` each, read once (under :data:`FONT_LOCK`)."""
        with FONT_LOCK:
            if name not in self._contours:
                coords, ends, flags = self._glyf[name].getCoordinates(self._glyf)
                pts = np.asarray(coords, dtype=np.float64).reshape(-1, 2)
                on = (np.asarray(flags, dtype=np.uint8) & 1).astype(bool)
                starts = [0, *(int(e) + 1 for e in ends[:-1])] if len(ends) else []
                self._contours[name] = [
                    (pts[a : int(b) + 1], on[a : int(b) + 1]) for a, b in zip(starts, ends, strict=True)
                ]
            return self._contours[name]


@functools.lru_cache(maxsize=4)
def _font(path: str) -> _Font:
    """The font file at ``path``, read once per process (its glyphs as they are asked for)."""
    with FONT_LOCK:
        return _Font(path)


def _flatten(pts: np.ndarray, on: np.ndarray, tol: float) -> np.ndarray:
    """One closed TrueType contour (already in mm) as a ring of chords, each curve within ``tol``."""
    if not on.any():  # all off-curve: the midpoints between them are on it
        pts = np.vstack([0.5 * (pts + np.roll(pts, -1, axis=0))[-1:], pts])
        on = np.concatenate([[True], on])
    first = int(np.argmax(on))
    pts, on = np.roll(pts, -first, axis=0), np.roll(on, -first)
    out = [pts[:1]]
    n = len(pts)
    k = 1
    p0 = pts[0]
    while k <= n:
        p = pts[k % n]
        if on[k % n]:
            out.append(p[None])
            p0, k = p, k + 1
            continue
        nxt = pts[(k + 1) % n]
        p2 = nxt if on[(k + 1) % n] else 0.5 * (p + nxt)
        bend = float(np.hypot(*(p0 - 2.0 * p + p2)))
        steps = max(1, math.ceil(math.sqrt(bend / (4.0 * tol)))) if tol > 0 else 16
        t = np.arange(1, steps + 1)[:, None] / steps
        out.append((1 - t) ** 2 * p0 + 2 * (1 - t) * t * p + t**2 * p2)
        p0 = p2
        k += 2 if on[(k + 1) % n] else 1
    ring = np.concatenate(out)[:-1]  # the last point closes the ring on the first
    keep = np.linalg.norm(np.diff(ring, axis=0, append=ring[:1]), axis=1) > 1e-6
    return ring[keep]


def _inside(ring: np.ndarray, other: np.ndarray) -> bool:
    """Whether ``ring`` lies inside ``other``: most of its vertices do.

    A glyph's contours may touch at a vertex (U+2732's inner star starts on its outer one), where a
    test of one vertex says each lies inside the other.
    """
    return 2 * int(np.count_nonzero(points_in_ring(ring, other))) > len(ring)


def _faces(rings: list[np.ndarray]) -> list[Glyph]:
    """A glyph's rings grouped into faces by nesting: ``(outer ccw, [holes cw])``."""
    rings = [r for r in rings if len(r) >= 3]
    inside = np.array(
        [[i != j and _inside(rings[i], rings[j]) for j in range(len(rings))] for i in range(len(rings))]
    ).reshape(len(rings), len(rings))
    depth = inside.sum(axis=1)
    faces: dict[int, Glyph] = {i: (as_ccw(r), []) for i, r in enumerate(rings) if depth[i] % 2 == 0}
    for i, r in enumerate(rings):
        if depth[i] % 2 == 1:
            owner = max((j for j in faces if inside[i, j]), key=lambda j: depth[j])
            faces[owner][1].append(as_cw(r))
    if len(faces) > 1 and rings_cross(rings, within=False):
        return _filled(rings)
    return list(faces.values())


def _filled(rings: list[np.ndarray]) -> list[Glyph]:
    """The faces a glyph's crossing contours fill by TrueType's non-zero rule: a mark merged with its letter.

    A cedilla or an ogonek overlaps or touches its letter (Ç, ą, ş): as faces of their own they
    would cross, which a plate's label refuses.
    """
    from manifold3d import CrossSection, FillRule

    filled = CrossSection([np.ascontiguousarray(r) for r in rings], FillRule.NonZero)
    out: list[Glyph] = []
    for part in filled.decompose():
        polys = [np.asarray(p, dtype=np.float64) for p in part.to_polygons()]
        k = int(np.argmax([abs(polygon_area(p)) for p in polys]))
        out.append((as_ccw(polys[k]), [as_cw(p) for i, p in enumerate(polys) if i != k]))
    return out


def _one_line(text: str) -> str:
    """``text`` with its control characters out: a tab or line break as a space, the rest dropped.

    The font has no glyph for them, so fontTools would set its missing-glyph box where OCCT's text
    builder spaced a tab, broke the line and stopped at a NUL; a label is one line.
    """
    return "".join((" " if ch.isspace() else "") if unicodedata.category(ch) == "Cc" else ch for ch in text)


def text_rings(text: str, size: float, path: str, tol: float) -> list[Glyph]:
    """The faces of ``text`` set in the font file ``path``, its ink's low corner at the origin.

    Args:
        text: One line of text (a tab or line break in it is set as a space, other control
            characters left out; a character the font lacks as its missing-glyph box).
        size: Font size in mm (the font's em).
        path: The font file (TrueType outlines).
        tol: Largest chord error of the rings in mm.

    Returns:
        ``(outer, holes)`` per face, glyph by glyph: ``(N, 2)`` rings in mm, the outer
        counter-clockwise, the holes clockwise.
    """
    font = _font(path)
    scale = float(size) / font.em
    names = [font.cmap.get(ord(ch), ".notdef") for ch in _one_line(text)]
    glyphs: list[Glyph] = []
    pen = 0.0
    for i, name in enumerate(names):
        rings = [_flatten(pts * scale + [pen, 0.0], on, tol) for pts, on in font.contours(name)]
        glyphs.extend(_faces(rings))
        kern = font.kerning.get((name, names[i + 1]), 0) if i + 1 < len(names) else 0
        pen += (font.advance.get(name, 0) + kern) * scale
    if not glyphs:
        return []
    lo = np.concatenate([g[0] for g in glyphs]).min(axis=0)
    return [(outer - lo, [h - lo for h in holes]) for outer, holes in glyphs]
