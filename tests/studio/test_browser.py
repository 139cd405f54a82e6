"""The studio in Debian's Chromium, driven by Selenium through Debian's chromedriver (no browser download).

Opens the page, uploads the example picture, changes the layer count and sees the preview change, makes
the job (cropped) and downloads the zip; a broken upload shows the command line's message and writes nothing; the
calibration wizard makes its card and fits a synthetic photo of it.
"""

import io
import threading
import time
import urllib.request
import zipfile

import pytest
from readers import need

from stencil_cad.imaging import example_image_path
from stencil_cad.studio import Workspace, create_app
from stencil_cad.studio.server import address, bind

pytestmark = pytest.mark.slow


@pytest.fixture
def studio(tmp_path):
    """A studio served by uvicorn on a free loopback port, in a thread; its address and workspace."""
    import uvicorn

    ws = Workspace(tmp_path / "ws")
    sock = bind("127.0.0.1", 0)
    server = uvicorn.Server(uvicorn.Config(create_app(ws), log_level="warning", lifespan="off"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    yield address(sock, "127.0.0.1"), ws
    server.should_exit = True
    thread.join(timeout=10)
    sock.close()


@pytest.fixture
def browser(tmp_path):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = need("chromium")
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        opts.add_argument(flag)
    driver = webdriver.Chrome(options=opts, service=Service(need("chromedriver")))
    yield driver
    driver.quit()


def wait_for(check, timeout=120.0, what="the page"):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = check()
        if got:
            return got
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def final_preview(driver):
    """The figures once the page shows a final preview: (holes text, S-CIELAB text)."""
    by = "id"
    return wait_for(
        lambda: (
            "final" in driver.find_element(by, "f-level").text
            and driver.find_element(by, "status").text == "ready"
            and (driver.find_element(by, "f-holes").text, driver.find_element(by, "f-scielab").text)
        ),
        timeout=900,
        what="a final preview",
    )


def first_preview(driver):
    """The page's first preview (any level): the page is up and its settings reach the server."""
    return wait_for(
        lambda: driver.find_element("id", "f-level").text not in ("", "—"), what="a first preview"
    )


def set_field(driver, field, value):
    """Type ``value`` into the setting ``field`` and leave it (leaving the field is the change)."""
    box = driver.find_element("id", field)
    box.clear()
    box.send_keys(value)
    driver.find_element("id", "distance_m").click()


def test_upload_change_layers_make_download(studio, browser, tmp_path):
    url, ws = studio
    by = "id"
    browser.get(url)
    # A 60 mm picture keeps the test short: each final preview runs the job's plate-design trials. The
    # 150 mm preview the page started is stale once the width changes, and is cancelled.
    first_preview(browser)
    set_field(browser, "width_mm", "60")
    bundled = final_preview(browser)
    # The last preview gives the range over the can prior (no can is measured yet).
    assert "depending on your can" in browser.find_element(by, "f-range").text
    # A broken upload: the command line's message on the page, nothing written.
    broken = tmp_path / "broken.png"
    broken.write_bytes(example_image_path().read_bytes()[:3000])
    browser.find_element(by, "file").send_keys(str(broken))
    message = wait_for(lambda: browser.find_element(by, "upload-error").text, what="the upload's message")
    assert "broken.png" in message and "re-export it" in message
    assert [p for p in ws.root.rglob("*") if p.is_file()] == []
    # The example picture, then three layers instead of four: the preview changes.
    picture = tmp_path / "portrait.png"
    picture.write_bytes(example_image_path().read_bytes())
    browser.find_element(by, "file").send_keys(str(picture))
    wait_for(lambda: "portrait.png" in browser.find_element(by, "picture-name").text, what="the upload")
    assert not browser.find_element(by, "upload-error").is_displayed()
    four = final_preview(browser)
    assert four == bundled  # the same picture as the bundled one
    set_field(browser, "layers", "3")
    three = wait_for(lambda: (p := final_preview(browser)) != four and p, what="the preview to change")
    # Passes per plate: each paint's light and dark plates (a paint with next to no dark tones keeps one).
    n3, n4 = len(three[0].split("·")), len(four[0].split("·"))
    assert 3 <= n3 <= 6 and 4 <= n4 <= 8 and n3 < n4
    # Make (the 60 mm picture): progress per stage, then the zip.
    # Crop: the middle 80 % of the width, typed.
    browser.find_element(by, "crop-panel").click()  # open the crop panel
    for field, value in (("crop_x", "10"), ("crop_w", "80")):
        box = browser.find_element(by, field)
        box.clear()
        box.send_keys(value)
    browser.find_element(by, "distance_m").click()
    browser.find_element(by, "make").click()
    wait_for(lambda: browser.find_element(by, "job-links").is_displayed(), timeout=600, what="the job")
    stages = browser.find_element(by, "stages").text
    assert "decompose ✓" in stages and "simulate ✓" in stages
    href = browser.find_element(by, "zip").get_attribute("href")
    with urllib.request.urlopen(href) as r:
        job = zipfile.ZipFile(io.BytesIO(r.read()))
    names = job.namelist()
    assert "job.yaml" in names and "output/instructions.html" in names and "output/layer_03.stl" in names
    # Three paints: at most a light and a dark plate each.
    assert "output/layer_07.stl" not in names
    # The job's picture is the crop, cut server-side.
    import yaml
    from PIL import Image

    image = yaml.safe_load(job.read("job.yaml"))["image"]
    with Image.open(example_image_path()) as whole, Image.open(io.BytesIO(job.read(image))) as cut:
        assert cut.size == (round(0.9 * whole.width) - round(0.1 * whole.width), whole.height)


def test_the_calibration_wizard_fits_a_synthetic_photo_of_its_card(studio, browser, tmp_path):
    import json

    import numpy as np

    from stencil_cad.config.spray import CanConstants, SprayConfig
    from stencil_cad.testcard import layout_from_description
    from stencil_cad.testcard.synthetic import PhotoSettings, synthetic_photo

    url, ws = studio
    by = "id"
    browser.get(url)
    first_preview(browser)
    browser.find_element(by, "calibrate").click()  # open the wizard
    browser.find_element(by, "make-card").click()
    sheet = wait_for(lambda: browser.find_element(by, "card-sheet").is_displayed(), what="the card")
    assert sheet
    href = browser.find_element(by, "card-sheet").get_attribute("href")
    with urllib.request.urlopen(href.replace("card_sheet.pdf", "card.json")) as r:
        layout = layout_from_description(json.loads(r.read()))
    passes = float(browser.find_element(by, "card-passes").text)
    truth = CanConstants(spread_k=0.1, bleed_sigma_mm=0.4, deposit_per_pass=0.55)
    data, suffix = synthetic_photo(
        layout, SprayConfig(model="physical", can=truth), passes, np.random.default_rng(0), PhotoSettings()
    )
    photo = tmp_path / f"sprayed_card{suffix}"
    photo.write_bytes(data)
    browser.find_element(by, "paint-name").send_keys("1")  # the profile of layer 1's paint
    browser.find_element(by, "photo").send_keys(str(photo))
    table = wait_for(
        lambda: browser.find_element(by, "fit").is_displayed() and browser.find_element(by, "fit").text,
        timeout=300,
        what="the fit",
    )
    assert "Markers found per wall" in table and "Spread k" in table
    spread = float(table.split("Spread k")[1].split()[0])
    assert spread == pytest.approx(0.1, rel=0.05)
    # The page lists the new profile (chosen) once it has asked for the list again after the fit.
    chosen = browser.find_element(by, "profile")
    wait_for(lambda: chosen.get_attribute("value"), what="the new profile chosen")
    assert chosen.text.startswith("1: spread")
    assert len(list(ws.profiles.glob("*.yaml"))) == 1
