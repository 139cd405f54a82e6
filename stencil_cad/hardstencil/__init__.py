"""Hard stencils: flat-colour segmentation, one cut stencil per colour, islands held by bridges.

:mod:`.segment` segments the image (K-means, Potts graph cut), :mod:`.topology`
finds the islands and lays the bridges, :mod:`.stencils` runs the stage.
"""

from .stencils import HardResult, make_hard_stencils, render_ideal, simulate_hard

__all__ = ["HardResult", "make_hard_stencils", "render_ideal", "simulate_hard"]
