"""One layer's holes as the refinement's optimisation state, and their projection onto the design rules.

:class:`_Layer` holds a layer's centres, radii and Adam moments in mm; :func:`_project` pulls
them back onto the rules after every step (see :mod:`.refine`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..frames import mm_to_px
from .refine_kernels import _cell_pairs, _project_pairs, _revert_broken
from .rules import NUDGE_SLACK_MM, DesignRules, _keepout_clearance, _push_out_of_keepouts

#: The spray model's per-hole contract, bound to the spray settings:
#: ``kernels(r_mm, spray_time) -> (sigma_mm, peak, dsigma_dr, dpeak_dr, combine)``
#: (see :func:`stencil_cad.simulate.spray.hole_kernels`).
Kernels = Callable[[np.ndarray, float], tuple]
#: One can's kernels: the same for every layer, or one per layer (each paint its own profile).
CanKernels = Kernels | Sequence[Kernels]


def layer_kernels(kernels: CanKernels, k: int) -> Kernels:
    """Layer ``k``'s kernels of one can: ``kernels`` itself, or its ``k``-th entry."""
    return kernels if callable(kernels) else kernels[k]


#: Rule tolerance of the refinement's own check, mm (a quarter of ``check_rules``' default).
_TOL_MM = 2.5e-4


# --------------------------------------------------------------------------- one layer's holes

#: Extra reach of a layer's neighbour list in mm: the list stays valid while no hole has
#: moved half of it from where the list was made (a Verlet list), so the pair search runs
#: every few steps rather than once per revert round.
_SKIN_MM = 0.4


@dataclass
class _Layer:
    """Mutable optimisation state of one layer's holes (mm, picture frame)."""

    x: np.ndarray
    y: np.ndarray
    r: np.ndarray
    rules: DesignRules
    spray_time: float
    rmax: float
    m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    v: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    added: int = 0
    removed: int = 0
    reverted: int = 0
    pairs: np.ndarray | None = None
    ref: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros(0))
    skin: float = _SKIN_MM
    #: Each hole's index in the input DotSet (-1 for a hole the add moves placed).
    ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: The last kernels computed for these radii: ``(kernels, spray_time, r, kernels' output)``.
    kernel_memo: tuple[Any, ...] | None = field(default=None, repr=False, compare=False)

    def reset_moments(self) -> None:
        self.m = np.zeros((len(self.x), 3))
        self.v = np.zeros((len(self.x), 3))

    def keep(self, mask: np.ndarray) -> None:
        """Keep the holes of ``mask`` (a boolean mask or an index array, in the new order)."""
        self.x, self.y, self.r = self.x[mask], self.y[mask], self.r[mask]
        self.m, self.v = self.m[mask], self.v[mask]
        self.ids = self.ids[mask]
        self.pairs = None

    def input_order(self) -> np.ndarray:
        """Indices that put the holes back in the input's order, the added ones after them."""
        last = int(self.ids.max(initial=-1)) + 1
        return np.argsort(np.where(self.ids >= 0, self.ids, last), kind="stable")

    def sort(self, band_mm: float) -> None:
        """Order the holes by bands of ``band_mm`` across, then along x.

        Neighbouring holes then touch neighbouring pixels one after the other: the per-hole
        gradient ran 4x faster on 100,000 holes than in the stippler's order (cache misses).
        """
        self.keep(np.lexsort((self.x, np.floor(self.y / band_mm))))


def _layer_kernels(layer: _Layer, kernels: Kernels) -> tuple[Any, ...]:
    """``kernels(layer.r, layer.spray_time)``, computed once for the same kernels and radii.

    Each refinement step evaluates the objective at the new holes and then takes the gradient at the
    same holes under the same can: the per-hole kernels (the plate's shading quadrature) were computed
    twice, a quarter of the refinement's time on the example.
    """
    memo = layer.kernel_memo
    if (
        memo is not None
        and memo[0] is kernels
        and memo[1] == layer.spray_time
        and memo[2].shape == layer.r.shape
        and np.array_equal(memo[2], layer.r)
    ):
        return memo[3]
    out = kernels(layer.r, layer.spray_time)
    layer.kernel_memo = (kernels, layer.spray_time, layer.r.copy(), out)
    return out


def _kernels_px(layer: _Layer, kernels: Kernels, pitch: float, height_px: int):
    sigma, peak, dsig, dpeak, combine = _layer_kernels(layer, kernels)
    rc = mm_to_px(np.column_stack([layer.x, layer.y]), height_px, pitch)
    return (
        np.ascontiguousarray(rc[:, 0]),
        np.ascontiguousarray(rc[:, 1]),
        np.ascontiguousarray(sigma / pitch),
        np.ascontiguousarray(peak, dtype=np.float64),
        dsig,
        dpeak,
        combine == "exp",
    )


def _box_and_keepouts(x, y, r, rules: DesignRules) -> None:
    lo = rules.edge_margin_mm + r + NUDGE_SLACK_MM
    np.clip(x, lo, rules.width_mm - lo, out=x)
    np.clip(y, lo, rules.height_mm - lo, out=y)
    if rules.keepouts:
        xy = np.column_stack([x, y])
        _push_out_of_keepouts(xy, r, rules)
        x[:] = xy[:, 0]
        y[:] = xy[:, 1]


def _self_broken(x, y, r, rules: DesignRules) -> np.ndarray:
    """Holes that break a rule of their own (radius floor, margin box, keep-outs)."""
    # The tolerance is a quarter of check_rules' (which covers the CSV's rounding): holes read
    # back from a CSV may sit that close to a limit, and must count as good here.
    m = rules.edge_margin_mm - _TOL_MM
    bad = (r < rules.hole_min_r_mm - _TOL_MM) | (x < m + r) | (x > rules.width_mm - m - r)
    bad |= (y < m + r) | (y > rules.height_mm - m - r)
    if rules.keepouts:
        bad |= _keepout_clearance(np.column_stack([x, y]), rules.keepouts) < r + m
    return bad


def _drift(x, y, ref_x, ref_y) -> float:
    return float(np.max(np.hypot(x - ref_x, y - ref_y), initial=0.0))


def _neighbours(layer: _Layer, old: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Every pair of holes that can break the web, with the holes where they are now or at ``old``.

    A pair matters only closer than ``2 rmax + web``; the list holds the pairs closer than
    that plus the skin where it was made, so it holds every pair that matters while no
    hole, now or at ``old``, is more than half the skin from there.
    """
    base = 2.0 * layer.rmax + layer.rules.web_mm + NUDGE_SLACK_MM
    if layer.pairs is not None:
        rx, ry = layer.ref
        if max(_drift(layer.x, layer.y, rx, ry), _drift(*old, rx, ry)) <= 0.5 * layer.skin:
            return layer.pairs
    layer.skin = max(_SKIN_MM, 2.0 * _drift(*old, layer.x, layer.y) + 1e-9)
    layer.pairs = _cell_pairs(layer.x, layer.y, base + layer.skin)
    layer.ref = (layer.x.copy(), layer.y.copy())
    return layer.pairs


def _project(layer: _Layer, x0, y0, r0) -> None:
    """Project the layer's holes onto the rules; revert holes that still break one to (x0, y0, r0)."""
    rules = layer.rules
    x, y, r = layer.x, layer.y, layer.r
    np.clip(r, rules.hole_min_r_mm, layer.rmax, out=r)
    if len(x) > 1:
        pairs = _neighbours(layer, (x0, y0))
        _project_pairs(pairs, x, y, r, rules.hole_min_r_mm, rules.web_mm + NUDGE_SLACK_MM, 4)
    _box_and_keepouts(x, y, r, rules)
    self_bad = _self_broken(x, y, r, rules)
    pairs = _neighbours(layer, (x0, y0)) if len(x) > 1 else np.empty((0, 2), dtype=np.int64)
    layer.reverted += _revert_broken(pairs, x, y, r, x0, y0, r0, self_bad, rules.web_mm - _TOL_MM)
