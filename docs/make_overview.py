"""Make docs/overview.png (input → simulated spray → stencil plate) from a run's output folder.

Usage: python docs/make_overview.py output/example
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw


def main(folder: str) -> None:
    """Compose the picture from the files of the run in `folder`."""
    out = Path(folder)
    preview = np.asarray(Image.open(out / "preview.png").convert("RGB"))
    w = preview.shape[1] // 4
    panels = [preview[:, :w], preview[:, 2 * w : 3 * w]]
    dots = Image.open(out / "layer_01_dots.png").convert("RGB").resize((w, preview.shape[0]))
    panels.append(np.asarray(dots))
    gap = np.full((preview.shape[0], 12, 3), 255, np.uint8)
    strip = np.concatenate([panels[0], gap, panels[1], gap, panels[2]], axis=1)
    im = Image.fromarray(strip)
    head = Image.new("RGB", (im.width, 28), "white")
    d = ImageDraw.Draw(head)
    for i, text in enumerate(["input", "simulated spray (4 layers)", "layer 1 stencil holes"]):
        d.text((i * (w + 12) + 8, 8), text, fill="black")
    full = Image.new("RGB", (im.width, im.height + 28), "white")
    full.paste(head, (0, 0))
    full.paste(im, (0, 28))
    full.thumbnail((1200, 1200))
    full.save(Path(__file__).with_name("overview.png"), optimize=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "output/example")
