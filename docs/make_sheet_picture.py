"""Make docs/instructions.png (the top of the instruction sheet) from a run's output folder.

Opens the run's ``instructions.html`` in headless Chromium (Debian's ``chromium``) and keeps
the top of the page as the README shows it.

Usage: stencil-cad run && python docs/make_sheet_picture.py output/example
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from PIL import Image

#: Browser window of the screenshot, px: the sheet's layout width and the part the README shows.
WINDOW = (1200, 1500)


def main(folder: str) -> None:
    """Screenshot the sheet of the run in ``folder`` into ``docs/instructions.png``."""
    page = (Path(folder) / "instructions.html").resolve()
    if not page.is_file():
        raise SystemExit(f"{page}: no instruction sheet here; run `stencil-cad run` first")
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        raise SystemExit("chromium is not installed (Debian: apt install chromium)")
    with tempfile.TemporaryDirectory() as tmp:
        shot = Path(tmp) / "shot.png"
        subprocess.run(
            [
                browser,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--no-first-run",
                f"--user-data-dir={tmp}/profile",
                "--hide-scrollbars",
                f"--window-size={WINDOW[0]},{WINDOW[1]}",
                f"--screenshot={shot}",
                page.as_uri(),
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
        with Image.open(shot) as im:
            im.convert("RGB").save(Path(__file__).with_name("instructions.png"), optimize=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "output/example")
