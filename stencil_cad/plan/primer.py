"""The primer a mostly dark picture is sprayed on: its dark colour, the light parts sprayed over it.

The decomposition ranks its starts by what the plates are predicted to spray
(:class:`stencil_cad.decompose.sprayed.PlateReach`), a prediction that takes a window for a full
coat and the holes for their mean tone. On a picture whose background is large and dark it
preferred a light primer with a dark paint sprayed over the whole background through windows and
holes; sprayed, that background comes out mottled (dark blobs where the windows are, the primer
showing in lanes between them) where a dark primer and the light parts sprayed over it keep it
dark. ``python -m benchmarks quality``'s hubble_deep_field (FDM, the job's own plate design):
primed light blue S-CIELAB 4.67 at 1 m and 4.31 at 2 m with a blue-grey sky; primed with its
dark colour 4.35 and 3.86 with a black one (its hard stencil: 5.74 and 5.46).

So when at least :data:`DARK_SHARE` of the picture is dark (relative luminance under
:data:`DARK_LUMINANCE`), the picture is decomposed primed with its dark pixels' median colour, and
the saved config names that primer (``decompose.primer``), so the stage commands repeat the run. Of the quality benchmark's twelve
pictures only the two mostly dark ones pass the share (hubble_deep_field 0.95, dark_sky 0.98, which
the decomposition primes dark already; rocket 0.36, astronaut 0.24).

Primed so, the background is the primer, and a paint the viewer can hardly tell from it has no
work there but to be sprayed over the whole background and tinted back. hubble_deep_field's
decomposition kept a black at CIEDE2000 2.74 from its dark primer (the decomposition drops paints
within ``decompose.min_delta_e``, 2.0, of the primer), sprayed it at 0.95 opacity over the whole
sky through holes in 8 passes, and brought the sky's colour back with faint blue and red layers
(opacity 0.03-0.05 over the sky), which the holes spray as a lattice of coloured dots: S-CIELAB 4.17
at 1 m, 3.70 at 2 m, 8,365 holes. So a job primed dark keeps its paints at least
:data:`DARK_MIN_DELTA_E` from the primer (unless the config sets ``decompose.min_delta_e``): the
black is dropped, the sky is left to the primer, and the same job scores 3.39 and 3.17 with 770 holes
(``python -m benchmarks fidelity --case hubble_deep_field-fdm``).

This is a rule, not a trial: ranking the two decompositions by the plate-design trials (stippled
and sprayed on a grid twice as coarse as the job's) put the light primer first, unrefined (5.25
against 5.54) and refined (3.71 against 4.36): the coarse grid blurs away the very mottling that
costs it 0.3 on the job's own grid.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from ..colour import to_hex
from ..model import Picture

if TYPE_CHECKING:
    from ..config.job import JobConfig

log = logging.getLogger(__name__)

#: Relative luminance (CIE Y of linear light) under which a pixel counts as dark.
DARK_LUMINANCE = 0.03
#: Share of the picture that must be dark before it is primed dark.
DARK_SHARE = 0.4
#: Smallest CIEDE2000 difference kept between a paint and a dark primer the job chose (the
#: decomposition's ``min_delta_e`` otherwise, 2.0): hubble_deep_field's black at 2.74 from its primer
#: is dropped (see the module's note).
DARK_MIN_DELTA_E = 3.0


def _luminance(rgb: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2xyz

    return np.asarray(rgb2xyz(np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)))[..., 1]


def dark_primer(picture: Picture) -> str | None:
    """The primer of a mostly dark picture: its dark pixels' median colour (``#rrggbb``), or None.

    Args:
        picture: The job's picture.
    """
    rgb = np.asarray(picture.rgb, dtype=np.float64)
    dark = _luminance(rgb) < DARK_LUMINANCE
    if picture.alpha is not None:
        dark &= np.asarray(picture.alpha) > 0.5
    if dark.mean() < DARK_SHARE:
        return None
    return to_hex(np.median(rgb[dark], axis=0))


def dark_primed(cfg: JobConfig, picture: Picture) -> tuple[JobConfig, str | None]:
    """``cfg`` with a mostly dark picture's dark colour as its primer: ``(config, the primer named or None)``.

    Only where the config leaves the primer and the paints to the job (``decompose.primer: auto``,
    ``decompose.palette: auto``): a chosen primer or can list is kept (``cfg`` comes back as it is).
    With the primer, ``decompose.min_delta_e`` becomes at least :data:`DARK_MIN_DELTA_E` unless the
    config sets it.
    """
    dcfg = cfg.decompose
    if dcfg.primer_rgb() is not None or dcfg.palette != "auto":
        return cfg, None
    hex_code = dark_primer(picture)
    if hex_code is None:
        return cfg, None
    log.info("primer: %s, the dark colour of a picture at least %.0f %% dark", hex_code, 100 * DARK_SHARE)
    update: dict[str, object] = {"primer": hex_code}
    if "min_delta_e" not in dcfg.model_fields_set:
        update["min_delta_e"] = max(dcfg.min_delta_e, DARK_MIN_DELTA_E)
    return cfg.model_copy(update={"decompose": dcfg.model_copy(update=update)}), hex_code
