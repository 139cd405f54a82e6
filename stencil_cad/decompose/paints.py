"""The maker's spray cans: can lists (CSV), snapping solved paints to a catalogue, paint to buy.

A can list is a CSV file with a header row and the columns ``name``, ``code`` and ``hex``
(``#rrggbb``); other columns are ignored, blank lines and lines starting with ``#`` are
skipped. It can stand wherever a palette goes (``decompose.palette``, ``hard.palette``),
and as ``paints.catalogue`` it is the list that an ``auto`` palette is snapped to.

Colour distances are CIEDE2000 in CIELAB under D65 (scikit-image), as everywhere else in
the project.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..colour import colour_to_rgb, parse_colour, to_hex
from ..errors import ConfigError
from ..files import read_text

__all__ = ["Can", "load_cans", "nearest_cans", "paint_estimate", "parse_cans"]

REQUIRED = ("name", "code", "hex")


@dataclass(frozen=True)
class Can:
    """One spray can.

    Attributes:
        name: The colour's name as the maker knows it (e.g. "Signal red").
        code: The maker's or shop's code for it (may be empty).
        hex: Its colour, ``#rrggbb``.
    """

    name: str
    code: str
    hex: str

    @property
    def rgb(self) -> tuple[float, float, float]:
        """The colour as RGB in [0, 1]."""
        return colour_to_rgb(self.hex)

    @property
    def label(self) -> str:
        """Name and code, as printed on the sheet."""
        return f"{self.name} ({self.code})" if self.code else self.name


def parse_cans(text: str, source: str = "can list") -> list[Can]:
    """Read a can list from CSV text.

    Args:
        text: CSV with a header row naming at least ``name``, ``code`` and ``hex``.
        source: What to call the text in messages (the file name).

    Returns:
        The cans in file order.

    Raises:
        ValueError: A missing column, a bad hex value, an empty list or a repeated colour,
            naming the line.
    """
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{source}: no cans (expected a header 'name,code,hex' and one can per line)")
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    fields = [f.strip().lower() for f in (reader.fieldnames or [])]
    missing = [c for c in REQUIRED if c not in fields]
    if missing:
        raise ValueError(
            f"{source}: missing column(s) {', '.join(missing)} in the header {','.join(fields) or '(none)'} "
            "(expected 'name,code,hex')"
        )
    reader.fieldnames = fields
    cans: list[Can] = []
    seen: dict[str, int] = {}
    for n, row in enumerate(reader, start=2):
        name = (row.get("name") or "").strip()
        if not name:
            raise ValueError(f"{source}: line {n}: the can has no name")
        try:
            hx = parse_colour((row.get("hex") or "").strip())
        except ValueError as exc:
            raise ValueError(f"{source}: line {n}: hex: {exc}") from None
        if hx in seen:
            raise ValueError(f"{source}: line {n}: colour {hx} is already can {seen[hx]} of the list")
        seen[hx] = len(cans) + 1
        cans.append(Can(name=name, code=(row.get("code") or "").strip(), hex=hx))
    if not cans:
        raise ValueError(f"{source}: no cans (expected one can per line after the header)")
    return cans


def load_cans(path: Path | str) -> list[Can]:
    """Read a can list CSV file.

    Raises:
        ConfigError: The file is missing, not a regular file or too large.
        ValueError: Its content is bad (see :func:`parse_cans`).
    """
    p = Path(path)
    text = read_text(p, "can list", error=ConfigError, fix="a CSV text file with the columns name,code,hex")
    return parse_cans(text.removeprefix("\ufeff"), str(p))


def _lab(rgb: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2lab

    return rgb2lab(np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0).reshape(-1, 1, 3)).reshape(-1, 3)


def nearest_cans(colours: np.ndarray, cans: list[Can]) -> tuple[np.ndarray, np.ndarray]:
    """The nearest can (CIEDE2000) for each colour.

    Args:
        colours: ``(N, 3)`` RGB in [0, 1].
        cans: The catalogue.

    Returns:
        ``(index, delta_e)``: ``(N,)`` int index into ``cans`` and ``(N,)`` float CIEDE2000 distance.
    """
    from skimage.color import deltaE_ciede2000

    a = _lab(np.asarray(colours).reshape(-1, 3))
    b = _lab(np.array([c.rgb for c in cans]))
    de = deltaE_ciede2000(a[:, None, :], b[None, :, :])
    idx = np.argmin(de, axis=1)
    return idx, de[np.arange(len(a)), idx]


def names_by_hex(cans: list[Can]) -> dict[str, str]:
    """``{hex: label}`` for looking up the can of a paint."""
    return {c.hex: c.label for c in cans}


def colour_names(hexes: list[str]) -> dict[str, str]:
    """Name colours after the nearest entry (CIEDE2000) of the shipped list ``data/colour_names.csv``.

    Args:
        hexes: Colours as ``#rrggbb``.

    Returns:
        ``{hex: "~Name (ΔE d)"}``: the ``~`` says the name is the nearest everyday colour, not a can.
    """
    from importlib import resources

    if not hexes:
        return {}
    text = (resources.files("stencil_cad") / "data" / "colour_names.csv").read_text(encoding="utf-8")
    names = parse_cans(text, "colour_names.csv")
    rgb = np.array([[int(h[i : i + 2], 16) / 255.0 for i in (1, 3, 5)] for h in hexes])
    idx, de = nearest_cans(rgb, names)
    return {h: f"~{names[int(i)].name} (ΔE {float(d):.1f})" for h, i, d in zip(hexes, idx, de, strict=True)}


def paint_estimate(
    area_mm2: float, mean_opacity: float, coverage_m2_per_can: float = 1.5, can_ml: float = 400.0
) -> dict:
    """Paint to buy for one layer: sprayed area × mean opacity at the can's coverage.

    The sprayed area is the picture area the maker sweeps; the mean opacity (over that area)
    says how much of it ends up covered, one full coat counting 1. Paint that lands on the
    plate instead of the wall is not counted.

    Args:
        area_mm2: The sprayed area in mm².
        mean_opacity: Mean opacity of the layer over that area, in [0, 1].
        coverage_m2_per_can: Area one can covers with one opaque coat, in m². Defaults to 1.5 m².
        can_ml: Contents of one can in ml. Defaults to 400 ml.

    Returns:
        ``covered_m2`` (area × opacity), ``ml``, ``cans`` (fractional) and ``cans_to_buy``
        (whole cans, at least 1).
    """
    if not (coverage_m2_per_can > 0 and can_ml > 0):
        raise ValueError(f"coverage and can size must be > 0, got {coverage_m2_per_can} m², {can_ml} ml")
    covered = max(float(area_mm2), 0.0) * float(np.clip(mean_opacity, 0.0, 1.0)) * 1e-6
    cans = covered / coverage_m2_per_can
    return {
        "covered_m2": covered,
        "ml": cans * can_ml,
        "cans": cans,
        "cans_to_buy": max(1, math.ceil(cans - 1e-9)),
    }


def to_hex_list(cans: list[Can]) -> tuple[str, ...]:
    """The cans' colours, in list order, as a palette."""
    return tuple(c.hex for c in cans)


def snap_report(colours: np.ndarray, cans: list[Can]) -> list[dict]:
    """For each solved paint: its nearest can and the CIEDE2000 cost of using the can instead."""
    idx, de = nearest_cans(colours, cans)
    return [
        {"solved": to_hex(c), "can": cans[int(i)].hex, "name": cans[int(i)].label, "delta_e2000": float(d)}
        for c, i, d in zip(np.asarray(colours).reshape(-1, 3), idx, de, strict=True)
    ]
