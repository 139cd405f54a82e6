"""The dot CSV files (stencil_cad.exchange.dots_csv): round trip within the design rules, errors by line."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.exchange.dots_csv import DotFileError, dots_from_csv, dots_to_csv
from stencil_cad.model import DotSet
from stencil_cad.stipple.rules import DesignRules, check_rules, enforce_rules

RULES = DesignRules(hole_min_r_mm=1.0, web_mm=0.8, edge_margin_mm=3.0, width_mm=100.0, height_mm=80.0)


def test_csv_round_trip_keeps_rules():
    rng = np.random.default_rng(3)
    xy, r, _ = enforce_rules(rng.uniform(0, 100, (500, 2)), rng.uniform(1.0, 2.0, 500), RULES)
    text = dots_to_csv(DotSet(xy, r))
    assert text.splitlines()[0] == "x_mm,y_mm,r_mm"
    back = dots_from_csv(text)
    np.testing.assert_allclose(back.xy_mm, xy, atol=5e-5)
    np.testing.assert_allclose(back.r_mm, r, atol=5e-5)
    check_rules(back.xy_mm, back.r_mm, RULES)


def test_csv_empty_set():
    back = dots_from_csv(dots_to_csv(DotSet(np.zeros((0, 2)), np.zeros(0))))
    assert len(back) == 0 and back.xy_mm.shape == (0, 2)


@pytest.mark.parametrize(
    "text, needle",
    [
        ("", "empty"),
        ("x,y,r\n1,2,3\n", "line 1: header must be 'x_mm,y_mm,r_mm', got 'x,y,r'"),
        ("x_mm,y_mm,r_mm\n1,2,1\n1,2\n", "line 3: expected 3 values"),
        ("x_mm,y_mm,r_mm\n1,two,1\n", "line 2: y_mm is not a number: 'two'"),
        ("x_mm,y_mm,r_mm\n1,2,nan\n", "line 2: r_mm is not finite"),
        ("x_mm,y_mm,r_mm\n1,2,0.45\n", "line 2: r_mm must be ≥ 0.5 mm, got 0.45"),
    ],
)
def test_csv_errors(text, needle):
    with pytest.raises(DotFileError) as err:
        dots_from_csv(text)
    assert needle in str(err.value)


def test_csv_accepts_bom_blank_lines_and_spaces():
    ds = dots_from_csv("\ufeffx_mm, y_mm, r_mm\n\n 1.5, 2.5 ,0.5\n")
    np.testing.assert_array_equal(ds.xy_mm, [[1.5, 2.5]])
    np.testing.assert_array_equal(ds.r_mm, [0.5])


def test_windows_round_trip_and_bad_files_fail():
    from stencil_cad.exchange.dots_csv import windows_from_json, windows_to_json

    ring = np.array([[1.0, 2.0], [5.5, 2.0], [5.5, 7.25], [1.0, 7.25]])
    back = windows_from_json(windows_to_json([(ring, ())]))
    assert len(back) == 1 and back[0][1] == ()
    np.testing.assert_allclose(back[0][0], ring)
    for bad in ("{}", '{"windows": [[[0, 0], [1, 1]]]}', "not json"):
        with pytest.raises(DotFileError):
            windows_from_json(bad)
