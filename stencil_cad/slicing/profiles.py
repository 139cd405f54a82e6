"""The print profiles shipped in ``templates/``: which slicer reads each and what it writes."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

from ..config.printers import printer_for_bed
from ..config.process import FDM_SINGLE_LAYER_MM, FDM_THIN_LAYER_MM, FDM_THIN_PLATE_MM

__all__ = [
    "PROFILES",
    "THIN_PLATE_SETTINGS",
    "WALL_SETTINGS",
    "Profile",
    "Slicer",
    "Technology",
    "get_profile",
    "is_wall",
    "part_settings",
    "printer_settings",
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


#: PrusaSlicer settings for the thinnest FDM plate (:data:`stencil_cad.config.process.FDM_THIN_PLATE_MM`,
#: 0.4 mm): two 0.2 mm layers instead of the profile's 0.3 mm (which would print it as 0.3 + 0.1 mm).
THIN_PLATE_SETTINGS: dict[str, object] = {
    "layer_height": FDM_THIN_LAYER_MM,
    "first_layer_height": FDM_THIN_LAYER_MM,
}


def part_settings(
    profile: str | Profile, path: str | Path, height_mm: float | None = None
) -> dict[str, object]:
    """Settings that win over a profile's for one part on PrusaSlicer FDM.

    :data:`WALL_SETTINGS` for a wall, :data:`THIN_PLATE_SETTINGS` for a plate no thicker than the
    thinnest FDM plate.

    Args:
        profile: The profile the part is sliced with.
        path: The part's file (its name says whether it is a wall; its height, unless given, whether
            it is a thin plate).
        height_mm: The part's height in mm, or None to read it from the STL (when there is one).

    Returns:
        PrusaSlicer ini keys and values; empty for any other plate, or a profile other than PrusaSlicer FDM.
    """
    prof = get_profile(profile)
    if prof.slicer is not Slicer.PRUSA or prof.technology is not Technology.FFF:
        return {}
    if is_wall(path):
        return dict(WALL_SETTINGS)
    if height_mm is None:
        height_mm = _stl_height(path)
    # A single-layer plate (0.3 mm) is one of the profile's own layers; a 0.4 mm one is two 0.2 mm layers.
    if height_mm is not None and FDM_SINGLE_LAYER_MM + 1e-3 < height_mm <= FDM_THIN_PLATE_MM + 1e-3:
        return dict(THIN_PLATE_SETTINGS)
    return {}


def _stl_height(path: str | Path) -> float | None:
    """The z extent in mm of an STL file, or None when there is no readable one."""
    from ..exchange.mesh import read_stl

    try:
        tri = read_stl(path)
    except (OSError, ValueError):
        return None
    if tri.size == 0:
        return None
    z = tri[..., 2]
    return float(z.max() - z.min())


def printer_settings(profile: str | Profile, bed: object) -> dict[str, object]:
    """Settings that win over a PrusaSlicer FDM profile for the printer a bed preset names.

    The printer's motion limits (emitted to the G-code, so the slicer's estimate and the printer
    agree), its maker's accelerations and speeds, and its filament's volumetric cap
    (:data:`stencil_cad.config.printers.PRINTERS`).

    Args:
        profile: The profile the part is sliced with.
        bed: The job's ``bed`` (a preset name, a size, or None).

    Returns:
        PrusaSlicer ini keys and values; empty for a bed that names no known printer, or a profile
        other than PrusaSlicer FDM.
    """
    prof = get_profile(profile)
    printer = printer_for_bed(bed)
    if printer is None or prof.slicer is not Slicer.PRUSA or prof.technology is not Technology.FFF:
        return {}
    return {
        "machine_limits_usage": "emit_to_gcode",
        **printer.limits,
        **printer.accelerations,
        **printer.speeds,
        "max_volumetric_speed": printer.max_flow_mm3_s,
    }
