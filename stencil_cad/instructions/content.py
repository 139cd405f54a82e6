"""What the instruction sheet says: its content (:class:`Sheet`), read from the job's manifest.

The sheet is built from the job's manifest (the same figures ``manifest.json`` holds) and
the job's preview images, so whatever a stage adds to the manifest (scores, spray units,
tiles) reaches the sheet without this module knowing the stage. It shows the picture and
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

from ..figures import LayerProfile
from . import make, mural
from .cans import layer_can, unmeasured_warning, uses_profiles

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


@dataclass(frozen=True)
class Sheet:
    """Everything the sheet shows, as plain values (see :func:`sheet_from_manifest`)."""

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
    tiles: list[dict[str, Any]]
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


def _val(d: Mapping[str, Any], *keys: str, default: Any = None) -> Any:
    for k in keys:
        if not isinstance(d, Mapping) or k not in d:
            return default
        d = d[k]
    return d


def _viewing(manifest: Mapping[str, Any]) -> str:
    """Viewing distance: the configured one (with its score) or the distance at which dots blend."""
    sim = manifest.get("simulate", {}) or {}
    d = _val(manifest, "config", "view", "distance_m") or sim.get("view_distance_m")
    blend = sim.get("dots_blend_m")
    blend_text = f"; the dots blend from about {float(blend):.1f} m" if blend else ""
    by_can = sim.get("scielab_by_can") or {}
    if len(by_can) > 1:
        lo, hi = min(by_can.values()), max(by_can.values())
        blend_text += (
            f"; S-CIELAB there between {float(lo):.2f} and {float(hi):.2f} depending on your can, "
            "spray the card to know"
        )
    if d:
        return f"{float(d):g} m (the distance the quality is scored at){blend_text}"
    pic = manifest.get("picture", {}) or {}
    area = float(pic.get("width_mm", 0)) * float(pic.get("height_mm", 0))
    holes = [int(h) for h in sim.get("holes", []) if h]
    if area > 0 and holes:
        pitch = math.sqrt(area / max(holes))
        return (
            f"dots blend from about {pitch * ARCMINUTE_FACTOR / 1000:.1f} m (mean hole pitch {pitch:.1f} mm, "
            "1 arcminute); closer, the dots show"
        )
    return "any: the cut-outs have hard edges"


def _wall_list(walls: Sequence[Mapping[str, Any]]) -> str:
    tiled = [w for w in walls if w.get("tile")]
    if tiled:
        heights = ", ".join(f"{h:g}" for h in sorted({float(w.get("standoff_mm", 0)) for w in tiled}))
        return f"one wall per tile, {tiled[0].get('file')} to {tiled[-1].get('file')}: stand-off {heights} mm"
    return ", ".join(f"{w.get('file')}: stand-off {float(w.get('standoff_mm', 0)):g} mm" for w in walls)


def _print_rows(manifest: Mapping[str, Any], steps: list[Step]) -> tuple[list[str], list[list[str]]]:
    """Per plate and per wall: files, hole count, and how to make it with a profile or bed it fits."""
    names = _file_names(manifest)
    kind = "cut-outs" if str(_val(manifest, "config", "mode", default="soft")) == "hard" else "holes"
    head = ["part", kind, "files", "cut length", "how to make it"]
    parts = make.plate_parts(manifest)
    if not parts:
        # No build figures (a sheet from the spray order alone): one row per step.
        parts = [make.Part("plate", s.plate, None, s.holes, layer=s.number) for s in steps]
    rows = []
    for part in [*parts, *make.wall_parts(manifest)]:
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
        advice = make.part_advice(manifest, part)
        said = make.print_text(part.print_hours, part.filament_m)
        if said:
            advice += f"; PrusaSlicer: {said}"
        rows.append([part.stem, count, ", ".join(files) or "not written", cut, advice])
    reason = (manifest.get("plate") or {}).get("thickness_reason")
    if reason and any(p.kind == "plate" for p in parts):
        rows.append(["plate thickness", "", "", "", str(reason)])
    total = (manifest.get("build") or {}).get("print") or {}
    if total.get("hours") is not None:
        said = make.print_text(float(total["hours"]), total.get("filament_m"))
        rows.append(["all parts", "", "", "", f"PrusaSlicer ({total.get('profile', 'prusa_fdm')}): {said}"])
    return head, rows


def _file_names(manifest: Mapping[str, Any]) -> set[str]:
    return {str(r.get("name")) for r in manifest.get("files", []) or [] if isinstance(r, Mapping)}


def _checks(manifest: Mapping[str, Any]) -> list[tuple[str, bool]]:
    out: list[tuple[str, bool]] = []
    build = manifest.get("build") or {}
    # A mural's plates and walls are checked tile by tile in the tile sections.
    for p in build.get("plates", []):
        if not p.get("tile"):
            out += make.plate_checks(p, f"plate {int(p.get('layer', 0)):02d}")
    out += [make.wall_check(w) for w in build.get("walls", []) if not w.get("tile")]
    rules = manifest.get("stipple") or []
    web = _val(manifest, "config", "stipple", "web_mm")
    for r in rules:
        mw = r.get("min_web_mm")
        if mw is not None:
            text = f"layer {r.get('layer', 0):02d}: smallest web between holes {mw:.2f} mm"
            out.append(
                (
                    text + (f" (rule ≥ {web:g} mm)" if web else " (design rules enforced)"),
                    web is None or mw >= web - 1e-6,
                )
            )
    hard = manifest.get("hard") or {}
    for i, lay in enumerate(hard.get("per_layer", []) or []):
        if "polygon_held_components" in lay:
            out.append(
                (
                    f"cut layer {i + 1:02d}: sheet in one piece, every island held by bridges",
                    lay.get("polygon_held_components") == 1,
                )
            )
    return out


def _scores(manifest: Mapping[str, Any]) -> list[tuple[str, str]]:
    sim = manifest.get("simulate") or {}
    rows = []
    for k, v in sim.items():
        if k in _SKIP_SCORES or isinstance(v, (dict, list, str, bool)) or v is None:
            continue
        name, fmt = _SCORE_NAMES.get(k, (k.replace("_", " "), "{:.4g}"))
        rows.append((name, fmt.format(v)))
    return rows


def _steps(manifest: Mapping[str, Any], mode: str, names: set[str]) -> list[Step]:
    """One :class:`Step` per plate in spray order."""
    order = (manifest.get("spray_order") or {}).get("steps", [])
    holes = _val(manifest, "simulate", "holes", default=None) or []
    # A plate's own count (hard mode's cut-outs are not simulated as holes) and its cut-outs' sizes.
    built = {int(p.get("layer", 0)): p for p in _val(manifest, "build", "plates", default=[]) or []}
    # What the hand does per layer, in the spray model's units, when the job says it.
    how = {
        r.get("layer"): str(r.get("text", ""))
        for r in manifest.get("spraying", []) or []
        if isinstance(r, Mapping)
    }
    # The can each layer sprays with, named when the job keys spray profiles to its paints.
    cans = _profiles(manifest)
    if _physical(manifest) and uses_profiles(cans):
        for row in cans:
            how[row.layer] = (how.get(row.layer, "") + f"; can: {layer_can(row)}").lstrip("; ")
    steps = []
    for k, o in enumerate(order):
        plate = o["plate"]
        plate_img = f"{plate}_dots.png" if f"{plate}_dots.png" in names else f"{plate}_cut.png"
        steps.append(
            Step(
                number=int(o["step"]),
                plate=plate,
                hex=o["hex"],
                name=o.get("name", "") or "",
                spray_time=o.get("spray_time"),
                holes=int(holes[k]) if k < len(holes) else built.get(int(o["step"]), {}).get("hole_count"),
                plate_image=plate_img,
                after_image=f"{plate}_after.png",
                kind="holes" if mode == "soft" else "cut-outs",
                how=how.get(int(o["step"]), ""),
                detail=_cutout_detail(built.get(int(o["step"]), {}).get("cutouts")),
            )
        )
    return steps


def _cutout_detail(fig: Mapping[str, Any] | None) -> str:
    """A hard plate's cut-outs in words: ``2.0 to 31.5 mm across, 374 mm² open``."""
    if not fig or not fig.get("count"):
        return ""
    lo, hi = float(fig["span_min_mm"]), float(fig["span_max_mm"])
    span = f"{lo:.1f} mm across" if abs(hi - lo) < 0.05 else f"{lo:.1f} to {hi:.1f} mm across"
    return f"{span}, {float(fig['open_mm2']):,.0f} mm² open"


def _plate_caption(step: Step, tiles: int = 0) -> str:
    """The caption under a step's plate: its hole or cut-out count and, for cut-outs, their sizes."""
    what = f"The layer's {tiles} plates, one per tile" if tiles else "The plate"
    if step.holes is None:
        return what
    return f"{what} ({step.holes:,} {step.kind}" + (f", {step.detail}" if step.detail else "") + ")"


def _wall_steps(
    manifest: Mapping[str, Any],
    cfg: Mapping[str, Any],
    primer: Mapping[str, Any],
    primer_hex: str,
    n_tiles: int,
) -> list[str]:
    """The set-up instructions: prime, set the wall, fit the plates, spray evenly (and the mural's tiles)."""
    nozzle = _val(cfg, "spray", "nozzle_height", default=None)
    # Hard mode sprays from its own nozzle height (the pipeline copies it into the spray section).
    section = "hard" if str(cfg.get("mode", "soft")) == "hard" else "spray"
    walls = _val(manifest, "build", "walls", default=[]) or []
    wall = [
        f"Prime the whole surface with the primer {primer_hex}"
        + (f" ({primer.get('name')})" if primer.get("name") else "")
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
        _spray_how(cfg, section, nozzle),
    ]
    if n_tiles:
        wall.append(
            f"The picture is a mural of {n_tiles} tiles (map below): spray it round by round, one layer "
            "on every tile in its own wall position, then the next layer (Order of work below)."
        )
    return wall


def _paint_table(
    manifest: Mapping[str, Any], cfg: Mapping[str, Any], primer_hex: str, steps: list[Step]
) -> tuple[list[list[str]], str]:
    """The paint to buy: one row for the primer and one per layer, and the note on how it was counted."""
    paint = manifest.get("paint") or {}
    prow = {r.get("layer"): r for r in paint.get("layers", [])}
    cov = paint.get("coverage_m2_per_can", _val(cfg, "paints", "coverage_m2_per_can", default=1.5))
    can_ml = paint.get("can_ml", _val(cfg, "paints", "can_ml", default=400.0))
    area = float(paint.get("sprayed_area_m2", 0.0))
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
    for s in steps:
        r = prow.get(s.number)
        if not r:
            continue
        paint_rows.append(
            [
                s.plate,
                s.hex + (f" {s.name}" if s.name else ""),
                f"{r['covered_m2']:.4f}",
                f"{r['mean_opacity']:.3f}",
                f"{r['ml']:.1f}",
                str(r["cans_to_buy"]),
            ]
        )
    paint_note = (
        f"Covered area = sprayed area ({area:.3f} m²) × the layer's mean opacity in the simulation; "
        f"at {cov:g} m² per {can_ml:g} ml can. Paint that lands on the plate is not counted: sweeping "
        "the whole plate uses more."
    )
    return paint_rows, paint_note


def _snap_lines(manifest: Mapping[str, Any]) -> list[str]:
    """Which can each solved paint (and the primer) was snapped to, and what that cost."""
    snap = []
    sn = _val(manifest, "cans", "snap")
    if sn:
        for r in sn.get("paints", []):
            snap.append(f"solved {r['solved']} → can {r['can']} {r['name']} (ΔE2000 {r['delta_e2000']:.1f})")
        if sn.get("primer"):
            r = sn["primer"]
            snap.append(f"primer {r['solved']} → can {r['can']} {r['name']} (ΔE2000 {r['delta_e2000']:.1f})")
        snap.append(
            f"cost of using the cans: composite RMSE {sn['rmse_solved']:.2f} → {sn['rmse_snapped']:.2f} (0-255 units)"
        )
    return snap


def _profiles(manifest: Mapping[str, Any]) -> list[LayerProfile]:
    """The manifest's ``spray_profiles``: the spray settings each layer sprayed with."""
    rows = manifest.get("spray_profiles") or []
    return [LayerProfile.from_json(r) for r in rows if isinstance(r, Mapping)]


def sheet_from_manifest(
    manifest: Mapping[str, Any], tiles: Sequence[Mapping[str, Any]] | None = None
) -> Sheet:
    """Collect what the sheet shows from a job's manifest.

    Args:
        manifest: The manifest (as written to ``manifest.json``; ``files`` may be partial).
        tiles: Tiles of a mural, each with ``x_mm``, ``y_mm``, ``width_mm``, ``height_mm`` (picture
            frame, bottom-left corner) and optionally ``name``; None takes ``manifest["tiles"]``
            (or ``manifest["mural"]["tiles"]``) when present.

    Returns:
        The :class:`Sheet`.
    """
    cfg = manifest.get("config", {}) or {}
    pic = manifest.get("picture", {}) or {}
    mode = str(cfg.get("mode", "soft"))
    spray = manifest.get("spray_order") or {}
    names = _file_names(manifest)
    steps = _steps(manifest, mode, names)
    primer = spray.get("primer") or {}
    primer_hex = (
        primer.get("hex")
        or _val(manifest, "decompose", "primer")
        or (_val(manifest, "hard", "palette") or ["#ffffff"])[0]
    )
    tiles_list = (
        list(tiles)
        if tiles is not None
        else list(manifest.get("tiles") or _val(manifest, "mural", "tiles", default=[]) or [])
    )
    head, rows = _print_rows(manifest, steps)
    paint_rows, paint_note = _paint_table(manifest, cfg, primer_hex, steps)
    warnings = [str(w) for w in (_val(manifest, "decompose", "warnings", default=[]) or [])]
    warnings += [str(w) for w in (_val(manifest, "hard", "warnings", default=[]) or [])]
    warnings += _dark_end_warnings(manifest)
    unmeasured = unmeasured_warning(_profiles(manifest)) if _physical(manifest) else None
    warnings += [unmeasured] if unmeasured else []
    return Sheet(
        job=str(cfg.get("name", "stencil")),
        mode=mode,
        width_mm=float(pic.get("width_mm", 0.0)),
        height_mm=float(pic.get("height_mm", 0.0)),
        viewing=_viewing(manifest),
        primer_hex=str(primer_hex),
        primer_name=str(primer.get("name", "") or ""),
        order_note=str(spray.get("note", "")),
        unit=str(spray.get("unit", "spray time")),
        steps=steps,
        wall=_wall_steps(manifest, cfg, primer, primer_hex, len(tiles_list)),
        tiles=mural.map_tiles(tiles_list),
        prints=rows,
        print_head=head,
        paint=paint_rows,
        paint_note=paint_note,
        snap=_snap_lines(manifest),
        scores=_scores(manifest),
        checks=_checks(manifest),
        files=sorted(names),
        warnings=warnings,
        plate_count=len(_val(manifest, "build", "plates", default=[]) or []) or len(steps),
        mural=mural.mural_plan(
            manifest, steps, lambda s: _amount(s, str(spray.get("unit", "spray time"))), names
        ),
    )


def _physical(manifest: Mapping[str, Any]) -> bool:
    """Whether the job sprays under the physical model (the only one with can constants)."""
    return str(_val(manifest, "config", "spray", "model", default="physical")) == "physical"


def _spray_how(cfg: Mapping[str, Any], section: str, nozzle: float | None) -> str:
    """How to hold and move the can: the physical model's distance and speed, or the paper's height."""
    if str(_val(cfg, "spray", "model", default="physical")) == "physical":
        cm = float(_val(cfg, "spray", "can_distance_mm", default=200.0)) / 10.0
        speed = float(_val(cfg, "spray", "pass_speed_m_s", default=0.5))
        return (
            f"Hold the can about {cm:g} cm from the plate and sweep evenly across the whole plate at about "
            f"{speed:g} m/s, starting and ending off the plate. Spray light passes, the number each step "
            "gives, and let each pass flash off (about a minute) before the next: a heavy coat under a "
            "lifted stencil runs and creeps. Let each layer dry before the next."
        )
    return (
        "Spray every layer from the same distance and sweep evenly over the whole plate"
        + (
            f" (at the nozzle height the simulation assumed, {section}.nozzle_height = {nozzle:g})"
            if nozzle is not None
            else ""
        )
        + "; let each layer dry before the next."
    )


def _dark_end_warnings(manifest: Mapping[str, Any]) -> list[str]:
    """A line per layer whose darkest tones its plate cannot spray in its passes: the layer and the shortfall."""
    out = []
    passes = {
        r.get("layer"): r.get("passes") for r in manifest.get("spraying", []) or [] if isinstance(r, Mapping)
    }
    for k, row in enumerate(manifest.get("dark_end", []) or []):
        share = float(row.get("unreachable_share", 0.0))
        if share < 0.005:
            continue
        n = passes.get(k + 1)
        within = f" in {n} pass{'' if n == 1 else 'es'}" if n else ""
        out.append(
            f"Layer {k + 1}: {100 * share:.0f} % of its area is darker than its plate can spray{within} even with "
            f"its densest holes (darkest opacity {float(row['darkest_sprayable']):.2f}, short by "
            f"{float(row['unreachable_by']):.2f} on average there): those parts come out lighter than the picture."
        )
    return out


#: The can column of a paint no can list (and no colour name, paints.can_names: false) names.
_NO_CAN = "no can named"


def _amount(step: Step, unit: str, bare: bool = False) -> str:
    """A step's amount of paint in the job's unit: ``2 passes`` or ``spray time 0.707``."""
    t = step.spray_time
    if t is None:
        return "–" if bare else ""
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
    return f"{m.plates} plates ({len(sheet.steps)} layers on each of {len(m.sections)} tiles) and {m.walls} walls"


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
            "Passes: whole sweeps of the can across the plate, at the can distance and speed given per step."
        )
    return "Spray time is relative to the job's spray.spray_time (1 = the planned dose)."
