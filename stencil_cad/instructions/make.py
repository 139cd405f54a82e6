"""How to make each part, for the instruction sheet: print or cut advice that fits, cut lengths and times.

Advice names only a profile whose bed the part fits (as exported, or turned 90°, which
``stencil-cad slice`` does by itself); a plate too large for the resin profile's vat is sent to
the FDM profile or a larger printer instead. Walls get their own line. A laser plate gets its
cut length and an estimated cut time.

Kernel-free: reads the job's build figures and settings only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..config.bed import Bed
from ..config.process import Method, Process
from ..figures import BuildFigures, CostFigures, PartCost, PlateRow, WallRow
from ..mural.cost import LASER_PIERCE_S, LASER_SPEED_MM_S, cut_seconds, hours_text
from ..names import WALL_STEM
from ..slicing import bed_size, place
from .settings import JobSettings

__all__ = [
    "LASER_PIERCE_S",
    "LASER_SPEED_MM_S",
    "Part",
    "cost_total_text",
    "cut_seconds",
    "estimate_text",
    "estimated_part",
    "fit_check",
    "part_advice",
    "plate_checks",
    "plate_parts",
    "wall_check",
    "wall_parts",
]

#: Holes above which the FDM profile slices a plate as tiles (as :func:`stencil_cad.slicing.slice_plate`).
_TILED_ABOVE = 450


@dataclass(frozen=True)
class Part:
    """One part to make: a plate or a wall, its file stem, footprint and hole count.

    Attributes:
        kind: ``"plate"`` or ``"wall"``.
        stem: File stem, e.g. ``layer_01`` or ``tile_A1_wall``.
        size_mm: ``(w, h)`` of its footprint as exported, mm; None when unknown.
        holes: Hole or cut-out count (plates), or None.
        cut_mm: Length of every cut in mm (plates), or None.
        tile: The mural tile it belongs to, or empty.
        layer: The layer number (plates), or 0.
        print_hours: PrusaSlicer's estimated print time in hours (``export.print_estimate``), or None.
        filament_m: PrusaSlicer's filament estimate in metres, or None.
    """

    kind: str
    stem: str
    size_mm: tuple[float, float] | None
    holes: int | None = None
    cut_mm: float | None = None
    tile: str = ""
    layer: int = 0
    print_hours: float | None = None
    filament_m: float | None = None


def plate_parts(build: BuildFigures | None) -> list[Part]:
    """Every plate of the job in the build's order (a mural: tile by tile, layer by layer)."""
    out = []
    for p in build.plates if build is not None else ():
        layer = p.number
        out.append(
            Part(
                kind="plate",
                stem=str(p.file or f"layer_{layer:02d}"),
                size_mm=p.size_mm,
                holes=None if p.hole_count is None else int(p.hole_count),
                cut_mm=p.cut_length_mm,
                tile=str(p.tile or ""),
                layer=layer,
                print_hours=p.print_hours,
                filament_m=p.filament_m,
            )
        )
    return out


def wall_parts(build: BuildFigures | None) -> list[Part]:
    """Every wall of the job (one per stand-off height, per tile for a mural)."""
    out = []
    for w in build.walls if build is not None else ():
        stem = str(w.file).rsplit(".", 1)[0] if w.has("file") else WALL_STEM
        out.append(
            Part(
                kind="wall",
                stem=stem,
                size_mm=w.size_mm,
                tile=str(w.tile or ""),
                print_hours=w.print_hours,
                filament_m=w.filament_m,
            )
        )
    return out


def print_text(hours: float | None, metres: float | None) -> str:
    """PrusaSlicer's estimate as the sheet says it, or empty without one."""
    if hours is None:
        return ""
    return f"prints in about {hours_text(hours)}" + (f" with {metres:.1f} m of filament" if metres else "")


def estimated_part(cost: CostFigures | None, part: Part) -> PartCost | None:
    """The cost model's estimate for one part (matched by kind, tile and layer), or None."""
    for c in cost.parts if cost is not None else ():
        if c.kind == part.kind and c.tile == part.tile and (part.kind == "wall" or c.layer == part.layer):
            return c
    return None


def estimate_text(c: PartCost | None) -> str:
    """The cost model's estimate for one part as the sheet says it, or empty."""
    if c is None:
        return ""
    if c.cut_m is not None:
        return f"estimated cut {c.cut_m:.1f} m in about {c.cut_minutes or 0:.0f} min"
    return (
        f"estimated {hours_text(c.print_hours)} with {c.filament_m:.1f} m ({c.filament_g:.0f} g) of filament"
    )


def cost_total_text(cost: CostFigures) -> str:
    """The job's estimated making cost in total and per square metre, for the sheet."""
    h_m2, kg_m2 = cost.per_m2()
    return (
        f"estimated before any CAD: {cost.line()}; {h_m2:.0f} printer-hours and {kg_m2:.2f} kg of filament "
        "per m² of picture"
    ) + "".join(
        f"; layer {c.layer} paint {c.cans:.2f} can(s) ({c.open_m2:.4f} m² open × {c.passes:g} passes)"
        for c in cost.paint
    )


def _duration(seconds: float) -> str:
    m = seconds / 60.0
    return f"{m:.0f} min" if m >= 10 else f"{m:.1f} min"


def _slice_command(stem: str, bed: Bed | None) -> str:
    return f"`stencil-cad slice{f' --bed {_bed_arg(bed)}' if bed is not None else ''} {stem}.stl`"


def _bed_arg(bed: Bed) -> str:
    return bed.name if "×" not in bed.name else f"{bed.x_mm:g}x{bed.y_mm:g}"


def _fdm(part: Part, bed: Bed | None, thickness: float | None) -> str:
    """FDM advice: the slice command on the job's bed (or the profile's), turned when that is how it fits."""
    bed_mm = (bed.x_mm, bed.y_mm) if bed is not None else bed_size("prusa_fdm")
    where = bed.name if bed is not None else "prusa_fdm"
    size = part.size_mm
    lay = place(size, bed_mm) if size is not None else None
    if lay is not None and not lay.fits:
        return (
            f"FDM: {lay.describe()} ({where}): print it on a printer whose bed holds it, "
            f"`stencil-cad slice --bed XxY {part.stem}.stl` with your bed's size"
        )
    holes = part.holes or 0
    tiles = math.ceil(holes / 300) if holes > _TILED_ABOVE else 1
    text = f"FDM: {_slice_command(part.stem, bed)} (PrusaSlicer, prusa_fdm, 0.3 mm layers"
    if part.kind == "wall":
        text += ", 10 % infill); print it as exported, base on the bed and pocket on top, no supports"
    else:
        text += (
            ", 100 % infill"
            + (f", sliced in {tiles} pieces" if tiles > 1 else "")
            + "); print flat, plate-down, no supports or brim"
        )
        if thickness:
            text += f"; plate {thickness:g} mm thick"
    if lay is not None and lay.rotate_deg == 90:
        text += f"; {lay.describe()} (slice turns it)"
    return text


def _sla(part: Part, bed: Bed | None, thickness: float | None) -> str:
    """Resin advice when the plate fits the SL1S profile's vat; else another vat, or the job designed for FDM."""
    vat = bed_size("prusa_sla")
    lay = place(part.size_mm, vat) if part.size_mm is not None else None
    if lay is not None and lay.fits and part.kind == "plate":
        text = (
            f"resin: `stencil-cad slice --profile prusa_sla {part.stem}.stl`; flat on the build plate, "
            "no supports, 0.1 mm layers"
        )
        if lay.rotate_deg == 90:
            text += " (turned 90° to fit the vat)"
        return text + (f"; plate {thickness:g} mm thick" if thickness else "")
    if part.kind == "plate" and lay is not None and not lay.fits:
        # Its holes and webs are resin's: on FDM the 0.5 mm webs break between the smallest holes
        # (python -m benchmarks printed --case web), so FDM needs the job designed for FDM.
        return (
            f"too large for the prusa_sla vat ({vat[0]:g} × {vat[1]:g} mm): print it on a resin printer whose "
            "vat holds it, flat, no supports, 0.1 mm layers; for FDM run the job again with "
            "`stipple.process: fdm` (resin's 0.5 mm webs break between the smallest holes on FDM), then "
            + _fdm(part, bed, thickness)
        )
    return f"{_fdm(part, bed, thickness)}; or a resin printer whose vat holds it"


def _laser(part: Part, kerf: float, kind: str) -> str:
    """Laser advice: the cut file, the order of cuts, the cut length and an estimated time."""
    text = (
        f"laser: {part.stem}.dxf (or .svg): engrave the label (score layer, blue) first at low power, "
        f"then cut the {kind}, the outline last (cut layer, red); kerf compensated {kerf:g} mm"
    )
    if part.cut_mm:
        pierces = (part.holes or 0) + 1
        text += (
            f"; cut length {part.cut_mm / 1000:.2f} m, about {_duration(cut_seconds(part.cut_mm, pierces))} "
            f"at {LASER_SPEED_MM_S:g} mm/s and {LASER_PIERCE_S:g} s per pierce"
        )
    return text


def part_advice(settings: JobSettings, part: Part) -> str:
    """How to make one part with the job's process, naming only a profile or bed it fits.

    Args:
        settings: The job's settings (process, plate thickness, kerf, bed).
        part: The plate or wall.

    Returns:
        One line for the sheet's print-or-cut table.
    """
    bed, thickness = settings.bed, settings.thickness_mm
    if part.kind == "wall":
        # A wall is a deep frame: FDM whatever the plates' process.
        return _fdm(part, bed, thickness)
    method = _method(settings.process)
    if method is Method.cut:
        return _laser(part, settings.kerf_mm, "cut-outs" if settings.hard else "holes")
    if method is Method.cure:
        return _sla(part, bed, thickness)
    return _fdm(part, bed, thickness)


def _method(process: str) -> Method:
    """How the saved job's process makes plates (a process this version does not know: as FDM)."""
    try:
        return Process(process).record.method
    except ValueError:
        return Method.extrude


def plate_checks(p: PlateRow, label: str) -> list[tuple[str, bool]]:
    """The checks one built plate passed or failed, as sheet lines named ``label`` (e.g. ``plate 01``)."""
    solids = p.n_solids if p.has("n_solids") else 0
    out = [(f"{label}: one solid, valid B-rep ({solids} solid)", bool(p.valid))]
    rel = p.rel_error
    if rel is not None:
        out.append((f"{label}: volume equals the analytic volume (relative error {rel:.1e})", rel < 1e-6))
    mesh = p.mesh
    if mesh is not None:
        out.append((f"{label}: mesh watertight and consistently wound", mesh.ok))
        if mesh.has("genus") and p.hole_count is not None:
            out.append(
                (
                    f"{label}: mesh genus {mesh.genus} = hole count {p.hole_count}",
                    mesh.genus == p.hole_count,
                )
            )
    return out


def wall_check(w: WallRow) -> tuple[str, bool]:
    """The check of one built wall as a sheet line."""
    name = str(w.file if w.has("file") else "wall")
    return (f"{name}: valid wall (stand-off {float(w.standoff_mm or 0):g} mm)", bool(w.valid))


def fit_check(settings: JobSettings, part: Part) -> tuple[str, bool] | None:
    """Whether a part lies on the job's bed (as exported or turned 90°), as a sheet line; None without a bed."""
    bed = settings.bed
    if bed is None or part.size_mm is None:
        return None
    lay = place(part.size_mm, (bed.x_mm, bed.y_mm))
    return (f"{part.stem}: {lay.describe()} ({bed.name})", lay.fits)
