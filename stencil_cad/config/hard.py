"""Config section `hard` (owned by the hard stage)."""

from __future__ import annotations

from .base import StrictModel


class HardConfig(StrictModel):
    """Settings of the hard stage."""
