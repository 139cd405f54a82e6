"""Spray profiles per paint: the keys of ``spray.profile`` when it maps layers to files.

``spray.profile`` is one file (every layer sprays with its constants) or a mapping from a
layer to a file. A key names a layer by its number in spray order (``1``, ``2`` …), by its
paint's hex code (``"#ff6900"``, as ``spray.json`` gives it), by its paint's name (the can's
label in the job's can list or catalogue, matched without regard to case), or is
``default`` (every layer no other key names). Each layer takes the one key that names it,
else ``default``, else the unmeasured constants of ``spray.can``. A key that names no layer of
the job, or two keys naming the same layer, stop the job before the stipple stage: both are
mistakes a maker wants to hear about rather than paint through.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["DEFAULT_KEY", "layer_key", "profile_key", "unmatched_keys"]

#: The key of the file every layer not named by another key sprays with.
DEFAULT_KEY = "default"

_HEX = re.compile(r"#[0-9a-f]{6}")
_FIX = (
    "a key is a layer number (1, 2, …), a paint's hex code in quotes (\"#ff6900\"), a paint's name "
    "from the job's can list, or default"
)


def profile_key(key: Any) -> str:
    """One key of ``spray.profile``'s mapping, normalised: ``"3"``, ``"#ff6900"``, a name or ``default``.

    Raises:
        ValueError: The key is not a layer number of at least 1, a ``#rrggbb`` hex code, ``default``
            or a non-empty name; the message names the key and the fix.
    """
    if isinstance(key, bool) or not isinstance(key, (int, str)):
        raise ValueError(f"key {key!r} is a {type(key).__name__}: {_FIX}")
    text = str(key).strip()
    if isinstance(key, int) or text.isdigit():
        if int(text) < 1:
            raise ValueError(f"key {key!r}: layers are numbered from 1 in spray order; {_FIX}")
        return str(int(text))
    if not text:
        raise ValueError(f"an empty key: {_FIX}")
    if text.startswith("#"):
        if not _HEX.fullmatch(text.lower()):
            raise ValueError(
                f'key {key!r} is not a hex code #rrggbb (six hex digits, e.g. "#ff6900"); {_FIX}'
            )
        return text.lower()
    if text.casefold() == DEFAULT_KEY:
        return DEFAULT_KEY
    return text


def _names_layer(key: str, number: int, hex_code: str, name: str | None) -> bool:
    if key.isdigit():
        return int(key) == number
    if key.startswith("#"):
        return key == hex_code.lower()
    return key != DEFAULT_KEY and name is not None and key.casefold() == name.strip().casefold()


def layer_key(keys: Sequence[str], number: int, hex_code: str, name: str | None = None) -> str | None:
    """The key of ``keys`` that names layer ``number``: its own key, else ``default``, else None.

    Args:
        keys: Normalised keys (:func:`profile_key`).
        number: The layer's number in spray order, from 1.
        hex_code: Its paint as ``#rrggbb``.
        name: Its paint's name, or None when the job has no name for it.

    Raises:
        ValueError: Two keys name the layer (the message names both and the fix).
    """
    own = [k for k in keys if _names_layer(k, number, hex_code, name)]
    if len(own) > 1:
        raise ValueError(
            f"keys {' and '.join(repr(k) for k in own)} both name layer {number} ({hex_code}"
            f"{', ' + name if name else ''}): keep one of them"
        )
    if own:
        return own[0]
    return DEFAULT_KEY if DEFAULT_KEY in keys else None


def unmatched_keys(
    keys: Sequence[str], hexes: Sequence[str], names: Mapping[str, str] | None = None
) -> list[str]:
    """The keys that name no layer of a job whose paints are ``hexes`` (in spray order).

    Args:
        keys: Normalised keys (:func:`profile_key`).
        hexes: Each layer's paint as ``#rrggbb``.
        names: ``{hex: paint name}`` of the paints the job has names for.
    """
    names = names or {}
    return [
        k
        for k in keys
        if k != DEFAULT_KEY and not any(_names_layer(k, i + 1, h, names.get(h)) for i, h in enumerate(hexes))
    ]
