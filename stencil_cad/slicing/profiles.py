"""The print profiles shipped in ``templates/``: which slicer reads each and what it writes."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "PROFILES",
    "WALL_SETTINGS",
    "Profile",
    "Slicer",
    "Technology",
    "get_profile",
    "is_wall",
    "part_settings",
    "templates_dir",
]


class Slicer(str, enum.Enum):
    """Slicer programs a shipped profile can drive."""

    PRUSA = "prusa-slicer"
    CURA = "CuraEngine"


class Technology(str, enum.Enum):
    """Printer technology of a profile: ``fff`` (filament) or ``sla`` (resin)."""

    FFF = "fff"
    SLA = "sla"


@dataclass(frozen=True)
class Profile:
    """One print profile shipped in ``templates/``.

    Attributes:
        name: Key in :data:`PROFILES`, e.g. ``"prusa_fdm"``.
        slicer: Program that reads the profile.
        technology: ``fff`` writes G-code, ``sla`` writes a zip of PNG layers.
        filename: File name inside the templates folder.
        suffix: Suffix of the slicer's output file (``.gcode`` or ``.sl1``).
        layer_height_mm: Layer height the profile slices at, in mm.
        description: One line for ``--help`` texts and the manifest.
    """

    name: str
    slicer: Slicer
    technology: Technology
    filename: str
    suffix: str
    layer_height_mm: float
    description: str

    @property
    def path(self) -> Path:
        """Absolute path of the profile file (see :func:`templates_dir`)."""
        return templates_dir() / self.filename


PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile(
            "prusa_fdm",
            Slicer.PRUSA,
            Technology.FFF,
            "prusa_fdm.ini",
            ".gcode",
            0.3,
            "PrusaSlicer FDM, 0.4 mm nozzle, 0.3 mm layers, tuned for plates with thousands of holes",
        ),
        Profile(
            "prusa_sla",
            Slicer.PRUSA,
            Technology.SLA,
            "prusa_sla.ini",
            ".sl1",
            0.1,
            "PrusaSlicer SLA/MSLA resin, 0.1 mm layers, flat on the plate, no supports",
        ),
        Profile(
            "cura_fdm",
            Slicer.CURA,
            Technology.FFF,
            "cura_fdm.def.json",
            ".gcode",
            0.2,
            "CuraEngine FDM, 0.4 mm nozzle, 0.2 mm layers",
        ),
    )
}


def templates_dir() -> Path:
    """Folder holding the shipped profiles.

    Looks for ``templates/`` next to the package (a source checkout or an
    editable install) and then for ``stencil_cad/templates`` (a wheel).

    Returns:
        The first folder that holds ``prusa_fdm.ini``, else the checkout's
        ``templates/`` path.
    """
    package = Path(__file__).resolve().parent.parent
    candidates = (package.parent / "templates", package / "templates")
    for folder in candidates:
        if (folder / "prusa_fdm.ini").is_file():
            return folder
    return candidates[0]


def get_profile(profile: str | Profile) -> Profile:
    """Return the :class:`Profile` for a name or pass a profile through.

    Raises:
        ValueError: For an unknown name; the message lists the choices.
    """
    if isinstance(profile, Profile):
        return profile
    try:
        return PROFILES[profile]
    except KeyError:
        raise ValueError(f"unknown slicer profile {profile!r}; choose from {', '.join(PROFILES)}") from None


#: PrusaSlicer settings for a wall (`wall.stl`, `tile_XN_wall.stl`, `card_wall_3mm.stl`): it only
#: holds the plates off the surface, so it prints sparse inside (a 10 % grid between two walls, three
#: top layers under the ledge the plate rests on, two bottom layers) with faster walls. The bundled
#: example's wall: 5 h 56 min and 37.4 m of filament at the plates' old settings (100 % infill,
#: 0.2 mm layers), 1 h 29 min and 13.0 m with these.
WALL_SETTINGS: dict[str, object] = {
    "fill_density": "10%",
    "fill_pattern": "grid",
    "perimeters": 2,
    "top_solid_layers": 3,
    "bottom_solid_layers": 2,
    "infill_speed": 80,
    "perimeter_speed": 60,
    "external_perimeter_speed": 45,
}


def is_wall(path: str | Path) -> bool:
    """True for a wall's file name (``wall``, ``wall_10mm``, ``tile_X1_wall``, ``card_wall_3mm``)."""
    return "wall" in Path(path).stem.lower().split("_")


def part_settings(profile: str | Profile, path: str | Path) -> dict[str, object]:
    """Settings that win over a profile's for one part: :data:`WALL_SETTINGS` for a wall on PrusaSlicer FDM.

    Args:
        profile: The profile the part is sliced with.
        path: The part's file (its name says whether it is a wall).

    Returns:
        PrusaSlicer ini keys and values; empty for a plate, or for a profile other than PrusaSlicer FDM.
    """
    prof = get_profile(profile)
    if prof.slicer is Slicer.PRUSA and prof.technology is Technology.FFF and is_wall(path):
        return dict(WALL_SETTINGS)
    return {}
