"""Small job configs the whole-job tests share: a 36 mm two-layer soft job and a hard laser job."""

from __future__ import annotations

from pathlib import Path

#: The bundled paint catalogue a soft job snaps its paints to.
CATALOGUE = Path(__file__).resolve().parents[1] / "stencil_cad" / "data" / "example_cans.csv"

#: A hard job's can list (written next to its config as ``cans.csv``).
HARD_CANS = "name,code,hex\nPaper,P0,#f5f1e6\nRust,R1,#b0472a\nInk,K1,#141414\n"


def small_soft(name: str) -> str:
    """A 36 mm soft job in two layers on SLA rules, its paints snapped to :data:`CATALOGUE`."""
    return f"""\
name: {name}
size:
  width_mm: 36
  px_per_mm: 2
decompose:
  layers: 2
stipple:
  process: sla
paints:
  catalogue: {CATALOGUE}
"""


def small_hard(name: str, extra: str = "") -> str:
    """A 36 mm hard job cut by laser from the cans of ``cans.csv`` (:data:`HARD_CANS`), plus ``extra`` YAML."""
    return f"""\
name: {name}
mode: hard
size:
  width_mm: 36
  px_per_mm: 2
hard:
  palette: cans.csv
stipple:
  process: laser
{extra}"""
