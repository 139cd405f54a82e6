"""S-CIELAB: colour difference as a viewer sees it from a distance (Zhang & Wandell 1997).

A pixel-by-pixel CIEDE2000 scores every paint dot as an error, however far away the
viewer stands. S-CIELAB first blurs both images the way the eye does, then compares
them with CIEDE2000:

1. sRGB -> CIE XYZ (D65) -> the opponent space of Poirson & Wandell (1993): one
   luminance and two chromatic channels (red-green, blue-yellow);
2. each channel is convolved with its own sum of Gaussians whose widths are angles
   of the visual field (degrees). The chromatic channels blur far more than the
   luminance one: the eye resolves fine luminance detail but little fine colour;
3. back to XYZ, then CIELAB (D65 white) and CIEDE2000 per pixel
   (:mod:`stencil_cad.simulate.ciede`); the score is the mean.

The widths are given in degrees, so the pixel pitch (mm per px) and the viewing
distance set them in pixels: ``samples per degree = D tan(1°) / pitch``. The widths
(full width at half maximum, degrees) and weights are those of the authors' reference
implementation:

============  ======================================  ==============================
channel       FWHM (degrees)                          weights
============  ======================================  ==============================
luminance     0.05, 0.225, 7.0                        1.00327, 0.114416, -0.117686
red-green     0.0685, 0.826                           0.616725, 0.383275
blue-yellow   0.0920, 0.6451                          0.567885, 0.432115
============  ======================================  ==============================

Every Gaussian is normalised to unit sum, so each channel's filter preserves a flat
field (the weights sum to 1). When the grid's pixels are coarser than the narrowest
Gaussian (its standard deviation under :data:`MIN_SIGMA_PX` pixels) the images are
upsampled (each pixel repeated, as a printed or displayed pixel is a flat square)
before filtering, so the kernel is sampled finely enough (the filter itself runs on
the input grid as one shorter filter per phase of the repetition, which gives the same
sums with about ``2 k² / (k + 1)`` times fewer operations for an upsampling ``k``). Gaussians much wider
than :data:`DIRECT_SIGMA_PX` pixels are applied on a block-averaged copy and
interpolated back (they are smooth on that scale).

The picture is filtered and scored block by block (:data:`BLOCK_PIXELS`), each block
with a margin of the direct Gaussians' reach, so its core is the same as the whole
picture's and the memory is that of one block: a mural of 20 megapixels, upsampled
twice at 1 m, would otherwise hold several 80-megapixel float copies. Against an exact
filter (every Gaussian applied directly to the whole picture) the mean differs by at
most 5e-4 ΔE on photos of 60 × 80 to 601 × 601 px (sizes that are and are not whole
multiples of the averaging cell) at 0.25 and 0.71 mm/px from 1 m; one block against many
agrees to 1e-12 (``tests/simulate/test_scielab.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..filters import correlate_axis
from .cells import cell_means, gaussian_reflect, mirrored
from .kept import Kept, digest

__all__ = [
    "DEFAULT_DISTANCE_M",
    "FILTERS",
    "filters_mm",
    "samples_per_degree",
    "scielab",
    "scielab_filter",
    "scielab_map",
    "smallest_sigma_mm",
    "view_scores",
]

#: Default viewing distance in metres (a picture on a wall seen from across a room).
DEFAULT_DISTANCE_M = 1.0

#: XYZ (Y of white = 1) to the opponent space (luminance, red-green, blue-yellow),
#: CIE 1931 2° observer, from the reference implementation of S-CIELAB.
XYZ_TO_OPP = np.array(
    [
        [0.2787336, 0.7218031, -0.1065520],
        [-0.4487736, 0.2898056, 0.0771569],
        [0.0859513, -0.5899859, 0.5011089],
    ]
)
OPP_TO_XYZ = np.linalg.inv(XYZ_TO_OPP)

#: Per opponent channel: ((FWHM in degrees, weight), ...).
FILTERS: tuple[tuple[tuple[float, float], ...], ...] = (
    ((0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)),
    ((0.0685, 0.616725), (0.826, 0.383275)),
    ((0.0920, 0.567885), (0.6451, 0.432115)),
)

#: Upsample when the narrowest Gaussian's standard deviation is below this, in pixels.
MIN_SIGMA_PX = 1.0
#: Largest upsampling factor.
MAX_UPSAMPLE = 8
#: Gaussians wider than this (standard deviation, px) are applied on a block-averaged copy.
DIRECT_SIGMA_PX = 24.0
#: Pixels (after upsampling, margin included) of one block of the blockwise filter: about 50 MB
#: per float copy of a block, so a score stays under 1 GB however large the picture.
BLOCK_PIXELS = 2_000_000
#: A wide Gaussian's cells are at most this many times smaller than the picture's shorter side.
CELLS_PER_SIDE = 16


_FWHM_TO_SIGMA = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))


def samples_per_degree(mm_per_px: float, distance_m: float) -> float:
    """Pixels per degree of visual angle for a pixel pitch seen from a distance.

    Args:
        mm_per_px: Pixel pitch in mm.
        distance_m: Viewing distance in metres.

    Returns:
        ``1000 D tan(1°) / pitch``.
    """
    if not (mm_per_px > 0 and distance_m > 0):
        raise ValueError(f"mm_per_px and distance_m must be > 0, got {mm_per_px} and {distance_m}")
    return 1000.0 * distance_m * math.tan(math.radians(1.0)) / mm_per_px


def smallest_sigma_mm(distance_m: float) -> float:
    """Standard deviation in mm of the eye's narrowest (luminance) Gaussian at a distance."""
    fwhm_deg = min(w for ch in FILTERS for w, _ in ch)
    return 1000.0 * distance_m * math.tan(math.radians(fwhm_deg)) * _FWHM_TO_SIGMA


def filters_mm(distance_m: float) -> tuple[tuple[tuple[float, float], ...], ...]:
    """:data:`FILTERS` at a viewing distance: per channel ``((sigma_mm, weight), ...)``."""
    mm_per_deg = 1000.0 * distance_m * math.tan(math.radians(1.0))
    return tuple(tuple((w * mm_per_deg * _FWHM_TO_SIGMA, wt) for w, wt in ch) for ch in FILTERS)


def _srgb_to_opp(rgb: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2xyz

    return rgb2xyz(np.clip(rgb, 0.0, 1.0)) @ XYZ_TO_OPP.T


def _upsample_factor(mm_per_px: float, distance_m: float) -> int:
    spd = samples_per_degree(mm_per_px, distance_m)
    narrow = min(w for ch in FILTERS for w, _ in ch) * spd * _FWHM_TO_SIGMA
    if narrow >= MIN_SIGMA_PX:
        return 1
    return int(min(MAX_UPSAMPLE, math.ceil(MIN_SIGMA_PX / narrow)))


class _Plan:
    """How one picture is filtered: the upsampling, the Gaussians in pixels, the blocks.

    Gaussians up to :data:`DIRECT_SIGMA_PX` (on the upsampled grid) are applied block by
    block, each block with a margin of their reach (4 sigma), so a block's filtered core
    equals the whole picture's. The wider ones (only the luminance 7° term at ordinary
    pitches) are smooth on the scale of many pixels: they are applied once, on a
    block-averaged copy of the whole picture, and interpolated into every block.
    """

    def __init__(self, shape: tuple[int, int], mm_per_px: float, distance_m: float, block_pixels: int):
        self.shape = shape
        self.k = k = _upsample_factor(mm_per_px, distance_m)
        spd = samples_per_degree(mm_per_px / k, distance_m)
        self.direct: list[list[tuple[float, float]]] = []
        self.wide: list[list[tuple[float, float]]] = []
        for gaussians in FILTERS:
            d: list[tuple[float, float]] = []
            w: list[tuple[float, float]] = []
            for fwhm_deg, weight in gaussians:
                sigma = fwhm_deg * spd * _FWHM_TO_SIGMA
                (d if sigma <= DIRECT_SIGMA_PX else w).append((sigma, weight))
            self.direct.append(d)
            self.wide.append(w)
        reach = max((s for ch in self.direct for s, _ in ch), default=0.0)
        # scipy's radius is int(4 sigma + 0.5) upsampled pixels; the margin is in input pixels.
        self.margin = int(math.ceil((int(4.0 * reach + 0.5) + 1) / k))
        side = max(int(math.sqrt(block_pixels)) // k - 2 * self.margin, 64)
        self.side = side

    def blocks(self):
        """Cores ``(r0, r1, c0, c1)`` and their regions ``(R0, R1, C0, C1)`` in input pixels."""
        h, w = self.shape
        m = self.margin
        for r0 in range(0, h, self.side):
            for c0 in range(0, w, self.side):
                r1, c1 = min(r0 + self.side, h), min(c0 + self.side, w)
                yield (r0, r1, c0, c1), (max(r0 - m, 0), min(r1 + m, h), max(c0 - m, 0), min(c1 + m, w))


def _wide_maps(rgb: np.ndarray, plan: _Plan, opp=None) -> list:
    """Per channel, the wide Gaussians' weighted sums on block-averaged grids: ``[(map, cell, pad), ...]`` or None.

    Each wide Gaussian is applied on cells of about a third of :data:`DIRECT_SIGMA_PX` of its own
    width (Gaussians whose cells are the same size share one map). The channel is mirrored past
    the picture's edges (scipy's "reflect") by the Gaussians' reach and rounded up to whole cells
    before averaging, so the picture's edge lies where the whole-picture filter reflects it and
    every cell holds ``cell`` × ``cell`` pixels. ``opp`` is ``rgb`` converted (:func:`_srgb_to_opp`), or None.
    """
    h, w = plan.shape
    out: list = []
    for c, gaussians in enumerate(plan.wide):
        if not gaussians:
            out.append(None)
            continue
        if opp is None:
            # Every channel from one conversion (per pixel, so the same values as one per channel).
            opp = np.empty((h, w, 3))
            for r0 in range(0, h, 512):
                opp[r0 : r0 + 512] = _srgb_to_opp(rgb[r0 : r0 + 512])
        by_cell: dict[int, list[tuple[float, float]]] = {}
        for sigma, weight in gaussians:
            by_cell.setdefault(_cell(sigma, gaussians, plan), []).append((sigma, weight))
        out.append([_cell_map(opp[..., c], f, group, plan) for f, group in by_cell.items()])
    return out


def _cell(sigma: float, gaussians: list[tuple[float, float]], plan: _Plan) -> int:
    """The cell side, input pixels, on which a wide Gaussian of a channel is applied.

    Cells of about a third of :data:`DIRECT_SIGMA_PX` for the channel's narrowest wide Gaussian;
    a wider one within the picture's size gets cells of its own width (at most a sixteenth of the
    picture's shorter side). With the narrowest one's cells, the 7° luminance Gaussian seen from
    6 m was applied on cells of 5 px with a kernel of 2,000 cells: 28 s of a 1600 x 2400 px score.
    One wider than the picture sees the picture mirrored (cut at four picture sizes), and keeps
    the narrowest one's cells: there, cells of its own width moved the score of a 300 x 450 px picture seen from 10 m by 7e-3.
    """
    h, w = plan.shape
    third = DIRECT_SIGMA_PX / 3.0
    narrowest = max(int(min(s for s, _ in gaussians) / plan.k // third), 1)
    if sigma / plan.k > max(h, w):
        return narrowest
    return max(min(int(sigma / plan.k // third), min(h, w) // CELLS_PER_SIDE), narrowest)


def _cell_map(channel: np.ndarray, f: int, gaussians: list[tuple[float, float]], plan: _Plan):
    """``(map, f, pad)``: the Gaussians' weighted sum of ``channel`` on cells of ``f`` × ``f`` pixels."""
    h, w = channel.shape
    # A Gaussian far wider than the picture (a small picture seen from far) sees the
    # mirrored picture over and over: four picture sizes of mirror are ample there.
    reach = min(4.0 * max(s for s, _ in gaussians) / plan.k, 4.0 * max(h, w))
    pad = f * int(math.ceil((reach + f) / f))
    small = cell_means(channel, mirrored(h, pad, pad + (-h) % f), mirrored(w, pad, pad + (-w) % f), f)
    acc = np.zeros_like(small)
    for sigma, weight in gaussians:
        acc += weight * gaussian_reflect(small, sigma / plan.k / f)
    return acc, f, pad


#: The reference's wide maps of the last few scores, by the reference's bytes and the filters: a
#: job scores many pictures against one reference at one distance (the prior's cans, a mural's
#: registration cases). On a 1600 x 2400 px picture at 0.25 mm per pixel seen from 3 m, a score
#: took 5.9 s with the reference's wide maps made again and 5.0 s with them kept; hashing the
#: reference takes 0.1 s.
_WIDE_CACHE = Kept(4)


def _reference_wide_maps(ref: np.ndarray, plan: _Plan, ref_digest: bytes) -> list:
    """:func:`_wide_maps` of the reference, computed once for the same pixels and filters (read-only maps).

    ``ref_digest`` is :func:`~stencil_cad.simulate.kept.digest` of ``ref``.
    """
    data = np.ascontiguousarray(ref)

    def make() -> list:
        maps = _wide_maps(data, plan)
        for entries in maps:
            for entry in entries or ():
                entry[0].setflags(write=False)
        return maps

    return _WIDE_CACHE.get((ref_digest, plan.k, tuple(tuple(ch) for ch in plan.wide)), make)


def _filter_region(part: np.ndarray, region, plan: _Plan, wide: list, opp=None) -> np.ndarray:
    """A region (``part``, the picture's pixels in ``region``; ``opp``, them converted, or None) as the eye sees it, upsampled, in XYZ."""
    r0, _, c0, _ = region
    k = plan.k
    # Colour conversion is per pixel, so it commutes with the upsampling (each pixel repeated):
    # converted first, it costs k² times less.
    opp = _srgb_to_opp(part) if opp is None else opp
    h, w = opp.shape[0] * k, opp.shape[1] * k
    out = np.zeros((h, w, 3))
    for c in range(3):
        for sigma, weight in plan.direct[c]:
            out[..., c] += weight * _upsampled_gaussian(opp[..., c], sigma, k)
        for small, f, pad in wide[c] or ():
            # Upsampled pixel centres in input pixels, then in the padded picture's cells.
            ys = (pad + r0 + (np.arange(h) + 0.5) / k) / f - 0.5
            xs = (pad + c0 + (np.arange(w) + 0.5) / k) / f - 0.5
            out[..., c] += _bilinear(small, ys, xs)
    return out @ OPP_TO_XYZ.T


def _lerp_index(n: int, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation along one axis of length ``n``: lower index, upper index, weight of the upper."""
    c = np.clip(coords, 0.0, n - 1.0)
    i0 = np.minimum(np.floor(c).astype(np.intp), max(n - 2, 0))
    return i0, np.minimum(i0 + 1, n - 1), c - i0


def _bilinear(small: np.ndarray, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """``small`` linearly interpolated at every ``(ys[i], xs[j])``, clamped at its edges.

    The values of ``map_coordinates(small, meshgrid(ys, xs), order=1, mode="nearest")``,
    one axis at a time (the points form a grid): a few times faster on a block.
    """
    y0, y1, fy = _lerp_index(small.shape[0], ys)
    x0, x1, fx = _lerp_index(small.shape[1], xs)
    rows = small[y0] * (1.0 - fy)[:, None] + small[y1] * fy[:, None]
    return rows[:, x0] * (1.0 - fx) + rows[:, x1] * fx


def _phase_kernels(sigma: float, k: int) -> list[np.ndarray]:
    """The Gaussian of scipy (radius ``int(4 sigma + 0.5)``, unit sum) folded onto ``k`` phases.

    On a picture whose pixels are each repeated ``k`` times, the filtered value at upsampled
    index ``j k + p`` is ``sum_q K_p[q] x[j + q]``: the taps ``d`` of the kernel that land on
    input pixel ``j + q`` (``(p + d) // k == q``) add up. Each phase's kernel is returned
    zero-padded to odd length with its ``q = 0`` tap in the middle (``correlate1d``'s centre).
    """
    radius = int(4.0 * sigma + 0.5)
    d = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 / (sigma * sigma) * d.astype(np.float64) ** 2)
    kernel /= kernel.sum()
    out = []
    for p in range(k):
        q = (p + d) // k
        lo, hi = int(q.min()), int(q.max())
        half = max(-lo, hi)
        w = np.zeros(2 * half + 1)
        np.add.at(w, q + half, kernel)
        out.append(w)
    return out


def _upsampled_gaussian(x: np.ndarray, sigma: float, k: int) -> np.ndarray:
    """``gaussian_filter(upsample(x, k), sigma, mode="reflect", truncate=4)`` without upsampling first.

    Every input pixel stands for ``k`` × ``k`` equal upsampled pixels, so along each axis the
    filter is ``k`` shorter filters on the input grid, one per phase (:func:`_phase_kernels`),
    interleaved: the same sums, about ``2 k² / (k + 1)`` times fewer operations (4.5 at the
    ``k = 3`` of a 1 mm grid seen from 1 m). Mirroring the input at its edges ("reflect") is
    mirroring the upsampled picture at its edges, so the borders agree too.
    """
    kernels = _phase_kernels(sigma, k)
    y = x
    for axis in (0, 1):
        shape = list(y.shape)
        shape[axis] *= k
        z = np.empty(shape)
        for p, w in enumerate(kernels):
            index = [slice(None), slice(None)]
            index[axis] = slice(p, None, k)
            z[tuple(index)] = correlate_axis(y, w, axis, "reflect")
        y = z
    return y


def _check_rgb(rgb: np.ndarray) -> np.ndarray:
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"rgb must be (H, W, 3), got shape {rgb.shape}")
    return rgb


def _core(region_out: np.ndarray, core, region, k: int) -> np.ndarray:
    (r0, r1, c0, c1), (R0, _, C0, _) = core, region
    return region_out[(r0 - R0) * k : (r1 - R0) * k, (c0 - C0) * k : (c1 - C0) * k]


def scielab_filter(
    rgb: np.ndarray, mm_per_px: float, distance_m: float, block_pixels: int = BLOCK_PIXELS
) -> np.ndarray:
    """The image as the eye sees it from ``distance_m``, in CIE XYZ (Y of white = 1).

    Args:
        rgb: ``(H, W, 3)`` sRGB in [0, 1].
        mm_per_px: Pixel pitch of ``rgb`` in mm.
        distance_m: Viewing distance in metres.
        block_pixels: Pixels (upsampled) of one block with its margin (see :class:`_Plan`).

    Returns:
        ``(k H, k W, 3)`` filtered XYZ, ``k`` the upsampling factor (1 unless the grid
        undersamples the narrowest Gaussian).
    """
    rgb = _check_rgb(rgb)
    plan = _Plan(rgb.shape[:2], mm_per_px, distance_m, block_pixels)
    k = plan.k
    wide = _wide_maps(rgb, plan)
    out = np.empty((rgb.shape[0] * k, rgb.shape[1] * k, 3))
    for core, region in plan.blocks():
        r0, r1, c0, c1 = core
        part = rgb[region[0] : region[1], region[2] : region[3]]
        out[r0 * k : r1 * k, c0 * k : c1 * k] = _core(
            _filter_region(part, region, plan, wide), core, region, k
        )
    return out


@dataclass(frozen=True)
class BlockTask:
    """One block of a score: both pictures' pixels in its region, where its core lies, the plan.

    ``ref_digest`` is the whole reference's :func:`~stencil_cad.simulate.kept.digest`, which with
    the plan and the region says what the reference's pixels there and its wide maps are.
    """

    ref: np.ndarray
    test: np.ndarray
    core: tuple[int, int, int, int]
    region: tuple[int, int, int, int]
    plan: _Plan
    wide_ref: list
    wide_test: list
    ref_digest: bytes
    test_opp: np.ndarray | None = None  # ``test`` converted (a block that is the whole picture), or None


#: The reference's filtered blocks of the last few scores, by the block's pixels, the reference's wide
#: maps and the plan: a job scores many pictures against one reference at one distance (the prior's
#: cans, a mural's registration cases), and the reference's half of a block's filtering was done
#: again for each. Blocks under :data:`KEPT_BLOCK_PIXELS` (a small patch scored at many distances)
#: are not kept.
_REF_BLOCKS = Kept(8)
KEPT_BLOCK_PIXELS = 250_000


def _reference_block(task: BlockTask) -> np.ndarray:
    """The reference's filtered core of a block (XYZ, upsampled), kept for the next score of the same block."""
    k = task.plan.k

    def make() -> np.ndarray:
        return _core(
            _filter_region(task.ref, task.region, task.plan, task.wide_ref), task.core, task.region, k
        )

    if task.ref.shape[0] * task.ref.shape[1] < KEPT_BLOCK_PIXELS:
        return make()

    def kept() -> np.ndarray:
        # Contiguous as the ΔE kernel reads it; left writable, so the kernel's compiled
        # signature stays the one it has (nothing writes to it).
        return np.ascontiguousarray(make())

    # The whole reference's digest, taken once per score, stands for the block's pixels and the
    # reference's wide maps (a function of the reference and the plan): hashing them again for
    # every block took the example's simulate stage 0.06 CPU-s of its 0.13 s of hashing.
    key = (
        task.ref_digest,
        task.core,
        task.region,
        task.plan.shape,
        k,
        tuple(tuple(ch) for ch in task.plan.direct),
        tuple(tuple(ch) for ch in task.plan.wide),
    )
    return _REF_BLOCKS.get(key, kept)


def block_delta_e(task: BlockTask) -> np.ndarray:
    """S-CIELAB ΔE of one block's core (upsampled), from its region (a task)."""
    from .ciede import delta_e_xyz

    k = task.plan.k
    xyz_ref = _reference_block(task)
    region = _filter_region(task.test, task.region, task.plan, task.wide_test, task.test_opp)
    xyz_test = _core(region, task.core, task.region, k)
    return delta_e_xyz(xyz_ref, xyz_test)


def block_sum(task: BlockTask) -> tuple[float, int]:
    """Sum and count of one block's S-CIELAB ΔE (a task)."""
    de = block_delta_e(task)
    return float(np.sum(de)), int(de.size)


def _block_tasks(reference_rgb, test_rgb, mm_per_px: float, distance_m: float, block_pixels: int):
    """``(plan, tasks, count)``: the blocks of a score, made one at a time as they are consumed.

    Each task carries only its region's pixels, so a lazy consumer holds one block at a time.
    """
    ref = _check_rgb(reference_rgb)
    test = _check_rgb(test_rgb)
    if ref.shape != test.shape:
        raise ValueError(f"images differ in shape: {ref.shape} and {test.shape}")
    plan = _Plan(ref.shape[:2], mm_per_px, distance_m, block_pixels)
    ref_digest = digest(np.ascontiguousarray(ref))
    blocks = list(plan.blocks())
    # One block of the whole picture: the test picture converted once, for its wide maps and its block.
    whole = len(blocks) == 1 and blocks[0][1] == (0, plan.shape[0], 0, plan.shape[1])
    test_opp = _srgb_to_opp(test) if whole else None
    wide_ref, wide_test = _reference_wide_maps(ref, plan, ref_digest), _wide_maps(test, plan, test_opp)

    def tasks():
        for core, region in blocks:
            r0, r1, c0, c1 = region
            yield BlockTask(
                np.ascontiguousarray(ref[r0:r1, c0:c1]),
                np.ascontiguousarray(test[r0:r1, c0:c1]),
                core,
                region,
                plan,
                wide_ref,
                wide_test,
                ref_digest,
                test_opp,
            )

    return plan, tasks(), len(blocks)


def scielab_map(
    reference_rgb: np.ndarray,
    test_rgb: np.ndarray,
    mm_per_px: float,
    distance_m: float,
    block_pixels: int = BLOCK_PIXELS,
) -> np.ndarray:
    """Per-pixel S-CIELAB ΔE (CIEDE2000 of the filtered images).

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.
        block_pixels: Pixels (upsampled) of one block with its margin.

    Returns:
        ``(k H, k W)`` ΔE map (``k`` as in :func:`scielab_filter`).
    """
    plan, tasks, _ = _block_tasks(reference_rgb, test_rgb, mm_per_px, distance_m, block_pixels)
    k = plan.k
    out = np.empty((plan.shape[0] * k, plan.shape[1] * k))
    for task in tasks:
        r0, r1, c0, c1 = task.core
        out[r0 * k : r1 * k, c0 * k : c1 * k] = block_delta_e(task)
    return out


def scielab(
    reference_rgb: np.ndarray,
    test_rgb: np.ndarray,
    mm_per_px: float,
    distance_m: float,
    block_pixels: int = BLOCK_PIXELS,
    tasks_map=None,
) -> float:
    """Mean S-CIELAB ΔE between two images of the same grid seen from ``distance_m``.

    Computed block by block (each with the margin of the eye's filters), so the memory is
    that of one block whatever the picture's size: a mural's score fits where its
    whole-picture filter (several upsampled float copies) would not.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.
        block_pixels: Pixels (upsampled) of one block with its margin.
        tasks_map: ``tasks_map(fn, items, desc, count)`` yielding ``fn(item)`` in order, consuming
            ``items`` lazily (a job's executor, so the blocks of a mural run on its workers), or
            None: in this process.

    Returns:
        The mean ΔE (0 for identical images).
    """
    _, tasks, blocks = _block_tasks(reference_rgb, test_rgb, mm_per_px, distance_m, block_pixels)
    results = tasks_map(block_sum, tasks, "score", blocks) if tasks_map is not None else map(block_sum, tasks)
    total, count = 0.0, 0
    for s, n in results:  # in block order: the same sum on any number of workers
        total += s
        count += n
    return total / count


def view_scores(
    reference_rgb: np.ndarray, test_rgb: np.ndarray, mm_per_px: float, distance_m: float, tasks_map=None
) -> dict:
    """S-CIELAB at the viewing distance and at twice it, for the manifest and the summary.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.
        tasks_map: Where the blocks run (see :func:`scielab`), or None: in this process.

    Returns:
        ``view_distance_m``, ``scielab`` (at the distance) and ``scielab_2x`` (at twice it).
    """
    return {
        "view_distance_m": float(distance_m),
        "scielab": scielab(reference_rgb, test_rgb, mm_per_px, distance_m, tasks_map=tasks_map),
        "scielab_2x": scielab(reference_rgb, test_rgb, mm_per_px, 2.0 * distance_m, tasks_map=tasks_map),
    }
