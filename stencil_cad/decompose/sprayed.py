"""What plates can spray of a layer's opacity: a fast proxy that ranks decomposition starts.

The decomposition compares candidate starts (primer, palette and spray order) by short trial
solves. The ideal layers' fit is not what a maker gets: a plate of holes cannot spray below its
opacity threshold or darker than its densest hole pattern, and between its holes the colour
underneath shows through as a pattern the viewer partly sees; a window (a hybrid plate) sprays a
solid coat where the layer is near opaque over a wide region. :class:`PlateReach` predicts the
sprayed composite of trial layers from those few facts, in microseconds on the trial grid, and
scores it, so the candidate the plates serve best is picked (``decompose.order: auto``).

The pattern of a layer at opacity ``a`` has colour variance ``a (1 - a) |dC/da|^2``; it is weighed
by :data:`TEXTURE_SEEN`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import coat_contrast, composite

#: Weight of a dot pattern's colour variance in the prediction. Set by ranking, not by optics:
#: ``python -m benchmarks decompose_choice`` forced every candidate start of the example, the
#: dark sky and coffee through the whole pipeline (SLA rules, S-CIELAB at 1 m); with 1.0 the
#: proxy's picks lost 0, 0 and 1.05 against the best candidate (with 0.15: 0, 1.02 and 1.05; the
#: ideal layers' fit, the choice before: 2.17, 1.32 and 0). A viewer sees the lattice of a
#: mid-tone layer nearly whole at 1 m: the patterns have their energy at the hole pitch and also
#: at the far coarser scale of the relaxation's irregularity.
TEXTURE_SEEN = 1.0


@dataclass(frozen=True)
class PlateReach:
    """What a layer's plate can spray, for ranking decomposition starts.

    Attributes:
        darkest: Darkest mean opacity the holes reach (the densest pattern the rules allow, at
            the most passes), in (0, 1].
        threshold: No hole where a layer's opacity is below this (``stipple.opacity_threshold``).
        window_from: Opacity from which a window sprays a solid coat (``stipple.window_opacity``),
            or None when windows are off.
        texture: Weight of a dot pattern's colour variance. Defaults to :data:`TEXTURE_SEEN`.
    """

    darkest: float
    threshold: float
    window_from: float | None
    texture: float = TEXTURE_SEEN

    def sprayed(self, alphas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The opacities plates spray for ideal ones, and where holes (not windows) spray them.

        Args:
            alphas: ``(L, H, W)`` ideal opacities.

        Returns:
            ``(sprayed, holes)``: ``(L, H, W)`` opacities and bool mask of hole-sprayed pixels.
        """
        a = np.asarray(alphas, dtype=np.float64)
        a = np.where(a < self.threshold, 0.0, a)
        window = np.zeros(a.shape, dtype=bool) if self.window_from is None else a >= self.window_from
        out = np.where(window, a, np.minimum(a, self.darkest))
        return out, (out > 0.0) & ~window

    def error(self, target: np.ndarray, primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> float:
        """Predicted mean squared sRGB error per pixel of the sprayed layers against ``target``.

        The composite of the sprayed opacities (tone and reach) plus the visible share of each
        hole-sprayed layer's dot pattern.

        Args:
            target: ``(H, W, 3)`` the picture on the trial grid.
            primer: ``(3,)`` primer colour.
            colours: ``(L, 3)`` paint colours in spray order.
            alphas: ``(L, H, W)`` the trial's ideal opacities.

        Returns:
            The error, in squared sRGB units summed over the channels, mean over pixels.
        """
        sprayed, holes = self.sprayed(alphas)
        tone = composite(primer, colours, sprayed) - np.asarray(target, dtype=np.float64)
        contrast = coat_contrast(primer, colours, sprayed)
        pattern = np.where(holes, sprayed * (1.0 - sprayed), 0.0) * contrast
        return float(np.mean(np.sum(tone * tone, axis=-1)) + self.texture * np.mean(np.sum(pattern, axis=0)))
