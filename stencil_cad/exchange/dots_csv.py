"""Dot sets as CSV text: ``x_mm,y_mm,r_mm``, one hole per line (picture frame, mm, y up)."""

from __future__ import annotations

import csv
import io
import math

import numpy as np

from ..config.stipple import HOLE_FLOOR_MM
from ..model import DotSet

__all__ = ["CSV_HEADER", "DotFileError", "dots_from_csv", "dots_to_csv"]

CSV_HEADER = ("x_mm", "y_mm", "r_mm")


class DotFileError(ValueError):
    """A dot file cannot be read (header, column count, a value, a radius below the floor)."""


def dots_to_csv(dotset: DotSet) -> str:
    """Format a dot set as CSV text with header ``x_mm,y_mm,r_mm`` (4 decimals, mm).

    Args:
        dotset: The holes.

    Returns:
        The CSV text, one hole per line, Unix line ends.
    """
    buf = io.StringIO()
    buf.write(",".join(CSV_HEADER) + "\n")
    if len(dotset):
        data = np.column_stack([np.asarray(dotset.xy_mm).reshape(-1, 2), np.asarray(dotset.r_mm)])
        np.savetxt(buf, data, fmt="%.4f", delimiter=",")
    return buf.getvalue()


def dots_from_csv(text: str) -> DotSet:
    """Parse CSV text written by :func:`dots_to_csv` (or by hand).

    Args:
        text: CSV with header ``x_mm,y_mm,r_mm`` then one hole per line. Blank
            lines are ignored.

    Returns:
        The dot set (``report`` holds ``{"source": "csv"}``).

    Raises:
        DotFileError: on a wrong header, a wrong column count, a value that is
            not a finite number, or a radius below 0.5 mm; the message names
            the line.
    """
    rows = [(n, row) for n, row in enumerate(csv.reader(io.StringIO(text)), start=1) if row and any(row)]
    if not rows:
        raise DotFileError("dot CSV is empty: expected the header 'x_mm,y_mm,r_mm'")
    n0, header = rows[0]
    if tuple(h.strip().lstrip("\ufeff") for h in header) != CSV_HEADER:
        raise DotFileError(f"dot CSV line {n0}: header must be 'x_mm,y_mm,r_mm', got {','.join(header)!r}")
    values = np.empty((len(rows) - 1, 3))
    for k, (n, row) in enumerate(rows[1:]):
        if len(row) != 3:
            raise DotFileError(f"dot CSV line {n}: expected 3 values (x_mm, y_mm, r_mm), got {len(row)}")
        for c, cell in enumerate(row):
            try:
                v = float(cell)
            except ValueError:
                raise DotFileError(
                    f"dot CSV line {n}: {CSV_HEADER[c]} is not a number: {cell.strip()!r}"
                ) from None
            if not math.isfinite(v):
                raise DotFileError(f"dot CSV line {n}: {CSV_HEADER[c]} is not finite: {cell.strip()!r}")
            values[k, c] = v
        if values[k, 2] < HOLE_FLOOR_MM:
            raise DotFileError(f"dot CSV line {n}: r_mm must be ≥ {HOLE_FLOOR_MM} mm, got {values[k, 2]:g}")
    return DotSet(xy_mm=values[:, :2].copy(), r_mm=values[:, 2].copy(), report={"source": "csv"})


def windows_to_json(windows) -> str:
    """A hybrid plate's windows as JSON text: ``{"windows": [[[x, y], ...], ...]}`` in picture mm.

    Args:
        windows: Each ``(outer, inner rings)``; a window's islands are bridged, so only the outer
            ring is written.
    """
    import json

    rings = [[[round(float(x), 6), round(float(y), 6)] for x, y in np.asarray(o)] for o, _ in windows]
    return json.dumps({"windows": rings}, separators=(",", ":"))


def windows_from_json(text: str) -> tuple:
    """The windows :func:`windows_to_json` wrote, each ``(outer, ())``.

    Raises:
        DotFileError: Not that JSON, or a ring of fewer than 3 finite points.
    """
    import json

    try:
        rings = json.loads(text)["windows"]
        out = tuple((np.asarray(r, dtype=np.float64).reshape(-1, 2), ()) for r in rings)
    except (ValueError, KeyError, TypeError) as exc:
        raise DotFileError(f"windows file: expected {{'windows': [[[x, y], ...], ...]}} ({exc})") from None
    for k, (ring, _) in enumerate(out):
        if len(ring) < 3 or not np.isfinite(ring).all():
            raise DotFileError(f"windows file: window {k} needs at least 3 finite points")
    return out
