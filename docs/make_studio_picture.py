"""Make docs/studio.png (the studio's page with the example's sprayed preview) from a real session.

Starts the studio on a free loopback port with a temporary workspace, opens its page in headless
Chromium (Debian's ``chromium`` and ``chromium-driver``, through Selenium), waits for the bundled
example's final preview, zooms in a little so the holes show, and keeps the window as the README
shows it.

Usage: python docs/make_studio_picture.py
"""

from __future__ import annotations

import shutil
import tempfile
import threading
import time
from pathlib import Path

#: Browser window of the screenshot, px.
WINDOW = (1400, 900)


def main() -> None:
    """Screenshot a studio session into ``docs/studio.png``."""
    import uvicorn
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    from stencil_cad.studio import Workspace, create_app
    from stencil_cad.studio.server import address, bind

    chromium, driver_path = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium is None or driver_path is None:
        raise SystemExit(
            "chromium and chromedriver are needed (Debian: apt install chromium chromium-driver)"
        )
    with tempfile.TemporaryDirectory() as tmp:
        sock = bind("127.0.0.1", 0)
        server = uvicorn.Server(
            uvicorn.Config(create_app(Workspace(Path(tmp))), log_level="warning", lifespan="off")
        )
        threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True).start()
        opts = webdriver.ChromeOptions()
        opts.binary_location = chromium
        for flag in ("--headless", "--no-sandbox", "--disable-gpu", f"--window-size={WINDOW[0]},{WINDOW[1]}"):
            opts.add_argument(flag)
        driver = webdriver.Chrome(options=opts, service=Service(driver_path))
        try:
            driver.get(address(sock, "127.0.0.1"))
            deadline = time.monotonic() + 300
            while "final" not in driver.find_element("id", "f-level").text:
                if time.monotonic() > deadline:
                    raise SystemExit("no final preview within 5 minutes")
                time.sleep(0.2)
            driver.execute_script(
                "document.getElementById('slider').value = 40;"
                "document.getElementById('slider').dispatchEvent(new Event('input'));"
            )
            out = Path(__file__).resolve().parent / "studio.png"
            driver.save_screenshot(str(out))
            print(f"wrote {out}")  # noqa: T201 - a script tells what it wrote
        finally:
            driver.quit()
            server.should_exit = True


if __name__ == "__main__":
    main()
