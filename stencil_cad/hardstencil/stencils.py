"""The hard-stencil stage: flat-colour segmentation, one cut stencil per colour, islands held by bridges.

The paper's baseline (Vavilala 2015, after Jain et al. 2015). The lightest colour
is the primer (the surface colour), so K colours give K - 1 cut stencils; they are
sprayed in order, each covering the earlier ones.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
from skimage.color import rgb2lab

from ..colour import to_hex
from ..config.hard import HardConfig, SprayOrder
from ..model import CutLayer, Picture, composite
from ..simulate.opacity import spray_mask
from .segment import hex_to_rgb
from .segment import segment as segment_image
from .topology import (
    CHEAP,
    bridge_footprint,
    mask_to_polygons,
    polygon_sheet_check,
    process_layer,
    rasterise_polygons,
)

log = logging.getLogger(__name__)

__all__ = ["HardResult", "make_hard_stencils", "render_ideal", "simulate_hard"]


@dataclass(frozen=True)
class HardResult:
    """The hard stencils of one picture.

    Attributes:
        labels: ``(H, W)`` int, the segmentation: index into ``palette`` per pixel.
        palette: ``(K, 3)`` float in [0, 1], the flat colours **in spray order**;
            ``palette[0]`` is the primer.
        order: ``(K,)`` int, palette indices in spray order (``0..K-1``, since the
            palette is stored in spray order).
        cut_masks: ``(L, H, W)`` bool, the open (cut) area of each layer, in spray order.
        cut_layers: One :class:`~stencil_cad.model.CutLayer` per cut mask: polygons
            in mm (outer rings counter-clockwise, holes clockwise, rings not closed).
        primer: ``(3,)`` float in [0, 1], the surface colour (``palette[0]``).
        painted: ``(H, W)`` int, the palette index each pixel ends up with when the
            layers are sprayed sharp and opaque (the segmentation after cut
            widening, trimming and bridges).
        layer_palette_index: ``(L,)`` int, the palette index of each cut layer.
        mm_per_px: Pixel size of the rasters in mm.
        report: Figures: counts of regions merged, islands bridged, bridges, regions
            widened / dropped, per-layer details and ``warnings``.
    """

    labels: np.ndarray
    palette: np.ndarray
    order: np.ndarray
    cut_masks: np.ndarray
    cut_layers: list
    primer: np.ndarray
    painted: np.ndarray
    layer_palette_index: np.ndarray
    mm_per_px: float
    report: dict = field(default_factory=dict)

    @property
    def count(self) -> int:
        """Number of cut layers L."""
        return int(self.cut_masks.shape[0])

    @property
    def colours(self) -> np.ndarray:
        """``(L, 3)`` paint colour of each cut layer, in spray order."""
        return self.palette[self.layer_palette_index].reshape(-1, 3)


def _spray_order(palette: np.ndarray, order: SprayOrder) -> np.ndarray:
    if order == SprayOrder.given:
        return np.arange(palette.shape[0])
    lightness = rgb2lab(palette.reshape(1, -1, 3))[0, :, 0]
    idx = np.argsort(lightness, kind="stable")
    return idx[::-1] if order == SprayOrder.light_to_dark else idx


def make_hard_stencils(
    picture: Picture,
    cfg: HardConfig,
    min_feature_mm: float,
    bridge_min_mm: float,
    rng: np.random.Generator,
) -> HardResult:
    """Segment a picture into flat colours and make one bridged cut stencil per paint colour.

    Args:
        picture: The picture on the working grid.
        cfg: The ``hard`` config section.
        min_feature_mm: Smallest cut feature the process makes, in mm (from the
            stipple process preset). Thinner cut-outs are widened or dropped;
            smaller regions are merged.
        bridge_min_mm: Narrowest bridge the process holds, in mm.
        rng: Random generator (K-means seeding).

    Returns:
        The :class:`HardResult`. Where the picture has an alpha channel below 0.5
        nothing is cut (the primer shows).

    Raises:
        ValueError: ``cfg.bridge_width_mm`` is below ``bridge_min_mm``, or a size
            is not positive.
    """
    s = float(picture.mm_per_px)
    bridge_mm = _bridge_width(s, min_feature_mm, bridge_min_mm, cfg)
    rgb = np.clip(np.asarray(picture.rgb, dtype=np.float64), 0.0, 1.0)
    h, w = rgb.shape[:2]
    min_px = max(cfg.min_region_mm2, min_feature_mm**2) / s**2
    fixed = hex_to_rgb(hexes) if (hexes := cfg.palette_hex()) is not None else None
    t0 = time.perf_counter()
    labels, colours, seg = segment_image(
        rgb, cfg.colours, cfg.smoothness, min_px, rng, palette=fixed, sweeps=cfg.sweeps, rounds=cfg.rounds
    )
    warnings = list(seg["warnings"])
    t_segment = time.perf_counter() - t0
    palette, labels = _in_spray_order(labels, colours, cfg.order)
    k = palette.shape[0]
    labels, transparent = _primer_where_clear(labels, picture.alpha)
    if k < 2:
        warnings.append("only one colour is left: the primer alone, no cut layers")

    bridge_px = bridge_mm / s
    painted, masks, layers, idx, per_layer = _cut_layers(
        labels, palette, cfg, s, min_feature_mm, bridge_mm, warnings
    )

    t_layers = time.perf_counter() - t0 - t_segment
    report = _report(
        seg,
        palette,
        per_layer,
        warnings,
        layers=len(layers),
        bridge_width_mm=bridge_mm,
        # Bridges are drawn one working pixel wider than asked (see topology.bridge_footprint).
        bridge_drawn_mm=float(bridge_footprint(bridge_px).shape[0] * s),
        min_feature_mm=float(min_feature_mm),
        min_region_px=float(min_px),
        painted_changed_px=int(np.count_nonzero(painted != labels)),
        transparent_px=transparent,
        seconds={"segment": round(t_segment, 3), "layers": round(t_layers, 3)},
    )
    for msg in warnings[len(seg["warnings"]) :]:
        log.warning(msg)
    cut_masks = np.array(masks, dtype=bool).reshape(len(masks), h, w)
    return HardResult(
        labels=labels,
        palette=palette,
        order=np.arange(k),
        cut_masks=cut_masks,
        cut_layers=layers,
        primer=palette[0].copy(),
        painted=painted,
        layer_palette_index=np.array(idx, dtype=np.intp),
        mm_per_px=s,
        report=report,
    )


def _in_spray_order(labels: np.ndarray, colours: np.ndarray, mode) -> tuple[np.ndarray, np.ndarray]:
    """The palette in spray order (the primer first) and the labels renumbered to it."""
    order = _spray_order(colours, mode)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return colours[order], rank[labels]


def _primer_where_clear(labels: np.ndarray, alpha) -> tuple[np.ndarray, int]:
    """Labels with the transparent parts (alpha below 0.5) left unpainted, and how many pixels they are."""
    if alpha is None:
        return labels, 0
    # Transparent parts of the image are left unpainted: they keep the primer.
    clear = np.asarray(alpha) < 0.5
    return np.where(clear, 0, labels), int(np.count_nonzero(clear))


def _bridge_width(s: float, min_feature_mm: float, bridge_min_mm: float, cfg: HardConfig) -> float:
    """The bridge width in mm: ``hard.bridge_width_mm``, or the process minimum.

    Raises:
        ValueError: A size is not positive, or the width is below the process minimum.
    """
    if not (s > 0 and min_feature_mm > 0 and bridge_min_mm > 0):
        raise ValueError(
            f"mm_per_px, min_feature_mm and bridge_min_mm must be > 0, got {s}, {min_feature_mm}, {bridge_min_mm}"
        )
    bridge_mm = float(bridge_min_mm if cfg.bridge_width_mm is None else cfg.bridge_width_mm)
    if bridge_mm < bridge_min_mm - 1e-9:
        raise ValueError(
            f"hard.bridge_width_mm must be ≥ the process minimum bridge width ({bridge_min_mm} mm), got {bridge_mm}"
        )
    return bridge_mm


def _cut_layers(
    labels: np.ndarray,
    palette: np.ndarray,
    cfg: HardConfig,
    s: float,
    min_feature_mm: float,
    bridge_mm: float,
    warnings: list[str],
):
    """One bridged cut layer per paint colour (the primer, colour 0, has none), bottom up.

    Returns:
        ``(painted, masks, layers, palette indices, per-layer reports)``; ``painted`` is the
        colour each pixel ends up with. Warnings are appended to ``warnings``.
    """
    h, w = labels.shape
    k = palette.shape[0]
    pal_lab = rgb2lab(palette.reshape(1, -1, 3))[0]
    painted = np.zeros((h, w), dtype=np.intp)
    masks, layers, idx, per_layer = [], [], [], []
    for j in range(1, k):
        # Bridges cost little where a later layer covers them, else by how much they show.
        visible_de = np.linalg.norm(pal_lab[painted] - pal_lab[j], axis=-1)
        cost = np.where(labels > j, CHEAP, 1.0 + cfg.bridge_visibility_weight * visible_de / 100.0)
        cut, rep, polys = _cut_layer(labels == j, labels > j, cost, cfg, s, min_feature_mm, bridge_mm)
        rep["palette_index"] = j
        if not cut.any():
            warnings.append(
                f"colour {j} ({to_hex(palette[j])}) has nothing left to cut; its layer is skipped"
            )
            per_layer.append(rep)
            continue
        pieces = (rep["sheet_components"], rep["robust_components"], rep["polygon_held_components"])
        if pieces != (1, 1, 1):
            warnings.append(
                f"layer of colour {j}: the sheet is in {pieces[0]} pieces ({pieces[1]} bridge-wide on the "
                f"raster, {pieces[2]} on the polygons); expected 1"
            )
        painted[cut] = j
        masks.append(cut)
        idx.append(j)
        per_layer.append(rep)
        layers.append(CutLayer(polygons=polys, colour=palette[j].copy(), report=rep))
    return painted, masks, layers, idx, per_layer


def _cut_layer(
    own: np.ndarray,
    later: np.ndarray,
    cost: np.ndarray,
    cfg: HardConfig,
    s: float,
    min_feature_mm: float,
    bridge_mm: float,
) -> tuple[np.ndarray, dict, list]:
    """One colour's cut mask (islands bridged), its polygons in mm and their checks.

    Args:
        own: ``(H, W)`` bool, where this colour is the top colour.
        later: ``(H, W)`` bool, where a later (darker) colour covers.
        cost: ``(H, W)`` cost of a bridge per pixel.
        cfg: The ``hard`` config section.
        s: Pixel size in mm.
        min_feature_mm: Smallest cut feature in mm.
        bridge_mm: Bridge width in mm.

    Returns:
        ``(cut, report, polygons)``.
    """
    shape = own.shape
    cut, rep = process_layer(own, later, cost, min_feature_mm / s, bridge_mm / s, cfg.union_cut)
    polys = mask_to_polygons(cut, s, cfg.simplify_tolerance_mm)
    back = rasterise_polygons(polys, shape, s)
    rep["polygons"] = len(polys)
    rep["polygon_holes"] = int(sum(len(p[1]) for p in polys))
    rep["polygon_mismatch_px"] = int(np.count_nonzero(back != cut))
    rep.update(polygon_sheet_check(polys, shape, s, bridge_mm))
    rep["cut_area_mm2"] = float(np.count_nonzero(cut) * s * s)
    return cut, rep, polys


def _report(
    seg: dict, palette: np.ndarray, per_layer: list[dict], warnings: list[str], **figures: object
) -> dict:
    """The figures of a hard-stencil run for the manifest, in the manifest's order.

    ``figures`` holds ``layers``, ``bridge_width_mm``, ``bridge_drawn_mm``,
    ``min_feature_mm``, ``min_region_px``, ``painted_changed_px``, ``transparent_px``
    and ``seconds``.
    """

    def total(key: str) -> int:
        return int(sum(r.get(key, 0) for r in per_layer))

    f = figures
    return {
        "colours_requested": seg["colours_requested"],
        "colours": int(palette.shape[0]),
        "layers": f["layers"],
        "distinct_colours": seg["distinct_colours"],
        "regions_merged": seg["regions_merged"],
        "islands_bridged": total("islands"),
        "bridges": total("bridges"),
        "islands_cut_as_later": total("islands_cut_as_later"),
        "islands_dropped": total("islands_dropped"),
        "regions_widened": total("regions_widened"),
        "regions_dropped": total("regions_dropped"),
        "trimmed_px": total("trimmed_px"),
        "bridge_width_mm": f["bridge_width_mm"],
        "bridge_drawn_mm": f["bridge_drawn_mm"],
        "min_feature_mm": f["min_feature_mm"],
        "min_region_px": f["min_region_px"],
        "painted_changed_px": f["painted_changed_px"],
        "transparent_px": f["transparent_px"],
        "sweeps": seg["sweeps"],
        "energy": seg["energy"],
        "palette": [to_hex(c) for c in palette],
        "seconds": f["seconds"],
        "per_layer": per_layer,
        "warnings": warnings,
    }


def render_ideal(result: HardResult) -> np.ndarray:
    """The picture the layers give when sprayed sharp and opaque: ``(H, W, 3)`` in [0, 1]."""
    return result.palette[result.painted]


def simulate_hard(
    result: HardResult, spray_cfg, *, geometry=None, layer_sprays=None
) -> tuple[np.ndarray, np.ndarray]:
    """Spray every cut layer with the simulator's spray model and composite.

    Args:
        result: The hard stencils.
        spray_cfg: A :class:`~stencil_cad.config.spray.SprayConfig`.
        geometry: Stand-off and plate thickness (physical spray model only).
        layer_sprays: Each cut layer's spray settings (its paint's profile), or None: ``spray_cfg``.

    Returns:
        ``(alphas, composite)``: ``(L, H, W)`` simulated opacities and the
        ``(H, W, 3)`` composite in [0, 1].
    """
    from ..simulate.spray import per_layer

    sprays = per_layer(spray_cfg, layer_sprays, len(result.cut_masks))
    alphas = np.stack(
        [
            spray_mask(m, result.mm_per_px, sp, geometry=geometry)
            for m, sp in zip(result.cut_masks, sprays, strict=True)
        ]
    ).reshape(result.count, *result.labels.shape)
    comp = np.clip(composite(result.primer, result.colours, alphas), 0.0, 1.0)
    return alphas, comp
