"""The post that carries a mural plate off the surface (:mod:`stencil_cad.mural.posts`).

A foot (a cylinder as tall as the stand-off) with a thinner pin on top, as tall as the plate is
thick: the pin pushes into the plate's pin hole from below, so the plate's underside rests on the
foot at the stand-off and the pin's top is flush with the plate's top. It prints foot down, the
pin on top, no overhang. Every post of a job is the same part.

One solid, analytic volume ``pi * R**2 * s + pi * r**2 * t``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import build123d as bd

from .solid import check_simple_solid

__all__ = ["PostCheckError", "PostModel", "build_post", "check_post", "post_step", "post_stl"]


@dataclass(frozen=True)
class PostModel:
    """A built post and its sizes.

    Attributes:
        part: The solid (foot on z = 0, pin up).
        radius_mm: The foot's radius, mm.
        height_mm: The foot's height (the stand-off), mm.
        pin_radius_mm: The pin's radius, mm.
        pin_height_mm: The pin's height (the plate's thickness), mm.
    """

    part: bd.Part
    radius_mm: float
    height_mm: float
    pin_radius_mm: float
    pin_height_mm: float

    @property
    def volume_mm3(self) -> float:
        """The analytic volume, mm³."""
        return math.pi * (self.radius_mm**2 * self.height_mm + self.pin_radius_mm**2 * self.pin_height_mm)

    @property
    def bbox(self) -> tuple[float, float, float, float, float, float]:
        """The expected bounding box ``(x0, y0, z0, x1, y1, z1)`` in mm."""
        r = self.radius_mm
        return (-r, -r, 0.0, r, r, self.height_mm + self.pin_height_mm)


def build_post(radius_mm: float, height_mm: float, pin_radius_mm: float, pin_height_mm: float) -> PostModel:
    """A post: a foot of ``radius_mm`` × ``height_mm`` and a pin of ``pin_radius_mm`` × ``pin_height_mm`` on it.

    Raises:
        ValueError: A size is not positive, or the pin is not thinner than the foot.
    """
    if min(radius_mm, height_mm, pin_radius_mm, pin_height_mm) <= 0:
        raise ValueError(
            f"post sizes must be positive: foot {radius_mm} × {height_mm} mm, pin {pin_radius_mm} × {pin_height_mm} mm"
        )
    if pin_radius_mm >= radius_mm:
        raise ValueError(
            f"a post's pin (radius {pin_radius_mm} mm) must be thinner than its foot ({radius_mm} mm)"
        )
    align = (bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN)
    foot = bd.Cylinder(radius_mm, height_mm, align=align)
    pin = bd.Pos(0, 0, height_mm) * bd.Cylinder(pin_radius_mm, pin_height_mm, align=align)
    part = foot.fuse(pin).clean()
    return PostModel(bd.Part(part.wrapped), radius_mm, height_mm, pin_radius_mm, pin_height_mm)


def post_step(model: PostModel, path: str | Path) -> None:
    """Write the post as STEP (AP214, mm, exact circles) to ``path``."""
    if not bd.export_step(model.part, str(path), timestamp="2000-01-01T00:00:00"):
        raise OSError(f"STEP export failed: {path}")


def post_stl(model: PostModel, path: str | Path, tolerance_mm: float = 0.01) -> None:
    """Write the post as binary STL to ``path`` (a chord error of ``tolerance_mm``)."""
    if not bd.export_stl(model.part, str(path), tolerance=tolerance_mm, angular_tolerance=0.1):
        raise OSError(f"STL export failed: {path}")


class PostCheckError(RuntimeError):
    """A built post failed its checks (not one valid solid, or the volume or box is off)."""


def check_post(model: PostModel, rel_tol: float = 1e-6) -> dict:
    """Check a post against its analytic oracle: one valid solid, its volume and bounding box.

    Returns:
        ``n_solids``, ``valid``, ``volume``, ``analytic_volume``, ``rel_error``, ``bbox``.

    Raises:
        PostCheckError: Naming the failed check.
    """
    return check_simple_solid(model.part, model.volume_mm3, model.bbox, "post", PostCheckError, rel_tol)
