"""One layer's opacity sprayed through its holes, its cut-outs and its windows, under the job's spray model.

Each function asks the spray model (:func:`stencil_cad.simulate.models.sprayer`) to spray: the
paper's (:mod:`.paper`, exact and fast evaluations) or the physical one (:mod:`.physical`).
"""

import numpy as np

from ..config.spray import SprayConfig
from ..frames import mm_to_px
from .kept import Kept, digest
from .models import sprayer
from .paper import dot_sigma_mm, tail_tolerance

__all__ = ["dot_sigma_mm", "spray_mask", "spray_opacity", "tail_tolerance"]


def spray_opacity(
    xy_mm: np.ndarray,
    r_mm: np.ndarray | float,
    shape_hw: tuple[int, int],
    mm_per_px: float,
    cfg: SprayConfig,
    exact: bool = False,
    *,
    spray_time: float | None = None,
    crop: tuple[int, int, int, int] | None = None,
    geometry=None,
    tail_tol: float | None = None,
) -> np.ndarray:
    """The opacity one stencil sprays: ``I = 1 - prod_i (1 - min(N_i, 1))``.

    Under ``spray.model: physical`` the opacity is
    :func:`stencil_cad.simulate.physical.physical_opacity`'s and ``spray_time`` counts passes.

    Args:
        xy_mm: ``(N, 2)`` hole centres in mm (picture frame, y up; see
            :mod:`stencil_cad.frames`). N may be 0 (gives an empty layer).
        r_mm: ``(N,)`` hole radii in mm, or one radius for all holes.
        shape_hw: ``(H, W)`` of the raster; pixel ``(row, col)`` is centred at
            :func:`stencil_cad.frames.px_to_mm` of it.
        mm_per_px: Raster pixel size in mm.
        cfg: Spray settings (``spray_time`` A, ``nozzle_height`` h, ``max_error``).
        exact: Evaluate every hole at every pixel (slow reference) instead of the
            truncated compiled splat. Defaults to False.
        spray_time: Overrides ``cfg.spray_time`` (used by sweeps and calibration).
        crop: ``(row0, row1, col0, col1)``: compute only this window of the
            raster (same values as the full computation, cropped).
        geometry: :class:`~stencil_cad.simulate.physical.SprayGeometry` (stand-off and plate
            thickness); needed by the physical model, ignored by the paper's.
        tail_tol: Fast path: drop each dot's tail below this paint density instead of the
            one derived from these holes (:func:`tail_tolerance`), so that parts of a hole
            set (the tiles of a mural) splat exactly the discs the whole set would.

    Returns:
        ``(H, W)`` (or the crop's shape) ndarray of float in [0, 1].

    Raises:
        ValueError: A ≤ 0, h < 0, a radius ≤ 0, a bad crop, or no geometry for the
            physical model.
    """
    a = cfg.amount if spray_time is None else float(spray_time)
    return sprayer(cfg).opacity(
        xy_mm, r_mm, shape_hw, mm_per_px, cfg, a, geometry=geometry, exact=exact, crop=crop, tail_tol=tail_tol
    )


def spray_mask(
    mask: np.ndarray,
    mm_per_px: float,
    cfg: SprayConfig,
    *,
    spray_time: float | None = None,
    reference_radius_mm: float | None = None,
    geometry=None,
) -> np.ndarray:
    """Spray through a hard-stencil cut-out given as a raster of its open area.

    Each open pixel is one tiny hole of the dot model. The dot model sends
    ``A * 2 pi sigma^2 = A * pi r^2 (1 + h) / 2`` units of paint through a hole of
    area ``pi r^2``, i.e. ``A (1 + h) / 2`` per unit open area. Its spread has two
    parts, ``sigma^2 = r^2 / 4 + r^2 h / 4``: the disc's own variance, which the
    mask already holds as geometry, and the nozzle's, which is applied as a
    Gaussian blur of ``sigma_n = r_ref sqrt(h) / 2`` (``r_ref`` =
    ``cfg.mask_reference_radius_mm``). Every tiny hole is far below saturation, so
    the product of their transmittances becomes an exponential:

        I = 1 - exp(-A (1 + h) / 2 * (mask (*) G_sigma_n)).

    With this, a disc-shaped cut-out of radius ``r_ref`` sprays a dot of the same
    variance and the same amount of paint as the dot model's hole. Well inside a
    large cut-out ``I = 1 - exp(-A (1 + h) / 2)`` (0.98 for A = 1, h = 7).

    Args:
        mask: ``(H, W)`` bool, True where the stencil is cut open.
        mm_per_px: Pixel size of the mask in mm.
        cfg: Spray settings.
        spray_time: Overrides ``cfg.spray_time``.
        reference_radius_mm: Overrides ``cfg.mask_reference_radius_mm``.
        geometry: Stand-off and plate thickness (physical model only, where the
            cut-out is blurred by the stand-off's sigma instead).

    Returns:
        ``(H, W)`` ndarray of float in [0, 1] on the mask's grid.
    """
    a = cfg.amount if spray_time is None else float(spray_time)
    return sprayer(cfg).mask_opacity(
        mask, mm_per_px, cfg, a, geometry=geometry, reference_radius_mm=reference_radius_mm
    )


def windows_opacity(
    windows,
    shape_hw: tuple[int, int],
    mm_per_px: float,
    cfg: SprayConfig,
    *,
    spray_time: float | None = None,
    geometry=None,
    supersample: int = 4,
) -> np.ndarray:
    """The opacity a hybrid plate's windows spray: their open area blurred as a cut-out's.

    The windows are rasterised ``supersample`` times finer and averaged back (each pixel's open
    fraction), then sprayed with :func:`spray_mask`: under the physical model with the same
    stand-off blur and deposit as the plate's holes, so a window's edge is as soft as a hole's.
    A layer's holes and windows combine as independent deposits: ``1 - (1 - I_holes)(1 - I_windows)``
    (exact under the physical model, where doses add).

    Args:
        windows: Each ``(outer, inner rings)`` in picture mm.
        shape_hw: ``(H, W)`` of the raster.
        mm_per_px: Raster pixel size in mm.
        cfg: Spray settings.
        spray_time: The layer's amount (passes under the physical model).
        geometry: Stand-off and plate thickness (physical model).
        supersample: Rasterising factor per axis. Defaults to 4.

    Returns:
        ``(H, W)`` opacity in [0, 1] (zeros without windows).
    """
    h, w = int(shape_hw[0]), int(shape_hw[1])
    if not len(windows):
        return np.zeros((h, w))
    cover = windows_cover(windows, (h, w), mm_per_px, supersample)
    return spray_mask(cover, mm_per_px, cfg, spray_time=spray_time, geometry=geometry)


def windows_cover(windows, shape_hw: tuple[int, int], mm_per_px: float, supersample: int = 4) -> np.ndarray:
    """Each pixel's open fraction under the windows: rasterised ``supersample`` times finer and averaged back.

    Only the pixels around the windows are rasterised (the same pixels as the whole raster's): on the
    600 x 400 mm coffee mural (1600 x 2400 px) rasterising the whole raster 4 times finer for every
    layer and tile of every simulation took 107 s of the job's 545 s (py-spy), and the job's files
    are the same without it. The rasterised pixels are kept for the next call with the same windows
    and raster (:func:`_cover_box`): a job sprays each layer's windows in several simulations.

    Args:
        windows: Each ``(outer, inner rings)`` in picture mm.
        shape_hw: ``(H, W)`` of the raster.
        mm_per_px: Raster pixel size in mm.
        supersample: Rasterising factor per axis. Defaults to 4.

    Returns:
        ``(H, W)`` open fraction in [0, 1].
    """
    h, w = int(shape_hw[0]), int(shape_hw[1])
    cover = np.zeros((h, w))
    box, part = _cover_box(windows, h, w, float(mm_per_px), max(int(supersample), 1))
    if part is not None:
        r0, r1, c0, c1 = box
        cover[r0:r1, c0:c1] = part
    return cover


#: The windows' rasterised pixels of the last few calls, by the windows' coordinates and the raster:
#: a job sprays a layer's windows in its simulation, in every can of the prior and every panel of the
#: sweep card, on the same raster. On the 600 x 400 mm coffee mural (3 layers, 1600 x 2400 px)
#: rasterising them took 17 s of the job's 392 s (py-spy), each layer's windows again for every simulation.
_COVER_CACHE = Kept(8)


def _cover_box(
    windows, h: int, w: int, mm_per_px: float, f: int
) -> tuple[tuple[int, int, int, int], np.ndarray | None]:
    """``(box, open fraction in the box)`` of :func:`windows_cover`, rasterised once per windows and raster.

    The box is :func:`_windows_box`'s; the fraction is None when the box is empty. The kept
    arrays are read-only.
    """
    from ..frames import rasterise_polygons

    def make() -> tuple[tuple[int, int, int, int], np.ndarray | None]:
        r0, r1, c0, c1 = box = _windows_box(windows, h, w, mm_per_px)
        if not (r1 > r0 and c1 > c0):
            return box, None
        fine = rasterise_polygons(
            list(windows), (h * f, w * f), mm_per_px / f, (r0 * f, r1 * f, c0 * f, c1 * f)
        )
        part = fine.reshape(r1 - r0, f, c1 - c0, f).mean(axis=(1, 3))
        part.setflags(write=False)
        return box, part

    # Each window's rings in order, the outer ring of each marked, so no two sets of windows share a key.
    rings = [a for outer, inner in windows for a in (np.zeros(0), outer, *inner)]
    return _COVER_CACHE.get((digest(*rings), h, w, mm_per_px, f), make)


def _windows_box(windows, h: int, w: int, mm_per_px: float) -> tuple[int, int, int, int]:
    """``(r0, r1, c0, c1)``: the raster's rows and columns that hold every window's rings, a pixel to spare."""
    rings = [
        np.asarray(ring, dtype=np.float64).reshape(-1, 2)
        for outer, inner in windows
        for ring in (outer, *inner)
    ]
    pts = np.concatenate(rings) if rings else np.zeros((0, 2))
    if not len(pts):
        return 0, 0, 0, 0
    rc = mm_to_px(pts, h, mm_per_px)
    lo, hi = np.floor(rc.min(axis=0)) - 1, np.ceil(rc.max(axis=0)) + 2
    r0, c0 = (int(max(v, 0)) for v in lo)
    r1, c1 = int(min(hi[0], h)), int(min(hi[1], w))
    return r0, max(r1, r0), c0, max(c1, c0)
