"""Run a real slicer on an exported stencil plate (kernel-free).

A maker's next step after ``stencil-cad run`` is a slicer, so the project ships
slicer profiles in ``templates/`` (:mod:`.profiles`) and this module finds the slicer binary,
builds the command line for a shipped profile, runs it with a timeout and
reports what the slicer said. It never imports the CAD kernel.

Profiles (see :data:`PROFILES` and ``docs/printing.md``):

* ``prusa_fdm`` — PrusaSlicer 2.5+, FDM, 0.3 mm layers, Arachne walls with
  the per-loop overhang detection and the seam ray-casting off; plates with
  many holes are sliced as touching tiles (:func:`.plates.slice_plate`), which keeps
  the slicing time linear in the hole count.
* ``prusa_sla`` — PrusaSlicer 2.5+, SLA/MSLA resin, 0.1 mm layers, no supports
  and no pad: the plate lies flat on the build plate.
* ``cura_fdm`` — CuraEngine 4.x (the engine behind Ultimaker Cura), FDM,
  0.2 mm layers; needs ``fdmprinter.def.json`` from the ``cura`` package.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import shutil
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exchange.mesh import read_stl
from .profiles import Profile, Slicer, Technology, get_profile, templates_dir
from .reports import MeshInfo, output_problem, parse_info, parse_messages

log = logging.getLogger(__name__)

#: Environment variables that override the slicer binaries found on ``PATH``.
ENV_PRUSA = "STENCIL_CAD_PRUSA_SLICER"
ENV_CURA = "STENCIL_CAD_CURA_ENGINE"
#: Environment variable naming a folder holding ``fdmprinter.def.json``.
ENV_CURA_DEFINITIONS = "STENCIL_CAD_CURA_DEFINITIONS"

_PRUSA_NAMES = ("prusa-slicer", "PrusaSlicer", "prusa-slicer-console", "PrusaSlicer-console")
_CURA_NAMES = ("CuraEngine", "curaengine")
_CURA_DEFINITION_DIRS = (
    "/usr/share/cura/resources/definitions",
    "/usr/local/share/cura/resources/definitions",
    "/opt/cura/resources/definitions",
)


class SlicerNotFoundError(RuntimeError):
    """The slicer program (or CuraEngine's printer definitions) is not installed."""


def find_slicer(slicer: Slicer | str = Slicer.PRUSA) -> Path | None:
    """Locate a slicer binary.

    The environment variable ``STENCIL_CAD_PRUSA_SLICER`` or
    ``STENCIL_CAD_CURA_ENGINE`` wins over ``PATH``.

    Args:
        slicer: Which program. Defaults to PrusaSlicer.

    Returns:
        The path of the executable, or None when it is not installed.
    """
    slicer = Slicer(slicer)
    env, names = (ENV_PRUSA, _PRUSA_NAMES) if slicer is Slicer.PRUSA else (ENV_CURA, _CURA_NAMES)
    override = os.environ.get(env)
    if override:
        found = shutil.which(override)
        return Path(found) if found else None
    for name in names:
        found = shutil.which(name)
        if found:
            return Path(found)
    return None


def find_cura_definitions() -> Path | None:
    """Folder holding CuraEngine's ``fdmprinter.def.json`` (Debian package ``cura``), or None."""
    env = os.environ.get(ENV_CURA_DEFINITIONS)
    for folder in ((env,) if env else ()) + _CURA_DEFINITION_DIRS:
        if (Path(folder) / "fdmprinter.def.json").is_file():
            return Path(folder)
    return None


def _require(slicer: Slicer, executable: str | os.PathLike | None) -> str:
    if executable is not None:
        return str(executable)
    found = find_slicer(slicer)
    if found is None:
        hint = (
            "Debian/Ubuntu: apt install prusa-slicer"
            if slicer is Slicer.PRUSA
            else "apt install cura-engine cura"
        )
        raise SlicerNotFoundError(f"{slicer.value} not found on PATH ({hint})")
    return str(found)


def _format_override(key: str, value: object) -> str:
    if isinstance(value, bool):
        value = int(value)
    return f"{key}={value}"


def _models(model: str | os.PathLike | Sequence[str | os.PathLike]) -> list[str]:
    if isinstance(model, (str, os.PathLike)):
        return [str(model)]
    models = [str(m) for m in model]
    if not models:
        raise ValueError("no model to slice")
    return models


def build_command(
    model: str | os.PathLike | Sequence[str | os.PathLike],
    output: str | os.PathLike,
    profile: str | Profile = "prusa_fdm",
    *,
    executable: str | os.PathLike | None = None,
    overrides: Mapping[str, object] | None = None,
    threads: int | None = None,
    extra_args: Sequence[str] = (),
) -> list[str]:
    """Build the command line that slices ``model`` into ``output`` with a shipped profile.

    Args:
        model: Mesh to slice (STL, 3MF or OBJ), exported plate-down; or several
            meshes (the tiles of one plate from :func:`split_into_tiles`),
            which are sliced as separate objects that keep their relative
            positions and are centred on the bed together.
        output: G-code (FDM) or ``.sl1`` (SLA) path to write.
        profile: Name in :data:`PROFILES` or a :class:`Profile`. Defaults to
            ``"prusa_fdm"``.
        executable: Slicer binary; found with :func:`find_slicer` when None.
        overrides: Extra settings ``{key: value}`` in the slicer's own names
            (PrusaSlicer ini keys such as ``bed_shape`` or Cura setting keys
            such as ``machine_width``); they win over the profile.
        threads: PrusaSlicer worker threads; None lets the slicer decide.
        extra_args: Further raw arguments placed after the settings.

    Returns:
        The argument list for :func:`subprocess.run`.

    Raises:
        SlicerNotFoundError: The slicer (or Cura's printer definitions) is missing.
        ValueError: Several meshes for a CuraEngine profile.
    """
    prof = get_profile(profile)
    exe = _require(prof.slicer, executable)
    models = _models(model)
    overrides = dict(overrides or {})
    if prof.slicer is Slicer.PRUSA:
        action = "--export-sla" if prof.technology is Technology.SLA else "--export-gcode"
        cmd = [exe, action, "--load", str(prof.path)]
        for key, value in overrides.items():
            cmd.append(f"--{key.replace('_', '-')}={_format_override(key, value).split('=', 1)[1]}")
        if threads is not None:
            cmd.append(f"--threads={int(threads)}")
        cmd += list(extra_args)
        if len(models) > 1:
            # One object per tile, kept where the exporter put it (touching its neighbours),
            # then the group is centred on the bed.
            cmd += ["--merge", "--dont-arrange", f"--center={_bed_centre(prof, overrides)}"]
        cmd += ["--output", str(output), *models]
        return cmd
    if len(models) > 1:
        # `center_object` (needed: CuraEngine drops geometry below z = 0 otherwise) centres
        # every mesh on its own, which would stack the tiles on top of each other.
        raise ValueError("CuraEngine centres each mesh on the bed; slice tiles with PrusaSlicer")
    # CuraEngine: `-j` loads our definition, which inherits fdmprinter from the search path.
    cmd = [exe, "slice", "-v", "-j", str(prof.path)]
    for key, value in overrides.items():
        cmd += ["-s", _format_override(key, value)]
    cmd += list(extra_args)
    cmd += ["-o", str(output), "-l", models[0]]
    return cmd


def bed_size(profile: str | Profile) -> tuple[float, float]:
    """Width and depth in mm of the printable area of a shipped profile.

    PrusaSlicer profiles: the bounding box of ``bed_shape``; CuraEngine definitions:
    ``machine_width`` × ``machine_depth``.
    """
    prof = get_profile(profile)
    if prof.slicer is Slicer.CURA:
        settings = json.loads(prof.path.read_text())["overrides"]
        return float(settings["machine_width"]["default_value"]), float(
            settings["machine_depth"]["default_value"]
        )
    for line in prof.path.read_text().splitlines():
        key, _, value = line.partition("=")
        if key.strip() == "bed_shape":
            pts = np.array([[float(v) for v in p.split("x")] for p in value.strip().split(",")])
            w, h = pts.max(axis=0) - pts.min(axis=0)
            return float(w), float(h)
    raise ValueError(f"profile {prof.name} has no bed_shape")


@dataclass(frozen=True)
class StlCheck:
    """What ``slice`` checks of an STL before the slicer sees it.

    Attributes:
        size: Width and depth in mm of its bounding box (x, y), of its finite corners.
        non_finite: Triangles with a NaN or infinite coordinate (the mesh is broken).
        open_edges: Edges that only one triangle uses (0 for a closed, watertight mesh).
    """

    size: tuple[float, float]
    non_finite: int
    open_edges: int


def check_stl(path: str | os.PathLike) -> StlCheck:
    """Read an STL and count what makes it unfit to slice: non-finite corners and open edges.

    Raises:
        ValueError: The file is not an STL, or is empty.
    """
    from ..geometry import index_triangles

    tri = read_stl(path)
    if tri.size == 0:
        raise ValueError(f"{path}: the STL has no triangles")
    bad = ~np.isfinite(tri).all(axis=(1, 2))
    good = tri[~bad]
    if len(good) == 0:
        return StlCheck((float("nan"), float("nan")), int(bad.sum()), 0)
    pts = good.reshape(-1, 3)
    w, h = pts[:, :2].max(axis=0) - pts[:, :2].min(axis=0)
    verts, faces = index_triangles(good)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges[:, 0] * np.int64(len(verts)) + edges[:, 1], return_counts=True)
    return StlCheck((float(w), float(h)), int(bad.sum()), int(np.count_nonzero(counts == 1)))


def stl_footprint(path: str | os.PathLike) -> tuple[float, float]:
    """Width and depth in mm of an STL's bounding box (x, y).

    Raises:
        ValueError: The file is not an STL, or is empty.
    """
    tri = read_stl(path)
    if tri.size == 0:
        raise ValueError(f"{path}: the STL has no triangles")
    pts = tri.reshape(-1, 3)
    w, h = pts[:, :2].max(axis=0) - pts[:, :2].min(axis=0)
    return float(w), float(h)


def _bed_centre(prof: Profile, overrides: Mapping[str, object]) -> str:
    shape = overrides.get("bed_shape")
    if shape is None:
        for line in prof.path.read_text().splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "bed_shape":
                shape = value.strip()
    if not shape:
        return "100,100"
    pts = np.array([[float(v) for v in p.split("x")] for p in str(shape).split(",")])
    cx, cy = (pts.min(axis=0) + pts.max(axis=0)) / 2
    return f"{cx:g},{cy:g}"


def cura_environment() -> dict[str, str]:
    """Environment for CuraEngine with the ``fdmprinter`` definitions on its search path.

    Raises:
        SlicerNotFoundError: ``fdmprinter.def.json`` is not installed.
    """
    definitions = find_cura_definitions()
    if definitions is None:
        raise SlicerNotFoundError(
            "CuraEngine needs fdmprinter.def.json (Debian/Ubuntu: apt install cura); "
            f"or set {ENV_CURA_DEFINITIONS} to the folder that holds it"
        )
    env = dict(os.environ)
    search = [str(templates_dir()), str(definitions)]
    extruders = definitions.parent / "extruders"
    if extruders.is_dir():
        search.append(str(extruders))
    if env.get("CURA_ENGINE_SEARCH_PATH"):
        search.append(env["CURA_ENGINE_SEARCH_PATH"])
    env["CURA_ENGINE_SEARCH_PATH"] = os.pathsep.join(search)
    return env


def inspect_mesh(
    model: str | os.PathLike, *, executable: str | os.PathLike | None = None, timeout_s: float = 120.0
) -> MeshInfo:
    """Run ``prusa-slicer --info`` on a mesh: facets, manifold, parts, volume.

    Unlike slicing (which silently repairs), ``--info`` reports the mesh as
    written, so it checks the exporter.

    Args:
        model: STL/3MF/OBJ path.
        executable: PrusaSlicer binary; found with :func:`find_slicer` when None.
        timeout_s: Seconds before the run is killed. Defaults to 120 s.

    Raises:
        SlicerNotFoundError: PrusaSlicer is not installed.
        RuntimeError: The slicer failed or printed no mesh information.
    """
    exe = _require(Slicer.PRUSA, executable)
    proc = subprocess.run(
        [exe, "--info", str(model)], capture_output=True, text=True, timeout=timeout_s, check=False
    )
    text = proc.stdout + "\n" + proc.stderr
    errors, _ = parse_messages(text, proc.returncode)
    if proc.returncode != 0 or errors:
        raise RuntimeError(
            f"prusa-slicer --info {model} failed (exit {proc.returncode}): {'; '.join(errors)}"
        )
    return parse_info(proc.stdout)


@dataclass(frozen=True)
class SliceResult:
    """Outcome of one slicer run.

    Attributes:
        profile: Profile name.
        command: The argument list that ran.
        returncode: Exit status (None when the run timed out).
        seconds: Wall-clock time in s.
        cpu_seconds: User + system CPU time of the slicer process in s
            (robust to other load on a shared machine; None when unknown).
        timed_out: True when the run was killed at the timeout.
        output: Path of the G-code or ``.sl1`` file.
        output_bytes: Its size in bytes (0 when missing).
        errors: Error messages the slicer printed.
        warnings: Warning messages the slicer printed.
        log: Last 4,000 characters of the console output.
        rotate_deg: 90 when the part was sliced turned a quarter turn to fit the bed, else 0.
    """

    profile: str
    command: tuple[str, ...]
    returncode: int | None
    seconds: float
    cpu_seconds: float | None
    timed_out: bool
    output: Path
    output_bytes: int
    errors: tuple[str, ...]
    warnings: tuple[str, ...]
    log: str = ""
    rotate_deg: int = 0

    @property
    def ok(self) -> bool:
        """True when the run finished with exit 0 and a complete output (log lines are warnings)."""
        return (not self.timed_out) and self.returncode == 0 and not self.errors and self.output_bytes > 0


def _children_cpu() -> float | None:
    try:
        import resource
    except ImportError:  # Windows
        return None
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def slice_file(
    model: str | os.PathLike | Sequence[str | os.PathLike],
    output: str | os.PathLike,
    profile: str | Profile = "prusa_fdm",
    *,
    timeout_s: float = 600.0,
    executable: str | os.PathLike | None = None,
    overrides: Mapping[str, object] | None = None,
    threads: int | None = None,
    extra_args: Sequence[str] = (),
) -> SliceResult:
    """Slice a mesh with a shipped profile and report what happened.

    The run is killed after ``timeout_s``; a timeout is reported, not raised,
    so a benchmark can record it.

    Args:
        model: Mesh to slice (STL, 3MF or OBJ), or the tiles of one plate
            (see :func:`build_command`).
        output: G-code or ``.sl1`` path to write; its folder must exist.
        profile: Name in :data:`PROFILES` or a :class:`Profile`. Defaults to
            ``"prusa_fdm"``.
        timeout_s: Seconds before the slicer is killed. Defaults to 600 s.
        executable: Slicer binary; found with :func:`find_slicer` when None.
        overrides: Settings that win over the profile (see :func:`build_command`).
        threads: PrusaSlicer worker threads; None lets the slicer decide.
        extra_args: Further raw arguments placed after the settings.

    Returns:
        A :class:`SliceResult`; check ``.ok``.

    Raises:
        SlicerNotFoundError: The slicer is not installed.
    """
    prof = get_profile(profile)
    output = Path(output)
    cmd = build_command(
        model,
        output,
        prof,
        executable=executable,
        overrides=overrides,
        threads=threads,
        extra_args=extra_args,
    )
    env = cura_environment() if prof.slicer is Slicer.CURA else None
    if output.exists():
        output.unlink()
    log.info("slicing %s with profile %s: %s", model, prof.name, " ".join(cmd))
    cpu0 = _children_cpu()
    start = time.perf_counter()
    text, returncode, timed_out = _run_slicer(cmd, env, output, timeout_s)
    seconds = time.perf_counter() - start
    cpu1 = _children_cpu()
    cpu = None if cpu0 is None or cpu1 is None else cpu1 - cpu0
    errors, warnings = _judge(text, returncode, timed_out, output, prof, timeout_s)
    size = output.stat().st_size if output.is_file() else 0
    result = SliceResult(
        profile=prof.name,
        command=tuple(cmd),
        returncode=returncode,
        seconds=seconds,
        cpu_seconds=cpu,
        timed_out=timed_out,
        output=output,
        output_bytes=size,
        errors=tuple(errors),
        warnings=tuple(warnings),
        log=(text or "")[-4000:],
    )
    log.info("sliced in %.1f s (ok=%s, %d bytes)", seconds, result.ok, size)
    return result


def _run_slicer(cmd: list[str], env, output: Path, timeout_s: float) -> tuple[str, int | None, bool]:
    """Run the slicer, killed at ``timeout_s``: ``(console text, exit status or None, timed out)``.

    Interrupted (Ctrl-C, SIGTERM), it stops the slicer before it writes on, removes what it
    wrote and re-raises.
    """
    timed_out = False
    # start_new_session lets a timeout kill the slicer's whole process group.
    with subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        errors="replace",
        env=env,
        start_new_session=True,
        preexec_fn=_die_with_parent,  # noqa: PLW1509 - only a prctl call, no locks taken
    ) as proc:
        try:
            text, _ = proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            timed_out = True
            _kill_group(proc)
            text, _ = proc.communicate()
        except BaseException:
            # Interrupted (Ctrl-C, SIGTERM): stop the slicer before it writes on, and remove what it wrote.
            _kill_group(proc)
            proc.wait()
            remove_partial(output)
            raise
        returncode = None if timed_out else proc.returncode
    return text, returncode, timed_out


def _judge(
    text: str | None, returncode: int | None, timed_out: bool, output: Path, prof: Profile, timeout_s: float
) -> tuple[list[str], list[str]]:
    """The run's errors and warnings, from its log, exit status and output."""
    errors, warnings = parse_messages(text or "", returncode)
    # Success is the exit code and a complete output, not the log's words: PrusaSlicer logs
    # `[error]` lines on runs that exit 0 with complete G-code. Those become warnings.
    incomplete = output_problem(output, prof) if returncode == 0 and not timed_out else None
    if returncode == 0 and not timed_out and incomplete is None:
        warnings = [*errors, *warnings]
        errors = []
    if timed_out:
        errors.append(f"timed out after {timeout_s:.0f} s")
    elif returncode != 0 and not errors:
        errors.append(f"{prof.slicer.value} exited with status {returncode}")
    elif incomplete is not None:
        errors.append(incomplete)
    return errors, warnings


def _die_with_parent() -> None:
    """In the slicer's process: be killed when stencil-cad dies, even by SIGKILL (Linux)."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, 9)  # PR_SET_PDEATHSIG, SIGKILL
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def remove_partial(output: str | os.PathLike) -> None:
    """Remove a slicer's output and the temporary file it writes first (``OUTPUT.tmp``)."""
    output = Path(output)
    for p in (output, output.with_name(output.name + ".tmp")):
        with contextlib.suppress(OSError):
            p.unlink()


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, 9)
    except (AttributeError, ProcessLookupError, PermissionError):
        proc.kill()
