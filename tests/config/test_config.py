from pathlib import Path

import pytest

from stencil_cad.config import JobConfig
from stencil_cad.config.io import default_yaml, json_schema, load_config, parse_config
from stencil_cad.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


def test_default_yaml_is_the_shipped_template():
    shipped = (ROOT / "templates" / "default.yaml").read_text(encoding="utf-8")
    assert shipped == default_yaml(), (
        "regenerate with: python -m stencil_cad init templates/default.yaml --force"
    )


def test_default_yaml_round_trips(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text(default_yaml())
    assert load_config(p) == JobConfig()


def _walk(model_cls, prefix=""):
    from pydantic import BaseModel

    for name, field in model_cls.model_fields.items():
        yield prefix + name, field
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            yield from _walk(ann, prefix + name + ".")


def test_every_key_is_documented():
    undocumented = [k for k, f in _walk(JobConfig) if not (f.description and len(f.description) > 10)]
    assert undocumented == []


def test_unknown_key_names_the_dotted_path():
    with pytest.raises(ConfigError) as e:
        parse_config({"size": {"widht_mm": 100}})
    assert "size.widht_mm" in str(e.value)
    assert "unknown key" in str(e.value)


def test_out_of_range_names_path_value_and_limit():
    with pytest.raises(ConfigError) as e:
        parse_config({"size": {"width_mm": -5}})
    msg = str(e.value)
    assert "size.width_mm" in msg and "-5" in msg and "greater than 10" in msg


def test_wrong_type():
    with pytest.raises(ConfigError) as e:
        parse_config({"seed": "abc"})
    assert "seed" in str(e.value) and "'abc'" in str(e.value)


def test_bad_choice_lists_choices():
    with pytest.raises(ConfigError) as e:
        parse_config({"mode": "medium"})
    assert "mode" in str(e.value) and "'soft'" in str(e.value) and "'hard'" in str(e.value)


def test_empty_config_file(tmp_path):
    p = tmp_path / "empty.yaml"
    p.write_text("# nothing\n")
    with pytest.raises(ConfigError, match="empty"):
        load_config(p)


def test_yaml_syntax_error_has_line(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("name: a\nsize:\n  width_mm: [1, 2\n")
    with pytest.raises(ConfigError, match=r"YAML syntax error at line \d+"):
        load_config(p)


def test_not_a_mapping(tmp_path):
    p = tmp_path / "list.yaml"
    p.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="mapping"):
        load_config(p)


def test_missing_config(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "nope.yaml")


def test_relative_image_is_taken_from_config_folder(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("image: pics/a.png\n")
    assert load_config(p).image == tmp_path / "pics" / "a.png"


def test_config_is_frozen():
    cfg = JobConfig()
    from pydantic import ValidationError

    with pytest.raises(ValidationError):
        cfg.seed = 3


def test_json_schema_forbids_extra_keys():
    schema = json_schema()
    assert schema["additionalProperties"] is False
    assert "size" in schema["properties"]


def test_booleans_are_not_numbers():
    with pytest.raises(ConfigError, match=r"size\.width_mm: must be a number"):
        parse_config({"size": {"width_mm": True}})


@pytest.mark.parametrize(
    ("data", "want"),
    [
        ({}, 30.0),
        ({"stipple": {"process": "fdm"}}, 30.0),
        ({"stipple": {"process": "sla"}}, 30.0),
        ({"stipple": {"process": "laser"}}, 30.0),
        ({"stipple": {"process": "sla"}, "spray": {"nozzle_height": None, "spray_time": 2.0}}, 30.0),
        ({"stipple": {"process": "sla"}, "spray": {"nozzle_height": 7.0}}, 7.0),
    ],
)
def test_nozzle_height_defaults_to_the_process_best(data, want):
    cfg = parse_config(data, source="test")
    assert cfg.spray.nozzle_height == want


def test_nozzle_height_is_filled_in_from_the_process(monkeypatch):
    """Each process gets its own entry of the table, and a dumped config keeps what it resolved to."""
    from dataclasses import replace

    from stencil_cad.config.process import PROCESSES, Process

    monkeypatch.setitem(PROCESSES, Process.fdm, replace(PROCESSES[Process.fdm], nozzle_height=22.0))
    fdm = parse_config({"stipple": {"process": "fdm"}}, source="test")
    assert fdm.spray.nozzle_height == 22.0
    assert parse_config({"stipple": {"process": "laser"}}, source="test").spray.nozzle_height == 30.0
    dumped = fdm.model_dump(mode="json")
    dumped["stipple"]["process"] = "sla"
    assert parse_config(dumped, source="test").spray.nozzle_height == 22.0


def test_template_leaves_the_nozzle_height_to_the_process(tmp_path):
    import yaml

    data = yaml.safe_load(default_yaml())
    assert data["spray"]["nozzle_height"] is None
    data["stipple"]["process"] = "sla"
    p = tmp_path / "c.yaml"
    p.write_text(yaml.safe_dump(data))
    assert load_config(p).spray.nozzle_height == 30.0


def test_a_renamed_key_is_read_with_a_message_for_one_release(caplog):
    import logging

    from stencil_cad.config.spray import CanConstants

    with caplog.at_level(logging.WARNING, logger="stencil_cad.config.base"):
        can = CanConstants.model_validate({"standoff_mm": 10.0})
    assert can.card_standoff_mm == 10.0
    assert "spray.can (or a spray profile): standoff_mm is now called card_standoff_mm" in caplog.text
    with pytest.raises(ValueError, match="standoff_mm is the old name of card_standoff_mm"):
        CanConstants.model_validate({"standoff_mm": 10.0, "card_standoff_mm": 12.0})


def test_the_old_tone_name_is_read_with_a_message_for_one_release(caplog):
    """``stipple.tone: calibrated`` (a word the photo-fit command also uses) is now ``response``."""
    import logging

    from stencil_cad.config import StippleConfig
    from stencil_cad.config.stipple import Tone

    with caplog.at_level(logging.WARNING, logger="stencil_cad.config.stipple"):
        st = StippleConfig.model_validate({"tone": "calibrated"})
    assert st.tone == Tone.response and st.tone_from_response
    assert "stipple.tone: calibrated is now called response" in caplog.text
    assert StippleConfig().tone == Tone.response
    with pytest.raises(ValueError, match="tone"):
        StippleConfig.model_validate({"tone": "measured"})


def test_hole_sizes_are_resolved_in_one_place():
    from stencil_cad.config.io import parse_config
    from stencil_cad.config.stipple import Process

    st = parse_config({"stipple": {"process": "sla"}}, source="test").stipple
    sizes = st.sizes
    record = Process.sla.record
    assert sizes.radius_mm == st.hole_floor_mm and sizes.max_radius_mm == sizes.radius_mm  # one size
    assert (sizes.web_mm, sizes.edge_margin_mm, sizes.hole_offset_mm) == (
        record.web_mm,
        record.edge_margin_mm,
        record.hole_offset_mm,
    )
    assert sizes.window_web_mm == sizes.web_mm + max(sizes.hole_offset_mm, 0.0)
    assert st.densest_pitch_mm == st.auto_spacing_factor * (2.0 * sizes.max_radius_mm + sizes.web_mm)
    given = parse_config(
        {"stipple": {"radius_mm": 0.8, "max_radius_mm": 1.1, "web_mm": 0.9, "variable_radius": True}},
        source="test",
    )
    assert (given.stipple.sizes.radius_mm, given.stipple.sizes.max_radius_mm) == (0.8, 1.1)
    assert given.stipple.sizes.web_mm == 0.9
    # The refinement's largest radius: the factor times the floor, or the stippler's largest when larger.
    assert given.refined_max_radius_mm == max(
        given.refine.max_radius_factor * given.stipple.hole_floor_mm, 1.1
    )
