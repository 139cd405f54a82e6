"""Config key `bed`: the print bed or laser sheet every plate, wall and sheet must fit.

Preset sizes (mm, X × Y), from the makers' specification pages (checked 2026-11):
Prusa MK4/MK4S 250 × 210, CORE One 250 × 220, XL 360 × 360, MINI+ 180 × 180,
SL1S (resin) 127 × 80; Bambu Lab X1C, P1S and A1 256 × 256, A1 mini 180 × 180;
Creality Ender-3 220 × 220; lasers: xTool S1 498 × 319, Glowforge about 495 × 279.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Bed presets: name → (x_mm, y_mm).
BED_PRESETS: dict[str, tuple[float, float]] = {
    "prusa_mk4": (250.0, 210.0),
    "prusa_mk4s": (250.0, 210.0),
    "prusa_core_one": (250.0, 220.0),
    "prusa_xl": (360.0, 360.0),
    "prusa_mini": (180.0, 180.0),
    "prusa_sl1s": (127.0, 80.0),
    "bambu_x1c": (256.0, 256.0),
    "bambu_p1s": (256.0, 256.0),
    "bambu_a1": (256.0, 256.0),
    "bambu_a1_mini": (180.0, 180.0),
    "ender_3": (220.0, 220.0),
    "xtool_s1": (498.0, 319.0),
    "glowforge": (495.0, 279.0),
}

#: Smallest and largest bed side accepted, in mm.
BED_RANGE_MM = (20.0, 5000.0)

BED_DESCRIPTION = (
    "Print bed or laser bed that every plate, wall and laser sheet must fit (either way round), "
    "checked before any CAD. A preset name (" + ", ".join(BED_PRESETS) + ") or [x_mm, y_mm], each "
    f"in [{BED_RANGE_MM[0]:g}, {BED_RANGE_MM[1]:g}]; null: no bed, one plate per layer whatever its size. "
    "A picture whose plates do not fit becomes a mural of tiles (A1, A2, …, B1, …) that do."
)


@dataclass(frozen=True)
class Bed:
    """A bed size.

    Attributes:
        name: Preset name, or ``"x × y mm"`` for a custom size.
        x_mm: Bed width in mm.
        y_mm: Bed depth in mm.
    """

    name: str
    x_mm: float
    y_mm: float

    def fits(self, w_mm: float, h_mm: float, tol_mm: float = 1e-6) -> bool:
        """True when a ``w × h`` mm part lies on the bed, either way round."""
        a, b = sorted((w_mm, h_mm))
        c, d = sorted((self.x_mm, self.y_mm))
        return a <= c + tol_mm and b <= d + tol_mm

    def __str__(self) -> str:
        size = f"{self.x_mm:g} × {self.y_mm:g} mm"
        return size if self.name == size else f"{self.name} ({size})"


def parse_bed(value) -> tuple[float, float] | str | None:
    """Validate a config value for ``bed``; returns it normalised (lower-case name or a pair).

    Raises:
        ValueError: An unknown preset or a bad size, naming the choices or the range.
    """
    if value is None:
        return None
    if isinstance(value, str):
        key = value.strip().lower().replace("-", "_").replace(" ", "_")
        if key not in BED_PRESETS:
            raise ValueError(
                f"unknown bed preset {value!r}; choose one of {', '.join(BED_PRESETS)} or give [x_mm, y_mm]"
            )
        return key
    if isinstance(value, (list, tuple)) and len(value) == 2:
        out = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"bed size must be two numbers [x_mm, y_mm], got {list(value)}")
            if not BED_RANGE_MM[0] <= float(v) <= BED_RANGE_MM[1]:
                raise ValueError(
                    f"each bed side must be in [{BED_RANGE_MM[0]:g}, {BED_RANGE_MM[1]:g}] mm, got {list(value)}"
                )
            out.append(float(v))
        return (out[0], out[1])
    raise ValueError(f"bed must be a preset name or [x_mm, y_mm], got {value!r}")


def resolve_bed(value) -> Bed | None:
    """The :class:`Bed` of a validated ``bed`` value (None for no bed)."""
    value = parse_bed(value)
    if value is None:
        return None
    if isinstance(value, str):
        x, y = BED_PRESETS[value]
        return Bed(value, x, y)
    x, y = value
    return Bed(f"{x:g} × {y:g} mm", x, y)


def parse_bed_arg(text: str) -> tuple[float, float] | str:
    """A ``--bed`` command-line value: a preset name or ``XxY`` (e.g. ``250x210``)."""
    t = text.strip().lower().replace("×", "x")
    if "x" in t and all(p.replace(".", "", 1).isdigit() for p in t.split("x", 1)):
        a, b = t.split("x", 1)
        return (float(a), float(b))
    return t
