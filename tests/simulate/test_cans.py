"""The prior of cans: what the simulation scores and what the refinement designs for."""

from __future__ import annotations

from stencil_cad.config import SprayConfig
from stencil_cad.simulate.cans import CAN_PRIOR, CAP_PRIOR, can_prior, layer_can_prior

PHYS = SprayConfig(model="physical")


def test_the_scoring_prior_varies_spread_deposit_and_bleed():
    cans = dict(can_prior(PHYS))
    assert list(cans) == [c.name for c in CAN_PRIOR] and cans["nominal"].can == PHYS.can
    # The scored caps span the published ranges: a skinny cap (0.03-0.10) and a fat one (0.15-0.35).
    assert {c.can.spread_k for c in cans.values()} == {0.05, 0.12, 0.25}
    deposits = sorted({round(c.can.deposit_per_pass, 4) for c in cans.values()})
    assert deposits == [round(1.5 * 0.85, 4), 1.5, round(1.5 * 1.15, 4)]


def test_the_refinement_prior_varies_the_cap_at_the_nominal_deposit():
    cans = layer_can_prior([PHYS, PHYS], CAP_PRIOR)
    assert [name for name, _ in cans] == ["nominal", "skinny cap", "fat cap"]
    assert all(sp.can.deposit_per_pass == PHYS.can.deposit_per_pass for _, per in cans for sp in per)
    spreads = [per[0].can.spread_k for _, per in cans]
    assert spreads == [PHYS.can.spread_k, 0.08, 0.16]
    bleeds = [per[0].can.bleed_sigma_mm for _, per in cans]
    assert bleeds[1] < bleeds[0] < bleeds[2]


def test_a_measured_can_or_the_paper_model_is_one_can():
    measured = PHYS.model_copy(update={"can": PHYS.can.model_copy(update={"fit": {"r": 1}})})
    assert can_prior(measured, CAP_PRIOR) == [("nominal", measured)]
    paper = SprayConfig(model="paper")
    assert layer_can_prior([paper], CAP_PRIOR) == [("nominal", [paper])]
    mixed = layer_can_prior([PHYS, measured], CAP_PRIOR)
    assert len(mixed) == 3 and all(per[1] is measured for _, per in mixed)
