"""The paints stage: ``spray.json``, the swatch card and the plate previews with their can names.

Run once a job's holes (or hard mode's cut-outs) are placed: :func:`stage_paints` makes the plate
previews, then the spray order and the swatch; the recorder writes them.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..colour import to_hex
from ..config import JobConfig, Mode
from ..figures import OrderStep, PrimerRow, SprayOrderFigures
from ..model import DotSet
from ..plan.cans import can_names
from ..plan.names import layer_stem
from ..plan.plan import Plan
from ..plan.results import PaintOrder
from ..record import Run

log = logging.getLogger(__name__)


def _order_note(cfg: JobConfig) -> str:
    """Why the paints come in this order, in one line for the swatch card."""
    if cfg.mode == Mode.hard:
        return {
            "light_to_dark": "light to dark: each darker paint covers the lighter ones",
            "dark_to_light": "dark to light (hard.order)",
            "given": "the order of hard.palette",
        }[cfg.hard.order.value]
    return {
        "auto": "each coat covers the ones before; of the primers and orders tried, this one is predicted to come out closest to the picture (decompose.order: auto)",
        "light_to_dark": "lightest paint first (decompose.order: light_to_dark)",
        "given": "the order of decompose.palette (decompose.order: given)",
    }[cfg.decompose.order.value]


def stage_paints(
    run: Run,
    plan: Plan,
    primer: np.ndarray,
    colours: np.ndarray,
    holes: list[Any],
    amounts: Sequence[float],
    name: Callable[[str], str],
) -> PaintOrder:
    """Each plate's preview (:func:`plate_cards`, named ``name(layer stem)``: ``dots_png`` or ``cut_png``) and the spray order.

    Args:
        run: The run (the cans' names it knows).
        plan: The job's plan (how it sprays: hard mode's from the cut-outs' height).
        primer: The primer's colour.
        colours: Each plate's paint.
        holes: Each plate's holes (a ``DotSet``) or cut-outs.
        amounts: Each plate's amount of paint: passes or spray time.
        name: A plate preview's file name from its layer's stem.
    """
    cards = tuple(
        (name(layer_stem(i)), card) for i, card in enumerate(plate_cards(run, plan, colours, holes))
    )
    spray, figures, swatch = spray_order(run, plan, primer, colours, amounts)
    return PaintOrder(cards, spray, figures, swatch)


def spray_order(
    run: Run, plan: Plan, primer: np.ndarray, colours: np.ndarray, spray_times: Sequence[float]
) -> tuple[dict[str, Any], SprayOrderFigures, np.ndarray]:
    """``spray.json`` (spray order, paints, spray times), its figure ``spray_order`` and the swatch card ``swatch.png``."""
    from ..simulate import labelled

    cfg = plan.cfg
    names = can_names(run.figures)
    if cfg.paints.can_names:
        from ..decompose import paints

        hexes = [to_hex(c) for c in (primer, *colours)]
        names = {**paints.colour_names([h for h in hexes if h not in names]), **names}
    order = [
        {
            "step": i + 1,
            "plate": layer_stem(i),
            "hex": to_hex(c),
            "name": names.get(to_hex(c), ""),
            "spray_time": float(t),
        }
        for i, (c, t) in enumerate(zip(colours, spray_times, strict=True))
    ]
    sp = cfg.spray
    how: dict[str, Any] = {"unit": sp.amount_unit}
    if sp.has_cans:
        for o, t in zip(order, spray_times, strict=True):
            o["passes"], speed = sp.hand(float(t))
            o["pass_speed_m_s"] = round(speed, 3)
        how.update(can_distance_cm=sp.can_distance_mm / 10.0, pass_speed_m_s=sp.pass_speed_m_s)
    else:
        how["nozzle_height"] = sp.nozzle_height
    spray = {
        "primer": {"hex": to_hex(primer), "name": names.get(to_hex(primer), "")},
        "order": order,
        "spray_times": [float(t) for t in spray_times],
        **how,
    }
    figures = SprayOrderFigures(
        primer=PrimerRow.from_json({"hex": to_hex(primer), "name": names.get(to_hex(primer), "")}),
        note=_order_note(cfg),
        unit=cfg.spray.amount_unit,
        steps=tuple(OrderStep.from_json(o) for o in order),
    )
    swatch = labelled.swatch_card(
        to_hex(primer),
        [{**o, "note": f"plate {o['plate']}"} for o in order],
        order_note=_order_note(cfg),
        unit=cfg.spray.amount_unit,
        primer_name=names.get(to_hex(primer), ""),
    )
    return spray, figures, swatch


def plate_cards(run: Run, plan: Plan, colours: np.ndarray, holes: list[Any]) -> list[np.ndarray]:
    """The plate previews of ``plan``'s plates: outline with key tabs and label area, holes or cut-outs, header and scale."""
    from .. import outline
    from ..simulate import labelled

    cfg, picture_mm = plan.cfg, plan.picture_mm
    ring = outline.plate_outline(*picture_mm, cfg.plate.outline)
    box = outline.label_region(*picture_mm, cfg.plate.outline)
    names = can_names(run.figures)
    cards = []
    for i, h in enumerate(holes):
        hx = to_hex(colours[i])
        kw = (
            {"circles_xy_r": np.column_stack([h.xy_mm, h.r_mm]) if len(h) else np.zeros((0, 3))}
            if isinstance(h, DotSet)
            else {"polygons": h.polygons}
        )
        cards.append(
            labelled.plate_card(
                ring, box, picture_mm, i + 1, len(holes), hx, names.get(hx, ""), job=cfg.name, **kw
            )
        )
    return cards
