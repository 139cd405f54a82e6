"""The cans a job knows: a can list given as a palette, the catalogue, and each can's name by colour.

The decomposition and hard mode read a palette that may be a can list (a CSV of cans); the plate
previews, the spray order and each layer's spray profile name a paint by its can.
"""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

from ..config import DecomposeConfig, HardConfig
from ..errors import ConfigError
from ..figures import CansFigures, Figures

__all__ = ["Section", "can_names", "with_can_list"]

#: A config section with a palette that may name a can list (the decomposition's or hard mode's).
Section = TypeVar("Section", DecomposeConfig, HardConfig)


def with_can_list(section: Section, where: str) -> tuple[Section, CansFigures | None]:
    """A config section whose palette CSV (a can list) is replaced by its colours, and figure ``cans`` (None: no list)."""
    from ..decompose import paints

    if not isinstance(section.palette, Path):
        return section, None
    try:
        cans = paints.load_cans(section.palette)
    except (ValueError, ConfigError) as exc:
        raise ConfigError(f"{where}: {exc}") from None
    hexes = paints.to_hex_list(cans)
    listed = section.model_copy(update={"palette": hexes if where.startswith("decompose") else list(hexes)})
    return listed, CansFigures(can_list=[c.__dict__ for c in cans])


def can_names(figures: Figures) -> dict[str, str]:
    """``{hex: can label}`` of every can this job knows (its can list and catalogue)."""
    from ..decompose import paints

    known = figures.cans or CansFigures()
    rows = [*(known.can_list or []), *(known.catalogue or [])]
    return paints.names_by_hex([paints.Can(**r) for r in rows])
