"""Compare the files of two runs byte for byte: a refactoring must not change a maker's files.

Usage::

    python -m benchmarks.compare_outputs --make BEFORE   # on the commit before the change
    python -m benchmarks.compare_outputs --make AFTER    # on the commit after it
    python -m benchmarks.compare_outputs BEFORE --out AFTER   # compares the two, job by job

    stencil-cad run --out BEFORE                          # or one job, the example:
    python -m benchmarks.compare_outputs BEFORE           # runs the example now, compares

``--make DIR`` runs four jobs into ``DIR/<job>``: the bundled example, the same picture as hard
stencils, a small mural (240 × 160 mm on a Prusa MK4 bed, 2 layers, FDM) and the calibration
card. It runs them with one thread for the compiled kernels (``NUMBA_NUM_THREADS=1``): their
parallel sums may differ in the last bit between runs on a loaded machine, and a hole centre
written with 4 decimals then flips its last digit. It also gives the kernels an empty cache
(``NUMBA_CACHE_DIR``, a fresh folder): a kernel loaded from a cache that another checkout filled
gave the example's refined holes other last digits than one compiled afresh. Folders holding job
folders are compared job by job.

Prints one JSON line per file (name, size, SHA-256 on each side, same or not) and a
last summary line; exits 1 when any compared file differs or is missing on one side.
Every kind of file a run writes is compared (CSV, STL, STEP, 3MF, PNG, DXF, SVG, PDF, HTML,
NPZ, JSON, YAML; ``--ext`` to choose); ``manifest.json`` is compared without the fields that
record when and where the job ran (:data:`PLACEMENT_KEYS`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

DEFAULT_EXTS = (
    ".csv",
    ".stl",
    ".step",
    ".3mf",
    ".png",
    ".dxf",
    ".svg",
    ".pdf",
    ".html",
    ".npz",
    ".json",
    ".yaml",
)

MANIFEST = "manifest.json"
#: The jobs ``--make`` runs: folder name and the command line after ``stencil-cad``.
JOBS = {
    "example": ["run"],
    "hard": ["hard"],
    "mural": ["run", "{mural}", "--workers", "0"],
    "card": ["card"],
}
MURAL_YAML = (
    "name: tiny_mural\n"
    "size: {width_mm: 240, height_mm: 160, px_per_mm: auto}\n"
    "bed: prusa_mk4\n"
    "decompose: {layers: 2}\n"
    "stipple: {process: fdm}\n"
)
#: Config keys that hold the path of an input file: compared by file name (a checkout elsewhere
#: reads the bundled example from another folder).
PATH_KEYS = ("image", "template", "source", "path")
#: Manifest keys that record when and where the job ran, not what it made: the time per stage,
#: the cluster (kind, workers, address, tasks), the versions of the tools, and the file table's
#: own rows (each compared file is compared itself).
PLACEMENT_KEYS = ("seconds", "compute", "versions", "created", "files")


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def manifest_content(path: Path) -> dict:
    """A manifest without :data:`PLACEMENT_KEYS` (at any depth), the file table as name → SHA-256."""

    def strip(obj):
        if isinstance(obj, dict):
            return {k: strip(v) for k, v in obj.items() if k not in PLACEMENT_KEYS}
        if isinstance(obj, list):
            return [strip(v) for v in obj]
        return obj

    data = json.loads(path.read_text(encoding="utf-8"))
    out = strip(data)
    out = _names_only(out)
    # config.yaml holds the input's absolute path: it is compared itself (config_content).
    out["files"] = {
        r["name"]: r["sha256"]
        for r in data.get("files", [])
        if isinstance(r, dict) and r["name"] != "config.yaml"
    }
    return out


def _names_only(cfg: dict) -> dict:
    """A config with every input path (:data:`PATH_KEYS`, at any depth) cut to its file name."""
    out = {}
    for k, v in cfg.items():
        if isinstance(v, dict):
            v = _names_only(v)
        elif k in PATH_KEYS and isinstance(v, str) and "/" in v:
            v = Path(v).name
        out[k] = v
    return out


def config_content(path: Path) -> dict:
    """A written ``config.yaml`` with its input paths cut to file names."""
    import yaml

    return _names_only(yaml.safe_load(path.read_text(encoding="utf-8")) or {})


def manifest_differences(a: dict, b: dict, where: str = "") -> list[str]:
    """Dotted paths at which two stripped manifests differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b), key=str):
            out += manifest_differences(a.get(k), b.get(k), f"{where}.{k}" if where else str(k))
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [
            d
            for i, (x, y) in enumerate(zip(a, b, strict=True))
            for d in manifest_differences(x, y, f"{where}[{i}]")
        ]
    return [] if a == b else [where or "(top level)"]


def compare(before: Path, after: Path, exts: tuple[str, ...] = DEFAULT_EXTS) -> list[dict]:
    """One row per file name with a compared suffix in either folder."""
    names = sorted({p.name for d in (before, after) for p in d.iterdir() if p.suffix.lower() in exts})
    rows = []
    for name in names:
        a, b = before / name, after / name
        row: dict = {"file": name}
        for side, p in (("before", a), ("after", b)):
            row[side] = {"bytes": p.stat().st_size, "sha256": _sha(p)[:16]} if p.is_file() else None
        if name == MANIFEST and a.is_file() and b.is_file():
            row["differ_at"] = manifest_differences(manifest_content(a), manifest_content(b))
            row["same"] = not row["differ_at"]
        elif name == "config.yaml" and a.is_file() and b.is_file():
            row["differ_at"] = manifest_differences(config_content(a), config_content(b))
            row["same"] = not row["differ_at"]
        else:
            row["same"] = a.is_file() and b.is_file() and a.read_bytes() == b.read_bytes()
        rows.append(row)
    return rows


def make(folder: Path, jobs: dict[str, list[str]] | None = None) -> None:
    """Run every job of :data:`JOBS` (or ``jobs``) into ``folder/<job>`` (one thread for the compiled kernels)."""
    import os
    import tempfile

    folder.mkdir(parents=True, exist_ok=True)
    mural = folder / "mural.yaml"
    mural.write_text(MURAL_YAML, encoding="utf-8")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_NUM_THREADS": "1", "NUMBA_CACHE_DIR": cache}
        for job, args in (jobs or JOBS).items():
            cmd = [sys.executable, "-m", "stencil_cad", *(a.format(mural=mural) for a in args)]
            subprocess.run([*cmd, "--out", str(folder / job), "-q"], check=True, env=env)


def compare_jobs(before: Path, after: Path, exts: tuple[str, ...] = DEFAULT_EXTS) -> list[dict]:
    """:func:`compare` per job folder when both folders hold job folders, else on the folders."""
    jobs = sorted(p.name for p in before.iterdir() if p.is_dir()) if before.is_dir() else []
    if not jobs:
        return compare(before, after, exts)
    rows = []
    for job in jobs:
        for row in compare(before / job, after / job, exts):
            rows.append({**row, "file": f"{job}/{row['file']}"})
    return rows


#: The keys the readers of the smoke row use (``python -m benchmarks --smoke`` checks them).
SMOKE_KEYS = ("compared", "identical", "differ", "seconds")


def smoke():
    """The card made twice as ``--make`` makes it, compared file by file: every file the same.

    The comparison needs two commits; its smoke case runs the same code on one, so the jobs,
    the one-thread run and the comparison are exercised, and a run that is not reproducible fails.
    """
    import time

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="stencil_compare_smoke_") as tmp:
        card = {"card": JOBS["card"]}
        make(Path(tmp) / "before", card)
        make(Path(tmp) / "after", card)
        rows = compare_jobs(Path(tmp) / "before", Path(tmp) / "after")
    differ = [r["file"] for r in rows if not r["same"]]
    row = {
        "bench": "compare_outputs",
        "case": "smoke-card",
        "compared": len(rows),
        "identical": len(rows) - len(differ),
        "differ": differ,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    if differ or not rows:
        row["error"] = f"the same job made twice differs in {differ or 'no compared file'}"
    yield row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.compare_outputs", description=__doc__)
    parser.add_argument("before", type=Path, nargs="?", help="output folder of the earlier run")
    parser.add_argument("--make", type=Path, metavar="DIR", help="run every job into DIR/<job> and stop")
    parser.add_argument(
        "--out", type=Path, help="output folder of the later run (default: run the example now)"
    )
    parser.add_argument("--ext", action="append", help="file suffix to compare (repeatable)")
    args = parser.parse_args(argv)
    exts = tuple(e if e.startswith(".") else f".{e}" for e in args.ext) if args.ext else DEFAULT_EXTS
    if args.make is not None:
        make(args.make)
        return 0
    if args.before is None:
        parser.error("give the folder of the earlier run, or --make DIR")
    with tempfile.TemporaryDirectory(prefix="stencil_compare_") as tmp:
        after = args.out
        if after is None:
            after = Path(tmp) / "example"
            cmd = [sys.executable, "-m", "stencil_cad", "run", "--out", str(after), "-q"]
            subprocess.run(cmd, check=True)
        rows = compare_jobs(args.before, after, exts)
    for row in rows:
        print(json.dumps(row))
    differ = [r["file"] for r in rows if not r["same"]]
    print(json.dumps({"compared": len(rows), "identical": len(rows) - len(differ), "differ": differ}))
    return 1 if differ or not rows else 0


if __name__ == "__main__":
    sys.exit(main())
