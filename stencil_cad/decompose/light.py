"""Light plates: each paint sprayed through two plates, a light one for its light tones and a dark one.

A stippled plate makes a light tone from few holes far apart, each sprayed to the layer's full
dose; seen from the viewing distance those sparse dots read as grain unless the wall lifts the
plate high enough to blur them, and that blur softens the whole picture. Printers that hide dots
in the highlights add light inks; a spray can has one strength, but a second plate of the same
paint can take a smaller dose. Each paint layer ``a`` becomes

* a **light plate**, ``a_l = min(a, below)``: its tone calibration (the stipple stage's) gives it
  the small dose its light tones want, so they are made of many close holes; and
* a **dark plate**, ``a_d = 1 - (1 - a) / (1 - a_l)``: what the light plate leaves, zero wherever
  ``a <= below``,

sprayed one after the other with the same can. Two coats of one paint cover ``1 - (1 - a_l)(1 - a_d)
= a``, so the pair sprays the layer's own opacity and the decomposition (its colours, primer and
order) is unchanged. The plates' holes, doses and stand-off are then designed and scored as any
plate's are.

Measured on the bundled example (``python -m benchmarks fidelity``-style job, S-CIELAB at 1 m on
the FDM plates it is designed for): 3.71 with one plate per paint (the trials chose an 8 mm wall),
2.68 with light plates (the trials chose 5 mm); at a fixed 8 mm wall 3.71 against 2.85. ``below``
0.25 and 0.4 scored alike at 8 mm (2.83, 2.85). A decomposition into twice the paints instead
(8 layers, 8 mm) scored 4.53, so the gain is the second dose, not the plate count. Doses under one
pass (one quicker pass, :meth:`stencil_cad.config.SprayConfig.doses`) gained nothing further on the
example (2.84 at 8 mm) and 0.06 on the Hubble deep field, whose faint light plate takes 0.75.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..model import Layers

__all__ = ["LIGHT_BELOW", "MIN_DARK_SHARE", "light_plates", "paint_of_plates"]

#: The light plate carries each layer's opacity up to this; the dark plate the rest.
LIGHT_BELOW = 0.4
#: A paint whose dark plate would carry less than this share of its opacity keeps one plate (a dark
#: plate with next to nothing to spray is not printed). Not more: on the bundled example the blue
#: paint's dark plate carries 7.7 % of it, and dropping plates under 10 % (7 plates) scored 2.90 at
#: 1 m against 2.67 with all 8 (the trials then chose the 8 mm wall instead of 5 mm).
MIN_DARK_SHARE = 0.01


def light_plates(
    layers: Layers, below: float = LIGHT_BELOW, min_dark_share: float = MIN_DARK_SHARE
) -> Layers:
    """``layers`` with each paint layer split into a light plate and a dark plate of the same paint.

    Args:
        layers: The decomposition, one layer per paint.
        below: The light plate's largest opacity, in (0, 1).
        min_dark_share: A paint whose dark plate would carry less than this share of its summed
            opacity stays one plate.

    Returns:
        Up to ``2 L`` layers in spray order (each paint's light plate, then its dark plate), the same
        primer, ``info["light_plates"]`` set; the composite equals ``layers``' to float rounding.

    Raises:
        ValueError: ``below`` outside (0, 1), or ``layers`` already split.
    """
    if not 0.0 < below < 1.0:
        raise ValueError(f"the light plate's opacity must be in (0, 1), got {below}")
    if layers.info.get("light_plates"):
        raise ValueError("these layers already have light plates")
    alphas, colours = [], []
    for colour, a in zip(np.asarray(layers.colours), np.asarray(layers.alphas), strict=True):
        light = np.minimum(a, np.asarray(below, dtype=a.dtype))
        dark = np.clip(1.0 - (1.0 - a) / (1.0 - light), 0.0, 1.0).astype(a.dtype)
        if float(dark.sum()) < min_dark_share * float(a.sum()):
            # Little above the light plate's range: one plate sprays this paint as before.
            alphas.append(a)
            colours.append(colour)
            continue
        alphas += [light, dark]
        colours += [colour, colour]
    return replace(
        layers,
        colours=np.array(colours),
        alphas=np.array(alphas),
        info={**layers.info, "light_plates": float(below)},
    )


def paint_of_plates(colours: np.ndarray) -> list[int]:
    """For each plate (in spray order), the index of its paint among the distinct paints, in order of first use.

    Plates of one paint (a light and a dark plate) share a paint; two paints of the same colour are one.
    """
    seen: dict[bytes, int] = {}
    out = []
    for c in np.asarray(colours, dtype=np.float32):
        out.append(seen.setdefault(c.tobytes(), len(seen)))
    return out
