"""What a slicer said and what it wrote: its log messages, its mesh report, and checks of its output.

:func:`parse_messages` sorts a slicer's console lines into errors and warnings,
:func:`parse_info` reads PrusaSlicer's ``--info`` report of a mesh (:func:`.slicers.inspect_mesh`
runs it), and
:func:`output_problem` / :func:`gcode_summary` judge the G-code or ``.sl1`` it wrote.
"""

from __future__ import annotations

import os
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from .profiles import Profile, Slicer, Technology, get_profile

# PrusaSlicer writes log lines as "[date] [thread] [level]   message"; errors also
# come bare on stderr ("file.stl: Loading of a model file failed.").
_LOG_LINE = re.compile(r"^\[[^\]]*\]\s*\[[^\]]*\]\s*\[(?P<level>\w+)\]\s*(?P<msg>.*)$")
_BARE_ERROR = re.compile(r"\b(error|failed|cannot|can't|could not|invalid)\b", re.IGNORECASE)
# Progress and result lines that are not messages.
_IGNORED_BARE = re.compile(
    r"^(\d+% =>|Slicing result exported|Resident memory|PrusaSlicer-|https?://|Usage:|"
    r"Cura_SteamEngine|Copyright|This program|it under|the Free|\(at your|but WITHOUT|MERCHANTABILITY|"
    r"GNU Affero|along with|Print time|Filament|End of gcode|Gcode header)"
)
_CURA_LINE = re.compile(r"^\[(?P<level>error|warning)\]\s*(?P<msg>.*)$", re.IGNORECASE)


def parse_messages(text: str, returncode: int | None = 0) -> tuple[list[str], list[str]]:
    """Split a slicer's console output into error and warning messages.

    Understands PrusaSlicer's Boost log lines (``[error]``, ``[fatal]``,
    ``[warning]``), PrusaSlicer's bare message lines (a failed run prints its
    reason without a prefix, e.g. a config validation message) and
    CuraEngine's ``[ERROR]`` / ``[WARNING]`` lines.

    Args:
        text: Combined stdout and stderr.
        returncode: The slicer's exit status. When it is non-zero, every bare
            line counts as an error; otherwise only bare lines that read like
            an error (``failed``, ``error``, ``cannot`` ...). Defaults to 0.

    Returns:
        ``(errors, warnings)``, each a list of message strings in order.
    """
    errors: list[str] = []
    warnings: list[str] = []
    for raw in text.splitlines():
        line = raw.strip()
        if not line:
            continue
        m = _LOG_LINE.match(line) or _CURA_LINE.match(line)
        if m:
            level = m.group("level").lower()
            if level in ("error", "fatal"):
                errors.append(m.group("msg").strip())
            elif level == "warning":
                warnings.append(m.group("msg").strip())
            continue
        if line.startswith("[") or _IGNORED_BARE.match(line):
            continue
        if returncode not in (0, None) or _BARE_ERROR.search(line):
            errors.append(line)
    return errors, warnings


@dataclass(frozen=True)
class MeshInfo:
    """What ``prusa-slicer --info`` reports about a mesh before repairing it.

    Attributes:
        facets: Number of triangles.
        manifold: True when PrusaSlicer found no open edges.
        parts: Number of connected shells (one per plate).
        volume_mm3: Enclosed volume in mm³.
        size_mm: ``(x, y, z)`` bounding-box size in mm.
        open_edges: Open edges reported (0 for a closed mesh).
        raw: Every ``key = value`` pair as printed.
    """

    facets: int
    manifold: bool
    parts: int
    volume_mm3: float
    size_mm: tuple[float, float, float]
    open_edges: int = 0
    raw: dict[str, str] = field(default_factory=dict)


def parse_info(text: str) -> MeshInfo:
    """Parse the ``key = value`` block that ``prusa-slicer --info`` prints.

    Raises:
        ValueError: When the text holds no ``number_of_facets``.
    """
    raw: dict[str, str] = {}
    for line in text.splitlines():
        if "=" in line and not line.startswith("["):
            key, _, value = line.partition("=")
            raw[key.strip()] = value.strip()
    if "number_of_facets" not in raw:
        raise ValueError("no mesh information in the slicer output")

    def num(key: str, default: float = 0.0) -> float:
        try:
            return float(raw[key])
        except (KeyError, ValueError):
            return default

    return MeshInfo(
        facets=int(num("number_of_facets")),
        manifold=raw.get("manifold", "").lower() == "yes",
        parts=int(num("number_of_parts", 1)),
        volume_mm3=num("volume"),
        size_mm=(num("size_x"), num("size_y"), num("size_z")),
        open_edges=int(num("open_edges")),
        raw=raw,
    )


def output_problem(output: str | os.PathLike, profile: str | Profile) -> str | None:
    """Why a slicer's output file is not complete, or None when it is.

    G-code is complete when it holds the slicer's closing block (PrusaSlicer's
    ``; prusaslicer_config = end``, CuraEngine's ``;End of Gcode``); an ``.sl1`` when it
    is a readable zip with ``config.ini`` and at least one layer image.
    """
    prof = get_profile(profile)
    path = Path(output)
    if not path.is_file() or path.stat().st_size == 0:
        return f"{prof.slicer.value} wrote no output to {path}"
    if prof.technology is Technology.SLA:
        try:
            with zipfile.ZipFile(path) as zf:
                names = zf.namelist()
        except (OSError, zipfile.BadZipFile):
            return f"{path} is not a complete .sl1 archive"
        if "config.ini" not in names or sla_layer_count(path) == 0:
            return f"{path} has no layers"
        return None
    with path.open("rb") as fh:
        fh.seek(max(0, path.stat().st_size - 65536))
        tail = fh.read().decode("ascii", errors="replace")
    if prof.slicer is Slicer.PRUSA:
        if "prusaslicer_config = end" in tail:
            return None
        return f"{path} is cut short (no closing configuration block)"
    return None if ";End of Gcode" in tail or ";TIME_ELAPSED" in tail else f"{path} is cut short"


def sla_layer_count(sl1: str | os.PathLike) -> int:
    """Number of PNG layer images in a PrusaSlicer ``.sl1`` archive."""
    with zipfile.ZipFile(sl1) as zf:
        return sum(1 for n in zf.namelist() if n.lower().endswith(".png") and "thumbnail" not in n.lower())


def gcode_summary(gcode: str | os.PathLike) -> dict[str, float | int | str]:
    """Figures from a G-code file: layers, moves and the slicer's own estimates.

    Returns:
        ``{"layers": int, "extrusion_moves": int, "bytes": int}`` plus
        ``"print_time"`` (PrusaSlicer's ``; estimated printing time``, or
        CuraEngine's last ``;TIME_ELAPSED:``) and ``"filament_mm"``
        (PrusaSlicer) when the file holds them.
    """
    path = Path(gcode)
    layers = 0
    moves = 0
    elapsed = None
    summary: dict[str, float | int | str] = {"bytes": path.stat().st_size}
    with path.open(errors="replace") as fh:
        for line in fh:
            if line.startswith(("G1 ", "G1\t")) and " E" in line:
                moves += 1
            elif line.startswith((";LAYER_CHANGE", ";LAYER:")):
                layers += 1
            elif line.startswith("; estimated printing time (normal mode)"):
                summary["print_time"] = line.split("=", 1)[1].strip()
            elif line.startswith(";TIME_ELAPSED:"):
                # CuraEngine's command line leaves placeholders in its header (";TIME:6666");
                # the elapsed time after the last layer is the real estimate.
                elapsed = float(line[14:])
            elif line.startswith("; filament used [mm]"):
                summary["filament_mm"] = float(line.split("=", 1)[1].split(",")[0])
    if elapsed is not None and "print_time" not in summary:
        summary["print_time"] = f"{int(elapsed) // 3600}h {int(elapsed) % 3600 // 60}m {int(elapsed) % 60}s"
    summary["layers"] = layers
    summary["extrusion_moves"] = moves
    return summary
