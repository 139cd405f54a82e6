"""Hostile inputs for ``python -m benchmarks limits``: each is refused (exit 2) or capped, fast and small.

Cases (each the command line in a child process that reports its own peak resident memory
and wall time, killed after 120 s and reported as ``hung``):

- ``profile_alias_bomb``: a spray profile whose ``fit:`` is a 9-level YAML alias bomb;
- ``dev_zero_config``: ``/dev/zero`` as the config;
- ``fifo_image``: a FIFO (named pipe) as the image;
- ``workers_1000``: ``--workers 1000`` (the local cluster is planned, started with the capped
  count and stopped; ``peak_mb`` is this process, ``children_peak_mb`` the largest worker);
- ``png_15000_2m``: a 15000 x 15000 px PNG onto a 2 m wide picture at 2 px/mm (the image load),
  then onto 50 m at 0.2 px/mm (``png_15000_50m``, the whole command);
- ``card_mismatch``: a photo of one card measured with another card's ``card.json``.

Targets: exit 2 (or a capped run), at most 10 s and 500 MB each; the big PNG at most 2 GB.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

CASES = [
    "profile_alias_bomb",
    "dev_zero_config",
    "fifo_image",
    "workers_1000",
    "png_15000_2m",
    "card_mismatch",
]

TIMEOUT_S = 120

_CHILD = """
import json, resource, sys, time
t0 = time.perf_counter()
extra = {}
if sys.argv[1] == "workers":
    from stencil_cad import compute
    from stencil_cad.config.compute import ComputeConfig, with_command_line
    where = with_command_line(ComputeConfig(), int(sys.argv[2]), None)
    with compute.executor(where, 10, quiet=True) as ex:
        extra = {"workers_asked": int(sys.argv[2]), "workers_started": ex.workers, "reason": ex.plan.reason}
    code = 0
elif sys.argv[1] == "load":
    from stencil_cad.config import io
    from stencil_cad.pipeline import load_picture
    cfg = io.load_config(sys.argv[2]).model_copy(update={"image": sys.argv[3]})
    pic = load_picture(cfg)
    extra, code = {"grid_px": list(pic.rgb.shape[:2])}, 0
else:
    from stencil_cad.cli import main
    code = main(sys.argv[1:])
use = resource.getrusage(resource.RUSAGE_SELF)
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"exit": code, "seconds": round(time.perf_counter() - t0, 2), **extra,
                  "cpu_seconds": round(use.ru_utime + use.ru_stime, 2),
                  "peak_mb": round(use.ru_maxrss / 1024.0, 1),
                  "children_peak_mb": round(kids.ru_maxrss / 1024.0, 1)}))
"""

SMALL = "name: hostile\nsize: {width_mm: 40, px_per_mm: 2}\ndecompose: {layers: 2}\nstipple: {process: sla}\n"

BOMB = "\n".join(
    [
        'a: &a ["x", "x", "x", "x", "x", "x", "x", "x", "x"]',
        *(f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]" for p, c in zip("abcdefg", "bcdefgh", strict=True)),
        "spread_k: 0.1",
        "bleed_sigma_mm: 0.4",
        "deposit_per_pass: 0.5",
        f"fit: [{', '.join(['*h'] * 9)}]",
    ]
)


def _child(args: list[str]) -> dict:
    return child_row(_CHILD, args, TIMEOUT_S)


def child_row(script: str, args: list[str], timeout_s: float | None = None) -> dict:
    """Run ``script`` in a child Python with ``args``: its last JSON line, its exit and stderr's last line."""
    try:
        proc = subprocess.run(
            [sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=timeout_s
        )
    except subprocess.TimeoutExpired:
        return {"exit": None, "hung": True, "seconds": timeout_s}
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    row = json.loads(lines[-1]) if lines else {"exit": proc.returncode}
    err = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    if err:
        row["stderr"] = err[-1][:300]
    return row


def _judge(row: dict, peak_mb: float = 500, seconds: float = 10, exits=(2,)) -> dict:
    row["targets"] = {"exit": list(exits), "peak_mb": peak_mb, "seconds": seconds}
    row["met"] = (
        row.get("exit") in exits and row.get("peak_mb", 1e9) <= peak_mb and row.get("seconds", 1e9) <= seconds
    )
    return row


def _card_mismatch(tmp: Path) -> dict:
    """A synthetic photo of the card of an SLA job, measured with the card.json of an FDM job's card."""
    make = """
import json, sys
import numpy as np
from stencil_cad.config.io import parse_config
from stencil_cad.config.spray import CanConstants, SprayConfig
from stencil_cad.testcard import card_description, card_layout
from stencil_cad.testcard.synthetic import PhotoSettings, synthetic_photo
shot = card_layout(parse_config({"stipple": {"process": "sla"}}, "photo"), [3.0, 12.0])
other = card_layout(parse_config({"stipple": {"process": "fdm"}}, "card"), [3.0, 12.0])
can = CanConstants(spread_k=0.1, bleed_sigma_mm=0.4, deposit_per_pass=0.55)
data, suffix = synthetic_photo(shot, SprayConfig(model="physical", can=can), 4, np.random.default_rng(0),
                               PhotoSettings(jpeg_quality=None))
open(sys.argv[1] + suffix, "wb").write(data)
open(sys.argv[2], "w").write(json.dumps(card_description(other)))
print(sys.argv[1] + suffix)
"""
    photo, card = tmp / "photo", tmp / "card.json"
    made = subprocess.run(
        [sys.executable, "-c", make, str(photo), str(card)], check=True, capture_output=True, text=True
    )
    photo = Path(made.stdout.strip().splitlines()[-1])
    return _child(["calibrate", str(photo), "--card", str(card), "--out", str(tmp / "p.yaml")])


def run(cases=None):
    cases = [c for c in (cases or CASES) if c in CASES]
    with tempfile.TemporaryDirectory(prefix="stencil_hostile_") as tmp:
        tmp = Path(tmp)
        cfg = tmp / "job.yaml"
        cfg.write_text(SMALL)
        for case in cases:
            if case == "profile_alias_bomb":
                (tmp / "can.yaml").write_text(BOMB)
                job = tmp / "bomb.yaml"
                job.write_text(SMALL + "spray: {model: physical, profile: can.yaml}\n")
                row = _judge(_child(["run", str(job), "--out", str(tmp / "o1"), "-q"]))
            elif case == "dev_zero_config":
                row = _judge(_child(["run", "/dev/zero", "--out", str(tmp / "o2"), "-q"]))
            elif case == "fifo_image":
                fifo = tmp / "pipe.png"
                os.mkfifo(fifo)
                row = _judge(_child(["run", str(cfg), "--image", str(fifo), "--out", str(tmp / "o3"), "-q"]))
            elif case == "workers_1000":
                row = _child(["workers", "1000"])
                row = _judge(row, exits=(0,))
                row["met"] = row["met"] and row.get("workers_started", 1e9) <= (os.cpu_count() or 1)
            elif case == "png_15000_2m":
                from benchmarks.limits import _make

                img = tmp / "big.png"
                _make(img, 15000, 15000)
                job = tmp / "big.yaml"
                job.write_text("name: big\nsize: {width_mm: 2000, px_per_mm: 2}\ndecompose: {layers: 2}\n")
                row = _judge(_child(["load", str(job), str(img)]), peak_mb=2000, exits=(0, 2))
                row.update(bench="limits", case=case)
                yield row
                # The same file onto a 50 m picture at 0.2 px/mm: a 100 MP grid, refused up front.
                job.write_text(
                    "name: huge\nsize: {width_mm: 50000, px_per_mm: 0.2}\ndecompose: {layers: 2}\n"
                )
                row = _judge(_child(["run", str(job), "--image", str(img), "--out", str(tmp / "o5"), "-q"]))
                case = "png_15000_50m"
                img.unlink()
            else:
                row = _judge(_card_mismatch(tmp))
            row.update(bench="limits", case=case)
            yield row
