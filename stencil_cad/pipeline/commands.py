"""The commands beside the job: the calibration card and the default config."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import OutputError, UserError
from ..names import CARD_PLATE_STEM, CARD_SHEET_PDF, INIT_CONFIG, part_file
from ..plan.names import card_stems
from ..plan.plan import unplanned, whole
from ..plan.results import CardMade
from ..record import Run
from .build import PartTask, build_part
from .manifest import finish
from .recorder import record_card

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..testcard.layout import CardLayout

log = logging.getLogger(__name__)

#: The card plate's files, whatever the job's ``export`` asks.
CARD_FORMATS = (".step", ".stl", ".dxf")


def _card_parts(
    cfg: JobConfig, card: CardLayout, ring: np.ndarray
) -> tuple[list[tuple[str, bytes]], dict[str, Any], list[dict[str, Any]]]:
    """Build, check and export the card's plate and its walls (one per stand-off) as a job's parts are built.

    ``cfg`` is the job's config with its plate values filled in (:func:`stencil_cad.plan.plan.unplanned`).

    Returns:
        ``(files, check, walls)``: the plate's files then each wall's, in order; the plate's solid
        check; the walls' manifest rows.
    """
    from dataclasses import replace

    from .. import cad

    w, h = card.width_mm, card.height_mm
    common: dict[str, Any] = {"cfg": cfg, "size_mm": (w, h), "lines": ([], []), "bed": None, "tile": None}
    plate = PartTask(
        kind="plate",
        stem=CARD_PLATE_STEM,
        holes=card.dots,
        label=cad.LabelInfo(layer=1, layers=1, colour="", job="CARD"),
        ring=ring,
        # The card is always made in every way a can is tested: printed (STEP, STL) or cut (DXF).
        order=CARD_FORMATS,
        # The job's process rules, without its picture's keep-outs.
        rules=replace(cfg.stipple.design_rules(w, h), keepouts=()),
        cut_name="CARD",
        what="card plate",
        **common,
    )
    heights = [fp.standoff_mm for fp in card.footprints]
    walls = [
        PartTask(kind="wall", stem=stem, standoff_mm=g, **common)
        for g, stem in zip(heights, card_stems(heights), strict=True)
    ]
    results = [build_part(task) for task in (plate, *walls)]
    files = [(name, data) for res in results for name, data in res.files]
    return files, results[0].check, [res.row for res in results[1:]]


def _card_sheet(cfg: JobConfig, card: CardLayout, paper: str) -> tuple[np.ndarray, bytes, dict[str, Any]]:
    """The card's sheet: ``(its picture, the PDF with its steps, card.json's content)``; ``cfg``: the job's as given."""
    from ..testcard import layout as card_mod
    from ..testcard import printout

    heights = [fp.standoff_mm for fp in card.footprints]
    picture = printout.printout_png(card)
    sp = cfg.spray
    steps = printout.card_steps(card, sp.can_distance_mm, sp.pass_speed_m_s)
    try:
        pdf = printout.printout_pdf(card, paper=paper, steps=steps)
    except ValueError as exc:
        raise UserError(f"card sheet: {exc}") from exc
    description = card_mod.card_description(
        card,
        {
            "job": cfg.name,
            "spray": {
                "can_distance_mm": sp.can_distance_mm,
                "pass_speed_m_s": sp.pass_speed_m_s,
                "passes": card.passes,
            },
            "files": {
                "plate": part_file(CARD_PLATE_STEM, ".step"),
                "walls": [part_file(s, ".step") for s in card_stems(heights)],
                "sheet": CARD_SHEET_PDF,
            },
        },
    )
    return picture, pdf, description


def stage_card(run: Run, standoffs_mm: list[float] | None = None, paper: str = "a4") -> CardMade:
    """The calibration card, computed: the plate, a wall per stand-off, the sheet, ``card.json`` and figure ``card``.

    The plate takes the job's hole radii, web, plate and key; it is built, checked and exported
    exactly like a layer's plate, and its walls like the job's. The card has no plan until it is
    laid out, so it reads the config as given (``run.cfg``, its plate values filled in by
    :func:`stencil_cad.plan.plan.unplanned`) and returns the plan it makes. Nothing is written:
    :func:`stencil_cad.pipeline.recorder.record_card` writes what it returns.
    """
    from .. import outline
    from ..testcard import layout as card_mod

    cfg = unplanned(run.cfg)
    try:
        card = card_mod.card_layout(cfg, standoffs_mm)
    except ValueError as exc:
        raise UserError(f"card: {exc}") from exc
    w, h = card.width_mm, card.height_mm
    with run.stage("card"):
        ring = outline.plate_outline(w, h, cfg.plate.outline)
        files, check, walls = _card_parts(cfg, card, ring)
        heights = [fp.standoff_mm for fp in card.footprints]
        sheet_png, sheet_pdf, description = _card_sheet(run.cfg, card, paper)
    size = ring.max(axis=0) - ring.min(axis=0)
    figures = {
        "holes": len(card.dots),
        "plate_mm": [round(float(v), 2) for v in size],
        "standoffs_mm": heights,
        "features": [
            {
                "kind": f.kind,
                "holes": len(f.index),
                "r_mm": f.r_mm,
                "open_fraction": round(f.open_fraction, 4),
            }
            for f in card.features
        ],
        "plate": check,
        "walls": walls,
        "sheet_mm": [round(v, 1) for v in card.sheet_mm],
        "paper": paper,
        "passes": card.passes,
    }
    # The card plans one plate of its own size (no tiling, no picture).
    return CardMade(whole(cfg, (w, h)), tuple(files), sheet_png, sheet_pdf, description, figures)


def run_card(run: Run, standoffs_mm: list[float] | None = None, paper: str = "a4") -> list[Path]:
    """`stencil-cad card`: the calibration plate, a wall per stand-off, the sheet and ``card.json``.

    The card computed (:func:`stage_card`), recorded (:func:`stencil_cad.pipeline.recorder.record_card`:
    the files, figure ``card``), then the manifest written; returns the files written.
    """
    made = stage_card(run, standoffs_mm, paper)
    record_card(run, made)
    return finish(run, made.plan, "card")


def write_default_config(path: Path, *, force: bool = False) -> None:
    """Write the commented default config (every key, its unit, range and default) to ``path``.

    Raises:
        OutputError: ``path`` is a folder, its folder does not exist, or it exists and not ``force``.
    """
    from ..config import io as cfg_io
    from ..files import write_text_over

    if path.is_dir():
        raise OutputError(f"{path} is a folder; give a file path such as {path / INIT_CONFIG}")
    write_text_over(path, cfg_io.default_yaml(), "config", force=force, error=OutputError)
