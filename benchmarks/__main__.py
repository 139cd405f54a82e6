"""Run the named benchmarks (all by default) and print one JSON object per line.

Each benchmark is a module ``benchmarks/<name>.py`` with ``run(cases=None)``
yielding dicts that hold at least ``bench``, ``case`` and ``seconds`` (or the
per-iteration figures that benchmark documents).

Every benchmark also has a tiny case, ``smoke()``, that CI runs (``--smoke``): the same code on
a picture, plate or job small enough that all of them together take a few minutes on two cores.
Its rows must carry the keys the benchmark's readers use (the module's ``SMOKE_KEYS``) and no
``error``; ``--smoke`` exits with 1 when one does not.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time

NAMES = [
    "decompose",
    "decompose_choice",
    "stipple",
    "spray",
    "cad",
    "wall_dxf",
    "quality",
    "fidelity",
    "refine",
    "slicer",
    "e2e",
    "cans",
    "limits",
    "calibrate",
    "mural",
    "mural_parts",
    "dask_overhead",
    "printed",
    "studio",
]
#: Tools run with their own command line (``python -m benchmarks.NAME``) whose smoke case
#: ``--smoke`` runs too.
SMOKE_ONLY = ["compare_outputs"]


def smoke_problems(name: str, rows: list[dict], keys: tuple[str, ...]) -> list[str]:
    """What is wrong with a benchmark's smoke rows: none at all, an error, or a key its readers use missing."""
    if not rows:
        return [f"{name}: no rows"]
    problems = []
    for row in rows:
        if not isinstance(row, dict):
            problems.append(f"{name}: a row is not a JSON object: {row!r}")
            continue
        if row.get("error"):
            problems.append(f"{name} {row.get('case')}: error: {str(row['error'])[-300:]}")
        missing = [k for k in ("bench", "case", *keys) if k not in row]
        if missing:
            problems.append(f"{name} {row.get('case')}: missing {', '.join(missing)}")
        try:
            json.dumps(row)
        except (TypeError, ValueError) as exc:
            problems.append(f"{name} {row.get('case')}: not JSON: {exc}")
    return problems


def _smoke(names: list[str]) -> int:
    problems: list[str] = []
    t_all = time.perf_counter()
    for name in names:
        module = importlib.import_module(f"benchmarks.{name}")
        t0 = time.perf_counter()
        rows = []
        for row in module.smoke():
            rows.append(row)
            print(json.dumps(row), flush=True)
        seconds = time.perf_counter() - t0
        found = smoke_problems(name, rows, module.SMOKE_KEYS)
        problems += found
        status = "ok" if not found else "FAILED"
        print(f"# smoke {name}: {len(rows)} rows in {seconds:.1f} s, {status}", file=sys.stderr, flush=True)
    print(f"# smoke: {len(names)} benchmarks in {time.perf_counter() - t_all:.1f} s", file=sys.stderr)
    for p in problems:
        print(f"# smoke problem: {p}", file=sys.stderr)
    return 1 if problems else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"benchmarks to run (default: all): {', '.join(NAMES)}")
    parser.add_argument("--case", action="append", help="run only this case (repeatable)")
    parser.add_argument(
        "--smoke",
        action="store_true",
        help="run each benchmark's tiny case and check its rows carry the keys its readers use (CI)",
    )
    parser.add_argument(
        "--baseline",
        metavar="COMMIT",
        help="e2e and mural only: also run the same job (e2e: the bundled example; mural: case mural600 unless "
        "--case names others) with the code of COMMIT (exported into a scratch folder) in the same call",
    )
    args = parser.parse_args(argv)
    if args.baseline is not None and args.names not in (["e2e"], ["mural"]):
        parser.error(
            "--baseline is for one benchmark, e2e or mural: python -m benchmarks e2e --baseline COMMIT, "
            "python -m benchmarks mural --case mural600 --baseline COMMIT"
        )
    names = args.names or (NAMES + SMOKE_ONLY if args.smoke else NAMES)
    for name in names:
        if name not in NAMES and not (args.smoke and name in SMOKE_ONLY):
            parser.error(f"unknown benchmark {name!r}; choose from {', '.join(NAMES)}")
    if args.smoke:
        if args.case:
            parser.error("--smoke runs each benchmark's own tiny case; it takes no --case")
        return _smoke(names)
    for name in names:
        module = importlib.import_module(f"benchmarks.{name}")
        extra = {"baseline": args.baseline} if args.baseline is not None else {}
        try:
            rows = module.run(cases=args.case, **extra)
            for row in rows:
                print(json.dumps(row), flush=True)
        except ValueError as exc:
            # A commit or case that does not exist is the caller's mistake: a message and exit 2.
            if not extra and not (name == "mural" and args.case):
                raise
            parser.error(str(exc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
