"""Measure a can from a photo of the sprayed calibration card: the spray-profile fit.

Not to be confused with the tone calibration of the simulator (:mod:`stencil_cad.calibrate`),
which chooses hole densities for a model; this module measures the model's constants.

Steps, per footprint (stand-off) of the card:

1. **Fiducials**: the four ArUco markers printed in the band under the wall
   (``cv2.aruco.ArucoDetector``) give 16 corners with known positions in mm; a homography
   (``cv2.findHomography``) maps mm to photo pixels.
2. **Rectify**: the footprint is resampled into the card's frame at :data:`FIT_PX_PER_MM`
   (``cv2.warpPerspective``), and decoded from sRGB to linear light.
3. **Flat-field**: ``I' = (I - D) / (F - D)``. ``F``, the unpainted white, is a quadratic
   surface fitted (robustly) to the paper in the band and to the primer far from any hole;
   ``D = b F`` with ``b`` the black patches' share of the white (printed black reflects light
   in proportion to it). Paper becomes 1 and printed black 0.
4. **Camera blur**: the printed patches' edges are sharp on paper, so their measured width is
   the camera's (and the rectification's) blur; the model is blurred by it before comparison.
5. **Fit**: the card is sprayed in simulation (:func:`stencil_cad.simulate.physical.physical_opacity`,
   every hole of the window, the single-hole rows and the dose ladder) and
   ``1 - c alpha`` compared with ``I'`` pixel by pixel over the picture area of every footprint
   at once (``scipy.optimize.least_squares``). Free: ``spread_k``, ``bleed_sigma_mm`` (with two
   or more stand-offs; with one it keeps its prior), ``deposit_per_pass``, the paint's contrast
   ``c`` and each footprint's offset of the wall from its printed outline.

The residual is reported as the RMS of ``I' - model`` over all fitted pixels, and per feature.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.fft

from ..config.io import parse_json
from ..config.spray import CanConstants, SprayConfig
from ..errors import UserError
from ..files import check_target, read_text, write_text_over
from .layout import CardLayout, layout_from_description
from .photo import PhotoError, _Footprint, _prepare_footprints, read_photo

log = logging.getLogger(__name__)

__all__ = ["FIT_PX_PER_MM", "CardFit", "PhotoError", "calibrate", "fit_card", "read_photo"]

#: Resolution the footprints are rectified to and fitted at (px per mm).
FIT_PX_PER_MM = 8.0


@dataclass(frozen=True)
class CardFit:
    """The constants a photo gave, and how well the model fits it.

    Attributes:
        can: The fitted constants (spread_k, bleed_sigma_mm, deposit_per_pass, distance, speed).
        contrast: The paint's contrast on the primer in the channel used, 1 - paint / primer.
        channel: The colour channel fitted (0 = R, 1 = G, 2 = B): the one with the most contrast.
        shifts_mm: Per footprint, the wall's fitted offset from its printed outline (mm).
        residual_rms: RMS of the flat-fielded photo minus the model over the fitted pixels.
        feature_residuals: RMS residual per feature kind (window, single, patch).
        patch_tones: Per footprint, per dose-ladder patch: measured and fitted mean opacity.
        camera_blur_mm: The photo's own blur measured on the printed patches.
        px_per_mm: Resolution of the photo on the card (the coarsest footprint).
        seconds: Time of the whole fit.
        info: Other figures (markers found, grey-patch linearity, iterations).
    """

    can: CanConstants
    contrast: float
    channel: int
    shifts_mm: tuple[tuple[float, float], ...]
    residual_rms: float
    feature_residuals: dict
    patch_tones: list
    camera_blur_mm: float
    px_per_mm: float
    seconds: float
    info: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- photo


# ----------------------------------------------------------------------------- fit


class _SprayFFT:
    """The physical model over one footprint's picture area, shifted and blurred in Fourier space.

    :func:`stencil_cad.simulate.physical.physical_opacity` rasterises the holes and blurs them for every
    call; the fit evaluates the model a few hundred times with only sigma, the plate's shading
    and the wall's offset changing. Shifting all holes shifts the dose image, and the shading
    depends on the radius alone, so the open area of each distinct radius is rasterised once
    (with a margin that keeps the circular convolution from wrapping) and every evaluation is one
    inverse FFT: ``dose = F^-1[sum_g T(r_g) A_g(f) exp(-2 pi^2 s^2 |f|^2) exp(-2 pi i f.shift)]``.
    """

    def __init__(self, layout: CardLayout, standoff_mm: float, shape: tuple[int, int], ppm: float):
        from ..frames import mm_to_px
        from ..simulate.physical import _raster_open_area

        self.g, self.t, self.ppm, self.shape = standoff_mm, layout.plate_thickness_mm, ppm, shape
        # Paint reaches 4 sigma beyond the picture (a tail of e^-8); sigma stays below 3 mm up to a
        # 25 mm stand-off for caps up to k = 0.12, and a wider spread only wraps a negligible tail.
        self.pad = int(math.ceil(max(12.0, 0.5 * standoff_mm) * ppm))
        H, W = shape[0] + 2 * self.pad, shape[1] + 2 * self.pad
        self.radii = np.unique(layout.dots.r_mm)
        self.spectra = []
        for rg in self.radii:
            sel = layout.dots.r_mm == rg
            rc = mm_to_px(layout.dots.xy_mm[sel], shape[0], 1.0 / ppm) + self.pad
            area = np.zeros((H, W))
            n = int(sel.sum())
            _raster_open_area(area, rc[:, 0].copy(), rc[:, 1].copy(), np.full(n, rg * ppm), np.ones(n), 24.0)
            self.spectra.append(scipy.fft.rfft2(area).astype(np.complex64))
        self.fy = np.fft.fftfreq(H)[:, None]
        self.fx = np.fft.rfftfreq(W)[None, :]
        self.full = (H, W)

    def opacity(self, cfg: SprayConfig, passes: float, dx_mm: float, dy_mm: float) -> np.ndarray:
        from ..simulate.physical import dose_per_pass, plate_transmission, spread_sigma_mm

        k = cfg.can.spread_k
        trans = plate_transmission(self.radii, self.t, k)
        spec = self.spectra[0] * np.float32(trans[0])
        for w, a in zip(trans[1:], self.spectra[1:], strict=True):
            spec += a * np.float32(w)
        s_px2 = max((spread_sigma_mm(cfg, self.g) * self.ppm) ** 2 - 1.0 / 12.0, 0.0)
        # Gaussian blur and shift are both separable in frequency. Holes move +dx in x (columns)
        # and +dy in y, i.e. -dy in rows.
        kx = np.exp(-2.0 * np.pi**2 * s_px2 * self.fx**2 - 2j * np.pi * self.fx * dx_mm * self.ppm)
        ky = np.exp(-2.0 * np.pi**2 * s_px2 * self.fy**2 + 2j * np.pi * self.fy * dy_mm * self.ppm)
        spec *= kx.astype(np.complex64)
        spec *= ky.astype(np.complex64)
        dose = scipy.fft.irfft2(spec, s=self.full, workers=-1)
        dose = dose[self.pad : self.pad + self.shape[0], self.pad : self.pad + self.shape[1]]
        return -np.expm1(-passes * dose_per_pass(cfg) * np.maximum(dose, 0.0))


def _channel(fps: list[_Footprint], layout: CardLayout, ppm: float) -> int:
    """The channel in which the window's centre is darkest relative to white."""
    win = next(f for f in layout.features if f.kind == "window")
    cx, cy = layout.dots.xy_mm[win.index[0]]
    r = int(round((layout.height_mm - cy) * ppm))
    c = int(round(cx * ppm))
    k = int(round(2.0 * ppm))
    depth = np.mean(
        [1.0 - f.lin[r - k : r + k, c - k : c + k].reshape(-1, 3).mean(axis=0) for f in fps], axis=0
    )
    return int(np.argmax(depth))


def _feature_masks(layout: CardLayout, shape, ppm) -> dict[str, np.ndarray]:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    x = (cols + 0.5) / ppm
    y = layout.height_mm - (rows + 0.5) / ppm
    out: dict[str, np.ndarray] = {}
    for f in layout.features:
        x0, y0, x1, y1 = f.box
        m = (x >= x0 - 2) & (x <= x1 + 2) & (y >= y0 - 2) & (y <= y1 + 2)
        out[f.kind] = out.get(f.kind, np.zeros(shape, bool)) | m
    return out


def _picture_masks(shape: tuple[int, int], ppm: float) -> tuple[np.ndarray, np.ndarray]:
    """The pixels scored (all but the outermost 0.5 mm) and the quarter of them fitted."""
    # The outermost 0.5 mm of the picture area touches the wall's inner face: left out.
    mask = np.zeros(shape, bool)
    e = int(round(0.5 * ppm))
    mask[e:-e, e:-e] = True
    # Every other pixel each way: the model is evaluated at full resolution (the blur must be
    # resolved), the residuals on a quarter of the pixels still hold ~10^5 values per footprint.
    fit_mask = mask.copy()
    fit_mask[1::2, :] = False
    fit_mask[:, 1::2] = False
    return mask, fit_mask


@dataclass
class _CardModel:
    """The sprayed card as a function of the fit's parameter vector.

    ``q = [log bleed_sigma_mm, log spread_k, log deposit_per_pass, contrast, dx_0, dy_0, dx_1, ...]``
    (offsets in mm, one pair per footprint).
    """

    models: list[_SprayFFT]
    obs: list[np.ndarray]  # per footprint, the flat-fielded channel fitted
    blur_px: list[float]  # per footprint, the camera's blur (px at the fit resolution)
    base: SprayConfig
    prior: CanConstants
    passes: float
    many: bool  # two or more stand-offs: the bleed is fitted
    distance_mm: float
    speed_m_s: float

    def constants(self, q) -> CanConstants:
        """The can's constants that ``q`` stands for (clamped to the schema's range)."""
        s0 = math.exp(q[0]) if self.many else self.prior.bleed_sigma_mm
        return CanConstants(
            spread_k=min(math.exp(q[1]), 1.0),
            bleed_sigma_mm=min(max(s0, 0.01), 10.0),
            deposit_per_pass=min(math.exp(q[2]), 20.0),
            distance_mm=self.distance_mm,
            speed_m_s=self.speed_m_s,
        )

    def predict(self, q, j: int) -> np.ndarray:
        """Footprint ``j`` as the camera would see it, flat-fielded (paper 1)."""
        from scipy.ndimage import gaussian_filter

        cfg = self.base.model_copy(update={"can": self.constants(q)})
        alpha = self.models[j].opacity(cfg, self.passes, q[4 + 2 * j], q[5 + 2 * j])
        img = 1.0 - q[3] * alpha
        if self.blur_px[j] > 0.3:
            img = gaussian_filter(img, self.blur_px[j], mode="nearest")
        return img

    def residuals(self, q, fit_mask: np.ndarray) -> np.ndarray:
        """Model minus photo over the fitted pixels of every footprint."""
        return np.concatenate([(self.predict(q, j) - self.obs[j])[fit_mask] for j in range(len(self.obs))])


def _start(card: _CardModel, depth0: list[float], shape: tuple[int, int], ppm: float) -> np.ndarray:
    """The parameter vector the fit starts from.

    The prior's spread, the deposit from the window's centre at a guessed contrast, and each
    footprint's offset from phase correlation against the model at that start.
    """
    import cv2

    prior, passes = card.prior, card.passes
    c_start = min(0.98, max(depth0) / 0.9 + 0.05)
    a_c = min(max(depth0) / c_start, 0.98)
    beta0 = (
        -math.log(1.0 - a_c)
        / passes
        * (card.distance_mm / prior.distance_mm)
        * (card.speed_m_s / prior.speed_m_s)
    )
    q0 = [
        math.log(max(prior.bleed_sigma_mm, 0.05)),
        math.log(max(prior.spread_k, 0.02)),
        math.log(max(beta0, 1e-3)),
        c_start,
    ]
    q0 += [0.0, 0.0] * len(card.obs)
    q = np.array(q0, dtype=np.float64)
    win = cv2.createHanningWindow(shape[::-1], cv2.CV_64F)
    for j in range(len(card.obs)):
        pred = 1.0 - card.predict(q, j)
        (dx, dy), _ = cv2.phaseCorrelate(pred.astype(np.float64), (1.0 - card.obs[j]).astype(np.float64), win)
        q[4 + 2 * j] = dx / ppm
        q[5 + 2 * j] = -dy / ppm
    return q


def _solve(card: _CardModel, q: np.ndarray, fit_mask: np.ndarray):
    """Least squares from ``q`` within the parameters' bounds (the bleed fixed with one stand-off).

    Returns:
        The fitted parameter vector and scipy's result (for its evaluation count and message).
    """
    from scipy.optimize import least_squares

    from ..config.spray import CanConstants

    n = len(card.obs)
    # The schema's bounds of each constant (log space; open lower ends kept off zero).
    box = [CanConstants.field_range(k) for k in ("bleed_sigma_mm", "spread_k", "deposit_per_pass")]
    lo = np.array([math.log(max(a, 1e-3)) for a, _ in box] + [0.05] + [-5.0] * (2 * n))
    hi = np.array([math.log(b) for _, b in box] + [1.0] + [5.0] * (2 * n))
    q = np.clip(q, lo + 1e-9, hi - 1e-9)
    active = np.ones(q.size, dtype=np.bool_)
    active[0] = card.many
    q_fixed = q.copy()

    def res_active(qa):
        qq = q_fixed.copy()
        qq[active] = qa
        return card.residuals(qq, fit_mask)

    sol = least_squares(res_active, q[active], bounds=(lo[active], hi[active]), x_scale="jac", diff_step=1e-4)
    q = q_fixed.copy()
    q[active] = sol.x
    return q, sol


def _patch_tones(
    card: _CardModel,
    fps: list[_Footprint],
    layout: CardLayout,
    q: np.ndarray,
    shape: tuple[int, int],
    ppm: float,
) -> list[dict]:
    """Per footprint and dose-ladder patch, the measured and the fitted mean opacity."""
    cfg_fit = card.base.model_copy(update={"can": card.constants(q)})
    tones = []
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    xg = (cols + 0.5) / ppm
    yg = layout.height_mm - (rows + 0.5) / ppm
    for j, f in enumerate(fps):
        shift = q[4 + 2 * j : 6 + 2 * j]
        alpha = card.models[j].opacity(cfg_fit, card.passes, shift[0], shift[1])
        measured = (1.0 - card.obs[j]) / q[3]
        for feat in layout.features:
            if feat.kind != "patch":
                continue
            x0, y0, x1, y1 = feat.box
            m = (
                (xg >= x0 + shift[0] + 1)
                & (xg <= x1 + shift[0] - 1)
                & (yg >= y0 + shift[1] + 1)
                & (yg <= y1 + shift[1] - 1)
            )
            tones.append(
                {
                    "standoff_mm": f.fp.standoff_mm,
                    "open_fraction": feat.open_fraction,
                    "measured": round(float(measured[m].mean()), 4),
                    "fitted": round(float(alpha[m].mean()), 4),
                }
            )
    return tones


#: A fit is refused when its residual RMS is more than this many times the photo's noise (the
#: robust spread of the bare paper around the picture) ...
RESIDUAL_NOISE_FACTOR = 2.5
#: ... and more than this (flat-fielded units). On synthetic photos (PNG and JPEG 85) of the right
#: card the residual is 0.96-1.05 times the noise (0.010-0.017); of another process's card (SLA
#: holes measured as FDM's and the reverse) 3.2-8.1 times (0.054-0.082). Not yet measured on
#: real photos, whose paint texture may leave more.
RESIDUAL_FLOOR = 0.03


def _check_residual(rms: float, noise: float) -> None:
    """Refuse a fit whose residual is far above the photo's noise: the photo is not of this card.

    Raises:
        PhotoError: With both figures and what to check.
    """
    if rms > max(RESIDUAL_NOISE_FACTOR * noise, RESIDUAL_FLOOR):
        raise PhotoError(
            f"the photo does not match the card description: the fit leaves a residual RMS of {rms:.3f}, "
            f"{rms / max(noise, 1e-6):.1f} times the photo's noise ({noise:.3f}); photograph the sheet of the "
            "card this card.json describes (each `stencil-cad card` writes its own), sprayed evenly and not moved"
        )


def fit_card(
    rgb: np.ndarray,
    layout: CardLayout,
    passes: float,
    *,
    distance_mm: float = 200.0,
    speed_m_s: float = 0.5,
    prior: CanConstants | None = None,
    ppm: float = FIT_PX_PER_MM,
) -> CardFit:
    """Fit the can's constants to a photo of the sprayed card.

    Args:
        rgb: ``(H, W, 3)`` uint8 sRGB photo (:func:`read_photo`).
        layout: The card (from ``card.json``).
        passes: Passes sprayed over the card in every footprint.
        distance_mm: Can distance from the plate while spraying, mm.
        speed_m_s: Sweep speed while spraying, m/s.
        prior: Starting values (and the bleed floor kept with a single stand-off). Defaults to
            :class:`CanConstants`' defaults.
        ppm: Fit resolution in px per mm. Defaults to :data:`FIT_PX_PER_MM`.

    Returns:
        The :class:`CardFit`.

    Raises:
        PhotoError: The photo cannot be read as a card (named reason).
    """
    t0 = time.perf_counter()
    prior = prior or CanConstants()
    fps = _prepare_footprints(rgb, layout, ppm)
    ch = _channel(fps, layout, ppm)
    shape = fps[0].lin.shape[:2]
    obs = [f.lin[..., ch] for f in fps]
    depth0 = [1.0 - float(np.percentile(o, 0.5)) for o in obs]
    if max(depth0) < 0.08:
        raise PhotoError(
            "no paint found on the card: the window is as light as the primer; spray the card (see "
            "`stencil-cad card`) and photograph the sprayed sheet"
        )
    card = _CardModel(
        models=[_SprayFFT(layout, f.fp.standoff_mm, shape, ppm) for f in fps],
        obs=obs,
        blur_px=[f.blur_mm * ppm for f in fps],
        base=SprayConfig(model="physical", can_distance_mm=distance_mm, pass_speed_m_s=speed_m_s),
        prior=prior,
        passes=passes,
        many=len({f.fp.standoff_mm for f in fps}) >= 2,
        distance_mm=distance_mm,
        speed_m_s=speed_m_s,
    )
    mask, fit_mask = _picture_masks(shape, ppm)
    q, sol = _solve(card, _start(card, depth0, shape, ppm), fit_mask)
    rms, feature_rms = _residuals(card, q, obs, _feature_masks(layout, shape, ppm), mask)
    noise = float(np.median([f.noise[ch] for f in fps]))
    _check_residual(rms, noise)
    return CardFit(
        can=card.constants(q),
        contrast=float(q[3]),
        channel=ch,
        shifts_mm=tuple(
            (round(float(q[4 + 2 * j]), 4), round(float(q[5 + 2 * j]), 4)) for j in range(len(fps))
        ),
        residual_rms=rms,
        feature_residuals=feature_rms,
        patch_tones=_patch_tones(card, fps, layout, q, shape, ppm),
        camera_blur_mm=float(np.median([f.blur_mm for f in fps])),
        px_per_mm=float(min(f.px_per_mm for f in fps)),
        seconds=time.perf_counter() - t0,
        info=_fit_info(card, fps, ch, noise, sol),
    )


def _residuals(card: _CardModel, q, obs: list, feats: dict, mask: np.ndarray) -> tuple[float, dict]:
    """RMS of model minus photo over ``mask`` of every footprint, and per feature (rounded to 1e-5)."""
    res_all = [card.predict(q, j) - obs[j] for j in range(len(obs))]
    rms = float(np.sqrt(np.mean(np.concatenate([rj[mask] for rj in res_all]) ** 2)))
    feature_rms = {
        k: round(float(np.sqrt(np.mean(np.concatenate([rj[m & mask] for rj in res_all]) ** 2))), 5)
        for k, m in feats.items()
    }
    return rms, feature_rms


def _fit_info(card: _CardModel, fps: list[_Footprint], ch: int, noise: float, sol) -> dict:
    """The fit's other figures: per footprint its stand-off, markers and patches; the solver's status."""
    return {
        "standoffs_mm": [f.fp.standoff_mm for f in fps],
        "markers_found": [f.markers for f in fps],
        "grey_patch": [round(float(f.grey[ch]), 4) for f in fps],
        "black_share": [round(float(f.black_share[ch]), 4) for f in fps],
        "bleed_fitted": card.many,
        "noise": round(noise, 5),
        "evaluations": int(sol.nfev),
        "status": str(sol.message),
    }


# ----------------------------------------------------------------------------- command


def profile_yaml(fit: CardFit, paint: str, photo: str, passes: float) -> str:
    """The spray profile file: the constants (the keys of ``spray.can``) and the fit's record."""
    import yaml

    can = fit.can.model_copy(
        update={
            "paint": paint or "unnamed",
            "card_standoff_mm": float(fit.info["standoffs_mm"][0]),
            "fit": {
                "photo": photo,
                "passes": passes,
                "standoffs_mm": fit.info["standoffs_mm"],
                "residual_rms": round(fit.residual_rms, 5),
                "feature_residual_rms": fit.feature_residuals,
                "paint_contrast": round(fit.contrast, 4),
                "channel": "RGB"[fit.channel],
                "wall_offsets_mm": [list(s) for s in fit.shifts_mm],
                "camera_blur_mm": round(fit.camera_blur_mm, 4),
                "photo_px_per_mm": round(fit.px_per_mm, 2),
                "bleed_fitted": fit.info["bleed_fitted"],
                "patch_tones": fit.patch_tones,
                "seconds": round(fit.seconds, 2),
            },
        }
    )
    data = can.model_dump(mode="json")
    for key in ("spread_k", "bleed_sigma_mm", "deposit_per_pass"):
        data[key] = round(float(data[key]), 5)
    head = (
        "# stencil_cad spray profile, measured from a photo of the sprayed calibration card.\n"
        "# Use it in a job config:  spray: {model: physical, profile: this_file.yaml}\n"
    )
    return head + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def calibrate(
    photo: Path,
    card: Path,
    out: Path,
    *,
    passes: float | None = None,
    distance_mm: float | None = None,
    speed_m_s: float | None = None,
    paint: str = "",
    force: bool = False,
) -> tuple[CardFit, str]:
    """`stencil-cad calibrate PHOTO --card card.json`: fit the can from the photo of the sprayed card and write the spray profile.

    Returns:
        ``(fit, report)``: the fit and the one-line report.

    Raises:
        UserError: Bad card file, unreadable photo (named reason), or an existing profile.
    """
    check_target(out, "spray profile", force=force)
    desc = parse_json(
        read_text(card, "card description", fix="write it with `stencil-cad card --out DIR`"), str(card)
    )
    try:
        layout = layout_from_description(desc)
    except ValueError as exc:
        raise UserError(f"{card}: {exc}") from None
    spray = desc.get("spray", {})
    n = float(passes if passes is not None else spray.get("passes", layout.passes))
    from ..config.spray import SprayConfig

    fields = SprayConfig.model_fields
    d = float(
        distance_mm
        if distance_mm is not None
        else spray.get("can_distance_mm", fields["can_distance_mm"].default)
    )
    v = float(
        speed_m_s if speed_m_s is not None else spray.get("pass_speed_m_s", fields["pass_speed_m_s"].default)
    )
    for name, val, lo, hi in (
        ("--passes", n, 0.1, 50),
        ("--distance-mm", d, *SprayConfig.field_range("can_distance_mm")),
        ("--speed", v, *SprayConfig.field_range("pass_speed_m_s")),
    ):
        if not lo <= val <= hi:
            raise UserError(f"{name} must be in [{lo:g}, {hi:g}], got {val:g}")
    rgb = read_photo(photo)
    # A coarse fit first (a quarter of the resolution, about a fifth of the time): a photo of another
    # card leaves the same residual-to-noise ratio there (3.2-8.2 against 1.0 on synthetic photos),
    # so it is refused in seconds, before the full fit.
    fit_card(rgb, layout, n, distance_mm=d, speed_m_s=v, ppm=FIT_PX_PER_MM / 4)
    fit = fit_card(rgb, layout, n, distance_mm=d, speed_m_s=v)
    text = profile_yaml(fit, paint, Path(photo).name, n)
    write_text_over(out, text, "spray profile", force=force)
    c = fit.can
    return fit, (
        f"stencil-cad: {out}: spread_k {c.spread_k:.4f}, bleed {c.bleed_sigma_mm:.3f} mm"
        f"{'' if fit.info['bleed_fitted'] else ' (kept: one stand-off)'}, deposit {c.deposit_per_pass:.4f} per pass "
        f"at {d:g} mm and {v:g} m/s; residual RMS {fit.residual_rms:.4f} "
        f"(window {fit.feature_residuals.get('window', float('nan')):.4f}, dots {fit.feature_residuals.get('single', float('nan')):.4f}, "
        f"patches {fit.feature_residuals.get('patch', float('nan')):.4f}); {fit.seconds:.1f} s"
    )
