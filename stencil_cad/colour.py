"""Colour values as the config writes them (``"#rrggbb"`` or ``[r, g, b]``) and as arrays."""

from __future__ import annotations

import re

import numpy as np

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")


def parse_colour(value: object) -> str:
    """Normalise one colour to lower-case ``"#rrggbb"``.

    Args:
        value: ``"#1a2b3c"`` / ``"1a2b3c"`` or a sequence of three integers 0-255.

    Returns:
        The colour as ``"#rrggbb"``.

    Raises:
        ValueError: The value is neither a 6-digit hex string nor three
            integers in 0-255.
    """
    if isinstance(value, str):
        m = _HEX.match(value.strip())
        if not m:
            raise ValueError(f"colour {value!r} is not a 6-digit hex string like '#1a2b3c'")
        return "#" + m.group(1).lower()
    if isinstance(value, (list, tuple)) and len(value) == 3:
        out = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or int(v) != v:
                raise ValueError(f"colour {list(value)!r}: components must be integers 0-255")
            if not 0 <= v <= 255:
                raise ValueError(f"colour {list(value)!r}: component {v} is outside 0-255")
            out.append(int(v))
        return "#{:02x}{:02x}{:02x}".format(*out)
    raise ValueError(f"colour {value!r} must be a hex string '#rrggbb' or a list [r, g, b] of integers 0-255")


def colour_to_rgb(value: object) -> tuple[float, float, float]:
    """A colour (hex or ``[r, g, b]`` 0-255) as an RGB triple of floats in [0, 1]."""
    h = parse_colour(value)[1:]
    return tuple(int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]


def to_hex(rgb) -> str:
    """An RGB triple of floats in [0, 1] (clipped) as ``"#rrggbb"``."""
    return "#{:02x}{:02x}{:02x}".format(
        *np.rint(np.clip(np.asarray(rgb, dtype=float), 0.0, 1.0) * 255.0).astype(int)
    )
