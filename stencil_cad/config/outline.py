"""Config section `plate.outline`: plate outline and the lock-and-key (owned by the wall/outline work)."""

from __future__ import annotations

from .base import StrictModel


class OutlineConfig(StrictModel):
    """Plate outline, margin around the picture and the asymmetric key."""
