"""The documentation site: it builds with warnings as errors, its internal links resolve, and its
references list every command, flag and config key of the code."""

from __future__ import annotations

import argparse
import html as html_lib
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PROG = "stencil-cad"


def cli_anchors() -> dict[str, str]:
    """Every command and flag of the parser, as ``{what: the anchor Sphinx gives it}``."""
    from stencil_cad.cli import _parser

    parser = _parser()
    anchors = {}
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for action in parser._actions:
        for opt in action.option_strings:
            if not isinstance(action, argparse._HelpAction):
                anchors[f"{PROG} {opt}"] = f"cmdoption-{PROG}-{opt.lstrip('-')}"
    for name, sub in subs.choices.items():
        anchors[f"{PROG} {name}"] = f"{PROG}-{name}"
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            if not action.option_strings:
                label = action.metavar or action.dest
                anchors[f"{PROG} {name} {label}"] = f"cmdoption-{PROG}-{name}-arg-{label}"
            for opt in action.option_strings:
                anchors[f"{PROG} {name} {opt}"] = f"cmdoption-{PROG}-{name}-{opt.lstrip('-')}"
    return anchors


def config_anchors() -> dict[str, str]:
    """Every leaf key of the job config (walked from the pydantic models), with its anchor."""
    from pydantic import BaseModel

    from stencil_cad.config import JobConfig

    keys = {}

    def walk(prefix: str, model: type[BaseModel]) -> None:
        for name, field in model.model_fields.items():
            ann = field.annotation
            if isinstance(ann, type) and issubclass(ann, BaseModel):
                walk(f"{prefix}{name}.", ann)
            else:
                keys[f"{prefix}{name}"] = f"confval-{prefix}{name}"

    walk("", JobConfig)
    return keys


class _Page(HTMLParser):
    """The ids and the links of one HTML page."""

    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        for key in ("href", "src"):
            if tag in ("a", "img", "link", "script") and a.get(key):
                self.links.append(a[key])


def read_site(html: Path) -> dict[Path, _Page]:
    pages = {}
    for path in html.rglob("*.html"):
        page = _Page()
        page.feed(path.read_text(encoding="utf-8"))
        pages[path.resolve()] = page
    return pages


def broken_links(html: Path) -> list[str]:
    """Every internal link or anchor of the built site that does not resolve."""
    pages = read_site(html)
    broken = []
    for path, page in pages.items():
        for link in page.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith("mailto:"):
                continue  # external: not checked here (no internet in the build)
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                broken.append(f"{path.relative_to(html)}: {link} (no such file)")
                continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else set()
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{path.relative_to(html)}: {link} (no such anchor)")
    return sorted(broken)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site as CI builds it: warnings are errors, every cross-reference must resolve."""
    out = tmp_path_factory.mktemp("html")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html", str(DOCS), str(out)],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out


@pytest.mark.slow
def test_every_internal_link_and_anchor_resolves(site):
    assert broken_links(site) == []


@pytest.mark.slow
def test_the_cli_reference_lists_every_command_and_flag(site):
    ids = read_site(site)[(site / "reference" / "cli.html").resolve()].ids
    anchors = cli_anchors()
    missing = sorted(what for what, anchor in anchors.items() if anchor not in ids)
    assert missing == [], f"{len(missing)} of {len(anchors)} commands and flags missing"
    assert len(anchors) > 100


@pytest.mark.slow
def test_the_config_reference_lists_every_key(site):
    ids = read_site(site)[(site / "reference" / "config.html").resolve()].ids
    anchors = config_anchors()
    missing = sorted(key for key, anchor in anchors.items() if anchor not in ids)
    assert missing == [], f"{len(missing)} of {len(anchors)} config keys missing"
    assert len(anchors) > 100


@pytest.mark.slow
def test_the_getting_started_page_and_the_guides_are_in_the_site(site):
    for page in ("getting-started", "guides/own-picture", "guides/printing-and-cutting", "guides/spraying"):
        assert (site / f"{page}.html").is_file(), page
    text = html_lib.unescape(
        re.sub(r"<[^>]+>", "", (site / "getting-started.html").read_text(encoding="utf-8"))
    )
    assert "pip install . && stencil-cad run" in text and "bash .ci/run" in text


def test_the_link_checker_finds_a_missing_page_and_a_missing_anchor(tmp_path):
    (tmp_path / "a.html").write_text('<p id="here"></p><a href="#here">ok</a><a href="b.html#gone">x</a>')
    (tmp_path / "b.html").write_text('<a href="c.html">x</a><a href="https://example.org/">ext</a>')
    assert broken_links(tmp_path) == ["a.html: b.html#gone (no such anchor)", "b.html: c.html (no such file)"]


def test_the_readme_is_short_and_links_into_the_docs():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    assert "pip install . && stencil-cad run" in text and "bash .ci/run" in text
    for target in ("docs/getting-started.md", "CONTRIBUTING.md", "LICENSE", "docs/overview.png"):
        assert target in text and (ROOT / target).exists(), target


def test_the_examples_figures_live_in_the_readme_only():
    """Getting started includes the README's paragraph on the example, so its figures cannot drift apart."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    start, end = "<!-- example-start -->", "<!-- example-end -->"
    assert readme.count(start) == 1 and readme.count(end) == 1
    paragraph = readme.split(start, 1)[1].split(end, 1)[0]
    page = (DOCS / "getting-started.md").read_text(encoding="utf-8")
    assert f"```{{include}} ../README.md\n:start-after: {start}\n:end-before: {end}\n```" in page
    figures = re.findall(r"\d+\.\d\d\b|\d+ × \d+ mm|\d+ seconds|\d+\.\d GB", paragraph)
    assert len(figures) >= 6, figures
    assert [f for f in figures if f in page] == []
