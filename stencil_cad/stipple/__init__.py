"""Stippling: one layer's opacity into round holes, under the printable design rules.

:mod:`.relax` places the holes (weighted centroidal Voronoi relaxation from :mod:`.sampling`'s
start points) and :mod:`.rules` enforces and checks the hole floor, web, margin and keep-outs.
"""

from .made import drawn_dots, drawn_radii, made_dots
from .relax import (
    HEX_G,
    MAX_GRID_PX,
    OMEGA,
    PX_PER_DOT,
    auto_dot_count,
    bucket_size,
    cvt_energy,
    cvt_optimum,
    e_norm,
    lloyd,
    refine_factor,
    stipple_layer,
    tone_map,
    voronoi_pass,
)
from .rules import (
    CHECK_TOL_MM,
    NUDGE_SLACK_MM,
    DesignRules,
    DotRuleError,
    check_rules,
    enforce_rules,
    min_web,
    rule_violations,
)
from .sampling import importance_sample, start_sample, stratified_sample

__all__ = [
    "drawn_dots",
    "drawn_radii",
    "made_dots",
    "CHECK_TOL_MM",
    "HEX_G",
    "MAX_GRID_PX",
    "NUDGE_SLACK_MM",
    "OMEGA",
    "PX_PER_DOT",
    "DesignRules",
    "DotRuleError",
    "auto_dot_count",
    "bucket_size",
    "check_rules",
    "cvt_energy",
    "cvt_optimum",
    "e_norm",
    "enforce_rules",
    "importance_sample",
    "start_sample",
    "stratified_sample",
    "lloyd",
    "min_web",
    "refine_factor",
    "rule_violations",
    "stipple_layer",
    "tone_map",
    "voronoi_pass",
]
