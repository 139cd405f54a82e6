"""What the fault tests check of a command-line run: its one-line error, the folder before and after."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from stencil_cad.cli import main
from stencil_cad.output import LOCK, STAGING_PREFIX

#: A small soft job (a 40 mm picture, two layers) the fault tests run and break.
SMALL = """\
name: small
size: {width_mm: 40, px_per_mm: 2}
decompose: {layers: 2}
stipple: {process: sla}
"""


def run_cli(argv, capsys):
    """The command line's exit code, stdout and stderr for ``argv``."""
    code = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def one_line_error(code, err, *needles):
    """Exit code 2 and exactly one ``stencil-cad: error:`` line holding every needle; that line."""
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.startswith("stencil-cad: error: ")]
    assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err, err
    for n in needles:
        assert n in lines[0], err
    return lines[0]


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry of ``folder``: a file's SHA-256, ``dir`` for a folder."""
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        for p in sorted(folder.iterdir())
    }


def no_leftovers(folder: Path) -> None:
    """No staging folder, lock or partial file in ``folder`` (or no folder at all)."""
    names = [p.name for p in folder.iterdir()] if folder.is_dir() else []
    assert not any(n.startswith(STAGING_PREFIX) or n == LOCK or ".partial" in n for n in names), names


def box_triangles(w: float, h: float, t: float = 1.2) -> np.ndarray:
    """The ``(12, 3, 3)`` triangles of a closed ``w x h x t`` mm box, outward-facing."""
    v = np.array(
        [[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0], [0, 0, t], [w, 0, t], [w, h, t], [0, h, t]], dtype=float
    )
    f = [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4]]
    f += [[1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]]
    return v[np.array(f)]
