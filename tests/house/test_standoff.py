"""House rule: the stand-off a job uses is read through one accessor.

``wall.standoff_mm`` means one thing, what the maker set (null: the job chooses). What the job
uses, whoever set it, is :attr:`stencil_cad.config.JobConfig.standoff` (its design stand-off and
its walls). Outside ``config/``, reading the key itself, or the job's private choice, fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
HOME = "config/"


def standoff_reads(rel: str, tree: ast.Module) -> list[tuple[int, str]]:
    """The places a module reads the stand-off other than through ``JobConfig.standoff``: (line, what)."""
    if rel.startswith(HOME):
        return []
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        owner = node.value
        # ``cfg.wall.standoff_mm``, or a wall section held in a local (``wc``, ``wall_cfg``); a built
        # wall part's ``standoff_mm`` is its own height, not the config's.
        on_wall = (isinstance(owner, ast.Attribute) and owner.attr in ("wall", "wall_cfg")) or (
            isinstance(owner, ast.Name) and owner.id in ("wall_cfg", "wc")
        )
        if node.attr == "standoff_mm" and on_wall:
            found.append((node.lineno, "wall.standoff_mm"))
        elif node.attr in ("_standoff_chosen", "heights") and (on_wall or node.attr.startswith("_")):
            found.append((node.lineno, node.attr))
    return sorted(found)


def test_the_stand_off_is_read_through_one_accessor():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bad += [f"{rel}:{line}: {what}" for line, what in standoff_reads(rel, tree)]
    assert not bad, "read the stand-off through JobConfig.standoff:\n" + "\n".join(bad)


def test_the_rule_sees_each_other_way():
    source = (
        "a = cfg.wall.standoff_mm[0]\n"
        "b = cfg.wall.heights()\n"
        "c = wc.standoff_mm\n"
        "d = cfg._standoff_chosen\n"
        "e = cfg.standoff.design_mm\n"
        "f = task.standoff_mm\n"
    )
    assert [line for line, _ in standoff_reads("pipeline/x.py", ast.parse(source))] == [1, 2, 3, 4]
    assert standoff_reads("config/job.py", ast.parse(source)) == []
