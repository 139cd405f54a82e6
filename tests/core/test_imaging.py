import numpy as np
import pytest
from PIL import Image

from stencil_cad.errors import ImageError
from stencil_cad.imaging import example_image_path, fit_to_size, load_picture, read_image


def test_example_image_is_bundled():
    assert example_image_path().exists()


def test_rgb_roundtrip(tmp_path):
    a = (np.arange(40 * 30 * 3) % 256).astype(np.uint8).reshape(40, 30, 3)
    p = tmp_path / "a.png"
    Image.fromarray(a).save(p)
    rgb, alpha, grey = read_image(p)
    assert rgb.shape == (40, 30, 3) and alpha is None and not grey
    np.testing.assert_allclose(rgb * 255, a, atol=1e-9)


def test_grey_16bit(tmp_path):
    a = np.linspace(0, 65535, 20 * 10).astype(np.uint16).reshape(20, 10)
    p = tmp_path / "g.png"
    Image.fromarray(a).save(p)
    rgb, alpha, grey = read_image(p)
    assert grey and rgb.shape == (20, 10, 3)
    assert rgb.max() == pytest.approx(1.0) and rgb.min() == 0.0


def test_rgba_alpha(tmp_path):
    a = np.zeros((8, 8, 4), np.uint8)
    a[..., 3] = 128
    p = tmp_path / "a.png"
    Image.fromarray(a, "RGBA").save(p)
    _, alpha, _ = read_image(p)
    assert alpha is not None and alpha.mean() == pytest.approx(128 / 255)


def test_exif_orientation_is_applied(tmp_path):
    a = np.zeros((10, 20, 3), np.uint8)
    im = Image.fromarray(a)
    exif = im.getexif()
    exif[0x0112] = 6  # rotate 90° on display
    p = tmp_path / "r.jpg"
    im.save(p, exif=exif)
    rgb, _, _ = read_image(p)
    assert rgb.shape[:2] == (20, 10)


def test_missing_file(tmp_path):
    with pytest.raises(ImageError, match="not found"):
        read_image(tmp_path / "x.png")


def test_not_an_image(tmp_path):
    p = tmp_path / "x.png"
    p.write_text("hello")
    with pytest.raises(ImageError, match="not an image"):
        read_image(p)


def test_truncated_image(tmp_path):
    a = (np.random.default_rng(0).random((200, 200, 3)) * 255).astype(np.uint8)
    p = tmp_path / "t.png"
    Image.fromarray(a).save(p)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(ImageError, match="truncated"):
        read_image(p)


def test_too_small_for_size():
    rgb = np.zeros((50, 50, 3))
    with pytest.raises(ImageError, match="too small"):
        fit_to_size(rgb, None, 150.0, None, 2.0)


def test_fit_crops_to_aspect():
    rgb = np.zeros((400, 200, 3))
    out, _, mm_per_px, h_mm = fit_to_size(rgb, None, 100.0, 100.0, 1.0)
    assert out.shape == (100, 100, 3) and mm_per_px == pytest.approx(1.0) and h_mm == pytest.approx(100.0)


def test_load_example():
    pic = load_picture(None, 60.0, None, 2.0)
    assert pic.shape == (120, 120) and pic.width_mm == pytest.approx(60.0)
    assert 0.0 <= pic.rgb.min() and pic.rgb.max() <= 1.0


def test_a_big_file_is_decoded_within_the_memory_budget(tmp_path, monkeypatch):
    """A big PNG whose decode at twice the grid would pass the budget is decoded nearer the grid."""
    from stencil_cad import imaging

    p = tmp_path / "big.png"
    Image.fromarray(np.random.default_rng(0).integers(0, 255, (500, 500, 3), dtype=np.uint8)).save(p)
    monkeypatch.setattr(imaging, "STREAM_BYTES", 1000)
    # Within the budget: decoded whole (500 px is less than twice the 300 px asked).
    assert imaging.read_image(p, min_size=(300, 300))[0].shape == (500, 500, 3)
    monkeypatch.setattr(imaging, "DECODE_BUDGET", 24 * 300 * 300)
    rgb = imaging.read_image(p, min_size=(300, 300))[0]
    assert rgb.shape == (300, 300, 3) and rgb.dtype == np.float64


def test_a_working_picture_over_the_limit_is_refused_before_decoding(tmp_path, monkeypatch):
    from stencil_cad import imaging
    from stencil_cad.errors import ConfigError

    p = tmp_path / "wide.png"
    Image.fromarray(np.zeros((100, 200, 3), np.uint8)).save(p)
    monkeypatch.setattr(imaging, "MAX_GRID_PIXELS", 150 * 75)
    with pytest.raises(ConfigError, match=r"would be 160 × 80 px .* lower size.px_per_mm or size.width_mm"):
        imaging.load_picture(p, 80.0, None, 2.0)
    assert imaging.load_picture(p, 70.0, None, 2.0).rgb.shape == (70, 140, 3)
