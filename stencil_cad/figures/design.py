"""The plate design chosen for the picture: windows on or off and the wall's stand-off, and its trials."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from .rows import Row


@dataclass(frozen=True)
class PlateTrial:
    """One plate design tried for the picture: windows on or off, the wall's stand-off, and its score."""

    #: ``auto`` (windows where a layer is solid) or ``off`` (holes only).
    windows: str
    standoff_mm: float
    #: S-CIELAB at the viewing distance of the plates stippled (not refined) and sprayed.
    scielab: float

    @property
    def label(self) -> str:
        """The design in words: ``windows, 10 mm`` or ``holes only, 15 mm``."""
        return f"{'windows' if self.windows == 'auto' else 'holes only'}, {self.standoff_mm:g} mm"

    @classmethod
    def from_json(cls, row: Row) -> PlateTrial:
        """One row of the manifest's ``standoff.trials``."""
        return cls(windows=row["windows"], standoff_mm=row["standoff_mm"], scielab=row["scielab"])

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``standoff.trials``."""
        return {"windows": self.windows, "standoff_mm": self.standoff_mm, "scielab": self.scielab}


@dataclass(frozen=True)
class StandoffFigures:
    """The plate design chosen for the picture: the windows' share of the paint, the trials, the choice.

    The design is whether the plates open windows (``stipple.windows: auto`` lets the job choose) and
    the wall's stand-off (``wall.standoff_mm: null`` lets it choose).
    """

    window_share: float
    standoff_mm: float
    #: The plate designs tried, in the order tried; empty without trials.
    trials: Sequence[PlateTrial]
    reason: str
    #: The windows chosen: ``auto`` or ``off``.
    windows: str = "auto"
    #: The trials' simulation grid in mm per pixel (None without trials).
    trial_mm_per_px: float | None = None
    #: Seconds the trials took.
    seconds: float = 0.0
    #: The two best designs' plates refined and sprayed, where their stand-offs differ (the
    #: refinement gains more under more blur), or with light plates the two walls refined outright
    #: (the second's score a scout's where ``scouted_after`` is set): empty otherwise.
    refined: Sequence[PlateTrial] = ()
    #: The refinement steps after which the refined designs were scored (they ranked two walls part
    #: way through their refinement), or None: scored refined in full.
    ranked_after: int | None = None
    #: Where the second of two walls was not stippled: the steps the first wall's holes (after
    #: ``ranked_after`` of their own) were refined for it before it was sprayed and scored
    #: (``refined``'s second score), or None: every refined design was stippled.
    scouted_after: int | None = None
    #: The first of two walls' blur floor (S-CIELAB at the viewing distance of its layers blurred
    #: as its wall blurs a hole, no dots), where the scout of the second looked at it, or None.
    blur_floor: float | None = None

    @property
    def chosen(self) -> PlateTrial | None:
        """The trial of the chosen design (None without trials)."""
        for t in self.trials:
            if t.windows == self.windows and t.standoff_mm == self.standoff_mm:
                return t
        return None

    @classmethod
    def from_json(cls, section: Row) -> StandoffFigures:
        """The manifest's ``standoff`` section."""
        return cls(
            window_share=section["window_share"],
            standoff_mm=section["standoff_mm"],
            trials=tuple(PlateTrial.from_json(t) for t in section.get("trials") or ()),
            reason=section.get("reason", ""),
            windows=section.get("windows", "auto"),
            trial_mm_per_px=section.get("trial_mm_per_px"),
            seconds=section.get("seconds", 0.0),
            refined=tuple(PlateTrial.from_json(t) for t in section.get("refined") or ()),
            ranked_after=section.get("ranked_after"),
            scouted_after=section.get("scouted_after"),
            blur_floor=section.get("blur_floor"),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``standoff`` section."""
        return {
            "window_share": self.window_share,
            "standoff_mm": self.standoff_mm,
            "windows": self.windows,
            "trials": [t.to_json() for t in self.trials],
            "trial_mm_per_px": self.trial_mm_per_px,
            "seconds": self.seconds,
            **({"refined": [t.to_json() for t in self.refined]} if self.refined else {}),
            **({"ranked_after": self.ranked_after} if self.ranked_after is not None else {}),
            **({"scouted_after": self.scouted_after} if self.scouted_after is not None else {}),
            **({"blur_floor": self.blur_floor} if self.blur_floor is not None else {}),
            "reason": self.reason,
        }
