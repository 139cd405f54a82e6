"""A mural's registration cases: its tiles (or layers) sprayed shifted apart, scored against the mural in register.

Each case is a tiled simulation and a score (:func:`registration_case`, a task), started once the
global simulation is there (:func:`start_registration`) and collected after the simulate stage
(:func:`stage_mural_simulate`), so a cluster runs them while this process goes on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import mural
from ..figures import MuralSimulation, SimulateFigures
from ..model import DotSet, Layers
from ..plan.plan import Plan

if TYPE_CHECKING:
    from ..config.spray import SprayConfig
    from ..record import Run
    from ..simulate import SimResult


#: The registration errors simulated: ``(between, error mm)``, tiles or layers shifted 1 mm apart.
#: Each case is a tiled simulation and a score (about 10 s on the 600 x 400 mm mural of
#: ``python -m benchmarks mural --case mural600``). There the 0.5 mm cases cost about a third of
#: the 1 mm ones (S-CIELAB at 3 m +0.17 against +0.54 between tiles, +0.14 against +0.41 between
#: layers, from 1.71 in register) and told the maker little more, so only the 1 mm cases run.
REGISTRATION_CASES = (("tiles", 1.0), ("layers", 1.0))
#: The scores each registration case gives, and what it costs against the mural in register.
_SCORES = ("scielab", "de2000_mean", "de2000_p95", "psnr", "ssim")


@dataclass(frozen=True)
class RegistrationJob:
    """What every registration case's task shares (see :func:`registration_case`)."""

    shape: tuple[int, int]
    mm_per_px: float
    per_tile: list[list[DotSet]]
    grid: mural.TileGrid
    spray: SprayConfig
    times: list[float]
    tols: list[float]
    geometry: Any
    sprays: list[SprayConfig]
    primer: np.ndarray
    colours: np.ndarray
    reference: np.ndarray
    distance_m: float


def registration_case(case: tuple[str, float], job: RegistrationJob) -> dict[str, float]:
    """The scores of the mural sprayed with its tiles (or layers) shifted ``case = (between, error mm)`` apart (a task)."""
    from .. import simulate
    from ..model import composite
    from ..simulate import scielab

    between, err = case
    off = mural.registration_offsets(job.grid, err, between)
    a = mural.simulate_tiles(
        job.shape,
        job.mm_per_px,
        job.per_tile,
        job.grid,
        job.spray,
        job.times,
        job.tols,
        off,
        job.geometry,
        job.sprays,
    )
    comp = np.clip(composite(job.primer, job.colours, a), 0, 1)
    del a
    return {
        **simulate.score(job.reference, comp),
        "scielab": scielab.scielab(job.reference, comp, job.mm_per_px, job.distance_m),
    }


def start_registration(
    run: Run,
    plan: Plan,
    sim: SimResult,
    reference: np.ndarray,
    layers: Layers,
    dotsets: list[DotSet],
    per_tile: list[list[DotSet]],
) -> tuple[Any, float] | None:
    """Start the registration cases (:data:`REGISTRATION_CASES`) as the job's tasks: ``(started, start time)``.

    None for one tile: no seam to register.

    Args:
        run: The run.
        plan: The job's plan: its config, each layer's spray settings and its tiles.
        sim: The global :class:`~stencil_cad.simulate.SimResult`.
        reference: ``(H, W, 3)`` picture on the simulation grid.
        layers: The decomposition.
        dotsets: The global holes per layer.
        per_tile: Per tile, per layer, holes in the tile frame.
    """
    from .. import simulate
    from ..simulate.physical import SprayGeometry

    cfg, sprays, grid = plan.cfg, plan.sprays, plan.grid
    if not mural.has_seams(grid):
        return None
    t0 = time.perf_counter()
    shape = sim.alphas.shape[1:]
    g = sim.mm_per_px
    tols = [
        simulate.tail_tolerance(d.xy_mm, d.r_mm, shape, g, sp) if len(d) else 0.0
        for d, sp in zip(dotsets, sprays, strict=True)
    ]
    job = RegistrationJob(
        (int(shape[0]), int(shape[1])),
        g,
        per_tile,
        grid,
        cfg.spray,
        [float(t) for t in sim.info["spray_time"]],
        tols,
        SprayGeometry.for_job(cfg),
        sprays,
        layers.primer,
        layers.colours,
        reference,
        cfg.view.distance_m,
    )
    return run.tasks.start(registration_case, list(REGISTRATION_CASES), "registration cases", job), t0


def stage_mural_simulate(
    run: Run, started: tuple[Any, float] | None, seen: SimulateFigures | None
) -> MuralSimulation | None:
    """The cost of misregistration: the tiles (or the layers) sprayed shifted apart, scored against the mural in register.

    In register the tiled simulation equals the global one (tested to 1e-6 in the tests of
    :func:`stencil_cad.mural.simulate_tiles`), so the scores in register are the global
    simulation's (``seen``, as :func:`stencil_cad.pipeline.simulate.stage_simulate` scored it). The
    cases' simulations and scores are tasks :func:`start_registration` started while the global
    simulation went on; this collects them.

    Args:
        run: The run.
        started: What :func:`start_registration` returned (None: no case, nothing to record).
        seen: Figure ``simulate``: the global simulation's scores.

    Returns:
        Figure ``mural.simulation`` (the recorder records it), or None without a case.
    """
    if started is None:
        return None
    if seen is None:
        raise AssertionError("the mural's registration costs need the global simulation's scores")
    base = {k: float(seen.scores[k]) for k in _SCORES}
    out: dict[str, Any] = {}
    tasks, t0 = started
    with run.stage("simulate_tiles"):
        costs = []
        for (between, err), sc in zip(REGISTRATION_CASES, tasks.results(), strict=True):
            costs.append(
                {
                    "between": between,
                    "error_mm": err,
                    **{k: round(v, 5) for k, v in sc.items()},
                    **{f"cost_{k}": round(sc[k] - base[k], 5) for k in _SCORES},
                }
            )
        out["zero_error_scores"] = {k: round(v, 5) for k, v in base.items()}
        out["registration_cost"] = costs
        out["seconds"] = round(time.perf_counter() - t0, 2)
    return MuralSimulation.from_json(out)
