"""A scheduler that never answers, and a cluster that lost every worker: exit 2, one line, nothing left.

A port that accepts connections and stays silent used to hang `run --scheduler` for good
(Dask waits for the server's handshake without a timeout); tasks on a cluster without a
worker waited for good too, or failed as "cannot use None: No valid workers found".
"""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from stencil_cad.compute import executors
from stencil_cad.errors import UserError
from stencil_cad.output import LOCK, STAGING_PREFIX


class _SilentServer:
    """A loopback port that accepts every connection and never sends a byte."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.accepted: list[socket.socket] = []
        self.thread = threading.Thread(target=self._accept, daemon=True)
        self.thread.start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.accepted.append(conn)

    def close(self) -> None:
        for c in self.accepted:
            c.close()
        self.sock.close()


@pytest.fixture
def silent_port():
    server = _SilentServer()
    try:
        yield server
    finally:
        server.close()


@pytest.fixture
def tiny_image(tmp_path):
    img = tmp_path / "pic.png"
    a = np.zeros((60, 80, 3), np.uint8)
    a[:, :40] = (200, 30, 30)
    a[20:, 40:] = (20, 20, 160)
    Image.fromarray(a).save(img)
    return img


def test_a_silent_scheduler_fails_in_seconds_and_leaves_nothing(tmp_path, silent_port, tiny_image):
    out = tmp_path / "out"
    cfg = tmp_path / "small.yaml"
    cfg.write_text("name: small\nsize: {width_mm: 40, px_per_mm: 2}\ndecompose: {layers: 2}\n")
    address = f"tcp://127.0.0.1:{silent_port.port}"
    t0 = time.monotonic()
    try:
        r = subprocess.run(
            [sys.executable, "-m", "stencil_cad", "run", str(cfg), "--image", str(tiny_image)]
            + ["--out", str(out)]
            + ["--scheduler", address, "-q"],
            capture_output=True,
            text=True,
            timeout=90,  # generous on a loaded machine; the bound asserted is 30 s
        )
    except subprocess.TimeoutExpired:
        pytest.fail("run --scheduler hung on a port that accepts and never answers")
    took = time.monotonic() - t0
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("stencil-cad: error: "), r.stderr
    assert address in lines[0] and "sent nothing" in lines[0] and "dask scheduler" in lines[0], r.stderr
    assert took < 30, f"took {took:.1f} s"
    assert silent_port.accepted, "the run never connected to the port"
    assert not out.exists(), sorted(p.name for p in out.iterdir())
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(STAGING_PREFIX) or p.name == LOCK]
    assert left == []


def test_the_probe_still_passes_a_port_that_speaks_first():
    """A Dask server sends its handshake first: one byte is enough for the probe."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    port = srv.getsockname()[1]

    def greet() -> None:
        conn, _ = srv.accept()
        conn.sendall(b"\x00")
        time.sleep(1)
        conn.close()

    t = threading.Thread(target=greet, daemon=True)
    t.start()
    try:
        executors._probe(f"tcp://127.0.0.1:{port}")
    finally:
        t.join(5)
        srv.close()


class _NoWorkers:
    """A Dask client whose cluster lost both its workers: scatter fails as Dask's does."""

    status = "running"

    def scheduler_info(self):
        return {"workers": {}}

    def scatter(self, data, **kw):
        raise TimeoutError("No valid workers found")


def test_losing_every_worker_names_them_and_the_fix():
    ex = executors.DaskExecutor.__new__(executors.DaskExecutor)
    ex.plan = SimpleNamespace(kind="remote", address="tcp://127.0.0.1:8786")
    ex.client = _NoWorkers()
    ex._seen = {"tcp://127.0.0.1:40001", "tcp://127.0.0.1:40002"}
    with pytest.raises(UserError) as info:
        ex._scatter(np.zeros(100_000), {"tcp://127.0.0.1:40001": 1}, "refine tiles")
    msg = str(info.value)
    assert "cannot use None" not in msg and "No valid workers found" not in msg
    assert msg.startswith("refine tiles: every worker of the Dask scheduler at tcp://127.0.0.1:8786 is gone")
    assert "tcp://127.0.0.1:40001, tcp://127.0.0.1:40002" in msg
    assert "`dask worker tcp://127.0.0.1:8786`" in msg and "no partial outputs were kept" in msg
