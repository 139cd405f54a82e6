"""Random YAML documents: the command line answers exit 0 or one line with exit 2, nothing else."""

from __future__ import annotations

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import stencil_cad.pipeline.run as pipeline_run
from stencil_cad.cli import main
from stencil_cad.config import JobConfig

# 120 documents through the command line: the full suite's (derandomized in CI), not the quick loop's.
pytestmark = pytest.mark.slow


def _keys(model, prefix=()):
    out = []
    for name, field in model.model_fields.items():
        out.append(prefix + (name,))
        ann = field.annotation
        if isinstance(ann, type) and hasattr(ann, "model_fields"):
            out.extend(_keys(ann, prefix + (name,)))
    return out


KEYS = _keys(JobConfig)
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**12), 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=30),
    st.sampled_from(["fdm", "sla", "laser", "calibrated", "engrave", "hard", "auto", "-1", "1e400", ".nan"]),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)


@st.composite
def config_documents(draw):
    """A mapping built from real config keys with random values, dumped as YAML."""
    doc: dict = {}
    for path in draw(st.lists(st.sampled_from(KEYS), max_size=6)):
        node = doc
        for key in path[:-1]:
            node = node.setdefault(key, {}) if isinstance(node.get(key, {}), dict) else {}
        node[path[-1]] = draw(values)
    return yaml.safe_dump(doc, allow_unicode=True)


yaml_noise = st.lists(
    st.sampled_from(
        list("abcdefgxyz_:-&*!|>'\"{}[],#%@` \n\t0123456789.\u00e9\x1e")
        + ["!!python/object:os.system", "<<: *a", "&a ", "size:", "\n  width_mm: ", "stipple:", "  dots: "]
    ),
    max_size=60,
).map("".join)


def _check(tmp_path, capsys, monkeypatch, text):
    monkeypatch.setattr(pipeline_run, "run_command", lambda *a, **k: (_ for _ in ()).throw(SystemExit(0)))
    cfg = tmp_path / "fuzz.yaml"
    cfg.write_text(text, encoding="utf-8")
    try:
        code = main(["run", str(cfg), "--out", str(tmp_path / "out"), "-q"])
    except SystemExit as exc:  # the config was accepted: the job itself is tested elsewhere
        code = exc.code
    err = capsys.readouterr().err
    assert code in (0, 2), err
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("stencil-cad: error: "), err
        assert len(lines[0]) < 800, lines[0]
    assert not (tmp_path / "out").exists()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=config_documents())
def test_random_config_documents(tmp_path, capsys, monkeypatch, text):
    _check(tmp_path, capsys, monkeypatch, text)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=yaml_noise)
def test_random_yaml_text(tmp_path, capsys, monkeypatch, text):
    _check(tmp_path, capsys, monkeypatch, text)
