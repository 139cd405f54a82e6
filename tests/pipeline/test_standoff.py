"""The wall's stand-off chosen for the picture when the config leaves it to the job."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.config.job import STANDOFF_BY_PROCESS, parse_overrides
from stencil_cad.model import Layers, Picture
from stencil_cad.mural import TileGrid
from stencil_cad.pipeline.standoff import WINDOW_SHARE, choose_standoff, window_share
from stencil_cad.record import Run

_SLA = {"stipple": {"process": "sla", "tone": "calibrated"}, "spray": {"calibrate": "spray_time"}}


def _cfg(**extra):
    return parse_config({**_SLA, "size": {"width_mm": 60.0, "px_per_mm": 2.0}, **extra}, source="test")


def test_only_a_stand_off_left_null_is_chosen():
    cfg = _cfg()
    assert cfg.chooses_standoff and cfg.wall.standoff_mm == [STANDOFF_BY_PROCESS[cfg.stipple.process]]
    assert not _cfg(wall={"standoff_mm": [10.0]}).chooses_standoff
    assert not _cfg(mode="hard").chooses_standoff
    assert not _cfg(spray={"model": "paper"}).chooses_standoff
    # The command line's overrides keep it left to the job; a chosen one keeps the mark.
    assert parse_overrides(cfg, seed=5).chooses_standoff
    low = cfg.with_standoff(4.0)
    assert low.wall.standoff_mm == [4.0] and low.chooses_standoff
    assert low.plate.thickness_mm == cfg.plate.thickness_mm


def _flat_layers(w_px: int = 120) -> tuple[Picture, Layers]:
    """A red disc and a blue bar on white, every paint solid (a flat-colour logo)."""
    yy, xx = np.mgrid[0:w_px, 0:w_px].astype(np.float64) / w_px
    red = (np.hypot(yy - 0.4, xx - 0.4) < 0.3).astype(np.float64)
    blue = ((yy > 0.78) & (yy < 0.92) & (xx > 0.1) & (xx < 0.9)).astype(np.float64)
    colours = np.array([[0.85, 0.1, 0.12], [0.05, 0.2, 0.6]])
    layers = Layers(primer=np.ones(3), colours=colours, alphas=np.stack([red, blue]), mm_per_px=0.5)
    return Picture(rgb=np.clip(layers.composite(), 0.0, 1.0), mm_per_px=0.5, source="test"), layers


def test_a_photo_keeps_the_process_stand_off_without_trials():
    rng = np.random.default_rng(1)
    smooth = np.clip(
        0.5 + 0.4 * np.sin(np.linspace(0, 6, 120))[None, :] + rng.normal(0, 0.05, (120, 120)), 0, 1
    )
    layers = Layers(
        primer=np.ones(3), colours=np.array([[0.1, 0.1, 0.1]]), alphas=smooth[None], mm_per_px=0.5
    )
    pic = Picture(rgb=np.clip(layers.composite(), 0.0, 1.0), mm_per_px=0.5, source="test")
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    assert window_share(run.cfg, layers, TileGrid.whole(60.0, 60.0), (60.0, 60.0)) < WINDOW_SHARE
    cfg = choose_standoff(run, layers, (60.0, 60.0), pic)
    assert cfg.wall.standoff_mm == [10.0] and run.figures.standoff is not None and run.figures.standoff.trials == {}


def test_flat_colour_art_sprays_from_lower_down():
    pic, layers = _flat_layers()
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    assert window_share(run.cfg, layers, TileGrid.whole(60.0, 60.0), (60.0, 60.0)) > 0.8
    cfg = choose_standoff(run, layers, (60.0, 60.0), pic)
    fig = run.figures.standoff
    assert fig is not None and set(fig.trials) == {"1", "4", "10"}
    # The windows' edges stay sharp low down: the trials say so, and the job takes the best.
    assert fig.trials["10"] > min(fig.trials["1"], fig.trials["4"])
    assert cfg.wall.standoff_mm == [fig.standoff_mm] and fig.standoff_mm < 10.0
    assert run.cfg is cfg and cfg.chooses_standoff


@pytest.mark.parametrize(
    "extra", [{"wall": {"standoff_mm": [10.0]}}, {"stipple": {**_SLA["stipple"], "windows": "off"}}]
)
def test_a_given_stand_off_or_no_windows_is_kept(extra):
    pic, layers = _flat_layers()
    run = Run(cfg=_cfg(**extra), out=None)  # type: ignore[arg-type]
    assert choose_standoff(run, layers, (60.0, 60.0), pic).wall.standoff_mm == [10.0]
