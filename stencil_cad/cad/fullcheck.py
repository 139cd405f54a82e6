"""OCCT's full B-rep check, on a whole shape or on tiles of the same construction.

``BRepCheck_Analyzer`` is quadratic in the wires of one face and in the faces of one shell,
so a big plate is checked on tiles (:func:`plate_tiles`): small plates built by the same code
from windows of its description (dense windows of holes, the label). The label's tile is
checked in groups of letters (:func:`label_windows`): its faces number about 30 per letter.
Measured on the example's eight labels (``time.process_time`` around building, storing the
plane curves and checking the label tiles): the whole label 1.64 CPU-s, in runs of six letters
1.32 (medians of three); runs of three took 1.33, of twelve 1.39 (one run each). A process checks
a letter or a pair of letters it found valid before only once (:func:`_label_valid`).
"""

from __future__ import annotations

import hashlib
import itertools
import threading
from collections import OrderedDict
from dataclasses import replace

import numpy as np

from ..model import PlateGeometry
from . import occt

__all__ = ["TILE_HOLES", "brep_valid", "check_tiles", "label_windows", "plate_tiles", "store_plane_pcurves"]

#: Holes per tile in the tile check.
TILE_HOLES = 80

#: Letters per run in the label tile's check (:func:`label_windows`).
LABEL_WINDOW_LETTERS = 6

#: Two letters whose bounding boxes, grown by this much (mm), meet are checked together.
LABEL_PAIR_MARGIN_MM = 0.1

#: Most letters and letter pairs a process remembers as found valid (:func:`_label_valid`): a key of
#: 32 bytes a letter, 64 a pair, a few hundred per job.
LABEL_CACHE_KEYS = 8192


def brep_valid(shape, plane_pcurves: bool = False) -> bool:
    """OCCT's full B-rep check (quadratic in the holes of one face: small shapes only).

    Args:
        shape: The OCCT shape.
        plane_pcurves: First store on every planar face the curves of its edges in the face's
            parameters (:func:`store_plane_pcurves`; this changes the shape): the same check,
            2-3 times faster on a face with many holes.
    """
    if plane_pcurves:
        store_plane_pcurves(shape)
    return occt.is_valid(shape)


def store_plane_pcurves(shape) -> None:
    """Store on each planar face of ``shape`` its edges' curves in the face's (u, v) parameters.

    A plate's planar faces carry no such curves: OCCT projects an edge onto a plane whenever it
    asks for the curve (``BRep_Tool::CurveOnSurface``), and ``BRepCheck_Face`` asks again for every
    pair of wires of a face when it classifies them, so most of a perforated face's check is
    that projection. ``BRepLib::BuildPCurveForEdgeOnPlane`` stores the very curve that call
    computes, with the edge's tolerance unchanged, so the check sees the same geometry and
    comes to the same verdict (``tests/cad/test_plate.py``), only sooner. Measured on the
    example's plates (OCP 7.9, ``time.process_time`` around ``BRepCheck_Analyzer(s).IsValid()``,
    two runs): a tile of 299 holes 1.06 -> 0.28-0.36 CPU-s, the whole plate of 274 holes and a
    label 1.6-2.2 -> 0.57-0.76 CPU-s, a label's tile 0.23-0.28 -> 0.19-0.22 CPU-s; the build
    stage of ``stencil-cad build`` on the example's saved dots 16.1 -> 13.2 CPU-s.
    """
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepLib import BRepLib
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    fexp = TopExp_Explorer(shape, TopAbs_FACE)
    while fexp.More():
        face = TopoDS.Face_s(fexp.Current())
        if BRepAdaptor_Surface(face, False).GetType() == GeomAbs_Plane:
            eexp = TopExp_Explorer(face, TopAbs_EDGE)
            while eexp.More():
                BRepLib.BuildPCurveForEdgeOnPlane_s(TopoDS.Edge_s(eexp.Current()), face)
                eexp.Next()
        fexp.Next()


def plate_tiles(geom: PlateGeometry, n_holes: int) -> list[tuple[str, PlateGeometry]]:
    """Small plates cut from windows of a big plate's description, built by the same code."""
    out = []
    xy = np.asarray(geom.circles_xy).reshape(-1, 2)
    r = np.asarray(geom.circles_r).reshape(-1)

    def window(name: str, cx: float, cy: float, half: float) -> None:
        x0, y0, x1, y1 = cx - half, cy - half, cx + half, cy + half
        inside = (xy[:, 0] - r > x0) & (xy[:, 0] + r < x1) & (xy[:, 1] - r > y0) & (xy[:, 1] + r < y1)
        polys = tuple(
            p
            for p in geom.polygons
            if p[:, 0].min() > x0 and p[:, 0].max() < x1 and p[:, 1].min() > y0 and p[:, 1].max() < y1
        )
        ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        out.append(
            (
                name,
                replace(
                    geom, outline=ring, circles_xy=xy[inside], circles_r=r[inside], polygons=polys, glyphs=()
                ),
            )
        )

    if len(r):
        # A window holding about n_holes holes at the densest place, and one at the first hole.
        area = geom.width_mm * geom.height_mm
        half = 0.5 * np.sqrt(area * n_holes / max(len(r), 1))
        i = int(np.argmax(r))
        window("largest-hole", float(xy[i, 0]), float(xy[i, 1]), half)
        window("first-hole", float(xy[0, 0]), float(xy[0, 1]), half)
        window("centre", 0.5 * geom.width_mm, 0.5 * geom.height_mm, half)
    elif geom.polygons:
        c = geom.polygons[0].mean(axis=0)
        window("first-polygon", c[0], c[1], max(geom.width_mm, geom.height_mm) * 0.2)
    if geom.glyphs and geom.label_box is not None:
        x0, y0, x1, y1 = geom.label_box
        ring = np.array([[x0 - 1, y0 - 1], [x1 + 1, y0 - 1], [x1 + 1, y1 + 1], [x0 - 1, y1 + 1]])
        out.append(
            (
                "label",
                replace(geom, outline=ring, circles_xy=np.zeros((0, 2)), circles_r=np.zeros(0), polygons=()),
            )
        )
    return out


def label_windows(
    glyphs: tuple, size: int = LABEL_WINDOW_LETTERS, margin_mm: float = LABEL_PAIR_MARGIN_MM
) -> list[tuple[int, ...]]:
    """Groups of a label's letters whose B-rep checks, together, check the whole label.

    What ``BRepCheck_Analyzer`` finds wrong in a label is either in one letter (its edges,
    vertices, wires, faces) or between two letters whose wires cross or nest, and two letters
    can only cross or nest where their bounding boxes meet. So the letters are checked in runs
    of ``size``, and every two letters in different runs whose boxes, grown by ``margin_mm``,
    meet are checked once more together: every letter and every such pair is in some group.

    Args:
        glyphs: ``(outer ring, inner rings)`` per letter, as in
            :attr:`~stencil_cad.model.PlateGeometry.glyphs`.
        size: Letters per run. Defaults to :data:`LABEL_WINDOW_LETTERS`.
        margin_mm: How much the boxes grow before they are compared. Defaults to
            :data:`LABEL_PAIR_MARGIN_MM`.

    Returns:
        Index tuples into ``glyphs``; one tuple of every letter when they fit in one run.
    """
    n = len(glyphs)
    if n <= size:
        return [tuple(range(n))]
    lo, hi = _letter_boxes(glyphs, margin_mm)
    meet = _boxes_meet(lo, hi)
    run = np.arange(n) // size
    i, j = np.nonzero(np.triu(meet & (run[:, None] != run[None, :]), 1))
    return [tuple(range(s, min(s + size, n))) for s in range(0, n, size)] + list(
        zip(i.tolist(), j.tolist(), strict=True)
    )


def _letter_boxes(glyphs: tuple, margin_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Each letter's bounding box grown by ``margin_mm`` (mm): ``(lo, hi)``, each ``(n, 2)``."""
    pts = [np.concatenate([np.asarray(o), *map(np.asarray, inner)]).reshape(-1, 2) for o, inner in glyphs]
    lo = np.array([p.min(axis=0) for p in pts]).reshape(-1, 2) - margin_mm
    hi = np.array([p.max(axis=0) for p in pts]).reshape(-1, 2) + margin_mm
    return lo, hi


def _boxes_meet(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``(n, n)`` booleans: whether boxes ``i`` and ``j`` meet (touching counts)."""
    return np.asarray(((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None])).all(axis=2))


class _Checked:
    """Keys of the letters and letter pairs a label tile's check found valid: the newest ``size``, thread-safe."""

    def __init__(self, size: int):
        self._keys: OrderedDict[bytes, None] = OrderedDict()
        self._size = size
        self._lock = threading.Lock()

    def __contains__(self, key: object) -> bool:
        with self._lock:
            if key not in self._keys:
                return False
            self._keys.move_to_end(key)  # type: ignore[arg-type]
            return True

    def add(self, keys: list[bytes]) -> None:
        with self._lock:
            for key in keys:
                self._keys[key] = None
                self._keys.move_to_end(key)
            while len(self._keys) > self._size:
                self._keys.popitem(last=False)


#: The letters and letter pairs this process has found valid (:func:`_label_valid`).
_CHECKED = _Checked(LABEL_CACHE_KEYS)


def _letter_key(tile: PlateGeometry, glyph) -> bytes:
    """A digest of everything a letter's own faces are built from: the plate's thickness and relief, its rings' bits."""
    h = hashlib.sha256(np.array([tile.thickness_mm, tile.relief_mm], dtype=np.float64).tobytes())
    outer, inner = glyph
    for ring in (outer, *inner):
        r = np.ascontiguousarray(ring, dtype=np.float64)
        h.update(len(r).to_bytes(8, "little"))
        h.update(r.tobytes())
    return h.digest()


def _label_valid(
    tile: PlateGeometry, size: int = LABEL_WINDOW_LETTERS, margin_mm: float = LABEL_PAIR_MARGIN_MM
) -> bool:
    """OCCT's full check of a label tile in groups of letters, leaving out what this process found valid before.

    The check in groups (:func:`label_windows`) rests on this: what ``BRepCheck_Analyzer`` finds
    wrong in a label tile is in one letter (its edges, vertices, wires, faces), between two
    letters whose boxes meet, or between a letter and the tile's outline. A letter's faces are
    built from its rings, the plate's thickness and its relief alone, by the same code, so a letter
    whose rings have the same bits as one found valid before, on the same thickness and relief,
    is the same B-rep and gets the same verdict; so does a pair of such letters. Its relation to
    the outline, a rectangle, needs no check when its box grown by ``margin_mm`` lies inside the
    rectangle. So only the letters (in runs of ``size``) and the meeting pairs not found valid
    before are checked; a changed letter, a letter across the edge, crossing letters are new and
    checked as before (``tests/cad/test_fullcheck.py``).

    Labels of one job differ in a few characters and the same text lays out to the same bits:
    of the example's 175 letters on seven label tiles, 74 are new to the process. Its seven label
    tiles' checks took 1.28 CPU-s in groups, 0.59 so (medians of three, each a fresh process,
    ``time.process_time`` around the checks of the label tiles ``stencil-cad build`` made).
    """
    from .solid import make_solid

    glyphs = tile.glyphs
    n = len(glyphs)
    keys = [_letter_key(tile, g) for g in glyphs]
    lo, hi = _letter_boxes(glyphs, margin_mm)
    ring = np.asarray(tile.outline, dtype=np.float64)
    olo, ohi = ring.min(axis=0), ring.max(axis=0)
    # A rectangle: four sides, each along x or along y (four corners in a bow-tie order are not one).
    sides = np.diff(ring, axis=0, append=ring[:1]) != 0
    rectangle = len(ring) == 4 and bool((sides.sum(axis=1) == 1).all()) and bool(sides.any(axis=0).all())
    inside = rectangle & (lo > olo).all(axis=1) & (hi < ohi).all(axis=1)
    todo = [i for i in range(n) if not (inside[i] and keys[i] in _CHECKED)]
    meet = _boxes_meet(lo, hi)
    pairs = {(i, j) for i, j in zip(*np.nonzero(np.triu(meet, 1)), strict=True)}
    pending = {(i, j) for i, j in pairs if _pair_key(keys, i, j) not in _CHECKED}
    runs = [tuple(todo[s : s + size]) for s in range(0, len(todo), size)]
    within = {(i, j) for w in runs for i, j in itertools.combinations(w, 2)}
    for w in runs + sorted(pending - within):
        if not brep_valid(make_solid(replace(tile, glyphs=tuple(glyphs[i] for i in w))), plane_pcurves=True):
            return False
        _CHECKED.add(
            [keys[i] for i in w]
            + [_pair_key(keys, i, j) for i, j in itertools.combinations(w, 2) if (i, j) in pairs]
        )
    return True


def _pair_key(keys: list[bytes], i: int, j: int) -> bytes:
    return b"".join(sorted((keys[i], keys[j])))


def _tile_valid(name: str, tile: PlateGeometry) -> bool:
    """OCCT's full check of one tile; the label tile's in groups of letters (:func:`_label_valid`)."""
    from .solid import make_solid

    if name != "label":
        return brep_valid(make_solid(tile), plane_pcurves=True)
    return _label_valid(tile)


def check_tiles(geom: PlateGeometry, tile_holes: int = TILE_HOLES) -> tuple[list[dict], list[str]]:
    """OCCT's full check on tiles of the same construction: ``(per-tile figures, failures)``."""
    tiles_info, fails = [], []
    for name, tg in plate_tiles(geom, tile_holes):
        ok = _tile_valid(name, tg)
        tiles_info.append({"tile": name, "holes": tg.hole_count, "valid": ok})
        if not ok:
            fails.append(f"BRepCheck_Analyzer: tile {name!r} ({tg.hole_count} holes) is not valid")
    return tiles_info, fails
