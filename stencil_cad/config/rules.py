"""The hole design rules of one hole set: a value object derived from the ``stipple`` section.

Built by :meth:`stencil_cad.config.StippleConfig.design_rules` (and
:meth:`stencil_cad.config.JobConfig.design_rules`); enforced and checked by
:mod:`stencil_cad.stipple.rules`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

#: No hole is ever smaller than this radius in mm, whatever the process (the paper's floor).
HOLE_FLOOR_MM = 0.5


def as_rect(k: Sequence[float]) -> tuple[float, float, float, float]:
    """A keep-out rectangle ``(x0, y0, x1, y1)`` in mm as Python floats."""
    x0, y0, x1, y1 = (float(v) for v in k)
    return x0, y0, x1, y1


@dataclass(frozen=True)
class HoleSizes:
    """The sizes and spacings of a job's holes, all in mm: each ``stipple`` value as given, or its process's preset.

    Made in one place, :attr:`stencil_cad.config.StippleConfig.sizes` (a null value read from the
    process's record, :mod:`stencil_cad.config.process`); every reader outside the config reads it
    there. The hole floor is :attr:`stencil_cad.config.StippleConfig.hole_floor_mm`, its one route.

    Attributes:
        radius_mm: The hole radius (the smallest with ``variable_radius``): ``radius_mm`` or the floor.
        max_radius_mm: The largest radius the stippler draws: ``radius_mm`` unless ``variable_radius``,
            then ``max_radius_mm`` or twice the radius.
        web_mm: The least material between two holes: ``web_mm`` (as the plan filled it in for a plate
            of one layer, :func:`stencil_cad.config.job.job_web`) or the process's.
        edge_margin_mm: The least material between a hole and the picture's edge or a keep-out.
        hole_offset_mm: The radius the process takes off each drawn hole (a plate draws it this much
            larger when it compensates).
    """

    radius_mm: float
    max_radius_mm: float
    web_mm: float
    edge_margin_mm: float
    hole_offset_mm: float

    @property
    def window_web_mm(self) -> float:
        """The web kept between a hole and a window: :attr:`web_mm` with the drawn holes' growth on top, so it holds as drawn."""
        return self.web_mm + max(self.hole_offset_mm, 0.0)


@dataclass(frozen=True)
class DesignRules:
    """Design rules of one hole set, all in mm.

    Attributes:
        hole_min_r_mm: Smallest allowed hole radius (>= 0.5 mm): the job's hole floor
            (:attr:`stencil_cad.config.StippleConfig.hole_floor_mm`), or :data:`HOLE_FLOOR_MM`
            for rules that hold whatever the job (:meth:`any_job`, :meth:`with_any_floor`).
        web_mm: Minimum material between two holes.
        edge_margin_mm: Minimum material between a hole and the picture-area
            border or a keep-out rectangle.
        width_mm: Picture-area width W.
        height_mm: Picture-area height H.
        keepouts: Keep-out rectangles ``(x0, y0, x1, y1)`` in picture mm.
    """

    hole_min_r_mm: float
    web_mm: float
    edge_margin_mm: float
    width_mm: float
    height_mm: float
    keepouts: tuple[tuple[float, float, float, float], ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if not self.hole_min_r_mm >= HOLE_FLOOR_MM:
            raise ValueError(f"hole_min_r_mm must be ≥ {HOLE_FLOOR_MM} mm, got {self.hole_min_r_mm}")
        if not self.web_mm > 0:
            raise ValueError(f"web_mm must be > 0 mm, got {self.web_mm}")
        if not self.edge_margin_mm >= 0:
            raise ValueError(f"edge_margin_mm must be ≥ 0 mm, got {self.edge_margin_mm}")
        if not (self.width_mm > 0 and self.height_mm > 0):
            raise ValueError(f"picture size must be > 0 mm, got {self.width_mm} x {self.height_mm}")
        object.__setattr__(self, "keepouts", tuple(tuple(float(v) for v in k) for k in self.keepouts))
        for k, (x0, y0, x1, y1) in enumerate(self.keepouts):
            if not (x1 > x0 and y1 > y0):
                raise ValueError(f"keep-out {k} must have x1 > x0 and y1 > y0, got ({x0}, {y0}, {x1}, {y1})")

    @classmethod
    def any_job(cls, width_mm: float, height_mm: float, web_mm: float) -> DesignRules:
        """The rules every job's holes keep over a picture area, whatever its process.

        The floor is :data:`HOLE_FLOOR_MM`, the web ``web_mm`` and the margin 0 (inside the
        picture: the plate's solid border holds a hole at its edge).
        """
        return cls(
            hole_min_r_mm=HOLE_FLOOR_MM,
            web_mm=web_mm,
            edge_margin_mm=0.0,
            width_mm=width_mm,
            height_mm=height_mm,
        )

    def with_any_floor(self) -> DesignRules:
        """These rules with the floor of every job (:data:`HOLE_FLOOR_MM`) in place of this job's.

        A hole the process makes a little under the stippler's radius (at the picture's margin,
        where it is not drawn larger) still keeps these.
        """
        return replace(self, hole_min_r_mm=min(self.hole_min_r_mm, HOLE_FLOOR_MM))
