"""Sphinx directives that write the references from the code, so they cannot drift from it.

``.. stencil-cli::`` documents every command and flag of the ``stencil-cad`` parser
(:func:`stencil_cad.cli._parser`) as Sphinx ``program`` / ``option`` entries, and
``.. stencil-config::`` every key of the job config, from the pydantic schema's JSON Schema
(:func:`stencil_cad.config.io.json_schema`), as ``confval`` entries with type, default, range
and description. Both are parsed as reStructuredText, so each flag and key gets its own anchor
(``cmdoption-stencil-cad-run-seed``, ``confval-size.width_mm``) that ``:option:`` and
``:confval:`` roles link to and ``tests/docs/test_docs_site.py`` checks.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.application import Sphinx
from sphinx.util.docutils import SphinxDirective
from sphinx.util.parsing import nested_parse_to_nodes

PROG = "stencil-cad"


def _indent(text: str, pad: str = "   ") -> list[str]:
    return [pad + line if line else "" for line in text.splitlines()]


def _escape(text: str) -> str:
    """Text for a reStructuredText body: markup characters the help strings use literally."""
    return text.replace("\\", "\\\\").replace("*", "\\*").replace("|", "\\|").replace("_ ", "\\_ ")


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The parser's commands by name, in the order they were added."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def command_helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    """Each command's one-line help."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def documented_actions(parser: argparse.ArgumentParser) -> Iterator[argparse.Action]:
    """Every argument of a command but ``--help``."""
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        yield action


def _option_signature(action: argparse.Action) -> str:
    if not action.option_strings:
        return action.metavar or action.dest
    if action.nargs == 0:
        return ", ".join(action.option_strings)
    metavar = action.metavar or action.dest.upper()
    return ", ".join(f"{s} {metavar}" for s in action.option_strings)


def _option_body(action: argparse.Action) -> str:
    text = _escape(action.help or "")
    extra = []
    if action.choices:
        extra.append("Choices: " + ", ".join(f"``{c}``" for c in action.choices) + ".")
    if action.required:
        extra.append("Required.")
    if action.nargs in ("+", "*"):
        extra.append("Takes several values.")
    if isinstance(action, argparse._AppendAction):
        extra.append("Repeatable.")
    return " ".join([text, *extra]).strip()


def cli_rst() -> list[str]:
    """The command-line reference as reStructuredText."""
    from stencil_cad.cli import _parser

    parser = _parser()
    helps = command_helps(parser)
    lines = [".. program:: " + PROG, ""]
    for action in documented_actions(parser):
        lines += [f".. option:: {_option_signature(action)}", "", *_indent(_option_body(action)), ""]
    for name, sub in subcommands(parser).items():
        title = f"``{PROG} {name}``"
        lines += [f".. _cli-{name}:", "", title, "-" * len(title), "", _escape(helps.get(name, "")), ""]
        usage = sub.format_usage().strip().removeprefix("usage: ")
        lines += ["::", "", *_indent(usage), ""]
        lines += [f".. program:: {PROG} {name}", ""]
        for action in documented_actions(sub):
            lines += [f".. option:: {_option_signature(action)}", "", *_indent(_option_body(action)), ""]
    return lines


def _resolve(schema: dict, node: dict) -> dict:
    ref = node.get("$ref")
    if ref:
        return schema["$defs"][ref.rsplit("/", 1)[1]]
    return node


def _is_section(schema: dict, node: dict) -> bool:
    return "properties" in _resolve(schema, node)


def config_keys(schema: dict | None = None) -> Iterator[tuple[str, dict]]:
    """Every leaf key of the job config as ``(dotted.name, its JSON Schema)``, in schema order."""
    from stencil_cad.config.io import json_schema

    schema = schema or json_schema()

    def walk(prefix: str, props: dict) -> Iterator[tuple[str, dict]]:
        for name, node in props.items():
            dotted = f"{prefix}{name}"
            if _is_section(schema, node):
                yield from walk(dotted + ".", _resolve(schema, node)["properties"])
            else:
                yield dotted, node

    yield from walk("", schema["properties"])


def _type_of(schema: dict, node: dict) -> str:
    if "anyOf" in node:
        return " or ".join(dict.fromkeys(_type_of(schema, n) for n in node["anyOf"]))
    if "const" in node:
        return f"``{json.dumps(node['const'])}``"
    res = _resolve(schema, node)
    if "enum" in res:
        return "one of " + ", ".join(f"``{v}``" for v in res["enum"])
    kind = res.get("type", "any")
    if isinstance(kind, list):
        return " or ".join(kind)
    if kind == "array":
        items = res.get("items")
        return f"list of {_type_of(schema, items)}" if items else "list"
    if kind == "object":
        values = res.get("additionalProperties")
        if isinstance(values, dict) and values:
            return f"mapping to {_type_of(schema, values)}"
        return "mapping"
    return {"number": "number", "integer": "integer", "string": "string", "boolean": "boolean"}.get(
        kind, kind
    )


def _range_of(node: dict) -> str:
    parts = []
    for n in node.get("anyOf", [node]):
        lo = (
            f"> {n['exclusiveMinimum']:g}"
            if "exclusiveMinimum" in n
            else (f"≥ {n['minimum']:g}" if "minimum" in n else "")
        )
        hi = (
            f"< {n['exclusiveMaximum']:g}"
            if "exclusiveMaximum" in n
            else (f"≤ {n['maximum']:g}" if "maximum" in n else "")
        )
        if n.get("minItems") is not None or n.get("maxItems") is not None:
            parts.append(f"{n.get('minItems', 0)} to {n.get('maxItems', 'any number of')} items")
        if lo or hi:
            parts.append(", ".join(p for p in (lo, hi) if p))
    return "; ".join(parts)


def config_rst() -> list[str]:
    """The config reference as reStructuredText, one ``confval`` per key, grouped by section."""
    from stencil_cad.config.io import json_schema

    schema = json_schema()
    lines: list[str] = []
    section = None
    for dotted, node in config_keys(schema):
        head = dotted.rsplit(".", 1)[0] if "." in dotted else "(top level)"
        if head != section:
            section = head
            title = f"``{head}``" if "." in dotted else "Top level"
            lines += [title, "-" * len(title), ""]
            if "." in dotted:
                top = schema["properties"][dotted.split(".", 1)[0]]
                desc = top.get("description") or _resolve(schema, top).get("description", "")
                if desc and head.count(".") == 0:
                    lines += [_escape(desc), ""]
        default = json.dumps(node.get("default"), ensure_ascii=False) if "default" in node else "(required)"
        lines += [
            f".. confval:: {dotted}",
            f"   :type: {_type_of(schema, node)}",
            f"   :default: ``{default}``",
            "",
        ]
        rng = _range_of(node)
        if rng:
            lines += [f"   Range: {rng}.", ""]
        lines += [*_indent(_escape(node.get("description", ""))), ""]
    return lines


class _Generated(SphinxDirective):
    has_content = False
    make = staticmethod(lambda: [])

    def run(self) -> list[nodes.Node]:
        source = self.get_source_info()[0]
        text = StringList(self.make(), source=source)
        return nested_parse_to_nodes(self.state, text, allow_section_headings=True)


class CliDirective(_Generated):
    """``.. stencil-cli::``: every command and flag of ``stencil-cad``."""

    make = staticmethod(cli_rst)


class ConfigDirective(_Generated):
    """``.. stencil-config::``: every key of the job config."""

    make = staticmethod(config_rst)


def setup(app: Sphinx) -> dict:
    """Register the directives."""
    app.add_directive("stencil-cli", CliDirective)
    app.add_directive("stencil-config", ConfigDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
