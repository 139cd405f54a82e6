"""What the instruction sheet says: its content (:class:`Sheet`), read from the job's figures.

The sheet is built from the job's figures (:class:`~stencil_cad.figures.Figures`, the run's or
those of a ``manifest.json`` read back with ``Figures.from_json``), its settings
(:class:`~.settings.JobSettings`) and its preview images. Every number it shows is a field of a
figures class; the simulation's scores it does not name are listed under their own names. It shows the picture and
its simulated result with size and viewing distance; the primer and paints in spray order
with swatches, hex codes and can names; one step per plate with its preview and the
simulated picture after that layer; how to set up the wall (and the tile map of a mural);
print or cut settings per plate; the paint estimate; and the checks that passed.

The HTML is one self-contained file (images as ``data:`` URIs, styles inline, no script, no
external reference), so it opens offline. The PDF is drawn with ReportLab's page layout
engine (text stays text, images are embedded PNGs).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..figures import Cutouts, Figures, WallRow
from ..names import after_png, cut_png, dots_png
from . import make, mural
from .cans import layer_can, unmeasured_warning, uses_profiles
from .settings import JobSettings

# Rule of thumb for when separate dots blend for the eye: one arcminute, about 3,400 x the pitch.
ARCMINUTE_FACTOR = 3438.0

# Manifest keys of quality figures, with how the sheet names them; other numeric figures of
# the `simulate` section are listed under their own key.
_SCORE_NAMES = {
    "de2000_mean": ("ΔE2000, mean (pixel by pixel)", "{:.2f}"),
    "de2000_p95": ("ΔE2000, 95th percentile", "{:.2f}"),
    "psnr": ("PSNR", "{:.1f} dB"),
    "ssim": ("SSIM", "{:.3f}"),
    "scielab": ("S-CIELAB at the viewing distance", "{:.2f}"),
    "scielab_2x": ("S-CIELAB at twice the viewing distance", "{:.2f}"),
    "view_distance_m": ("viewing distance", "{:g} m"),
    "dots_blend_m": ("distance from which the dots blend", "{:.1f} m"),
    "dots_blend_layer": ("layer whose dots show longest", "{:g}"),
    "dots_hole_r_mm": ("its smallest hole radius", "{:g} mm"),
}
_SKIP_SCORES = {
    "holes",
    "scielab_worst",
    "spray_time",
    "seconds",
    "shape",
    "blur_sigma_mm",
    "layer_rmse",
    "layer_tone_rmse",
    "nozzle_height",
}


@dataclass(frozen=True)
class Step:
    """One spraying step: a plate, its paint, its preview and the picture after it."""

    number: int
    plate: str
    hex: str
    name: str
    spray_time: float | None
    holes: int | None
    plate_image: str
    after_image: str
    kind: str
    how: str = ""
    detail: str = ""
    passes: int | None = None
    speed_m_s: float | None = None


@dataclass(frozen=True)
class Sheet:
    """Everything the sheet shows, as plain values (see :func:`sheet`)."""

    job: str
    mode: str
    width_mm: float
    height_mm: float
    viewing: str
    primer_hex: str
    primer_name: str
    order_note: str
    unit: str
    steps: list[Step]
    wall: list[str]
    tiles: list[mural.MapTile]
    prints: list[list[str]]
    print_head: list[str]
    paint: list[list[str]]
    paint_note: str
    snap: list[str]
    scores: list[tuple[str, str]]
    checks: list[tuple[str, bool]]
    files: list[str]
    warnings: list[str] = field(default_factory=list)
    plate_count: int = 0
    mural: mural.MuralPlan | None = None


def _viewing(f: Figures, s: JobSettings) -> str:
    """Viewing distance: the configured one (with its score) or the distance at which dots blend."""
    sim = f.simulate
    d = s.view_distance_m or (sim.view_distance_m if sim is not None else None)
    blend = sim.dots_blend_m if sim is not None else None
    blend_text = f"; the dots blend from about {float(blend):.1f} m" if blend else ""
    by_can = (sim.scielab_by_can if sim is not None else None) or {}
    if len(by_can) > 1:
        lo, hi = min(by_can.values()), max(by_can.values())
        blend_text += (
            f"; S-CIELAB there between {float(lo):.2f} and {float(hi):.2f} depending on your can, "
            "spray the card to know"
        )
    if d:
        return f"{float(d):g} m (the distance the quality is scored at){blend_text}"
    pic = f.picture
    area = float(pic.width_mm) * float(pic.height_mm) if pic is not None else 0.0
    holes = [h for h in (sim.holes if sim is not None else []) if h]
    if area > 0 and holes:
        pitch = math.sqrt(area / max(holes))
        return (
            f"dots blend from about {pitch * ARCMINUTE_FACTOR / 1000:.1f} m (mean hole pitch {pitch:.1f} mm, "
            "1 arcminute); closer, the dots show"
        )
    return "any: the cut-outs have hard edges"


def _wall_list(walls: Sequence[WallRow]) -> str:
    tiled = [w for w in walls if w.tile]
    if tiled:
        heights = ", ".join(f"{h:g}" for h in sorted({float(w.standoff_mm or 0) for w in tiled}))
        return f"one wall per tile, {tiled[0].file} to {tiled[-1].file}: stand-off {heights} mm"
    return ", ".join(f"{w.file}: stand-off {float(w.standoff_mm or 0):g} mm" for w in walls)


def _print_rows(
    f: Figures, s: JobSettings, names: set[str], steps: list[Step]
) -> tuple[list[str], list[list[str]]]:
    """Per plate and per wall: files, hole count, and how to make it with a profile or bed it fits."""
    kind = "cut-outs" if s.hard else "holes"
    head = ["part", kind, "files", "cut length", "how to make it"]
    parts = make.plate_parts(f.build)
    if not parts:
        # No build figures (a sheet from the spray order alone): one row per step.
        parts = [make.Part("plate", st.plate, None, st.holes, layer=st.number) for st in steps]
    rows = []
    for part in [*parts, *make.wall_parts(f.build)]:
        files = [part.stem + e for e in (".stl", ".step", ".3mf", ".dxf", ".svg") if part.stem + e in names]
        count = (
            "frame"
            if part.kind == "wall"
            else (f"{part.holes:,}" if part.holes is not None else "not counted")
        )
        cut = (
            f"{part.cut_mm / 1000:.2f} m"
            if part.cut_mm
            else ("not cut" if part.kind == "wall" else "not measured")
        )
        advice = make.part_advice(s, part)
        estimated = make.estimate_text(make.estimated_part(f.cost, part))
        if estimated:
            advice += f"; {estimated}"
        said = make.print_text(part.print_hours, part.filament_m)
        if said:
            advice += f"; PrusaSlicer: {said}"
        rows.append([part.stem, count, ", ".join(files) or "not written", cut, advice])
    reason = f.plate.thickness_reason if f.plate is not None else None
    if reason and any(p.kind == "plate" for p in parts):
        rows.append(["plate thickness", "", "", "", str(reason)])
    if f.cost is not None:
        rows.append(["all parts", "", "", "", make.cost_total_text(f.cost)])
    total = f.build.print_estimate if f.build is not None else None
    if total is not None and total.hours is not None:
        said = make.print_text(float(total.hours), total.filament_m)
        rows.append(["all parts", "", "", "", f"PrusaSlicer ({total.profile or 'prusa_fdm'}): {said}"])
    return head, rows


def _checks(f: Figures, s: JobSettings) -> list[tuple[str, bool]]:
    out: list[tuple[str, bool]] = []
    build = f.build
    # A mural's plates and walls are checked tile by tile in the tile sections.
    for p in build.plates if build is not None else ():
        if not p.tile:
            out += make.plate_checks(p, f"plate {p.number:02d}")
    out += [make.wall_check(w) for w in (build.walls if build is not None else ()) if not w.tile]
    web = s.web_mm
    for r in f.stipple or ():
        mw = r.min_web_mm
        if mw is not None:
            text = f"layer {r.layer:02d}: smallest web between holes {mw:.2f} mm"
            out.append(
                (
                    text + (f" (rule ≥ {web:g} mm)" if web else " (design rules enforced)"),
                    web is None or mw >= web - 1e-6,
                )
            )
    per_layer = (f.hard.per_layer if f.hard is not None else None) or ()
    for i, lay in enumerate(per_layer):
        if lay.has("polygon_held_components"):
            out.append(
                (
                    f"cut layer {i + 1:02d}: sheet in one piece, every island held by bridges",
                    lay.polygon_held_components == 1,
                )
            )
    return out


def _scores(f: Figures) -> list[tuple[str, str]]:
    """The simulation's numeric figures, named (the ones the sheet knows) or by their manifest name."""
    rows = []
    for k, v in (f.simulate.scores if f.simulate is not None else {}).items():
        if k in _SKIP_SCORES or isinstance(v, (dict, list, str, bool)) or v is None:
            continue
        name, fmt = _SCORE_NAMES.get(k, (k.replace("_", " "), "{:.4g}"))
        rows.append((name, fmt.format(v)))
    return rows


def _how(f: Figures, s: JobSettings) -> dict[int | None, str]:
    """What the hand does per layer, in the spray model's units, and the can, when the job says them."""
    how = {r.layer: str(r.text or "") for r in f.spraying or ()}
    # The can each layer sprays with, named when the job keys spray profiles to its paints.
    cans = f.spray_profiles or ()
    if s.has_cans and uses_profiles(cans):
        for row in cans:
            how[row.layer] = (how.get(row.layer, "") + f"; can: {layer_can(row)}").lstrip("; ")
    return how


def _steps(f: Figures, s: JobSettings, names: set[str]) -> list[Step]:
    """One :class:`Step` per plate in spray order."""
    order = f.spray_order.steps if f.spray_order is not None else ()
    holes = f.simulate.holes if f.simulate is not None else []
    # A plate's own count (hard mode's cut-outs are not simulated as holes) and its cut-outs' sizes.
    built = {p.number: p for p in (f.build.plates if f.build is not None else ())}
    how = _how(f, s)
    pair = _light_and_dark(order) if s.mode == "soft" else {}
    steps = []
    for k, o in enumerate(order):
        plate = str(o.plate)
        number = int(o.step or 0)
        own = built.get(number)
        plate_img = dots_png(plate) if dots_png(plate) in names else cut_png(plate)
        steps.append(
            Step(
                number=number,
                plate=plate,
                hex=str(o.hex),
                name=o.name or "",
                spray_time=o.spray_time,
                holes=holes[k] if k < len(holes) else (own.hole_count if own is not None else None),
                plate_image=plate_img,
                after_image=after_png(plate),
                kind="holes" if s.mode == "soft" else "cut-outs",
                how=how.get(number, ""),
                detail=pair.get(k) or _cutout_detail(own.cutouts if own is not None else None),
                passes=o.passes,
                speed_m_s=o.pass_speed_m_s,
            )
        )
    return steps


def _light_and_dark(order: Sequence[Any]) -> dict[int, str]:
    """Which steps are a paint's light plate and its dark plate (two steps of one paint in a row)."""
    out = {}
    for k in range(1, len(order)):
        if order[k].hex == order[k - 1].hex and k - 1 not in out:
            out[k - 1] = "its light plate: this paint's light tones, at a small dose"
            out[k] = (
                f"its dark plate: the same paint and can as step {order[k - 1].step}, for its darker tones"
            )
    return out


def _cutout_detail(fig: Cutouts | None) -> str:
    """A hard plate's cut-outs in words: ``2.0 to 31.5 mm across, 374 mm² open``."""
    if fig is None or not fig.count:
        return ""
    lo, hi = float(fig.span_min_mm or 0.0), float(fig.span_max_mm or 0.0)
    span = f"{lo:.1f} mm across" if abs(hi - lo) < 0.05 else f"{lo:.1f} to {hi:.1f} mm across"
    return f"{span}, {float(fig.open_mm2 or 0.0):,.0f} mm² open"


def _plate_caption(step: Step, tiles: int = 0) -> str:
    """The caption under a step's plate: its hole or cut-out count and, for cut-outs, their sizes."""
    what = f"The layer's {tiles} plates, one per tile" if tiles else "The plate"
    if step.holes is None:
        return what
    return f"{what} ({step.holes:,} {step.kind}" + (f", {step.detail}" if step.detail else "") + ")"


def _wall_steps(f: Figures, s: JobSettings, primer_hex: str, n_tiles: int) -> list[str]:
    """The set-up instructions: prime, set the wall, fit the plates, spray evenly (and the mural's tiles)."""
    # Hard mode sprays from its own nozzle height (the pipeline copies it into the spray section).
    section = "hard" if s.hard else "spray"
    walls = f.build.walls if f.build is not None else ()
    primer_name = f.spray_order.primer.name if f.spray_order is not None else None
    wall = [
        f"Prime the whole surface with the primer {primer_hex}"
        + (f" ({primer_name})" if primer_name else "")
        + " and let it dry.",
        (
            "Set each tile's wall on its ticks (see Registration below)"
            if n_tiles
            else "Set the wall on the surface where the picture goes"
        )
        + (f" ({_wall_list(walls)}; a taller wall gives softer dots)" if walls else "")
        + ". Tape or hold it so it cannot move between layers.",
        "Each plate fits the wall one way only: the key tabs match the wall's notches and the label, "
        "in the bottom border, reads the right way up from the top.",
        _spray_how(s, section),
    ]
    if n_tiles:
        wall.append(
            f"The picture is a mural of {n_tiles} tiles (map below): spray it round by round, one layer "
            "on every tile in its own wall position, then the next layer (Order of work below)."
        )
    return wall


def _paint_table(
    f: Figures, s: JobSettings, primer_hex: str, steps: list[Step]
) -> tuple[list[list[str]], str]:
    """The paint to buy: one row for the primer and one per layer, and the note on how it was counted."""
    paint = f.paint
    prow = {r.layer: r for r in (paint.layers if paint is not None else ())}
    cov = s.coverage_m2_per_can
    can_ml = s.can_ml
    if paint is not None:
        cov = paint.coverage_m2_per_can if paint.coverage_m2_per_can is not None else cov
        can_ml = paint.can_ml if paint.can_ml is not None else can_ml
    area = float(paint.sprayed_area_m2) if paint is not None else 0.0
    paint_rows = []
    if area:
        p_ml = area / cov * can_ml
        paint_rows.append(
            [
                "primer",
                primer_hex,
                f"{area:.3f}",
                "1 coat",
                f"{p_ml:.1f}",
                f"{max(1, math.ceil(area / cov - 1e-9))}",
            ]
        )
    for st in steps:
        r = prow.get(st.number)
        if r is None:
            continue
        paint_rows.append(
            [
                st.plate,
                st.hex + (f" {st.name}" if st.name else ""),
                f"{r.covered_m2:.4f}",
                f"{r.mean_opacity:.3f}",
                f"{r.ml:.1f}",
                str(r.cans_to_buy),
            ]
        )
    paint_note = (
        f"Covered area = sprayed area ({area:.3f} m²) × the layer's mean opacity in the simulation; "
        f"at {cov:g} m² per {can_ml:g} ml can. Paint that lands on the plate is not counted: sweeping "
        "the whole plate uses more."
    )
    if any(r.cans_to_buy == 0 for r in prow.values()):
        paint_note += " 0 cans: the plate sprays the same paint as an earlier plate (its light plate), from the same cans."
    return paint_rows, paint_note


def _snap_lines(f: Figures) -> list[str]:
    """Which can each solved paint (and the primer) was snapped to, and what that cost."""
    snap = []
    sn = f.cans.snap if f.cans is not None else None
    if sn is not None:
        for r in sn.paints or ():
            snap.append(f"solved {r.solved} → can {r.can} {r.name} (ΔE2000 {r.delta_e2000:.1f})")
        if sn.primer is not None:
            r = sn.primer
            snap.append(f"primer {r.solved} → can {r.can} {r.name} (ΔE2000 {r.delta_e2000:.1f})")
        snap.append(
            f"cost of using the cans: composite RMSE {sn.rmse_solved:.2f} → {sn.rmse_snapped:.2f} (0-255 units)"
        )
    return snap


def sheet_from_manifest(
    manifest: Mapping[str, Any], tiles: Sequence[Mapping[str, Any]] | None = None
) -> Sheet:
    """Collect what the sheet shows from a job's manifest (as written to ``manifest.json``).

    Args:
        manifest: The manifest (``files`` may be partial): its figures are read with
            :meth:`Figures.from_json`, its config with :meth:`JobSettings.from_json`.
        tiles: Tiles of a mural, each with ``x_mm``, ``y_mm``, ``width_mm``, ``height_mm`` (picture
            frame, bottom-left corner) and optionally ``name``; None takes ``manifest["tiles"]``
            (or the mural's tiles) when present.

    Returns:
        The :class:`Sheet`.
    """
    names = {str(r.get("name")) for r in manifest.get("files") or [] if isinstance(r, Mapping)}
    given = tiles if tiles is not None else (manifest.get("tiles") or None)
    return sheet(Figures.from_json(manifest), JobSettings.from_json(manifest.get("config")), names, given)


def sheet(
    f: Figures, s: JobSettings, names: set[str], tiles: Sequence[Mapping[str, Any]] | None = None
) -> Sheet:
    """Collect what the sheet shows from a job's figures and settings.

    Args:
        f: What the job's stages recorded.
        s: The job's settings.
        names: The job's file names.
        tiles: Tiles of a mural for the map (see :func:`sheet_from_manifest`); None takes the
            mural's tiles when it has them.

    Returns:
        The :class:`Sheet`.
    """
    steps = _steps(f, s, names)
    so = f.spray_order
    palette = (f.hard.palette if f.hard is not None else None) or ["#ffffff"]
    primer_hex = (
        (so.primer.hex if so is not None else None)
        or (f.decompose.primer if f.decompose else None)
        or palette[0]
    )
    built = f.mural.built if f.mural is not None else None
    mapped = mural.map_tiles(tiles if tiles is not None else (built.tiles if built is not None else ()))
    head, rows = _print_rows(f, s, names, steps)
    paint_rows, paint_note = _paint_table(f, s, str(primer_hex), steps)
    unit = (so.unit if so is not None else None) or "spray time"
    pic = f.picture
    return Sheet(
        job=s.name,
        mode=s.mode,
        width_mm=float(pic.width_mm) if pic is not None else 0.0,
        height_mm=float(pic.height_mm) if pic is not None else 0.0,
        viewing=_viewing(f, s),
        primer_hex=str(primer_hex),
        primer_name=str((so.primer.name if so is not None else None) or ""),
        order_note=str((so.note if so is not None else None) or ""),
        unit=unit,
        steps=steps,
        wall=_wall_steps(f, s, str(primer_hex), len(mapped)),
        tiles=mapped,
        prints=rows,
        print_head=head,
        paint=paint_rows,
        paint_note=paint_note,
        snap=_snap_lines(f),
        scores=_scores(f),
        checks=_checks(f, s),
        files=sorted(names),
        warnings=_warnings(f, s),
        plate_count=len(f.build.plates if f.build is not None else ()) or len(steps),
        mural=mural.mural_plan(f, s, steps, lambda st: _amount(st, unit), names),
    )


def _warnings(f: Figures, s: JobSettings) -> list[str]:
    """The decomposition's and hard mode's warnings, the layers' dark ends and unmeasured cans."""
    warnings = f.decompose.warnings if f.decompose is not None else []
    warnings += [str(w) for w in (f.hard.warnings if f.hard is not None else None) or []]
    warnings += _dark_end_warnings(f)
    unmeasured = unmeasured_warning(f.spray_profiles or ()) if s.has_cans else None
    return warnings + ([unmeasured] if unmeasured else [])


def _spray_how(s: JobSettings, section: str) -> str:
    """How to hold and move the can: the physical model's distance and speed, or the paper's height."""
    if s.has_cans:
        cm = s.can_distance_mm / 10.0
        speed = s.pass_speed_m_s
        return (
            f"Hold the can about {cm:g} cm from the plate and sweep evenly across the whole plate at the pace "
            f"each step gives (about {speed:g} m/s, a little faster or slower where a layer's dose lies "
            "between whole passes), starting and ending off the plate. Spray light passes, the number each step "
            "gives, and let each pass flash off (about a minute) before the next: a heavy coat under a "
            "lifted stencil runs and creeps. Let each layer dry before the next."
        )
    nozzle = s.nozzle_height
    return (
        "Spray every layer from the same distance and sweep evenly over the whole plate"
        + (
            f" (at the nozzle height the simulation assumed, {section}.nozzle_height = {nozzle:g})"
            if nozzle is not None
            else ""
        )
        + "; let each layer dry before the next."
    )


def _dark_end_warnings(f: Figures) -> list[str]:
    """A line per layer whose darkest tones its plate cannot spray in its passes: the layer and the shortfall."""
    out = []
    passes = {r.layer: r.passes for r in f.spraying or ()}
    for k, row in enumerate(f.dark_end or ()):
        share = float(row.unreachable_share)
        if share < 0.005:
            continue
        n = passes.get(k + 1)
        within = f" in {n} pass{'' if n == 1 else 'es'}" if n else ""
        out.append(
            f"Layer {k + 1}: {100 * share:.0f} % of its area is darker than its plate can spray{within} even with "
            f"its densest holes (darkest opacity {float(row.darkest_sprayable):.2f}, short by "
            f"{float(row.unreachable_by):.2f} on average there): those parts come out lighter than the picture."
        )
    return out


#: The can column of a paint no can list (and no colour name, paints.can_names: false) names.
_NO_CAN = "no can named"


def _amount(step: Step, unit: str, bare: bool = False) -> str:
    """A step's amount of paint in the job's unit: ``2 passes`` or ``spray time 0.707``."""
    t = step.spray_time
    if t is None:
        return "–" if bare else ""
    if unit == "passes" and step.passes is not None and step.speed_m_s is not None:
        # The dose as the hand sprays it: whole passes at a pace (spray.dose_step).
        n = step.passes
        text = f"{n} pass{'' if n == 1 else 'es'} at {step.speed_m_s:.2g} m/s"
        return text if bare else f", {text}"
    text = (
        f"{t:g} pass{'' if t == 1 else 'es'}"
        if unit == "passes"
        else (f"{t:.3g}" if bare else f"spray time {t:.3g}")
    )
    return text if bare else f", {text}"


def _plates_text(sheet: Sheet) -> str:
    """The plate count for the sheet's head: every plate of the job (a mural: every tile's)."""
    if sheet.mural is None:
        return f"{sheet.plate_count or len(sheet.steps)} plates"
    m = sheet.mural
    walls = "1 wall (moved from tile to tile)" if m.walls == 1 else f"{m.walls} walls"
    return f"{m.plates} plates ({len(sheet.steps)} layers on each of {len(m.sections)} tiles) and {walls}"


def _drop(sheet: Sheet, step: Step) -> str:
    """What to put into the wall for a step: the plate, or on a mural each tile's plate of that layer."""
    if sheet.mural is None:
        return f"Drop {step.plate} into the wall"
    first = sheet.mural.sections[0].name if sheet.mural.sections else "A1"
    return (
        f"Round {step.number}, on every tile in turn (see Tile by tile): drop the tile's plate of this "
        f"layer (tile_{first}_{step.plate} on {first}, and so on) into the tile's wall"
    )


def _unit_note(unit: str) -> str:
    if unit == "passes":
        return (
            "Passes: whole sweeps of the can across the plate, at the can distance and speed given per step "
            "(a little faster or slower than the usual pace where the layer's dose lies between whole passes)."
        )
    return "Spray time is relative to the job's spray.spray_time (1 = the planned dose)."
