"""The run's record on disk: the resolved config, the manifest (merged for stage commands, stale files named) and the instruction sheet."""

from __future__ import annotations

import logging
import platform
from pathlib import Path
from typing import Any

import yaml

from .. import __version__
from ..command_table import command as command_named
from ..config import JobConfig
from ..output import MANIFEST, OutputDir, manifest_header
from ..plan.names import CONFIG_COPY, INSTRUCTIONS, LATER_STAGES, PLAN_JSON, STAGE_FILES
from ..plan.plan import Plan
from ..plan.saved import saved_config
from ..record import Run

log = logging.getLogger(__name__)


def save_config(run: Run, plan: Plan) -> None:
    """Write ``plan``'s config (the config as the job resolved it) beside the results, so stage commands can re-read it."""
    # Absolute paths, so the copy runs from anywhere.
    run.out.write_text(CONFIG_COPY, yaml.safe_dump(saved_config(plan.cfg), sort_keys=False))


def finish(run: Run, plan: Plan, command: str, plan_text: str | None = None) -> list[Path]:
    """Write the manifest (its config: ``plan``'s) and move every file into place.

    The run's figures are written as they stand: the orchestrator records figure ``compute``'s
    task count first (:func:`stencil_cad.pipeline.recorder.record_tasks`).

    ``plan_text``: the job's saved plan (:func:`stencil_cad.plan.saved.plan_json`), or None. Like the
    manifest it is the folder's record, not a file the maker uses: it is written after the
    instruction sheet, whose file list it stays out of.
    """
    cfg = plan.cfg
    whole = command_named(command).whole
    sheet = whole and cfg.export.instructions
    if plan_text is not None and not sheet:
        run.out.write_text(PLAN_JSON, plan_text)
    manifest = {
        **manifest_header(),
        "command": command,
        "stencil_cad": __version__,
        "versions": _versions(),
        "config": cfg.model_dump(mode="json"),
        "seconds": run.times,
        **run.figures.to_json(),
        "files": run.out.file_table(),
    }
    if run.template is not None:
        manifest["template"] = run.template
    old_path = run.out.path / MANIFEST
    if not whole and old_path.exists():
        manifest = _merge_manifest(old_path, manifest, run.out)
        run.stale = manifest.get("stale", {}).get("files", [])
    if sheet:
        with run.stage("instructions"):
            write_instructions(run, cfg, manifest)
        if plan_text is not None:
            run.out.write_text(PLAN_JSON, plan_text)
        manifest["seconds"] = run.times
        manifest["files"] = run.out.file_table()
    run.out.write_json(MANIFEST, manifest)
    return run.out.commit()


def write_instructions(
    run: Run, cfg: JobConfig, manifest: dict[str, Any], tiles: list[Any] | None = None
) -> None:
    """Write the instruction sheet (HTML and PDF) from the run's figures and the job's preview images.

    Args:
        run: The command's state; its staged PNGs and ``sheet_images`` are the pictures.
        cfg: The job's planned config (the settings the sheet reads).
        manifest: The manifest as it will be written (its file list so far).
        tiles: A mural's tiles for the map (see :func:`stencil_cad.instructions.sheet_from_manifest`);
            None takes the mural's.
    """
    from .. import instructions

    names = {str(row["name"]) for row in manifest.get("files", [])} | set(INSTRUCTIONS)
    settings = instructions.JobSettings.from_config(cfg)
    data = instructions.sheet(run.figures, settings, names, tiles=tiles)
    images = dict(run.sheet_images)
    for name in run.out.files:
        if name.endswith(".png"):
            images[name] = (run.out.stage / name).read_bytes()
    run.out.write_text(INSTRUCTIONS[0], instructions.render_html(data, images))
    run.out.write_bytes(INSTRUCTIONS[1], instructions.render_pdf(data, images))


def _merge_manifest(old_path: Path, new: dict[str, Any], out: OutputDir) -> dict[str, Any]:
    """A stage command adds its figures and files to the folder's existing manifest."""
    from ..output import read_manifest

    old = read_manifest(old_path)
    if old is None:
        return new
    merged = {**old, **{k: v for k, v in new.items() if k not in ("seconds", "files")}}
    merged.update(manifest_header())
    merged["command"] = f"{old.get('command', '?')} + {new['command']}"
    merged["seconds"] = {**old.get("seconds", {}), **new["seconds"]}
    written = {row["name"] for row in new["files"]}
    kept = [
        row
        for row in old.get("files", [])
        if isinstance(row, dict)
        and row.get("name") not in written
        and (out.path / str(row.get("name"))).is_file()
    ]
    merged["files"] = kept + new["files"]
    merged.pop("stale", None)
    stale = stale_files(new["command"], [str(r["name"]) for r in kept], old.get("stale"), written)
    if stale:
        later = ", ".join(f"`stencil-cad {c}`" for c in LATER_STAGES.get(new["command"], ()))
        merged["stale"] = {
            "files": stale,
            "why": f"made before `stencil-cad {new['command']}` ran again; re-run {later or 'them'} (or `stencil-cad run`)",
        }
    return merged


def stale_files(command: str, kept: list[str], earlier: object, written: set[str]) -> list[str]:
    """Files left in a folder that a re-run of ``command`` made out of date.

    Args:
        command: The stage command that just ran.
        kept: Names of the files it left in place.
        earlier: The manifest's ``stale`` record before this run (its files stay stale).
        written: Names this run wrote (no longer stale).

    Returns:
        Sorted names: files of later stages (and the instruction sheet, which shows every stage).
    """
    import fnmatch

    before = set(earlier.get("files", [])) if isinstance(earlier, dict) else set()
    stages = (*LATER_STAGES.get(command, ()), "instructions")
    now = {n for n in kept if any(fnmatch.fnmatch(n, p) for s in stages for p in STAGE_FILES[s])}
    return sorted(((before & set(kept)) | now) - written)


def _versions() -> dict[str, Any]:
    from importlib.metadata import PackageNotFoundError, version

    out: dict[str, str | None] = {"python": platform.python_version()}
    for dist in ("build123d", "cadquery-ocp", "numpy", "scipy", "scikit-image", "ezdxf", "numba"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    out["OCP"] = out.pop("cadquery-ocp")
    return out
