"""Config section `decompose` (owned by the decompose stage)."""

from __future__ import annotations

from .base import StrictModel


class DecomposeConfig(StrictModel):
    """Settings of the decompose stage."""
