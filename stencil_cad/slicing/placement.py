"""How a part lies on the bed: as exported, or turned a quarter turn when only that fits (kernel-free).

Plates and walls are exported in the picture frame, so a portrait tile of a mural comes out
taller than wide; on a landscape bed (Prusa MK4: 250 × 210 mm) it fits only turned by 90°.
The slicer is given a turned copy of the mesh (about its own centre, in the bed plane), which
keeps a plate split into slicing tiles together, whatever the slicer.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exchange.mesh import read_stl, write_triangles_stl

__all__ = ["Placement", "place", "rotated_copy"]

#: Slack in mm when comparing a part with the bed (floating-point bounding boxes).
FIT_TOL_MM = 1e-6


@dataclass(frozen=True)
class Placement:
    """A part's footprint and how it lies on a bed.

    Attributes:
        size_mm: ``(w, h)`` of the part as exported, in mm.
        bed_mm: ``(x, y)`` of the bed, in mm.
        rotate_deg: 0 (as exported) or 90 (a quarter turn about Z); None when neither fits.
    """

    size_mm: tuple[float, float]
    bed_mm: tuple[float, float]
    rotate_deg: int | None

    @property
    def fits(self) -> bool:
        """True when the part lies on the bed one way or the other."""
        return self.rotate_deg is not None

    def describe(self) -> str:
        """One phrase for the maker, e.g. ``turned 90° to fit the 250 × 210 mm bed``."""
        w, h = self.size_mm
        bx, by = self.bed_mm
        if self.rotate_deg == 90:
            return f"{w:.1f} × {h:.1f} mm, turned 90° to fit the {bx:g} × {by:g} mm bed"
        if self.rotate_deg == 0:
            return f"{w:.1f} × {h:.1f} mm, as exported on the {bx:g} × {by:g} mm bed"
        return f"{w:.1f} × {h:.1f} mm, larger than the {bx:g} × {by:g} mm bed either way round"


def place(size_mm: tuple[float, float], bed_mm: tuple[float, float]) -> Placement:
    """How a ``w × h`` part lies on an ``x × y`` bed: as exported when it fits, else turned 90°.

    Args:
        size_mm: ``(w, h)`` of the part's footprint in mm.
        bed_mm: ``(x, y)`` of the bed in mm.

    Returns:
        The :class:`Placement` (``rotate_deg`` None when the part fits neither way).
    """
    w, h = (float(v) for v in size_mm)
    bx, by = (float(v) for v in bed_mm)
    if w <= bx + FIT_TOL_MM and h <= by + FIT_TOL_MM:
        rot: int | None = 0
    elif h <= bx + FIT_TOL_MM and w <= by + FIT_TOL_MM:
        rot = 90
    else:
        rot = None
    return Placement((w, h), (bx, by), rot)


def rotated_copy(stl: str | os.PathLike, dest: str | os.PathLike) -> Path:
    """Write ``stl`` turned a quarter turn (counter-clockwise about Z, seen from above) to ``dest``.

    The turn is about the footprint's centre, so the part stays where it was on the bed;
    z is unchanged (a plate stays plate-down).

    Returns:
        ``dest``.
    """
    tri = read_stl(stl)
    pts = tri.reshape(-1, 3)
    centre = 0.5 * (pts[:, :2].min(axis=0) + pts[:, :2].max(axis=0))
    x, y = pts[:, 0] - centre[0], pts[:, 1] - centre[1]
    out = np.column_stack([centre[0] - y, centre[1] + x, pts[:, 2]]).reshape(tri.shape)
    write_triangles_stl(dest, out)
    return Path(dest)
