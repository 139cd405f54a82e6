"""build123d part classes for engineers composing stencils in build123d.

:class:`StencilPlate` wraps :func:`stencil_cad.cad.build_plate` as a ``BasePartObject``, so a
plate can be placed in a ``BuildPart`` context or used in algebra mode next to the
:class:`Wall`; the pipeline itself works on the :class:`~stencil_cad.cad.plate.PlateModel` and
the :class:`~stencil_cad.cad.wall.WallModel`, which carry what the fast exporters need and
make no build123d object unless asked.
"""

from __future__ import annotations

import build123d as bd

from ..config.cad import PlateConfig, WallConfig
from ..config.outline import OutlineConfig
from ..model import PlateGeometry
from .plate import LabelInfo, PlateBuildError, PlateModel
from .template import build_plate
from .wall import WallRings, wall_solid

__all__ = ["StencilPlate", "Wall"]


class StencilPlate(bd.BasePartObject):
    """One layer's stencil plate as a build123d part.

    Args:
        holes: A :class:`~stencil_cad.model.DotSet` (round holes, mm) or a
            :class:`~stencil_cad.model.CutLayer` (polygon cut-outs), in the picture frame.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        cfg: Plate settings. Defaults to ``PlateConfig()`` (1.2 mm, engraved label).
        label: What the label says, or None for the layer-less default ``L1/1``.
        rotation: Rotation applied after building. Defaults to none.
        align: Alignment; None (default) keeps the picture frame, which registration in the
            wall needs.
        mode: Builder combine mode. Defaults to ADD.

    Raises:
        PlateBuildError: Holes that break the design rules (listing the first offending
            ones), a label that cannot fit, or a template problem.
    """

    _applies_to = [bd.BuildPart._tag]

    def __init__(
        self,
        holes,
        width_mm: float,
        height_mm: float,
        cfg: PlateConfig | None = None,
        label: LabelInfo | None = None,
        rotation: bd.RotationLike = (0, 0, 0),
        align: bd.Align | tuple[bd.Align, bd.Align, bd.Align] | None = None,
        mode: bd.Mode = bd.Mode.ADD,
    ):
        cfg = PlateConfig() if cfg is None else cfg
        label = LabelInfo(layer=1, layers=1) if label is None else label
        self.model: PlateModel = build_plate(holes, width_mm, height_mm, cfg, label)
        super().__init__(part=self.model.part, rotation=rotation, align=align, mode=mode)

    @property
    def geometry(self) -> PlateGeometry:
        """The plate's kernel-free description.

        Raises:
            PlateBuildError: The plate template returned a shape of its own, which has none.
        """
        if self.model.geometry is None:
            raise PlateBuildError("the plate template returned its own shape: it has no plate description")
        return self.model.geometry

    @property
    def analytic_volume(self) -> float:
        """Volume in mm³ from the outline area, the holes and the label (the oracle)."""
        return float(self.geometry.volume)

    @property
    def hole_count(self) -> int:
        """Number of holes (cut-outs) in the plate."""
        return int(self.geometry.hole_count)

    @property
    def thickness_mm(self) -> float:
        """Plate thickness in mm."""
        return float(self.geometry.thickness_mm)


class Wall(bd.BasePartObject):
    """The interlocking wall as a build123d part (usable in BuildPart or algebra mode).

    The solid is :func:`stencil_cad.cad.wall.wall_solid`'s, the one a job builds; the first six
    arguments, and the ``ValueError`` on sizes that make no wall, are that function's.

    Args:
        rotation: Rotation applied after building. Defaults to none.
        align: Alignment; None (default) keeps the picture frame, which registration needs.
        mode: Builder combine mode. Defaults to ADD.
    """

    _applies_to = [bd.BuildPart._tag]

    def __init__(
        self,
        width_mm: float,
        height_mm: float,
        outline: OutlineConfig,
        wall: WallConfig,
        plate_thickness_mm: float,
        standoff_mm: float,
        rotation: bd.RotationLike = (0, 0, 0),
        align: bd.Align | tuple[bd.Align, bd.Align, bd.Align] | None = None,
        mode: bd.Mode = bd.Mode.ADD,
    ):
        made = wall_solid(width_mm, height_mm, outline, wall, plate_thickness_mm, standoff_mm)
        self.rings: WallRings = made.rings
        self.standoff_mm = made.standoff_mm
        self.pocket_depth_mm = made.pocket_depth_mm
        self.total_height_mm = made.total_height_mm
        self.slot_volume_mm3 = made.slot_volume_mm3
        self.analytic_volume_mm3 = made.analytic_volume_mm3
        super().__init__(part=bd.Part(made.shape), rotation=rotation, align=align, mode=mode)
