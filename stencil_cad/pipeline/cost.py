"""What making the job costs: recorded once the holes are placed (before any CAD), and the dry run.

The estimate itself is :func:`stencil_cad.mural.making_cost`; this glue returns it for the
manifest's ``cost`` section (the recorder records it) and prints the plan with it for ``stencil-cad run --dry-run``,
which reads the image and writes nothing.
"""

from __future__ import annotations

from collections.abc import Sequence

from .. import mural
from ..config import JobConfig
from ..figures import CostFigures
from ..model import DotSet
from ..mural.cost import hours_text
from ..plan.picture import load_picture
from ..plan.plan import Plan


def stage_cost(plan: Plan, dotsets: Sequence[DotSet]) -> CostFigures:
    """The cost of making ``plan``'s plates and walls from the placed holes: figure ``cost``, which the recorder records."""
    return mural.making_cost(plan.grid, plan.cfg, len(dotsets), dotsets)


def cost_lines(made: CostFigures) -> list[str]:
    """The cost in total, per square metre and per part, one line each (the dry run's and the summary's)."""
    h_m2, kg_m2 = made.per_m2()
    lines = [
        f"to make: {made.line()}",
        f"  per m² of picture ({made.area_m2:.3f} m²): {h_m2:.0f} printer-hours, {kg_m2:.2f} kg of filament",
    ]
    for p in made.parts:
        text = f"  {p.name}: "
        if p.cut_m is not None:
            holes = f"{p.holes:,} holes, " if p.kind == "plate" else ""
            text += f"{holes}laser cut {p.cut_m:.1f} m in about {p.cut_minutes or 0:.0f} min"
        else:
            holes = f"{p.holes:,} holes, " if p.kind == "plate" else ""
            text += f"{holes}{hours_text(p.print_hours)}, {p.filament_m:.1f} m ({p.filament_g:.0f} g)"
        lines.append(text)
    for c in made.paint:
        lines.append(
            f"  paint, layer {c.layer:02d}: {c.open_m2:.4f} m² open × {c.passes:g} passes = {c.cans:.2f} can(s) "
            f"at {made.coverage_m2_per_can or 0:g} m² per can per coat (buy at least one)"
        )
    return lines


def dry_run(cfg: JobConfig) -> list[str]:
    """The plan and its cost from the config and the image alone, in seconds; nothing is written.

    Args:
        cfg: The resolved job config.

    Returns:
        The plan line, then the cost in total, per square metre and per part (the plan's expected holes).

    Raises:
        UserError: The image cannot be read, or a part does not fit the bed.
    """
    from ..config.job import with_margin
    from ..plan import tiles
    from ..plan.plan import labelled

    # The label and the tiles' margin the job fills in: a mural's tiles, posts and plates follow them.
    cfg = with_margin(labelled(cfg))
    picture = load_picture(cfg)
    shape = picture.shape
    grid, plan = tiles.plan(cfg, picture.width_mm, picture.height_mm, shape[0] * shape[1])
    made = mural.making_cost(grid, cfg, mural.plate_layers(cfg, grid))
    return [tiles.plan_line(plan, cfg), *cost_lines(made)]
