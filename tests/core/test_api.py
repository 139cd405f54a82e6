"""The public Python API: configs from files, mappings and overrides; jobs with progress and cancel; previews."""

import pytest

from stencil_cad import api
from stencil_cad.errors import ConfigError
from stencil_cad.pipeline.preview import PreviewCache, decomposition_key, holes_key

SMALL = {"size": {"width_mm": 40.0}, "decompose": {"layers": 2}}


def small_example(layers: int = 2):
    """The bundled example at 40 mm from a mapping that leaves the stand-off to the job, as the studio's does."""
    import yaml

    from stencil_cad.imaging import example_config_path

    data = yaml.safe_load(example_config_path().read_text(encoding="utf-8"))
    data.pop("image")
    cfg = api.load_config(
        {**data, "size": {**data["size"], "width_mm": 40.0}, "decompose": {"layers": layers}}
    )
    assert cfg.chooses_standoff
    return cfg


def test_a_config_from_the_example_a_mapping_and_overrides():
    example = api.load_config(None)
    assert example.name == "example" and example.decompose.layers == 4
    cfg = api.load_config(None, overrides=SMALL)
    assert (cfg.size.width_mm, cfg.decompose.layers, cfg.stipple.process.value) == (40.0, 2, "fdm")
    assert api.load_config({"decompose": {"layers": 3}}).decompose.layers == 3
    with pytest.raises(ConfigError, match="decompose.layers"):
        api.load_config(None, overrides={"decompose": {"layers": 0}})
    with pytest.raises(ValueError, match="command must be one of"):
        api.run(cfg, "nowhere", command="paint")


def test_overrides_keep_what_the_config_left_to_the_job():
    """A config changed through the API fills in again what it filled in: the wall stays the job's to choose."""
    cfg = api.load_config()
    assert cfg.chooses_standoff
    changed = api.load_config(cfg, overrides={"decompose": {"layers": 3}})
    assert changed.chooses_standoff and changed.wall.standoff_mm is None
    fixed = api.load_config(cfg, overrides={"wall": {"standoff_mm": [8.0]}})
    assert not fixed.chooses_standoff and fixed.standoff.design_mm == 8.0


def test_the_decomposition_is_keyed_on_what_it_reads():
    cfg = api.load_config(None)
    key = decomposition_key(cfg)
    assert decomposition_key(api.load_config(None, overrides={"view": {"distance_m": 3.0}})) == key
    assert decomposition_key(api.load_config(None, overrides={"decompose": {"layers": 3}})) != key
    assert decomposition_key(api.load_config(None, overrides={"size": {"width_mm": 120.0}})) != key
    # The holes do not depend on the refinement, but do on the process.
    holes = holes_key(cfg, key)
    assert holes_key(api.load_config(None, overrides={"refine": {"iterations": 5}}), key) == holes
    assert holes_key(api.load_config(None, overrides={"stipple": {"process": "sla"}}), key) != holes


def test_the_cache_is_bounded_least_recently_used_first():
    cache = PreviewCache(entries=2)
    for k in "abc":
        cache.put(cache.layers, k, k)
        if k == "b":
            assert cache.get(cache.layers, "a") == "a"  # a is used again: b goes first
    assert list(cache.layers) == ["a", "c"] and cache.get(cache.layers, "b") is None


def test_a_second_preview_reuses_the_decomposition_and_holes():
    cfg = api.load_config(None, overrides=SMALL)
    cache = api.preview_cache()
    first = list(api.previews(cfg, cache))
    assert [p.level for p in first] == ["coarse", "stippled", "refined", "designed"] and first[-1].final
    # The first preview's quick decomposition at half the resolution, then the job's.
    assert len(cache.layers) == 2 and len(cache.designs) == 1 and 1 <= len(cache.holes) <= 2
    assert first[0].sprayed.shape == first[-1].sprayed.shape
    again = list(api.previews(api.load_config(cfg, overrides={"view": {"distance_m": 2.0}}), cache))
    assert [p.level for p in again] == ["coarse", "stippled", "refined", "designed"]
    assert len(cache.layers) == 2
    assert again[1].holes == first[1].holes and again[-1].distance_m == 2.0
    assert first[-1].sprayed.shape == first[-1].reference.shape and first[-1].sprayed.max() <= 1.0
    # The last level's range over the can prior (no can measured): the nominal can's score is in it.
    lo, hi = first[-1].scielab_range
    assert (
        first[-1].scielab_by_can["nominal"] == first[-1].scielab and lo <= first[-1].scielab <= hi and lo < hi
    )
    assert first[1].scielab_by_can is None and first[-1].figures()["scielab_range"] == [
        round(lo, 3),
        round(hi, 3),
    ]


def test_the_last_preview_is_of_the_plate_design_the_job_chooses(monkeypatch):
    from stencil_cad.pipeline import standoff
    from stencil_cad.plan.plan import designed
    from stencil_cad.plan.results import Designed

    seen = []

    def choose(run, plan, layers, picture):
        seen.append(plan.cfg)
        return Designed(designed(plan, "off", 14.0))

    monkeypatch.setattr(standoff, "stage_standoff", choose)
    cfg = small_example()
    cache = api.preview_cache()
    shown = list(api.previews(cfg, cache))
    # Before the trials the previews start at the prior: with light plates, 5 mm below the process's 10 mm.
    assert [(p.level, p.standoff_mm, p.designed, p.final) for p in shown] == [
        ("coarse", 5.0, False, False),
        ("stippled", 5.0, False, False),
        ("refined", 5.0, False, False),
        ("designed", 14.0, True, True),
    ]
    assert shown[-1].windows == "off" and shown[-1].final
    # The trials ran on the job's own config (its grid and refinement), not the preview's.
    assert (
        seen[0].spray.px_per_mm == cfg.spray.px_per_mm and seen[0].refine.iterations == cfg.refine.iterations
    )
    # The design is kept: the same settings again run no trials, and every level shows the job's design.
    again = list(api.previews(cfg, cache))
    assert [(p.standoff_mm, p.windows, p.designed) for p in again] == [(14.0, "off", True)] * 4
    assert len(seen) == 1
    # Other paints (another decomposition): the trials run again, the previews before them start at
    # the design last chosen for the same picture, process and spray.
    other = list(api.previews(small_example(layers=3), cache))
    assert [(p.level, p.standoff_mm, p.designed) for p in other][1:3] == [
        ("stippled", 14.0, False),
        ("refined", 14.0, False),
    ]
    assert len(seen) == 2
    # The process's stand-off fixed (the windows still the job's): its own trials, not the design
    # chosen where the stand-off was left to the job.
    ten = list(api.previews(api.load_config(cfg, overrides={"wall": {"standoff_mm": [10.0]}}), cache))
    assert [p.standoff_mm for p in ten[:3]] == [10.0] * 3 and len(seen) == 3
    # A config that fixes the design (its stand-off and no windows) runs none either.
    fixed = api.load_config(cfg, overrides={"wall": {"standoff_mm": [12.0]}, "stipple": {"windows": "off"}})
    last = list(api.previews(fixed, cache))[-1]
    assert (last.level, last.standoff_mm, last.designed, len(seen)) == ("refined", 12.0, False, 3)


def test_the_prior_design_is_lower_with_light_plates():
    from stencil_cad.pipeline.standoff import prior_design

    cfg = small_example()
    assert prior_design(cfg) == ("auto", 5.0)
    from stencil_cad.config.stipple import LightPlates

    one_plate = cfg.model_copy(
        update={"stipple": cfg.stipple.model_copy(update={"light_plates": LightPlates.off})}
    )
    assert one_plate.chooses_standoff and prior_design(one_plate) == ("auto", 10.0)
    fixed = api.load_config(cfg, overrides={"wall": {"standoff_mm": [12.0]}})
    assert prior_design(fixed) == ("auto", 12.0)


def test_a_preview_stops_when_cancelled():
    token = api.CancelToken()
    got = api.previews(api.load_config(None, overrides=SMALL), cancel=token)
    assert next(got).level == "coarse"
    token.cancel()
    with pytest.raises(api.Cancelled):
        next(got)


@pytest.mark.slow
def test_a_job_reports_its_stages_and_a_cancelled_one_leaves_nothing(tmp_path):
    cfg = api.load_config(None, overrides=SMALL)
    seen = []
    result = api.run(cfg, tmp_path / "job", progress=lambda event, stage: seen.append((event, stage)))
    assert seen[:2] == [("start", "load"), ("done", "load")]
    assert ("done", "simulate") in seen and ("done", "build") in seen
    assert result.simulated().shape[2] == 3 and result.figures.simulate.scielab > 0
    assert all(p.parent == tmp_path / "job" for p in result.files) and "total" in result.times
    token = api.CancelToken()

    def cancel_at_stipple(event, stage):
        if (event, stage) == ("start", "stipple"):
            token.cancel()

    with pytest.raises(api.Cancelled):
        api.run(cfg, tmp_path / "cancelled", progress=cancel_at_stipple, cancel=token)
    assert not (tmp_path / "cancelled").exists() or list((tmp_path / "cancelled").iterdir()) == []
