"""The job config: one YAML file describes a whole job.

Each stage owns its section in a module of this package; :mod:`.job` holds the top
level and :mod:`.io` the loader that turns pydantic errors into one-line messages.
"""

from .base import StrictModel
from .cad import ExportConfig, PlateConfig, WallConfig
from .compute import ComputeConfig
from .decompose import DecomposeConfig
from .hard import HardConfig
from .job import JobConfig, Mode, SizeConfig, parse_overrides
from .paints import PaintsConfig
from .refine import RefineConfig
from .spray import SprayConfig
from .stipple import StippleConfig
from .view import ViewConfig

__all__ = [
    "ComputeConfig",
    "DecomposeConfig",
    "ExportConfig",
    "HardConfig",
    "JobConfig",
    "Mode",
    "PaintsConfig",
    "PlateConfig",
    "RefineConfig",
    "SizeConfig",
    "SprayConfig",
    "StippleConfig",
    "StrictModel",
    "ViewConfig",
    "WallConfig",
    "parse_overrides",
]
