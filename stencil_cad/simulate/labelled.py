"""Previews a maker can read: titled panels, scale bars in mm, colour bars, keys and labels.

Every picture here is drawn with Pillow's ``ImageDraw`` and the bundled DejaVu Sans Bold,
so the text looks the same on every machine. Functions take arrays and plain values and
return ``(H, W, 3)`` uint8 images; the pipeline writes them.

Orientation: every preview shows the picture as it is seen on the wall, x to the right
and y up (the picture frame); a plate preview shows the plate from its top side, as it
sits in the wall, with its key tabs and label area, so it can be matched with the print.
"""

from __future__ import annotations

import functools
import math
import textwrap
from collections.abc import Sequence
from importlib import resources

import numpy as np
from PIL import Image, ImageDraw, ImageFont

__all__ = [
    "job_preview",
    "opacity_card",
    "plate_card",
    "swatch_card",
    "sweep_card",
]

INK = (20, 20, 20)
GREY = (120, 120, 120)
PAPER = (255, 255, 255)
PAD = 10


@functools.lru_cache(maxsize=16)
def font(size: int) -> ImageFont.FreeTypeFont:
    """The bundled DejaVu Sans Bold at ``size`` px."""
    path = resources.files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf"
    with resources.as_file(path) as p:
        return ImageFont.truetype(str(p), size)


def _u8(img: np.ndarray) -> np.ndarray:
    a = np.asarray(img)
    if a.dtype != np.uint8:
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])


def _text_size(text: str, size: int) -> tuple[int, int]:
    box = font(size).getbbox(text)
    return int(box[2] - box[0]), int(box[3] - min(box[1], 0))


def _nice_length(max_mm: float) -> float:
    """The largest 1-2-5 length in mm not above ``max_mm``."""
    if max_mm <= 0:
        return 0.0
    e = 10.0 ** math.floor(math.log10(max_mm))
    for m in (5.0, 2.0, 1.0):
        if m * e <= max_mm:
            return m * e
    return e


def _fmt_mm(v: float) -> str:
    return f"{v:g} mm" if v < 1000 else f"{v / 1000:g} m"


def scale_bar(
    draw: ImageDraw.ImageDraw, x: int, y: int, px_per_mm: float, max_px: int, size: int = 13
) -> int:
    """Draw a scale bar with its length in mm at ``(x, y)`` (top-left); returns its height in px."""
    length_mm = _nice_length(max_px / px_per_mm)
    if length_mm <= 0:
        return 0
    w = max(int(round(length_mm * px_per_mm)), 1)
    h = 6
    half = w // 2
    draw.rectangle([x, y, x + half, y + h], fill=INK)
    draw.rectangle([x + half, y, x + w, y + h], fill=PAPER, outline=INK)
    draw.rectangle([x, y, x + w, y + h], outline=INK)
    draw.text((x, y + h + 2), "0", font=font(size), fill=INK)
    label = _fmt_mm(length_mm)
    draw.text((x + w - _text_size(label, size)[0] // 2, y + h + 2), label, font=font(size), fill=INK)
    return h + 2 + _text_size("0", size)[1] + 2


def _canvas(w: int, h: int) -> tuple[Image.Image, ImageDraw.ImageDraw]:
    img = Image.new("RGB", (max(int(w), 1), max(int(h), 1)), PAPER)
    return img, ImageDraw.Draw(img)


def _panel(
    image: np.ndarray,
    title: str,
    subtitle: str = "",
    px_per_mm: float | None = None,
    width: int | None = None,
) -> Image.Image:
    """One titled panel: title, optional subtitle, the image, a scale bar under it."""
    im = Image.fromarray(_u8(image))
    if width is not None and im.width != width:
        im = im.resize((width, max(int(round(im.height * width / im.width)), 1)), Image.Resampling.LANCZOS)
        if px_per_mm is not None:
            px_per_mm = px_per_mm * width / image.shape[1]
    ts, ss = 18, 13
    head = _text_size("Ag", ts)[1] + 6 + (_text_size("Ag", ss)[1] + 4 if subtitle else 0)
    foot = 34 if px_per_mm else 0
    out, d = _canvas(im.width + 2 * PAD, head + im.height + foot + 2 * PAD)
    d.text((PAD, PAD), title, font=font(ts), fill=INK)
    if subtitle:
        d.text((PAD, PAD + _text_size("Ag", ts)[1] + 6), subtitle, font=font(ss), fill=GREY)
    out.paste(im, (PAD, PAD + head))
    d.rectangle([PAD - 1, PAD + head - 1, PAD + im.width, PAD + head + im.height], outline=GREY)
    if px_per_mm:
        scale_bar(d, PAD, PAD + head + im.height + 8, px_per_mm, max(im.width // 3, 10))
    return out


def _row(panels: Sequence[Image.Image], gap: int = 6) -> np.ndarray:
    h = max(p.height for p in panels)
    w = sum(p.width for p in panels) + gap * (len(panels) - 1)
    out, _ = _canvas(w, h)
    x = 0
    for p in panels:
        out.paste(p, (x, 0))
        x += p.width + gap
    return np.asarray(out)


def colour_bar(
    ramp, vmax: float, height: int, label: str, ticks: int = 4, open_top: bool = True
) -> Image.Image:
    """A vertical colour bar: ``ramp(values, vmax)`` from 0 (bottom) to ``vmax`` (top), ticks and a label.

    ``open_top`` marks the top tick ``vmax+`` (values above it share the top colour).
    """
    bar_w = 18
    values = np.linspace(vmax, 0.0, max(height, 2))
    strip = _u8(ramp(values[:, None].repeat(bar_w, axis=1), vmax))
    size = 12
    tw = max(_text_size(f"{vmax * k / ticks:g}", size)[0] for k in range(ticks + 1))
    lw = _text_size(label, size)[0]
    out, d = _canvas(max(bar_w + 6 + tw, lw) + 2 * PAD + 4, height + 2 * PAD + 20)
    d.text((PAD, PAD), label, font=font(size), fill=INK)
    top = PAD + 20
    out.paste(Image.fromarray(strip), (PAD, top))
    d.rectangle([PAD - 1, top - 1, PAD + bar_w, top + height], outline=GREY)
    for k in range(ticks + 1):
        v = vmax * k / ticks
        y = top + int(round((1 - k / ticks) * (height - 1)))
        d.line([PAD + bar_w, y, PAD + bar_w + 4, y], fill=INK)
        lab = f"{v:g}" + ("+" if k == ticks and open_top else "")
        d.text((PAD + bar_w + 6, y - 7), lab, font=font(size), fill=INK)
    return out


def job_preview(
    input_rgb: np.ndarray,
    decomposition_rgb: np.ndarray,
    simulated_rgb: np.ndarray,
    error_map: np.ndarray,
    error_ramp,
    de_max: float,
    mm_per_px: float,
    notes: Sequence[str] = (),
    panel_px: int = 360,
) -> np.ndarray:
    """Input | decomposition | simulated spray | error map, each titled, with scale bars and a colour bar.

    Args:
        input_rgb: ``(H, W, 3)`` the input on the simulation grid, in [0, 1].
        decomposition_rgb: ``(H, W, 3)`` the exact composite of the layers (what perfectly
            sprayed opacities would give), in [0, 1].
        simulated_rgb: ``(H, W, 3)`` the simulated spray through the plates, in [0, 1].
        error_map: ``(H, W)`` per-pixel CIEDE2000 between input and simulated spray.
        error_ramp: ``ramp(values, vmax) -> (..., 3)`` RGB in [0, 1] used for the map.
        de_max: ΔE2000 at the top of the ramp.
        mm_per_px: Pixel size of these images in mm.
        notes: Lines printed under the panels (e.g. the scores).
        panel_px: Width of each panel in px. Defaults to 360.

    Returns:
        ``(H', W', 3)`` uint8 image.
    """
    ppm = 1.0 / mm_per_px
    panels = [
        _panel(input_rgb, "1 Input", "the picture asked for", ppm, panel_px),
        _panel(decomposition_rgb, "2 Layers, ideal", "primer + paints, opacity exact", ppm, panel_px),
        _panel(simulated_rgb, "3 Simulated spray", "through the plates, as sprayed", ppm, panel_px),
        _panel(_u8(error_ramp(error_map, de_max)), "4 Error, 1 vs 3", "CIEDE2000 per pixel", ppm, panel_px),
    ]
    img_h = panels[0].height - 2 * PAD - 34 - _text_size("Ag", 18)[1] - 6 - _text_size("Ag", 13)[1] - 4
    bar = colour_bar(error_ramp, de_max, max(img_h, 40), "ΔE2000")
    body = Image.fromarray(_row([*panels, bar]))
    if not notes:
        return np.asarray(body)
    line_h = _text_size("Ag", 13)[1] + 4
    out, d = _canvas(body.width, body.height + line_h * len(notes) + PAD)
    out.paste(body, (0, 0))
    for k, line in enumerate(notes):
        d.text((PAD, body.height + k * line_h), line, font=font(13), fill=INK)
    return np.asarray(out)


def sweep_card(
    panels: Sequence[np.ndarray],
    factors: Sequence[float],
    mm_per_px: float,
    panel_px: int = 360,
    unit: str = "spray time",
) -> np.ndarray:
    """The sweep of the amount of paint: one titled panel per factor (``passes × f``) with scale bars.

    ``unit`` names the amount: ``passes`` (the physical model: the paint of f times each layer's
    passes, a heavier or lighter hand) or ``spray time`` (the paper's model).
    """
    ppm = 1.0 / mm_per_px
    what = "paint per layer" if unit == "passes" else "spray time"
    titled = [
        _panel(
            p,
            f"{what} × {f:g}",
            "as planned" if abs(f - 1.0) < 1e-9 else f"{f:g} × the planned {what}",
            ppm,
            panel_px,
        )
        for p, f in zip(panels, factors, strict=True)
    ]
    return _row(titled)


def opacity_card(
    alpha: np.ndarray, mm_per_px: float, layer: int, layers: int, paint_hex: str, width_px: int = 480
) -> np.ndarray:
    """A layer's target opacity, dark = more paint, with a tone bar and a scale bar."""
    img = 1.0 - np.clip(np.asarray(alpha, dtype=np.float64), 0.0, 1.0)
    panel = _panel(
        img,
        f"Layer {layer:02d} of {layers:02d}: target opacity of {paint_hex}",
        "dark = more paint, white = none",
        1.0 / mm_per_px,
        width_px,
    )
    grey = lambda v, vmax: np.repeat((1.0 - np.asarray(v) / vmax)[..., None], 3, axis=-1)  # noqa: E731
    bar = colour_bar(grey, 100.0, max(panel.height - 120, 40), "opacity %", open_top=False)
    return _row([panel, bar])


def _frame(ring: np.ndarray, margin_mm: float = 3.0):
    lo = ring.min(axis=0) - margin_mm
    hi = ring.max(axis=0) + margin_mm
    return lo, hi


#: Longest side of a plate card in pixels. A 4 m mural's whole-picture card at 4 px/mm
#: would be 16,000 px wide (480 MB of RGB per layer, and PIL's drawing took the stipple
#: stage of a 10 m² mural to 8.3 GB); 6,000 px still draws 0.5 mm holes of a 1.5 m picture.
CARD_MAX_SIDE_PX = 6000


def plate_card(
    outline_ring: np.ndarray,
    label_box: tuple[float, float, float, float],
    picture_mm: tuple[float, float],
    layer: int,
    layers: int,
    paint_hex: str,
    paint_name: str = "",
    circles_xy_r: np.ndarray | None = None,
    polygons: Sequence | None = None,
    job: str = "",
    px_per_mm: float = 4.0,
) -> np.ndarray:
    """A plate seen from its top side in the wall: outline with key tabs, holes or cut-outs, label area.

    Args:
        outline_ring: ``(M, 2)`` plate outline in picture mm (key tabs included).
        label_box: ``(x0, y0, x1, y1)`` of the label area in mm.
        picture_mm: ``(width, height)`` of the picture area in mm.
        layer: 1-based layer number.
        layers: Number of layers.
        paint_hex: The layer's paint.
        paint_name: The can's name, when known.
        circles_xy_r: ``(N, 3)`` holes (x, y, r) in mm, or None.
        polygons: Hard-mode cut-outs (``(outer, holes)`` pairs in mm), or None.
        job: Job name, printed in the header.
        px_per_mm: Drawing resolution in px per mm. Defaults to 4; lowered so that the
            plate's longer side stays within :data:`CARD_MAX_SIDE_PX`.

    Returns:
        ``(H, W, 3)`` uint8 image: a header (layer, paint, count), the plate, a key and a scale bar.
    """
    ring = np.asarray(outline_ring, dtype=np.float64)
    lo, hi = _frame(ring)
    px_per_mm = min(px_per_mm, CARD_MAX_SIDE_PX / max(float(np.max(hi - lo)), 1e-9))
    w = int(math.ceil((hi[0] - lo[0]) * px_per_mm))
    h = int(math.ceil((hi[1] - lo[1]) * px_per_mm))

    plate, d = _canvas(w, h)
    count = _draw_plate(
        d, ring, lo, hi, px_per_mm, label_box, picture_mm, f"LAYER {layer}/{layers}  {paint_hex}", polygons
    )
    arr = np.asarray(plate).copy()
    if circles_xy_r is not None and len(circles_xy_r):
        arr, count = _with_holes(arr, circles_xy_r, lo, hi, px_per_mm, w, h)
    what = "holes" if circles_xy_r is not None else "cut-outs"
    title = f"Plate {layer:02d} of {layers:02d}" + (f"  ·  {job}" if job else "")
    sub = f"paint {paint_hex}" + (f" ({paint_name})" if paint_name else "") + f"  ·  {count} {what}"
    return np.asarray(_with_key(_panel(arr, title, sub, None), what, px_per_mm, w))


def _draw_plate(d, ring, lo, hi, px_per_mm: float, label_box, picture_mm, label: str, polygons) -> int:
    """Draw the plate, its label area and the picture's edge (and hard-mode cut-outs); how many cut-outs."""

    def to_px(pts: np.ndarray) -> list[tuple[float, float]]:
        p = np.asarray(pts, dtype=np.float64)
        return list(
            zip(
                ((p[:, 0] - lo[0]) * px_per_mm).tolist(),
                ((hi[1] - p[:, 1]) * px_per_mm).tolist(),
                strict=True,
            )
        )

    d.polygon(to_px(ring), fill=(236, 236, 236), outline=(60, 60, 60), width=2)
    x0, y0, x1, y1 = label_box
    d.rectangle(
        [
            (x0 - lo[0]) * px_per_mm,
            (hi[1] - y1) * px_per_mm,
            (x1 - lo[0]) * px_per_mm,
            (hi[1] - y0) * px_per_mm,
        ],
        outline=GREY,
    )
    ls = max(int((y1 - y0) * px_per_mm * 0.6), 8)
    d.text(((x0 - lo[0]) * px_per_mm + 4, (hi[1] - y1) * px_per_mm + 1), label, font=font(ls), fill=GREY)
    pw, ph = picture_mm
    d.rectangle(
        [
            (0 - lo[0]) * px_per_mm,
            (hi[1] - ph) * px_per_mm,
            (pw - lo[0]) * px_per_mm,
            (hi[1] - 0) * px_per_mm,
        ],
        outline=(190, 190, 190),
    )
    count = 0
    if polygons:
        for outer, holes in polygons:
            d.polygon(to_px(np.asarray(outer)), fill=INK)
            for hole in holes:
                d.polygon(to_px(np.asarray(hole)), fill=(236, 236, 236))
            count += 1
    return count


def _with_holes(
    arr: np.ndarray, circles_xy_r, lo, hi, px_per_mm: float, w: int, h: int
) -> tuple[np.ndarray, int]:
    """The plate drawing with its round holes in ink, and how many there are."""
    from ..model import DotSet
    from .previews import dots_preview

    c = np.asarray(circles_xy_r, dtype=np.float64).reshape(-1, 3)
    holes = dots_preview(
        DotSet(c[:, :2], c[:, 2]), w / px_per_mm, h / px_per_mm, px_per_mm, (lo[0], hi[1] - h / px_per_mm)
    )
    cover = (1.0 - holes.astype(np.float64) / 255.0)[..., None]
    return (arr * (1.0 - cover) + np.array(INK) * cover).astype(np.uint8), len(c)


def _with_key(panel: Image.Image, what: str, px_per_mm: float, w: int) -> Image.Image:
    """The panel with a key under it: what the drawing shows, which way is up, the scale."""
    key_lines = [
        "seen from the top, as it sits in the wall; picture edge = thin line",
        f"black = {'hole' if what == 'holes' else 'cut-out'} (paint passes), grey = plate; tabs = key (fits one way)",
    ]
    line_h = _text_size("Ag", 12)[1] + 4
    out, dd = _canvas(max(panel.width, 520), panel.height + line_h * len(key_lines) + 44)
    out.paste(panel, (0, 0))
    y = panel.height - PAD + 2
    for line in key_lines:
        dd.text((PAD, y), line, font=font(12), fill=INK)
        y += line_h
    scale_bar(dd, PAD, y + 4, px_per_mm, max(w // 3, 10))
    # "Up" arrow at the right of the scale bar.
    ax = min(out.width - PAD - 20, PAD + w)
    dd.line([ax, y + 36, ax, y + 6], fill=INK, width=3)
    dd.polygon([(ax - 7, y + 12), (ax + 7, y + 12), (ax, y + 2)], fill=INK)
    dd.text((ax - 40, y + 14), "up", font=font(12), fill=INK)
    return out


def swatch_card(
    primer_hex: str,
    paints: Sequence[dict],
    order_note: str = "",
    primer_name: str = "",
    chip_px: int = 56,
    unit: str = "spray time",
) -> np.ndarray:
    """The primer and the paints in spray order: numbered, bordered chips, hex, can name, spray time.

    Args:
        primer_hex: The primer colour.
        paints: Per layer in spray order, dicts with ``hex`` and optionally ``name`` (the can),
            ``spray_time`` (the layer's amount, in ``unit``) and ``note``.
        order_note: One line on why this is the spray order.
        primer_name: The primer can's name, when known.
        chip_px: Side of each colour chip in px. Defaults to 56.
        unit: What the amount per layer counts: ``spray time`` (paper model) or ``passes``.

    Returns:
        ``(H, W, 3)`` uint8 image.
    """
    rows = [("0", primer_hex, primer_name, "primer: the whole surface, first", "")]
    for i, p in enumerate(paints):
        t = p.get("spray_time")
        rows.append(
            (
                str(i + 1),
                p["hex"],
                p.get("name", "") or "",
                p.get("note", f"plate layer_{i + 1:02d}"),
                (f"{t:g} passes" if unit == "passes" else f"{unit} {t:.3g}") if t is not None else "",
            )
        )
    size = 15
    row_h = chip_px + 8
    note_lines = textwrap.wrap(order_note, 80) if order_note else []
    texts = [_text_size(r[1] + "  " + r[2], size)[0] for r in rows] + [_text_size(r[3], 12)[0] for r in rows]
    width = max(
        [PAD * 2 + 34 + chip_px + 14 + t for t in texts]
        + [PAD * 2 + _text_size(n, 12)[0] for n in note_lines]
        + [360]
    )
    head = 36 + 18 * len(note_lines)
    out, d = _canvas(width, head + row_h * len(rows) + PAD)
    d.text((PAD, PAD), "Paints in spray order", font=font(18), fill=INK)
    for k, line in enumerate(note_lines):
        d.text((PAD, PAD + 26 + 18 * k), line, font=font(12), fill=GREY)
    for k, (num, hx, name, note, time_) in enumerate(rows):
        y = head + k * row_h
        d.text((PAD, y + chip_px // 2 - 10), num, font=font(20), fill=INK)
        x = PAD + 34
        rgb = tuple(int(hx[j : j + 2], 16) for j in (1, 3, 5))
        # Every chip is bordered, so a white primer shows on white paper.
        d.rectangle([x, y, x + chip_px, y + chip_px], fill=rgb, outline=INK, width=2)
        tx = x + chip_px + 14
        d.text((tx, y + 2), hx + (f"  {name}" if name else ""), font=font(size), fill=INK)
        d.text((tx, y + 24), note, font=font(12), fill=GREY)
        if time_:
            d.text((tx, y + 40), time_, font=font(12), fill=GREY)
    return np.asarray(out)
