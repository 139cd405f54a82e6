"""Small frozen value objects passed between the pipeline stages.

Image → :class:`Picture` → :class:`Layers` → :class:`DotSet` (soft) or
:class:`CutLayer` (hard) → :class:`PlateGeometry` → :class:`TriMesh`, STEP, DXF.

Arrays follow one convention: images are ``(row, col)`` with the origin at the
top-left pixel; geometry is ``(x, y)`` in millimetres with y up and the origin at
the bottom-left corner of the picture area. Only :mod:`stencil_cad.frames`
converts between the two.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from .geometry import polygon_area


@dataclass(frozen=True)
class Picture:
    """An input image resampled to the working grid.

    Attributes:
        rgb: ``(H, W, 3)`` ndarray of float in [0, 1], sRGB.
        mm_per_px: Size of one pixel on the stencil, in mm.
        alpha: ``(H, W)`` ndarray of float in [0, 1], or None. The image's own
            alpha channel (RGBA input) or None.
        grey: True when the source had a single channel.
        source: Where the picture came from (a path or "bundled example").
        distinct_colours: Number of distinct 8-bit colours of the source file
            BEFORE resampling (resampling blends edges into new colours),
            counted up to a cap (a value at the cap means "at least"), or None
            when unknown.
    """

    rgb: np.ndarray
    mm_per_px: float
    alpha: np.ndarray | None = None
    grey: bool = False
    source: str = ""
    distinct_colours: int | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` in pixels."""
        return int(self.rgb.shape[0]), int(self.rgb.shape[1])

    @property
    def width_mm(self) -> float:
        """Width of the picture area in mm."""
        return self.rgb.shape[1] * self.mm_per_px

    @property
    def height_mm(self) -> float:
        """Height of the picture area in mm."""
        return self.rgb.shape[0] * self.mm_per_px


@dataclass(frozen=True)
class Layers:
    """A primer colour plus L paint layers composited with Porter-Duff *over*.

    ``C_0 = primer``; ``C_i = (1 - alpha_i) C_{i-1} + alpha_i colours[i-1]``;
    layer order is spray order.

    Attributes:
        primer: ``(3,)`` ndarray of float in [0, 1].
        colours: ``(L, 3)`` ndarray of float in [0, 1], in spray order.
        alphas: ``(L, H, W)`` ndarray of float in [0, 1], in spray order.
        mm_per_px: Pixel size in mm of the grid the alphas live on.
        energy_trace: Total energy after each solver iteration (empty when the
            decomposition was skipped).
        iterations: Solver iterations run.
        info: Free-form figures for the manifest (RMSE, warnings, timings).
    """

    primer: np.ndarray
    colours: np.ndarray
    alphas: np.ndarray
    mm_per_px: float
    energy_trace: tuple[float, ...] = ()
    iterations: int = 0
    info: dict = field(default_factory=dict)

    @property
    def count(self) -> int:
        """Number of paint layers L."""
        return int(self.alphas.shape[0])

    def composite(self) -> np.ndarray:
        """The composite image, ``(H, W, 3)`` float in [0, 1]."""
        return composite(self.primer, self.colours, self.alphas)


def composite(primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """Porter-Duff *over* of each layer onto the primer, in order.

    Args:
        primer: ``(3,)`` primer colour in [0, 1].
        colours: ``(L, 3)`` paint colours in [0, 1].
        alphas: ``(L, H, W)`` opacities in [0, 1].

    Returns:
        ``(H, W, 3)`` ndarray of float.
    """
    planes = _primer_planes(primer, alphas.shape[1:])
    for _ in _over(planes, colours, alphas):
        pass
    return np.ascontiguousarray(planes.transpose(1, 2, 0))


def composites(primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> Iterator[np.ndarray]:
    """:func:`composite` of the first 1, 2, … L layers, in turn: the picture as each layer is sprayed.

    Each is a new ``(H, W, 3)`` array, the same bits as :func:`composite` of that many layers.
    """
    planes = _primer_planes(primer, alphas.shape[1:])
    for _ in _over(planes, colours, alphas):
        yield np.ascontiguousarray(planes.transpose(1, 2, 0))


def _primer_planes(primer: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``(3, H, W)``: the primer's colour planes."""
    planes = np.empty((3, *shape), dtype=np.float64)
    planes[...] = np.asarray(primer, dtype=np.float64)[:, None, None]
    return planes


def _over(planes: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> Iterator[None]:
    """Composite each layer over ``planes`` in place, yielding after each.

    The colour planes are composited apart, each contiguous, and interleaved once per picture:
    the same operations per pixel as over the interleaved picture, about 5 times faster (8 layers
    of 600 x 600 px: 0.050 CPU-s interleaved, 0.010 planar; ``model.composite`` in the profile of
    ``python -m cProfile -m stencil_cad run``).
    """
    for colour, a in zip(colours, alphas, strict=True):
        c = np.asarray(colour, dtype=np.float64)
        t = 1.0 - a
        for k in range(3):
            planes[k] *= t
            planes[k] += a * c[k]
        yield


def coat_contrast(primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """How much each layer's opacity moves the composite colour: ``|T_l (c_l - B_{l-1})|^2``.

    With every other layer fixed the composite is affine in ``alpha_l``, with slope
    ``T_l (c_l - B_{l-1})`` (``B_{l-1}``: the composite of the layers below, ``T_l``: the
    transmittance of those above), so an opacity error ``e`` of layer ``l`` at a pixel is a
    colour error of squared size ``e^2`` times this. It weighs a layer's opacity errors
    in composite colour: a sparse scatter of orange dots over dark blue counts for more
    than the same scatter over yellow.

    Args:
        primer: ``(3,)`` primer colour in [0, 1].
        colours: ``(L, 3)`` paint colours in [0, 1].
        alphas: ``(L, H, W)`` opacities in [0, 1].

    Returns:
        ``(L, H, W)`` ndarray (squared sRGB distance, 0 to 3) in the alphas' float type
        (float32 alphas, as the pipeline keeps them, give float32: a mural's layers are large).
    """
    alphas = np.asarray(alphas)
    dtype = alphas.dtype if alphas.dtype in (np.float32, np.float64) else np.dtype(np.float64)
    alphas = alphas.astype(dtype, copy=False)
    below = np.empty((*alphas.shape[1:], 3), dtype=dtype)
    below[...] = np.asarray(primer, dtype=dtype)
    out = np.empty(alphas.shape, dtype=dtype)
    for layer, (colour, a) in enumerate(zip(np.asarray(colours, dtype=dtype), alphas, strict=True)):
        out[layer] = ((colour - below) ** 2).sum(axis=-1)
        below += a[..., None] * (colour - below)
    trans = np.ones(alphas.shape[1:], dtype=dtype)
    for layer in range(alphas.shape[0] - 1, -1, -1):
        out[layer] *= trans * trans
        trans *= 1.0 - alphas[layer]
    return out


@dataclass(frozen=True)
class DotSet:
    """The holes of one soft-stencil layer: round holes, and windows on a hybrid plate.

    Like :class:`CutLayer` it has ``xy_mm``, ``r_mm``, ``polygons`` and
    ``hole_count``, so the plate builder, its checks and the DXF writer take either
    (see :data:`Holes`) without asking which.

    Attributes:
        xy_mm: ``(N, 2)`` ndarray of float, hole centres in mm (x right, y up,
            origin at the bottom-left of the picture area).
        r_mm: ``(N,)`` ndarray of float, hole radii in mm (never below 0.5).
        report: Figures about how the dots were made and checked (removed,
            merged or nudged counts, smallest web achieved, iterations).
        spray_time: The layer's amount of paint: whole passes (physical spray model) or
            the paper model's spray time; None until the tone calibration or ``spray.json``
            gives one (then the config's, see :meth:`amount`).
        windows: Open windows of a hybrid plate (:mod:`stencil_cad.stipple.windows`), each
            ``(outer, ())``: ``outer`` an ``(M, 2)`` ring of (x, y) mm, counter-clockwise, its
            islands held by bridges (so no inner rings); every hole keeps a web's distance from
            them. Empty for a plate of holes only.
    """

    xy_mm: np.ndarray
    r_mm: np.ndarray
    report: dict = field(default_factory=dict)
    spray_time: float | None = None
    windows: tuple = ()

    def __len__(self) -> int:
        return int(self.r_mm.shape[0])

    def amount(self, default: float) -> float:
        """The layer's amount of paint (:attr:`spray_time`), or ``default`` (the config's) when unset."""
        return float(default if self.spray_time is None else self.spray_time)

    @property
    def polygons(self) -> tuple:
        """Polygon cut-outs: the windows (none on a plate of holes only)."""
        return self.windows

    @property
    def hole_count(self) -> int:
        """Number of through holes: round holes and windows."""
        return len(self) + len(self.windows)


@dataclass(frozen=True)
class CutLayer:
    """The cut-outs of one hard-stencil layer, as polygons in mm.

    Attributes:
        polygons: Each entry is ``(outer, holes)``: ``outer`` an ``(M, 2)``
            ndarray ring of (x, y) mm counter-clockwise, ``holes`` a list of
            rings clockwise, the parts of the cut that stay as sheet.
        colour: ``(3,)`` paint colour in [0, 1].
        report: Figures (bridges, widened or dropped regions).
    """

    polygons: list
    colour: np.ndarray
    report: dict = field(default_factory=dict)

    @property
    def xy_mm(self) -> np.ndarray:
        """Round hole centres: none, ``(0, 2)`` (a hard layer has polygon cut-outs only)."""
        return np.zeros((0, 2))

    @property
    def r_mm(self) -> np.ndarray:
        """Round hole radii: none, ``(0,)``."""
        return np.zeros(0)

    @property
    def hole_count(self) -> int:
        """Number of cut-outs."""
        return len(self.polygons)

    def cutout_figures(self) -> dict:
        """What the cut-outs are like: count, smallest and largest span and open area.

        Returns:
            ``{"count", "span_min_mm", "span_max_mm", "open_mm2"}``: the span of a cut-out is the
            longer side of its bounding box in mm; the open area (mm²) leaves out the islands.
        """
        spans, area = [], 0.0
        for outer, holes in self.polygons:
            ring = np.asarray(outer, dtype=np.float64).reshape(-1, 2)
            spans.append(float(np.max(ring.max(axis=0) - ring.min(axis=0))))
            area += abs(polygon_area(ring)) - sum(abs(polygon_area(np.asarray(h))) for h in holes)
        return {
            "count": len(spans),
            "span_min_mm": round(min(spans), 2) if spans else 0.0,
            "span_max_mm": round(max(spans), 2) if spans else 0.0,
            "open_mm2": round(area, 1),
        }


#: The holes of one plate: round (a soft layer's :class:`DotSet`) or polygon cut-outs (a
#: hard layer's :class:`CutLayer`). Both have ``xy_mm``, ``r_mm``, ``polygons`` and
#: ``hole_count``; the one a layer does not use is empty.
Holes = DotSet | CutLayer


@dataclass(frozen=True)
class PlateGeometry:
    """A plate as plain arrays, in the picture frame (mm, y up), z from 0 up.

    Attributes:
        width_mm: Picture width in mm (the picture area is ``[0, w] x [0, h]``).
        height_mm: Picture height in mm.
        thickness_mm: Plate thickness in mm.
        outline: ``(M, 2)`` ring, counter-clockwise: the plate's outer boundary.
        circles_xy: ``(N, 2)`` round hole centres in mm.
        circles_r: ``(N,)`` round hole radii in mm.
        polygons: Polygon cut-outs (hard stencils), each an ``(K, 2)`` ring,
            counter-clockwise.
        glyphs: The label's letters and up-arrow, each ``(outer, inners)``:
            ``outer`` a counter-clockwise ring, ``inners`` clockwise rings.
        relief_mm: Label relief in mm: negative engraves the glyphs that deep
            into the top face, positive embosses them that high, 0 for none.
        label_box: ``(x0, y0, x1, y1)`` mm, a rectangle inside the plate and
            clear of every hole that contains all glyphs, or None.
        extra_holes: How many of the last round holes a template added (a hanging
            hole, say) on top of the layer's own dots.
    """

    width_mm: float
    height_mm: float
    thickness_mm: float
    outline: np.ndarray
    circles_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    circles_r: np.ndarray = field(default_factory=lambda: np.zeros(0))
    polygons: tuple = ()
    glyphs: tuple = ()
    relief_mm: float = 0.0
    label_box: tuple[float, float, float, float] | None = None
    extra_holes: int = 0

    @property
    def hole_count(self) -> int:
        """Number of through holes (round and polygonal)."""
        return int(len(self.circles_r) + len(self.polygons))

    @property
    def outline_area(self) -> float:
        """Area of the outline in mm²."""
        return polygon_area(self.outline)

    @property
    def hole_area(self) -> float:
        """Total area of the through holes in mm² (exact circles)."""
        return float(
            math.pi * np.sum(np.square(self.circles_r)) + sum(polygon_area(p) for p in self.polygons)
        )

    @property
    def glyph_area(self) -> float:
        """Total area of the label's glyphs in mm²."""
        return float(sum(polygon_area(o) + sum(polygon_area(i) for i in inn) for o, inn in self.glyphs))

    @property
    def volume(self) -> float:
        """Analytic volume in mm³: (outline − holes) × thickness + glyphs × relief."""
        return (self.outline_area - self.hole_area) * self.thickness_mm + self.glyph_area * self.relief_mm

    @property
    def bbox(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """``((xmin, ymin, zmin), (xmax, ymax, zmax))`` in mm."""
        lo = self.outline.min(axis=0)
        hi = self.outline.max(axis=0)
        top = self.thickness_mm + max(self.relief_mm, 0.0)
        return (float(lo[0]), float(lo[1]), 0.0), (float(hi[0]), float(hi[1]), float(top))


@dataclass(frozen=True)
class TriMesh:
    """An indexed triangle mesh, triangles counter-clockwise seen from outside.

    Attributes:
        vertices: ``(V, 3)`` float64 in mm.
        faces: ``(F, 3)`` int64 vertex indices.
        info: Figures from the mesher (vertices, recovery rounds, timings).
    """

    vertices: np.ndarray
    faces: np.ndarray
    info: dict = field(default_factory=dict)
