"""One spray profile per paint: the keys of spray.profile, their resolution per layer, and bad keys."""

from __future__ import annotations

import pytest
import yaml

from stencil_cad.config import profiles
from stencil_cad.config.io import load_config
from stencil_cad.config.job import parse_overrides
from stencil_cad.errors import ConfigError


def _profile(path, **over):
    data = {"spread_k": 0.08, "bleed_sigma_mm": 0.4, "deposit_per_pass": 2.5, "paint": "black test"}
    data.update(over)
    path.write_text(yaml.safe_dump(data))
    return path


def _job(tmp_path, profile: str, extra: str = ""):
    path = tmp_path / "job.yaml"
    path.write_text(f"spray:\n  profile: {profile}\n{extra}")
    return load_config(path)


@pytest.mark.parametrize(
    ("key", "want"),
    [
        (1, "1"),
        ("2", "2"),
        ("#FF6900", "#ff6900"),
        ("Default", "default"),
        (" Montana Black ", "Montana Black"),
    ],
)
def test_keys_are_normalised(key, want):
    assert profiles.profile_key(key) == want


@pytest.mark.parametrize(
    ("key", "says"),
    [(0, "numbered from 1"), ("#ff69", "six hex digits"), (1.5, "float"), (True, "bool"), ("", "empty key")],
)
def test_bad_keys_name_the_key_and_the_fix(key, says):
    with pytest.raises(ValueError, match=says) as err:
        profiles.profile_key(key)
    assert "layer number" in str(err.value)


def test_each_layer_takes_its_own_key_then_default():
    keys = ["1", "#ff6900", "montana blue", "default"]
    assert profiles.layer_key(keys, 1, "#000000") == "1"
    assert profiles.layer_key(keys, 2, "#FF6900") == "#ff6900"
    assert profiles.layer_key(keys, 3, "#0000ff", "Montana Blue") == "montana blue"
    assert profiles.layer_key(keys, 4, "#00ff00", "green") == "default"
    assert profiles.layer_key(["1"], 2, "#00ff00") is None
    with pytest.raises(ValueError, match="both name layer 1"):
        profiles.layer_key(["1", "#000000"], 1, "#000000")
    assert profiles.unmatched_keys(keys, ["#000000", "#ff6900"]) == ["montana blue"]


def test_a_mapping_loads_one_can_per_key(tmp_path):
    _profile(tmp_path / "black.yaml", fit={"residual": 0.01})
    _profile(tmp_path / "orange.yaml", deposit_per_pass=0.9, paint="orange test")
    cfg = _job(tmp_path, '{1: black.yaml, "#FF6900": orange.yaml}')
    assert set(cfg.spray.profile) == {"1", "#ff6900"}
    assert cfg.spray.layer_cans["#ff6900"].deposit_per_pass == 0.9
    assert not cfg.spray.is_measured  # spray.can (layers no key names) stays the unmeasured prior
    one = cfg.layer_spray(1, "#000000")
    assert one.can.deposit_per_pass == 2.5 and one.is_measured and one.profile == tmp_path / "black.yaml"
    two = cfg.layer_spray(2, "#ff6900")
    assert two.can.deposit_per_pass == 0.9 and two.is_measured
    three = cfg.layer_spray(3, "#123456")
    assert three.can == cfg.spray.can and three.profile is None and not three.is_measured
    # The resolved config survives the command line's round trip (the constants are a record).
    assert parse_overrides(cfg, seed=3).spray.layer_cans == cfg.spray.layer_cans


def test_one_file_and_no_file_give_the_spray_section_itself(tmp_path):
    _profile(tmp_path / "can.yaml")
    cfg = _job(tmp_path, "can.yaml")
    assert cfg.layer_spray(2, "#ff6900") is cfg.spray and cfg.spray.is_measured
    plain = load_config(_write(tmp_path / "plain.yaml", "name: plain\n"))
    assert plain.layer_spray(1, "#000000") is plain.spray and plain.spray.layer_cans == {}


def test_default_key_fills_spray_can(tmp_path):
    _profile(tmp_path / "all.yaml", deposit_per_pass=3.0)
    _profile(tmp_path / "black.yaml")
    cfg = _job(tmp_path, "{default: all.yaml, 1: black.yaml}")
    assert cfg.spray.can.deposit_per_pass == 3.0 and cfg.spray.is_measured
    assert cfg.layer_spray(2, "#ffffff").can.deposit_per_pass == 3.0
    assert cfg.layer_spray(1, "#ffffff").can.deposit_per_pass == 2.5


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("profile", "extra", "says"),
    [
        ("{0: black.yaml}", "", "key 0: layers are numbered from 1"),
        ('{"#ff69": black.yaml}', "", "'#ff69' is not a hex code"),
        ("{}", "", "an empty mapping"),
        ("{9: black.yaml}", "", "key 9 names layer 9, but the job has decompose.layers 4"),
        ("{1: gone.yaml}", "", "key '1': spray profile not found"),
        ("{1: black.yaml, '01': black.yaml}", "", "both read as '1'"),
        ("{1: [a, b]}", "", "give the path of a spray profile file"),
        ("{1: black.yaml}", "  layer_cans:\n    2: {spread_k: 0.1}\n", "key '2' has no file"),
        ("{1: black.yaml}", "  layer_cans:\n    1: {spread_k: 0.3}\n", "key '1' differs from its file"),
    ],
)
def test_bad_mappings_fail_with_the_key_and_the_fix(tmp_path, profile, extra, says):
    _profile(tmp_path / "black.yaml")
    with pytest.raises(ConfigError, match=says) as err:
        _job(tmp_path, profile, extra)
    assert "spray" in str(err.value)


def test_a_key_naming_no_layer_is_refused_with_the_layers(tmp_path):
    _profile(tmp_path / "black.yaml")
    cfg = _job(tmp_path, '{"#ff6900": black.yaml}')
    cfg.check_profile_keys(["#000000", "#ff6900"])
    with pytest.raises(ConfigError, match=r"'#ff6900' names no layer .*1 #000000, 2 #123456 \(blue\)"):
        cfg.check_profile_keys(["#000000", "#123456"], {"#123456": "blue"})
    both = _job(tmp_path, '{1: black.yaml, "#000000": black.yaml}')
    with pytest.raises(ConfigError, match="both name layer 1"):
        both.layer_spray(1, "#000000")


def test_a_mapping_whose_files_were_not_read_is_refused():
    from stencil_cad.config import io as cfg_io

    cfg = cfg_io.parse_config({"spray": {"profile": {1: "black.yaml"}}}, "test")
    with pytest.raises(ConfigError, match="file of key '1' was not read"):
        cfg.layer_spray(1, "#000000")
    assert cfg.layer_spray(2, "#ffffff").profile is None
