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
