"""Config sections `plate`, `wall` and `export` (owned by the CAD stage)."""

from __future__ import annotations

from pydantic import Field

from .base import StrictModel
from .outline import OutlineConfig


class PlateConfig(StrictModel):
    """The stencil plate."""

    outline: OutlineConfig = Field(
        default_factory=OutlineConfig, description="Plate outline, margin and key."
    )


class WallConfig(StrictModel):
    """The interlocking wall."""


class ExportConfig(StrictModel):
    """Which files are written and how."""
