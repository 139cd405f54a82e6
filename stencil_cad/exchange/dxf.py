"""Laser-cutting DXF from dots and polygons (kernel-free: ezdxf and numpy only).

One file holds one or more stencils, each on its own cut layer: the holes as one CIRCLE each
(or closed LWPOLYLINEs for hard-mode cut-outs) and the plate outline as a closed
LWPOLYLINE, holes first so that a laser that cuts in file order frees the plate last. A
stencil's label (layer, paint, tile: the letters of the plate's own label, as outlines) is on
a score layer of its own in blue, first in the file, to engrave or score at low power. The
drawing is R2010, in millimetres (``$INSUNITS`` = 4), and moved into the +X/+Y quadrant,
where laser software expects it; the shift from the picture frame is returned and stored
in the header as the custom properties ``STENCIL_OFFSET_X_MM`` and ``STENCIL_OFFSET_Y_MM``.

Kerf compensation moves every cut line half the kerf into the waste: holes and cut-outs
shrink by ``kerf / 2``, islands and the plate outline grow by ``kerf / 2``.
"""

from __future__ import annotations

import contextlib
import io
import logging
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import ezdxf
import numpy as np
from ezdxf import units

from ..geometry import as_ccw, as_cw
from ..model import Holes

__all__ = [
    "CUT_COLOURS",
    "SCORE_COLOUR",
    "DxfInfo",
    "DxfStencil",
    "cut_length_mm",
    "dxf_from_layers",
    "offset_ring",
    "write_dxf",
    "write_dxf_stencils",
]

log = logging.getLogger(__name__)

DXF_VERSION = "R2010"
#: ACI colour of the score (label) layers: blue, the engrave colour of most laser software.
SCORE_COLOUR = 5
#: ACI colours of the cut layers, one per stencil in turn (blue left out for the score layers).
CUT_COLOURS = (1, 2, 3, 4, 6)


@dataclass(frozen=True)
class DxfStencil:
    """One stencil to draw: its outline and its cuts, in the picture frame (mm).

    Attributes:
        outline_ring: ``(M, 2)`` ring of the plate outline (any orientation).
        circles_xy_r: ``(N, 3)`` array of (x, y, r) in mm, or a pair ``(xy (N, 2), r (N,))``,
            or None.
        polygons: Hard-mode cut-outs, or None. Each entry is a ring ``(K, 2)`` or a pair
            ``(outer, holes)`` as in :class:`stencil_cad.model.CutLayer` (holes are islands
            that stay as sheet).
        layer_name: DXF layer name (letters, digits, ``_``, ``-``): the cut layer.
        label: The plate's label text (layer, paint, tile), or empty.
        label_glyphs: The label's letters as ``(outer, inners)`` rings in the picture frame (the
            plate's own label glyphs); drawn on the score layer ``<layer_name>_SCORE`` in
            :data:`SCORE_COLOUR`, to engrave or score, never to cut.
    """

    outline_ring: np.ndarray
    circles_xy_r: np.ndarray | tuple[np.ndarray, np.ndarray] | None = None
    polygons: Sequence | None = None
    layer_name: str = "STENCIL_01"
    label: str = ""
    label_glyphs: Sequence = ()

    @property
    def score_layer(self) -> str:
        """Name of the layer that holds the label to engrave or score."""
        return f"{self.layer_name}_SCORE"

    def score_rings(self) -> list[np.ndarray]:
        """Every ring of the label's glyphs (outer rings and their inner rings), ``(K, 2)`` mm each."""
        out = []
        for outer, inners in self.label_glyphs:
            out.append(np.asarray(outer, dtype=np.float64).reshape(-1, 2))
            out += [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in inners]
        return out


@dataclass(frozen=True)
class DxfInfo:
    """What was written.

    Attributes:
        path: The file written.
        layers: Layer names, one per stencil.
        offset_mm: ``(dx, dy)`` added to picture-frame coordinates to put the drawing in +X/+Y.
        circles: CIRCLE entities written, per layer.
        polylines: Closed LWPOLYLINE entities written (outline included), per layer.
        kerf_mm: Kerf compensated for, in mm.
        bbox_mm: ``(xmin, ymin, xmax, ymax)`` of the drawing in DXF coordinates.
    """

    path: str
    layers: list[str]
    offset_mm: tuple[float, float]
    circles: list[int]
    polylines: list[int]
    kerf_mm: float
    bbox_mm: tuple[float, float, float, float]
    extra: dict = field(default_factory=dict)


def _as_ring(ring, ccw: bool) -> np.ndarray:
    r = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
    if len(r) > 1 and np.allclose(r[0], r[-1]):
        r = r[:-1]
    if len(r) < 3:
        raise ValueError(f"a ring needs at least 3 distinct vertices, got {len(r)}")
    return np.ascontiguousarray(as_ccw(r) if ccw else as_cw(r))


def offset_ring(ring: np.ndarray, delta_mm: float, miter_limit: float = 4.0) -> np.ndarray:
    """Move every edge of a ring by ``delta_mm`` to its left (into a counter-clockwise ring).

    Each vertex moves along its bisector by ``delta / cos(half the turn)``: the exact offset of
    the edges' lines, which is what a kerf of a fraction of a millimetre needs on rings whose
    edges are longer than the offset. Spikes are limited to ``miter_limit * |delta|``.

    Args:
        ring: ``(M, 2)`` ndarray ring.
        delta_mm: Offset in mm; positive moves left (shrinks a counter-clockwise ring).
        miter_limit: Largest vertex move as a multiple of ``|delta_mm|``. Defaults to 4.

    Returns:
        ``(M, 2)`` ndarray ring, same vertex order.
    """
    r = np.asarray(ring, dtype=np.float64)
    if delta_mm == 0.0:
        return r.copy()
    e_in = r - np.roll(r, 1, axis=0)
    e_out = np.roll(r, -1, axis=0) - r
    e_in /= np.maximum(np.hypot(e_in[:, 0], e_in[:, 1]), 1e-300)[:, None]
    e_out /= np.maximum(np.hypot(e_out[:, 0], e_out[:, 1]), 1e-300)[:, None]
    n_in = np.stack([-e_in[:, 1], e_in[:, 0]], axis=1)
    n_out = np.stack([-e_out[:, 1], e_out[:, 0]], axis=1)
    bis = n_in + n_out
    cos_half_sq = np.maximum(0.5 * (1.0 + np.einsum("ij,ij->i", n_in, n_out)), 1e-12)
    # |bis| = 2 cos(half); the move is delta / cos(half) along bis / |bis|.
    move = bis / (2.0 * cos_half_sq)[:, None]
    length = np.hypot(move[:, 0], move[:, 1])
    too_long = length > miter_limit
    move[too_long] *= (miter_limit / length[too_long])[:, None]
    return r + delta_mm * move


def _as_circles(circles) -> np.ndarray:
    if circles is None:
        return np.zeros((0, 3))
    if isinstance(circles, tuple) and len(circles) == 2:
        xy, rr = circles
        c = np.column_stack(
            [np.asarray(xy, dtype=np.float64).reshape(-1, 2), np.asarray(rr, dtype=np.float64)]
        )
    else:
        c = np.asarray(circles, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(c)):
        raise ValueError("circle centres and radii must be finite")
    if np.any(c[:, 2] <= 0):
        raise ValueError(f"circle radii must be > 0 mm, smallest is {c[:, 2].min():g}")
    return c


def _iter_polygons(polygons) -> Iterator[tuple[np.ndarray, list[np.ndarray]]]:
    for p in polygons or ():
        if isinstance(p, tuple | list) and len(p) == 2 and not np.isscalar(p[0]) and np.ndim(p[0]) == 2:
            outer, holes = p
            yield np.asarray(outer, dtype=np.float64), [np.asarray(h, dtype=np.float64) for h in holes]
        else:
            yield np.asarray(p, dtype=np.float64), []


def _sorted_classes(doc) -> None:
    """Write the CLASSES section in a fixed order.

    ezdxf collects the required classes from a set, so their order (and the file's bytes)
    changes with Python's string hashing from one process to the next.
    """
    section = doc.classes
    export = section.export_dxf

    def export_sorted(tagwriter):
        section.classes = dict(sorted(section.classes.items()))
        export(tagwriter)

    section.export_dxf = export_sorted


@contextlib.contextmanager
def _fixed_metadata(on: bool):
    old = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = bool(on) or old
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = old


def _prepare(st: DxfStencil, kerf_mm: float):
    """Kerf-compensated rings and circles of one stencil, in the picture frame."""
    half = 0.5 * kerf_mm
    outline = offset_ring(_as_ring(st.outline_ring, ccw=True), -half)
    circles = _as_circles(st.circles_xy_r).copy()
    if half > 0 and len(circles):
        if np.any(circles[:, 2] <= half):
            raise ValueError(
                f"kerf_mm ({kerf_mm} mm) is too wide for the smallest hole (radius {circles[:, 2].min():g} mm): "
                "holes must keep a radius > kerf / 2"
            )
        circles[:, 2] -= half
    rings = []
    for outer, holes in _iter_polygons(st.polygons):
        # The cut region is on the left of a CCW outer ring and of CW hole rings: moving both
        # left by kerf/2 shrinks the cut and grows the islands.
        rings.append(offset_ring(_as_ring(outer, ccw=True), half))
        rings.extend(offset_ring(_as_ring(h, ccw=False), half) for h in holes)
    return outline, circles, rings


def _circle_text(handles: list[int], owner: str, layer: str, circles: np.ndarray) -> str:
    """DXF text of CIRCLE entities, in the group-code layout ezdxf writes for R2010."""
    fmt = (
        "  0\nCIRCLE\n  5\n%X\n330\n"
        + owner
        + "\n100\nAcDbEntity\n  8\n"
        + layer.replace("%", "%%")
        + "\n100\nAcDbCircle\n 10\n%r\n 20\n%r\n 30\n0.0\n 40\n%r\n"
    )
    return "".join([fmt % row for row in zip(handles, *circles.T.tolist(), strict=True)])


def _polyline_text(handle: int, owner: str, layer: str, ring: list[list[float]]) -> str:
    """DXF text of one closed LWPOLYLINE, in the group-code layout ezdxf writes for R2010."""
    head = (
        f"  0\nLWPOLYLINE\n  5\n{handle:X}\n330\n{owner}\n100\nAcDbEntity\n  8\n{layer}\n"
        f"100\nAcDbPolyline\n 90\n{len(ring)}\n 70\n1\n"
    )
    return head + "".join([f" 10\n{x!r}\n 20\n{y!r}\n" for x, y in ring])


def _polylines(msp, layer: str, rings: list[np.ndarray], shift: np.ndarray, blocks: dict[str, str]) -> None:
    """Closed LWPOLYLINEs of ``rings`` moved by ``shift``: the first made by ezdxf, its text the block of all.

    ezdxf spends about 0.2 ms on a polyline of a label's letter (create and export), a third of the
    bundled example's DXF time: its eight files (316 polylines) took 0.163 CPU-s with every polyline
    made by ezdxf and 0.102 s so (median of 5 calls of :func:`write_dxf_stencils` each, on the
    job's stencils), the same bytes. The others' handles are reserved as ezdxf would have given
    them, one after another.
    """
    if not rings:
        return
    points = [(r + shift).tolist() for r in rings]
    first = msp.add_lwpolyline(points[0], format="xy", close=True, dxfattribs={"layer": layer})
    start = int(first.dxf.handle, 16)
    msp.doc.entitydb.handles.reset("%X" % (start + len(rings)))
    owner = msp.layout_key
    blocks[f"  0\nLWPOLYLINE\n  5\n{first.dxf.handle}\n"] = "".join(
        [_polyline_text(start + k, owner, layer, ring) for k, ring in enumerate(points)]
    )


def _extent(outline, circles, rings) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    if len(circles):
        lo = np.minimum(lo, (circles[:, :2] - circles[:, 2:3]).min(axis=0))
        hi = np.maximum(hi, (circles[:, :2] + circles[:, 2:3]).max(axis=0))
    for r in rings:
        lo, hi = np.minimum(lo, r.min(axis=0)), np.maximum(hi, r.max(axis=0))
    return lo, hi


def _add_score(doc, st: DxfStencil, shift: np.ndarray, blocks: dict[str, str]) -> int:
    """Draw a stencil's label rings on its score layer (created when it has any); returns how many."""
    score = st.score_rings()
    if score:
        doc.layers.add(st.score_layer, color=SCORE_COLOUR)
        _polylines(doc.modelspace(), st.score_layer, score, shift, blocks)
    return len(score)


def _shifts(extents: list, arrange: str, gap_mm: float) -> list[np.ndarray]:
    """Per-stencil shift into the +X/+Y quadrant: stacked stencils share one shift so they register."""
    shifts = []
    if arrange == "stack":
        lo = np.min([e[0] for e in extents], axis=0)
        shifts = [-lo] * len(extents)
    else:
        x = 0.0
        for lo, hi in extents:
            shifts.append(np.array([x - lo[0], -lo[1]]))
            x += (hi[0] - lo[0]) + gap_mm
    return shifts


def _draw(doc, stencils: Sequence[DxfStencil], prepared: list, shifts: list, extents: list):
    """Draw every stencil on a layer of its own; the first circle of each stands for all of them.

    Returns:
        ``(circles, polylines, score polylines)`` per stencil, the circle templates
        ``(handle, layer, circles)``, the polylines' blocks (:func:`_polylines`) and the
        drawing's extent ``(lo, hi)``.
    """
    msp = doc.modelspace()
    counts_c, counts_p, scored = [], [], []
    templates: list[tuple[str, str, np.ndarray]] = []
    blocks: dict[str, str] = {}
    all_lo, all_hi = np.full(2, np.inf), np.full(2, -np.inf)
    for i, (st, (outline, circles, rings), shift, (lo, hi)) in enumerate(
        zip(stencils, prepared, shifts, extents, strict=True)
    ):
        doc.layers.add(st.layer_name, color=CUT_COLOURS[i % len(CUT_COLOURS)])
        attribs = {"layer": st.layer_name}
        # The label first: a laser that works in file order scores it while the sheet is still whole.
        scored.append(_add_score(doc, st, shift, blocks))
        if len(circles):
            moved = circles.copy()
            moved[:, :2] += shift
            # ezdxf spends ~0.4 ms per entity (create + export); only the first circle of a
            # layer is made by ezdxf, as a template whose text is replaced after writing.
            first = msp.add_circle(tuple(moved[0, :2].tolist()), float(moved[0, 2]), dxfattribs=attribs)
            templates.append((first.dxf.handle, st.layer_name, moved))
        _polylines(msp, st.layer_name, [*rings, outline], shift, blocks)
        counts_c.append(len(circles))
        counts_p.append(len(rings) + 1)
        all_lo, all_hi = np.minimum(all_lo, lo + shift), np.maximum(all_hi, hi + shift)
    return counts_c, counts_p, scored, templates, blocks, all_lo, all_hi


def _text_with_templates(
    doc, templates: list[tuple[str, str, np.ndarray]], blocks: dict[str, str], deterministic: bool
) -> str:
    """The document's DXF text, each template entity replaced by its block.

    A circle template stands for its layer's every circle (``templates``); a polyline template
    for a run of polylines (``blocks``, keyed by the template's first lines).
    """
    owner = doc.modelspace().layout_key
    handles = doc.entitydb.handles
    blocks = dict(blocks)
    for handle, layer, moved in templates:
        start = int(str(handles), 16)
        # The template keeps its handle; the others take fresh ones, reserved by advancing
        # the generator so that $HANDSEED stays above every handle in the file.
        hs = [int(handle, 16)] + list(range(start, start + len(moved) - 1))
        handles.reset("%X" % (start + len(moved) - 1))
        blocks[f"  0\nCIRCLE\n  5\n{handle}\n"] = _circle_text(hs, owner, layer, moved)
    stream = io.StringIO()
    if deterministic:
        _sorted_classes(doc)
    with _fixed_metadata(deterministic):
        doc.write(stream)
    text = stream.getvalue()
    cuts = []
    for head, block in blocks.items():
        i = text.index(head)
        cuts.append((i, text.index("\n  0\n", i + len(head)) + 1, block))
    pieces, at = [], 0
    for i, j, block in sorted(cuts):
        pieces += [text[at:i], block]
        at = j
    return "".join([*pieces, text[at:]])


def write_dxf_stencils(
    path: str | Path,
    stencils: Sequence[DxfStencil],
    kerf_mm: float = 0.0,
    arrange: str = "stack",
    gap_mm: float = 5.0,
    deterministic: bool = False,
) -> DxfInfo:
    """Write several stencils into one DXF, a layer each.

    Args:
        path: Output file.
        stencils: The stencils; layer names must differ.
        kerf_mm: Laser kerf in mm (≥ 0) to compensate for. Defaults to 0.
        arrange: ``"stack"`` draws every stencil in the same place (they register, and the
            laser software shows one layer at a time); ``"row"`` places them side by side,
            ``gap_mm`` apart, to cut all on one sheet. Defaults to ``"stack"``.
        gap_mm: Gap between stencils in mm for ``"row"``. Defaults to 5 mm.
        deterministic: Write fixed dates and GUIDs so the same input gives the same bytes.

    Returns:
        What was written, including the shift applied to reach the +X/+Y quadrant.

    Raises:
        ValueError: On bad input (kerf wider than a hole, duplicate layer names, ...).
    """
    if kerf_mm < 0:
        raise ValueError(f"kerf_mm must be ≥ 0, got {kerf_mm}")
    if arrange not in ("stack", "row"):
        raise ValueError(f"arrange must be 'stack' or 'row', got {arrange!r}")
    names = [s.layer_name for s in stencils]
    if not names:
        raise ValueError("no stencil to write")
    if len(set(n.upper() for n in names)) != len(names):
        raise ValueError(f"layer names must differ (DXF layer names ignore case), got {names}")
    prepared = [_prepare(s, kerf_mm) for s in stencils]
    extents = [_extent(*p) for p in prepared]
    shifts = _shifts(extents, arrange, gap_mm)

    with _fixed_metadata(deterministic):  # ezdxf stamps its creation time in new()
        doc = ezdxf.new(DXF_VERSION, setup=False, units=units.MM)
    doc.header["$MEASUREMENT"] = 1
    doc.header["$LUNITS"] = 2
    counts_c, counts_p, scored, templates, blocks, all_lo, all_hi = _draw(
        doc, stencils, prepared, shifts, extents
    )

    offset = (float(shifts[0][0]), float(shifts[0][1]))
    doc.header.custom_vars.append("STENCIL_OFFSET_X_MM", repr(offset[0]))
    doc.header.custom_vars.append("STENCIL_OFFSET_Y_MM", repr(offset[1]))
    doc.header.custom_vars.append("STENCIL_KERF_MM", repr(float(kerf_mm)))
    doc.header["$EXTMIN"] = (float(all_lo[0]), float(all_lo[1]), 0.0)
    doc.header["$EXTMAX"] = (float(all_hi[0]), float(all_hi[1]), 0.0)
    text = _text_with_templates(doc, templates, blocks, deterministic)
    Path(path).write_bytes(doc.encode(text))
    info = DxfInfo(
        path=str(path),
        layers=names,
        offset_mm=offset,
        circles=counts_c,
        polylines=counts_p,
        kerf_mm=float(kerf_mm),
        bbox_mm=(float(all_lo[0]), float(all_lo[1]), float(all_hi[0]), float(all_hi[1])),
        extra={"shifts_mm": [(float(s[0]), float(s[1])) for s in shifts], "score_polylines": scored},
    )
    log.info("dxf: wrote %s (%s circles, %s polylines)", path, counts_c, counts_p)
    return info


def write_dxf(
    path: str | Path,
    outline_ring: np.ndarray,
    circles_xy_r: np.ndarray | tuple[np.ndarray, np.ndarray] | None = None,
    polygons: Sequence | None = None,
    layer_name: str = "STENCIL_01",
    kerf_mm: float = 0.0,
    deterministic: bool = False,
) -> DxfInfo:
    """Write one stencil as a laser DXF.

    Args:
        path: Output file.
        outline_ring: ``(M, 2)`` plate outline ring in mm (picture frame), e.g. from
            :func:`stencil_cad.outline.plate_outline`.
        circles_xy_r: Holes as an ``(N, 3)`` array of (x, y, r) mm, or a pair ``(xy, r)``;
            None for none.
        polygons: Hard-mode cut-outs: rings, or ``(outer, holes)`` pairs; None for none.
        layer_name: The stencil's layer. Defaults to ``"STENCIL_01"``.
        kerf_mm: Laser kerf in mm to compensate for. Defaults to 0.
        deterministic: Fixed dates and GUIDs (for tests and golden files).

    Returns:
        What was written; ``offset_mm`` is the shift from the picture frame.
    """
    st = DxfStencil(
        outline_ring=outline_ring, circles_xy_r=circles_xy_r, polygons=polygons, layer_name=layer_name
    )
    return write_dxf_stencils(path, [st], kerf_mm=kerf_mm, deterministic=deterministic)


def stencil_for(
    holes: Holes, outline_ring: np.ndarray, layer_name: str, label: str = "", glyphs: Sequence = ()
) -> DxfStencil:
    """The DXF description of one layer's plate: round holes (a DotSet) or cut-outs (a CutLayer).

    Args:
        holes: The layer's holes.
        outline_ring: The plate outline ring.
        layer_name: DXF layer name.
        label: The plate's label text. Defaults to none.
        glyphs: The label's glyph rings ``(outer, inners)`` in the picture frame. Defaults to none.
    """
    return DxfStencil(
        outline_ring=outline_ring,
        circles_xy_r=(holes.xy_mm, holes.r_mm),
        polygons=holes.polygons,
        layer_name=layer_name,
        label=label,
        label_glyphs=tuple(glyphs),
    )


def cut_length_mm(holes: Holes, ring: np.ndarray) -> float:
    """Length of every cut of a plate in mm: the holes (or cut-out rings) and the outline."""

    def perimeter(r) -> float:
        r = np.asarray(r, dtype=np.float64)
        return float(np.sum(np.linalg.norm(np.roll(r, -1, axis=0) - r, axis=1)))

    total = perimeter(ring) + float(2.0 * np.pi * np.sum(holes.r_mm))
    for outer, inner in holes.polygons:
        total += perimeter(outer) + sum(perimeter(h) for h in inner)
    return total


def dxf_from_layers(
    path: str | Path,
    layers: Sequence[Holes],
    outline_ring: np.ndarray,
    kerf_mm: float = 0.0,
    arrange: str = "stack",
    layer_prefix: str = "STENCIL_",
    deterministic: bool = False,
) -> DxfInfo:
    """Write every layer of a job (spray order) into one DXF, one DXF layer per plate.

    Round holes are CIRCLEs, cut-outs closed LWPOLYLINEs (their islands too); layers
    are named ``STENCIL_01``, ``STENCIL_02``, ... in spray order.

    Args:
        path: Output file.
        layers: The :class:`~stencil_cad.model.DotSet` or :class:`~stencil_cad.model.CutLayer`
            of each layer.
        outline_ring: The plate outline ring, shared by every layer.
        kerf_mm: Laser kerf in mm. Defaults to 0.
        arrange: ``"stack"`` or ``"row"``, see :func:`write_dxf_stencils`.
        layer_prefix: Prefix of the layer names. Defaults to ``"STENCIL_"``.
        deterministic: Fixed dates and GUIDs.
    """
    stencils = [stencil_for(h, outline_ring, f"{layer_prefix}{i + 1:02d}") for i, h in enumerate(layers)]
    return write_dxf_stencils(path, stencils, kerf_mm=kerf_mm, arrange=arrange, deterministic=deterministic)
