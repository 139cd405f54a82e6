"""The public Python API: what the command line and the studio call, and what a script or notebook calls.

Load a config (a YAML file, a mapping or the bundled example), run the whole job or one stage into an
output folder, and get typed results back: the run's :class:`~stencil_cad.figures.Figures`, the
simulated picture and the files written. A job reports each stage as it starts and ends
(``progress``) and stops at the next stage edge or progress step once its
:class:`~stencil_cad.interrupts.CancelToken` is cancelled, leaving nothing in the output folder.
:func:`previews` shows in seconds what a config sprays, without writing anything.

Example::

    from stencil_cad import api

    cfg = api.load_config(None, overrides={"decompose": {"layers": 3}})
    for p in api.previews(cfg):
        print(p.level, round(p.scielab, 2))
    result = api.run(cfg, "output/three_layers", progress=lambda event, stage: print(event, stage))
    print(result.figures.simulate.scielab, result.simulated().shape)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .command_table import JOB_COMMANDS
from .command_table import SAVED_STAGES as _SAVED_STAGES
from .config import ComputeConfig, JobConfig
from .interrupts import Cancelled, CancelToken
from .names import SIMULATED_PNG

if TYPE_CHECKING:
    from .figures import Figures
    from .pipeline.preview import Preview, PreviewCache
    from .testcard.fit import CardFit

#: The commands :func:`run` takes: the whole job, hard mode, and the stages run on saved intermediates.
COMMANDS = JOB_COMMANDS
#: The stages that read a run's saved intermediates (``src``).
SAVED_STAGES = _SAVED_STAGES

#: Called ``(event, stage)``: event ``"start"`` or ``"done"``, stage a name such as ``"decompose"``.
Progress = Callable[[str, str], None]


@dataclass(frozen=True)
class JobResult:
    """What a job made.

    Attributes:
        command: The command run (``run``, ``hard``, a stage).
        cfg: The config as the job resolved it (the plate design and thickness it chose).
        out: The output folder.
        files: The files written, in the output folder.
        figures: What each stage recorded (the manifest's sections, typed).
        times: Seconds per stage, and ``total``.
    """

    command: str
    cfg: JobConfig
    out: Path
    files: tuple[Path, ...]
    figures: Figures
    times: dict[str, float]
    _run: Any

    def simulated(self) -> np.ndarray | None:
        """The simulated sprayed picture, ``(H, W, 3)`` ndarray of float in [0, 1]; None if the job did not spray."""
        path = self.out / SIMULATED_PNG
        if not path.is_file():
            return None
        from PIL import Image

        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"), dtype=np.float64) / 255.0

    def summary(self) -> str:
        """The summary the command line prints: files, holes, checks, quality, time per stage."""
        from . import report

        return report.summary(self._run, list(self.files), self.out)


def load_config(
    source: Path | str | Mapping[str, Any] | JobConfig | None = None,
    *,
    overrides: Mapping[str, Any] | None = None,
    image: Path | str | None = None,
    seed: int | None = None,
    bed: str | tuple[float, float] | None = None,
    hard: bool = False,
) -> JobConfig:
    """A checked job config.

    Args:
        source: A YAML file, a mapping with the keys of one (relative paths in it are taken from the
            working folder), a config, or None for the bundled example.
        overrides: Keys to change, nested like the YAML (``{"decompose": {"layers": 3}}``); checked
            like the file's.
        image: The input image instead of the config's (``--image``).
        seed: The random seed instead of the config's (``--seed``).
        bed: The bed every part must fit (a preset name or ``(x_mm, y_mm)``; ``--bed``).
        hard: Hard-stencil mode (the ``hard`` command).

    Returns:
        The validated config.

    Raises:
        ConfigError: The file cannot be read, or a key or value is wrong (the message names the
            dotted path, the value and what is allowed).
    """
    from .config import io as cfg_io
    from .config import parse_overrides
    from .imaging import example_config_path

    if isinstance(source, JobConfig):
        cfg = source
    elif isinstance(source, Mapping):
        # Relative paths in a mapping (image, can lists, template, spray profiles) are the working folder's.
        data = dict(source)
        cfg = cfg_io.resolve_files(cfg_io.parse_config(data, source="config"), data, Path.cwd())
    else:
        cfg = cfg_io.load_config(example_config_path() if source is None else Path(source))
    if overrides:
        # What the maker left null stays null for the changed config (a wall left to the job stays the
        # job's to choose; the plan fills the label, margin, thickness and web in for the new size).
        data = _merged(cfg.unfilled_data(), overrides)
        cfg = cfg_io.resolve_files(cfg_io.parse_config(data, source="config"), data, Path.cwd())
    if image is not None or seed is not None or bed is not None or hard:
        cfg = parse_overrides(
            cfg, image=None if image is None else Path(image), seed=seed, hard=hard, bed=bed
        )
    return cfg


def _merged(base: dict[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in changes.items():
        if isinstance(v, Mapping) and isinstance(out.get(k), dict):
            out[k] = _merged(out[k], v)
        else:
            out[k] = v
    return out


def run(
    cfg: JobConfig,
    out: Path | str,
    *,
    command: str = "run",
    src: Path | str | None = None,
    force: bool = False,
    quiet: bool = True,
    where: ComputeConfig | None = None,
    announce: Callable[[str], None] | None = None,
    progress: Progress | None = None,
    cancel: CancelToken | None = None,
) -> JobResult:
    """Run a whole job (``run``, ``hard``) or one stage on a folder's saved intermediates.

    Everything that can be checked is checked before the first stage; the files land in ``out``
    all at once, or not at all (an error, a signal or a cancel leaves the folder as it was).

    Args:
        cfg: The job config (:func:`load_config`).
        out: The output folder.
        command: One of :data:`COMMANDS`.
        src: Folder whose intermediates a stage command reads. Defaults to ``out``.
        force: Replace the files stencil-cad wrote earlier in the folder.
        quiet: No progress bars.
        where: Where the tasks run (the ``compute`` section with the command line's flags). Defaults
            to the config's.
        announce: Told one line saying what the job will cost, before any work.
        progress: Told ``(event, stage)`` as each stage starts and ends.
        cancel: Cancels the run at its next check; the run then raises
            :class:`~stencil_cad.interrupts.Cancelled`.

    Returns:
        The job's :class:`JobResult`.

    Raises:
        UserError: A problem the user can fix (the message names it and the fix).
        Cancelled: ``cancel`` was cancelled.
    """
    from .pipeline import run as pipeline_run

    if command not in COMMANDS:
        raise ValueError(f"command must be one of {', '.join(COMMANDS)}, got {command!r}")
    out = Path(out)
    r, resolved, files = pipeline_run.run_command(
        command,
        cfg,
        out,
        src=None if src is None else Path(src),
        force=force,
        quiet=quiet,
        where=where,
        announce=announce,
        progress=progress,
        cancel=cancel,
    )
    return JobResult(command, resolved, out, tuple(files), r.figures, dict(r.times), r)


def run_stage(stage: str, cfg: JobConfig, out: Path | str, **kwargs: Any) -> JobResult:
    """One stage (``decompose``, ``stipple``, ``build``, ``simulate``) on a folder's saved intermediates.

    Takes the keyword arguments of :func:`run`.
    """
    if stage not in COMMANDS[2:]:
        raise ValueError(f"stage must be one of {', '.join(COMMANDS[2:])}, got {stage!r}")
    return run(cfg, out, command=stage, **kwargs)


def dry_run(cfg: JobConfig) -> list[str]:
    """The plan and what making it costs, from the config and the image alone; nothing is written."""
    from . import pipeline

    return pipeline.dry_run(cfg)


def previews(
    cfg: JobConfig, cache: PreviewCache | None = None, cancel: CancelToken | None = None
) -> Iterator[Preview]:
    """Fast previews of what ``cfg`` sprays, coarse first (see :mod:`stencil_cad.pipeline.preview`).

    Args:
        cfg: The job config (soft mode).
        cache: What earlier previews computed (:func:`preview_cache`); None keeps nothing.
        cancel: Stops the previews at the next check.

    Yields:
        One :class:`~stencil_cad.pipeline.preview.Preview` per level, each better than the last.
    """
    from .pipeline import preview

    return preview.previews(cfg, cache, cancel)


def preview(cfg: JobConfig, cache: PreviewCache | None = None) -> Preview:
    """The best preview of ``cfg`` (the last of :func:`previews`)."""
    *_, last = previews(cfg, cache)
    return last


def preview_cache() -> PreviewCache:
    """A bounded cache of decompositions and hole sets to share between previews of nearby settings."""
    from .pipeline.preview import PreviewCache

    return PreviewCache()


def make_card(
    cfg: JobConfig,
    out: Path | str,
    *,
    standoffs_mm: list[float] | None = None,
    paper: str = "a4",
    force: bool = False,
    quiet: bool = True,
) -> JobResult:
    """Write the calibration card for ``cfg``'s holes, plate and wall: the plate, its walls, the sheet, ``card.json``.

    Args:
        cfg: The job whose holes, plate and wall the card uses.
        out: The output folder (written all at once, or not at all).
        standoffs_mm: The walls' stand-offs to measure (up to 3); defaults to the job's, plus 3 mm.
        paper: ``a4`` or ``letter``: the paper the sheet is printed on.
        force: Replace the files stencil-cad wrote earlier in the folder.
        quiet: No progress bars.

    Returns:
        The card's :class:`JobResult` (its figures' ``card`` section says what it holds).
    """
    import time

    from .output import OutputDir
    from .pipeline.commands import run_card
    from .record import Run

    folder = OutputDir(Path(out), force=force)
    r = Run(cfg=cfg, out=folder, quiet=quiet)
    t0 = time.perf_counter()
    try:
        files = run_card(r, standoffs_mm, paper)
    except BaseException:
        folder.abort()
        raise
    r.times["total"] = round(time.perf_counter() - t0, 3)
    return JobResult("card", r.cfg, Path(out), tuple(files), r.figures, dict(r.times), r)


def calibrate(
    photo: Path | str,
    card: Path | str,
    out: Path | str,
    *,
    passes: float | None = None,
    distance_mm: float | None = None,
    speed_m_s: float | None = None,
    paint: str = "",
    force: bool = False,
) -> tuple[CardFit, str]:
    """Measure a can from a photo of the sprayed card and write its spray profile (``stencil-cad calibrate``).

    Args:
        photo: The photo of the sprayed card sheet, every marker in view.
        card: The ``card.json`` :func:`make_card` wrote.
        out: The spray profile to write (YAML; a job's ``spray.profile``).
        passes: Passes sprayed over the card (default: the card's).
        distance_mm: The can's distance from the plate, mm (default: the card's).
        speed_m_s: Sweep speed, m/s (default: the card's).
        paint: The can, cap and paint, recorded in the profile.
        force: Replace an existing profile.

    Returns:
        ``(fit, report)``: the fitted constants with the residual and markers found, and the one-line report.

    Raises:
        UserError: A bad card file, a photo that cannot be read or fitted (the reason named), an existing profile.
    """
    from .testcard import fit

    return fit.calibrate(
        Path(photo),
        Path(card),
        Path(out),
        passes=passes,
        distance_mm=distance_mm,
        speed_m_s=speed_m_s,
        paint=paint,
        force=force,
    )


def check_image(path: Path | str, cfg: JobConfig | None = None) -> tuple[int, int]:
    """Read an image as a job of ``cfg`` reads its input, and return the working picture's ``(width, height)`` in px.

    Args:
        path: The image file.
        cfg: The job it is for (its size and resolution decide how much of the file is decoded and
            whether it has enough pixels); defaults to the bundled example's.

    Raises:
        ImageError: The message a job gives for the same file (missing, not an image, too large, …).
    """
    from . import pipeline

    job = load_config(cfg, image=path)
    pic = pipeline.load_picture(job)
    return int(pic.shape[1]), int(pic.shape[0])


__all__ = [
    "COMMANDS",
    "SAVED_STAGES",
    "CancelToken",
    "Cancelled",
    "JobResult",
    "Progress",
    "calibrate",
    "check_image",
    "make_card",
    "dry_run",
    "load_config",
    "preview",
    "preview_cache",
    "previews",
    "run",
    "run_stage",
]
