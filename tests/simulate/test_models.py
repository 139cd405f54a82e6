"""The spray models behind one interface: a third model is one class and one registry entry."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.config.spray import SprayConfig, SprayModel
from stencil_cad.model import DotSet, Layers
from stencil_cad.simulate import models, simulate, spray_opacity
from stencil_cad.simulate.physical import SprayGeometry


class FlatSprayer(models.Sprayer):
    """A toy model: every layer with holes sprays one flat opacity, its amount over four, capped at 1."""

    def opacity(self, xy_mm, r_mm, shape_hw, mm_per_px, cfg, amount, **kwargs) -> np.ndarray:
        """A flat field of ``amount / 4``."""
        return np.full(shape_hw, min(1.0, amount / 4.0))

    def blur_mm(self, r_mm, cfg, geometry) -> float:
        """No blur."""
        return 0.0

    def info(self, cfg, geometry) -> dict:
        """The toy's name."""
        return {"model": "flat"}


def _job():
    layers = Layers(
        primer=np.ones(3),
        colours=np.array([[0.0, 0.0, 0.0]]),
        alphas=np.full((1, 8, 12), 0.5),
        mm_per_px=0.5,
    )
    dots = DotSet(xy_mm=np.array([[2.0, 2.0]]), r_mm=np.array([0.8]))
    return layers, [dots]


def test_a_third_model_is_one_class_and_one_registry_entry(monkeypatch):
    # Registering the toy is all it takes: simulate, spray_opacity and the info dispatch to it.
    monkeypatch.setitem(models.SPRAYERS, "flat", FlatSprayer())
    cfg = SprayConfig(model="paper").model_copy(update={"model": "flat"})
    layers, dots = _job()
    res = simulate(layers, dots, cfg, grid_mm_per_px=0.5, spray_times=[2.0])
    assert np.all(res.alphas == 0.5)
    assert res.info["model"] == "flat"
    assert res.layer_rmse == (0.0,)
    assert np.all(spray_opacity(dots[0].xy_mm, dots[0].r_mm, (3, 4), 0.5, cfg, spray_time=1.0) == 0.25)


def test_an_unregistered_model_is_refused():
    cfg = SprayConfig(model="paper").model_copy(update={"model": "flat"})
    layers, dots = _job()
    with pytest.raises(KeyError):
        simulate(layers, dots, cfg, spray_times=[1.0])


@pytest.mark.parametrize("model", list(SprayModel))
def test_each_model_answers_the_simulators_questions(model):
    cfg = SprayConfig(model=model)
    geometry = SprayGeometry(standoff_mm=5.0, plate_thickness_mm=1.2) if cfg.has_wall else None
    s = models.sprayer(cfg)
    sigma, peak, *_, combine = s.hole_kernels(np.array([0.5, 1.0]), cfg, cfg.amount, geometry)
    assert sigma.shape == peak.shape == (2,) and combine in ("product", "exp")
    assert s.blur_mm(1.0, cfg, geometry) > 0.0
    assert 0.0 < s.full_coat(cfg, cfg.amount) <= 1.0
    assert s.amount_candidates(cfg)


def test_a_model_that_sees_the_wall_needs_the_plates_geometry():
    cfg = SprayConfig(model=SprayModel.physical)
    assert cfg.has_wall
    with pytest.raises(ValueError, match="geometry"):
        spray_opacity(np.zeros((1, 2)), np.array([1.0]), (4, 4), 0.5, cfg)
