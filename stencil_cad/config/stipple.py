"""Config section `stipple` (owned by the stipple stage)."""

from __future__ import annotations

from .base import StrictModel


class StippleConfig(StrictModel):
    """Settings of the stipple stage."""
