import os
import subprocess
import sys

import pytest

SCRIPT = """
import hashlib
from stencil_cad.cad.label import DEFAULT_FONT, _text_glyphs
g = _text_glyphs("TILE A2 of 2x1 L2/2 SPRAY 2 #1A2B3C mural i:j", 3.0, DEFAULT_FONT, 0.01)
print(hashlib.sha256(b"".join(o.tobytes() + b"".join(r.tobytes() for r in i) for o, i in g)).hexdigest())
"""


@pytest.mark.slow
def test_label_glyphs_come_in_the_same_order_in_every_process():
    # The kernel's face order differs between processes; unsorted, three runs gave three orders.
    runs = {
        subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True).stdout
        for _ in range(3)
    }
    assert len(runs) == 1


SAME_AS_BUILD123D = """
import sys
import numpy as np
from stencil_cad.cad.label import DEFAULT_FONT, _bundled_font, _face_rings, _text_glyphs

texts = ["L3/8  SPRAY 3  #1A2B3C  example", "TILE B2 of 2x3  L1/2  SPRAY 1  BLACK  café ijk", "L8/8"]
ours = {(t, s): _text_glyphs(t, s, DEFAULT_FONT, 0.01) for t in texts for s in (4.0, 2.7182818)}
assert "build123d" not in sys.modules
from build123d import Align, FontStyle, Text

for (t, s), glyphs in ours.items():
    sketch = Text(t, font_size=s, font=DEFAULT_FONT, font_path=_bundled_font(), font_style=FontStyle.BOLD,
                  align=(Align.MIN, Align.MIN))
    theirs = [r for r in (_face_rings(f.wrapped, 0.01) for f in sketch.faces()) if r[0] is not None]
    theirs.sort(key=lambda g: (*np.round(g[0].min(axis=0), 6), *np.round(g[0].max(axis=0), 6)))
    assert len(theirs) == len(glyphs), (t, s)
    for (o1, i1), (o2, i2) in zip(glyphs, theirs):
        assert o1.tobytes() == o2.tobytes() and [r.tobytes() for r in i1] == [r.tobytes() for r in i2], (t, s)
print("same")
"""


@pytest.mark.slow
def test_label_glyphs_are_build123ds_text_to_the_bit():
    # The bundled font goes through OCCT's font classes directly (no build123d import); the
    # rings are those of build123d's Text with the same font, to the bit.
    out = subprocess.run(
        [sys.executable, "-c", SAME_AS_BUILD123D], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "same"


def _bits(glyphs):
    return [(o.tobytes(), [r.tobytes() for r in i]) for o, i in glyphs]


def test_labels_laid_out_in_threads_are_the_same_and_leave_the_environment_alone(monkeypatch):
    # OCCT's font manager is one per process and not thread-safe: a worker with several threads
    # lays out one label at a time, and the font configuration is set once, before the manager.
    from concurrent.futures import ThreadPoolExecutor

    from stencil_cad.cad.label import DEFAULT_FONT, _text_glyphs

    texts = [f"L{k}/8  SPRAY {k}  #1A2B3C" for k in range(1, 9)]
    alone = [_bits(_text_glyphs(t, 3.0, DEFAULT_FONT, 0.01)) for t in texts]
    monkeypatch.setenv("FONTCONFIG_FILE", "my-fonts.conf")
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda t: _bits(_text_glyphs(t, 3.0, DEFAULT_FONT, 0.01)), texts))
    assert threaded == alone
    assert os.environ["FONTCONFIG_FILE"] == "my-fonts.conf"
