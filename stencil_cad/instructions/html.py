"""The instruction sheet as one self-contained HTML file (``instructions.html``)."""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence

from ..names import INPUT_PNG, MURAL_MAP_PNG, PREVIEW_PNG, SIMULATED_PNG
from . import mural
from .content import _NO_CAN, Sheet, _amount, _drop, _plate_caption, _plates_text, _unit_note


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _img(images: Mapping[str, bytes], name: str, alt: str, width: str = "100%") -> str:
    data = images.get(name)
    if not data:
        return ""
    b64 = base64.b64encode(data).decode("ascii")
    return f'<img src="data:image/png;base64,{b64}" alt="{_e(alt)}" style="width:{width}">'


def _chip(hx: str) -> str:
    return f'<span class="chip" style="background:{_e(hx)}"></span>'


def tile_map_svg(tiles: Sequence[mural.MapTile], width_mm: float, height_mm: float, px: int = 480) -> str:
    """An inline SVG map of a mural's tiles (picture frame, y up drawn up)."""
    if not tiles or width_mm <= 0 or height_mm <= 0:
        return ""
    s = px / max(width_mm, height_mm)
    w, h = width_mm * s, height_mm * s
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w + 2:.0f}" height="{h + 2:.0f}" viewBox="-1 -1 {w + 2:.1f} {h + 2:.1f}">'
    ]
    parts.append(f'<rect x="0" y="0" width="{w:.1f}" height="{h:.1f}" fill="#f4f4f4" stroke="#888"/>')
    for t in tiles:
        x, y, tw, th = t.x_mm, t.y_mm, t.width_mm, t.height_mm
        name = t.name
        parts.append(
            f'<rect x="{x * s:.1f}" y="{h - (y + th) * s:.1f}" width="{tw * s:.1f}" height="{th * s:.1f}" '
            'fill="none" stroke="#222" stroke-width="1.5"/>'
        )
        parts.append(
            f'<text x="{(x + tw / 2) * s:.1f}" y="{h - (y + th / 2) * s:.1f}" font-size="13" '
            f'text-anchor="middle" font-family="sans-serif">{_e(name)}</text>'
        )
    parts.append("</svg>")
    return "".join(parts)


_CSS = """
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;color:#141414;max-width:1000px;margin:24px auto;padding:0 16px;line-height:1.4}
h1{font-size:26px;margin:0 0 4px} h2{font-size:19px;border-bottom:2px solid #141414;margin-top:28px;padding-bottom:2px}
h3{font-size:16px;margin:18px 0 6px} table{border-collapse:collapse;width:100%;font-size:13px;margin:6px 0}
th,td{border:1px solid #bbb;padding:4px 6px;text-align:left;vertical-align:top} th{background:#eee}
.chip{display:inline-block;width:26px;height:26px;border:2px solid #141414;vertical-align:middle;margin-right:6px}
.pair{display:flex;gap:14px;align-items:flex-start} .pair figure{flex:1;margin:0}
figcaption{font-size:12px;color:#555} .ok{color:#15702a;font-weight:bold} .bad{color:#b00020;font-weight:bold}
.step{page-break-inside:avoid;border:1px solid #ccc;padding:8px 10px;margin:12px 0}
.note{font-size:12px;color:#555} code{font-size:12px}
@media print{body{margin:0;max-width:none}}
"""


def _html_paints_and_wall(sheet: Sheet, images: Mapping[str, bytes]) -> list[str]:
    """The paints table (the primer row comes before it), why this order, the wall set-up and a mural's tiles."""
    e = _e
    out: list[str] = []
    for s in sheet.steps:
        t = _amount(s, sheet.unit, bare=True)
        out.append(
            f"<tr><td>{s.number}</td><td>{_chip(s.hex)}</td><td><code>{e(s.hex)}</code></td>"
            f"<td>{e(s.name) or _NO_CAN}</td><td>{e(s.plate)}</td><td>{t}</td></tr>"
        )
    out.append("</table>")
    if sheet.order_note:
        out.append(f'<p class="note">Why this order: {e(sheet.order_note)}.</p>')
    out.append(f'<p class="note">{e(_unit_note(sheet.unit))}</p>')
    if sheet.snap:
        out.append(
            "<h3>Snapped to your cans</h3><ul>" + "".join(f"<li>{e(x)}</li>" for x in sheet.snap) + "</ul>"
        )
    out.append("<h2>Set up the wall</h2><ol>" + "".join(f"<li>{e(x)}</li>" for x in sheet.wall) + "</ol>")
    if sheet.tiles:
        out.append("<h3>Tile map</h3>" + tile_map_svg(sheet.tiles, sheet.width_mm, sheet.height_mm))
        out.append(_img(images, MURAL_MAP_PNG, "the mural map: grid lines, tiles and order of work"))
    if sheet.mural is not None:
        out.append(mural.mural_html(sheet.mural, e, _chip))
    return out


def _html_steps(sheet: Sheet, images: Mapping[str, bytes]) -> list[str]:
    """One section per plate: where it goes, how to spray it, its preview and the picture after it."""
    e = _e
    out: list[str] = []
    out.append("<h2>Spray, plate by plate</h2>")
    for s in sheet.steps:
        t = _amount(s, sheet.unit)
        out.append(
            f'<div class="step"><h3>Step {s.number}: plate {e(s.plate)}, paint {_chip(s.hex)}<code>{e(s.hex)}</code>'
            f"{' ' + e(s.name) if s.name else ''}</h3>"
            f'<p class="note">{e(_drop(sheet, s))}, label towards you and readable; spray '
            f"evenly{e(t)}; let it dry, lift it out.</p>"
            + (f'<p class="note">{e(s.how)}</p>' if s.how else "")
            + '<div class="pair">'
            f"<figure>{_img(images, s.plate_image, f'plate {s.plate}')}<figcaption>"
            f"{e(_plate_caption(s, len(sheet.mural.sections) if sheet.mural else 0))}</figcaption></figure>"
            f"<figure>{_img(images, s.after_image, f'after step {s.number}')}<figcaption>The picture after "
            f"step {s.number} (simulated)</figcaption></figure></div></div>"
        )
    return out


def _html_make_and_checks(sheet: Sheet, images: Mapping[str, bytes]) -> list[str]:
    """How to print or cut each part, the paint to buy, the quality scores and the checks."""
    e = _e
    out: list[str] = []
    out.append(
        "<h2>Print or cut the plates</h2><table><tr>"
        + "".join(f"<th>{e(h)}</th>" for h in sheet.print_head)
        + "</tr>"
    )
    for r in sheet.prints:
        out.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>")
    out.append("</table>")
    if sheet.paint:
        out.append(
            "<h2>Paint to buy</h2><table><tr><th>coat</th><th>paint</th><th>covered m²</th>"
            "<th>mean opacity</th><th>ml</th><th>cans</th></tr>"
        )
        for r in sheet.paint:
            out.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>")
        out.append(f'</table><p class="note">{e(sheet.paint_note)}</p>')
    out.append("<h2>Checks</h2>")
    if sheet.scores:
        out.append("<table><tr><th>quality, simulated spray vs picture</th><th>value</th></tr>")
        out += [f"<tr><td>{e(k)}</td><td>{e(v)}</td></tr>" for k, v in sheet.scores]
        out.append("</table>")
    out.append(_img(images, PREVIEW_PNG, "input, ideal layers, simulated spray, error map"))
    out.append("<ul>")
    for text, ok in sheet.checks:
        out.append(
            f'<li><span class="{"ok" if ok else "bad"}">{"passed" if ok else "FAILED"}</span> {e(text)}</li>'
        )
    out.append("</ul>")
    if sheet.warnings:
        out.append("<h3>Warnings</h3><ul>" + "".join(f"<li>{e(w)}</li>" for w in sheet.warnings) + "</ul>")
    return out


def render_html(sheet: Sheet, images: Mapping[str, bytes]) -> str:
    """The instruction sheet as one self-contained HTML page.

    Args:
        sheet: What to show (:func:`sheet_from_manifest`).
        images: PNG bytes by file name: ``input.png`` (the picture), ``simulated.png``,
            ``swatch.png``, ``preview.png`` and, per step, the plate preview and the
            ``layer_NN_after.png`` picture. Missing images are left out.

    Returns:
        The HTML text (UTF-8).
    """
    e = _e
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{e(sheet.job)}: stencil instructions</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>{e(sheet.job)}: how to spray it</h1>",
        f'<p class="note">{"Stippled" if sheet.mode == "soft" else "Hard-edged cut"} stencils, '
        f"{_plates_text(sheet)}. Picture {sheet.width_mm:g} × {sheet.height_mm:g} mm; "
        f"viewing distance: {e(sheet.viewing)}.</p>",
        '<div class="pair">',
        f"<figure>{_img(images, INPUT_PNG, 'the picture asked for')}<figcaption>The picture "
        f"({sheet.width_mm:g} × {sheet.height_mm:g} mm)</figcaption></figure>",
        f"<figure>{_img(images, SIMULATED_PNG, 'the simulated spray')}<figcaption>What the plates "
        "give, simulated</figcaption></figure>",
        "</div>",
        "<h2>Paints, in spray order</h2>",
        f"<table><tr><th>#</th><th>colour</th><th>hex</th><th>can</th><th>plate</th><th>{e(sheet.unit)}</th></tr>",
        f"<tr><td>0</td><td>{_chip(sheet.primer_hex)}primer</td><td><code>{e(sheet.primer_hex)}</code></td>"
        f"<td>{e(sheet.primer_name) or _NO_CAN}</td><td>none: the whole surface</td><td>full coat</td></tr>",
    ]
    out += _html_paints_and_wall(sheet, images)
    out += _html_steps(sheet, images)
    out += _html_make_and_checks(sheet, images)
    out.append(f'<h2>Files</h2><p class="note">{e(", ".join(sheet.files))}</p>')
    out.append("</body></html>")
    return "\n".join(out) + "\n"
