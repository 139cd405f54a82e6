"""End to end: `stencil-cad run` on the bundled example, in a child process.

Prints seconds (wall clock of the whole command, imports included), CPU seconds, the
child's peak resident memory, and the stage times and figures from the manifest it wrote.
Case ``example`` is the bundled job as shipped (refinement on); ``example-norefine`` is
the same job with ``refine.enabled: false``. Both run in the same call, so their ratio is
measured on the same machine state; the ``example`` row carries the ratios (on a shared
machine, compare CPU seconds and run the benchmark several times for medians).
``example-nominal`` refines for the nominal can alone (``refine.cans: nominal``; the shipped job
refines for the prior's caps), and the ``example`` row carries its refinement time over that one's
(``refine_ratio_vs_one_can``); ``example-paper`` is the job under the paper's spray
model. Every row scores against the source image resized to the simulated grid (the manifest's
``simulate.scielab``), and under the physical model gives ``scielab_worst`` over the prior of cans.

``--baseline COMMIT`` (``python -m benchmarks e2e --baseline 1e9aeab``) also runs the bundled example of
another commit, in the same call: the commit's tree is exported from git into a scratch folder (removed
afterwards) and its own ``stencil-cad run`` makes its own bundled example there. The ``example`` row
then gives ``baseline_cpu_seconds``, ``baseline_seconds``, ``cpu_ratio_vs_baseline`` (this tree's CPU
seconds over the commit's) and ``baseline_commit``; ``baseline`` holds the commit's whole row. The
commit's example job is the one it shipped (its size, layers and process), as a maker would have run it.
Both examples run once unrecorded (the kernels compile into each tree's cache), then
:data:`EXAMPLE_RUNS` times in turn; each side's row is its median run.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

CASES = ("example-norefine", "example-nominal", "example", "example-paper")
#: Runs of a case on each side of a paired comparison (:func:`paired`), alternated; each side gives its median run.
PAIRED_RUNS = 3
#: Runs of the example on each side with ``--baseline``: with three, two calls on the same commit
#: gave ratios 0.595 and 0.584 (the machine's load moves both sides, not always alike); the
#: example's runs are short enough to take five.
EXAMPLE_RUNS = 5
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = ("seconds", "cpu_seconds", "peak_mb", "stage_seconds", "dots", "scielab", "scielab_2x", "passes")
#: The smoke case's job: the bundled example at 40 mm in two layers.
SMOKE_JOB = {"size": {"width_mm": 40.0}, "decompose": {"layers": 2}}


#: The repository whose tree these benchmarks run (and whose history ``--baseline`` reads).
REPO = Path(__file__).resolve().parents[1]


def _config(tmp: Path, case: str, job: dict | None = None, root: Path = REPO) -> Path:
    import yaml

    data_dir = root / "stencil_cad" / "data"
    cfg = yaml.safe_load((data_dir / "example.yaml").read_text())
    cfg["image"] = str(data_dir / cfg["image"])
    cfg.setdefault("refine", {})["enabled"] = case != "example-norefine"
    if case == "example-nominal":
        cfg["refine"]["cans"] = "nominal"
    if case == "example-paper":
        cfg["spray"]["model"] = "paper"
    for section, values in (job or {}).items():
        cfg.setdefault(section, {}).update(values)
    path = tmp / f"{case}{'' if root == REPO else '-baseline'}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _one(case: str, tmp: Path, job: dict | None = None, root: Path = REPO) -> dict:
    """One job of ``case`` made by the tree at ``root`` (this one, or a baseline commit's), in a child process."""
    import os

    out = tmp / (case if root == REPO else f"{case}-baseline")
    cfg = _config(tmp, case, job, root)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # RUSAGE_CHILDREN's peak is the largest child so far, so each child reports its own peak.
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "import resource, sys; from stencil_cad.cli import main; rc = main(sys.argv[1:]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr); sys.exit(rc)",
            "run",
            str(cfg),
            "--out",
            str(out),
            "-q",
        ],
        capture_output=True,
        text=True,
        cwd=root,
        env=env,
    )
    seconds = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = proc.stderr.strip().splitlines()
    peak_mb = float(lines[-1]) / 1024.0 if lines and lines[-1].strip().isdigit() else float("nan")
    row = {
        "bench": "e2e",
        "case": case,
        "seconds": round(seconds, 2),
        "cpu_seconds": round(cpu, 2),
        "peak_mb": round(peak_mb, 1),
    }
    if proc.returncode != 0:
        row["error"] = lines[-1] if lines else f"exit {proc.returncode}"
        return row
    manifest = json.loads((out / "manifest.json").read_text())
    row["stage_seconds"] = manifest.get("seconds", {})
    row["dots"] = [r["dots"] for r in manifest.get("stipple", [])]
    row["files"] = len(manifest.get("files", []))
    sim = manifest.get("simulate", {})
    for k in (
        "de2000_mean",
        "de2000_p95",
        "psnr",
        "ssim",
        "view_distance_m",
        "scielab",
        "scielab_2x",
        "scielab_worst",
        "scielab_by_can",
    ):
        if k in sim:
            row[k] = sim[k]
    row["passes"] = [s.get("passes") for s in manifest.get("spraying", [])]
    return row


def export_tree(commit: str, dest: Path) -> str:
    """Write the tree of ``commit`` (of this repository) into ``dest``; returns the commit's full hash.

    Raises:
        ValueError: ``commit`` names no commit of this repository.
    """
    import io
    import tarfile

    rev = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--verify", "--quiet", f"{commit}^{{commit}}"],
        capture_output=True,
        text=True,
    )
    if rev.returncode != 0:
        raise ValueError(f"--baseline {commit!r} is no commit of this repository; give a hash or a branch")
    full = rev.stdout.strip()
    tar = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", full], capture_output=True, check=True
    )
    with tarfile.open(fileobj=io.BytesIO(tar.stdout)) as archive:
        archive.extractall(dest, filter="data")
    return full


def _ratios(rows: dict, case: str) -> None:
    """The ``example`` row's ratios against the cases run before it in the same call."""
    row = rows[case]
    if case == "example" and "example-norefine" in rows:
        base = rows["example-norefine"]
        for key in ("seconds", "cpu_seconds", "peak_mb"):
            if base.get(key):
                row[f"{key}_ratio_vs_norefine"] = round(row[key] / base[key], 3)
    if case == "example" and "example-nominal" in rows:
        one = rows["example-nominal"].get("stage_seconds", {}).get("refine")
        many = row.get("stage_seconds", {}).get("refine")
        if one and many:
            row["refine_ratio_vs_one_can"] = round(many / one, 3)


def run(cases=None, baseline: str | None = None):
    """The rows of ``cases`` (all by default; only ``example`` with a ``baseline`` commit unless cases are named)."""
    if baseline is not None and not cases:
        wanted = ["example"]
    else:
        wanted = [c for c in CASES if not cases or c in cases or "example" in cases]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        paired = None
        if baseline is not None:
            root = Path(tmp) / "baseline"
            full = export_tree(baseline, root)
            paired = _paired(Path(tmp), root)
        for case in wanted:
            if case == "example" and paired is not None:
                rows[case] = paired[0]
            else:
                rows[case] = _one(case, Path(tmp))
            _ratios(rows, case)
            if case == "example" and paired is not None:
                row, base_row = rows[case], {**paired[1], "commit": full}
                row["baseline_commit"] = base_row["commit"]
                row["baseline_seconds"] = base_row["seconds"]
                row["baseline_cpu_seconds"] = base_row["cpu_seconds"]
                if base_row.get("cpu_seconds"):
                    row["cpu_ratio_vs_baseline"] = round(row["cpu_seconds"] / base_row["cpu_seconds"], 3)
                row["baseline"] = base_row
            yield rows[case]


def _paired(tmp: Path, root: Path) -> tuple[dict, dict]:
    """The example made :data:`EXAMPLE_RUNS` times by this tree and by the baseline's, in turn: each side's median run.

    Each side first makes one job unrecorded: the exported baseline's first job compiled its kernels
    (64 CPU-s against 42 and 46 warm), and one such run counted made the ratio look like 0.91-1.01
    where the warm jobs give 1.5.
    """

    def make(where: Path, folder: Path) -> dict:
        return _one("example", folder, root=where)

    return paired(tmp, root, make, make, runs=EXAMPLE_RUNS)


def paired(
    tmp: Path,
    root: Path,
    make: Callable[[Path, Path], dict],
    warm: Callable[[Path, Path], object],
    runs: int = PAIRED_RUNS,
) -> tuple[dict, dict]:
    """This tree's and the baseline tree's (at ``root``) median runs of ``make``: ``(ours, theirs)``.

    ``warm(tree, folder)`` first runs once unrecorded in each tree: a tree's first job compiles its
    kernels into its own cache (the exported baseline's always). Then ``make(tree, folder)`` runs
    ``runs`` times on each side, in turn, so both are measured under the same load; each side's row
    is its median run by CPU seconds, with every counted run's CPU seconds (``cpu_seconds_runs``).
    """
    ours: list[dict] = []
    theirs: list[dict] = []
    warm_dir = tmp / "warm"
    warm_dir.mkdir(exist_ok=True)
    for where in (root, REPO):
        warm(where, warm_dir)
    for i in range(runs):
        for side, where in ((theirs, root), (ours, REPO)):
            folder = tmp / f"paired-{i}"
            folder.mkdir(exist_ok=True)
            side.append(make(where, folder))

    def median(rows: list[dict]) -> dict:
        done = sorted((r for r in rows if "error" not in r), key=lambda r: r["cpu_seconds"]) or rows
        return {**done[len(done) // 2], "cpu_seconds_runs": [r["cpu_seconds"] for r in rows]}

    return median(ours), median(theirs)


def smoke():
    """The bundled example at 40 mm in two layers, as shipped."""
    with tempfile.TemporaryDirectory() as tmp:
        yield {**_one("example", Path(tmp), SMOKE_JOB), "case": "smoke-example"}
