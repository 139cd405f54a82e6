"""The command table: the parser, its help and the API read it; each command says what it does."""

from __future__ import annotations

from stencil_cad import api, cli
from stencil_cad.command_table import COMMANDS, JOB_COMMANDS, SAVED_STAGES, command


def _names(**flags: bool) -> set[str]:
    return {c.name for c in COMMANDS if all(getattr(c, k) == v for k, v in flags.items())}


def test_every_command_has_its_arguments_and_handler():
    assert set(cli._CLI) == {c.name for c in COMMANDS}


def test_parser_lists_the_table_in_order_with_its_help():
    sub = next(a for a in cli._parser()._actions if a.dest == "command")
    assert list(sub.choices) == [c.name for c in COMMANDS]
    assert [a.help for a in sub._choices_actions] == [c.help for c in COMMANDS]


def test_the_api_takes_the_job_commands():
    assert api.COMMANDS == JOB_COMMANDS == ("run", "hard", "decompose", "stipple", "build", "simulate")
    assert api.SAVED_STAGES == SAVED_STAGES == ("stipple", "build", "simulate")


def test_what_each_command_does():
    assert _names(whole=True) == {"run", "hard"}
    assert _names(from_picture=True) == {"run", "hard", "decompose"}
    assert _names(builds=True) == {"run", "hard", "build"}
    assert _names(hard=True) == {"hard"}
    assert {c.name for c in COMMANDS if c.reads_picture} == {
        "run",
        "decompose",
        "hard",
        "simulate",
        "stipple",
    }
    assert {c.name for c in COMMANDS if c.reads_dots} == {"build", "simulate"}
    assert command("schema").job is False
