"""Base class for every config section: strict, frozen, self-describing."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


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
