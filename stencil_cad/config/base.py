"""Base class for every config section: strict, frozen, self-describing."""

from __future__ import annotations

import logging
import math
import types
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import ClassVar

from pydantic import BaseModel, ConfigDict, ValidationInfo, field_validator, model_validator

log = logging.getLogger(__name__)

#: A palette list once read: its colours as ``'#rrggbb'`` strings, in order. A config's palette
#: may instead still name a can list (a CSV file) until the pipeline has read it.
HexPalette = tuple[str, ...]


def resolved_palette(palette: str | Sequence[str] | Path | None, field: str) -> HexPalette | None:
    """The palette's colours, or None where the config leaves the colours to the image.

    Args:
        palette: The field's value: ``'auto'``/None, a list of ``'#rrggbb'``, or a can list path.
        field: The field's dotted name, for the message.

    Raises:
        ValueError: The palette is still a can list file (read it first, see :mod:`stencil_cad.decompose.paints`).
    """
    if palette is None or isinstance(palette, str):  # null or 'auto' (the validators allow no other string)
        return None
    if isinstance(palette, Path):
        raise ValueError(f"{field} {palette} is a can list: read it first (stencil_cad.decompose.paints)")
    return tuple(palette)


class StrictModel(BaseModel):
    """A config section.

    Unknown keys are rejected (``extra="forbid"``), values are immutable once
    validated, and every field carries a ``description`` that states its unit,
    range and choices: ``templates/default.yaml`` and ``stencil-cad init`` are
    generated from those descriptions, so a field without one is a defect.
    """

    model_config = ConfigDict(
        extra="forbid",
        frozen=True,
        validate_default=True,
        use_enum_values=False,
    )

    #: Keys renamed in this release, old name → new name: the old name is still read, with a
    #: deprecation message, until the next release.
    RENAMED: ClassVar[dict[str, str]] = {}
    #: Where this section's keys are written, for the deprecation message.
    WHERE: ClassVar[str] = "config"

    @model_validator(mode="before")
    @classmethod
    def _renamed_keys(cls, data):
        """Read a renamed key under its new name and say so once per key."""
        if not isinstance(data, dict) or not cls.RENAMED:
            return data
        for old, new in cls.RENAMED.items():
            if old not in data:
                continue
            if new in data:
                raise ValueError(f"{old} is the old name of {new}; give only {new}")
            log.warning(
                "%s: %s is now called %s; the old name is read until the next release, rename it",
                cls.WHERE,
                old,
                new,
            )
            data = {**{k: v for k, v in data.items() if k != old}, new: data[old]}
        return data

    @classmethod
    def field_range(cls, name: str) -> tuple[float, float]:
        """``(lowest, highest)`` a numeric field allows (its schema bounds; ±inf where open).

        For code that must stay inside the schema (a fit's bounds, a command-line check) without
        restating it.
        """
        lo, hi = -math.inf, math.inf
        for m in cls.model_fields[name].metadata:
            for attr in ("ge", "gt"):
                if getattr(m, attr, None) is not None:
                    lo = float(getattr(m, attr))
            for attr in ("le", "lt"):
                if getattr(m, attr, None) is not None:
                    hi = float(getattr(m, attr))
        return lo, hi

    @field_validator("*", mode="before")
    @classmethod
    def _no_bools_as_numbers(cls, value, info: ValidationInfo):
        """Reject ``true``/``false`` where a number is expected (pydantic would read them as 1/0)."""
        if isinstance(value, bool) and info.field_name is not None:
            ann = cls.model_fields[info.field_name].annotation
            args = (
                typing.get_args(ann)
                if isinstance(ann, types.UnionType) or typing.get_origin(ann) is typing.Union
                else (ann,)
            )
            if bool not in args and any(a in (int, float) for a in args):
                raise ValueError("must be a number, not a true/false value")
        return value
