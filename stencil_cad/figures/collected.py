"""Every stage's figures for one command: :class:`Figures`, written as the manifest's stage sections."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from .cost import CostFigures
from .design import StandoffFigures
from .mural import MuralFigures
from .parts import BuildFigures
from .rows import Row, rows_of, to_json
from .spray import LayerProfile, PaintFigures, SimulateFigures, SprayOrderFigures, SprayStep
from .stages import (
    CansFigures,
    ComputeFigures,
    DarkEnd,
    DecomposeFigures,
    HardFigures,
    LayerStipple,
    LayerWindows,
    PictureFigures,
    PlateFigures,
)


def _list(read: Callable[[Row], Any]) -> Callable[[Any], tuple[Any, ...]]:
    return lambda rows: rows_of(read, rows)


def _same(value: Any) -> Any:
    return value


#: How each section of a manifest is read back (by its name, which is the attribute's).
_READERS: Mapping[str, Callable[[Any], Any]] = {
    "compute": ComputeFigures.from_json,
    "picture": PictureFigures.from_json,
    "mural": MuralFigures.from_json,
    "plate": PlateFigures.from_json,
    "standoff": StandoffFigures.from_json,
    "decompose": DecomposeFigures.from_json,
    "cans": CansFigures.from_json,
    "dark_end": _list(DarkEnd.from_json),
    "refine": _same,
    "windows": _list(LayerWindows.from_json),
    "stipple": _list(LayerStipple.from_json),
    "tone_calibration": _same,
    "build": BuildFigures.from_json,
    "simulate": SimulateFigures.from_json,
    "spraying": _list(SprayStep.from_json),
    "paint": PaintFigures.from_json,
    "spray_order": SprayOrderFigures.from_json,
    "spray_profiles": _list(LayerProfile.from_json),
    "card": _same,
    "hard": HardFigures.from_json,
    "cost": CostFigures.from_json,
}


class Figures:
    """Every stage's figures for one command, written to the manifest in the order stages recorded them.

    Each attribute is one section of the manifest (None until its stage records it). The
    refinement's figures (``refine``), the tone choices (``tone_calibration``) and the card's
    (``card``) are the stage's plain rows: neither the summary nor the sheet reads them.
    """

    compute: ComputeFigures | None = None
    picture: PictureFigures | None = None
    mural: MuralFigures | None = None
    plate: PlateFigures | None = None
    standoff: StandoffFigures | None = None
    decompose: DecomposeFigures | None = None
    cans: CansFigures | None = None
    dark_end: tuple[DarkEnd, ...] | None = None
    refine: Row | None = None
    windows: tuple[LayerWindows, ...] | None = None
    stipple: tuple[LayerStipple, ...] | None = None
    tone_calibration: list[Any] | None = None
    build: BuildFigures | None = None
    simulate: SimulateFigures | None = None
    spraying: tuple[SprayStep, ...] | None = None
    paint: PaintFigures | None = None
    spray_order: SprayOrderFigures | None = None
    spray_profiles: tuple[LayerProfile, ...] | None = None
    card: Row | None = None
    hard: HardFigures | None = None
    cost: CostFigures | None = None

    def __init__(self) -> None:
        self._order: list[str] = []

    def __setattr__(self, name: str, value: Any) -> None:
        if not name.startswith("_") and name not in self._order:
            if name not in type(self).__annotations__:
                raise AttributeError(f"no stage records figures called {name!r}")
            self._order.append(name)
        object.__setattr__(self, name, value)

    @classmethod
    def from_json(cls, manifest: Row) -> Figures:
        """The figures of a manifest (as :meth:`to_json` wrote them, or read from disk).

        The manifest's other keys (its header, config, timings, files) are not figures and are
        left out.
        """
        out = cls()
        for name, value in manifest.items():
            if name in _READERS:
                setattr(out, name, None if value is None else _READERS[name](value))
        return out

    def to_json(self) -> dict[str, Any]:
        """The manifest's stage sections, in the order the stages first recorded them."""
        return {name: to_json(getattr(self, name)) for name in self._order}
