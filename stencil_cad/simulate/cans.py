"""The prior over cans: the few cans a stencil is designed and scored for when no can was measured.

A stencil designed for one assumed can is only as good as that assumption. Real caps spread
the spray by ``k`` = 0.03-0.10 (skinny caps), 0.10-0.20 (standard fan tips) and 0.15-0.35 (fat
caps) per mm of stand-off (graffiti cap charts' line widths at their distances), and the optical depth a
pass leaves varies with the paint, the distance and the hand's speed. Without a measured profile
(``spray.profile``), the simulation scores every can below (``simulate.scielab_by_can``,
``simulate.scielab_worst``) and the maker reads "between X and Y depending on your can; spray
the card to know". With ``refine.cans: prior`` (the default) the refinement minimises the
expected error over the prior's caps (:data:`CAP_PRIOR`: the spreads and bleeds below at the
nominal deposit; one can per step, in turn, so it costs what one can costs). A measured profile
collapses the prior to that can.

The cans, as the nominal can (``spray.can``) changed by:

=============  =========  ===============  =========================
can            spread k   deposit / pass   bleed sigma
=============  =========  ===============  =========================
nominal        k          beta             sigma_0
skinny light   0.05       0.85 beta        0.8 sigma_0
skinny heavy   0.05       1.15 beta        0.8 sigma_0
fat light      0.25       0.85 beta        1.25 sigma_0
fat heavy      0.25       1.15 beta        1.25 sigma_0
=============  =========  ===============  =========================

The scored spreads are the middles of the skinny and fat caps' published ranges (0.05 near the
geometric middle of 0.03-0.10, 0.25 of 0.15-0.35), so the range the maker reads spans the caps
they may own; the deposit factors are a hand or a paint 15 % lighter or heavier than the nominal
one; fat caps wet more, so their bleed is larger. The holes are refined for narrower caps
(:data:`CAP_PRIOR`: 0.08 and 0.16): refined for 0.05 and 0.25 the bundled example scored 4.56 at
1 m on the nominal can against 3.71 (FDM holes, 8 mm wall), as the holes chased a fat cap's blur
that a skinny one does not have. Scored over the wide caps, the example (refined for the narrow
ones) ranges from 3.71 (nominal) through 8.40 (skinny light: its holes show) to 12.30 (fat light).
The table below was measured with the narrower scored caps of before (0.08 and 0.16).

What each can costs the bundled example (``python -m benchmarks cans``, S-CIELAB at 1 m; "tone"
is the same score after a 6 mm blur of both pictures, which leaves only the tone of areas wider
than the holes' pattern), with the holes refined for the prior's caps (the default) and, for
comparison, for the nominal can alone:

==============================  ===========  =====  =============
can                             caps: 1 m    tone   nominal: 1 m
==============================  ===========  =====  =============
nominal                         3.92         1.08   3.70
deposit 15 % lighter (alone)    5.78         3.37   5.69
deposit 15 % heavier (alone)    4.87         3.21   4.62
skinny cap (k 0.08, alone)      4.30         1.56   5.27
fat cap (k 0.16, alone)         5.76         1.48   5.54
the prior's worst (fat light)   8.11         4.42   7.98
mean over the prior's 5 cans    5.64                5.84
==============================  ===========  =====  =============

A coat 15 % lighter or heavier moves every layer's mean opacity by about 10 % and costs most
of the difference as tone, which no placement of holes changes. Designing for the expected error
over all five cans did not narrow the range: the tone choice made from the mean response of
the five (density and passes) scored 3.73 nominal and 8.03 worst, and refining for all five in
turn 4.33 and 8.19 (its mean 6.02), as the holes' sizes chased each coat's darkness. Refining for
the caps alone keeps the skinny cap's pattern from showing (5.27 to 4.30) at a cost of 0.2 to the
nominal can, and lowers the mean over the prior on each of 3 seeds (by 0.19-0.22). A measured can
(the card) is what closes the rest.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..config.spray import SprayConfig

__all__ = ["CAN_PRIOR", "CAP_PRIOR", "PriorCan", "can_prior", "deposit_prior", "layer_can_prior"]


@dataclass(frozen=True)
class PriorCan:
    """One can of the prior, relative to the nominal can.

    Attributes:
        name: What the can is like (``nominal``, ``skinny light`` …).
        spread_k: Its spread per mm of stand-off, or None for the nominal can's.
        deposit_factor: Its deposit per pass as a multiple of the nominal can's.
        bleed_factor: Its bleed sigma as a multiple of the nominal can's.
    """

    name: str
    spread_k: float | None
    deposit_factor: float
    bleed_factor: float


#: The cans a stencil without a measured profile is refined and scored for (see the module doc).
CAN_PRIOR: tuple[PriorCan, ...] = (
    PriorCan("nominal", None, 1.0, 1.0),
    PriorCan("skinny light", 0.05, 0.85, 0.8),
    PriorCan("skinny heavy", 0.05, 1.15, 0.8),
    PriorCan("fat light", 0.25, 0.85, 1.25),
    PriorCan("fat heavy", 0.25, 1.15, 1.25),
)


#: The cans the holes are refined for (``refine.cans: prior``): the prior's caps (spread and
#: bleed) at the nominal can's deposit. A coat's darkness is left out: it moves the tone of whole
#: areas, which no placement of holes undoes, and refined in turn with the lighter and heavier
#: coats the holes chased it (module doc).
CAP_PRIOR: tuple[PriorCan, ...] = (
    PriorCan("nominal", None, 1.0, 1.0),
    PriorCan("skinny cap", 0.08, 1.0, 0.8),
    PriorCan("fat cap", 0.16, 1.0, 1.25),
)


#: The deposit per pass of an unmeasured can follows its paint's hiding power, read from the paint's
#: CIELAB lightness: dark paints hide in two coats (the cans' directions: "two light coats";
#: 1.5 per pass leaves 78 % after one pass and 95 % after two), white, yellow and pastels need three or
#: more (the same directions and makers' advice for light colours over dark: 0.7-1.0 per pass, 0.85
#: here, 92 % after three). Lightness sets it because a light paint hides with scattering pigment
#: (titanium white, lead-free yellows) at low tinting strength, a dark one absorbs at once. Paints
#: of L* up to :data:`DARK_L` take the dark deposit, from :data:`LIGHT_L` the light one, linear
#: between. Brands and colours still differ by about x0.5-1.2: the prior's lighter and heavier cans
#: (:data:`CAN_PRIOR`) score that, and the card measures it.
DARK_DEPOSIT, LIGHT_DEPOSIT = 1.5, 0.85
DARK_L, LIGHT_L = 60.0, 95.0


def deposit_prior(paint_rgb) -> float:
    """The deposit per pass an unmeasured can of this paint is assumed to leave (see :data:`DARK_DEPOSIT`).

    Args:
        paint_rgb: ``(3,)`` the paint's sRGB in [0, 1].

    Returns:
        Optical depth per pass at the can's reference distance and speed.
    """
    from skimage.color import rgb2lab

    lightness = float(
        rgb2lab(np.clip(np.asarray(paint_rgb, dtype=np.float64), 0.0, 1.0).reshape(1, 1, 3))[0, 0, 0]
    )
    t = min(1.0, max(0.0, (lightness - DARK_L) / (LIGHT_L - DARK_L)))
    return round(DARK_DEPOSIT + t * (LIGHT_DEPOSIT - DARK_DEPOSIT), 3)


def can_prior(cfg: SprayConfig, cans: Sequence[PriorCan] = CAN_PRIOR) -> list[tuple[str, SprayConfig]]:
    """The spray settings of every can a stencil is designed for, the nominal one first.

    Args:
        cfg: The job's spray settings.
        cans: The prior: :data:`CAN_PRIOR` (scoring) or :data:`CAP_PRIOR` (refinement).

    Returns:
        ``(name, settings)`` per can: the whole prior under the physical model without a measured
        profile; only ``("nominal", cfg)`` under the paper model or with a measured can.
    """
    if not cfg.has_cans or cfg.is_measured:
        return [("nominal", cfg)]
    out = []
    for can in cans:
        c = cfg.can
        changed = c.model_copy(
            update={
                "spread_k": c.spread_k if can.spread_k is None else can.spread_k,
                "deposit_per_pass": min(20.0, c.deposit_per_pass * can.deposit_factor),
                "bleed_sigma_mm": min(10.0, max(0.01, c.bleed_sigma_mm * can.bleed_factor)),
            }
        )
        out.append((can.name, cfg.model_copy(update={"can": changed})))
    return out


def layer_can_prior(
    sprays: Sequence[SprayConfig], cans: Sequence[PriorCan] = CAN_PRIOR
) -> list[tuple[str, list[SprayConfig]]]:
    """Every can of the prior as each layer's spray settings, the nominal can first.

    A layer with a measured profile (or under the paper model) sprays with its own can in every
    entry; the others take the prior's can of that entry (:func:`can_prior`), so a prior entry
    such as "fat heavy" changes only the layers whose can was not measured.

    Args:
        sprays: Each layer's spray settings, in spray order.
        cans: The prior (see :func:`can_prior`).

    Returns:
        ``(name, settings per layer)`` per can: one entry (``nominal``) when no layer's prior has
        more than one can.
    """
    priors = [[sp for _, sp in can_prior(layer, cans)] for layer in sprays]
    n = max((len(p) for p in priors), default=1)
    names = [can.name for can in cans] if n > 1 else ["nominal"]
    return [(names[c], [p[c] if len(p) > 1 else p[0] for p in priors]) for c in range(n)]
