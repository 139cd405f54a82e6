"""The decompose stage's glue: solve whole or in tiles, a can list or catalogue as the palette; the layers to save (``layers.npz``)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..colour import to_hex
from ..config import DecomposeConfig, JobConfig
from ..errors import ConfigError, UserError
from ..figures import CansFigures, CanSnap, DecomposeFigures
from ..model import Layers, Picture
from ..output import plain as _plain
from ..plan.cans import with_can_list
from ..plan.plan import Plan
from ..plan.results import Decomposed
from ..record import Run

if TYPE_CHECKING:
    from ..decompose.paints import Can
    from ..decompose.sprayed import PlateReach
    from ..decompose.tiled import TilePlan

log = logging.getLogger(__name__)


def stage_decompose(run: Run, plan: Plan, picture: Picture) -> Decomposed:
    """Decompose the picture into a primer and paint layers under ``plan``, written nowhere.

    ``plan``'s config is the job's planned config: a mostly dark picture's primer is in it already
    (:func:`stencil_cad.plan.plan.primed`), and ``plan.primer`` names that primer for figure
    ``decompose`` (None: the config's own). The layers come back as ``layers.npz`` holds them
    (float32 opacities), so a preview or a stage command run later on the saved file goes on from
    the same numbers as the job. The recorder saves them (``layers.npz`` and its previews) and
    records figures ``cans`` and ``decompose``; the preview records them without saving.
    """
    from dataclasses import replace

    from .. import decompose as dec
    from ..exchange.layers_npz import layers_from_npz, layers_to_npz

    cfg, primed = plan.cfg, plan.primer
    with run.stage("decompose"):
        # Iterations run per pyramid level, so the total is not known in advance.
        with run.bar(None, "decompose") as bar:

            def progress(_iteration: int, energy: float) -> None:
                bar.update(1)
                bar.set_postfix(energy=f"{energy:.4g}", refresh=False)

            dcfg, listed = with_can_list(cfg.decompose, "decompose.palette")
            reach = plate_reach(cfg)
            try:
                tiles = _decompose_tiles(cfg, picture)

                def solve(section: DecomposeConfig) -> Layers:
                    if tiles is None:
                        return dec.decompose(
                            picture, section, run.rng_for("decompose"), progress=progress, reach=reach
                        )
                    return _decompose_tiled(run, picture, tiles, progress, section, reach)

                layers, cans = solve(dcfg), None
                if dcfg.palette == "auto" and cfg.paints.catalogue is not None:
                    layers, cans = _snap_to_catalogue(cfg.paints.catalogue, dcfg, layers, solve)
            except ValueError as exc:
                # A config that does not suit this image (e.g. opacity_source: alpha on RGB).
                raise UserError(str(exc)) from exc
        # Timings go to the manifest only, so the same job writes the same bytes.
        saved = layers_to_npz(replace(layers, info={k: v for k, v in layers.info.items() if k != "seconds"}))
        # Go on with exactly what is saved (float32 opacities), so a stage command run later
        # on layers.npz gives the same dots as this run.
        layers = layers_from_npz(saved)
    info = dict(layers.info)
    figures = DecomposeFigures(
        layers=layers.count,
        primer=to_hex(layers.primer),
        colours=[to_hex(c) for c in layers.colours],
        iterations=layers.iterations,
        solver={
            **{k: v for k, v in info.items() if isinstance(v, (int, float, str, list))},
            **({"primer_rule": f"{primed}: the picture's dark colour"} if primed else {}),
        },
        tiled=_plain(info["tiled"]) if "tiled" in info else None,
    )
    known = replace(listed or CansFigures(), catalogue=cans.catalogue, snap=cans.snap) if cans else listed
    return Decomposed(layers, saved, figures, known)


def plates_of(plan: Plan, layers: Layers) -> Layers:
    """The plates ``plan``'s job stipples from its paint layers: two per paint with light plates, else the layers.

    With ``stipple.light_plates`` (:func:`stencil_cad.mural.light_plates_on`, which the plan's tiling
    decides) each paint gets a light and a dark plate (:func:`stencil_cad.decompose.light.light_plates`).
    Split from the layers as ``layers.npz`` holds them, so a stage command on the saved file makes
    the same plates. The recorder's :func:`stencil_cad.pipeline.recorder.record_plates` says how many
    (figure ``decompose.plates``).
    """
    from ..decompose.light import light_plates
    from ..mural import light_plates_on

    return light_plates(layers) if light_plates_on(plan.cfg, plan.grid) else layers


def _decompose_tiles(cfg: JobConfig, picture: Picture) -> TilePlan | None:
    """The decomposition's tiles for a big picture (None: solved whole), checked against the memory per task."""
    from .. import compute
    from ..decompose import tiled

    if not tiled.applies(picture, cfg.decompose):
        return None
    n = cfg.decompose.layers
    tiles = tiled.plan(picture.shape, n, cfg.compute.memory_per_task_bytes)
    if tiles is None:
        return None
    side = tiles.tile_px + 2 * tiles.halo_px
    compute.check_fits(
        f"a decomposition tile of {side} x {side} px with {n} layers",
        tiled.tile_bytes(tiles.tile_px, n),
        cfg.compute,
    )
    ch, cw = tiles.coarse_shape
    compute.check_fits(
        f"the colour solve on {ch} x {cw} px with {n} layers", tiled.whole_bytes((ch, cw), n), cfg.compute
    )
    return tiles


def plate_reach(cfg: JobConfig) -> PlateReach:
    """What this job's plates can spray (:class:`stencil_cad.decompose.sprayed.PlateReach`), for ranking starts.

    The darkest tone is the densest hole pattern the rules allow at the most passes (or the paper
    model's spray time), measured with the spray model as the stipple stage's dark-end figures are;
    the same measurement gives the pattern's variance at each opacity, and a window sprays a full
    coat at that amount.
    """
    from ..decompose.sprayed import PlateReach
    from ..simulate import tone
    from ..simulate.models import sprayer

    st = cfg.stipple
    amount = sprayer(cfg.spray).reach_amount(cfg.spray)
    curve = tone.plate_response(cfg, amount)
    return PlateReach(
        darkest=float(curve.max_opacity),
        threshold=st.opacity_threshold,
        window_from=None if st.windows == "off" else st.window_opacity,
        coat=tone.full_coat(cfg.spray, amount),
        pattern=(tuple(float(m) for m in curve.mean), tuple(float(v) for v in curve.var)),
    )


def _decompose_tiled(
    run: Run,
    picture: Picture,
    tiles: TilePlan,
    progress: Callable[[int, float], None],
    cfg: DecomposeConfig,
    reach: PlateReach | None = None,
) -> Layers:
    """Colours on a small copy of the picture, then the opacities tile by tile as tasks.

    ``cfg`` is the decompose section to solve with (the job's; a can list or the catalogue's cans
    replace its palette).
    """
    from .. import decompose as dec
    from ..decompose import tiled

    coarse = dec.decompose(
        tiled.coarse_picture(picture, tiles), cfg, run.rng_for("decompose"), progress=progress, reach=reach
    )
    results = run.tasks.map(
        tiled.solve_tile, tiled.tasks(picture, coarse, tiles, cfg), "decompose tiles", count=tiles.count
    )
    return tiled.assemble(coarse, tiles, results, picture.mm_per_px)


def _catalogue(catalogue: Any) -> list[Can]:
    from ..decompose import paints

    try:
        cans = paints.load_cans(catalogue)
    except (ValueError, ConfigError) as exc:
        raise ConfigError(f"paints.catalogue: {exc}") from None
    return cans


def _snap_to_catalogue(
    catalogue: Any,
    dcfg: DecomposeConfig,
    layers: Layers,
    solve: Callable[[DecomposeConfig], Layers],
) -> tuple[Layers, CansFigures]:
    """Snap the solved paints (and an 'auto' primer) to the nearest cans of ``catalogue`` and solve the opacities again.

    ``solve(section)`` decomposes the picture with a decompose section (whole or in tiles).

    Returns:
        ``(layers, cans)``: the layers solved again, and figure ``cans``'s catalogue and snap.
    """
    from ..decompose import paints

    cans = _catalogue(catalogue)
    paint_snap = paints.snap_report(layers.colours, cans)
    update: dict[str, object] = {"order": "given"}
    primer_snap = None
    if dcfg.primer == "auto":
        primer_snap = paints.snap_report(layers.primer[None, :], cans)[0]
        update["primer"] = primer_snap["can"]
    chosen: list[str] = []
    for row in paint_snap:
        if row["can"] not in chosen and row["can"] != update.get("primer", dcfg.primer):
            chosen.append(row["can"])
    if not chosen:
        raise ValueError(
            "paints.catalogue: every solved paint snaps to the primer's can; add cans closer to the "
            "picture's colours, or set decompose.palette to a list"
        )
    update["palette"] = tuple(chosen)
    snapped = solve(dcfg.model_validate({**dcfg.model_dump(), **update}))
    before = float(layers.info.get("rmse", float("nan")))
    after = float(snapped.info.get("rmse", float("nan")))
    snap = {
        "paints": paint_snap,
        "primer": primer_snap,
        "rmse_solved": before,
        "rmse_snapped": after,
        "rmse_cost": after - before,
        "de2000_mean_shift": float(sum(r["delta_e2000"] for r in paint_snap) / len(paint_snap)),
    }
    log.info("paints: snapped to the catalogue, composite RMSE %.2f → %.2f (0-255 units)", before, after)
    return snapped, CansFigures(catalogue=[c.__dict__ for c in cans], snap=CanSnap.from_json(snap))
