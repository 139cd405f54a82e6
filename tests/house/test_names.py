"""House rule: every file name stencil_cad writes comes from ``stencil_cad/names.py``.

A file-name literal (``"simulated.png"``, ``f"{stem}.step"``, ``stem + "_dots.csv"``) anywhere else in
the package fails, so a renamed file is renamed in one place and the lists of what a command
writes cannot miss one. Extensions alone (``".step"``) name formats and are allowed.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
NAMES_MODULE = "names.py"
#: Extensions of the files a job writes (and of the scratch files around it).
OUTPUT_EXTENSIONS = (
    "png jpg jpeg tif tiff json yaml yml csv npz stl step stp 3mf obj ply dxf svg pdf html zip "
    "gcode bgcode sl1 ini txt"
).split()
_ALTERNATIVES = "|".join(OUTPUT_EXTENSIONS)
_NAME = re.compile(rf"^\S*[^\s.]\S*\.(?:{_ALTERNATIVES})$", re.IGNORECASE)
_EXTENSION_END = re.compile(rf"\.(?:{_ALTERNATIVES})$", re.IGNORECASE)

#: The only file names allowed outside ``names.py``: inputs the package reads, never writes.
INPUTS = {
    # Data shipped in the wheel (stencil_cad/data): the example job and the colour and can lists.
    ("imaging.py", "example.png"): "the bundled example picture",
    ("imaging.py", "example.yaml"): "the bundled example config",
    ("decompose/paints.py", "colour_names.csv"): "the shipped list of colour names",
    ("studio/settings.py", "example_cans.csv"): "the shipped example can list",
    # Slicer profiles shipped with the package, and the printer definitions Cura installs.
    ("slicing/profiles.py", "prusa_fdm.ini"): "a shipped PrusaSlicer profile",
    ("slicing/profiles.py", "prusa_sla.ini"): "a shipped PrusaSlicer profile",
    ("slicing/profiles.py", "cura_fdm.def.json"): "a shipped CuraEngine profile",
    ("slicing/slicers.py", "fdmprinter.def.json"): "Cura's printer definitions, read from its install",
    # A member of the archive PrusaSlicer writes for a resin printer, read back for its estimate.
    ("slicing/gcode.py", "config.ini"): "a member of a slicer's SL1 archive",
    ("slicing/reports.py", "config.ini"): "a member of a slicer's SL1 archive",
    # The studio's page, a static asset shipped in the wheel.
    ("studio/app.py", "index.html"): "the studio's page",
}


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def file_name_literals(source: str) -> list[tuple[int, str]]:
    """The file-name literals of a module's source: (line, text), f-string fields shown as ``{}``."""
    tree = ast.parse(source)
    skip = _docstrings(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            text = "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
            skip.update(id(v) for v in node.values)
            if _NAME.match(text):
                found.append((node.lineno, text))
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
            right = node.right
            if isinstance(right, ast.Constant) and isinstance(right.value, str):
                if _EXTENSION_END.search(right.value) and not any(c.isspace() for c in right.value):
                    skip.add(id(right))
                    found.append((node.lineno, "{} + " + right.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            if _NAME.match(node.value):
                found.append((node.lineno, node.value))
    return sorted(found)


def test_the_check_sees_names():
    src = 'a = "simulated.png"\nb = f"{s}.step"\nc = s + ".ini"\nd = ".stl"\ne = "see manifest.json"\n'
    assert [t for _, t in file_name_literals(src)] == ["simulated.png", "{}.step", "{} + .ini"]


def test_no_file_name_literal_outside_names():
    bad, used = [], set()
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel == NAMES_MODULE:
            continue
        for line, text in file_name_literals(path.read_text(encoding="utf-8")):
            if (rel, text) in INPUTS:
                used.add((rel, text))
            else:
                bad.append(f"{rel}:{line} {text!r}")
    assert not bad, "file names belong in stencil_cad/names.py: " + "; ".join(bad)
    stale = sorted(set(INPUTS) - used)
    assert not stale, f"exceptions no longer needed, drop them from INPUTS: {stale}"
