"""The mural's part of the instruction sheet: the order of work, registration, one section per tile.

Built from the job's mural figures (each tile's core and sheet in mm from the mural's
bottom-left corner, the halo, the holes per tile and layer), its build figures (every plate and
wall, with the tile it belongs to) and the sheet's steps (paint and amount per layer):

* the order of work: round by round (one layer on every tile, then the next), which is the
  only order that keeps the picture's *over* order at a seam where two tiles' sprays overlap;
* registration: how to mark the corner, the grid lines (a chalk line on a long mural, a
  straightedge and pencil on a short one, tape marks where neither takes), where the first
  tile's notches sit and how each next tile meets its neighbour on their shared line;
* per tile, in order of work: where it sits, which line each side's notches meet, its wall,
  its plates with paint, amount, holes and files, and every check of its parts.

The renderers take the HTML escaper or the PDF kit of :mod:`stencil_cad.sheet` as arguments,
so this module stays below it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..figures import Figures, MuralBuildFigures, MuralFigures, MuralSimulation, PlateRow, TileRow, WallRow
from . import make
from .settings import JobSettings

__all__ = [
    "MapTile",
    "MuralPlan",
    "TilePlate",
    "TileSection",
    "map_tiles",
    "mural_html",
    "mural_pdf",
    "mural_plan",
]

#: A mural whose longer side is above this (mm) gets its grid lines snapped with a chalk line;
#: a shorter one is drawn with a straightedge or level.
CHALK_LINE_ABOVE_MM = 1000.0

_EXTS = (".stl", ".step", ".3mf", ".dxf", ".svg")


@dataclass(frozen=True)
class TilePlate:
    """One plate of a tile: its layer, paint, amount, holes and files."""

    stem: str
    layer: int
    hex: str
    name: str
    amount: str
    holes: int | None
    files: list[str]


@dataclass(frozen=True)
class TileSection:
    """Everything one tile needs: where it goes, which lines its notches meet, its wall, plates, checks."""

    name: str
    where: str
    sides: list[str]
    walls: list[str]
    plates: list[TilePlate]
    checks: list[tuple[str, bool]] = field(default_factory=list)


@dataclass(frozen=True)
class MuralPlan:
    """The mural's order of work, registration steps and tile sections."""

    grid: str
    plates: int
    walls: int
    rounds: list[str]
    registration: list[str]
    sections: list[TileSection]
    checks: list[tuple[str, bool]] = field(default_factory=list)


@dataclass(frozen=True)
class MapTile:
    """One tile on the map: its name and its core's corner and size in mm (picture frame, y up)."""

    name: str
    x_mm: float
    y_mm: float
    width_mm: float
    height_mm: float

    @classmethod
    def from_json(cls, row: Mapping[str, Any], k: int) -> MapTile:
        """A tile given as ``name``, ``x_mm``, ``y_mm``, ``width_mm``, ``height_mm`` (the ``k``-th)."""
        return cls(
            name=str(row.get("name") or row.get("tile") or f"T{k + 1}"),
            x_mm=float(row.get("x_mm", 0)),
            y_mm=float(row.get("y_mm", 0)),
            width_mm=float(row.get("width_mm", 0)),
            height_mm=float(row.get("height_mm", 0)),
        )


def map_tiles(rows: Sequence[TileRow | Mapping[str, Any]]) -> list[MapTile]:
    """Tiles for the tile map: each core's name, corner and size.

    Takes the mural's tiles (``tile``, ``core_mm``) or tiles given in the map's form.
    """
    out = []
    for k, given in enumerate(rows):
        t = TileRow.from_json(given) if isinstance(given, Mapping) and "core_mm" in given else given
        if isinstance(t, TileRow) and t.core_mm is not None:
            x0, y0, x1, y1 = (float(v) for v in t.core_mm)
            out.append(MapTile(str(t.tile or f"T{k + 1}"), x0, y0, x1 - x0, y1 - y0))
        else:
            out.append(MapTile.from_json(t.to_json() if isinstance(t, TileRow) else t, k))
    return out


def _mm(v: float) -> str:
    return f"{v:.1f}"


def _edges(rows: Sequence[TileRow], axis: int) -> list[float]:
    return sorted({round(float(_core(t)[i]), 3) for t in rows for i in (axis, axis + 2)})


def _core(t: TileRow) -> Sequence[float]:
    """A tile's core ``(x0, y0, x1, y1)`` in mm (every tile the plan takes has one)."""
    if t.core_mm is None:
        raise ValueError(f"tile {t.tile} has no core")
    return t.core_mm


def _neighbours(rows: Sequence[TileRow]) -> dict[tuple[int, int], str]:
    return {(int(t.row or 0), int(t.column or 0)): str(t.tile) for t in rows}


def _sides(t: TileRow, near: Mapping[tuple[int, int], str]) -> list[str]:
    """Which grid line each side's notches meet, and the tile across it (or the picture's edge)."""
    x0, y0, x1, y1 = (float(v) for v in _core(t))
    r, c = int(t.row or 0), int(t.column or 0)
    # Row A is the top row: the tile above has the smaller row number.
    sides = (
        ("left", f"x = {_mm(x0)} mm", near.get((r, c - 1))),
        ("right", f"x = {_mm(x1)} mm", near.get((r, c + 1))),
        ("top", f"y = {_mm(y1)} mm", near.get((r - 1, c))),
        ("bottom", f"y = {_mm(y0)} mm", near.get((r + 1, c))),
    )
    return [
        f"{side} notches on {line} ({'meets ' + other if other else 'the picture edge'})"
        for side, line, other in sides
    ]


def _method(width: float, height: float) -> str:
    if max(width, height) > CHALK_LINE_ABOVE_MM:
        return (
            "Snap a chalk line through each pair of marks (pull it taut over both, lift it straight up, "
            "let it go): vertical lines through the x marks, horizontal through the y marks."
        )
    return (
        "Draw each grid line through its pair of marks with a straightedge or a long level and a soft "
        f"pencil (the mural is {_mm(width)} × {_mm(height)} mm: a chalk line is for longer runs)."
    )


def _registration(m: MuralFigures, rows: Sequence[TileRow], walls: Mapping[str, list[WallRow]]) -> list[str]:
    """The registration steps, from the tiles' geometry."""
    xs, ys = _edges(rows, 0), _edges(rows, 1)
    width, height = max(xs), max(ys)
    halo = float(m.halo_mm or 0.0)
    first = rows[0]
    near = _neighbours(rows)
    notches = next((int(w.notches or 0) for w in walls.get(str(first.tile), [])), 0)
    steps = [
        "Mark the mural's bottom-left corner on the surface. Draw its bottom edge level and its left edge "
        "plumb (a spirit level or a laser level): every position on this sheet is in mm from that corner, "
        f"x to the right, y up; the picture is {_mm(width)} × {_mm(height)} mm.",
        "Measure from the corner with a steel tape (always from the corner, not from the last mark, so "
        f"errors do not add up) and mark the grid lines: x = {', '.join(_mm(x) for x in xs)} mm along the "
        f"bottom and the top edge, y = {', '.join(_mm(y) for y in ys)} mm along the left and the right edge.",
        _method(width, height)
        + " Where chalk or pencil does not take (glass, fresh paint), put a short strip of masking tape "
        "across the line at each place a notch will meet it and mark the exact position on the tape.",
        f"First tile, {first.tile}: set its wall with its "
        + "; ".join(_sides(first, near))
        + f". Pencil a tick through each of its {notches or 'sight'} notches: the wall goes back onto "
        "these ticks for every layer.",
    ]
    if len(rows) > 1:
        second = rows[1]
        shared = [s for s in _sides(second, near) if f"meets {first.tile}" in s]
        steps.append(
            "Each next tile meets its neighbour on their shared grid line"
            + (f" ({second.tile}: {shared[0]})" if shared else "")
            + f". Its wall and plate reach {halo:.1f} mm past that line over the neighbour, where the "
            "plate is solid, so paint already on the neighbour stays covered; the holes on either side "
            "of the line belong to one picture, split between the tiles."
        )
    steps.append(
        "Every plate of a tile has the same notches in its border as the tile's wall: before each spray, "
        "check that the plate's notches line up with the wall's and with the ticks on the surface."
    )
    shared = sorted({str(w.tile) for ws in walls.values() for w in ws})
    if len(shared) < len(rows):
        steps.append(
            f"One wall serves {'every tile' if len(shared) == 1 else 'several tiles'} ({', '.join(shared)}): every "
            "tile's plates have the same size and notches, their border reaching the halo past the core on "
            "every side (solid past the mural's edge). To spray a tile, set the wall on that tile's ticks "
            "(pencil them the first time, with the wall's notches on the tile's grid lines), spray, lift the "
            "wall straight up and carry it to the next tile."
        )
    stand = _laser_stand_step(m)
    if stand:
        steps.append(stand)
    posts = _posts_step(m)
    if posts:
        steps.append(posts)
    cost = _registration_cost(m.simulation)
    if cost:
        steps.append(cost)
    return steps


def _walls(n: int) -> str:
    """``1 wall`` (moved from tile to tile) or ``8 walls``."""
    return "1 wall (moved from tile to tile)" if n == 1 else f"{n} walls"


def _laser_stand_step(m: MuralFigures) -> str:
    """How a laser-cut mural's frame and spacers go together, as one step (empty for a printed wall)."""
    parts = {str(p.get("name")): p for p in (m.built.laser_stand if m.built is not None else None) or ()}
    if not parts:
        return ""
    base, top, spacer = parts.get("frame_base"), parts.get("frame_top"), parts.get("spacer")
    text = ""
    if base is not None and top is not None:
        text = (
            f"Frame (laser-cut, no printed wall): cut frame_base.dxf {int(base['count'])} times from "
            f"{float(base['thickness_mm']):g} mm sheet and frame_top.dxf once from the plates' "
            f"{float(top['thickness_mm']):g} mm sheet; glue the base rings in a stack with their notches "
            "and edges flush, and the top ring on them: the plate drops into the top ring and rests on the "
            "base. The frame serves every tile as the wall would."
        )
    if spacer is not None:
        text += (
            f" Spacers: cut spacer.dxf {int(spacer['count'])} times from the base's sheet; a post is a stack "
            "of them, threaded with the plate on a 2 mm pin through the plate's pin hole."
        )
    return text.strip()


def _posts_step(m: MuralFigures) -> str:
    """How the plates stand on their posts, as one step (empty when the walls alone carry them)."""
    posts = m.built.posts if m.built is not None else None
    if not posts:
        return ""
    most = int(posts.get("most") or 0)
    return (
        f"Posts: print {most} of post.stl (a foot {float(posts.get('height_mm') or 0):g} mm high, the wall's "
        f"stand-off, with a pin on top). Each plate is thin and has a pin hole in its picture wherever it "
        "stands on a post, sited where that plate sprays nothing: before laying a plate in its wall, push "
        "a post's pin into each pin hole from below (foot down, pin flush with the plate's top), then lay the "
        "plate in the wall so that every foot stands on the surface. Move the posts from plate to plate; a "
        "post never stands under another plate's holes. Pull them out before cleaning the plate."
    )


def _registration_cost(sim: MuralSimulation | None) -> str:
    """What a misregistration costs in the simulation, as one sentence."""
    if sim is None:
        return ""
    base = sim.zero_error_scores.scielab if sim.zero_error_scores is not None else None
    rows = [r for r in sim.registration_cost or () if r.has("scielab")]
    if base is None or not rows:
        return ""
    parts = [
        f"{float(r.error_mm or 0.0):g} mm between {r.between}: {float(r.scielab or 0.0):.2f}"
        for r in rows
        if r.has("error_mm")
    ]
    return (
        f"How exact: in the simulation the S-CIELAB error at the viewing distance is {float(base):.2f} "
        "in register, and with a shift of " + "; ".join(parts) + "."
    )


def _rounds(rows: Sequence[TileRow], steps: Sequence[Any], amount: Callable[..., Any]) -> list[str]:
    order = " ".join(str(t.tile) for t in rows)
    return [
        f"Round {s.number}: {s.plate} of every tile, paint {s.hex}"
        + (f" {s.name}" if s.name else "")
        + f"{amount(s)}, tile by tile in this order: {order}. Let it dry before the next round."
        for s in steps
    ]


@dataclass(frozen=True)
class _Job:
    """What every tile's section reads: the job's figures, settings, steps by layer, amounts and files."""

    figures: Figures
    settings: JobSettings
    steps: Mapping[int, object]
    amount: Callable[..., Any]
    names: set[str]


def _section(
    job: _Job,
    t: TileRow,
    near: Mapping[tuple[int, int], str],
    plates: list[PlateRow],
    walls: list[WallRow],
) -> TileSection:
    """One tile's section: position, notches, wall, plates (paint, amount, holes, files) and checks."""
    x0, y0, x1, y1 = (float(v) for v in _core(t))
    reach = t.part_mm if t.part_mm is not None else t.sheet_mm
    s0, _, s1, _ = (float(v) for v in (reach if reach is not None else _core(t)))
    name = str(t.tile)
    where = (
        f"row {name.rstrip('0123456789')}, column {int(t.column or 0)}: its holes cover x {_mm(x0)}–{_mm(x1)} mm, "
        f"y {_mm(y0)}–{_mm(y1)} mm from the bottom-left corner; its plates reach x {_mm(s0)}–{_mm(s1)} mm"
    )
    wall_lines = []
    for w in walls:
        stem = str(w.file or "").rsplit(".", 1)[0]
        files = [stem + e for e in (".stl", ".step") if stem + e in job.names]
        shared = f" (made once, for {w.tile}; moved here)" if w.tile and str(w.tile) != name else ""
        wall_lines.append(
            f"{', '.join(files) or stem}{shared}: stand-off {float(w.standoff_mm or 0):g} mm, "
            f"{int(w.notches or 0)} sight notches"
        )
    tile_plates, checks = [], []
    for p in plates:
        stem = str(p.file)
        s = job.steps.get(p.number)
        tile_plates.append(
            TilePlate(
                stem=stem,
                layer=p.number,
                hex=str(getattr(s, "hex", "")),
                name=str(getattr(s, "name", "") or ""),
                amount=job.amount(s).lstrip(", ") if s is not None else "",
                holes=None if p.hole_count is None else int(p.hole_count),
                files=[stem + e for e in _EXTS if stem + e in job.names],
            )
        )
        checks += make.plate_checks(p, stem)
    checks += [make.wall_check(w) for w in walls]
    build = job.figures.build
    parts = [p for p in make.plate_parts(build) if p.tile == name]
    parts += [w for w in make.wall_parts(build) if w.tile == name]
    checks += [c for c in (make.fit_check(job.settings, part) for part in parts) if c is not None]
    return TileSection(name, where, _sides(t, near), wall_lines, tile_plates, checks)


def mural_plan(
    f: Figures, s: JobSettings, steps: Sequence[Any], amount: Callable[..., Any], names: set[str]
) -> MuralPlan | None:
    """The mural's order of work, registration and tile sections, or None for a one-plate job.

    Args:
        f: The job's figures (the mural's tiles, the build's plates and walls).
        s: The job's settings (the bed the parts are checked on).
        steps: The sheet's steps (one per layer, in spray order: ``number``, ``plate``, ``hex``, ``name``).
        amount: A step's amount of paint as text (``", 3 passes"``).
        names: The job's file names.
    """
    m = f.mural
    built = m.built if m is not None else None
    rows = [t for t in (built.tiles if built is not None else ()) if t.core_mm is not None]
    if m is None or built is None or not m.tiled or not rows:
        return None
    plates: dict[str, list[PlateRow]] = {}
    walls: dict[str, list[WallRow]] = {}
    for p in f.build.plates if f.build is not None else ():
        plates.setdefault(str(p.tile), []).append(p)
    for w in f.build.walls if f.build is not None else ():
        # One wall serves every tile of its size and notches (``tiles``; older manifests: its own).
        for name in w.other.get("tiles") or [w.tile]:
            walls.setdefault(str(name), []).append(w)
    near = _neighbours(rows)
    job = _Job(f, s, {int(st.number): st for st in steps}, amount, names)
    sections = [
        _section(
            job,
            t,
            near,
            sorted(plates.get(str(t.tile), []), key=lambda p: p.number),
            walls.get(str(t.tile), []),
        )
        for t in rows
    ]
    n_rows = max(int(t.row or 0) for t in rows)
    n_cols = max(int(t.column or 0) for t in rows)
    return MuralPlan(
        grid=f"{len(rows)} tiles, {n_rows} rows × {n_cols} columns",
        plates=sum(len(v) for v in plates.values()),
        walls=len(f.build.walls) if f.build is not None else 0,
        rounds=_rounds(rows, steps, amount),
        registration=_registration(m, rows, walls),
        sections=sections,
        checks=_union_checks(built),
    )


def _union_checks(built: MuralBuildFigures) -> list[tuple[str, bool]]:
    """The checks across the tiles: every hole on one tile, the design rules across the seams."""
    checks = []
    if built.holes_total is not None and built.holes_global is not None:
        checks.append(
            (
                f"the tiles hold {int(built.holes_total):,} holes, the mural's {int(built.holes_global):,}",
                built.holes_total == built.holes_global,
            )
        )
    if built.union_check_rules:
        checks.append(
            (
                "every tile's holes together keep the design rules across the seams",
                built.union_check_rules == "passed",
            )
        )
    return checks


# ------------------------------------------------------------------------------------ rendering


def mural_html(plan: MuralPlan, e: Callable[[object], str], chip: Callable[[str], str]) -> str:
    """The order of work, the registration steps and the tile sections as HTML."""
    out = [
        f'<h2>Order of work</h2><p class="note">{e(plan.grid)}: {plan.plates} plates and {_walls(plan.walls)}. '
        "Spray round by round: one layer on every tile, then the next layer; a tile's later "
        "layer goes over its neighbours' earlier ones at the seams, as in the picture.</p>",
        '<ol class="rounds">' + "".join(f"<li>{e(r)}</li>" for r in plan.rounds) + "</ol>",
        '<h2>Registration: where each tile goes</h2><ol class="registration">'
        + "".join(f"<li>{e(r)}</li>" for r in plan.registration)
        + "</ol>",
        "<h2>Tile by tile</h2>",
    ]
    for sec in plan.sections:
        rows = "".join(
            f"<tr><td>{p.layer:02d}</td><td>{e(p.stem)}</td><td>{chip(p.hex)}<code>{e(p.hex)}</code>"
            f"{' ' + e(p.name) if p.name else ''}</td><td>{e(p.amount)}</td>"
            f"<td>{p.holes if p.holes is not None else 'not counted'}</td><td>{e(', '.join(p.files))}</td></tr>"
            for p in sec.plates
        )
        checks = "".join(
            f'<li><span class="{"ok" if ok else "bad"}">{"passed" if ok else "FAILED"}</span> {e(t)}</li>'
            for t, ok in sec.checks
        )
        out.append(
            f'<section class="tile" id="tile-{e(sec.name)}"><h3>Tile {e(sec.name)}</h3>'
            f'<p class="note">{e(sec.where)}.</p>'
            "<p>Notches: " + "; ".join(e(s) for s in sec.sides) + ".</p>"
            "<p>Wall: " + "; ".join(e(w) for w in sec.walls) + ".</p>"
            "<table><tr><th>layer</th><th>plate</th><th>paint</th><th>amount</th><th>holes</th>"
            f"<th>files</th></tr>{rows}</table>"
            f'<h4>Checks of tile {e(sec.name)}</h4><ul class="tile-checks">{checks}</ul></section>'
        )
    if plan.checks:
        out.append(
            "<h3>Checks across the tiles</h3><ul>"
            + "".join(
                f'<li><span class="{"ok" if ok else "bad"}">{"passed" if ok else "FAILED"}</span> {e(t)}</li>'
                for t, ok in plan.checks
            )
            + "</ul>"
        )
    return "\n".join(out)


def mural_pdf(plan: MuralPlan, k: Any) -> list[Any]:
    """The order of work, the registration steps and the tile sections as ReportLab flowables.

    Args:
        plan: The mural's plan.
        k: The sheet's PDF kit (styles, ``p``, ``heading``, ``table``, ``page_w``).
    """
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether

    story = [
        k.heading("Order of work", k.h2),
        k.p(
            f"{plan.grid}: {plan.plates} plates and {_walls(plan.walls)}. Spray round by round: one layer "
            "on every tile, then the next layer."
        ),
    ]
    story += [k.p(f"{j + 1}. {r}") for j, r in enumerate(plan.rounds)]
    story.append(k.heading("Registration: where each tile goes", k.h2))
    story += [k.p(f"{j + 1}. {r}") for j, r in enumerate(plan.registration)]
    story.append(k.heading("Tile by tile", k.h2))
    for sec in plan.sections:
        rows = [
            [
                f"{p.layer:02d}",
                p.stem,
                f"{p.hex} {p.name}".rstrip(),
                p.amount,
                str(p.holes) if p.holes is not None else "not counted",
                ", ".join(p.files),
            ]
            for p in sec.plates
        ]
        block = [
            k.heading(f"Tile {sec.name}", k.h3),
            k.p(sec.where + ".", k.small),
            k.p("Notches: " + "; ".join(sec.sides) + "."),
            k.p("Wall: " + "; ".join(sec.walls) + "."),
            k.table(
                ["layer", "plate", "paint", "amount", "holes", "files"],
                rows,
                [12 * mm, 34 * mm, 30 * mm, 24 * mm, 14 * mm, k.page_w - 114 * mm],
            ),
        ]
        story.append(KeepTogether(block))
        story.append(k.p(f"Checks of tile {sec.name}:", k.small))
        story += [k.p(f"{'passed' if ok else 'FAILED'}: {t}", k.small) for t, ok in sec.checks]
    if plan.checks:
        story.append(k.heading("Checks across the tiles", k.h3))
        story += [k.p(f"{'passed' if ok else 'FAILED'}: {t}") for t, ok in plan.checks]
    return story
