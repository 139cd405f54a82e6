"""Small frozen value objects passed between the pipeline stages.

Arrays follow one convention: images are ``(row, col)`` with the origin at the
top-left pixel; geometry is ``(x, y)`` in millimetres with y up and the origin at
the bottom-left corner of the picture area. Only :mod:`stencil_cad.frames`
converts between the two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    h, w = alphas.shape[1:]
    out = np.empty((h, w, 3), dtype=np.float64)
    out[...] = np.asarray(primer, dtype=np.float64)
    for colour, a in zip(colours, alphas, strict=True):
        a3 = a[..., None]
        out *= 1.0 - a3
        out += a3 * np.asarray(colour, dtype=np.float64)
    return out


@dataclass(frozen=True)
class DotSet:
    """The holes of one soft-stencil layer.

    Attributes:
        xy_mm: ``(N, 2)`` ndarray of float, hole centres in mm (x right, y up,
            origin at the bottom-left of the picture area).
        r_mm: ``(N,)`` ndarray of float, hole radii in mm (never below 0.5).
        report: Figures about how the dots were made and checked (removed,
            merged or nudged counts, smallest web achieved, iterations).
    """

    xy_mm: np.ndarray
    r_mm: np.ndarray
    report: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.r_mm.shape[0])


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
