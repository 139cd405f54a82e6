"""``mural_map.png``: the grid over the picture, tile names, positions and the order of work."""

from __future__ import annotations

import numpy as np

from .tiling import TileGrid, order_of_work


def mural_map(
    grid: TileGrid, layers: int, preview: np.ndarray | None = None, width_px: int = 1600
) -> np.ndarray:
    """The assembly map: the tile grid over the picture, names, positions and order of work.

    Args:
        grid: The tiles.
        layers: Number of paint layers.
        preview: ``(H, W, 3)`` picture in [0, 1] drawn faintly under the grid, or None.
        width_px: Width of the map's drawing area in px.

    Returns:
        ``(H, W, 3)`` uint8 image.
    """
    from importlib.resources import files

    from PIL import Image, ImageDraw, ImageFont

    scale = width_px / grid.width_mm
    pw, ph = width_px, max(1, int(round(grid.height_mm * scale)))
    pad, text_h = 60, 28 * (layers + 3)
    img = Image.new("RGB", (pw + 2 * pad, ph + 2 * pad + text_h), "white")
    if preview is not None:
        pic = Image.fromarray((np.clip(preview, 0, 1) * 255).astype(np.uint8)).resize((pw, ph))
        pic = Image.blend(Image.new("RGB", (pw, ph), "white"), pic, 0.35)
        img.paste(pic, (pad, pad))
    font_path = str(files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf")
    big = ImageFont.truetype(font_path, max(12, min(48, int(0.2 * min(pw / grid.cols, ph / grid.rows)))))
    small = ImageFont.truetype(font_path, 16)
    draw = ImageDraw.Draw(img)

    def px(x: float, y: float) -> tuple[float, float]:
        return pad + x * scale, pad + (grid.height_mm - y) * scale

    for t in grid.tiles:
        x0, y0 = px(t.part_box[0], t.part_box[3])
        x1, y1 = px(t.part_box[2], t.part_box[1])
        draw.rectangle([x0, y0, x1, y1], outline=(150, 150, 220), width=1)
    for x in grid.x_edges:
        draw.line([px(x, 0), px(x, grid.height_mm)], fill=(200, 30, 30), width=3)
        draw.text((px(x, 0)[0], pad + ph + 4), f"{x:.0f}", fill="black", font=small, anchor="ma")
    for y in grid.y_edges:
        draw.line([px(0, y), px(grid.width_mm, y)], fill=(200, 30, 30), width=3)
        draw.text((pad - 4, px(0, y)[1]), f"{y:.0f}", fill="black", font=small, anchor="rm")
    for t in grid.tiles:
        cx, cy = px(0.5 * (t.core[0] + t.core[2]), 0.5 * (t.core[1] + t.core[3]))
        draw.text((cx, cy), t.name, fill="black", font=big, anchor="mm")
        draw.text(
            (cx, cy + big.size),
            f"({t.core[0]:.0f}, {t.core[1]:.0f}) mm",
            fill="black",
            font=small,
            anchor="mt",
        )
    ty = pad + ph + 30
    lines = [
        f"{grid.rows} × {grid.cols} tiles, grid lines in mm from the bottom-left corner (red); "
        f"blue: each sheet's reach ({grid.halo_mm:.1f} mm halo)",
        "order of work (let each layer dry before the next):",
        *order_of_work(grid, layers),
    ]
    for line in lines:
        draw.text((pad, ty), line, fill="black", font=small)
        ty += 26
    return np.asarray(img)
