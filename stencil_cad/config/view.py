"""Config section `view`: where the picture will be seen from (owned by the simulate stage)."""

from __future__ import annotations

from pydantic import Field

from .base import StrictModel


class ViewConfig(StrictModel):
    """How far the viewer stands: it sets the S-CIELAB score and what the refinement aims at."""

    distance_m: float = Field(
        1.0,
        gt=0.05,
        le=100.0,
        description=(
            "Viewing distance in metres: the distance people will see the sprayed picture from (1 m: a "
            "picture on a wall seen across a room). The spray is scored with S-CIELAB at this distance and "
            "at twice it, and the summary says whether the holes show as dots from here. Range (0.05, 100]."
        ),
    )
