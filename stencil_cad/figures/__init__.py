"""The figures each stage records: one frozen dataclass per stage, collected in :class:`Figures`.

The stage glue (``pipeline/``) fills a :class:`Figures`; the terminal summary (``report.py``) and
the instruction sheet (``instructions/``) read its fields; the manifest is
:meth:`Figures.to_json`, whose keys, order and values are those the manifest has always had, and
:meth:`Figures.from_json` reads a manifest back (``from_json`` then ``to_json`` gives the same
JSON). Rows whose keys come from a check or a stage report (a plate's solid check, a stipple
pass's counts) type the keys that are read and keep the others as written
(:class:`~.rows.KeyedRow`).

Plain values only: no numpy arrays (the glue converts), nothing from the stages, so any layer may
import this package. :mod:`.rows` holds the keyed rows, :mod:`.stages` the figures before the
build, :mod:`.parts` the build's, :mod:`.spray` the simulation's and spraying's, :mod:`.mural` a
mural's, :mod:`.design` the plate design chosen for the picture, :mod:`.cost` what making the job costs, :mod:`.collected` the :class:`Figures` that holds them all.
"""

from .collected import Figures
from .cost import CostFigures, PaintCost, PartCost
from .design import PlateTrial, StandoffFigures
from .mural import MuralBed, MuralBuildFigures, MuralFigures, MuralSimulation, RegistrationCost, TileRow
from .parts import BuildFigures, Cutouts, MeshCheck, PlateRow, PrintEstimate, WallRow
from .rows import KeyedRow, Row
from .spray import (
    LayerProfile,
    OrderStep,
    PaintFigures,
    PaintLayer,
    PrimerRow,
    ScoreRow,
    SimulateFigures,
    SprayOrderFigures,
    SprayStep,
    WallScores,
)
from .stages import (
    CansFigures,
    CanSnap,
    ComputeFigures,
    DarkEnd,
    DecomposeFigures,
    HardFigures,
    HardLayer,
    LayerStipple,
    LayerWindows,
    PictureFigures,
    PlateFigures,
    SnapRow,
)

__all__ = [
    "BuildFigures",
    "CanSnap",
    "CansFigures",
    "ComputeFigures",
    "CostFigures",
    "Cutouts",
    "DarkEnd",
    "DecomposeFigures",
    "Figures",
    "HardFigures",
    "HardLayer",
    "KeyedRow",
    "LayerProfile",
    "LayerStipple",
    "LayerWindows",
    "MeshCheck",
    "MuralBed",
    "MuralBuildFigures",
    "MuralFigures",
    "MuralSimulation",
    "OrderStep",
    "PaintCost",
    "PaintFigures",
    "PaintLayer",
    "PictureFigures",
    "PlateFigures",
    "PartCost",
    "PlateTrial",
    "PlateRow",
    "PrimerRow",
    "PrintEstimate",
    "RegistrationCost",
    "Row",
    "ScoreRow",
    "SimulateFigures",
    "SnapRow",
    "SprayOrderFigures",
    "SprayStep",
    "StandoffFigures",
    "TileRow",
    "WallRow",
    "WallScores",
]
