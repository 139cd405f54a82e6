"""What plates can spray of a layer's opacity: a fast proxy that ranks decomposition starts.

The decomposition compares candidate starts (primer, palette and spray order) by short trial
solves. The ideal layers' fit is not what a maker gets: a plate of holes cannot spray below its
opacity threshold or darker than its densest hole pattern, and between its holes the colour
underneath shows through as a pattern the viewer partly sees; a window (a hybrid plate) sprays a
full coat where the layer is near opaque over a wide region. :class:`PlateReach` predicts the
sprayed composite of trial layers from those few facts, in microseconds on the trial grid, and
scores it in the units of the job's score, so the candidate the plates serve best is picked
(``decompose.order: auto``).

The prediction is a mean colour difference (CIELAB ΔE, as S-CIELAB's score is a mean ΔE): at each
pixel the tone error of the sprayed composite (every channel: it is as coarse as the picture) and
the pattern of each hole-sprayed layer, seen in lightness only. A layer's pattern at sprayed
opacity ``a`` has the variance the spray model measures for the stippler's pattern at that tone
(:class:`stencil_cad.simulate.tone.ToneCurve`, soft dots overlapping: it vanishes as the holes
close up), or ``a (1 - a)`` of hard-edged dots without a measurement; it moves the lightness by
``dL*/da`` (the layer's colour step ``T_l (c_l - B_{l-1})`` through the lightness gradient at the
composite). The eye's chromatic channels blur the hole pattern away at viewing distance (their
narrowest Gaussians are 1.4 and 1.8 times the luminance one, and the pitches are a few mm), which
is why colour steps without a lightness step cost the pattern nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import composite

#: Weight of the lightness pattern's variance in the prediction: 1, the pattern is seen whole (not
#: fitted). ``python -m benchmarks decompose_choice`` forced every candidate start of the example,
#: coffee, the dark sky and the logo through the whole pipeline (SLA rules, S-CIELAB at 1 m): the
#: proxy's picks lost 0, 0, 0 and 0.07 against the best candidate. The proxy before (squared sRGB
#: error, hard-edged ``a (1 - a)`` in every channel, windows spraying the layer's opacity) lost 0,
#: 0.55, 0 and 0; the ideal layers' fit 2.28, 0, 0.14 and 0. The measured pattern is several times
#: fainter than ``a (1 - a)`` and vanishes as the holes close up; counted in every channel it
#: outweighed everything else, and coffee's light primer under black dots won on it.
TEXTURE_SEEN = 1.0

#: Y of linear sRGB (D65), as :func:`skimage.color.rgb2lab` converts.
_Y_OF_RGB = np.array([0.212671, 0.715160, 0.072169])


@dataclass(frozen=True)
class PlateReach:
    """What a layer's plate can spray, for ranking decomposition starts.

    Attributes:
        darkest: Darkest mean opacity the holes reach (the densest pattern the rules allow, at
            the most passes), in (0, 1].
        threshold: No hole where a layer's opacity is below this (``stipple.opacity_threshold``).
        window_from: Opacity from which a window sprays a full coat (``stipple.window_opacity``),
            or None when windows are off.
        coat: Opacity of a full coat, which a window sprays. Defaults to 1.
        pattern: ``(opacity, variance)`` samples of the sprayed pattern's variance against its
            mean opacity (increasing opacity), or None for hard-edged dots' ``a (1 - a)``.
        texture: Weight of a dot pattern's lightness variance. Defaults to :data:`TEXTURE_SEEN`.
    """

    darkest: float
    threshold: float
    window_from: float | None
    coat: float = 1.0
    pattern: tuple[tuple[float, ...], tuple[float, ...]] | None = None
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
        out = np.where(window, self.coat, np.minimum(a, self.darkest))
        return out, (out > 0.0) & ~window

    def variance(self, sprayed: np.ndarray) -> np.ndarray:
        """Variance of the hole pattern's opacity about the sprayed opacity ``sprayed``."""
        if self.pattern is None:
            return sprayed * (1.0 - sprayed)
        opacity, var = (np.asarray(v, dtype=np.float64) for v in self.pattern)
        # A tiny ramp makes saturated stretches strictly increasing for np.interp.
        return np.interp(sprayed, opacity + 1e-9 * np.arange(opacity.size), var)

    def error(self, target: np.ndarray, primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> float:
        """Predicted mean colour difference (CIELAB ΔE) of the sprayed layers against ``target``.

        Per pixel the root of the squared ΔE of the composite of the sprayed opacities (tone and
        reach) plus the seen variance of each hole-sprayed layer's pattern in lightness; the mean.

        Args:
            target: ``(H, W, 3)`` the picture on the trial grid.
            primer: ``(3,)`` primer colour.
            colours: ``(L, 3)`` paint colours in spray order.
            alphas: ``(L, H, W)`` the trial's ideal opacities.

        Returns:
            The predicted mean ΔE.
        """
        from skimage.color import rgb2lab

        sprayed, holes = self.sprayed(alphas)
        comp = np.clip(composite(primer, colours, sprayed), 0.0, 1.0)
        tone = rgb2lab(comp) - rgb2lab(np.clip(np.asarray(target, dtype=np.float64), 0.0, 1.0))
        grad = lightness_gradient(comp)
        steps = np.sum(coat_steps(primer, colours, sprayed) * grad, axis=-1)
        pattern = np.sum(np.where(holes, self.variance(sprayed), 0.0) * steps * steps, axis=0)
        return float(np.mean(np.sqrt(np.sum(tone * tone, axis=-1) + self.texture * pattern)))


def coat_steps(primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """Each layer's colour step ``T_l (c_l - B_{l-1})``: the composite's slope in its opacity.

    Args:
        primer: ``(3,)`` primer colour in [0, 1].
        colours: ``(L, 3)`` paint colours in [0, 1].
        alphas: ``(L, H, W)`` opacities in [0, 1].

    Returns:
        ``(L, H, W, 3)`` sRGB steps (:func:`stencil_cad.model.coat_contrast` is their squared norm).
    """
    a = np.asarray(alphas, dtype=np.float64)
    below = np.empty((*a.shape[1:], 3))
    below[...] = np.asarray(primer, dtype=np.float64)
    out = np.empty((*a.shape, 3))
    for layer, colour in enumerate(np.asarray(colours, dtype=np.float64)):
        out[layer] = colour - below
        below += a[layer][..., None] * out[layer]
    trans = np.ones(a.shape[1:])
    for layer in range(a.shape[0] - 1, -1, -1):
        out[layer] *= trans[..., None]
        trans *= 1.0 - a[layer]
    return out


def lightness_gradient(rgb: np.ndarray) -> np.ndarray:
    """``dL*/d(sRGB channel)`` at each colour (D65), as :func:`skimage.color.rgb2lab` computes L*.

    Args:
        rgb: ``(..., 3)`` sRGB in [0, 1].

    Returns:
        ``(..., 3)`` lightness per unit of each channel.
    """
    v = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    linear = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    dlinear = np.where(v <= 0.04045, 1.0 / 12.92, 2.4 / 1.055 * ((v + 0.055) / 1.055) ** 1.4)
    y = np.sum(linear * _Y_OF_RGB, axis=-1, keepdims=True)
    dl_dy = np.where(y > 0.008856, 116.0 / 3.0 * np.cbrt(np.maximum(y, 0.008856)) ** -2, 903.3)
    return dl_dy * _Y_OF_RGB * dlinear
