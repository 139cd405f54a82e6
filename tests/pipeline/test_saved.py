"""What an earlier command saved, read back: a hybrid plate's windows come back with its holes."""

import numpy as np
import pytest

from stencil_cad.exchange.dots_csv import dots_to_csv, windows_to_json
from stencil_cad.model import DotSet
from stencil_cad.pipeline.saved import read_dots
from stencil_cad.plan.names import dots_name, windows_name


def test_read_dots_brings_back_the_windows(tmp_path):
    ring = np.array([[10.0, 10.0], [20.0, 10.0], [20.0, 20.0], [10.0, 20.0]])
    hybrid = DotSet(xy_mm=np.array([[5.0, 5.0]]), r_mm=np.array([0.5]), windows=((ring, ()),))
    plain = DotSet(xy_mm=np.array([[7.0, 7.0]]), r_mm=np.array([0.6]))
    for i, ds in enumerate((hybrid, plain)):
        (tmp_path / dots_name(i)).write_text(dots_to_csv(ds))
    (tmp_path / windows_name(0)).write_text(windows_to_json(hybrid.windows))
    back = read_dots(tmp_path, count=2)
    assert len(back[0].windows) == 1 and back[1].windows == ()
    np.testing.assert_allclose(back[0].windows[0][0], ring)
    np.testing.assert_allclose(back[0].xy_mm, hybrid.xy_mm)


def test_a_half_pass_dose_agrees_with_either_whole_number_of_passes(tmp_path):
    """The hand sprays 4.5 passes' dose as 4 slower passes or 5 quicker ones; 8 passes disagree."""
    import json

    from stencil_cad.errors import UserError
    from stencil_cad.pipeline import read_spray_times

    p = tmp_path / "spray.json"
    for passes in (4, 5):
        p.write_text(json.dumps({"spray_times": [3.5, 4.5], "order": [{"passes": 4}, {"passes": passes}]}))
        assert read_spray_times(p, 2, 100.0) == [3.5, 4.5]
    p.write_text(json.dumps({"spray_times": [3.5, 4.5], "order": [{"passes": 4}, {"passes": 8}]}))
    with pytest.raises(UserError, match=r"order\[1\]\.passes is 8 .*4 or 5 passes"):
        read_spray_times(p, 2, 100.0)
