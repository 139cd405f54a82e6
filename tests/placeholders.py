"""Find placeholders where a value belongs on a maker's page: "?", "None", "nan", a bare "–"."""

import html
import re

# A lone question mark (not in a word), Python's None, a NaN, or an en dash that is not a range
# between two numbers ("120.0–240.0 mm" is a range; "–" alone in a cell is a missing value).
_PATTERNS = (
    re.compile(r"(?<![\w?])\?(?![\w?])"),
    re.compile(r"\bNone\b"),
    re.compile(r"\b(?:nan|NaN)\b"),
    re.compile(r"(?<![\d.])\s*–|–\s*(?![\s\d])|(?<![\d.])–(?!\s*\d)"),
)


def html_text(page: str) -> str:
    """The visible text of an HTML page: tags, styles and data URIs removed, one line per block."""
    page = re.sub(r"<style>.*?</style>", " ", page, flags=re.S)
    page = re.sub(r"<(?:/?(?:p|li|tr|h\d|figcaption|div|section|table))[^>]*>", "\n", page)
    page = re.sub(r"<(?:td|th)[^>]*>", " | ", page)
    page = re.sub(r"<[^>]+>", " ", page)
    return html.unescape(page)


def placeholders(text: str) -> list[str]:
    """Every line of ``text`` that holds a placeholder, with the placeholder found."""
    bad = []
    for line in text.splitlines():
        for pat in _PATTERNS:
            m = pat.search(line)
            if m:
                bad.append(f"{m.group(0)!r} in: {line.strip()[:200]}")
                break
    return bad
