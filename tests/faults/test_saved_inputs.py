"""What a stage command reads back from a run's folder: stale dots, oversized dots files, spray.json.

Each case used to go through silently (plates from the earlier picture's dots, a spray order
that disagrees with the plates) or took minutes and gigabytes before it refused.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_checks import SMALL
from cli_checks import no_leftovers as _no_leftovers
from cli_checks import one_line_error as _one_line_error
from cli_checks import run_cli as _run
from cli_checks import snapshot as _snapshot
from PIL import Image

from stencil_cad.cli import main


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    """A finished small run to copy from."""
    root = tmp_path_factory.mktemp("saved")
    cfg = root / "small.yaml"
    cfg.write_text(SMALL)
    out = root / "out"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    return out


@pytest.fixture
def run_copy(job, tmp_path):
    dst = tmp_path / "out"
    shutil.copytree(job, dst)
    return dst


# --------------------------------------------------------------------------- stale inputs


@pytest.mark.slow
def test_build_and_simulate_refuse_dots_made_before_a_new_decomposition(run_copy, tmp_path, capsys):
    out = run_copy
    other = tmp_path / "other.png"
    a = np.zeros((80, 80, 3), np.uint8)
    a[:, :40] = (20, 160, 40)
    a[40:, 40:] = (240, 220, 30)
    Image.fromarray(a).save(other)
    code, _, err = _run(["decompose", "--image", other, "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    man = json.loads((out / "manifest.json").read_text())
    marked = set(man["stale"]["files"])
    assert {"layer_01_dots.csv", "spray.json", "layer_01.stl", "simulated.png"} <= marked
    before = _snapshot(out)
    for command in ("build", "simulate"):
        code, _, err = _run([command, "--out", out, "--force", "-q"], capsys)
        _one_line_error(code, err, "layer_01_dots.csv", "stale", "stencil-cad stipple")
        assert _snapshot(out) == before, f"{command} changed the folder"
        _no_leftovers(out)
    # Every file made from the earlier decomposition is still marked.
    assert set(json.loads((out / "manifest.json").read_text())["stale"]["files"]) == marked


# --------------------------------------------------------------------------- the saved plan


@pytest.mark.slow
@pytest.mark.parametrize("command", ["stipple", "build", "simulate"])
def test_a_missing_plan_is_refused_naming_the_file_and_the_fix(run_copy, capsys, command):
    out = run_copy
    (out / "plan.json").unlink()
    before = _snapshot(out)
    code, _, err = _run([command, "--out", out, "--force", "-q"], capsys)
    _one_line_error(code, err, "plan.json", "missing", "stencil-cad decompose")
    assert _snapshot(out) == before
    _no_leftovers(out)


@pytest.mark.slow
def test_a_plan_made_on_another_decomposition_or_in_another_format_is_refused(run_copy, capsys):
    out = run_copy
    plan = json.loads((out / "plan.json").read_text())
    (out / "plan.json").write_text(json.dumps({**plan, "layers_sha256": "0" * 64}))
    before = _snapshot(out)
    code, _, err = _run(["simulate", "--out", out, "--force", "-q"], capsys)
    _one_line_error(code, err, "plan.json", "stale", "layers.npz", "stencil-cad decompose")
    assert _snapshot(out) == before
    (out / "plan.json").write_text(json.dumps({**plan, "format": 99}))
    code, _, err = _run(["build", "--out", out, "--force", "-q"], capsys)
    _one_line_error(code, err, "plan.json", "not a readable plan", "format 99")
    _no_leftovers(out)


@pytest.mark.slow
def test_a_stage_command_given_another_config_plans_anew(run_copy, capsys, monkeypatch):
    import yaml

    from stencil_cad.pipeline import run as pipeline_run

    out = run_copy
    config = out / "config.yaml"
    config.write_text(yaml.safe_dump({**yaml.safe_load(config.read_text()), "seed": 12345}, sort_keys=False))
    planned = json.loads((out / "plan.json").read_text())["configs_sha256"]
    chosen = []
    choose = pipeline_run.stage_standoff
    monkeypatch.setattr(pipeline_run, "stage_standoff", lambda *a: chosen.append(1) or choose(*a))
    code, _, err = _run(["stipple", "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    assert chosen, "the design was not chosen again for the edited config"
    # The plan now names the config it was planned for: the next stage takes it as it is.
    again = json.loads((out / "plan.json").read_text())["configs_sha256"]
    assert len(again) == 1 and again[0] not in planned
    chosen.clear()
    code, _, err = _run(["simulate", "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    assert not chosen


@pytest.mark.slow
def test_stage_commands_repeat_the_run_from_its_plan_without_the_trials(job, tmp_path, monkeypatch, capsys):
    from stencil_cad.pipeline import run as pipeline_run

    def no_trials(*a, **k):
        raise AssertionError("the plate-design trials ran again")

    monkeypatch.setattr(pipeline_run, "stage_standoff", no_trials)
    out = tmp_path / "again"
    shutil.copytree(job, out)
    for command in ("stipple", "build", "simulate"):
        code, _, err = _run([command, "--out", out, "--force", "-q"], capsys)
        assert code == 0, err
    # The stipple stage's files and the plan come back byte for byte. (The plates and the
    # simulation do not: the run builds its holes as computed, `build` reads them from the dots
    # files, which hold 4 decimals.)
    stippled = [
        n for n in _snapshot(job) if n.endswith(("_dots.csv", "_dots.png", "spray.json", "swatch.png"))
    ]
    assert len(stippled) >= 5
    for name in [*stippled, "plan.json", "layers.npz", "config.yaml"]:
        assert (out / name).read_bytes() == (job / name).read_bytes(), name


# --------------------------------------------------------------------------- bounds


def _peak_run(argv: list[str]) -> tuple[int, str, float, int]:
    """Run the command line in a child; its exit code, stderr, seconds and peak memory in bytes."""
    # VmHWM is this process image's own peak: getrusage's ru_maxrss keeps the forking parent's (a
    # pytest process past 1 GB after the slow tests) across the exec.
    code = (
        "import sys\n"
        "from stencil_cad.cli import main\n"
        "c = main(sys.argv[1:])\n"
        "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM:')][0]\n"
        "print('peak_kb', hwm, file=sys.stderr)\n"
        "sys.exit(c)\n"
    )
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=300)
    took = time.monotonic() - t0
    peak = [ln for ln in r.stderr.splitlines() if ln.startswith("peak_kb ")]
    assert peak, r.stderr
    err = "\n".join(ln for ln in r.stderr.splitlines() if not ln.startswith("peak_kb "))
    return r.returncode, err, took, int(peak[0].split()[1]) * 1024


@pytest.mark.slow
def test_a_200k_row_dots_csv_is_refused_in_seconds_and_little_memory(run_copy):
    out = run_copy
    rng = np.random.default_rng(0)
    n = 200_000
    rows = np.column_stack([rng.uniform(1, 39, (n, 2)), np.full(n, 0.6)])
    text = "x_mm,y_mm,r_mm\n" + "\n".join(f"{x:.4f},{y:.4f},{r:.4f}" for x, y, r in rows) + "\n"
    (out / "layer_01_dots.csv").write_text(text)
    before = _snapshot(out)
    code, err, took, peak = _peak_run(["build", "--out", str(out), "--force", "-q"])
    assert code == 2, err
    assert "layer_01_dots.csv: 200000 holes, but at most" in err and "stencil-cad stipple" in err, err
    assert took <= 10, f"{took:.1f} s"
    assert peak < 1 << 30, f"{peak / 1e9:.2f} GB"
    assert _snapshot(out) == before


def test_rule_violations_are_counted_up_to_a_cap():
    from stencil_cad.config.rules import DesignRules
    from stencil_cad.stipple.rules import DotRuleError, check_rules

    rules = DesignRules(0.5, 0.5, 0.5, 40.0, 40.0)
    rng = np.random.default_rng(0)
    # 8,000 holes piled in a 2 mm square: 32 million overlapping pairs, all counted before.
    n = 8_000
    xy = rng.uniform(19, 21, (n, 2))
    r = np.full(n, 0.6)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.monotonic()
    with pytest.raises(DotRuleError) as info:
        check_rules(xy, r, rules)
    assert time.monotonic() - t0 < 10
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) * 1024 < 300e6
    msg = str(info.value)
    assert msg.startswith(f"at least 100000 design-rule violation(s) among {n} dots"), msg[:200]
    assert msg.count("web to dot") == 5


# --------------------------------------------------------------------------- spray.json


@pytest.mark.slow
def test_spray_json_steps_that_disagree_with_spray_times_are_refused(run_copy, capsys):
    out = run_copy
    spray = out / "spray.json"
    data = json.loads(spray.read_text())
    assert "passes" in data["order"][0]
    data["order"][0]["passes"] = int(data["order"][0]["passes"]) + 3
    spray.write_text(json.dumps(data, indent=2))
    before = _snapshot(out)
    code, _, err = _run(["build", "--out", out, "--force", "-q"], capsys)
    _one_line_error(code, err, "spray.json", "order[0].passes", "spray_times[0]", "stencil-cad stipple")
    assert _snapshot(out) == before


@pytest.mark.slow
def test_a_hand_edited_spray_json_is_mentioned(run_copy, capsys, caplog):
    out = run_copy
    spray = out / "spray.json"
    data = json.loads(spray.read_text())
    t = float(data["spray_times"][0]) + 1.0
    data["spray_times"][0] = t
    data["order"][0]["spray_time"] = t
    data["order"][0]["passes"] = max(1, round(t))
    spray.write_text(json.dumps(data, indent=2))
    code, _, err = _run(["simulate", "--out", out, "--force", "-q"], capsys)
    assert code == 0, err
    said = err + caplog.text
    assert "spray.json was edited since stencil-cad wrote it" in said and "SHA-256" in said, said


# --------------------------------------------------------------------------- templates


def _template(tmp_path: Path, body: str) -> Path:
    from stencil_cad.cad.template import builtin_template

    text = builtin_template().read_text()
    assert "    return plate\n" in text
    path = tmp_path / "my_plate.py"
    path.write_text(text.replace("    return plate\n", body))
    return path


@pytest.fixture
def tiny_image(tmp_path):
    img = tmp_path / "pic.png"
    a = np.zeros((60, 80, 3), np.uint8)
    a[:, :40] = (200, 30, 30)
    a[20:, 40:] = (20, 20, 160)
    Image.fromarray(a).save(img)
    return img


@pytest.fixture
def no_stages(monkeypatch):
    """Records the first stage instead of running it (and stops the job there)."""
    import stencil_cad.pipeline.run as pipeline
    from stencil_cad.errors import UserError

    calls: list = []

    def first_stage(*a, **k):
        calls.append(a)
        raise UserError("stopped at the first stage")

    monkeypatch.setattr(pipeline, "stage_decompose", first_stage)
    return calls


def test_a_template_whose_build_raises_is_reported_as_its_own_before_the_first_stage(
    tmp_path, capsys, no_stages, tiny_image
):
    tpl = _template(tmp_path, '    raise RuntimeError("the corner fillet failed")\n')
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL + f"plate:\n  template: {tpl}\n")
    out = tmp_path / "out"
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", out], capsys)
    _one_line_error(
        code, err, str(tpl), "one-hole", "RuntimeError: the corner fillet failed", "the template's"
    )
    assert no_stages == [] and not out.exists()


def test_a_users_template_is_named_with_its_sha256_when_it_runs(
    tmp_path, capsys, caplog, no_stages, tiny_image
):
    tpl = _template(tmp_path, "    return plate\n")
    cfg = tmp_path / "job.yaml"
    cfg.write_text(SMALL + f"plate:\n  template: {tpl}\n")
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", tmp_path / "out"], capsys)
    _one_line_error(code, err, "stopped at the first stage")
    said = err + caplog.text
    sha = hashlib.sha256(tpl.read_bytes()).hexdigest()
    assert f"plate template {tpl.resolve()} (SHA-256 {sha})" in said, said
    assert "runs with your rights" in said
    # The bundled template is not announced.
    caplog.clear()
    cfg.write_text(SMALL)
    code, _, err = _run(["run", cfg, "--image", tiny_image, "--out", tmp_path / "out2"], capsys)
    assert "SHA-256" not in err + caplog.text


def test_a_template_error_in_build_is_the_templates_at_build_time_too(tmp_path):
    """A template that passes the one-hole trial and fails on a real plate still names itself."""
    from stencil_cad import cad
    from stencil_cad.config import PlateConfig
    from stencil_cad.model import DotSet

    tpl = _template(
        tmp_path,
        "    if len(holes.r_mm) > 1:\n        raise KeyError('hole 2')\n    return plate\n",
    )
    plate = PlateConfig(template=tpl)
    dots = DotSet(xy_mm=np.array([[10.0, 10.0], [30.0, 30.0]]), r_mm=np.array([1.0, 1.0]))
    with pytest.raises(ValueError) as info:
        cad.build_plate(dots, 40.0, 40.0, plate, None)
    assert str(tpl) in str(info.value) and "KeyError" in str(info.value)
    assert os.path.basename(str(tpl)) in str(info.value)
