"""Posts that carry a mural's plates off the surface, so the plates can be thin.

A mural plate rests on its wall's ledge all round; with nothing under its middle, the sag rule
(:mod:`stencil_cad.config.thickness`) makes a 234 mm plate 1.5 mm thick, and a plate's print is
mostly its plastic. A mural's plates are instead also carried by short printed posts standing on
the surface: each post is a foot as tall as the wall's stand-off with a pin on top that the maker
pushes into a pin hole of the plate from below. The posts stand about every :data:`POST_PITCH_MM`,
so the sag rule sees a panel between four posts (:func:`stencil_cad.config.thickness.column_side_mm`)
instead of the whole plate, and the plates come out two 0.2 mm layers (0.4 mm) thick; with a label
that needs no floor (``plate.label`` emboss or none) the posts stand every
:data:`SINGLE_LAYER_POST_PITCH_MM` and the plates are one 0.3 mm layer.

A post must shade no hole: under the plate the spray of a hole spreads out to the surface, and a
post in its way would cut that spray. Each post's site is chosen per plate (each layer sprays
elsewhere) near a target point on a grid of :data:`POST_PITCH_MM` over the tile, as the point
within :data:`SEARCH_FRACTION` of the pitch around the target whose keep-out disc (the foot's
radius plus :func:`shade_reach_mm`, measured to each hole's edge) holds the fewest holes, the nearest to the target among those. Where the layer
sprays everywhere near a target, the holes in the chosen site's disc are dropped from the layer
before the simulation scores it (:func:`clear_post_sites`), so the score is the plate's as made.
A window (an open area of a hybrid plate) is never shaded: the search widens around it, and a
target whose whole neighbourhood is window gets no post.

The same holes give the same sites: the build finds them again from the saved holes, and every
site it finds has an empty disc.

Measured on the 600 × 400 mm coffee mural (3 layers, FDM, ``view.distance_m`` 3, ``--bed
prusa_mk4``, with one wall for every tile): 1.5 mm plates on the ledge and 8 walls 436 printer-h and
8.96 kg of PLA per m² (the cost from the placed holes), S-CIELAB at 3 m 1.74; 0.6 mm plates on
posts 190 h and 3.33 kg per m², S-CIELAB 1.67 (259 of 78,954 holes displaced). 0.6 mm plates
without posts (8 walls; they would sag) scored 1.55: the posts cost 0.12 of S-CIELAB. With the
posts every 90 mm and 0.4 mm plates (two 0.2 mm layers), PrusaSlicer's estimate on a third of
the parts: 144 h and 2.27 kg per m² against 149 h and 3.29 kg for 0.6 mm plates on the same
profile, S-CIELAB 1.69 against 1.71 (307 holes displaced, 2 posts a plate as before).

Kernel-free: numpy and SciPy's KD-tree.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..config.cad import LabelMode
from ..config.job import job_label
from ..config.process import Method
from .tiling import TileGrid, spray_halo_mm

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..model import DotSet

__all__ = [
    "PIN_RADIUS_MM",
    "POST_PITCH_MM",
    "POST_RADIUS_MM",
    "SINGLE_LAYER_POST_PITCH_MM",
    "PostPlan",
    "clear_post_sites",
    "post_pitch_mm",
    "post_plan",
    "with_post_pitch",
    "post_sites",
    "post_span_mm",
    "sag_side_mm",
    "shade_reach_mm",
    "targets",
    "with_pin_holes",
]

#: Spacing of the posts' target points, mm. 90 mm lets the thinnest FDM plate (0.4 mm: two 0.2 mm
#: layers, :data:`stencil_cad.config.process.FDM_THIN_PLATE_MM`) stay within the sag limit (5 % of a
#: 10 mm stand-off: 0.49 mm by the model for the longest span the search allows) and still puts 2-4
#: posts under a plate of a Prusa MK4's bed (the 600 x 400 mm coffee mural: 2 a plate, as at the
#: 100 mm of before, whose 0.6 mm plates used 50 % more filament).
POST_PITCH_MM = 90.0
#: Spacing of the targets where the plate may be one 0.3 mm layer (FDM, its thickness left to the
#: process and a label that needs no floor: ``plate.label`` emboss or none;
#: :data:`stencil_cad.config.process.FDM_SINGLE_LAYER_MM`): the sag model allows a 111 mm square
#: at 0.3 mm, which the longest span the search allows at 78 mm (101 mm between posts) stays within.
#: 4 posts under a plate of the 600 x 400 mm coffee mural instead of 2.
SINGLE_LAYER_POST_PITCH_MM = 78.0
#: How far a site may move from its target, as a share of the pitch (each way, in x and y).
SEARCH_FRACTION = 0.15
#: Where a window leaves no site within :data:`SEARCH_FRACTION`, the search widens to this share of
#: the pitch; where it still finds none, that target gets no post (a window is never shaded).
WIDE_SEARCH_FRACTION = 0.45
#: Spacing of the candidate sites around a target, mm.
CANDIDATE_STEP_MM = 1.0
#: A post's foot keeps this many blur sigmas from every hole's edge (:func:`shade_reach_mm`). The
#: spray halo first used here (5 sigmas plus the largest hole) kept a 19 mm disc free of holes round
#: each post: on the 600 x 400 mm coffee mural 1,268 holes went and S-CIELAB at 3 m rose from 1.74
#: to 2.20.
SHADE_SIGMAS = 2.0
#: The post's foot radius, mm: wide enough to stand, narrow enough to find a site between holes.
POST_RADIUS_MM = 3.0
#: The pin's radius, mm; its hole in the plate is drawn :data:`PIN_CLEARANCE_MM` larger (and
#: compensated like every hole) so that the pin pushes in with a light fit.
PIN_RADIUS_MM = 1.0
PIN_CLEARANCE_MM = 0.1
#: A window's vertex inside a keep-out disc counts as this many holes (a window cannot be dropped).
_WINDOW_WEIGHT = 10**6


@dataclass(frozen=True)
class PostPlan:
    """Where a job's plates are carried by posts.

    Attributes:
        pitch_mm: Spacing of the target points, mm.
        keepout_mm: Radius of the disc around a post that no hole's edge may enter, mm.
        height_mm: The post's foot height: the wall's stand-off, mm.
        radius_mm: The foot's radius, mm.
        pin_radius_mm: The pin's radius, mm.
        pin_hole_mm: The pin hole's radius as asked of the plate, mm.
    """

    pitch_mm: float
    keepout_mm: float
    height_mm: float
    radius_mm: float = POST_RADIUS_MM
    pin_radius_mm: float = PIN_RADIUS_MM
    pin_hole_mm: float = PIN_RADIUS_MM + PIN_CLEARANCE_MM


def post_span_mm(pitch_mm: float = POST_PITCH_MM) -> float:
    """The longest span between two supports a plate carried by posts can have, mm.

    The tile's side cut into spans of at most ``pitch_mm``, each end moved by the search.
    """
    return pitch_mm * (1.0 + 2.0 * SEARCH_FRACTION)


def post_plan(cfg: JobConfig, grid: TileGrid) -> PostPlan | None:
    """The posts of a mural's plates, or None for a one-plate job (its wall carries it).

    Only soft stencils of holes get posts (a hard stencil's plate is one plate in its wall).
    """
    if not grid.tiled or cfg.mode.value != "soft":
        return None
    height = min(cfg.standoff.walls_mm)
    pitch = post_pitch_mm(cfg) if grid.post_pitch_mm is None else grid.post_pitch_mm
    return PostPlan(pitch, POST_RADIUS_MM + shade_reach_mm(cfg), height)


def with_post_pitch(grid: TileGrid, cfg: JobConfig) -> TileGrid:
    """``grid`` with the spacing its posts aim at (:func:`post_pitch_mm`) when it is a mural's; a one-plate job's as it is.

    A one-plate job's plate stands in its wall, on no posts: its grid stays the plain one tile
    (:meth:`TileGrid.whole`), the same as the plate-design trials', so the job finds the holes they
    made (kept by the tiling).
    """
    return replace(grid, post_pitch_mm=post_pitch_mm(cfg)) if grid.tiled else grid


def post_pitch_mm(cfg: JobConfig) -> float:
    """The targets' spacing: :data:`SINGLE_LAYER_POST_PITCH_MM` where the plate may be one FDM layer, else :data:`POST_PITCH_MM`.

    One layer where the job fills the thickness in (``cfg`` is the maker's: its
    :attr:`~stencil_cad.config.job.JobConfig.fills_thickness`) and the label needs no floor (an
    engraving needs two layers). The tiling asks it once and keeps it
    (:attr:`~stencil_cad.mural.tiling.TileGrid.post_pitch_mm`): the plan's config has the thickness filled in.
    """
    single = (
        cfg.stipple.process.record.method is Method.extrude
        and job_label(cfg) is not LabelMode.engrave
        and cfg.fills_thickness
    )
    return SINGLE_LAYER_POST_PITCH_MM if single else POST_PITCH_MM


def shade_reach_mm(cfg: JobConfig) -> float:
    """How far from a hole's edge a post's foot must stand to shade almost none of its spray, mm.

    :data:`SHADE_SIGMAS` of the widest blur of any layer's can under the tallest wall: the paint a
    post at that distance stops is the Gaussian's tail beyond it, within the narrow angle the foot
    subtends (under 1 % of the hole's paint). A model without one blur (the paper's): the mural's spray halo.
    """
    from ..simulate.models import sprayer

    sigma = sprayer(cfg.spray).widest_blur_mm(cfg)
    if sigma is None:
        return spray_halo_mm(cfg)
    return SHADE_SIGMAS * sigma


def sag_side_mm(grid: TileGrid, cfg: JobConfig) -> float:
    """The plate side the sag rule fills the thickness in for, mm.

    The longest plate of the tiling, resting on its wall's ledge; for plates carried by posts, the
    square that sags as much as a panel between posts (when that is smaller).
    """
    from ..config.thickness import column_side_mm
    from .tiling import part_sizes

    side = max(max(part_sizes(*t.part_size, cfg)["plate"]) for t in grid.tiles)
    plan = post_plan(cfg, grid)
    if plan is None:
        return side
    return min(side, column_side_mm(post_span_mm(plan.pitch_mm)))


def targets(w: float, h: float, pitch: float) -> np.ndarray:
    """The interior grid points of a ``w`` × ``h`` mm sheet cut into spans of at most ``pitch``."""
    m, n = max(1, math.ceil(w / pitch - 1e-9)), max(1, math.ceil(h / pitch - 1e-9))
    xs = [w * i / m for i in range(1, m)]
    ys = [h * j / n for j in range(1, n)]
    return np.array([(x, y) for y in ys for x in xs], dtype=np.float64).reshape(-1, 2)


def _conflicts(
    cands: np.ndarray,
    xy: np.ndarray,
    r: np.ndarray,
    windows: np.ndarray,
    keepout: float,
    rings: Sequence[np.ndarray] = (),
) -> tuple[np.ndarray, list[list[int]]]:
    """Per candidate, the holes whose edge enters its keep-out disc, and their count.

    A window's edge near a candidate, or the candidate inside a window ``rings``, weighs so much
    that it is never chosen while another is.
    """
    from scipy.spatial import cKDTree

    counts = np.zeros(len(cands), dtype=np.int64)
    hits: list[list[int]] = [[] for _ in range(len(cands))]
    if len(xy):
        tree = cKDTree(xy)
        reach = keepout + float(np.max(r))
        for c, near in enumerate(tree.query_ball_point(cands, reach)):
            if near:
                idx = np.asarray(near, dtype=np.int64)
                d = np.hypot(*(xy[idx] - cands[c]).T)
                inside = sorted(int(i) for i in idx[d < keepout + r[idx]])
                hits[c] = inside
                counts[c] = len(inside)
    if len(windows):
        wtree = cKDTree(windows)
        for c, near in enumerate(wtree.query_ball_point(cands, keepout)):
            counts[c] += _WINDOW_WEIGHT * len(near)
    for ring in rings:
        counts += _WINDOW_WEIGHT * _inside(cands, ring)
    return counts, hits


def _inside(pts: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Whether each point lies inside the closed ring (even-odd ray casting)."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    a, b = ring, np.roll(ring, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    odd: np.ndarray = np.count_nonzero(crosses & (x < xc), axis=1) % 2 == 1
    return odd


def _dense(ring: np.ndarray, step_mm: float = 0.5) -> np.ndarray:
    """Points along a closed ring at most ``step_mm`` apart (a window's edges, not only its corners)."""
    ring = ring.reshape(-1, 2)
    nxt = np.roll(ring, -1, axis=0)
    out = [ring]
    for a, b in zip(ring, nxt, strict=True):
        n = int(np.ceil(np.hypot(*(b - a)) / step_mm))
        if n > 1:
            t = np.arange(1, n)[:, None] / n
            out.append(a + t * (b - a))
    return np.vstack(out)


def post_sites(
    ds: DotSet, sheet: tuple[float, float, float, float], plan: PostPlan
) -> tuple[np.ndarray, list[int]]:
    """The posts under one plate and the holes they displace.

    Args:
        ds: The layer's holes over the whole mural (mural mm).
        sheet: The tile's sheet ``(x0, y0, x1, y1)`` in mural mm.
        plan: The job's posts.

    Returns:
        ``(sites, dropped)``: ``(P, 2)`` post centres in mural mm, and the indices into ``ds`` of
        the holes inside a chosen site's keep-out disc (sorted; empty when every site is clear).
    """
    x0, y0, x1, y1 = sheet
    aims = targets(x1 - x0, y1 - y0, plan.pitch_mm) + np.array([x0, y0])
    xy = np.asarray(ds.xy_mm, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(ds.r_mm, dtype=np.float64)
    rings = [np.asarray(o, dtype=np.float64).reshape(-1, 2) for o, _ in ds.windows]
    windows = (
        np.vstack([_dense(np.asarray(o, dtype=np.float64)) for o, _ in ds.windows])
        if ds.windows
        else np.zeros((0, 2))
    )
    sites, dropped = [], set()
    for t in aims:
        for frac in (SEARCH_FRACTION, WIDE_SEARCH_FRACTION):
            s = frac * plan.pitch_mm
            offsets = np.arange(-s, s + 1e-9, CANDIDATE_STEP_MM)
            cands = t + np.array([(dx, dy) for dy in offsets for dx in offsets])
            counts, hits = _conflicts(cands, xy, r, windows, plan.keepout_mm, rings)
            dist = np.hypot(*(cands - t).T)
            best = int(np.lexsort((dist, counts))[0])
            if counts[best] < _WINDOW_WEIGHT:
                sites.append(cands[best])
                dropped.update(hits[best])
                break
        # Else a window (the layer sprays everything there) fills the whole neighbourhood: no post.
    return np.array(sites, dtype=np.float64).reshape(-1, 2), sorted(dropped)


def clear_post_sites(
    dotsets: Sequence[DotSet], grid: TileGrid, plan: PostPlan | None
) -> tuple[list[DotSet], int]:
    """Every layer with the holes its posts would shade dropped, and how many were dropped.

    Args:
        dotsets: Each layer's holes over the whole mural (mural mm).
        grid: The tiling.
        plan: The job's posts (None: the holes come back as they are).
    """
    if plan is None:
        return list(dotsets), 0
    out, total = [], 0
    for ds in dotsets:
        drop: set[int] = set()
        for t in grid.tiles:
            drop.update(post_sites(ds, t.sheet, plan)[1])
        if drop:
            keep = np.ones(len(ds), dtype=bool)
            keep[sorted(drop)] = False
            report = {**ds.report, "removed_post": int(len(drop))}
            ds = replace(ds, xy_mm=ds.xy_mm[keep], r_mm=ds.r_mm[keep], report=report)
            total += len(drop)
        out.append(ds)
    return out, total


def with_pin_holes(holes: DotSet, sites_mm: np.ndarray, plan: PostPlan) -> DotSet:
    """A plate's holes (tile frame) with a pin hole at every post site (tile frame) after them."""
    sites = np.asarray(sites_mm, dtype=np.float64).reshape(-1, 2)
    if not len(sites):
        return holes
    return replace(
        holes,
        xy_mm=np.vstack([np.asarray(holes.xy_mm, dtype=np.float64).reshape(-1, 2), sites]),
        r_mm=np.concatenate(
            [np.asarray(holes.r_mm, dtype=np.float64), np.full(len(sites), plan.pin_hole_mm)]
        ),
    )
