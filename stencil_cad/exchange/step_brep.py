"""The B-rep of a plate's STEP text, as :func:`~stencil_cad.exchange.step.step_text` writes it, read into arrays.

This reads exactly the entities our writer uses (points, directions, vectors, placements,
lines, circles, planes, cylinders, vertices, edges, loops, bounds, faces, one shell, one
solid and the shape representation that lists it), one entity per line, ``#id=NAME('',...);``;
it is not a general STEP reader, and it raises :class:`StepReadError` on what it does not read
so (an entity of another kind where one of these belongs, one with a label, a real that is not
a finite number). It exists so :mod:`stencil_cad.exchange.step_check` can check the very text a
maker gets, kernel-free; :func:`geometry_of` and :func:`shell_of` gather what its checks read
(every point behind a vertex, curve and surface; a shell's faces down to their edge uses, in loop
order), :func:`shape_items` what the product's shape holds and its unit.

Every step is vectorised over the whole text: a plate of 4,300 holes is 150,000 entities
(7 MB), and a Python loop over them would cost more than the check is meant to save. No
library reads it fast enough: the one pure-Python Part 21 reader on PyPI (steputils 0.1, MIT)
took 3.9 CPU-s to parse the bundled example's biggest plate (4,344 holes) into entities, this
module 0.12 s to read it into arrays; OCCT's reader is the CAD kernel this check avoids. The
lines are found and typed with numpy (the first eight bytes of each name), every ``#``
reference is parsed at once as digits after a ``#`` and given to its line, and the reals come
from one regular expression per entity that holds any (a literal name first, which Python's
``re`` finds quickly).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

__all__ = [
    "KINDS",
    "Brep",
    "Geometry",
    "Shell",
    "StepReadError",
    "geometry_of",
    "kind_of",
    "read_brep",
    "segments",
    "shape_items",
    "shell_of",
]


class StepReadError(ValueError):
    """The text is not a STEP file of the kind :func:`~stencil_cad.exchange.step.step_text` writes."""


#: The entities read, each with the number of ``#`` references it holds (None: a list) and
#: whether it ends with a ``.T.``/``.F.`` flag.
KINDS: dict[str, tuple[int | None, bool]] = {
    "CARTESIAN_POINT": (0, False),
    "DIRECTION": (0, False),
    "VECTOR": (1, False),
    "AXIS2_PLACEMENT_3D": (3, False),
    "LINE": (2, False),
    "CIRCLE": (1, False),
    "PLANE": (1, False),
    "CYLINDRICAL_SURFACE": (1, False),
    "VERTEX_POINT": (1, False),
    "EDGE_CURVE": (3, True),
    "ORIENTED_EDGE": (1, True),
    "EDGE_LOOP": (None, False),
    "FACE_BOUND": (1, True),
    "FACE_OUTER_BOUND": (1, True),
    "ADVANCED_FACE": (None, True),
    "CLOSED_SHELL": (None, False),
    "OPEN_SHELL": (None, False),
    "MANIFOLD_SOLID_BREP": (1, False),
    "ADVANCED_BREP_SHAPE_REPRESENTATION": (None, False),
}

#: The reals of the entities that hold any: the text between the name's ``('',`` and its end.
_REALS = {
    "CARTESIAN_POINT": (re.compile(r"=CARTESIAN_POINT\('',\(([^)]*)\)\);"), 3),
    "DIRECTION": (re.compile(r"=DIRECTION\('',\(([^)]*)\)\);"), 3),
    "VECTOR": (re.compile(r"=VECTOR\('',#\d+,([^)]*)\);"), 1),
    "CIRCLE": (re.compile(r"=CIRCLE\('',#\d+,([^)]*)\);"), 1),
    "CYLINDRICAL_SURFACE": (re.compile(r"=CYLINDRICAL_SURFACE\('',#\d+,([^)]*)\);"), 1),
}

_DIGITS = 10  # most digits of a reference


@dataclass
class Brep:
    """The entities of one STEP text as arrays, by kind.

    Attributes:
        kind: ``(max id + 1,)`` the kind's index in :data:`KINDS` of each entity id, -1 for ids
            not written or of other kinds.
        row: ``(max id + 1,)`` each entity's row among its kind's.
        ids: Per kind, ``(n,)`` entity ids in the order written.
        refs: Per kind of fixed arity, ``(n, k)`` referenced ids.
        lists: Per kind holding a list, ``(ptr, flat)``: the references of row ``i`` are
            ``flat[ptr[i]:ptr[i + 1]]`` (an ADVANCED_FACE's last one is its surface).
        flag: Per flagged kind, ``(n,)`` bool, True for ``.T.``.
        reals: Per kind holding reals, ``(n, k)`` float64 (mm for lengths).
        data: The data section's bytes.
        span: ``(max id + 1, 2)`` each entity's line in ``data``, from after its ``=`` to
            before its ``;`` (``(0, 0)`` for ids not written).
    """

    kind: np.ndarray
    row: np.ndarray
    ids: dict[str, np.ndarray]
    refs: dict[str, np.ndarray]
    lists: dict[str, tuple[np.ndarray, np.ndarray]]
    flag: dict[str, np.ndarray]
    reals: dict[str, np.ndarray]
    data: np.ndarray
    span: np.ndarray

    def line(self, i: int) -> str:
        """Entity ``#i`` as written, without its ``#i=`` and ``;`` (empty when not written)."""
        if not 0 <= i < len(self.span):
            return ""
        lo, hi = self.span[i]
        return self.data[lo:hi].tobytes().decode("ascii")

    def count(self, kind: str) -> int:
        """How many entities of ``kind`` the text holds."""
        return len(self.ids[kind])

    def rows(self, refs: np.ndarray, kind: str, where: str) -> np.ndarray:
        """The rows of ``refs`` among the entities of ``kind``.

        Raises:
            StepReadError: A reference names no entity of that kind (``where`` says whose).
        """
        refs = np.asarray(refs, dtype=np.int64)
        inside = (refs >= 0) & (refs < len(self.kind))
        code = list(KINDS).index(kind)
        ok = inside & (self.kind[np.where(inside, refs, 0)] == code)
        if not ok.all():
            bad = int(refs[np.flatnonzero(~ok)[0]])
            raise StepReadError(f"{where} #{bad} is not a {kind}")
        return self.row[refs]


def _lines(b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The data section's bytes, each line's start and end (exclusive, before the newline)."""
    nl = np.flatnonzero(b == 10)
    starts = np.concatenate([[0], nl + 1])
    ends = np.concatenate([nl, [len(b)]])
    return b, starts, ends


def _hash_numbers(b: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ``#`` of the section: the number after it, and each line's first ``#`` index.

    Raises:
        StepReadError: A ``#`` with no number after it, or a line that does not start with one.
    """
    pos = np.flatnonzero(b == 35)
    last = len(b) - 1  # a reference at the very end reads its last byte again, not past it
    value = np.zeros(len(pos), dtype=np.int64)
    ndig = np.zeros(len(pos), dtype=np.int64)
    alive = np.ones(len(pos), dtype=bool)
    # Digit by digit over every reference at once; references are short, so this stops early.
    for k in range(_DIGITS + 1):
        d = b[np.minimum(pos + 1 + k, last)] - np.uint8(48)  # a byte that is not a digit wraps past 9
        d[pos + 1 + k > last] = 10
        alive &= d < 10
        if not alive.any():
            break
        value = np.where(alive, value * 10 + d, value)
        ndig += alive
    if (ndig == 0).any() or (ndig > _DIGITS).any():
        at = int(pos[np.flatnonzero((ndig == 0) | (ndig > _DIGITS))[0]])
        raise StepReadError(f"a '#' at byte {at} of the data section is not followed by a number")
    first = np.searchsorted(pos, starts)
    if not (first < len(pos)).all() or not (pos[np.minimum(first, len(pos) - 1)] == starts).all():
        raise StepReadError("every entity line of the data section must start with '#id='")
    return value, first


def _kinds(b: np.ndarray, eq: np.ndarray) -> np.ndarray:
    """Each line's kind (index in :data:`KINDS`, -1 for others), from the name after its ``=``."""
    last = len(b) - 1
    head = (
        np.ascontiguousarray(b[np.minimum(eq[:, None] + 1 + np.arange(8), last)]).view(np.uint64).reshape(-1)
    )
    code = np.full(len(eq), -1, dtype=np.int64)
    for i, kind in enumerate(KINDS):
        key = np.frombuffer((kind + "('',")[:8].encode("ascii"), dtype=np.uint64)[0]
        lines = np.flatnonzero(head == key)
        # The first eight bytes find the candidates; the whole name and its empty label decide
        # (an entity with a label is of no kind read here: a '#' in a label is not a reference).
        name = np.frombuffer((kind + "('',").encode("ascii"), dtype=np.uint8)
        same = (b[np.minimum(eq[lines, None] + 1 + np.arange(len(name)), last)] == name).all(axis=1)
        code[lines[same]] = i
    return code


def _equals(b: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Each line's ``=`` (the one after its id).

    Raises:
        StepReadError: A line with no ``=``, or more than one.
    """
    eq = np.flatnonzero(b == 61)
    line = np.searchsorted(starts, eq, side="right") - 1
    if len(eq) != len(starts) or not (line == np.arange(len(starts))).all() or (eq >= ends).any():
        raise StepReadError("every line of the data section must be one entity '#id=...;'")
    return eq


def _flags(b: np.ndarray, ends: np.ndarray, where: str) -> np.ndarray:
    """The ``.T.``/``.F.`` before each line's ``);``.

    Raises:
        StepReadError: A line that does not end so.
    """
    tail = b[ends[:, None] + np.arange(-5, 0)]
    fixed = np.frombuffer(b".T.);", dtype=np.uint8)
    ok = (tail[:, [0, 2, 3, 4]] == fixed[[0, 2, 3, 4]]).all(axis=1) & np.isin(tail[:, 1], (84, 70))
    if not ok.all():
        raise StepReadError(f"a {where} does not end with .T. or .F.")
    return tail[:, 1] == 84


def _fixed_point(joined: str) -> np.ndarray | None:
    """Comma-separated reals in fixed notation (``-12.3456789012``, ``0.``) as float64, or None.

    Three times faster than ``float`` on each (numpy parses integers quickly): each real is its
    digits as an integer over a power of ten, one correctly rounded division of two exact
    doubles, so the value is the one ``float`` gives. None when a real is not of that form
    (an exponent, more than 15 digits): the caller parses those one by one.
    """
    raw = np.frombuffer(joined.encode("ascii"), dtype=np.uint8)
    dots = np.flatnonzero(raw == 46)
    ends = np.concatenate([np.flatnonzero(raw == 44), [len(raw)]])
    if len(dots) != len(ends) or len(raw) == 0 or np.isin(raw, (69, 101)).any():
        return None
    starts = np.concatenate([[0], ends[:-1] + 1])
    places = ends - dots - 1
    if ((dots < starts) | (places < 0)).any() or (ends - starts > 16).any():
        return None
    digits = np.fromstring(joined.replace(".", ""), dtype=np.int64, sep=",")
    if len(digits) != len(ends):
        return None
    value = digits / 10.0**places
    # "-0." is an integer 0 here; its sign is kept for the record.
    negative = raw[starts] == 45
    return np.where(negative & (digits == 0), -0.0, value)


def _lines_text(b: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> str:
    """The given lines alone, each with its newline: a short text for a regular expression to scan."""
    n = ends - starts + 1
    first = np.concatenate([[0], np.cumsum(n)[:-1]])
    take = np.minimum(np.repeat(starts - first, n) + np.arange(int(n.sum())), len(b) - 1)
    return b[take].tobytes().decode("ascii")


def _reals(text: str, kind: str, n: int) -> np.ndarray:
    """The reals of every entity of ``kind``, in the order written.

    Raises:
        StepReadError: An entity of that kind whose reals cannot be read.
    """
    pattern, width = _REALS[kind]
    found = pattern.findall(text)
    if len(found) != n:
        raise StepReadError(f"{n - len(found)} {kind} entities cannot be read")
    if n == 0:
        return np.zeros((0, width))
    # Each entity's own count of values, not only the total: (1, 2) and (3, 4, 5, 6) are not two points.
    joined = ";".join(found)
    raw = np.frombuffer(joined.encode("ascii"), dtype=np.uint8)
    commas = np.concatenate([[0], np.cumsum(raw == 44)])
    ends = np.concatenate([np.flatnonzero(raw == 59), [len(raw)]])
    starts = np.concatenate([[0], ends[:-1] + 1])
    if len(ends) != n or (commas[ends] - commas[starts] != width - 1).any():
        raise StepReadError(f"a {kind} holds the wrong number of values (expected {width})")
    joined = joined.replace(";", ",")
    values = _fixed_point(joined)
    if values is None:
        try:
            values = np.fromiter(map(float, joined.split(",")), dtype=np.float64)
        except ValueError:
            raise StepReadError(f"a {kind} holds a value that is not a number") from None
    if len(values) != n * width:
        raise StepReadError(f"a {kind} holds the wrong number of values (expected {width})")
    if not np.isfinite(values).all():
        # float() reads "nan" and "inf", which no check below would see (every comparison is False).
        raise StepReadError(f"a {kind} holds a value that is not a finite number")
    return values.reshape(n, width)


def _data(text: str) -> np.ndarray:
    """The data section's bytes (a view of the encoded text, not a copy).

    Raises:
        StepReadError: No ``DATA;`` section, or text that is not ASCII.
    """
    try:
        raw = text.encode("ascii")
    except UnicodeEncodeError:
        raise StepReadError("the text is not ASCII") from None
    begin, end = raw.find(b"\nDATA;\n"), raw.rfind(b"\nENDSEC;\nEND-ISO-10303-21;")
    if not raw.startswith(b"ISO-10303-21;") or begin < 0 or end < begin:
        raise StepReadError("not a STEP file: no ISO-10303-21 header with a DATA section")
    return np.frombuffer(raw, dtype=np.uint8, count=end - begin - 7, offset=begin + 7)


def read_brep(text: str) -> Brep:
    """Read the B-rep entities of a STEP text written by :func:`~stencil_cad.exchange.step.step_text`.

    Args:
        text: The file's text.

    Returns:
        The entities as arrays.

    Raises:
        StepReadError: The text is not of that form (a line that is not one entity, an id used
            twice, an entity of a known kind that cannot be read).
    """
    b, starts, ends = _lines(_data(text))
    eq = _equals(b, starts, ends)
    value, first = _hash_numbers(b, starts)
    nref = np.diff(np.concatenate([first, [len(value)]])) - 1
    ids = value[first]
    # The writer numbers its entities from 1 without gaps; ids far past their count would only
    # make the id-indexed arrays below huge.
    if int(ids.max(initial=0)) > 2 * len(ids) + 64:
        raise StepReadError(f"entity ids run to #{int(ids.max())} for {len(ids)} entities")
    if len(ids) and np.bincount(ids).max() > 1:
        raise StepReadError("an entity id is used twice")
    code = _kinds(b, eq)
    kind = np.full(int(ids.max(initial=0)) + 1, -1, dtype=np.int64)
    row = np.full(len(kind), -1, dtype=np.int64)
    span = np.zeros((len(kind), 2), dtype=np.int64)
    span[ids, 0], span[ids, 1] = eq + 1, ends - 1
    out = Brep(kind, row, {}, {}, {}, {}, {}, b, span)
    for i, (name, (arity, flagged)) in enumerate(KINDS.items()):
        lines = np.flatnonzero(code == i)
        out.ids[name] = ids[lines]
        kind[ids[lines]] = i
        row[ids[lines]] = np.arange(len(lines))
        if arity is None:
            counts = nref[lines]
            ptr = np.concatenate([[0], np.cumsum(counts)])
            take = np.repeat(first[lines] + 1 - ptr[:-1], counts) + np.arange(ptr[-1])
            out.lists[name] = (ptr, value[take])
        else:
            if (nref[lines] != arity).any():
                raise StepReadError(f"a {name} holds other than {arity} references")
            out.refs[name] = value[first[lines][:, None] + 1 + np.arange(arity)]
        if flagged:
            out.flag[name] = _flags(b, ends[lines], name)
        if name in _REALS:
            out.reals[name] = _reals(_lines_text(b, starts[lines], ends[lines]), name, len(lines))
    return out


_SHAPE_DEFINITION = re.compile(rb"=SHAPE_DEFINITION_REPRESENTATION\(#\d+,#(\d+)\);")
_UNITS = re.compile(r"GLOBAL_UNIT_ASSIGNED_CONTEXT\(\(([^)]*)\)\)")


def shape_items(br: Brep) -> np.ndarray:
    """The ids of the items of the product's shape, whose lengths are in millimetres.

    An importer finds a file's solids through its SHAPE_DEFINITION_REPRESENTATION, which names the
    one ADVANCED_BREP_SHAPE_REPRESENTATION; that lists the items (OCCT's reader transfers
    nothing else) and the context whose units every length is read in.

    Raises:
        StepReadError: No such pair, more than one, or lengths not in millimetres.
    """
    reps = br.ids["ADVANCED_BREP_SHAPE_REPRESENTATION"]
    if len(reps) != 1:
        raise StepReadError(f"expected one ADVANCED_BREP_SHAPE_REPRESENTATION, the file has {len(reps)}")
    named = [int(m.group(1)) for m in _SHAPE_DEFINITION.finditer(br.data.data)]
    if named.count(int(reps[0])) != 1:
        raise StepReadError(f"no one SHAPE_DEFINITION_REPRESENTATION names the shape #{int(reps[0])}")
    ptr, flat = br.lists["ADVANCED_BREP_SHAPE_REPRESENTATION"]
    refs = flat[ptr[0] : ptr[1]]
    units = _UNITS.search(br.line(int(refs[-1]))) if len(refs) > 1 else None
    if units is None:
        raise StepReadError(f"the shape #{int(reps[0])} has no context with units")
    lengths = [br.line(int(u)) for u in re.findall(r"#(\d+)", units.group(1))]
    lengths = [u for u in lengths if "LENGTH_UNIT()" in u]
    if len(lengths) != 1 or "SI_UNIT(.MILLI.,.METRE.)" not in lengths[0]:
        raise StepReadError("the shape's lengths are not in millimetres")
    return refs[:-1]


def segments(ptr: np.ndarray, flat: np.ndarray, rows: np.ndarray, drop_last: bool = False):
    """The list entries of ``rows``: ``(owner, values)``, the owner an index into ``rows``."""
    lo = ptr[rows]
    n = ptr[rows + 1] - lo - (1 if drop_last else 0)
    owner = np.repeat(np.arange(len(rows)), n)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    return owner, flat[np.repeat(lo - start, n) + np.arange(int(n.sum()))]


def kind_of(br: Brep, refs: np.ndarray, kinds: tuple[str, ...], where: str) -> tuple[np.ndarray, np.ndarray]:
    """Each reference's kind (index in ``kinds``) and row.

    Raises:
        StepReadError: A reference to an entity of none of ``kinds``.
    """
    codes = np.array([list(KINDS).index(k) for k in kinds])
    inside = (refs >= 0) & (refs < len(br.kind))
    code = np.where(inside, br.kind[np.where(inside, refs, 0)], -1)
    which = np.argmax(code[:, None] == codes[None, :], axis=1)
    ok = code == codes[which]
    if not ok.all():
        bad = int(refs[np.flatnonzero(~ok)[0]])
        raise StepReadError(
            f"{where} #{bad} is not a {' or '.join(kinds)} (this check reads what step_text writes)"
        )
    return which, br.row[refs]


@dataclass
class Shell:
    """The solid's faces, bounds and edge uses, as arrays (uses in loop order)."""

    faces: np.ndarray  # ADVANCED_FACE rows
    surface_kind: np.ndarray  # 0 plane, 1 cylinder, per face
    surface: np.ndarray  # its row among planes or cylinders
    face_of_bound: np.ndarray
    bound_fwd: np.ndarray
    bound_outer: np.ndarray
    loop_id: np.ndarray  # EDGE_LOOP id per bound
    loop_of_use: np.ndarray
    edge: np.ndarray  # EDGE_CURVE row per use
    fwd: np.ndarray  # ORIENTED_EDGE's sense per use
    start: np.ndarray  # VERTEX_POINT row where the use starts
    end: np.ndarray
    nxt: np.ndarray  # the next use in the same loop


@dataclass
class Geometry:
    """Every point the edges and surfaces need, by row of their kind (mm, unit directions)."""

    vertex: np.ndarray  # (n, 3) per VERTEX_POINT
    edge_v1: np.ndarray  # VERTEX_POINT rows per EDGE_CURVE
    edge_v2: np.ndarray
    curve_kind: np.ndarray  # per EDGE_CURVE: 0 line, 1 circle
    curve: np.ndarray  # its row among lines or circles
    edge_fwd: np.ndarray  # EDGE_CURVE's sense
    line_point: np.ndarray
    line_dir: np.ndarray
    circle_centre: np.ndarray
    circle_axis: np.ndarray
    circle_r: np.ndarray
    plane_point: np.ndarray
    plane_normal: np.ndarray
    cyl_centre: np.ndarray
    cyl_axis: np.ndarray
    cyl_r: np.ndarray


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def geometry_of(br: Brep) -> Geometry:
    """The points, directions and radii behind every vertex, curve and surface."""
    pts = br.reals["CARTESIAN_POINT"]
    dirs = br.reals["DIRECTION"]

    def point(refs: np.ndarray, where: str) -> np.ndarray:
        return pts[br.rows(refs, "CARTESIAN_POINT", where)]

    def axis(refs: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
        ax = br.refs["AXIS2_PLACEMENT_3D"][br.rows(refs, "AXIS2_PLACEMENT_3D", where)]
        return point(ax[:, 0], "a placement's origin"), _unit(
            dirs[br.rows(ax[:, 1], "DIRECTION", "a placement's axis")]
        )

    vec = br.refs["VECTOR"][:, 0]
    vec_dir = _unit(dirs[br.rows(vec, "DIRECTION", "a vector's direction")])
    line = br.refs["LINE"]
    kind, curve = kind_of(br, br.refs["EDGE_CURVE"][:, 2], ("LINE", "CIRCLE"), "an edge's curve")
    cc, ca = axis(br.refs["CIRCLE"][:, 0], "a circle's placement")
    pc, pn = axis(br.refs["PLANE"][:, 0], "a plane's placement")
    yc, ya = axis(br.refs["CYLINDRICAL_SURFACE"][:, 0], "a cylinder's placement")
    ends = br.refs["EDGE_CURVE"]
    return Geometry(
        vertex=point(br.refs["VERTEX_POINT"][:, 0], "a vertex's point"),
        edge_v1=br.rows(ends[:, 0], "VERTEX_POINT", "an edge's vertex"),
        edge_v2=br.rows(ends[:, 1], "VERTEX_POINT", "an edge's vertex"),
        curve_kind=kind, curve=curve, edge_fwd=br.flag["EDGE_CURVE"],
        line_point=point(line[:, 0], "a line's point"),
        line_dir=vec_dir[br.rows(line[:, 1], "VECTOR", "a line's vector")],
        circle_centre=cc, circle_axis=ca, circle_r=br.reals["CIRCLE"][:, 0],
        plane_point=pc, plane_normal=pn,
        cyl_centre=yc, cyl_axis=ya, cyl_r=br.reals["CYLINDRICAL_SURFACE"][:, 0],
    )  # fmt: skip


def shell_of(br: Brep, g: Geometry, faces: np.ndarray) -> Shell:
    """The faces (ADVANCED_FACE rows) down to their edge uses.

    Raises:
        StepReadError: A reference to an entity of a kind the writer does not put there.
    """
    ptr, flat = br.lists["ADVANCED_FACE"]
    surface_kind, surface = kind_of(
        br, flat[ptr[faces + 1] - 1], ("PLANE", "CYLINDRICAL_SURFACE"), "a face's surface"
    )
    face_of_bound, brefs = segments(ptr, flat, faces, drop_last=True)
    outer, brow = kind_of(br, brefs, ("FACE_BOUND", "FACE_OUTER_BOUND"), "a face's bound")
    bound_outer = outer == 1
    loop_ref = np.zeros(len(brefs), dtype=np.int64)
    bound_fwd = np.zeros(len(brefs), dtype=bool)
    for k, kind in enumerate(("FACE_BOUND", "FACE_OUTER_BOUND")):
        mine = outer == k
        loop_ref[mine] = br.refs[kind][brow[mine], 0]
        bound_fwd[mine] = br.flag[kind][brow[mine]]
    loops = br.rows(loop_ref, "EDGE_LOOP", "a bound's loop")
    loop_of_use, oe_ref = segments(*br.lists["EDGE_LOOP"], loops)
    oe = br.rows(oe_ref, "ORIENTED_EDGE", "a loop's oriented edge")
    edge = br.rows(br.refs["ORIENTED_EDGE"][oe, 0], "EDGE_CURVE", "an oriented edge's edge")
    fwd = br.flag["ORIENTED_EDGE"][oe]
    v1, v2 = g.edge_v1[edge], g.edge_v2[edge]
    first = np.searchsorted(loop_of_use, np.arange(len(loops)))
    nxt = np.arange(len(oe)) + 1
    last = np.concatenate([first[1:], [len(oe)]]) - 1
    nxt[last] = first
    return Shell(
        faces, surface_kind, surface, face_of_bound, bound_fwd, bound_outer, loop_ref,
        loop_of_use, edge, fwd, np.where(fwd, v1, v2), np.where(fwd, v2, v1), nxt,
    )  # fmt: skip
