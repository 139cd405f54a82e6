"""Config section `spray` (owned by the spray stage)."""

from __future__ import annotations

from .base import StrictModel


class SprayConfig(StrictModel):
    """Settings of the spray stage."""
