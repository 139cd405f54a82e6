"""Every file name stencil_cad writes: the job's files, their stems and patterns, the scratch and studio files.

Names are built here and nowhere else (``tests/house`` fails on a file-name literal elsewhere):
a module that writes or reads a job's file asks this one for its name. Which names a command
may write for a given config is :mod:`stencil_cad.plan.names`, built from these.
Extensions alone (``".step"``) name formats, not files, and are used where formats are chosen.
"""

from __future__ import annotations

# The run record and the config.
MANIFEST = "manifest.json"
CONFIG_COPY = "config.yaml"
#: Where ``init`` writes the commented default config, unless told otherwise.
INIT_CONFIG = "stencil.yaml"
#: Where ``calibrate`` writes the fitted spray profile, unless told otherwise.
SPRAY_PROFILE_YAML = "spray_profile.yaml"

# What the stages write besides the per-layer files.
LAYERS_NPZ = "layers.npz"
#: The job's plan, saved beside the layers: what a stage command repeats the run from.
PLAN_JSON = "plan.json"
SPRAY_JSON = "spray.json"
SWATCH_PNG = "swatch.png"
COMPOSITE_PNG = "composite.png"
ENERGY_CSV = "energy.csv"
SIMULATED_PNG = "simulated.png"
PREVIEW_PNG = "preview.png"
SWEEP_PNG = "sweep.png"
SEGMENTATION_PNG = "segmentation.png"
MURAL_MAP_PNG = "mural_map.png"
INSTRUCTIONS = ("instructions.html", "instructions.pdf")
#: The input picture as the instruction sheet shows it (an image of the sheet, not a file of the job).
INPUT_PNG = "input.png"

# The calibration card.
CARD_JSON = "card.json"
CARD_SHEET_PNG = "card_sheet.png"
CARD_SHEET_PDF = "card_sheet.pdf"
CARD_PLATE_STEM = "card_plate"

#: The stem of a mural's post (:mod:`stencil_cad.mural.posts`; every post is the same part).
POST_STEM = "post"
#: The stem of the wall when there is one stand-off height.
WALL_STEM = "wall"


def part_file(stem: str, ext: str) -> str:
    """A part's file: its stem and a format's extension (``layer_01``, ``.step``: ``layer_01.step``)."""
    return stem + ext


def layer_stem(i: int) -> str:
    """Stem of layer ``i``'s files (0-based index, 1-based in the name)."""
    return f"layer_{i + 1:02d}"


def dots_name(i: int) -> str:
    """File name of layer ``i``'s dots (0-based index, 1-based in the name)."""
    return f"{layer_stem(i)}_dots.csv"


def windows_name(i: int) -> str:
    """File name of layer ``i``'s windows (a hybrid plate's cut-outs), written when it has any."""
    return f"{layer_stem(i)}_windows.json"


#: The dots files of every layer (a shell pattern).
DOTS_PATTERN = "layer_*_dots.csv"


def windows_beside(dots: str) -> str:
    """The windows file that goes with a dots file (``layer_01_dots.csv``: ``layer_01_windows.json``)."""
    return dots.replace("_dots.csv", "_windows.json")


def dots_png(stem: str) -> str:
    """A plate's preview of its holes (``layer_01_dots.png``)."""
    return f"{stem}_dots.png"


def cut_png(stem: str) -> str:
    """A hard stencil plate's preview of its cut-outs (``layer_01_cut.png``)."""
    return f"{stem}_cut.png"


def after_png(stem: str) -> str:
    """The simulated picture after a plate is sprayed (``layer_01_after.png``)."""
    return f"{stem}_after.png"


def opacity_png(stem: str) -> str:
    """A layer's opacity map (``layer_01_opacity.png``)."""
    return f"{stem}_opacity.png"


def step_name(i: int) -> str:
    """File name of the simulated picture after layer ``i`` (0-based)."""
    return after_png(layer_stem(i))


def wall_stems(heights: list[float]) -> list[str]:
    """File stems of the walls (``heights``: :meth:`~stencil_cad.config.WallConfig.heights`).

    ``wall`` for one stand-off height, ``wall_10mm`` … for several.
    """
    return [WALL_STEM] if len(heights) == 1 else [f"{WALL_STEM}_{h:g}mm" for h in heights]


def simulated_wall_name(stem: str) -> str:
    """The simulated picture through one of several walls (``simulated_wall_10mm.png``)."""
    return f"simulated_{stem}.png"


def card_stems(standoffs_mm: list[float]) -> list[str]:
    """File stems of the card's walls: ``card_wall_6mm`` … (one per stand-off)."""
    return [f"card_wall_{h:g}mm" for h in sorted(set(standoffs_mm))]


def tile_stem(tile_name: str, i: int) -> str:
    """Stem of a tile's layer files, e.g. ``tile_B3_layer_02`` (layer ``i`` 0-based)."""
    return f"tile_{tile_name}_{layer_stem(i)}"


def tile_wall_stems(tile_name: str, heights: list[float]) -> list[str]:
    """Stems of a tile's walls: ``tile_B3_wall`` or ``tile_B3_wall_10mm`` … for several heights."""
    return [f"tile_{tile_name}_{stem}" for stem in wall_stems(heights)]


#: The files each stage writes (shell patterns), for telling which files a re-run makes stale.
STAGE_FILES = {
    "stipple": ("layer_*_dots.csv", "layer_*_windows.json", "layer_*_dots.png", SPRAY_JSON, SWATCH_PNG),
    "build": ("layer_[0-9][0-9].*", "wall*.step", "wall*.stl", "tile_*", MURAL_MAP_PNG),
    "simulate": ("simulated*.png", PREVIEW_PNG, SWEEP_PNG, "layer_*_after.png"),
    "instructions": INSTRUCTIONS,
}

#: Files a whole run writes besides the ``layer_NN*`` and ``wall*`` files.
RUN_FILES = (
    CONFIG_COPY,
    LAYERS_NPZ,
    PLAN_JSON,
    SPRAY_JSON,
    MANIFEST,
    SWATCH_PNG,
    COMPOSITE_PNG,
    ENERGY_CSV,
    SIMULATED_PNG,
    PREVIEW_PNG,
    SWEEP_PNG,
    SEGMENTATION_PNG,
)
#: The patterns of a whole run's per-layer, wall and tile files.
RUN_PATTERNS = ("layer_*", "wall*", "tile_*", MURAL_MAP_PNG)
#: What ``decompose`` alone may write.
DECOMPOSE_FILES = (
    CONFIG_COPY,
    LAYERS_NPZ,
    PLAN_JSON,
    MANIFEST,
    SWATCH_PNG,
    COMPOSITE_PNG,
    ENERGY_CSV,
    "layer_*_opacity.png",
)

# Scratch files around a job (written in a temporary folder or renamed into place).


def partial_name(name: str) -> str:
    """The hidden name a file is written under before it is renamed into place."""
    return f".{name}.partial.3mf"


def ini_beside(name: str) -> str:
    """The full slicer settings saved beside a sliced file (``layer_01.gcode.ini``)."""
    return name + ".ini"


#: A plate turned on the bed for the slicer (in a temporary folder).
TURNED_STL = "turned.stl"


def slice_tile_name(i: int, j: int) -> str:
    """A big plate's tile handed to the slicer (``tile_0_1.stl``, in a temporary folder)."""
    return f"tile_{i}_{j}.stl"


# The studio's files around a job.
JOB_YAML = "job.yaml"
JOB_ZIP = "job.zip"


def numbered_profile_yaml(n: int) -> str:
    """The ``n``-th spray profile in a job's zip (``spray_profile_2.yaml``)."""
    return SPRAY_PROFILE_YAML.replace(".yaml", f"_{n}.yaml")


def job_zip_download(short_id: str) -> str:
    """The name a job's zip is downloaded under (``stencil-job-1a2b3c4d.zip``)."""
    return f"stencil-job-{short_id}.zip"


def profile_yaml(ident: str) -> str:
    """A kept spray profile in the studio's workspace."""
    return f"{ident}.yaml"


def profile_json(ident: str) -> str:
    """The card figures kept beside a spray profile in the studio's workspace."""
    return f"{ident}.json"


#: Every kept profile's figures (a shell pattern).
PROFILE_JSON_PATTERN = "*.json"


def upload_png(ident: str) -> str:
    """An uploaded picture in the studio's workspace, as PNG."""
    return f"{ident}.png"
