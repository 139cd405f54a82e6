"""Reading back what an earlier command saved (layers, dots, spray times), checked, for the stage commands."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..config import JobConfig
from ..errors import ConfigError, UserError
from ..model import DotSet, Layers
from .names import LAYERS_NPZ, SPRAY_JSON, dots_name

log = logging.getLogger(__name__)


def read_layers(folder: Path) -> Layers:
    """Read the decomposition a previous `decompose` or `run` saved."""
    from ..exchange.layers_npz import layers_from_npz
    from ..files import DATA_LIMIT, open_input

    path = folder / LAYERS_NPZ
    import zipfile

    fix = "run `stencil-cad decompose` first, or pass --from DIR"
    try:
        with open_input(path, "decomposition", limit=DATA_LIMIT, fix=fix) as fh, np.load(fh) as data:
            return layers_from_npz(dict(data))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise UserError(
            f"{path}: not a readable decomposition ({exc}); re-run `stencil-cad decompose`"
        ) from None


def read_dots(folder: Path, count: int | None = None, max_time: float = 800.0) -> list[DotSet]:
    """Read the dots CSV files of a folder, in layer order, with ``spray.json``'s spray times.

    Args:
        folder: The run folder.
        count: Layers of the decomposition (the files must match), or None.
        max_time: Largest spray time ``spray.json`` may give a layer (8 x the config's cap:
            the tone calibration chooses up to 8 x the base amount).
    """
    from ..exchange.dots_csv import dots_from_csv
    from ..files import DATA_LIMIT
    from ..files import read_text as read_checked

    files = sorted(folder.glob("layer_*_dots.csv"))
    if not files:
        raise UserError(
            f"no layer_NN_dots.csv in {folder} (run `stencil-cad stipple` first, or pass --from DIR)"
        )
    if count is not None and len(files) != count:
        raise UserError(f"{folder} has {len(files)} dots files but the decomposition has {count} layers")
    out = []
    for f in files:
        text = read_checked(f, "dots file", limit=DATA_LIMIT, fix="re-run `stencil-cad stipple`")
        try:
            out.append(dots_from_csv(text))
        except ValueError as exc:
            raise UserError(f"{f}: {str(exc)[:300]}") from None
        windows = f.with_name(f.name.replace("_dots.csv", "_windows.json"))
        if windows.exists():
            from dataclasses import replace as _replace

            from ..exchange.dots_csv import windows_from_json

            wtext = read_checked(
                windows, "windows file", limit=DATA_LIMIT, fix="re-run `stencil-cad stipple`"
            )
            try:
                out[-1] = _replace(out[-1], windows=windows_from_json(wtext))
            except ValueError as exc:
                raise UserError(f"{windows}: {str(exc)[:300]}") from None
        if len(out[-1]) == 0 and not out[-1].windows:
            log.warning(
                "%s has no holes: its plate will spray nothing (re-run `stencil-cad stipple`, or add rows "
                "x_mm,y_mm,r_mm)",
                f,
            )
    spray = folder / SPRAY_JSON
    if spray.exists() or spray.is_symlink():
        from dataclasses import replace

        times = read_spray_times(spray, len(out), max_time)
        out = [replace(ds, spray_time=t) for ds, t in zip(out, times, strict=True)]
    return out


def read_spray_times(path: Path, layers: int, max_time: float) -> list[float]:
    """The per-layer spray times of a ``spray.json``: one per layer, each in (0, ``max_time``].

    Raises:
        UserError: Not a regular file, not JSON, or the list's length or a value is wrong (named).
    """
    import math

    from ..config.io import parse_json
    from ..files import read_text as read_checked

    fix = "fix it, or delete it to use spray.spray_time"
    bad = f"{path}: not a valid spray-time file"
    try:
        data = parse_json(read_checked(path, "spray-time file", fix=fix), str(path))
    except ConfigError as exc:
        raise UserError(f"{bad} ({str(exc).removeprefix(f'{path}: ')}); {fix}") from None
    times = data.get("spray_times") if isinstance(data, dict) else None
    if not isinstance(times, list) or not all(
        isinstance(t, (int, float)) and not isinstance(t, bool) for t in times
    ):
        raise UserError(f"{bad}: spray_times must be a list of numbers, one per layer; {fix}")
    if len(times) != layers:
        raise UserError(f"{bad}: spray_times has {len(times)} values but there are {layers} layers; {fix}")
    for i, t in enumerate(times):
        if not (math.isfinite(t) and 0 < t <= max_time):
            raise UserError(f"{bad}: spray_times[{i}] must be in (0, {max_time:g}], got {t!r}; {fix}")
    return [float(t) for t in times]


def check_dots(cfg: JobConfig, dotsets: list[DotSet], picture_mm: tuple[float, float]) -> None:
    """Check dots read from files against the design rules before any CAD.

    Raises:
        UserError: Naming the file's layer and the first offending dots.
    """
    from ..stipple import rules as rules_mod

    rules = cfg.stipple.design_rules(*picture_mm)
    for i, ds in enumerate(dotsets):
        try:
            rules_mod.check_rules(ds.xy_mm, ds.r_mm, rules)
        except ValueError as exc:
            raise UserError(f"{dots_name(i)}: {exc}") from None
