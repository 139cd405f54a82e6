"""The post under a mural plate: one valid solid with the analytic volume, its files."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("build123d")

from stencil_cad.cad import post  # noqa: E402


def test_post_is_one_solid_with_its_analytic_volume(tmp_path):
    model = post.build_post(3.0, 10.0, 1.0, 0.6)
    check = post.check_post(model)
    assert check["n_solids"] == 1 and check["valid"]
    assert check["analytic_volume"] == pytest.approx(math.pi * (9.0 * 10.0 + 1.0 * 0.6), abs=1e-4)
    assert check["rel_error"] < 1e-6
    assert check["bbox"] == pytest.approx([-3.0, -3.0, 0.0, 3.0, 3.0, 10.6])
    post.post_step(model, tmp_path / "post.step")
    post.post_stl(model, tmp_path / "post.stl")
    assert (tmp_path / "post.step").read_text().startswith("ISO-10303-21")
    assert (tmp_path / "post.stl").stat().st_size > 84


@pytest.mark.parametrize(
    ("sizes", "match"),
    [
        ((3.0, 10.0, 3.0, 0.6), "thinner"),
        ((3.0, 0.0, 1.0, 0.6), "positive"),
        ((3.0, 10.0, 1.0, -1.0), "positive"),
    ],
)
def test_bad_post_sizes_are_refused(sizes, match):
    with pytest.raises(ValueError, match=match):
        post.build_post(*sizes)


def test_a_wrong_volume_fails_the_check():
    model = post.build_post(3.0, 10.0, 1.0, 0.6)
    wrong = post.PostModel(model.part, 3.0, 10.0, 1.0, 1.2)
    with pytest.raises(post.PostCheckError, match="analytic"):
        post.check_post(wrong)
