"""Reading back what an earlier command saved (layers, the plan, dots, spray times), checked, for the stage commands."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ..config import JobConfig
from ..config.io import parse_json
from ..errors import ConfigError, UserError
from ..model import DotSet, Layers
from ..names import DOTS_PATTERN, windows_beside
from ..plan.names import LAYERS_NPZ, PLAN_JSON, SPRAY_JSON, STAGE_FILES, dots_name
from ..plan.saved import SavedPlan

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


def read_plan(folder: Path) -> SavedPlan:
    """The plan a previous `decompose`, `run` or `stipple` saved beside the layers, checked against them.

    Whether it was planned for the stage command's config is :meth:`SavedPlan.planned_for`'s to say:
    a stage command given another config plans the job anew.

    Raises:
        UserError: The file is missing, unreadable or of another format, or was planned on another
            decomposition (stale); naming the file and the fix.
    """
    from ..files import read_text as read_checked
    from ..output import sha256_file
    from ..plan.saved import read_plan_json

    path = folder / PLAN_JSON
    again = "re-run `stencil-cad decompose` on the folder to plan the job again, or `stencil-cad run`"
    if not (path.exists() or path.is_symlink()):
        raise UserError(
            f"{path}: missing: the job's plan (the plate design, the primer, each layer's spray), which a "
            f"stage command repeats the run from; {again}"
        )
    try:
        saved = read_plan_json(parse_json(read_checked(path, "plan file", fix=again), str(path)))
    except (ConfigError, ValueError) as exc:
        raise UserError(
            f"{path}: not a readable plan ({str(exc).removeprefix(f'{path}: ')}); {again}"
        ) from None
    layers = folder / LAYERS_NPZ
    if not layers.is_file() or saved.layers_sha256 != sha256_file(layers):
        raise UserError(f"{path}: stale: planned on another decomposition than {layers.name}; {again}")
    return saved


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

    files = sorted(folder.glob(DOTS_PATTERN))
    if not files:
        raise UserError(
            f"no layer_NN_dots.csv in {folder} (run `stencil-cad stipple` first, or pass --from DIR)"
        )
    if count is not None and len(files) != count:
        raise UserError(
            f"{folder} has {len(files)} dots files but the job stipples {count} plates (a light and a dark "
            "plate per paint with stipple.light_plates): run `stencil-cad stipple` on this folder again"
        )
    out = []
    for f in files:
        text = read_checked(f, "dots file", limit=DATA_LIMIT, fix="re-run `stencil-cad stipple`")
        try:
            out.append(dots_from_csv(text))
        except ValueError as exc:
            raise UserError(f"{f}: {str(exc)[:300]}") from None
        windows = f.with_name(windows_beside(f.name))
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
        _mention_hand_edit(spray)
        out = [replace(ds, spray_time=t) for ds, t in zip(out, times, strict=True)]
    return out


def check_fresh(folder: Path, command: str) -> None:
    """Refuse the dots, windows and ``spray.json`` of a folder when its manifest marks them stale.

    A re-run of ``decompose`` marks the files made from the earlier layers stale; a plate or a
    simulation made from them would show the earlier picture.

    Raises:
        UserError: Naming the stale files and the command that remakes them.
    """
    import fnmatch

    from ..output import MANIFEST, read_manifest

    manifest = read_manifest(folder / MANIFEST) or {}
    stale = manifest.get("stale")
    files = stale.get("files") if isinstance(stale, dict) else None
    if not isinstance(files, list):
        return
    inputs = STAGE_FILES["stipple"]
    hit = sorted(
        str(n)
        for n in files
        if any(fnmatch.fnmatch(str(n), p) for p in inputs) and (folder / str(n)).exists()
    )
    if not hit:
        return
    shown = ", ".join(hit[:4]) + (f" and {len(hit) - 4} more" if len(hit) > 4 else "")
    raise UserError(
        f"{folder}: {shown} are stale: made from an earlier decomposition (manifest.json: stale), so "
        f"`stencil-cad {command}` would use the earlier picture's dots; re-run `stencil-cad stipple` on the "
        "folder first, or `stencil-cad run`"
    )


def _mention_hand_edit(path: Path) -> None:
    """Say so when a file differs from the SHA-256 the folder's manifest recorded for it."""
    import hashlib

    from ..output import MANIFEST, read_manifest

    manifest = read_manifest(path.parent / MANIFEST) or {}
    rows = manifest.get("files")
    recorded = next(
        (
            r.get("sha256")
            for r in (rows if isinstance(rows, list) else [])
            if isinstance(r, dict) and r.get("name") == path.name
        ),
        None,
    )
    if not isinstance(recorded, str):
        return
    try:
        now = hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return
    if now != recorded:
        log.warning(
            "%s was edited since stencil-cad wrote it (its SHA-256 differs from manifest.json's); its "
            "spray_times are used (re-run `stencil-cad stipple` to get the calibrated ones back)",
            path,
        )


def read_spray_times(path: Path, layers: int, max_time: float) -> list[float]:
    """The per-layer spray times of a ``spray.json``: one per layer, each in (0, ``max_time``].

    Raises:
        UserError: Not a regular file, not JSON, or the list's length or a value is wrong (named).
    """
    import math

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
    _check_order(path, data.get("order"), times)
    return [float(t) for t in times]


def _check_order(path: Path, order: object, times: list[float]) -> None:
    """Refuse a spray order whose steps disagree with ``spray_times`` (the maker sprays the order).

    Raises:
        UserError: Naming the step, both values and the fix.
    """
    import math

    if order is None:
        return
    fix = "make order[].spray_time, order[].passes and spray_times agree, or re-run `stencil-cad stipple`"
    if not isinstance(order, list) or len(order) != len(times):
        raise UserError(
            f"{path}: order must be a list of {len(times)} steps, one per layer like spray_times; {fix}"
        )
    for i, (step, t) in enumerate(zip(order, times, strict=True)):
        if not isinstance(step, dict):
            raise UserError(f"{path}: order[{i}] must be a mapping (step, plate, spray_time ...); {fix}")
        said = step.get("spray_time")
        if said is not None and (not isinstance(said, (int, float)) or abs(float(said) - float(t)) > 1e-6):
            raise UserError(
                f"{path}: order[{i}].spray_time is {said!r} but spray_times[{i}] is {t:g}: the steps would "
                f"spray one amount and the plates be made for another; {fix}"
            )
        passes = step.get("passes")
        # The hand sprays a dose in whole passes at a pace (SprayConfig.hand): 4.5 may be 4 slower
        # passes or 5 quicker ones, so either whole number around the dose agrees with it.
        lo, hi = max(1, math.floor(float(t))), max(1, math.ceil(float(t)))
        if passes is not None and not (isinstance(passes, int) and lo <= passes <= hi):
            said = f"{lo}" if lo == hi else f"{lo} or {hi}"
            raise UserError(
                f"{path}: order[{i}].passes is {passes!r} but spray_times[{i}] is {t:g} "
                f"({said} passes): the steps would spray one amount and the plates be "
                f"made for another; {fix}"
            )


def check_rows(cfg: JobConfig, dotsets: list[DotSet], picture_mm: tuple[float, float]) -> None:
    """Refuse a dots file with more rows than holes fit the picture, before any work on its pairs.

    Raises:
        UserError: Naming the file, its rows, the bound and the fix.
    """
    from ..bounds import max_dots

    most = max_dots(cfg.stipple, *picture_mm)
    for i, ds in enumerate(dotsets):
        if len(ds) > most:
            raise UserError(
                f"{dots_name(i)}: {len(ds)} holes, but at most {most} holes of radius "
                f"{cfg.stipple.hole_floor_mm:g} mm with {cfg.stipple.sizes.web_mm:g} mm webs fit "
                f"in {picture_mm[0]:.4g} × {picture_mm[1]:.4g} mm: the file is not this job's dots; re-run "
                "`stencil-cad stipple` (or give the folder the file belongs to with --from)"
            )


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
