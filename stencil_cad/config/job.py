"""The top level of the job config: size, mode, seed, and one section per stage."""

from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    Field,
    PrivateAttr,
    SerializerFunctionWrapHandler,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from ..errors import ConfigError
from . import profiles
from .base import StrictModel
from .bed import BED_DESCRIPTION, parse_bed, resolve_bed
from .cad import DEFAULT_THICKNESS_MM, ExportConfig, LabelMode, PlateConfig, Standoff, WallConfig
from .compute import ComputeConfig
from .decompose import DecomposeConfig
from .hard import HardConfig
from .outline import TILE_MARGIN_MM, OutlineConfig
from .paints import PaintsConfig
from .process import FDM_SINGLE_LAYER_MM, Method, Process
from .refine import RefineConfig
from .rules import DesignRules
from .spray import Calibrate, SprayConfig
from .stipple import StippleConfig
from .thickness import LABEL_FLOOR_MM, Thickness, fill_thickness, given_thickness
from .view import ViewConfig

#: The lowest stand-off a plate's sag limit follows (5 % of it, :mod:`.thickness`), mm.
SAG_STANDOFF_FLOOR_MM = 5.0
#: The wall's stand-off (mm) of hard stencils: low, so their cut-outs keep sharp edges.
HARD_STANDOFF_MM = 1.0


def _process_of(stipple) -> Process | None:
    """The process a raw stipple section asks for (fdm when it says none), or None if it is malformed."""
    if isinstance(stipple, StippleConfig):
        return stipple.process
    try:
        return Process((stipple or {}).get("process") or Process.fdm)
    except (AttributeError, TypeError, ValueError):
        return None


class Mode(str, enum.Enum):
    """Which kind of stencil to make."""

    soft = "soft"
    hard = "hard"


#: Largest picture side in mm (a 50 m wall).
MAX_SIZE_MM = 50_000.0


class SizeConfig(StrictModel):
    """Physical size of the picture area on the stencil."""

    width_mm: float = Field(
        150.0,
        gt=10.0,
        le=MAX_SIZE_MM,
        description=(
            "Width of the picture area in mm. Range (10, 50000]. The plate adds its margin around it; "
            "a picture larger than the bed becomes a mural of tiles."
        ),
    )
    height_mm: float | None = Field(
        None,
        gt=10.0,
        le=MAX_SIZE_MM,
        description=(
            "Height of the picture area in mm, or null to follow the image's aspect ratio. "
            "When both are set and the aspect differs, the image is centre-cropped to fit."
        ),
    )
    px_per_mm: Annotated[float, Field(gt=0.1, le=20.0)] | Literal["auto"] = Field(
        2.0,
        description=(
            "Working resolution in pixels per mm for decomposition and stippling. Range (0.1, 20], or auto. "
            "A number: the image must have at least half this many pixels per mm of picture (it is never "
            "upscaled by more than 2x), and the simulation runs at spray.px_per_mm. auto: the grids follow "
            "what the holes can show: working pixels of a third of the hole pitch (coarser if "
            "the eye cannot see finer at view.distance_m), simulation pixels of half the smallest dot's "
            "spray sigma, and any image with one pixel per hole pitch will do (a 512 px photo makes a 1.6 m "
            "FDM mural)."
        ),
    )


class JobConfig(StrictModel):
    """A whole stencil job."""

    name: str = Field(
        "stencil",
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9_.\- ]+$",
        description="Job name, used in labels and the manifest. Letters, digits, space, '_', '-', '.'.",
    )
    image: Path | None = Field(
        None,
        description=(
            "Input image (PNG, JPEG, TIFF, BMP, WebP; RGB, RGBA, grey, 8 or 16 bit). A relative path "
            "is taken from the config file's folder. null means the bundled example image."
        ),
    )
    mode: Mode = Field(
        Mode.soft,
        description="Stencil kind. Choices: soft (stippled continuous-tone layers), hard (flat-colour cut stencils).",
    )
    seed: int = Field(0, ge=0, description="Random seed; the same config and seed give the same dots.")
    size: SizeConfig = Field(default_factory=SizeConfig, description="Physical size of the picture area.")
    decompose: DecomposeConfig = Field(
        default_factory=DecomposeConfig, description="Soft layer decomposition."
    )
    stipple: StippleConfig = Field(
        default_factory=StippleConfig, description="Stippling and hole design rules."
    )
    refine: RefineConfig = Field(
        default_factory=RefineConfig, description="Refinement of the holes against the spray model."
    )
    plate: PlateConfig = Field(default_factory=PlateConfig, description="The stencil plate.")
    wall: WallConfig = Field(default_factory=WallConfig, description="The interlocking wall.")
    spray: SprayConfig = Field(default_factory=SprayConfig, description="Spray simulation.")
    view: ViewConfig = Field(default_factory=ViewConfig, description="Viewing distance of the picture.")
    hard: HardConfig = Field(default_factory=HardConfig, description="Hard-stencil mode.")
    export: ExportConfig = Field(default_factory=ExportConfig, description="Output files.")
    paints: PaintsConfig = Field(
        default_factory=PaintsConfig, description="The maker's cans and the paint estimate."
    )
    compute: ComputeConfig = Field(
        default_factory=ComputeConfig,
        description="Where the work runs: this process, a local Dask cluster or a remote one.",
    )

    bed: str | tuple[float, float] | None = Field(None, description=BED_DESCRIPTION)

    #: The stand-off in mm the job chose for its picture (:meth:`with_standoff`), or None.
    _standoff_chosen: float | None = PrivateAttr(None)

    @field_validator("bed", mode="before")
    @classmethod
    def _bed(cls, value):
        return parse_bed(value)

    @model_validator(mode="before")
    @classmethod
    def _fill_by_process(cls, data):
        """Keys left out (or null) that take the best value of the job's process and mode.

        ``spray.nozzle_height`` and ``export.dxf_kerf_mm``, from the process's record
        (:class:`~stencil_cad.config.process.ProcessRecord`). A section given as a model object, or a key given a value, is
        kept as given. ``wall.standoff_mm`` stays null: :attr:`standoff` says what the job uses.
        """
        if not isinstance(data, dict):
            return data
        process = _process_of(data.get("stipple"))
        if process is None:
            return data  # the stipple section's own validation names what is wrong
        fills = {
            ("spray", "nozzle_height"): process.record.nozzle_height,
            ("export", "dxf_kerf_mm"): process.record.dxf_kerf_mm,
        }
        for (section, key), value in fills.items():
            raw = data.get(section) or {}
            if isinstance(raw, dict) and raw.get(key) is None:
                data = {**data, section: {**raw, key: value}}
        return data

    def unfilled_data(self) -> dict[str, Any]:
        """The config's data as the maker gave it, the stand-off a dump lists (:meth:`_listed_standoff`) null again.

        What a changed config is parsed from (``--image``, ``--bed``, ``hard``, the API's overrides),
        so that the job decides again for the change what the maker left null: the stand-off, and
        the label, the tiles' margin, the plate's thickness and the one-layer web, which stay null in
        a parsed config and which the plan fills in (:func:`stencil_cad.plan.plan.planned`).
        """
        data = self.model_dump(mode="json")
        if self.wall.standoff_mm is None:
            data["wall"]["standoff_mm"] = None
        return data

    @model_serializer(mode="wrap")
    def _listed_standoff(self, handler: SerializerFunctionWrapHandler):
        """A dump is the resolved config (the saved config, the manifest): it lists the stand-off used.

        So a stage command that reads the saved config repeats the run's walls.
        """
        data = handler(self)
        wall = data.get("wall") if isinstance(data, dict) else None
        if isinstance(wall, dict) and "standoff_mm" in wall:
            wall["standoff_mm"] = list(self.standoff.listed_mm)
        return data

    @property
    def standoff(self) -> Standoff:
        """The wall's stand-off the job uses: the one accessor (``wall.standoff_mm`` is what the maker set).

        The one the job chose for its picture (:meth:`with_standoff`); else the maker's
        ``wall.standoff_mm``; else the process's (its record's ``standoff_mm``; :data:`HARD_STANDOFF_MM`
        for hard stencils).
        """
        if self._standoff_chosen is not None:
            return Standoff((self._standoff_chosen,), "job")
        if self.wall.standoff_mm is not None:
            return Standoff(tuple(self.wall.standoff_mm), "maker")
        g = HARD_STANDOFF_MM if self.mode == Mode.hard else self.stipple.process.record.standoff_mm
        return Standoff((g,), "default")

    @property
    def chooses_standoff(self) -> bool:
        """Whether the job chooses its wall's stand-off for the picture: left null, soft, a spray model that sees the wall."""
        return self.wall.standoff_mm is None and self.mode == Mode.soft and self.spray.has_wall

    def with_standoff(self, standoff_mm: float) -> JobConfig:
        """This config with the stand-off the job chose, in mm (:attr:`standoff`); ``wall.standoff_mm`` is kept.

        Raises:
            ValueError: The stand-off is outside ``wall.standoff_mm``'s range, [0.5, 300] mm.
        """
        g = float(standoff_mm)
        if not 0.5 <= g <= 300.0:
            raise ValueError(f"wall.standoff_mm: a stand-off must be in [0.5, 300] mm, got {g:g}")
        cfg = self.model_copy()
        cfg._standoff_chosen = g
        return cfg

    @property
    def fills_thickness(self) -> bool:
        """Whether the job fills the plate's thickness in: ``plate.thickness_mm`` null, no plate template.

        A plate template keeps its own ``THICKNESS_MM`` unless the config gives one.
        """
        return self.plate.thickness_mm is None and self.plate.template is None

    @property
    def refined_max_radius_mm(self) -> float:
        """The largest radius a refined hole may grow to, mm: ``refine.max_radius_factor`` times the hole floor, or the stippler's largest when larger.

        The one place it is computed: the refinement's settings, a mural tile's refinement halo and
        the plates' tone response read it.
        """
        st = self.stipple
        return max(self.refine.max_radius_factor * st.hole_floor_mm, st.sizes.max_radius_mm)

    def design_rules(self, width_mm: float, height_mm: float, keepouts: Sequence = ()) -> DesignRules:
        """The job's hole design rules over a picture area (see :meth:`StippleConfig.design_rules`)."""
        return self.stipple.design_rules(width_mm, height_mm, keepouts)

    @property
    def chooses_spray_time(self) -> bool:
        """Whether each layer gets its own spray time: response tone and ``spray.calibrate: spray_time``."""
        return self.stipple.tone_from_response and self.spray.calibrate == Calibrate.spray_time

    def layer_spray(self, number: int, hex_code: str, name: str | None = None) -> SprayConfig:
        """The spray settings layer ``number`` sprays with: its own profile's constants (``spray.profile``).

        Args:
            number: The layer's number in spray order, from 1.
            hex_code: Its paint as ``#rrggbb``.
            name: Its paint's name (the can's label), or None.

        Returns:
            ``spray`` itself with one profile file or none; with a mapping, ``spray`` with the
            constants of the file whose key names the layer (:mod:`.profiles`) and that file as
            ``profile``, or ``spray.can`` and no profile when no key does.

        Raises:
            ConfigError: Two keys name the layer.
        """
        if not self.spray.profile_keys:
            return self.spray
        return self.spray.for_profile_key(self.layer_profile_key(number, hex_code, name))

    def layer_profile_key(self, number: int, hex_code: str, name: str | None = None) -> str | None:
        """The key of the ``spray.profile`` mapping that names layer ``number`` (see :meth:`layer_spray`).

        None without a mapping, or when no key (not even ``default``) names the layer.

        Raises:
            ConfigError: Two keys name the layer.
        """
        try:
            return profiles.layer_key(self.spray.profile_keys, number, hex_code, name)
        except ValueError as exc:
            raise ConfigError(f"spray.profile: {exc}") from None

    def check_profile_keys(self, hexes: Sequence[str], names: Mapping[str, str] | None = None) -> None:
        """Refuse a ``spray.profile`` mapping with a key that names no layer of the job.

        Args:
            hexes: Each layer's paint as ``#rrggbb``, in spray order.
            names: ``{hex: paint name}`` of the paints the job has names for.

        Raises:
            ConfigError: Naming the key, the job's layers and the fix.
        """
        bad = profiles.unmatched_keys(self.spray.profile_keys, hexes, names)
        if not bad:
            return
        names = names or {}
        have = ", ".join(
            f"{i + 1} {h}" + (f" ({names[h]})" if names.get(h) else "") for i, h in enumerate(hexes)
        )
        raise ConfigError(
            f"spray.profile: key {bad[0]!r} names no layer of this job (its layers: {have or 'none'}): "
            "key each file by one of these layer numbers, hex codes or paint names, or by default"
        )

    @model_validator(mode="after")
    def _cross_checks(self) -> JobConfig:
        # What the job will fill in for null, as the config alone can tell (the plan fits the
        # thickness again to the plates it tiles, and checks the wall again then).
        thickness = job_thickness(self).thickness_mm
        self.wall.check_plate(with_margin(self).plate.outline, thickness)
        if self.plate.label is None or self.plate.thickness_mm is None:
            try:
                self.plate.check_label(job_label(self), thickness)
            except ValueError as exc:
                raise ValueError(f"plate: {exc}") from None
        numbers = [int(k) for k in self.spray.profile_keys if k.isdigit()]
        if self.mode == Mode.soft and numbers and max(numbers) > self.decompose.layers:
            raise ValueError(
                f"spray.profile: key {max(numbers)} names layer {max(numbers)}, but the job has "
                f"decompose.layers {self.decompose.layers}: key the file by a layer from 1 to "
                f"{self.decompose.layers}, or raise decompose.layers"
            )
        return self


def soft_mural(mode: Mode, size: SizeConfig, bed: str | tuple[float, float] | None) -> bool:
    """Whether a job is soft and its picture wider or taller than the bed's longer side (tiled whatever its margins)."""
    found = resolve_bed(bed)
    if mode != Mode.soft or found is None:
        return False
    return max(size.width_mm, size.height_mm or 0.0) > max(found.x_mm, found.y_mm)


def job_label(cfg: JobConfig) -> LabelMode:
    """The label ``cfg``'s plates carry: ``plate.label`` as given, or for null the one its job fills in.

    Raised on a soft FDM mural's plates (an extruding process), engraved otherwise. An engraving
    needs a floor under it, so an engraved plate prints in two layers at least; a raised label lets a
    mural's plates on posts be one 0.3 mm layer (:mod:`.thickness`). On the 600 x 400 mm coffee mural
    (3 layers, 3 m, ``--bed prusa_mk4``) that took the plates from 113.0 to 72.4 printer-hours and from
    1.97 to 1.52 kg of PLA per m² by PrusaSlicer's estimate, at S-CIELAB 1.86 against 1.69 at 3 m
    (``STENCIL_BENCH_COST_EVERY=3 python -m benchmarks printed --case mural600``). The plan fills it in
    (:func:`stencil_cad.plan.plan.labelled`); the config keeps null.
    """
    if cfg.plate.label is not None:
        return cfg.plate.label
    extrudes = cfg.stipple.process.record.method is Method.extrude
    return LabelMode.emboss if extrudes and soft_mural(cfg.mode, cfg.size, cfg.bed) else LabelMode.engrave


def job_margin(cfg: JobConfig) -> float:
    """The solid border ``cfg``'s plates take, mm: ``plate.outline.margin_mm`` as given, or the one its job fills in for null.

    A picture wider or taller than the bed's longer side is tiled whatever its margins (:func:`soft_mural`);
    its plates take :data:`~stencil_cad.config.outline.TILE_MARGIN_MM`. Anything else, or a margin the
    rest of the outline or the wall cannot take (a larger corner radius, label gap or wall opening),
    takes a plate's (:attr:`OutlineConfig.border_mm`).
    """
    outline = cfg.plate.outline
    if outline.margin_mm is not None or not soft_mural(cfg.mode, cfg.size, cfg.bed):
        return outline.border_mm
    try:
        tile = OutlineConfig.model_validate({**outline.model_dump(), "margin_mm": TILE_MARGIN_MM})
        cfg.wall.check_plate(tile, float("inf"))
    except (ValidationError, ValueError):
        return outline.border_mm
    return TILE_MARGIN_MM


def with_margin(cfg: JobConfig) -> JobConfig:
    """``cfg`` with ``plate.outline.margin_mm`` left null filled in (:func:`job_margin`); the same config when given."""
    outline = cfg.plate.outline
    if outline.margin_mm is not None:
        return cfg
    filled = outline.model_copy(update={"margin_mm": job_margin(cfg)})
    return cfg.model_copy(update={"plate": cfg.plate.model_copy(update={"outline": filled})})


def guessed_side_mm(cfg: JobConfig) -> float:
    """The plate's longest side as the config alone knows it, mm: what it checks a filled-in thickness at.

    The picture's sides (its width for both when ``size.height_mm`` follows the image, which is read
    later) plus the margins (:func:`job_margin`), at most the bed's longer side (a mural's tiles fit
    the bed). The plan fills the thickness in for the plates it tiles (:func:`job_thickness`).
    """
    size = cfg.size
    side = max(size.width_mm, size.height_mm or size.width_mm) + 2.0 * job_margin(cfg)
    bed = resolve_bed(cfg.bed)
    return side if bed is None else min(side, max(bed.x_mm, bed.y_mm))


def job_thickness(
    cfg: JobConfig, side_mm: float | None = None, standoff_mm: float | None = None
) -> Thickness:
    """The plate's thickness and why: ``plate.thickness_mm`` as given, or the one its job fills in for null.

    For null (:attr:`JobConfig.fills_thickness`) the process's thinnest flat plate (:mod:`.thickness`)
    for plates of longest side ``side_mm`` (None: :func:`guessed_side_mm`), thick enough for the label
    its job uses (:func:`job_label`). A plate template's thickness is its own ``THICKNESS_MM``.

    Args:
        cfg: The config.
        side_mm: The longest side of the plates the job tiles, mm, or None.
        standoff_mm: The wall the plates sit in when the job chose one lower than the process's (the
            sag limit is a share of it); None: the process's stand-off.
    """
    plate = cfg.plate
    if plate.thickness_mm is not None:
        return given_thickness(plate.thickness_mm)
    if plate.template is not None:
        return Thickness(DEFAULT_THICKNESS_MM, 0.0, 0.0, "the plate template's THICKNESS_MM")
    side = guessed_side_mm(cfg) if side_mm is None else side_mm
    return _thickness_for(cfg.stipple.process, side, plate, standoff_mm, job_label(cfg))


def job_web(st: StippleConfig, thickness_mm: float) -> float | None:
    """``stipple.web_mm`` as given, or for null the web of a plate ``thickness_mm`` thick (None: the process's).

    A plate printed in one layer (at most one FDM layer thick) is all first layer, which needs a wider
    web than the process's preset (its record's ``one_layer_web_mm``).
    """
    if st.web_mm is not None:
        return st.web_mm
    one_layer = thickness_mm <= FDM_SINGLE_LAYER_MM + 1e-9
    web = st.process.record.one_layer_web_mm if one_layer else None
    return None if web is None or web <= st.process.record.web_mm else web


def with_thickness(cfg: JobConfig, thickness: Thickness, web_left: bool | None = None) -> JobConfig:
    """``cfg`` with its plate ``thickness`` (:func:`job_thickness`) and the web that follows it (:func:`job_web`).

    ``web_left``: whether the maker left ``stipple.web_mm`` null (None: whether ``cfg`` does), so a web
    filled in for a thickness follows it when it is chosen again. A plate template's fields the
    maker did not set stay unset (the template keeps its own, :func:`stencil_cad.cad.template.config_overrides`).

    Raises:
        ValueError: The wall cannot take the plate (``wall.pocket_depth_mm``).
    """
    plate = cfg.plate
    if plate.thickness_mm != thickness.thickness_mm:
        values = {**dict(plate), "thickness_mm": thickness.thickness_mm}
        plate = PlateConfig.model_construct(_fields_set=set(plate.model_fields_set), **values)
        cfg.wall.check_plate(plate.outline, thickness.thickness_mm)
    st = cfg.stipple
    left = st.web_mm is None if web_left is None else web_left
    web = job_web(st.model_copy(update={"web_mm": None}) if left else st, thickness.thickness_mm)
    if web != st.web_mm:
        st = st.model_copy(update={"web_mm": web})
    if plate is cfg.plate and st is cfg.stipple:
        return cfg
    return cfg.model_copy(update={"plate": plate, "stipple": st})


def filled(cfg: JobConfig, side_mm: float | None = None) -> tuple[JobConfig, Thickness]:
    """``cfg`` with the tiles' margin, the plate's thickness and the web left null filled in, and the thickness's why.

    The thickness for plates of longest side ``side_mm`` (None: as the config alone knows it,
    :func:`guessed_side_mm`). ``plate.label`` stays as it is (the plan fills it in). The plan calls it
    (:func:`stencil_cad.plan.plan.planned`), and a mural's cost for the plates it tiles.
    """
    cfg = with_margin(cfg)
    thickness = job_thickness(cfg, side_mm)
    return with_thickness(cfg, thickness), thickness


def _thickness_for(
    process: Process,
    side_mm: float,
    plate: PlateConfig,
    standoff_mm: float | None = None,
    label: LabelMode | None = None,
) -> Thickness:
    """The filled-in thickness of ``plate`` (the floor of its label, or of ``label`` its job fills in) for its process, longest side and stand-off."""
    label = plate.label if label is None else label
    floor = plate.label_depth_mm + LABEL_FLOOR_MM if label is LabelMode.engrave else 0.0
    g = process.record.standoff_mm
    if standoff_mm is not None:
        # Under SAG_STANDOFF_FLOOR_MM the blur is mostly the paint's bleed, and a window sprayed from a
        # wall a millimetre high only sharpens where the plate sags onto the surface.
        g = min(max(standoff_mm, SAG_STANDOFF_FLOOR_MM), g)
    return fill_thickness(process, side_mm, g, floor)


def parse_overrides(
    cfg: JobConfig,
    image: Path | None = None,
    seed: int | None = None,
    hard: bool = False,
    bed: str | tuple[float, float] | None = None,
) -> JobConfig:
    """Apply command-line overrides, validating them like config values.

    Args:
        cfg: The loaded config.
        image: ``--image`` path, or None.
        seed: ``--seed``, or None.
        hard: The `hard` command forces ``mode: hard``.
        bed: ``--bed`` (a preset name or ``(x_mm, y_mm)``), or None.

    Returns:
        A new validated config.
    """
    from .io import parse_config

    data = cfg.unfilled_data()
    if image is not None:
        data["image"] = str(image)
    if seed is not None:
        data["seed"] = seed
    if hard:
        if cfg.mode != Mode.hard and cfg.standoff.listed_mm == (cfg.stipple.process.record.standoff_mm,):
            # The soft stencil's default wall: hard mode fills in its own (a user who wrote exactly
            # this height for a soft job gets the hard one too).
            data["wall"]["standoff_mm"] = None
        data["mode"] = Mode.hard.value
    if bed is not None:
        data["bed"] = list(bed) if isinstance(bed, tuple) else bed
    return parse_config(data, source="command line")
