"""Base class for every config section: strict, frozen, self-describing."""

from __future__ import annotations

import types
import typing
from collections.abc import Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationInfo, field_validator

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
