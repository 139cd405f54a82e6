"""The `stencil-cad` command: run a whole job, or one stage on saved intermediates."""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

from . import __version__, interrupts
from .command_table import COMMANDS
from .command_table import command as command_named
from .errors import ConfigError, UserError
from .names import CARD_JSON, CONFIG_COPY, INIT_CONFIG, SPRAY_PROFILE_YAML
from .runtime import tune_process

log = logging.getLogger("stencil_cad")

EXAMPLE_OUT = Path("output") / "example"


def _card_args(sp: argparse.ArgumentParser) -> None:
    """``card`` writes the calibration card."""
    sp.add_argument(
        "config", nargs="?", type=Path, help="job config YAML whose holes, plate and wall the card uses"
    )
    sp.add_argument(
        "--out", type=Path, default=Path("output") / "card", help="output folder (default: output/card)"
    )
    sp.add_argument(
        "--standoff",
        type=float,
        action="append",
        metavar="MM",
        help="stand-off of a wall to measure (repeatable, up to 3; default: the job's, plus a 3 mm wall if only one)",
    )
    sp.add_argument(
        "--paper",
        choices=("a4", "letter"),
        default="a4",
        help="paper the sheet and its steps are printed on (default: a4)",
    )
    sp.add_argument("--force", action="store_true", help="replace files in a non-empty output folder")
    g = sp.add_mutually_exclusive_group()
    g.add_argument("-v", "--verbose", action="store_true", help="log each step; show tracebacks")
    g.add_argument("-q", "--quiet", action="store_true", help="no summary")


def _calibrate_args(sp: argparse.ArgumentParser) -> None:
    """``calibrate`` measures a can from a photo of the sprayed card."""
    sp.add_argument(
        "photo", type=Path, help="photo (JPEG/PNG) of the sprayed card sheet, all markers in view"
    )
    sp.add_argument("--card", type=Path, required=True, help="the card.json that `stencil-cad card` wrote")
    sp.add_argument("--passes", type=float, help="passes sprayed over the card (default: the card's, 4)")
    sp.add_argument(
        "--distance-mm",
        type=float,
        default=None,
        help="can distance from the plate in mm (default: card.json's)",
    )
    sp.add_argument("--speed", type=float, default=None, help="sweep speed in m/s (default: card.json's)")
    sp.add_argument("--paint", default="", help="can, cap and paint, recorded in the profile")
    sp.add_argument(
        "--out",
        type=Path,
        default=Path(SPRAY_PROFILE_YAML),
        help="profile to write (default: spray_profile.yaml)",
    )
    sp.add_argument("--force", action="store_true", help="replace an existing profile")
    sp.add_argument("-v", "--verbose", action="store_true", help="log each step; show tracebacks")


def _studio_args(sp: argparse.ArgumentParser) -> None:
    """``studio``: the local web page."""
    sp.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default: 127.0.0.1, this machine only; any other lets others in: a warning)",
    )
    sp.add_argument("--port", type=int, default=0, help="port to listen on (default: 0, a free one)")
    sp.add_argument(
        "--workspace",
        type=Path,
        help="folder the studio keeps uploads and jobs in (default: stencil_cad/studio in your cache folder)",
    )
    sp.add_argument(
        "--workspace-gb",
        type=float,
        default=2.0,
        help="most the workspace may hold, in GB; the oldest jobs and pictures go first (default: 2)",
    )
    sp.add_argument("--no-browser", action="store_true", help="do not open the page in the browser")
    sp.add_argument("-v", "--verbose", action="store_true", help="log each step; show tracebacks")


_DRY_RUN_HELP = (
    "print the plan and what making it costs (printer-hours, filament, laser, paint); write nothing"
)


def _job_args(sp: argparse.ArgumentParser, with_from: bool = False, dry_run: bool = False) -> None:
    """The arguments every job command takes (``--from`` for a stage command, ``--dry-run`` for ``run``)."""
    sp.add_argument("config", nargs="?", type=Path, help="job config YAML (default: the bundled example)")
    sp.add_argument("--image", type=Path, help="input image (overrides the config's `image`)")
    sp.add_argument("--out", type=Path, help="output folder (default: output/<name>, or output/example)")
    sp.add_argument("--force", action="store_true", help="replace files in a non-empty output folder")
    sp.add_argument("--seed", type=int, help="random seed (overrides the config's `seed`)")
    sp.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local Dask cluster of N worker processes; 0: in this process (default: one per core, "
        "for big jobs only; overrides compute.workers)",
    )
    sp.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the tasks on the Dask cluster whose scheduler is at ADDRESS, e.g. tcp://host:8786 "
        "(overrides compute.scheduler)",
    )
    sp.add_argument(
        "--bed",
        help="print or laser bed every part must fit: a preset (prusa_mk4, bambu_x1c, xtool_s1, …) or XxY "
        "in mm (e.g. 250x210); overrides the config's `bed`",
    )
    if with_from:
        sp.add_argument(
            "--from", dest="src", type=Path, help="folder with the saved intermediates (default: --out)"
        )
    if dry_run:
        sp.add_argument("--dry-run", action="store_true", help=_DRY_RUN_HELP)
    g = sp.add_mutually_exclusive_group()
    g.add_argument("-v", "--verbose", action="store_true", help="log each step; show tracebacks")
    g.add_argument("-q", "--quiet", action="store_true", help="no progress bars or summary")


def _stage_args(sp: argparse.ArgumentParser) -> None:
    """A stage command's arguments: a job's, with ``--from``."""
    _job_args(sp, with_from=True)


def _run_args(sp: argparse.ArgumentParser) -> None:
    """``run``'s arguments: a job's, with ``--dry-run``."""
    _job_args(sp, dry_run=True)


def _slice_args(sp: argparse.ArgumentParser) -> None:
    """``slice``: exported plate STLs through a shipped print profile."""
    sp.add_argument("stl", nargs="+", type=Path, help="plate STL files (e.g. output/example/layer_01.stl)")
    sp.add_argument(
        "--profile",
        default="prusa_fdm",
        choices=["prusa_fdm", "prusa_sla", "cura_fdm"],
        help="print profile from templates/ (default: prusa_fdm, tiled above ~450 holes)",
    )
    sp.add_argument(
        "--timeout", type=float, default=900.0, help="seconds per plate before giving up (default 900)"
    )
    sp.add_argument(
        "--project",
        action="store_true",
        help="write a PrusaSlicer 3MF project per plate (tiles and every setting inside) instead of slicing",
    )
    sp.add_argument(
        "--bed", help="the printer's bed (preset such as prusa_mk4, or XxY mm) instead of the profile's"
    )
    sp.add_argument("--force", action="store_true", help="replace existing G-code / .sl1 / .3mf files")
    sp.add_argument(
        "-v", "--verbose", action="store_true", help="show the slicer's log on failure; tracebacks"
    )


def _init_args(sp: argparse.ArgumentParser) -> None:
    """``init``: where to write the commented config."""
    sp.add_argument(
        "path", nargs="?", type=Path, default=Path(INIT_CONFIG), help="where (default: stencil.yaml)"
    )
    sp.add_argument("--force", action="store_true", help="replace an existing file")


def _no_args(sp: argparse.ArgumentParser) -> None:
    """A command without arguments."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="stencil-cad",
        description="Turn an image into spray-paint stencils to 3D-print or laser-cut.",
    )
    p.add_argument("--version", action="version", version=f"stencil-cad {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for command in COMMANDS:
        setup, _ = _CLI[command.name]
        setup(sub.add_parser(command.name, help=command.help))
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of `stencil-cad`; returns the exit code."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    # The process runs commands of ours: its collector and allocator are tuned for a job (runtime.py).
    tune_process()
    verbose = getattr(args, "verbose", False)
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s"
        if verbose
        else "stencil-cad: %(levelname)s: %(message)s",
        stream=sys.stderr,
    )
    if verbose:
        logging.getLogger("stencil_cad").setLevel(logging.DEBUG)
        # Third-party debug chatter (image decoders, font parsing) drowns our own steps.
        for noisy in ("PIL", "fontTools", "numba", "matplotlib", "ezdxf"):
            logging.getLogger(noisy).setLevel(logging.WARNING)
    try:
        with interrupts.as_interrupts():
            return _dispatch(args)
    except UserError as exc:
        if verbose:
            log.exception("failed")
        print(f"stencil-cad: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # Output piped into `head` and the like: not an error of ours.
        sys.stderr.close()
        return 0
    except KeyboardInterrupt as exc:
        signum = exc.signum if isinstance(exc, interrupts.Interrupted) else int(signal.SIGINT)
        name = signal.Signals(signum).name
        print(f"stencil-cad: interrupted ({name}); no partial outputs were kept", file=sys.stderr)
        return 128 + signum
    except OSError as exc:
        # An OS condition no more specific handler turned into a message: still the user's to fix.
        from .output import os_error_message

        if verbose:
            log.exception("failed")
        print(f"stencil-cad: error: {os_error_message(exc, 'cannot use', None)}", file=sys.stderr)
        return 2
    except Exception as exc:  # noqa: BLE001 - the top level reports any failure cleanly
        if verbose:
            raise
        print(
            f"stencil-cad: internal error: {type(exc).__name__}: {exc} (run again with -v for the traceback "
            "and report it; no partial outputs were kept)",
            file=sys.stderr,
        )
        return 1


def _dispatch(args) -> int:
    _, handler = _CLI[args.command]
    return handler(args)


def _schema(args) -> int:
    from .config import io as cfg_io

    print(json.dumps(cfg_io.json_schema(), indent=2))
    return 0


def _init(args) -> int:
    from .pipeline.commands import write_default_config

    write_default_config(args.path, force=args.force)
    print(f"wrote {args.path}; edit it, then: stencil-cad run {args.path}")
    return 0


def _slice(args) -> int:
    from collections import Counter

    from . import pipeline
    from .instructions.make import hours_text as _hours

    if args.project:
        return _projects(args)
    failed = 0
    from .config.bed import parse_bed_arg

    bed = parse_bed_arg(args.bed) if args.bed else None
    hours = metres = resin = 0.0
    estimated = 0
    for stl, out, result in pipeline.slice_plates(
        args.stl, args.profile, force=args.force, timeout_s=args.timeout, bed=bed
    ):
        if result.ok:
            turned = ", turned 90° to fit the bed" if result.rotate_deg else ""
            est = pipeline.print_estimate(out)
            said = ""
            if est.print_s is not None:
                estimated += 1
                hours += est.print_s / 3600.0
                metres += est.filament_m or 0.0
                resin += est.resin_ml or 0.0
                said = f"; prints in about {_hours(est.print_s / 3600.0)}"
                if est.filament_m is not None:
                    said += f" with {est.filament_m:.1f} m of filament"
                elif est.resin_ml is not None:
                    said += f" with {est.resin_ml:.1f} ml of resin"
            print(
                f"{out}: {result.output_bytes} bytes in {result.seconds:.1f} s ({args.profile}{turned}){said}"
            )
            # PrusaSlicer repeats some log lines once per tile or island: say each once, with a count.
            for w, n in Counter(result.warnings).items():
                print(f"  warning   slicer: {w[:300]}" + (f" ({n} times)" if n > 1 else ""))
        else:
            failed += 1
            why = "timed out" if result.timed_out else "; ".join(result.errors) or f"exit {result.returncode}"
            print(f"stencil-cad: error: slicing {stl} failed: {why[:500]}", file=sys.stderr)
            if args.verbose:
                print(result.log, file=sys.stderr)
    if estimated > 1:
        used = f"{resin:.1f} ml of resin" if resin and not metres else f"{metres:.1f} m of filament"
        print(f"total: {estimated} parts print in about {_hours(hours)} with {used}")
    return 1 if failed else 0


def _card(args) -> int:
    from . import api
    from .config import io as cfg_io

    cfg = cfg_io.load_config(args.config) if args.config is not None else cfg_io.parse_config({}, "defaults")
    if args.standoff:
        from pydantic import ValidationError

        from .config import WallConfig

        try:  # the wall's own rule for a stand-off
            WallConfig(standoff_mm=args.standoff)
        except ValidationError as exc:
            raise UserError(f"--standoff: {exc.errors()[0]['msg']}, got {args.standoff}") from None
        if len(set(args.standoff)) > 3:
            raise UserError(f"the card takes at most 3 stand-offs, got {len(set(args.standoff))}")
    t0 = time.perf_counter()
    result = api.make_card(
        cfg, args.out, standoffs_mm=args.standoff, paper=args.paper, force=args.force, quiet=args.quiet
    )
    files = result.files
    if not args.quiet:
        c = result.figures.card or {}
        ok = c["plate"].get("valid") and all(w.get("valid") for w in c["walls"])
        print(
            f"stencil-cad: calibration card → {args.out}/ ({len(files)} files, {time.perf_counter() - t0:.1f} s)\n"
            f"  plate     {c['plate_mm'][0]:g} × {c['plate_mm'][1]:g} mm, {c['holes']} holes, "
            f"{'valid' if ok else 'INVALID'}; walls at {', '.join(f'{g:g}' for g in c['standoffs_mm'])} mm\n"
            f"  sheet     card_sheet.pdf, {c['sheet_mm'][0]:g} × {c['sheet_mm'][1]:g} mm on {c['paper']} with the "
            "steps: print at 100 %\n"
            f"  then      spray the card {c['passes']} passes in each wall on the sheet, photograph it "
            f"(docs/guides/spraying.md, 'Measuring your can') and run: stencil-cad calibrate PHOTO --card {args.out / CARD_JSON}"
        )
    return 0


def _calibrate(args) -> int:
    from . import api

    print(
        api.calibrate(
            args.photo,
            args.card,
            args.out,
            passes=args.passes,
            distance_mm=args.distance_mm,
            speed_m_s=args.speed,
            paint=args.paint,
            force=args.force,
        )[1]
    )
    return 0


def _studio(args) -> int:
    from . import studio

    if args.workspace_gb <= 0:
        raise UserError(f"--workspace-gb must be more than 0, got {args.workspace_gb:g}")
    if not 0 <= args.port <= 65535:
        raise UserError(f"--port must be 0 (a free port) to 65535, got {args.port}")
    try:
        studio.serve(
            host=args.host,
            port=args.port,
            workspace=args.workspace,
            cap_bytes=int(args.workspace_gb * 1e9),
            open_browser=not args.no_browser,
            say=lambda line: print(line, flush=True),
        )
    except OSError as exc:
        if exc.errno is None:
            raise
        raise UserError(
            f"cannot listen on {args.host}:{args.port}: {exc.strerror} (choose another --port or --host)"
        ) from None
    return 0


def _projects(args) -> int:
    """`slice --project`: one PrusaSlicer 3MF project per plate, written whole or not at all."""
    from . import pipeline
    from .config.bed import parse_bed_arg

    failed = 0
    bed = parse_bed_arg(args.bed) if args.bed else None
    for stl, out, error in pipeline.plate_projects(
        args.stl, args.profile, force=args.force, timeout_s=args.timeout, bed=bed
    ):
        if error is None:
            print(f"{out}: PrusaSlicer project with the {args.profile} settings")
        else:
            failed += 1
            print(f"stencil-cad: error: writing the project of {stl} failed: {error}", file=sys.stderr)
    return 1 if failed else 0


def _load_job(args):
    from . import api

    src = getattr(args, "src", None)
    config_path = args.config
    command = command_named(args.command)
    if config_path is None and command.job and not command.whole:
        # A stage command in a run's folder uses the folder's config (the docs' promise).
        folder = src or args.out
        if folder is not None and (folder / CONFIG_COPY).exists():
            config_path = folder / CONFIG_COPY
    if config_path is None and args.image is None and command.from_picture:
        # No config and no image: the bundled example job (api.load_config's default).
        source = None
    else:
        source = config_path if config_path is not None else {}
    from .config.bed import parse_bed_arg

    bed = parse_bed_arg(args.bed) if getattr(args, "bed", None) else None
    cfg = api.load_config(source, image=args.image, seed=args.seed, hard=command.hard, bed=bed)
    if args.out is not None:
        out = args.out
    elif args.config is None and args.image is None:
        out = EXAMPLE_OUT
    else:
        out = Path("output") / cfg.name.replace(" ", "_")
    return cfg, out


def _job(args) -> int:
    from . import api
    from .config.compute import with_command_line

    cfg, out_path = _load_job(args)
    if getattr(args, "dry_run", False):
        print("\n".join(api.dry_run(cfg)))
        return 0
    where = with_command_line(cfg.compute, args.workers, args.scheduler)
    src = (args.src or out_path) if args.command in api.SAVED_STAGES else None
    announce = None if args.quiet else (lambda line: print(line, file=sys.stderr))
    result = api.run(
        cfg,
        out_path,
        command=args.command,
        src=src,
        force=args.force,
        quiet=args.quiet,
        where=where,
        announce=announce,
    )
    if not args.quiet:
        print(result.summary())
    return 0


#: Each command's arguments and the function that runs it (its name and help: :data:`COMMANDS`).
_CLI: dict[str, tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {
    "run": (_run_args, _job),
    "decompose": (_job_args, _job),
    "stipple": (_stage_args, _job),
    "build": (_stage_args, _job),
    "simulate": (_stage_args, _job),
    "hard": (_job_args, _job),
    "slice": (_slice_args, _slice),
    "card": (_card_args, _card),
    "calibrate": (_calibrate_args, _calibrate),
    "studio": (_studio_args, _studio),
    "init": (_init_args, _init),
    "schema": (_no_args, _schema),
}


if __name__ == "__main__":
    sys.exit(main())

__all__ = ["main", "ConfigError"]
