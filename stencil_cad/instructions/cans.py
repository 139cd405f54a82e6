"""What each layer's can was, in words: the spray profile it used and whether it was measured.

Read from the manifest's ``spray_profiles`` (one row per layer, see
:func:`stencil_cad.plan.profiles.layer_sprays`); the summary and the sheet say the same.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..figures import LayerProfile

__all__ = ["layer_can", "unmeasured_warning", "uses_profiles"]

#: What a maker does to measure a can ({paints}: which paints).
MEASURE = (
    "spray the calibration card (stencil-cad card) with {paints}, photograph it, run "
    "stencil-cad calibrate and key each profile to its layer in spray.profile"
)


def uses_profiles(rows: Sequence[LayerProfile] | None) -> bool:
    """Whether any layer sprays with a spray profile file."""
    return any(r.profile for r in rows or [])


def layer_can(row: LayerProfile) -> str:
    """One layer's can in words: ``profile black.yaml (measured: Montana Black)`` or ``spray.can, not measured``."""
    paint = str(row.paint or "")
    named = f": {paint}" if paint and paint != "unmeasured" else ""
    if row.profile:
        state = "measured" if row.measured else "not measured"
        return f"profile {row.profile} ({state}{named})"
    return "spray.can (measured" + named + ")" if row.measured else "spray.can, not measured"


def _numbers(ks: Sequence[int]) -> str:
    return ("layer " if len(ks) == 1 else "layers ") + ", ".join(str(k) for k in ks)


def unmeasured_warning(rows: Sequence[LayerProfile] | None) -> str | None:
    """The warning for the layers that spray with unmeasured can constants, or None when every one is measured."""
    rows = list(rows or [])
    bad = [r.layer for r in rows if not r.measured]
    if not bad:
        return None
    whole = len(bad) == len(rows)
    verb = "sprays" if len(bad) == 1 else "spray"
    who = "Every layer sprays" if whole else f"{_numbers(bad).capitalize()} {verb}"
    # A paint's light and dark plates are two layers of one paint.
    paints = len({r.hex for r in rows if not r.measured})
    these = "your cans" if whole else ("that paint" if paints == 1 else "those paints")
    each = {True: "each of the paints", False: "each of those paints"}[whole] if paints > 1 else "that paint"
    each = "the paint" if whole and paints == 1 else each
    return (
        f"{who} with can constants nobody measured (the priors of spray.can): the simulated picture and "
        f"the passes are a guess for {these}. To know, {MEASURE.format(paints=each)}."
    )
