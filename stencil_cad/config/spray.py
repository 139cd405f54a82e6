"""Config section `spray` (owned by the spray stage)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from pydantic import Field, field_validator, model_validator

from ..errors import ConfigError
from .base import StrictModel
from .process import Process
from .profiles import DEFAULT_KEY, profile_key

#: The nozzle height of a spray section outside a job, where no process is known (a job fills in its
#: process's, :attr:`stencil_cad.config.process.ProcessRecord.nozzle_height`).
DEFAULT_NOZZLE_HEIGHT = Process.sla.record.nozzle_height
#: The sweep speeds a layer's dose may ask for, as multiples of ``spray.pass_speed_m_s``: a hand that
#: sweeps at about 0.5 m/s keeps an even pace between about 0.3 and 0.75 m/s; slower drips sooner,
#: faster leaves gaps between the fan's overlapping passes.
SWEEP_PACE = (0.6, 1.5)


class Calibrate(str, enum.Enum):
    """How the calibrated tone curve picks the free spray parameter of each layer."""

    none = "none"
    dots = "dots"
    spray_time = "spray_time"


class SprayModel(str, enum.Enum):
    """Which spray model the simulator and the tone calibration use.

    What a model means for the settings is its :class:`ModelTerms` (:attr:`terms`, in
    :data:`MODEL_TERMS`); how it sprays is its class in :mod:`stencil_cad.simulate.models`.
    """

    paper = "paper"
    physical = "physical"

    @property
    def terms(self) -> ModelTerms:
        """What this model means for the settings: its row of :data:`MODEL_TERMS`."""
        return MODEL_TERMS[self]


@dataclass(frozen=True)
class ModelTerms:
    """What a spray model means for the settings, the run's figures and the maker's sheet.

    Attributes:
        amount_field: The ``spray`` field that holds a layer's base amount of paint.
        amount_unit: That amount's unit, in words.
        has_wall: The model sees the wall: a hole's blur follows the wall's stand-off and the
            plate's thickness shades it, so every spray needs the plate's geometry and a job may
            choose its stand-off for the picture.
        has_cans: The model sprays a can's constants (``spray.can``, a spray profile, the prior of
            cans), and its amount is passes of that can at a distance and a pace.
        light_plates: ``stipple.light_plates: auto`` gives a one-plate job light plates.
    """

    amount_field: str
    amount_unit: str
    has_wall: bool
    has_cans: bool
    light_plates: bool


#: Each spray model's terms: a new model is a member of :class:`SprayModel`, its row here and its
#: class in :mod:`stencil_cad.simulate.models`.
MODEL_TERMS: dict[SprayModel, ModelTerms] = {
    SprayModel.paper: ModelTerms(
        amount_field="spray_time",
        amount_unit="spray time",
        has_wall=False,
        has_cans=False,
        light_plates=False,
    ),
    SprayModel.physical: ModelTerms(
        amount_field="passes", amount_unit="passes", has_wall=True, has_cans=True, light_plates=True
    ),
}


class CanConstants(StrictModel):
    """What one can, cap and paint do under a stencil: the constants the calibration card measures.

    A spray profile file (``stencil-cad calibrate`` writes one) holds exactly these keys.
    """

    #: ``standoff_mm`` read as a wall's stand-off (``wall.standoff_mm``): the card's is a record.
    RENAMED: ClassVar[dict[str, str]] = {"standoff_mm": "card_standoff_mm"}
    WHERE: ClassVar[str] = "spray.can (or a spray profile)"

    spread_k: float = Field(
        0.12,
        ge=0.0,
        le=1.0,
        description=(
            "Angular spread of the spray, tan of its sigma: a plate held g mm off the surface blurs every "
            "hole by a Gaussian of sigma = spread_k * g mm (whatever the hole's size). Caps run from about "
            "0.03-0.10 (skinny) through 0.10-0.20 (standard fan tips) to 0.15-0.35 (fat); 0.12, a standard "
            "tip, is a prior, not a measurement: "
            "the card's photo measures it (its two stand-offs separate it from the bleed). Range [0, 1]."
        ),
    )
    bleed_sigma_mm: float = Field(
        0.25,
        ge=0.01,
        le=10.0,
        description=(
            "Spread in mm that the paint has even with no gap (wetting, bleeding under the plate, droplet "
            "size): sigma^2 = bleed_sigma_mm^2 + (spread_k * g)^2. 0.25 is a prior of the order of a spray "
            "droplet's wetted spot, not a measurement; the card's photo measures it. Range [0.01, 10]."
        ),
    )
    deposit_per_pass: float = Field(
        1.5,
        gt=0.0,
        le=20.0,
        description=(
            "Optical depth one pass leaves on open surface at distance_mm and speed_m_s: after n passes an "
            "open area has opacity 1 - exp(-n * deposit_per_pass). It decides how many passes a dark layer "
            "needs. 1.5 (78 % after one pass, 95 % after two) is a prior from the cans' own directions, which "
            "ask for two light coats for full cover at 20-30 cm; it is not measured under our plates. A maker's first card photo replaces it: expect it to move most "
            "with the paint (thin artist paints lower, high-cover paints higher) and the hand's speed. "
            "Range (0, 20]."
        ),
    )
    distance_mm: float = Field(
        200.0,
        ge=20.0,
        le=2000.0,
        description=(
            "Can distance from the plate in mm at which deposit_per_pass was measured. The deposit of a "
            "sweeping fan falls as 1 / distance. Range [20, 2000]."
        ),
    )
    speed_m_s: float = Field(
        0.5,
        ge=0.02,
        le=10.0,
        description=(
            "Sweep speed in m/s at which deposit_per_pass was measured; the deposit falls as 1 / speed. "
            "Range [0.02, 10]."
        ),
    )
    card_standoff_mm: float | None = Field(
        None,
        ge=0.0,
        le=300.0,
        description=(
            "Stand-off in mm of the card's wall the constants were measured with (formerly standoff_mm) (a record; the model carries "
            "them to other stand-offs). null: not measured (the defaults are priors from the literature)."
        ),
    )
    paint: str = Field(
        "unmeasured",
        max_length=200,
        description="Can, cap and paint these constants describe (free text, a record).",
    )
    fit: dict[str, Any] = Field(
        default_factory=dict,
        description="Figures of the photo fit that measured these constants (residual, photo, date): a record.",
    )


class SprayConfig(StrictModel):
    """Settings of the spray simulation and of the tone calibration.

    Two models (``model``). The paper's: a hole of radius r at p_i leaves the
    Gaussian N_i(p) = A exp(-|p - p_i|^2 / (2 sigma_i^2)) with
    sigma_i^2 = r^2 (1 + h) / 4, and the layer's opacity is
    I = 1 - prod_i (1 - min(N_i, 1)). The physical one works in what the maker
    controls (stand-off, can distance, passes; see
    :mod:`stencil_cad.simulate.physical`): dose E = n d sum_i T_i (disc(r_i) * G_sigma)(x - c_i),
    sigma^2 = sigma_0^2 + (k g)^2, opacity 1 - exp(-E).
    """

    model: SprayModel = Field(
        SprayModel.physical,
        description=(
            "Spray model. Choices: physical (the default, in the maker's units: every wall.standoff_mm gets "
            "its own blur, the can's distance and whole passes set the dose, the constants come from "
            "spray.can or a measured spray.profile; without a profile the holes are refined and scored for "
            "a prior of cans, see stencil_cad.simulate.cans), paper (Vavilala 2015, to reproduce the paper's "
            "setup: each hole a Gaussian of sigma = r sqrt(1 + h) / 2, amount spray_time, in model units; "
            "the wall's stand-off is not modelled)."
        ),
    )
    passes: float = Field(
        2.0,
        gt=0.0,
        le=50.0,
        description=(
            "Physical model: passes of the can over the stencil per layer, sweeping at can_distance_mm and "
            "pass_speed_m_s. The tone calibration (spray.calibrate: spray_time) chooses each layer's dose "
            "(in steps of spray.dose_step, sprayed as whole passes at a pace), starting here. Range (0, 50]."
        ),
    )
    max_passes: int = Field(
        8,
        ge=1,
        le=20,
        description=(
            "Physical model: the most whole passes any layer may ask for. Every layer is designed to reach "
            "its darkest tone within this many passes at can_distance_mm and pass_speed_m_s; where it "
            "cannot, the plate opens more area (larger and denser holes within the design rules) instead "
            "of asking for more paint, and the summary names the layer and its shortfall. A heavy coat "
            "under a lifted stencil runs and creeps: a few light passes, each let to flash off, are what "
            "a maker sprays. 8: a light paint's unmeasured can deposits 0.85 per pass (simulate.cans: white "
            "and yellow hide in three coats or more), and the bundled example's white layer asks for all 8 "
            "(S-CIELAB at 1 m 3.99 against 4.35 when held to 6). Range [1, 20]."
        ),
    )
    can_distance_mm: float = Field(
        200.0,
        ge=50.0,
        le=1000.0,
        description=(
            "Physical model: distance in mm from the can's nozzle to the plate while spraying (cans are held "
            "150-400 mm away). Range [50, 1000]."
        ),
    )
    pass_speed_m_s: float = Field(
        0.5,
        ge=0.05,
        le=5.0,
        description=(
            "Physical model: sweep speed of the can in m/s during a pass, the hand's usual pace. A layer whose "
            "dose falls between whole passes is swept a little faster or slower (spray.dose_step). "
            "Range [0.05, 5]."
        ),
    )
    dose_step: float = Field(
        0.25,
        gt=0.0,
        le=1.0,
        description=(
            "Physical model: finest step, in passes, of the dose the tone calibration gives a layer. The "
            "maker sprays it as whole passes at a sweep speed within 0.6-1.5 times pass_speed_m_s "
            "(2.5 passes' dose: 3 passes at 1.2 times the pace), so each layer gets the dose it was "
            "designed for, not the nearest whole pass (2 passes or 3 is a 50 % step). 1: whole passes "
            "at pass_speed_m_s. Range (0, 1]."
        ),
    )
    can: CanConstants = Field(
        default_factory=CanConstants,
        description=(
            "Physical model: the can's constants (spread, bleed, deposit per pass). Replaced by the file's "
            "values when spray.profile is set."
        ),
    )
    profile: Path | dict[str, Path] | None = Field(
        None,
        description=(
            "Physical model: a spray profile YAML written by `stencil-cad calibrate` from a photo of the "
            "sprayed calibration card (`stencil-cad card`); its constants replace spray.can. One file for "
            "every layer, or one per paint: a mapping from a layer to a file, keyed by the layer's number "
            "in spray order (1, 2, ...), its paint's hex code in quotes (\"#ff6900\"), its paint's name "
            "(the can's label in the can list or catalogue) or default (every layer no other key names; "
            'its constants replace spray.can), e.g. {1: black.yaml, "#ff6900": orange.yaml}. A layer '
            "no key names sprays with spray.can's unmeasured constants. A relative path is taken from the "
            "config file's folder. null: use spray.can for every layer."
        ),
    )
    layer_cans: dict[str, CanConstants] = Field(
        default_factory=dict,
        description=(
            "Physical model: the constants of each file of a spray.profile mapping but default's, by its "
            "key; filled from the files when the config is read (a record, so the resolved config says "
            "what each layer sprayed with). Written by hand it must agree with the files. {}: none."
        ),
    )

    spray_time: float = Field(
        1.0,
        gt=0.0,
        le=100.0,
        description=(
            "Paper model: spray time A, the peak paint density one hole deposits (dimensionless; 1 = a hole's centre just "
            "reaches full cover). Range (0, 100]. The tone calibration may choose it per layer "
            "(spray.calibrate: spray_time); this is then the starting value."
        ),
    )
    # null is read as "the process's best" (see the validator and JobConfig), so a validated
    # section always holds a number: the schema says null is allowed, the type says float.
    nozzle_height: float = Field(
        DEFAULT_NOZZLE_HEIGHT,
        ge=0.0,
        le=1000.0,
        json_schema_extra={"type": ["number", "null"], "default": None},
        description=(
            "Paper model: nozzle height h, dimensionless: the extra spread of the paint as a multiple of the "
            "hole's own spread. A hole of radius r sprays a Gaussian dot of sigma = r * sqrt(1 + h) / 2 "
            "(r^2 / 4 is the variance of a uniform disc, so h = 0 puts the paint exactly under the hole and "
            "the dot's variance grows linearly with h, i.e. with the nozzle's distance). To fit it to a real "
            "can, spray one test hole and measure the dot's full width at half maximum W: "
            "h = (W / (1.1774 r))^2 - 1. Range [0, 1000], or null: the height where soft stencils of "
            "stipple.process score best from 1 m, 30 for fdm, sla and laser (python -m benchmarks quality, "
            "S-CIELAB at 1 m at h 22 / 30 / 60: FDM astronaut 10.3 / 10.0 / 12.0, FDM coffee 6.3 / 6.2 / 7.2; "
            "SLA astronaut 7.4 / 6.8 / 6.9; laser holes are the size of SLA ones and take its value; rocket, "
            "a photo of large flat sky, scores best at 60). Hard mode sprays from hard.nozzle_height instead."
        ),
    )
    px_per_mm: float = Field(
        4.0,
        gt=0.1,
        le=40.0,
        description=(
            "Resolution of the simulation raster in pixels per mm. Range (0.1, 40]. The simulated picture "
            "and the scores are computed on this grid; the dots' sigma should span at least one pixel."
        ),
    )
    max_error: float = Field(
        1e-3,
        ge=1e-6,
        le=0.05,
        description=(
            "Largest absolute opacity error allowed for the fast spray path against the exact evaluation. "
            "Range [1e-6, 0.05]. Each dot is evaluated out to the distance where its tail, summed over its "
            "neighbours, falls below this."
        ),
    )
    calibrate: Calibrate = Field(
        Calibrate.spray_time,
        description=(
            "Used when stipple.tone is response. Choices: none (keep the paper's linear density, "
            "density proportional to opacity), dots (keep spray_time and derive the hole density and count "
            "from the spray response), spray_time (also choose each layer's spray time, from 1/64 to 8 times "
            "spray_time, that minimises the layer's predicted error in composite colour: each pixel's opacity "
            "error weighted by the colour change a full coat of the paint makes there)."
        ),
    )
    sweep_factors: tuple[float, ...] = Field(
        (0.5, 1.0, 2.0),
        min_length=1,
        max_length=8,
        description=(
            "Spray-time multipliers shown side by side in sweep.png (as in the paper's figure). "
            "1 to 8 values, each in (0, 20]."
        ),
    )
    mask_reference_radius_mm: float = Field(
        1.0,
        gt=0.0,
        le=20.0,
        description=(
            "Hard stencils: the hole radius in mm whose spray spread is applied to a cut-out's edge. A cut-out "
            "is sprayed as a field of tiny holes blurred by sigma = r_ref * sqrt(h) / 2, the part of the "
            "dot model's sigma that comes from the nozzle. Range (0, 20]."
        ),
    )

    @property
    def is_physical(self) -> bool:
        """True under the physical spray model.

        The package asks what a model does instead (:attr:`has_wall`, :attr:`has_cans`,
        :mod:`stencil_cad.simulate.models`); this stays for scripts that name the model.
        """
        return self.model == SprayModel.physical

    @property
    def terms(self) -> ModelTerms:
        """What the spray model means for these settings (:data:`MODEL_TERMS`)."""
        return MODEL_TERMS[self.model]

    @property
    def has_wall(self) -> bool:
        """Whether the spray model sees the wall (stand-off and plate thickness): :attr:`ModelTerms.has_wall`."""
        return self.terms.has_wall

    @property
    def has_cans(self) -> bool:
        """Whether the spray model sprays a can's constants in passes: :attr:`ModelTerms.has_cans`."""
        return self.terms.has_cans

    @property
    def is_measured(self) -> bool:
        """True when ``spray.can`` comes from a measured spray profile (one file, or a mapping's default).

        With a mapping, a layer's own settings (:meth:`for_profile_key`) say whether it is measured.
        """
        if isinstance(self.profile, dict):
            return DEFAULT_KEY in self.profile or bool(self.can.fit)
        return self.profile is not None or bool(self.can.fit)

    @property
    def profile_keys(self) -> list[str]:
        """The keys of a ``spray.profile`` mapping (empty for one file or none)."""
        return list(self.profile) if isinstance(self.profile, dict) else []

    def for_profile_key(self, key: str | None) -> SprayConfig:
        """The settings a layer named by ``key`` of a ``spray.profile`` mapping sprays with.

        Args:
            key: A key of the mapping, ``default``, or None (no key names the layer).

        Returns:
            These settings with that file's constants in ``can`` and that file alone as ``profile``
            (None: ``spray.can``, unmeasured); these settings themselves without a mapping.
        """
        if not isinstance(self.profile, dict):
            return self
        if key is None or key not in self.profile:
            return self.model_copy(update={"profile": None, "layer_cans": {}})
        if key != DEFAULT_KEY and key not in self.layer_cans:
            # The files are read with the config (config.io.load_config); a section built without
            # them must not pass spray.can's priors off as the measured can.
            raise ConfigError(
                f"spray.profile: the file of key {key!r} was not read (spray.layer_cans has no {key!r}): "
                "load the config with stencil_cad.config.io.load_config"
            )
        can = self.can if key == DEFAULT_KEY else self.layer_cans[key]
        return self.model_copy(update={"profile": self.profile[key], "can": can, "layer_cans": {}})

    def all_cans(self) -> list[CanConstants]:
        """Every can a layer may spray with: ``spray.can`` and each profile's constants."""
        return [self.can, *self.layer_cans.values()]

    @property
    def dose_per_pass(self) -> float:
        """Optical depth one pass leaves on open surface at the job's can distance and speed.

        ``beta (d_ref / d) (v_ref / v)``: ``can.deposit_per_pass`` carried from the distance and speed
        it was measured at to ``can_distance_mm`` and ``pass_speed_m_s`` (a sweeping fan's deposit
        falls as 1 / distance and 1 / speed).
        """
        c = self.can
        return (
            c.deposit_per_pass * (c.distance_mm / self.can_distance_mm) * (c.speed_m_s / self.pass_speed_m_s)
        )

    def doses(self) -> list[float]:
        """Every dose (in passes at ``pass_speed_m_s``) a layer may be given.

        Multiples of ``dose_step`` up to ``max_passes`` that some whole number of passes sprays at a pace
        in :data:`SWEEP_PACE`: below one pass, one quicker pass (0.75 at the default step: one pass at
        1.33 times the pace). A light plate's faint tones want less than a pass: on the quality
        benchmark's Hubble deep field (FDM) the dose 0.75 took the job from 2.999 to 2.934 S-CIELAB at
        1 m (0.508 to 0.497 times the hard stencil's).
        """
        n = int(round(self.max_passes / self.dose_step))
        out = [round(k * self.dose_step, 10) for k in range(1, n + 1)]
        return [d for d in out if d <= self.max_passes + 1e-9 and self.passes_and_speed(d) is not None]

    def passes_and_speed(self, dose: float) -> tuple[int, float] | None:
        """How the hand sprays ``dose`` (passes' worth at ``pass_speed_m_s``): ``(passes, speed in m/s)``.

        The whole passes nearest the dose whose speed ``pass_speed_m_s * passes / dose`` stays within
        :data:`SWEEP_PACE` of the usual pace (a pass's deposit falls as 1 / speed), at most
        ``max_passes``; None when none does (see :meth:`hand`).
        """
        lo, hi = SWEEP_PACE
        best: tuple[float, int] | None = None
        for n in range(1, self.max_passes + 1):
            pace = n / float(dose)
            if lo - 1e-9 <= pace <= hi + 1e-9 and (best is None or abs(n - dose) <= best[0]):
                best = (abs(n - dose), n)
        if best is None:
            return None
        n = best[1]
        return n, self.pass_speed_m_s * n / float(dose)

    def hand(self, dose: float) -> tuple[int, float]:
        """How the hand sprays ``dose``: :meth:`passes_and_speed`, or else the nearest whole passes.

        At the pace that sprays ``dose`` when no pace in :data:`SWEEP_PACE` does (a dose under one
        pass: one quicker pass).
        """
        got = self.passes_and_speed(dose)
        if got is not None:
            return got
        n = max(1, min(self.max_passes, round(float(dose))))
        return n, self.pass_speed_m_s * n / max(float(dose), 1e-9)

    def full_cover_passes(self, cover: float = 0.98) -> int:
        """The fewest whole passes (at most ``max_passes``) that cover ``cover`` of an open area.

        What a cut-out of a hard stencil is sprayed with under the physical model.
        """
        return max(1, min(self.max_passes, math.ceil(-math.log(1.0 - cover) / self.dose_per_pass)))

    @property
    def amount(self) -> float:
        """The base amount of paint per layer in the model's unit: passes (physical) or spray time A (paper)."""
        return float(getattr(self, self.terms.amount_field))

    @property
    def amount_cap(self) -> float:
        """Largest base amount the config accepts: ``passes``' or ``spray_time``'s upper bound."""
        for meta in type(self).model_fields[self.terms.amount_field].metadata:
            if getattr(meta, "le", None) is not None:
                return float(meta.le)
        return math.inf  # pragma: no cover - both fields are bounded

    @property
    def amount_unit(self) -> str:
        """``passes`` or ``spray time``."""
        return self.terms.amount_unit

    @field_validator("nozzle_height", mode="before")
    @classmethod
    def _nozzle_default(cls, v: Any) -> Any:
        # A job fills null in with its process's value (JobConfig); alone, the SLA/laser one.
        return DEFAULT_NOZZLE_HEIGHT if v is None else v

    @field_validator("profile", mode="before")
    @classmethod
    def _profile_keys(cls, v: Any) -> Any:
        if not isinstance(v, dict):
            return v
        if not v:
            raise ValueError("an empty mapping: give one file per layer (e.g. {1: black.yaml}) or null")
        out: dict[str, Any] = {}
        for key, path in v.items():
            k = profile_key(key)
            if k in out:
                raise ValueError(f"keys {key!r} and another key both read as {k!r}: keep one of them")
            if path is None or isinstance(path, (dict, list)):
                raise ValueError(f"key {key!r}: give the path of a spray profile file, got {path!r}")
            out[k] = path
        return out

    @field_validator("layer_cans", mode="before")
    @classmethod
    def _layer_can_keys(cls, v: Any) -> Any:
        return {profile_key(k): c for k, c in v.items()} if isinstance(v, dict) else v

    @model_validator(mode="after")
    def _layer_cans_have_files(self) -> SprayConfig:
        keys = set(self.profile_keys) - {DEFAULT_KEY}
        extra = [k for k in self.layer_cans if k not in keys]
        if extra:
            raise ValueError(
                f"layer_cans: key {extra[0]!r} has no file in spray.profile (layer_cans records the "
                "constants of spray.profile's files): remove it, or name its file in spray.profile"
            )
        return self

    @field_validator("sweep_factors")
    @classmethod
    def _factors_positive(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        for f in v:
            if not 0.0 < f <= 20.0:
                raise ValueError(f"each sweep factor must be in (0, 20], got {f}")
        return v
