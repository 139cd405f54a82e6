"""Murals: `stencil-cad run` on a 1 m² and a 4 m² mural (4 layers, FDM, bed prusa_mk4), in a child process.

Each case is a mural (1 m × 1 m, 2 m × 2 m, 4 m × 2.5 m) from the bundled 512 px photo enlarged
to 1024 px, or 1600 px for the 4 m wide one (an ordinary photo; the auto resolution needs one
pixel per 3.2 mm hole pitch along the picture's width), with ``size.px_per_mm: auto``. Prints one JSON line per case: ``bench: "mural"``, ``area_m2``,
``workers`` (1: one process), ``seconds`` (wall clock of the whole command), ``peak_mb_all``
(the largest sum of the resident memory of the command and all its child processes, sampled
every 0.2 s, and never below the kernel's peak of the largest one), ``tiles``, ``holes``
and the stage times, and ``cpu_seconds`` (the command and every process it waited for). The
4 m² row also gives ``ratio_to_1m2`` (wall clocks) and ``cpu_ratio_to_1m2``.

The Dask rows (cases ``4m2-w2``, ``10m2-w2``; ``10m2-w1`` on request) run the same command with
``--workers N`` (a local cluster of N worker processes; the one-process rows run with
``--workers 0``). ``10m2`` is 4 m × 2.5 m. ``identical`` is true when every output file but
``manifest.json`` (timings, where it ran) is byte-identical to the one-process run of the same
size in this invocation, and null when there was none; ``speedup_vs_1`` is the one-process
run's seconds over this one's. ``peak_mb_all`` sums the command and its worker processes.
Run ``python -m benchmarks mural --case 4m2 --case 4m2-w2`` several times on a quiet machine
and quote the medians: the speed-up is a ratio of wall clocks.

Case ``mural600`` is the mural of issue 44 as a maker runs it: scikit-image's ``coffee`` photo
(as ``benchmarks/quality.py`` loads it, saved as ``coffee.png``) at 600 x 400 mm, 3 layers,
``stipple.process: fdm``, ``view.distance_m: 3``, ``--bed prusa_mk4`` on the command line and no
``--workers`` (the job's own choice). Its row also gives ``scielab`` (the manifest's
``simulate.scielab``, S-CIELAB at 3 m).

``--baseline COMMIT`` (``python -m benchmarks mural --case mural600 --baseline 1e9aeab``; only
``mural600`` when no case is named) also runs the same job with another commit's code in the
same call: the commit's tree is exported from git into a scratch folder (removed afterwards, as
``python -m benchmarks e2e --baseline`` does) and its own ``stencil-cad run`` runs there. Each tree
first makes the smoke mural once, unrecorded (the exported tree has no compiled kernels: counted,
their compilation flattered the ratio), then the case three times on each side in turn; each side
gives its median run by CPU seconds, with every run's CPU seconds in ``cpu_seconds_runs``. Each row then gives ``baseline_seconds``, ``baseline_cpu_seconds``,
``baseline_scielab``, ``ratio_vs_baseline`` (this tree's wall clock over the commit's),
``cpu_ratio_vs_baseline`` and ``baseline_commit``; ``baseline`` holds the commit's whole row.
"""

from __future__ import annotations

import json
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import yaml

from .e2e import REPO, export_tree, paired

#: Case name: (width mm, height mm, workers; 0 = one process, None = the job's own choice).
CASES: dict[str, tuple[float, float, int | None]] = {
    "mural600": (600.0, 400.0, None),
    "1m2": (1000.0, 1000.0, 0),
    "4m2": (2000.0, 2000.0, 0),
    "4m2-w2": (2000.0, 2000.0, 2),
    "10m2-w2": (4000.0, 2500.0, 2),
}
#: The smoke case: a 240 x 120 mm mural in two layers on a 180 mm bed (two or more tiles).
SMOKE = {"smoke": (240.0, 120.0, 0)}
SMOKE_JOB = {"bed": "prusa_mini", "decompose": {"layers": 2}}
#: The keys the readers of these rows use (checked on the smoke rows).
SMOKE_KEYS = (
    "area_m2",
    "workers",
    "seconds",
    "peak_mb_all",
    "cpu_seconds",
    "tiles",
    "holes",
    "stage_seconds",
)
#: Cases run only when asked for by name.
ON_REQUEST: dict[str, tuple[float, float, int | None]] = {
    "10m2-w1": (4000.0, 2500.0, 0),
    "1m2-w2": (1000.0, 1000.0, 2),
}
#: The mural of issue 44 (case ``mural600``): its job, and its bed given on the command line.
MURAL600_JOB = {
    "name": "coffee mural",
    "decompose": {"layers": 3},
    "stipple": {"process": "fdm"},
    "view": {"distance_m": 3},
}
MURAL600_BED = "prusa_mk4"


def _tree_rss_mb(pid: int) -> float:
    import psutil

    try:
        p = psutil.Process(pid)
        procs = [p, *p.children(recursive=True)]
    except psutil.NoSuchProcess:
        return 0.0
    total = 0
    for q in procs:
        try:
            total += q.memory_info().rss
        except psutil.NoSuchProcess:
            pass
    return total / 2**20


def _photo(tmp: Path, width_mm: float) -> Path:
    """The bundled photo enlarged to 1024 px, or more when the picture is wider than 3.2 m."""
    from PIL import Image

    from stencil_cad.imaging import example_image_path

    side = 1600 if width_mm > 3200 else 1024
    image = tmp / f"photo_{side}.png"
    if not image.exists():
        Image.open(example_image_path()).convert("RGB").resize((side, side), Image.LANCZOS).save(image)
    return image


def _coffee(tmp: Path) -> Path:
    """scikit-image's ``coffee`` photo (600 x 400 px), as the quality benchmark loads it, saved as PNG."""
    from PIL import Image
    from skimage import data

    image = tmp / "coffee.png"
    if not image.exists():
        Image.fromarray(data.coffee()).save(image)
    return image


def _command(name: str, case: tuple[float, float, int | None], tmp: Path, job: dict | None, root: Path):
    """The config file's path, the output folder and the command line of one case, for the tree at ``root``."""
    width_mm, height_mm, workers = case
    area = width_mm * height_mm / 1e6
    tag = "" if root == REPO else "-baseline"
    if name == "mural600":
        cfg = {**MURAL600_JOB, "image": str(_coffee(tmp)), "size": {"width_mm": width_mm}}
    else:
        cfg = {
            "name": f"mural_{area:g}m2",
            "image": str(_photo(tmp, width_mm)),
            "size": {"width_mm": width_mm, "height_mm": height_mm, "px_per_mm": "auto"},
            "bed": "prusa_mk4",
            "decompose": {"layers": 4},
            "stipple": {"process": "fdm"},
            **(job or {}),
        }
    path = tmp / f"{name}{tag}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = tmp / f"{name}{tag}"
    cmd = [sys.executable, "-m", "stencil_cad", "run", str(path), "--out", str(out), "-q"]
    if name == "mural600":
        cmd += ["--bed", MURAL600_BED]
    if workers is not None:
        cmd += ["--workers", str(workers)]
    return out, cmd


def _run_case(
    name: str,
    case: tuple[float, float, int | None],
    tmp: Path,
    job: dict | None = None,
    root: Path = REPO,
) -> tuple[dict, Path]:
    """One case made by the tree at ``root`` (this one, or a baseline commit's), in a child process."""
    import os

    width_mm, height_mm, workers = case
    area = width_mm * height_mm / 1e6
    out, cmd = _command(name, case, tmp, job, root)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    t0 = time.perf_counter()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=root, env=env)
    peak = [0.0]

    def sample() -> None:
        while proc.poll() is None:
            peak[0] = max(peak[0], _tree_rss_mb(proc.pid))
            time.sleep(0.2)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    _, err = proc.communicate()
    th.join()
    seconds = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    kernel_peak = c1.ru_maxrss / 1024.0
    row = {
        "bench": "mural",
        "case": name,
        "area_m2": round(area, 3),
        "workers": None if workers is None else max(workers, 1),
        "seconds": round(seconds, 1),
        "peak_mb_all": round(max(peak[0], kernel_peak), 1),
        # CPU of the command and every process it waited for (a local cluster's workers too):
        # the figure to compare when the machine is shared.
        "cpu_seconds": round(c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, 1),
    }
    if proc.returncode != 0:
        row["error"] = err.strip().splitlines()[-1] if err.strip() else f"exit {proc.returncode}"
        return row, out
    manifest = json.loads((out / "manifest.json").read_text())
    m = manifest.get("mural", {})
    row["tiles"] = len(m.get("tiles", [])) or 1
    row["holes"] = sum(r["dots"] for r in manifest.get("stipple", []))
    row["stage_seconds"] = manifest.get("seconds", {})
    row["scielab"] = manifest.get("simulate", {}).get("scielab")
    return row, out


def _identical(a: Path, b: Path) -> bool:
    """Every file but the manifest byte-identical, and the same set of files."""
    names = sorted(p.name for p in a.iterdir())
    if names != sorted(p.name for p in b.iterdir()):
        return False
    return all((a / n).read_bytes() == (b / n).read_bytes() for n in names if n != "manifest.json")


def _with_baseline(row: dict, base: dict) -> None:
    """The baseline commit's figures and the ratios against them, on this tree's row."""
    row["baseline_commit"] = base["commit"]
    row["baseline_seconds"] = base["seconds"]
    row["baseline_cpu_seconds"] = base["cpu_seconds"]
    row["baseline_scielab"] = base.get("scielab")
    if base.get("error") is None and "error" not in row:
        row["ratio_vs_baseline"] = round(row["seconds"] / base["seconds"], 3)
        if base["cpu_seconds"]:
            row["cpu_ratio_vs_baseline"] = round(row["cpu_seconds"] / base["cpu_seconds"], 3)
    row["baseline"] = base


def _paired_case(
    name: str, case: tuple[float, float, int | None], tmp: Path, root: Path, warmed: set[Path]
) -> tuple[dict, Path, dict]:
    """``name`` made by this tree and by the baseline's at ``root`` in turn: ``(our median row, its folder, theirs)``.

    Before the first case each tree makes the smoke mural once, unrecorded: the exported baseline
    has no compiled kernels, and its first job would count their compilation (the e2e benchmark's
    baseline took 64 CPU-s in its first job against 42-46 warm). Then each side makes the case
    :data:`benchmarks.e2e.PAIRED_RUNS` times, alternated, and gives its median run
    (:func:`benchmarks.e2e.paired`). The baseline's folders are removed as they are made, ours but
    the median run's at the end.
    """
    folders: list[Path] = []

    def make(where: Path, folder: Path) -> dict:
        row, out = _run_case(name, case, folder, root=where)
        if where == REPO:
            folders.append(out)
            return {**row, "folder": str(out)}
        shutil.rmtree(out, ignore_errors=True)
        return row

    def warm(where: Path, folder: Path) -> None:
        if where not in warmed:
            warmed.add(where)
            _, out = _run_case("smoke", SMOKE["smoke"], folder, SMOKE_JOB, root=where)
            shutil.rmtree(out, ignore_errors=True)

    (tmp / name).mkdir(exist_ok=True)
    ours, theirs = paired(tmp / name, root, make, warm)
    chosen = Path(ours.pop("folder"))
    for out in folders:
        if out != chosen:
            shutil.rmtree(out, ignore_errors=True)
    return ours, chosen, theirs


def run(cases=None, baseline: str | None = None):
    """The rows of ``cases`` (the default set; only ``mural600`` with a ``baseline`` commit unless cases are named).

    Raises:
        ValueError: ``baseline`` names no commit of this repository, or ``cases`` names no mural case.
    """
    every = {**CASES, **ON_REQUEST}
    if cases and not any(c in every for c in cases):
        raise ValueError(f"no mural case among {', '.join(cases)}; choose from {', '.join(every)}")
    if baseline is not None and not cases:
        cases = ["mural600"]
    names = [c for c in every if (c in cases if cases else c in CASES)]
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        root = None
        if baseline is not None:
            root = tmp / "baseline"
            full = export_tree(baseline, root)
        warmed: set[Path] = set()
        first = None
        one_process: dict[float, tuple[dict, Path]] = {}
        for name in names:
            if root is None:
                row, out = _run_case(name, every[name], tmp)
            else:
                row, out, theirs = _paired_case(name, every[name], tmp, root, warmed)
                _with_baseline(row, {**theirs, "commit": full})
            ok = "error" not in row
            if name == "mural600" or not ok:
                # Not one of the square photo's murals whose rows are compared with each other.
                yield row
                continue
            if every[name][2] == 0:
                one_process[row["area_m2"]] = (row, out)
                if first is None:
                    first = row
                else:
                    row["ratio_to_1m2"] = round(row["seconds"] / first["seconds"], 2)
                    row["cpu_ratio_to_1m2"] = round(row["cpu_seconds"] / first["cpu_seconds"], 2)
            else:
                base = one_process.get(row["area_m2"])
                row["identical"] = None if base is None else _identical(base[1], out)
                if base is not None:
                    row["speedup_vs_1"] = round(base[0]["seconds"] / row["seconds"], 2)
                if first is not None:
                    row["ratio_to_1m2"] = round(row["seconds"] / first["seconds"], 2)
            yield row


def smoke():
    """A 240 x 120 mm mural in two layers on a 180 mm bed, in one process."""
    with tempfile.TemporaryDirectory() as tmp:
        row, _ = _run_case("smoke", SMOKE["smoke"], Path(tmp), SMOKE_JOB)
        yield row
