"""Slicing exported parts with a shipped profile, print estimates and PrusaSlicer projects."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import OutputError, UserError
from ..figures import BuildFigures, PrintEstimate
from ..names import part_file, partial_name
from ..record import Run

if TYPE_CHECKING:
    from ..config.bed import Bed
    from ..plan.plan import Plan
    from ..slicing.profiles import Profile

    BedArg = str | tuple[float, float] | Bed | None
    from ..slicing import SliceResult
    from ..slicing.gcode import GcodeEstimate

log = logging.getLogger(__name__)


def slice_plates(
    stls: list[Path],
    profile: str,
    *,
    force: bool = False,
    timeout_s: float = 600.0,
    bed: str | tuple[float, float] | None = None,
) -> Iterator[tuple[Path, Path, SliceResult]]:
    """Slice exported plates with a shipped profile, each beside its STL.

    Every STL is checked, and every output name found free (or ``force``), before the
    first slice runs; a failed slice leaves no output file.

    Args:
        stls: The plates' STL files.
        profile: A shipped profile name (``prusa_fdm``, ``prusa_sla``, ``cura_fdm``).
        force: Replace existing outputs.
        timeout_s: Seconds before a slicer run is killed. Defaults to 600 s.
        bed: The printer's bed (a preset name or ``(x_mm, y_mm)``) replacing the profile's,
            so each mural tile is sliced on the bed it was sized for; None keeps the profile's.

    Yields:
        ``(stl, output, result)`` per plate, in order, as each slice finishes.

    Raises:
        UserError: An STL is missing, an output exists, or the slicer is not installed.
    """
    from .. import slicing

    prof = slicing.get_profile(profile)
    overrides = _bed_overrides(prof, bed)
    jobs = _slice_jobs(stls, prof, bed, prof.suffix, force=force, timeout_s=timeout_s)
    for stl, out, turn in jobs:
        # A slice killed earlier (SIGKILL, power loss) may have left these: they are ours by name.
        tmp = out.with_name(f".{out.name}.partial{prof.suffix}")
        slicing.remove_partial(tmp)
        try:
            # A wall prints sparse (it only holds the plates off the surface): slicing.WALL_SETTINGS.
            settings = {**slicing.part_settings(prof, stl), **overrides}
            result = slicing.slice_plate(
                stl, tmp, prof, timeout_s=timeout_s, overrides=settings, rotate_deg=turn
            )
        except slicing.SlicerNotFoundError as exc:
            slicing.remove_partial(tmp)
            raise UserError(f"{exc}") from None
        except BaseException:
            slicing.remove_partial(tmp)
            raise
        if result.ok:
            tmp.replace(out)
        slicing.remove_partial(tmp)
        yield stl, out, result


def plate_projects(
    stls: list[Path],
    profile: str,
    *,
    force: bool = False,
    timeout_s: float = 300.0,
    bed: str | tuple[float, float] | None = None,
) -> Iterator[tuple[Path, Path, str | None]]:
    """Write a PrusaSlicer 3MF project (plate as tiles, every setting inside) beside each STL.

    Args:
        stls: The plates' STL files.
        profile: A shipped PrusaSlicer profile name (``prusa_fdm``, ``prusa_sla``).
        force: Replace existing ``.3mf`` files.
        timeout_s: Seconds before a PrusaSlicer run is killed. Defaults to 300 s.
        bed: The printer's bed (a preset name or ``(x_mm, y_mm)``) replacing the profile's.

    Yields:
        ``(stl, output, error)`` per plate; ``error`` is None when the project was written.

    Raises:
        UserError: An STL is missing, an output exists, the profile is not PrusaSlicer's, or
            PrusaSlicer is not installed.
    """
    import subprocess

    from .. import slicing

    prof = slicing.get_profile(profile)
    if prof.slicer is not slicing.Slicer.PRUSA:
        raise UserError(f"--project writes PrusaSlicer projects; {profile} is a CuraEngine profile")
    overrides = _bed_overrides(prof, bed)
    jobs = _slice_jobs(stls, prof, bed, ".3mf", force=force, timeout_s=timeout_s)
    for stl, out, turn in jobs:
        tmp = out.with_name(partial_name(out.name))
        slicing.remove_partial(tmp)
        try:
            slicing.plate_project(
                stl,
                tmp,
                prof,
                timeout_s=timeout_s,
                overrides={**slicing.part_settings(prof, stl), **overrides},
                rotate_deg=turn or 0,
            )
        except slicing.SlicerNotFoundError as exc:
            slicing.remove_partial(tmp)
            raise UserError(f"{exc}") from None
        except (RuntimeError, subprocess.TimeoutExpired) as exc:
            slicing.remove_partial(tmp)
            yield stl, out, str(exc)
            continue
        except BaseException:
            slicing.remove_partial(tmp)
            raise
        tmp.replace(out)
        yield stl, out, None


def _slice_jobs(
    stls: list[Path], prof: Profile, bed: BedArg, suffix: str, *, force: bool, timeout_s: float
) -> list[tuple[Path, Path, int]]:
    """``(stl, output, turn)`` per plate, every input and output checked before the first slicer run.

    ``turn`` is 0, or 90 for a part that fits the bed only turned a quarter turn.

    Raises:
        UserError: A bad ``--timeout``, an STL missing, not a regular file, not an STL or larger
            than the bed, or an output in the way (a folder, device, FIFO, or a file without ``force``).
    """
    import math

    from .. import slicing
    from ..files import DATA_LIMIT, check_input, check_target

    if not (math.isfinite(timeout_s) and timeout_s > 0):
        raise UserError(f"--timeout must be a positive number of seconds, got {timeout_s}")
    bed = slicing.bed_size(prof) if bed is None else _bed_xy(bed)
    jobs = []
    for stl in stls:
        check_input(stl, "STL", limit=DATA_LIMIT, fix="run `stencil-cad run` first, or check the path")
        try:
            mesh = slicing.check_stl(stl)
        except ValueError:
            raise UserError(f"{stl} is not an STL file (give a plate's layer_NN.stl)") from None
        except OSError as exc:
            raise UserError(f"cannot read {stl}: {exc.strerror} (check the file)") from None
        if mesh.non_finite:
            raise UserError(
                f"{stl}: {mesh.non_finite} triangle(s) have a NaN or infinite corner: the mesh is broken, "
                "and no size or slice of it is meaningful; export it again (`stencil-cad build` writes "
                "layer_NN.stl) or repair it"
            )
        if mesh.open_edges:
            log.warning(
                "%s has %d open edge(s) (the mesh is not closed): the slicer may fill or drop parts of the "
                "plate; check the print preview, or export it again (`stencil-cad build`) or repair it",
                stl,
                mesh.open_edges,
            )
        size = mesh.size
        # A part that fits only turned (a portrait tile on a landscape bed) is sliced turned.
        lay = slicing.place(size, bed)
        if lay.rotate_deg is None:
            fits = [
                f"{name} ({w:g} × {h:g} mm)"
                for name, (w, h) in ((n, slicing.bed_size(n)) for n in slicing.PROFILES)
                if slicing.place(size, (w, h)).fits
            ]
            raise UserError(
                f"{stl} is {size[0]:.1f} × {size[1]:.1f} mm but the {prof.name} bed is {bed[0]:g} × "
                f"{bed[1]:g} mm, either way round: use a smaller picture (size.width_mm)"
                + (f", another profile (--profile {' or '.join(fits)})" if fits else "")
                + ", or a printer with a larger bed (copy the profile and edit its bed size)"
            )
        out = stl.with_suffix(suffix)
        if out.is_dir():
            raise OutputError(f"{out} is a folder where the sliced file goes (move it away)")
        check_target(out, "sliced file", force=force, error=OutputError)
        jobs.append((stl, out, lay.rotate_deg))
    return jobs


def stage_print_estimate(run: Run, plan: Plan, build: BuildFigures | None) -> BuildFigures:
    """Slice every plate and wall the build staged: figure ``build`` with the slicer's estimates (``export.print_estimate``).

    ``plan``'s config gives the bed and exports; ``build`` is the build's figure ``build``, which the
    recorder then replaces with the one returned.

    Each part is sliced as ``stencil-cad slice`` would (walls sparse, on the job's bed); its
    ``print_hours`` and ``filament_m`` go into its build row and the sums into ``build.print``.

    Raises:
        UserError: PrusaSlicer is not installed, the STLs were not exported, or a slice failed.
    """
    import tempfile

    from .. import slicing

    cfg = plan.cfg
    prof = slicing.get_profile("prusa_fdm")
    if not cfg.export.stl:
        raise UserError("export.print_estimate slices the STL files: set export.stl: true")
    if slicing.find_slicer(prof.slicer) is None:
        raise UserError("export.print_estimate needs PrusaSlicer (Debian/Ubuntu: apt install prusa-slicer)")
    if build is None:
        raise AssertionError("the print estimate slices the plates the build stage made")
    # Copies of the rows, which the estimate adds to; the build's figures are then replaced.
    plates = [p.to_json() for p in build.plates]
    walls = [w.to_json() for w in build.walls]
    parts = [(row, f"layer_{int(row['layer']):02d}") for row in plates]
    parts += [(row, str(row["file"]).rsplit(".", 1)[0]) for row in walls]
    bed = _bed_overrides(prof, cfg.bed) if cfg.bed is not None else {}
    bed_xy = slicing.bed_size(prof) if cfg.bed is None else _bed_xy(cfg.bed)
    total_h = total_m = 0.0
    with run.stage("print_estimate"), tempfile.TemporaryDirectory(prefix="stencil_print_") as tmp:
        for row, stem in parts:
            stl = run.out.stage / part_file(stem, ".stl")
            lay = slicing.place(slicing.stl_footprint(stl), bed_xy)
            if lay.rotate_deg is None:
                row["print"] = "larger than the bed either way round: not sliced"
                continue
            out = Path(tmp) / part_file(stem, ".gcode")
            settings = {**slicing.part_settings(prof, stl), **bed}
            result = slicing.slice_plate(stl, out, prof, overrides=settings, rotate_deg=lay.rotate_deg)
            if not result.ok:
                raise UserError(
                    f"export.print_estimate: slicing {stem}.stl failed: {'; '.join(result.errors)[:300]}"
                )
            est = slicing.read_estimate(out)
            row["print_hours"] = None if est.print_hours is None else round(est.print_hours, 3)
            row["filament_m"] = None if est.filament_m is None else round(est.filament_m, 2)
            total_h += est.print_hours or 0.0
            total_m += est.filament_m or 0.0
            out.unlink()
    total = PrintEstimate(prof.name, round(total_h, 3), round(total_m, 2))
    return BuildFigures.from_rows(plates, walls, total)


def print_estimate(path: Path) -> GcodeEstimate:
    """The slicer's estimated print time and filament (G-code) or resin (``.sl1``) in a sliced file."""
    from ..slicing.gcode import read_estimate, read_sl1_estimate

    return read_sl1_estimate(path) if path.suffix == ".sl1" else read_estimate(path)


def _bed_xy(bed: BedArg) -> tuple[float, float]:
    from ..config.bed import resolve_bed

    b = resolve_bed(bed)
    if b is None:
        raise UserError("--bed: no bed given (name a preset such as prusa_mk4, or XxY mm)")
    return (b.x_mm, b.y_mm)


def _bed_overrides(prof: Profile, bed: BedArg) -> dict[str, Any]:
    """Slicer settings for the bed: its size, and the printer a bed preset names.

    The size is PrusaSlicer's ``bed_shape`` or Cura's machine width and depth; on PrusaSlicer FDM a
    preset that names a printer adds its limits and speeds (:func:`stencil_cad.slicing.printer_settings`).
    """
    from .. import slicing
    from ..config.bed import resolve_bed

    try:
        b = resolve_bed(bed)
    except ValueError as exc:
        raise UserError(f"--bed: {exc}") from None
    if b is None:
        return {}
    if prof.slicer is slicing.Slicer.CURA:
        return {"machine_width": b.x_mm, "machine_depth": b.y_mm}
    shape = {"bed_shape": f"0x0,{b.x_mm:g}x0,{b.x_mm:g}x{b.y_mm:g},0x{b.y_mm:g}"}
    # A bed preset that names a printer slices for that printer's limits and its maker's speeds.
    return {**shape, **slicing.printer_settings(prof, b.name)}
