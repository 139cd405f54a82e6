"""The commands of ``stencil-cad``, in one table: each one's name, its help and what it does.

The command line builds its parser and help from this table (``cli.py`` adds each command's
arguments and the function that runs it), the public API takes its job commands from it, and
the orchestrator asks a command what it does (starts from the picture, runs one saved stage,
builds plates …) instead of comparing its name.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["COMMANDS", "Command", "JOB_COMMANDS", "SAVED_STAGES", "command"]


@dataclass(frozen=True)
class Command:
    """One command of ``stencil-cad``.

    Attributes:
        name: What the user types, e.g. ``run``.
        help: Its one-line help, as ``stencil-cad --help`` lists it.
        job: It runs a job (:func:`stencil_cad.api.run`): a config and an output folder.
        whole: It runs every stage into a fresh folder, replaces the manifest and writes the
            instruction sheet (``run``, ``hard``).
        hard: Hard-stencil mode.
        from_picture: It starts from the picture (the bundled example when given neither config
            nor image).
        saved: It runs one stage on the intermediates a run saved (``--from``).
        stipples: It places the holes.
        builds: It builds plates (the plate template is checked before any work).
        simulates: It sprays the plates in simulation.
    """

    name: str
    help: str
    job: bool = False
    whole: bool = False
    hard: bool = False
    from_picture: bool = False
    saved: bool = False
    stipples: bool = False
    builds: bool = False
    simulates: bool = False

    @property
    def reads_picture(self) -> bool:
        """It loads the picture (a saved stage goes on without it when the image is gone)."""
        return self.from_picture or (self.saved and (self.stipples or self.simulates))

    @property
    def reads_dots(self) -> bool:
        """It reads the holes a run saved."""
        return self.saved and not self.stipples


#: Every command, in the order ``stencil-cad --help`` lists them.
COMMANDS: tuple[Command, ...] = (
    Command(
        "run",
        "run the whole job: decompose, stipple, build, simulate",
        job=True,
        whole=True,
        from_picture=True,
        stipples=True,
        builds=True,
        simulates=True,
    ),
    Command(
        "decompose",
        "decompose the image into primer + paint layers (layers.npz)",
        job=True,
        from_picture=True,
    ),
    Command(
        "stipple", "stipple saved layers into holes (layer_NN_dots.csv)", job=True, saved=True, stipples=True
    ),
    Command(
        "build", "build plates and wall from saved dots (STEP, STL, DXF)", job=True, saved=True, builds=True
    ),
    Command(
        "simulate",
        "spray saved dots in simulation and score the result",
        job=True,
        saved=True,
        simulates=True,
    ),
    Command(
        "hard",
        "hard-stencil mode: flat colours, cut-outs held by bridges",
        job=True,
        whole=True,
        hard=True,
        from_picture=True,
        builds=True,
        simulates=True,
    ),
    Command("slice", "slice exported plate STLs with a shipped print profile"),
    Command(
        "card", "write the calibration card: a test plate, its wall(s), the sheet to spray it on, card.json"
    ),
    Command("calibrate", "measure a can from a photo of the sprayed calibration card; write a spray profile"),
    Command("studio", "open the studio: a local web page that previews the sprayed result as you choose"),
    Command("init", "write a commented config file"),
    Command("schema", "print the config's JSON Schema (for editor completion)"),
)
_BY_NAME = {c.name: c for c in COMMANDS}

#: The commands that run a job: the whole ones first (``run``, ``hard``), then the stages.
JOB_COMMANDS: tuple[str, ...] = tuple(c.name for c in COMMANDS if c.whole) + tuple(
    c.name for c in COMMANDS if c.job and not c.whole
)
#: The stages run on a run's saved intermediates.
SAVED_STAGES: tuple[str, ...] = tuple(c.name for c in COMMANDS if c.saved)


def command(name: str) -> Command:
    """The command called ``name``.

    Raises:
        KeyError: No command has that name.
    """
    return _BY_NAME[name]
