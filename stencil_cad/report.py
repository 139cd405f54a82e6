"""The one-screen summary printed at the end of a run."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .config import Mode

if TYPE_CHECKING:
    from .figures import BuildFigures, Figures, LayerProfile, MuralFigures, SimulateFigures
    from .record import Run


def _fmt(v, digits: int = 3) -> str:
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return str(v)


def summary(run: Run, files: list[Path], out_path: Path) -> str:
    """Files written, dots per layer, smallest web, validation, quality and time per stage."""
    f = run.figures
    lines = [f"stencil-cad: {run.cfg.name} → {out_path}/ ({len(files)} files)"]
    lines += _layer_lines(run, f)
    if f.standoff is not None and (f.standoff.trials or f.standoff.refined):
        lines.append(f"  design    {f.standoff.reason}")
    lines += _build_lines(run, f)
    lines += _cost_lines(f)
    if f.plate is not None and f.plate.thickness_reason:
        lines.append(f"  thickness {f.plate.thickness_reason}")
    sim = f.simulate
    if sim is not None:
        lines += _seen_lines(run, sim)
    where = f.compute
    if where is not None and where.kind != "in_process":
        place = (
            f"local cluster of {where.workers} workers"
            if where.kind == "local"
            else f"cluster at {where.address}"
        )
        lines.append(f"  compute   {place}, {where.tasks or 0} tasks")
    for w in (sim.walls or []) if sim is not None else []:
        lines.append(
            f"  wall {w.standoff_mm:g} mm  ΔE2000 mean {_fmt(w.de2000_mean)}, "
            f"PSNR {_fmt(w.psnr)} dB, SSIM {_fmt(w.ssim)}  ({w.file})"
        )
    for step in f.spraying or ():
        lines.append(f"  {step.text}")
    lines += _can_lines(run, f.spray_profiles or ())
    times = ", ".join(f"{k} {v:.1f} s" for k, v in run.times.items())
    lines.append(f"  time      {times}")
    lines += _folder_lines(run, files)
    for warning in getattr(run, "warnings", []) or []:
        lines.append(f"  warning   {warning}")
    return "\n".join(lines)


def _cost_lines(f: Figures) -> list[str]:
    """What making the parts costs (estimated before CAD from the placed holes), beside the slicer's own."""
    from .mural.cost import hours_text

    made = f.cost
    if made is None:
        return []
    h_m2, kg_m2 = made.per_m2()
    lines = [f"  to make   {made.line()}; {h_m2:.0f} printer-h and {kg_m2:.2f} kg per m² (estimated)"]
    for kind in ("plate", "wall"):
        parts = [p for p in made.parts if p.kind == kind and p.print_hours > 0]
        if not parts:
            continue
        hours = sorted(p.print_hours for p in parts)
        each = hours_text(hours[0]) + (f" to {hours_text(hours[-1])}" if len(hours) > 1 else "")
        lines.append(
            f"  {kind + 's':9s} {len(parts)}: {each} each, {sum(hours):.1f} h and "
            f"{sum(p.filament_g for p in parts):.0f} g together"
        )
    if made.paint:
        cans = ", ".join(f"layer {c.layer} {c.cans:.2f}" for c in made.paint)
        lines.append(
            f"  paint     cans (open area × passes at {made.coverage_m2_per_can or 0:g} m² per coat): {cans}"
        )
    sliced = [p.print_hours for p in (f.build.plates + f.build.walls if f.build else ()) if p.print_hours]
    if sliced:
        lines.append(
            f"  slicer    PrusaSlicer's estimate: {sum(sliced):.1f} h for the {len(sliced)} part(s) it sliced"
        )
    return lines


def _can_lines(run: Run, rows: Sequence[LayerProfile]) -> list[str]:
    """The can each layer sprayed with (when the job keys profiles to paints), and the unmeasured ones."""
    from .instructions.cans import layer_can, unmeasured_warning, uses_profiles

    if not run.cfg.spray.has_cans or not rows:
        return []
    lines = []
    if uses_profiles(rows):
        lines.append("  cans      " + "; ".join(f"layer {r.layer} {layer_can(r)}" for r in rows))
    warning = unmeasured_warning(rows)
    if warning:
        lines.append(f"  warning   {warning}")
    return lines


def _layer_lines(run: Run, f: Figures) -> list[str]:
    """The picture, the decomposition and each layer's holes and dark end."""
    lines: list[str] = []
    pic = f.picture
    if pic is not None:
        lines.append(
            f"  picture   {pic.width_mm:g} × {pic.height_mm:g} mm, {pic.pixels[1]}×{pic.pixels[0]} px ({pic.source})"
        )
    dec = f.decompose
    if dec is not None:
        rmse = dec.rmse
        lines.append(
            f"  layers    {dec.layers} on primer {dec.primer}: {' '.join(dec.colours)}"
            + (
                f"  (composite RMSE {_fmt(rmse)} /255, {dec.iterations} iterations)"
                if rmse is not None
                else ""
            )
        )
    for row in f.stipple or ():
        lines.append(
            f"  layer {row.layer:02d}  {row.dots:6d} holes  smallest web {_fmt(row.min_web_mm)} mm"
            f"  removed {row.count('removed')}  merged {row.count('merged')}  nudged {row.count('nudged')}"
            + (f"  {run.cfg.spray.amount_unit} {_fmt(row.spray_time)}" if row.spray_time is not None else "")
        )
    for k, end in enumerate(f.dark_end or ()):
        if end.unreachable_share >= 0.005:
            lines.append(
                f"  layer {k + 1:02d}  {100 * end.unreachable_share:.0f} % of its pixels are darker than this "
                f"stencil can spray (darkest {end.darkest_sprayable:.2f}; short by {end.unreachable_by:.2f} "
                "on average)"
            )
    return lines


def _build_lines(run: Run, f: Figures) -> list[str]:
    """Hard-mode figures, then every plate and wall and whether each solid is valid."""
    lines: list[str] = []
    hard = f.hard
    if hard:
        lines.append("  hard      " + ", ".join(f"{k} {_fmt(v)}" for k, v in hard.plain()))
    build = f.build
    if build is not None and build.tiled:
        lines += _mural_lines(build, f.mural)
    elif build is not None:
        ok = all(p.valid for p in build.plates)
        for p in build.plates:
            solids = p.n_solids if p.has("n_solids") else "?"
            holes = p.hole_count if p.has("hole_count") else "not counted"
            lines.append(
                f"  plate {p.number:02d}  {'valid' if p.valid else 'INVALID'}, {solids} solid, "
                f"{_kind(run)} {holes}, volume error {_fmt(p.rel_error)}"
            )
        lines.append(
            "  walls     "
            + ", ".join(
                f"{w.file} (stand-off {w.standoff_mm:g} mm, {'valid' if w.valid else 'INVALID'})"
                for w in build.walls
            )
        )
        ok = ok and all(w.valid for w in build.walls)
        lines.append(f"  checks    {'all solids valid' if ok else 'SOME SOLIDS FAILED — see manifest.json'}")
    return lines


def _folder_lines(run: Run, files: list[Path]) -> list[str]:
    """The files written, and those kept, removed or left stale in the folder."""
    lines: list[str] = []
    names = sorted(p.name for p in files)
    lines.append("  files     " + _wrap(_grouped_tile_files(names)))
    out = getattr(run, "out", None)
    kept = list(getattr(out, "kept", []) or [])
    if kept:
        lines.append(
            f"  kept      {len(kept)} file(s) stencil-cad did not write or that changed since it did: "
            + _wrap(kept)
        )
    removed = list(getattr(out, "removed", []) or [])
    if removed:
        lines.append(
            f"  removed   {len(removed)} file(s) of the earlier run not written again: " + _wrap(removed)
        )
    stale = list(getattr(run, "stale", []) or [])
    if stale:
        lines.append(
            f"  stale     {len(stale)} file(s) of later stages made from the earlier inputs (listed under "
            "`stale` in manifest.json; re-run those stages): " + _wrap(stale)
        )
    return lines


def _kind(run) -> str:
    """What a plate's openings are called: round ``holes`` (soft) or ``cut-outs`` (hard mode)."""
    return "cut-outs" if run.cfg.mode == Mode.hard else "holes"


def _cutout_advice(f: Figures) -> str:
    """Hard mode in plain words: the cut-outs per plate and their sizes; hard edges read from any distance."""
    rows = []
    for p in f.build.plates if f.build is not None else ():
        c = p.cutouts
        if c is not None and c.count:
            rows.append(
                f"plate {p.number:02d} {c.count} from {c.span_min_mm:g} to {c.span_max_mm:g} mm across"
            )
    bridge = f.hard.bridge_drawn_mm if f.hard is not None else None
    return (
        "; ".join(rows or ["no cut-outs"])
        + (f"; bridges {bridge:g} mm wide" if bridge else "")
        + "; their edges are hard, so shapes read the same from near and far"
    )


def _seen_lines(run: Run, sim: SimulateFigures) -> list[str]:
    """The simulation's scores: pixel by pixel, as a viewer sees them, by can, and the dots or cut-outs."""
    lines = [
        f"  spray     ΔE2000 mean {_fmt(sim.de2000_mean)}, p95 {_fmt(sim.de2000_p95)}, "
        f"PSNR {_fmt(sim.psnr)} dB, SSIM {_fmt(sim.ssim)}"
    ]
    if sim.scielab is None:
        return lines
    d = float(sim.view_distance_m or 0.0)
    lines.append(
        f"  seen      S-CIELAB ΔE {_fmt(sim.scielab)} at {d:g} m, {_fmt(sim.scielab_2x)} at {2 * d:g} m"
        " (what a viewer sees; pixel ΔE2000 above scores every dot)"
    )
    by_can = sim.scielab_by_can or {}
    if len(by_can) > 1:
        lines.append(
            f"  can       S-CIELAB at {d:g} m between {_fmt(min(by_can.values()))} and "
            f"{_fmt(max(by_can.values()))} depending on your can; spray the card to know "
            "(stencil-cad card, then stencil-cad calibrate)"
        )
    if _kind(run) == "holes":
        lines.append("  dots      " + _dots_advice(run, sim, d))
    else:
        lines.append("  cut-outs  " + _cutout_advice(run.figures))
    return lines


def _dots_advice(run: Run, sim: SimulateFigures, distance_m: float) -> str:
    """Plain words: do the job's holes show as dots from the viewing distance, and from how far they blend.

    The distance is measured on the job's own sprayed picture where its holes show most
    (:func:`stencil_cad.simulate.visibility.pattern_blend_distance_m`), usually a light paint's
    sparse holes over a dark ground.
    """
    hole = f"{2.0 * (sim.dots_hole_r_mm or 0.0):.1f}".rstrip("0").rstrip(".")
    blend = sim.dots_blend_m
    pic = run.figures.picture
    size = f"this {pic.width_mm:g} mm picture" if pic is not None else "the picture"
    where = ""
    at = sim.scores.get("dots_blend_at_mm")
    if sim.scores.get("dots_blend_layer") and at:
        where = (
            f" (measured where they show most: layer {sim.scores['dots_blend_layer']}'s holes around "
            f"{float(at[0]):g}, {float(at[1]):g} mm from the top left)"
        )
    if blend is None:
        return f"at {distance_m:g} m the {hole} mm holes show as dots, and still do from 64 m{where}"
    if blend > distance_m:
        return (
            f"at {distance_m:g} m the {hole} mm holes show as dots; {size} reads as continuous tone "
            f"from about {blend:.1f} m{where}"
        )
    return f"from {distance_m:g} m the {hole} mm holes blend into continuous tone (they do from about {blend:.1f} m{where})"


def _grouped_tile_files(names: list[str]) -> list[str]:
    """The file names, a mural's tile files counted per kind instead of listed one by one.

    ``tile_A1_layer_01.stl`` … ``tile_E6_layer_04.stl`` become one entry such as
    ``tile_A1…E6_layer_NN.stl (120)``; a mural has hundreds of them.
    """
    import re

    pattern = re.compile(r"tile_([A-Z]+\d+)_(.+)$")
    groups: dict[str, list[str]] = {}
    rest = []
    for n in names:
        m = pattern.match(n)
        if m is None:
            rest.append(n)
            continue
        kind = re.sub(r"layer_\d+", "layer_NN", m.group(2))
        groups.setdefault(kind, []).append(m.group(1))
    if sum(len(v) for v in groups.values()) <= 12:
        return names

    def order(tile: str) -> tuple[int, str, int]:
        row = tile.rstrip("0123456789")
        return len(row), row, int(tile[len(row) :])

    out = []
    for kind, tiles in sorted(groups.items()):
        first, last = min(tiles, key=order), max(tiles, key=order)
        out.append(f"tile_{first}…{last}_{kind} ({len(tiles)})")
    return out + rest


def _wrap(names: list[str], width: int = 100) -> str:
    out, line = [], ""
    for n in names:
        if line and len(line) + len(n) + 2 > width - 12:
            out.append(line)
            line = ""
        line = f"{line}, {n}" if line else n
    out.append(line)
    return "\n            ".join(out)


def _mural_lines(build: BuildFigures, m: MuralFigures | None) -> list[str]:
    """The build and mural part of the summary for a tiled job."""
    plates, walls = build.plates, build.walls
    ok = all(p.valid for p in plates) and all(w.valid for w in walls)
    built = m.built if m is not None else None
    bed = m.bed if m is not None else None
    tiles = built.tiles if built is not None else []
    holes = (built.holes_total, built.holes_global, built.union_check_rules) if built else (None, None, None)
    lines = [
        f"  mural     {len(tiles)} tiles, {len(plates)} plates, {len(walls)} walls on {bed.name if bed is not None else None}; "
        f"holes {holes[0]} (global {holes[1]}); rules on the union: {holes[2]}",
        f"  checks    {'all solids valid' if ok else 'SOME SOLIDS FAILED — see manifest.json'}",
    ]
    sim = m.simulation if m is not None else None
    if sim is not None:
        for c in sim.registration_cost or ():
            err = float(c.error_mm or 0.0)
            lines.append(
                f"  register  ±{err / 2:g} mm between {c.between} ({err:g} mm apart): "
                f"S-CIELAB {c.cost_scielab:+.3g}, ΔE2000 mean {c.cost_de2000_mean:+.3g}, "
                f"PSNR {c.cost_psnr:+.3g} dB, SSIM {c.cost_ssim:+.3g}"
            )
    lines.append("  map       mural_map.png (tile grid, positions, order of work)")
    if bed is not None:
        from .slicing import place

        boxes = [p.bbox_mm for p in plates] + [w.bbox for w in walls]
        sizes = [(s[0], s[1]) if len(s) == 2 else (s[3] - s[0], s[4] - s[1]) for s in boxes if s]
        turned = sum(1 for s in sizes if place(s, (bed.x_mm, bed.y_mm)).rotate_deg == 90)
        if turned:
            arg = bed.name if "×" not in bed.name else f"{bed.x_mm:g}x{bed.y_mm:g}"
            lines.append(
                f"  bed       {turned} of {len(sizes)} parts fit the {bed.x_mm:g} × {bed.y_mm:g} mm bed turned 90° "
                f"(`stencil-cad slice --bed {arg}` turns them)"
            )
    return lines
