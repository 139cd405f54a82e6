"""Run the named benchmarks (all by default) and print one JSON object per line.

Each benchmark is a module ``benchmarks/<name>.py`` with ``run(cases=None)``
yielding dicts that hold at least ``bench``, ``case`` and ``seconds`` (or the
per-iteration figures that benchmark documents).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys

NAMES = [
    "decompose",
    "decompose_choice",
    "stipple",
    "spray",
    "cad",
    "wall_dxf",
    "quality",
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
]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"benchmarks to run (default: all): {', '.join(NAMES)}")
    parser.add_argument("--case", action="append", help="run only this case (repeatable)")
    args = parser.parse_args(argv)
    names = args.names or NAMES
    for name in names:
        if name not in NAMES:
            parser.error(f"unknown benchmark {name!r}; choose from {', '.join(NAMES)}")
    for name in names:
        module = importlib.import_module(f"benchmarks.{name}")
        for row in module.run(cases=args.case):
            print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
