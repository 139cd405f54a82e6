"""A fast, progressive preview of what a job sprays: the same stages as the job, on a coarser grid, nothing written.

Three or four levels, each better and slower than the one before. On the bundled example with light
plates (eight plates), after one change of its settings (``python -m benchmarks studio``, five changes
of each kind, medians, two cores shared with other work at a load average of 1-6) the first preview
came in 0.6-1.2 s, one within 0.5 of the job's S-CIELAB at 1 m in 0.6-3.8 s (often the coarse level;
the refined holes in 7-13 s) and the last, after the trials, in 59-94 s (a fixed stand-off: 8.2 s
and 9.8 s). When the previews before
the trials showed the process's 10 mm and the job chose 5 mm, a change of paints took 58.7 s to a
close preview:

- ``coarse``: the decomposition, its opacities blurred as the can blurs them at the wall's stand-off
  (sigma = spread x stand-off) and composited: how the tones land, before any hole is placed. When
  the settings' decomposition is not in the cache yet, this level decomposes the picture at half the
  resolution first (about half the time: the bundled example with 6 layers, 2.4-2.9 s against
  5.9-8.5 s on a loaded two-core machine), and the job's decomposition follows for the next levels;
- ``stippled``: the holes as the stipple stage places them (not refined), sprayed on the preview grid;
- ``refined``: those holes refined against the spray model (:data:`PREVIEW_ITERATIONS` iterations,
  the nominal can) and sprayed;
- ``designed`` (when the config leaves the plate design to the job): the plate design the job's own
  trials choose, its holes stippled and refined as above, sprayed; the same holes as ``refined`` when
  the job keeps the config's design.

Every level scores what it shows against the source image like the job's simulate stage (S-CIELAB at
the viewing distance and twice it); the last also sprays its holes with every can of the can prior,
as the job's ``scielab_by_can`` does, for the range of scores the maker's can may give.

The plate design is the job's: when the config leaves the windows or the stand-off to the job
(:func:`leaves_design`), the levels before the trials show a design the trials are likely to choose
(the job's own when these settings' trials ran before; else :func:`start_design`, the one the trials
chose most often for the same picture, process, spray and distance, or the prior of
:func:`stencil_cad.pipeline.standoff.prior_design`), and then the job's own plate-design trials
(:func:`stencil_cad.pipeline.standoff.stage_standoff`, on the job's config and grid) choose the design
the last level, ``designed``, shows. The decomposition is the job's, at the config's stand-off. A
mural keeps the config's design, as the job does.

What does not change between two settings is kept (:class:`PreviewCache`): the decomposition, keyed on
everything it reads (the image file, the size, the decomposition and paints sections, the seed and what
the plates can spray), the unrefined holes, keyed on the whole config but the refinement, view and
paints' cost settings, and the plate design chosen, keyed on the decomposition and the whole job config
but its name and output settings (:func:`design_key`), and the designs chosen by :func:`family_key`.
All are bounded (a few entries each, least recently used dropped).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np

from ..config import JobConfig, Mode
from ..errors import UserError
from ..figures import CostFigures
from ..interrupts import CancelToken
from ..model import DotSet, Layers, Picture
from ..plan.cans import can_names
from ..plan.plan import Plan, capped, designed, painted, planned, primed, refilled, repainted
from ..record import Run
from .decompose import plates_of
from .recorder import record_decompose, record_plates

#: Refinement iterations of the last preview (the job's default is 90): on the bundled example 30
#: iterations on the preview grid scored 3.98 at 1 m against the full job's 3.99.
PREVIEW_ITERATIONS = 30
#: The preview's simulation pixel, in mm (the bundled example's job sprays on 0.25 mm).
PREVIEW_MM_PER_PX = 0.5
#: Entries kept per cache (decompositions, each setting's at two resolutions; hole sets).
CACHE_ENTRIES = 6
#: The levels, first to last.
LEVELS = ("coarse", "stippled", "refined", "designed")


@dataclass(frozen=True)
class Preview:
    """One preview of the sprayed result and its figures.

    Attributes:
        level: ``"coarse"``, ``"stippled"`` or ``"refined"`` (see the module).
        final: True for the last level.
        sprayed: The simulated composite, ``(H, W, 3)`` ndarray of float in [0, 1].
        reference: The source image on the same grid, ``(H, W, 3)`` float in [0, 1].
        mm_per_px: Pixel size of both pictures, mm.
        scielab: S-CIELAB at the viewing distance.
        scielab_2x: S-CIELAB at twice the viewing distance.
        distance_m: The viewing distance, m.
        primer: Primer colour, ``#rrggbb``.
        paints: Paint colour of each layer, ``#rrggbb``, in spray order.
        passes: Passes (or spray time) of each layer; None at the coarse level.
        holes: Holes of each layer's plate; None at the coarse level.
        plates: Plates to make (layers x tiles).
        walls: Walls to make.
        tiles: Tiles of the mural (1 for a one-plate job).
        cost: What making it costs (printer-hours, filament, laser, paint).
        standoff_mm: The wall's stand-off previewed, mm.
        seconds: Time since the preview was asked for, s.
        windows: The plates' windows previewed (``auto`` or ``off``).
        designed: True when the plate design is the one the job's trials choose (:func:`leaves_design`).
        scielab_by_can: On the last level, S-CIELAB at the viewing distance sprayed by every can of the
            prior (``nominal`` first), as the job's ``simulate.scielab_by_can``; None when the prior
            is one can (every layer measured, or the paper model) and on the other levels.
        size_mm: The picture's ``(width, height)``, mm.
        tile_cores: Each tile of the job's tiling (:func:`stencil_cad.plan.tiles.plan`, as the job
            tiles): its name and the part of the picture it owns, ``(name, x0, y0, x1, y1)`` mm from the
            picture's bottom-left corner; one tile for a picture that fits the bed.
    """

    level: str
    final: bool
    sprayed: np.ndarray
    reference: np.ndarray
    mm_per_px: float
    scielab: float
    scielab_2x: float
    distance_m: float
    primer: str
    paints: tuple[str, ...]
    passes: tuple[float, ...] | None
    holes: tuple[int, ...] | None
    plates: int
    walls: int
    tiles: int
    cost: CostFigures
    standoff_mm: float
    seconds: float
    windows: str = "auto"
    designed: bool = False
    scielab_by_can: dict[str, float] | None = None
    size_mm: tuple[float, float] = (0.0, 0.0)
    tile_cores: tuple[tuple[str, float, float, float, float], ...] = ()

    @property
    def scielab_range(self) -> tuple[float, float] | None:
        """The least and the most S-CIELAB at the viewing distance over the can prior; None when it is one can."""
        if not self.scielab_by_can:
            return None
        return min(self.scielab_by_can.values()), max(self.scielab_by_can.values())

    def figures(self) -> dict[str, Any]:
        """The preview's figures as plain JSON values (no pictures)."""
        return {
            "level": self.level,
            "final": self.final,
            "scielab": round(self.scielab, 3),
            "scielab_2x": round(self.scielab_2x, 3),
            "distance_m": self.distance_m,
            "primer": self.primer,
            "paints": list(self.paints),
            "passes": None if self.passes is None else list(self.passes),
            "holes": None if self.holes is None else list(self.holes),
            "plates": self.plates,
            "walls": self.walls,
            "tiles": self.tiles,
            "standoff_mm": self.standoff_mm,
            "windows": self.windows,
            "designed": self.designed,
            "scielab_by_can": None
            if self.scielab_by_can is None
            else {k: round(v, 3) for k, v in self.scielab_by_can.items()},
            "size_mm": [round(v, 3) for v in self.size_mm],
            "tiles_mm": [
                {"name": n, "x0": round(x0, 3), "y0": round(y0, 3), "x1": round(x1, 3), "y1": round(y1, 3)}
                for n, x0, y0, x1, y1 in self.tile_cores
            ],
            "scielab_range": None
            if self.scielab_range is None
            else [round(x, 3) for x in self.scielab_range],
            "cost": self.cost.to_json(),
            "seconds": round(self.seconds, 3),
        }


@dataclass
class PreviewCache:
    """What two previews can share, bounded: decompositions, unrefined hole sets, plate designs and each family's (least recently used dropped)."""

    entries: int = CACHE_ENTRIES
    layers: OrderedDict[str, tuple[Layers, JobConfig]] = field(default_factory=OrderedDict)
    holes: OrderedDict[str, list[DotSet]] = field(default_factory=OrderedDict)
    designs: OrderedDict[str, tuple[str, float]] = field(default_factory=OrderedDict)
    families: OrderedDict[str, dict[tuple[str, float], int]] = field(default_factory=OrderedDict)

    def get(self, table: OrderedDict[str, Any], key: str) -> Any:
        """The entry under ``key`` (marked as just used), or None."""
        if key not in table:
            return None
        table.move_to_end(key)
        return table[key]

    def put(self, table: OrderedDict[str, Any], key: str, value: Any) -> None:
        """Keep ``value`` under ``key``, dropping the least recently used entry beyond :attr:`entries`."""
        table[key] = value
        table.move_to_end(key)
        while len(table) > self.entries:
            table.popitem(last=False)


def _digest(*parts: Any) -> str:
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()


def _image_key(cfg: JobConfig) -> Any:
    """The image file as the cache sees it: path, size and modification time (the bundled example by name)."""
    if cfg.image is None:
        return "bundled example"
    try:
        st = cfg.image.stat()
    except OSError:
        return str(cfg.image)
    return [str(cfg.image), st.st_size, st.st_mtime_ns]


def decomposition_key(cfg: JobConfig) -> str:
    """What the decomposition reads: the image, size, decomposition, paints, seed and what the plates can spray."""
    from .decompose import plate_reach

    reach = plate_reach(cfg)
    dump = cfg.model_dump(mode="json")
    return _digest(_image_key(cfg), dump["size"], dump["decompose"], dump["paints"], cfg.seed, repr(reach))


def holes_key(cfg: JobConfig, layers_key: str) -> str:
    """What the unrefined holes read: the decomposition and every section but refinement, view and cost."""
    dump = cfg.model_dump(mode="json")
    for k in ("refine", "view", "export", "compute", "name"):
        dump.pop(k, None)
    dump["paints"] = {k: v for k, v in dump["paints"].items() if k not in ("coverage_m2_per_can", "can_ml")}
    return _digest(layers_key, dump)


def preview_config(cfg: JobConfig) -> JobConfig:
    """``cfg`` as the preview runs it: the preview grid, :data:`PREVIEW_ITERATIONS` refinement steps, the nominal can."""
    spray = cfg.spray.model_copy(update={"px_per_mm": 1.0 / PREVIEW_MM_PER_PX})
    refine = cfg.refine.model_copy(
        update={"iterations": min(cfg.refine.iterations, PREVIEW_ITERATIONS), "cans": "nominal"}
    )
    return cfg.model_copy(update={"spray": spray, "refine": refine})


def previews(
    cfg: JobConfig, cache: PreviewCache | None = None, cancel: CancelToken | None = None
) -> Iterator[Preview]:
    """The previews of ``cfg``'s job, coarse first; each is yielded as soon as it is made.

    Args:
        cfg: The resolved job config (soft mode).
        cache: Decompositions and hole sets kept from earlier previews; None keeps nothing.
        cancel: Checked between levels and inside the long loops; a cancelled preview stops
            with :class:`stencil_cad.interrupts.Cancelled`.

    Yields:
        One :class:`Preview` per level of :data:`LEVELS`.

    Raises:
        UserError: The image cannot be read, the config asks for hard mode, or a part does not fit the bed.
    """
    from .. import mural
    from ..plan.picture import load_picture
    from ..plan.refinement import refine_holes

    if cfg.mode == Mode.hard:
        raise UserError("the preview shows soft (stippled) jobs; hard mode has no preview yet (use `run`)")
    t0 = time.perf_counter()
    cache = cache or PreviewCache()
    pcfg = preview_config(cfg)
    # No output folder: every step a preview takes computes without writing (a write would fail).
    run = Run(cfg=pcfg, out=cast("Any", None), quiet=True, cancel=cancel)
    picture = load_picture(pcfg)
    # The preview's plan, as the job's (:mod:`stencil_cad.plan.plan`): each step returns the next.
    plan = planned(pcfg, (picture.width_mm, picture.height_mm), picture.shape[0] * picture.shape[1])[0]
    designing = mural.chooses_design(plan.grid) and leaves_design(plan.cfg)
    start = start_design(cfg, cache) if designing else None
    decomposed = cache.get(cache.layers, decomposition_key(plan.cfg)) is not None
    if not decomposed:
        # Not decomposed yet: the first preview comes from a decomposition at half the resolution.
        yield _quick(run, plan, picture, cache, t0, start)
        run.check()
    plan, layers = _layers(run, plan, picture, cache)
    layers = record_plates(run, plates_of(plan, layers))
    plan = painted(plan, layers.colours, can_names(run.figures))
    # Decomposed as the job decomposes (at the config's stand-off); the holes start at ``start``.
    own, job, known = plan, plan, None
    if designing:
        job = _job_plan(cfg, plan)
        known = cast("tuple[str, float] | None", cache.get(cache.designs, design_key(job.cfg)))
        plan = designed(own, *(known or cast("tuple[str, float]", start)))
    made = _Made(run, picture, layers, t0, designed=known is not None)
    if decomposed:
        yield made.coarse(plan)
        run.check()
    holes = _holes(run, plan, layers, picture, cache)
    refining = plan.cfg.refine.enabled
    yield made.sprayed("stippled", plan, holes, final=not (refining or designing))
    if refining:
        run.check()
        refined = refine_holes(run, _whole(plan), layers, holes, picture)[0]
        yield made.sprayed("refined", plan, refined, final=not designing)
    if designing:
        run.check()
        windows, standoff = known or _design(run, job, layers, picture, cache, family_key(cfg))
        made.designed = True
        if (windows, standoff) != (plan.cfg.stipple.windows.value, plan.cfg.standoff.design_mm):
            plan = designed(own, windows, standoff)
            holes = _holes(run, plan, layers, picture, cache)
            if refining:
                run.check()
                refined = refine_holes(run, _whole(plan), layers, holes, picture)[0]
        yield made.sprayed("designed", plan, refined if refining else holes, final=True)


def _whole(plan: Plan) -> Plan:
    """``plan`` on one tile: the preview stipples and refines a mural whole."""
    from ..mural import TileGrid

    return replace(plan, grid=TileGrid.whole(*plan.picture_mm))


def leaves_design(cfg: JobConfig) -> bool:
    """Whether the job chooses its plate design (windows, stand-off) by trials: the preview then runs them too."""
    from ..config.stipple import Windows

    return cfg.stipple.windows != Windows.off or cfg.chooses_standoff


def design_key(job_cfg: JobConfig) -> str:
    """What the plate-design trials read: the decomposition and every section of the job's config but its name and output."""
    dump = job_cfg.model_dump(mode="json")
    for k in ("export", "compute", "name"):
        dump.pop(k, None)
    # A stand-off left to the job and the same one fixed dump alike: only the first is chosen again.
    return _digest("design", decomposition_key(job_cfg), dump, job_cfg.chooses_standoff)


def family_key(cfg: JobConfig) -> str:
    """What a plate design rests on but the paints, layers and size: the image, how its plates are made, sprayed and seen."""
    dump = cfg.model_dump(mode="json")
    parts = [dump[k] for k in ("mode", "stipple", "spray", "wall", "refine", "view")]
    return _digest("family", _image_key(cfg), parts, cfg.chooses_standoff)


def start_design(cfg: JobConfig, cache: PreviewCache) -> tuple[str, float]:
    """The plate design ``(windows, stand-off in mm)`` a preview starts at before its trials have run.

    The design the trials chose most often for ``cfg``'s family (:func:`family_key`: the same picture,
    process, spray and distance, other paints, layers or size), counted in ``cache``, the prior
    (:func:`stencil_cad.pipeline.standoff.prior_design`) winning a tie and standing alone before any
    trial. A count, not the last choice: on the bundled example the trials chose 5 mm for four of five
    paint sets and 8 mm for one, and the set after that one chose 5 mm again.
    """
    from .standoff import prior_design

    prior = prior_design(cfg)
    votes = cast("dict[tuple[str, float], int]", cache.get(cache.families, family_key(cfg)) or {})
    return max([prior, *votes], key=lambda d: (votes.get(d, 0), d == prior))


def _job_plan(cfg: JobConfig, plan: Plan) -> Plan:
    """The job's plan as its plate-design trials read it: its own grid, the thickness its tiling asks, the primer chosen, the holes capped."""
    job = refilled(plan, cfg)
    return capped(repainted(replace(job, cfg=job.cfg.model_copy(update={"decompose": plan.cfg.decompose}))))


def _design(
    run: Run, job: Plan, layers: Layers, picture: Picture, cache: PreviewCache, family: str
) -> tuple[str, float]:
    """The plate design the job chooses, ``(windows, stand-off in mm)``: its own trials, on its own grid.

    The trials run on the job's plan ``job`` (:func:`_job_plan`: not the preview's grid or
    iterations), so the design is the one the job makes; it is kept in ``cache`` under
    :func:`design_key`, and counted among its ``family``'s choices (:func:`family_key`, :func:`start_design`).
    """
    from .standoff import stage_standoff

    trials = Run(cfg=job.cfg, out=run.out, quiet=True, cancel=run.cancel)
    chosen = stage_standoff(trials, job, layers, picture).plan.cfg
    design = (chosen.stipple.windows.value, chosen.standoff.design_mm)
    cache.put(cache.designs, design_key(job.cfg), design)
    votes = dict(cache.get(cache.families, family) or {})
    votes[design] = votes.get(design, 0) + 1
    cache.put(cache.families, family, votes)
    return design


def _holes(run: Run, plan: Plan, layers: Layers, picture: Picture, cache: PreviewCache) -> list[DotSet]:
    """The unrefined holes of ``plan``'s plates (from the cache when nothing they read changed)."""
    key = holes_key(plan.cfg, decomposition_key(plan.cfg))
    holes = cache.get(cache.holes, key)
    if holes is None:
        holes = _stipple(run, plan, layers, picture, refined=False)
        cache.put(cache.holes, key, holes)
    return cast("list[DotSet]", holes)


def half_config(cfg: JobConfig) -> JobConfig:
    """``cfg`` on a working grid of half the resolution: the quick decomposition of the first preview."""
    from .. import resolution

    px = 0.5 / resolution.working_mm_per_px(cfg)
    return cfg.model_copy(update={"size": cfg.size.model_copy(update={"px_per_mm": max(px, 0.25)})})


def _half_key(cfg: JobConfig) -> str:
    return "half:" + decomposition_key(half_config(cfg))


def _quick(
    run: Run, plan: Plan, picture: Picture, cache: PreviewCache, t0: float, start: tuple[str, float] | None
) -> Preview:
    """The coarse level from a decomposition at half the resolution (about half the time of the job's).

    Decomposed at the config's stand-off, as the job decomposes; blurred at the ``start`` design's.
    """
    from ..plan.picture import load_picture

    half = replace(plan, cfg=half_config(plan.cfg))
    key = _half_key(plan.cfg)
    hit = cache.get(cache.layers, key)
    if hit is None:
        small = load_picture(half.cfg)
        half = primed(half, small)
        layers = _decomposed_cached(run, half, small, cache, key)
    else:
        layers = hit[0]
        half = replace(half, cfg=half.cfg.model_copy(update={"decompose": hit[1].decompose}))
    if start is not None:
        half = designed(half, *start)
    return _Made(run, picture, record_plates(run, plates_of(half, layers)), t0).coarse(half)


def _decomposed_cached(run: Run, plan: Plan, picture: Picture, cache: PreviewCache, key: str) -> Layers:
    """The decompose stage's layers under ``plan`` (not saved), kept in ``cache`` under ``key``."""
    from .decompose import stage_decompose

    layers = record_decompose(run, stage_decompose(run, plan, picture), save=False)
    cache.put(cache.layers, key, (layers, plan.cfg))
    return layers


def _layers(run: Run, plan: Plan, picture: Picture, cache: PreviewCache) -> tuple[Plan, Layers]:
    """The decomposition (from the cache when nothing it reads changed), with the plan naming the primer the job would."""
    key = decomposition_key(plan.cfg)
    hit = cache.get(cache.layers, key)
    if hit is not None:
        return replace(plan, cfg=plan.cfg.model_copy(update={"decompose": hit[1].decompose})), hit[0]
    plan = primed(plan, picture)
    return plan, _decomposed_cached(run, plan, picture, cache, key)


def _stipple(run: Run, plan: Plan, layers: Layers, picture: Picture, refined: bool) -> list[DotSet]:
    from ..plan import holes

    cfg = plan.cfg
    plain = cfg.model_copy(update={"refine": cfg.refine.model_copy(update={"enabled": refined})})
    trial = Run(cfg=run.cfg, out=run.out, quiet=True, executor=run.executor, cancel=run.cancel)
    tried = capped(_whole(replace(plan, cfg=plain)))
    return holes.refined(trial, tried, layers, holes.stippled(trial, tried, layers)[0], picture)[0].sets


@dataclass
class _Made:
    """What every level shares: the run, the picture, its layers, and when the preview was asked for.

    Each level is shown under the plan it is given (the design it shows).
    """

    run: Run
    picture: Picture
    layers: Layers
    t0: float
    designed: bool = False

    def coarse(self, plan: Plan) -> Preview:
        """The decomposition's opacities blurred as the can blurs a hole at the stand-off, composited."""
        from .. import mural, simulate

        sprayed = simulate.blurred_composite(self.layers, _blur_mm(plan.cfg), PREVIEW_MM_PER_PX)
        cost = mural.making_cost(plan.grid, plan.cfg, self.layers.count, None)
        return self._preview(plan, "coarse", sprayed, None, None, cost, final=False)

    def sprayed(self, level: str, plan: Plan, holes: list[DotSet], final: bool) -> Preview:
        """The holes sprayed as the process makes them, on the preview grid."""
        from .. import mural, simulate
        from ..simulate.physical import SprayGeometry
        from ..stipple.made import made_dots

        cfg = plan.cfg
        self.run.check()
        made = [made_dots(d, cfg.stipple, plan.picture_mm) for d in holes]
        geometry = SprayGeometry.for_job(cfg)
        sprays = plan.sprays
        sim = simulate.simulate(
            self.layers, made, cfg.spray, PREVIEW_MM_PER_PX, geometry=geometry, layer_sprays=sprays
        )
        passes = tuple(float(d.amount(cfg.spray.amount)) for d in holes)
        cost = mural.making_cost(plan.grid, plan.cfg, len(holes), holes)
        others = self._other_cans(cfg, made, geometry, sprays) if final else {}
        return self._preview(
            plan, level, sim.composite, passes, tuple(len(d) for d in holes), cost, final, others
        )

    def _other_cans(
        self, cfg: JobConfig, made: list[Any], geometry: Any, sprays: list[Any]
    ) -> dict[str, np.ndarray]:
        """The holes sprayed by every other can of the prior (as the job's ``scielab_by_can``), by name.

        Each can of the prior changes the layers without a measured profile; empty when the prior is
        one can (every layer measured, or the paper model).
        """
        from .. import simulate
        from ..simulate.cans import layer_can_prior

        out = {}
        for name, per_layer in layer_can_prior(sprays):
            if name == "nominal":
                continue
            self.run.check()
            other = simulate.simulate(
                self.layers,
                made,
                cfg.spray,
                PREVIEW_MM_PER_PX,
                geometry=geometry,
                layer_sprays=per_layer,
            )
            out[name] = other.composite
        return out

    def _preview(
        self,
        plan: Plan,
        level: str,
        sprayed: np.ndarray,
        passes: tuple[float, ...] | None,
        holes: tuple[int, ...] | None,
        cost: CostFigures,
        final: bool,
        others: dict[str, np.ndarray] | None = None,
    ) -> Preview:
        from ..colour import to_hex
        from ..plan.picture import source_reference
        from ..simulate.scielab import scielab

        cfg = plan.cfg
        ref = source_reference(cfg, self.picture, self.layers, sprayed.shape[:2], PREVIEW_MM_PER_PX)
        d = float(cfg.view.distance_m)
        score = float(scielab(ref, sprayed, PREVIEW_MM_PER_PX, d))
        by_can = {k: float(scielab(ref, v, PREVIEW_MM_PER_PX, d)) for k, v in (others or {}).items()}
        walls = sum(1 for p in cost.parts if p.kind == "wall")
        return Preview(
            level=level,
            final=final,
            sprayed=sprayed,
            reference=ref,
            mm_per_px=PREVIEW_MM_PER_PX,
            scielab=score,
            scielab_2x=float(scielab(ref, sprayed, PREVIEW_MM_PER_PX, 2.0 * d)),
            distance_m=d,
            primer=to_hex(self.layers.primer),
            paints=tuple(to_hex(c) for c in self.layers.colours),
            passes=passes,
            holes=holes,
            plates=sum(1 for p in cost.parts if p.kind == "plate"),
            walls=walls,
            tiles=len(plan.grid.tiles),
            cost=cost,
            standoff_mm=cfg.standoff.design_mm,
            seconds=time.perf_counter() - self.t0,
            windows=cfg.stipple.windows.value,
            designed=self.designed,
            scielab_by_can={"nominal": score, **by_can} if by_can else None,
            size_mm=(float(plan.picture_mm[0]), float(plan.picture_mm[1])),
            tile_cores=tuple(_core(t) for t in plan.grid.tiles),
        )


def _core(tile: Any) -> tuple[str, float, float, float, float]:
    """A tile's name and core ``(x0, y0, x1, y1)`` in mm."""
    x0, y0, x1, y1 = (float(v) for v in tile.core)
    return (tile.name, x0, y0, x1, y1)


def _blur_mm(cfg: JobConfig) -> float:
    """The blur of a hole's spray, sigma in mm: the can's spread times the stand-off, or the paper model's."""
    from ..simulate.models import sprayer

    return sprayer(cfg.spray).rough_blur_mm(cfg)


#: A callback told each preview as it is made.
PreviewCallback = Callable[[Preview], None]
