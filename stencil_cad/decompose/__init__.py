"""Soft layer decomposition: a primer plus L alpha-blended paint layers.

:mod:`.decomposition` runs the stage, :mod:`.tiled` splits big pictures into tiles, :mod:`.energy` holds the paper's energy and
its compiled kernels, :mod:`.solver` the block-coordinate descent, :mod:`.palette`
the K-means start and the luminance order.
"""

from .decomposition import decompose, energy_of

__all__ = ["decompose", "energy_of"]
