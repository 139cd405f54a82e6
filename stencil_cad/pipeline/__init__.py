"""The orchestrator: calls the stages in order, reports progress, writes through :mod:`stencil_cad.output`.

Stages are pure functions; this package is the only one that knows their order
(:mod:`.run`), which intermediates a stage command reads back (:mod:`.saved`) and which
files a job writes (:mod:`.names`). One module holds each stage's glue.
"""

from ..record import Run
from .build import stage_build
from .commands import run_card, run_hard, write_default_config
from .cost import dry_run
from .decompose import stage_decompose
from .manifest import finish
from .names import STAGE_COMMANDS
from .picture import load_picture, source_reference
from .refine import stage_refine
from .run import build_any, run_all, run_command
from .saved import read_dots, read_layers, read_spray_times
from .simulate import stage_simulate
from .slicing import plate_projects, print_estimate, slice_plates
from .stipple import stage_stipple

__all__ = [
    "STAGE_COMMANDS",
    "Run",
    "build_any",
    "dry_run",
    "finish",
    "load_picture",
    "plate_projects",
    "print_estimate",
    "read_dots",
    "read_layers",
    "read_spray_times",
    "run_all",
    "run_card",
    "run_command",
    "run_hard",
    "slice_plates",
    "source_reference",
    "stage_build",
    "stage_decompose",
    "stage_refine",
    "stage_simulate",
    "stage_stipple",
    "write_default_config",
]
