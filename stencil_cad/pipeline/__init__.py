"""The orchestrator: calls the stages in order, reports progress, writes through :mod:`stencil_cad.output`.

Stages are pure functions; this package is the only one that knows their order. One module holds
each stage's glue, and no stage's glue imports another's: :mod:`.run` (the job and the stage
commands), :mod:`.commands` (the card, the default config) and :mod:`.preview` order them, and
what the stages share lives below, in :mod:`stencil_cad.plan` (the names a job writes, the picture,
the tiling, each layer's spray, the holes a design gets, what each stage returns). Each stage returns
its result and :mod:`.recorder` writes its files and records its figures. This package re-exports
stage glue only:
the command line and the public API import the three orchestrating modules themselves.
"""

from ..plan.names import STAGE_COMMANDS
from ..plan.picture import load_picture, source_reference
from ..record import Run
from .cost import dry_run
from .decompose import stage_decompose
from .manifest import finish
from .recorder import record_decompose, record_simulate
from .refine import stage_refine
from .saved import read_dots, read_layers, read_spray_times
from .simulate import stage_simulate
from .slicing import plate_projects, print_estimate, slice_plates
from .stipple import stage_stipple

__all__ = [
    "STAGE_COMMANDS",
    "Run",
    "dry_run",
    "finish",
    "load_picture",
    "plate_projects",
    "print_estimate",
    "read_dots",
    "read_layers",
    "read_spray_times",
    "record_decompose",
    "record_simulate",
    "slice_plates",
    "source_reference",
    "stage_decompose",
    "stage_refine",
    "stage_simulate",
    "stage_stipple",
]
