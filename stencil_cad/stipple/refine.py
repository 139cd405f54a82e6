"""Model-based hole refinement: move and resize the stippled holes so the sprayed picture matches.

The stippler places holes by density alone; what the viewer sees is the composite of all
layers sprayed through them. This stage optimises every hole's centre and radius against
the spray model (least-squares model-based halftoning, Pappas & Neuhoff 1999; the add/remove
moves follow direct binary search, Analoui & Allebach 1992), with the design rules held
after every step.

Objective. On the simulation grid, with ``C(p)`` the composite of the primer and every
layer sprayed in order (Porter-Duff *over*) and ``C*(p)`` the input picture::

    E = sum_p |g * (C - C*)|^2(p)

(``p`` over the whole plane, the error zero outside the picture; images in float32)
where ``g`` is a Gaussian of the eye's narrowest (luminance) lobe at the viewing distance
(:func:`stencil_cad.simulate.scielab.smallest_sigma_mm`): error finer than the eye resolves from
there costs nothing. Each layer's own filtered opacity error ``sum_p (g * (alpha_l -
alpha*_l))^2`` is added with a weight (``refine.layer_weight``): the composite alone
lets one layer drift from its target to make up for another's colour. The composite is affine in each layer's opacity ``alpha_l``:
``dC/dalpha_l = (c_l - C_{l-1}) prod_{m > l} (1 - alpha_m)``, so ``dE/dalpha_l`` is one
pass over the layers. Each layer's opacity follows the per-hole contract of
:func:`stencil_cad.simulate.spray.hole_kernels` (Gaussian deposits ``N_i`` of width ``sigma_i``
and height ``peak_i`` combined as a product of transmittances or an exponential of the
summed dose), whose derivative with respect to a hole's centre and radius is exact:

* product: ``dalpha/dN_i = T / (1 - N_i)`` where ``N_i < 1`` (0 where the hole clamps);
* exp: ``dalpha/dN_i = T``;

with ``T = 1 - alpha`` and ``dN_i/dc = N_i (p - c) / sigma^2``,
``dN_i/dr = N_i |p - c|^2 / sigma^3 dsigma/dr + N_i / peak dpeak/dr``. A hole touches
the pixels within the distance where its deposit falls below ``1e-4`` (a few sigma), in
compiled code, so one iteration is linear in the number of holes.

Steps are Adam's (Kingma & Ba 2015) with a decaying step size. After every step the
holes are projected onto the design rules: radii are clamped to ``[floor, max]``; each
pair closer than the web first shrinks both radii (towards the floor), and only the
deficit left is resolved by pushing the centres apart (pushing first made the later rule
enforcement remove a third of the holes in a prototype); centres are clamped into the
edge-margin box and out of keep-outs. A hole that still breaks a rule after that goes
back to where it was before the step (that state passed the rules), until none does, so
the rules hold at every step, not just at the end.

Add / remove. Every few iterations each layer gets two moves scored on the composite
error: a hole is removed where removing it lowers ``E``, and a hole of the floor radius is
added at local minima of the predicted change of ``E`` where it fits the rules. The
composite is affine in one layer's opacity, so the change is
``dE ≈ sum_p G dalpha + Q dalpha^2`` with ``G = dE/dalpha`` and
``Q = |dC/dalpha|^2`` (exact without the eye filter); for an added hole both sums are
Gaussian filters of ``G T`` and ``Q T^2``.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..frames import px_to_mm
from ..model import DotSet
from .refine_holes import CanKernels, Kernels, _kernels_px, _Layer, _project, layer_kernels
from .refine_kernels import _BAND, _greedy_add, _removal_change
from .refine_objective import (
    ViewFilters,
    _Eval,
    _evaluate,
    _g_and_q,
    _gauss,
    _hole_grads,
    _layer_g_and_q,
    _Viewer,
)
from .rules import NUDGE_SLACK_MM, DesignRules, _keepout_clearance, check_rules

log = logging.getLogger(__name__)

__all__ = ["Kernels", "Paused", "RefineSettings", "ViewFilters", "refine_dots"]


#: Adam's moment decay rates and epsilon.
_B1, _B2, _EPS = 0.9, 0.99, 1e-12


@dataclass(frozen=True)
class RefineSettings:
    """Knobs of the refinement (the ``refine`` config section resolves to this).

    Attributes:
        iterations: Gradient steps.
        step_mm: Adam step size of the centres at the start, in mm (decays to a fifth).
        radius_step_mm: Adam step size of the radii at the start, in mm.
        max_radius_mm: Largest hole radius in mm (per layer the rules' floor is the smallest).
        add_remove_every: Add/remove moves every this many iterations (0: never).
        eye_sigma_mm: Standard deviation of the eye filter in the objective, mm (0: none).
        layer_weight: Weight of each layer's own opacity error beside the composite's.
        view: The viewer's filters: with them the composite's error is the viewer's colour
            error (:class:`_Viewer`); without, the sRGB error filtered by ``eye_sigma_mm``.
        stop_after: Stop after this many of the ``iterations`` steps (None: run them all). The
            steps taken are those of the whole refinement (its step sizes decay over
            ``iterations``), so the holes are the whole refinement's after that step: the
            plate-design trials rank two walls on them (:mod:`stencil_cad.pipeline.standoff`).
    """

    iterations: int = 60
    step_mm: float = 0.05
    radius_step_mm: float = 0.02
    max_radius_mm: float = 1.0
    add_remove_every: int = 15
    eye_sigma_mm: float = 0.0
    layer_weight: float = 1.0
    view: ViewFilters | None = None
    stop_after: int | None = None


# --------------------------------------------------------------------------- moves


def _remove_holes(layer, g, q, t, kernels, pitch, h) -> int:
    if len(layer.x) == 0:
        return 0
    rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, kernels, pitch, h)
    change = _removal_change(g, q, t, rows, cols, sig, peak, exp_mode)
    cand = np.flatnonzero(change < 0.0)
    if len(cand) == 0:
        return 0
    cand = cand[np.argsort(change[cand], kind="stable")]
    # Neighbours' predictions interact: remove at most one hole per neighbourhood per round.
    cell = 6.0 * float(sig.max())
    key_r = np.floor(rows / cell).astype(np.int64)
    key_c = np.floor(cols / cell).astype(np.int64)
    taken: set[tuple[int, int]] = set()
    drop = np.zeros(len(layer.x), dtype=bool)
    for i in cand:
        kr, kc = int(key_r[i]), int(key_c[i])
        if any((kr + a, kc + b) in taken for a in (-1, 0, 1) for b in (-1, 0, 1)):
            continue
        taken.add((kr, kc))
        drop[i] = True
    layer.keep(~drop)
    return int(drop.sum())


def _add_holes(layer, g, q, t, kernels, pitch, shape) -> int:
    from scipy.ndimage import minimum_filter

    rules = layer.rules
    h, w = shape
    r_new = rules.hole_min_r_mm
    sigma, peak, _, _, _ = kernels(np.array([r_new]), layer.spray_time)
    s_px = float(sigma[0]) / pitch
    a = min(float(peak[0]), 1.0)
    # Predicted change of E for a new hole centred on each pixel (see the module doc).
    lin = _gauss(g * t, s_px) * (2.0 * math.pi * s_px * s_px) * a
    quad = _gauss(q * t * t, s_px / math.sqrt(2.0)) * (math.pi * s_px * s_px) * a * a
    change = lin + quad
    spacing_px = (2.0 * r_new + rules.web_mm) / pitch
    local = change <= minimum_filter(change, size=max(3, int(spacing_px)), mode="nearest")
    cand = np.flatnonzero(local & (change < 0.0))
    if len(cand) == 0:
        return 0
    cand = cand[np.argsort(change.ravel()[cand], kind="stable")]
    rows, cols = np.divmod(cand, w)
    xy = px_to_mm(np.column_stack([rows, cols]).astype(np.float64), h, pitch)
    m = rules.edge_margin_mm + r_new + NUDGE_SLACK_MM
    inside = (
        (xy[:, 0] >= m)
        & (xy[:, 0] <= rules.width_mm - m)
        & (xy[:, 1] >= m)
        & (xy[:, 1] <= rules.height_mm - m)
    )
    if rules.keepouts:
        inside &= _keepout_clearance(xy, rules.keepouts) >= m
    xy = xy[inside]
    if len(xy) == 0:
        return 0
    web = rules.web_mm + NUDGE_SLACK_MM
    cell = 2.0 * layer.rmax + web
    cap = int(math.ceil((cell / (2.0 * r_new + rules.web_mm)) ** 2 * 2.0)) + 4
    ok = _greedy_add(
        np.ascontiguousarray(xy[:, 0]),
        np.ascontiguousarray(xy[:, 1]),
        layer.x,
        layer.y,
        layer.r,
        r_new,
        web,
        cell,
        cap,
    )
    n_new = int(ok.sum())
    if n_new:
        layer.x = np.concatenate([layer.x, xy[ok, 0]])
        layer.y = np.concatenate([layer.y, xy[ok, 1]])
        layer.r = np.concatenate([layer.r, np.full(n_new, r_new)])
        layer.m = np.concatenate([layer.m, np.zeros((n_new, 3))])
        layer.v = np.concatenate([layer.v, np.zeros((n_new, 3))])
        layer.ids = np.concatenate([layer.ids, np.full(n_new, -1, dtype=np.int64)])
        layer.sort(_BAND * pitch)
    return n_new


# --------------------------------------------------------------------------- the stage


def _adam_step(layer: _Layer, grad: np.ndarray, it: int, frac: float, settings: RefineSettings) -> None:
    """One Adam step of a layer's centres and radii (step sizes scaled by ``frac``), projected."""
    layer.m = _B1 * layer.m + (1.0 - _B1) * grad
    layer.v = _B2 * layer.v + (1.0 - _B2) * grad * grad
    mhat = layer.m / (1.0 - _B1**it)
    vhat = layer.v / (1.0 - _B2**it)
    step = mhat / (np.sqrt(vhat) + _EPS)
    x0, y0, r0 = layer.x.copy(), layer.y.copy(), layer.r.copy()
    layer.x = layer.x - frac * settings.step_mm * step[:, 0]
    layer.y = layer.y - frac * settings.step_mm * step[:, 1]
    layer.r = layer.r - frac * settings.radius_step_mm * step[:, 2]
    _project(layer, x0, y0, r0)


def _start_layers(
    dotsets: list[DotSet],
    rules: list[DesignRules],
    spray_times: list[float],
    settings: RefineSettings,
    mm_per_px: float,
) -> list[_Layer]:
    """Each layer's holes as the optimiser's state: float64 copies, fresh moments, in band order."""
    state = []
    for ds, rl, a in zip(dotsets, rules, spray_times, strict=True):
        rmax = max(settings.max_radius_mm, rl.hole_min_r_mm, float(np.max(ds.r_mm, initial=0.0)))
        layer = _Layer(
            x=np.array(ds.xy_mm[:, 0], dtype=np.float64),
            y=np.array(ds.xy_mm[:, 1], dtype=np.float64),
            r=np.array(ds.r_mm, dtype=np.float64),
            rules=rl,
            spray_time=float(a),
            rmax=rmax,
            ids=np.arange(len(ds), dtype=np.int64),
        )
        layer.reset_moments()
        layer.sort(_BAND * mm_per_px)
        state.append(layer)
    return state


def _add_and_remove(p: _Problem, ev: _Eval, final: bool) -> _Eval | None:
    """One round of removals and additions per layer, each scored on the composite.

    Each layer's moves read its ``G`` and ``Q`` after the layers before it moved (one layer at a
    time: moving all at once from one evaluation scored worse, the Hubble deep field S-CIELAB 3.01
    at 1 m against 2.93). Returns the evaluation after the round (``final``), else None: with a
    prior of cans the next step evaluates under another can anyway.
    """
    shape = p.target.shape[:2]
    trans = ev.trans.copy()
    g, q = _g_and_q(ev, 0)
    for k, layer in enumerate(p.state):
        kern = layer_kernels(p.kernels, k)
        removed = _remove_holes(layer, g, q, trans[k], kern, p.mm_per_px, shape[0])
        layer.removed += removed
        if removed:
            # With none removed the layers are as they were when layer k's G and Q were taken: the
            # same bits again (in the bundled example's refinement, `stencil-cad run`, 11 of the 40
            # layer rounds after the trials' 30 steps remove none).
            g, q = p.layer_g_and_q(trans, k, k)
        layer.added += _add_holes(layer, g, q, trans[k], kern, p.mm_per_px, shape)
        if k + 1 < len(p.state):
            g, q = p.layer_g_and_q(trans, k, k + 1)
    return p.evaluate() if final else None


def _refined(ds: DotSet, layer: _Layer) -> DotSet:
    """The layer's refined holes as a DotSet (input order first), checked against its rules."""
    layer.keep(layer.input_order())
    xy = np.column_stack([layer.x, layer.y])
    check_rules(xy, layer.r, layer.rules)
    rep = {
        **ds.report,
        "n_stippled": len(ds),
        "refine_added": layer.added,
        "refine_removed": layer.removed,
        "refine_reverted": layer.reverted,
        "n_final": len(layer.x),
    }
    return replace(ds, xy_mm=xy, r_mm=layer.r.copy(), report=rep)


def _check_counts(dotsets, rules, colours, spray_times, cans) -> None:
    """Raise ValueError unless there is one rule set, colour and spray time per DotSet, and a can's kernels."""
    n = len(dotsets)
    if not cans:
        raise ValueError("need the kernels of at least one can")
    if any(not callable(c) and len(c) != n for c in cans):
        raise ValueError(f"a can's kernels per layer need one entry per layer ({n})")
    if not (len(rules) == len(colours) == len(spray_times) == n):
        raise ValueError(
            f"need one rule set, colour and spray time per DotSet: {n} DotSets, {len(rules)} rules, "
            f"{len(colours)} colours, {len(spray_times)} spray times"
        )


@dataclass
class _Problem:
    """What the objective is evaluated on: the holes' state, the can whose kernels apply now, the targets."""

    state: list[_Layer]
    kernels: CanKernels
    mm_per_px: float
    target: np.ndarray
    alpha_targets: np.ndarray | None
    lam: float
    primer: np.ndarray
    colours: np.ndarray
    eye_px: float
    viewer: _Viewer | None
    fixed_trans: np.ndarray | None = None

    def _common(
        self,
    ) -> tuple[
        list[_Layer], CanKernels, float, np.ndarray, np.ndarray | None, float, np.ndarray, np.ndarray, float
    ]:
        """The arguments every evaluation takes first."""
        return (
            self.state,
            self.kernels,
            self.mm_per_px,
            self.target,
            self.alpha_targets,
            self.lam,
            self.primer,
            self.colours,
            self.eye_px,
        )

    def layer_g_and_q(self, trans: np.ndarray, changed: int, want: int) -> tuple[np.ndarray, np.ndarray]:
        """Layer ``want``'s ``G`` and ``Q`` after layer ``changed`` moved (``trans`` updated in place)."""
        return _layer_g_and_q(
            *self._common(),
            viewer=self.viewer,
            fixed_trans=self.fixed_trans,
            trans=trans,
            changed=changed,
            want=want,
        )

    def evaluate(self, want_q: bool = False) -> _Eval:
        """The objective and its gradients at the current state, under the current can."""
        return _evaluate(*self._common(), want_q=want_q, viewer=self.viewer, fixed_trans=self.fixed_trans)


@dataclass(frozen=True)
class Paused:
    """A refinement stopped part way (``stop_after``), to be carried on to its end (``resume``).

    The holes' state after step ``step`` of ``iterations`` (positions, Adam moments, neighbour lists,
    add/remove counts), the index of the can whose kernels the next step takes, the evaluation the
    next step's gradient reads and the objective before the first step, all copied when it stopped.
    Carried on, the refinement takes the very steps it takes unstopped: the plate-design trials
    refine the winning wall's first :data:`stencil_cad.pipeline.standoff.RANK_AFTER` steps, and the
    job's refinement of that wall goes on from there instead of taking them again.
    """

    step: int
    iterations: int
    state: list[_Layer]
    can: int
    ev: _Eval
    e_start: float


def _paused(
    p: _Problem, cans: list[CanKernels], ev: _Eval, step: int, iterations: int, e_start: float
) -> Paused:
    """A copy of the refinement's state after ``step`` (the kernels' memo left out: it is a cache)."""
    state = [copy.deepcopy(replace(layer, kernel_memo=None)) for layer in p.state]
    can = next(i for i, c in enumerate(cans) if c is p.kernels)
    return Paused(step, iterations, state, can, copy.deepcopy(ev), e_start)


def _iterate(
    p: _Problem, cans: list[CanKernels], ev: _Eval, settings: RefineSettings, progress, first: int = 1
) -> _Eval:
    """Run the Adam steps and the add/remove rounds from step ``first`` on, from ``ev``.

    The last step's evaluation is under the can the next step would take; :func:`_nominal` turns it
    to the nominal can's.
    """
    shape = p.target.shape[:2]
    iters = settings.iterations
    every = settings.add_remove_every
    last = iters if settings.stop_after is None else min(iters, settings.stop_after)
    for it in range(first, last + 1):
        grads = _hole_grads(p.state, p.kernels, p.mm_per_px, shape[0], ev.gt)
        # Linear decay of the step size to a fifth: large moves first, then polish.
        frac = 1.0 - 0.8 * (it - 1) / max(iters - 1, 1)
        for layer, grad in zip(p.state, grads, strict=True):
            if len(layer.x):
                _adam_step(layer, grad, it, frac, settings)
        moves = bool(every) and it % every == 0 and it < iters
        if not moves:
            # Step i + 1 takes the next can's gradient (one evaluation a step, as with one can).
            p.kernels = cans[it % len(cans)]
        ev = p.evaluate(want_q=moves)
        if moves:
            after = _add_and_remove(p, ev, final=len(cans) == 1)
            if after is not None:
                ev = after
            else:
                p.kernels = cans[it % len(cans)]
                ev = p.evaluate()
        if progress is not None:
            progress(it, last)
    return ev


def _nominal(p: _Problem, cans: list[CanKernels], ev: _Eval) -> _Eval:
    """``ev``, or the evaluation at the same holes under the nominal can where another's kernels apply."""
    if p.kernels is not cans[0]:
        p.kernels = cans[0]
        ev = p.evaluate()
    return ev


def refine_dots(
    target_rgb: np.ndarray,
    mm_per_px: float,
    primer: np.ndarray,
    colours: np.ndarray,
    dotsets: list[DotSet],
    rules: list[DesignRules],
    kernels: Kernels | Sequence[CanKernels],
    spray_times: list[float],
    settings: RefineSettings,
    progress: Callable[[int, int], None] | None = None,
    alpha_targets: np.ndarray | None = None,
    fixed_trans: np.ndarray | None = None,
    resume: Paused | None = None,
    on_pause: Callable[[Paused], None] | None = None,
) -> tuple[list[DotSet], dict]:
    """Move and resize every layer's holes so the sprayed composite matches the target.

    Args:
        target_rgb: ``(H, W, 3)`` sRGB in [0, 1], the picture to match, on the grid the
            spray is evaluated on.
        mm_per_px: Pixel size of that grid in mm.
        primer: ``(3,)`` primer colour in [0, 1].
        colours: ``(L, 3)`` paint colours in spray order.
        dotsets: One DotSet per layer (each passing its rules).
        rules: The design rules of each layer.
        kernels: The spray model's per-hole kernels bound to the spray settings (:data:`Kernels`),
            or one per can of a prior of cans (:mod:`stencil_cad.simulate.cans`), the nominal can
            first. With several, the expected error over the cans is minimised stochastically:
            step ``i`` takes its gradient (and its add/remove moves) under can ``i mod n``, Adam's
            moments average the cans' gradients, and one step costs what one can costs. The
            reported objectives are the first (nominal) can's. A can's entry is one
            :data:`Kernels` for every layer, or a sequence of one per layer (each paint sprayed
            with its own profile).
        spray_times: Spray time of each layer.
        settings: Iterations, step sizes, largest radius, add/remove cadence, eye filter.
        progress: Called as ``progress(iteration, iterations)``.
        alpha_targets: ``(L, H, W)`` target opacity of each layer on the grid, or None. With
            it, each layer's own filtered opacity error is added to the objective, weighted
            by ``settings.layer_weight``.
        fixed_trans: ``(L, H, W)`` transmittance of each layer's windows (fixed open area), or None.
        resume: The same refinement (the same arguments but ``settings.stop_after``) stopped part
            way, carried on from there (:class:`Paused`; it is copied, not changed), or None.
        on_pause: With ``settings.stop_after`` short of the steps, called with the state there.

    Returns:
        ``(dotsets, report)``: the refined DotSets (each passes :func:`check_rules` of its
        rules; the holes that stay keep the input's order, the added ones follow; ``report`` of each adds ``refine_added``, ``refine_removed``,
        ``refine_reverted``) and the stage report (``objective_start``, ``objective_end``
        as RMS composite errors, ``iterations``, ``seconds``).

    Raises:
        ValueError: The counts of DotSets, rules, colours and spray times differ, or ``resume``
            is of another number of steps or layers.
    """
    t_start = time.perf_counter()
    cans: list[CanKernels] = [kernels] if callable(kernels) else list(kernels)
    _check_counts(dotsets, rules, colours, spray_times, cans)
    problem = _problem(target_rgb, mm_per_px, primer, colours, alpha_targets, fixed_trans, settings, cans[0])
    npx = float(problem.target.shape[0] * problem.target.shape[1] * 3)
    if resume is None:
        problem.state = _start_layers(dotsets, rules, spray_times, settings, mm_per_px)
        e_start = (ev := problem.evaluate()).e
    else:
        ev, e_start = _resumed(problem, cans, resume, settings, len(dotsets))
    ev = _iterate(problem, cans, ev, settings, progress, 1 if resume is None else resume.step + 1)
    last = min(settings.iterations, settings.stop_after or settings.iterations)
    if on_pause is not None and last < settings.iterations:
        on_pause(_paused(problem, cans, ev, last, settings.iterations, e_start))
    ev = _nominal(problem, cans, ev)
    out = [_refined(ds, layer) for ds, layer in zip(dotsets, problem.state, strict=True)]
    report = {
        "iterations": last,
        "objective_start": math.sqrt(e_start / npx),
        "objective_end": math.sqrt(ev.e / npx),
        "seconds": round(time.perf_counter() - t_start, 3),
    }
    log.debug("refined: %s", report)
    return out, report


def _resumed(p: _Problem, cans: list[CanKernels], resume: Paused, settings: RefineSettings, n: int):
    """``p`` set to a copy of ``resume``'s state: ``(the evaluation there, the starting objective)``."""
    if resume.iterations != settings.iterations or len(resume.state) != n:
        raise ValueError("resume is of another refinement (its steps or layers differ)")
    p.state = copy.deepcopy(resume.state)
    p.kernels = cans[resume.can]
    return copy.deepcopy(resume.ev), resume.e_start


def _problem(
    target_rgb, mm_per_px, primer, colours, alpha_targets, fixed_trans, settings, kernels
) -> _Problem:
    """The refinement's problem with no holes yet: the images in float32, the viewer's filters."""
    # float32 images: half the memory traffic of every whole-image pass (see the kernels' note).
    target = np.ascontiguousarray(target_rgb, dtype=np.float32)
    alpha_targets = None if alpha_targets is None else np.ascontiguousarray(alpha_targets, dtype=np.float32)
    return _Problem(
        state=[],
        kernels=kernels,
        mm_per_px=mm_per_px,
        target=target,
        alpha_targets=alpha_targets,
        lam=settings.layer_weight if alpha_targets is not None else 0.0,
        primer=np.asarray(primer, dtype=np.float64),
        colours=np.asarray(colours, dtype=np.float64).reshape(-1, 3),
        eye_px=settings.eye_sigma_mm / mm_per_px,
        viewer=_Viewer(target, mm_per_px, settings.view) if settings.view is not None else None,
        fixed_trans=None if fixed_trans is None else np.ascontiguousarray(fixed_trans, dtype=np.float32),
    )
