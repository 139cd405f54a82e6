"""What each stage's glue computed and returns, written nowhere: the recorder writes it.

A stage of :mod:`stencil_cad.pipeline` computes and returns one of these frozen values; the
recorder (:mod:`stencil_cad.pipeline.recorder`) writes its files and records its figures, called
by :mod:`stencil_cad.pipeline.run` (the card's by :mod:`stencil_cad.pipeline.commands`) after the
stage, in order. They sit below the pipeline so that the stages and the recorder both read them
and neither imports the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..figures import (
    BuildFigures,
    CansFigures,
    DecomposeFigures,
    MuralBuildFigures,
    PaintFigures,
    SimulateFigures,
    SprayOrderFigures,
    SprayStep,
    StandoffFigures,
)
from ..model import Layers
from .plan import Plan


@dataclass(frozen=True, eq=False)
class Decomposed:
    """The decompose stage's layers, as ``layers.npz`` holds them, and figure ``decompose``.

    Attributes:
        layers: The primer and paint layers (float32 opacities, as saved).
        saved: ``layers.npz``'s arrays.
        figures: Figure ``decompose``.
        cans: Figure ``cans``: the can list, or the catalogue and the paints' snap to it; None: neither.
    """

    layers: Layers
    saved: dict[str, Any]
    figures: DecomposeFigures
    cans: CansFigures | None = None


@dataclass(frozen=True, eq=False)
class Segmented:
    """Hard mode's segment stage: the cut stencils and their layers (each layer's spray is the plan's).

    Attributes:
        hard: The cut stencils (:func:`stencil_cad.hardstencil.make_hard_stencils`).
        layers: Their layers: each cut layer's colour and mask.
        segmentation: ``segmentation.png``: each pixel in its cut layer's colour.
        cans: Figure ``cans``: the can list ``hard.palette`` names, or None.
    """

    hard: Any
    layers: Layers
    segmentation: np.ndarray
    cans: CansFigures | None = None


@dataclass(frozen=True, eq=False)
class PaintOrder:
    """The paints stage's plate previews, spray order (``spray.json``) and swatch card.

    Attributes:
        cards: Each plate's preview, by its file name (``dots_png`` or ``cut_png``), in plate order.
        spray: ``spray.json``'s content.
        figures: Figure ``spray_order``.
        swatch: The swatch card ``swatch.png``.
    """

    cards: tuple[tuple[str, np.ndarray], ...]
    spray: dict[str, Any]
    figures: SprayOrderFigures
    swatch: np.ndarray


@dataclass(frozen=True, eq=False)
class Simulated:
    """The simulate stage's pictures and figures (a soft job's or hard mode's).

    The pictures are their PNG files' bytes: a simulation's pictures are as large as the picture,
    and a mural's several would stay in memory until recorded.

    Attributes:
        composite: ``simulated.png``: the design stand-off's simulated spray.
        preview: ``preview.png``: input, ideal layers, simulated spray, error map.
        sweep: ``sweep.png`` (the layers sprayed with less and more paint), or None (hard mode).
        steps: Per layer, the simulated picture after it is sprayed (``step_N.png``).
        walls: Every other wall height's ``(file name, simulated spray)`` (the physical model).
        paint: Figure ``paint``: each layer's paint estimate.
        figures: Figure ``simulate``: the scores.
        spraying: Figure ``spraying``: what the hand does for each layer.
        scores: The design stand-off's scores.
        sim: The simulation (:class:`stencil_cad.simulate.SimResult`), kept when asked, else None.
        reference: The reference on the simulation's grid, kept when asked, else None.
        started: What the stage's ``also`` started (a mural's registration cases), or None.
    """

    composite: bytes
    preview: bytes
    sweep: bytes | None
    steps: tuple[bytes, ...]
    walls: tuple[tuple[str, bytes], ...]
    paint: PaintFigures
    figures: SimulateFigures
    spraying: tuple[SprayStep, ...]
    scores: dict[str, Any]
    sim: Any = None
    reference: np.ndarray | None = None
    started: Any = None


@dataclass(frozen=True, eq=False)
class Stand:
    """A mural's stand beyond its walls: the printed post's or the laser-cut parts' files and rows.

    Attributes:
        files: ``(file name, bytes)`` of the post (STEP, STL) or of each laser-cut part (DXF, SVG), in order.
        post_row: The post's figures, or None.
        stand_rows: The laser-cut parts' rows, or None.
    """

    files: tuple[tuple[str, bytes], ...] = ()
    post_row: dict[str, Any] | None = None
    stand_rows: list[dict[str, Any]] | None = None


@dataclass(frozen=True)
class PartResult:
    """What one plate's or wall's task made: its files (name, bytes) in writing order, its manifest row and its solid's check."""

    kind: str
    files: tuple[Any, ...]
    row: dict[str, Any]
    check: dict[str, Any]


@dataclass(frozen=True, eq=False)
class Built:
    """The build's figures once its parts are collected: figure ``build``, and a mural's tiles and map.

    Attributes:
        build: Figure ``build``: every plate's and wall's row.
        mural: Figure ``mural.built`` (a mural's tiles, holes per tile, order of work, stand), or None.
        mural_map: ``mural_map.png``, or None (one tile).
    """

    build: BuildFigures
    mural: MuralBuildFigures | None = None
    mural_map: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Designed:
    """The plate-design trials' choice (:func:`stencil_cad.pipeline.standoff.stage_standoff`).

    Attributes:
        plan: The plan with the design chosen (windows, stand-off), or the plan as given when the
            config leaves nothing to the job.
        figures: Figure ``standoff``: the share through windows, the trials and the choice; None
            when nothing was tried.
    """

    plan: Plan
    figures: StandoffFigures | None = None


@dataclass(frozen=True, eq=False)
class CardMade:
    """The calibration card (:func:`stencil_cad.pipeline.commands.stage_card`): its files and figure ``card``.

    Attributes:
        plan: The card's plan: one plate of its own size (no tiling, no picture).
        parts: The plate's files, then each wall's, ``(name, bytes)`` in the order they are written.
        sheet_png: The printed sheet's picture (``card_sheet.png``).
        sheet_pdf: The sheet with its steps (``card_sheet.pdf``).
        description: ``card.json``'s content.
        figures: Figure ``card``.
    """

    plan: Plan
    parts: tuple[tuple[str, bytes], ...]
    sheet_png: np.ndarray
    sheet_pdf: bytes
    description: dict[str, Any]
    figures: dict[str, Any]
