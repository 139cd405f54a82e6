"""A real Dask cluster: `dask scheduler` and `dask worker` processes on 127.0.0.1, as the docs start them (docs/guides/murals-and-dask.md).

A small mural run with ``--scheduler`` writes the bytes of the same job run in this process;
it still does when a worker is killed while refinement tasks run and another while plates
are built (the tasks that lose their inputs are sent again); and a scheduler stopped mid-run
ends the job with exit 2, one line and no output folder, as does losing every worker. Nothing
of the cluster's listens beyond loopback.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from stencil_cad.cli import main

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from benchmarks.compare_outputs import compare  # noqa: E402

MURAL = """\
name: tiny_mural
size: {width_mm: 240, height_mm: 160, px_per_mm: auto}
bed: prusa_mk4
decompose: {layers: 2}
stipple: {process: fdm}
"""

# `--no-dashboard` still leaves an HTTP server (health, metrics) on every interface: on 0.0.0.0:8787
# for the scheduler and a random port for each worker. Bound to loopback, like the comms.
LOOPBACK_HTTP = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0"]

# The docs' worker settings (docs/guides/murals-and-dask.md).
WORKER_ENV = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False",
    "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "1s",
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A scheduler and worker processes on 127.0.0.1, every port (comms and HTTP) on loopback."""

    def __init__(self, logs: Path, workers: int = 2):
        self.logs = logs
        self.address = f"tcp://127.0.0.1:{_free_port()}"
        self.env = {**os.environ, **WORKER_ENV}
        # The workers import this checkout's stencil_cad, as the test process does.
        self.env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(
            os.pathsep
        )
        port = self.address.rsplit(":", 1)[1]
        self.scheduler = self._start(
            "scheduler", ["scheduler", "--host", "127.0.0.1", "--port", port, *LOOPBACK_HTTP]
        )
        self.workers: list[subprocess.Popen] = []
        self._pids: dict[str, int] = {}
        from distributed import Client

        self.client = None
        try:
            deadline = time.monotonic() + 60
            while self.client is None:
                try:
                    self.client = Client(self.address, timeout="2s", set_as_default=False)
                except OSError:
                    assert time.monotonic() < deadline, "the scheduler did not start"
                    time.sleep(0.2)
            for _ in range(workers):
                self.add_worker()
            self.client.wait_for_workers(workers, timeout=120)
            self.assert_loopback_only()
        except BaseException:
            # The fixture never gets the cluster to close: stop what was started here.
            self.close()
            raise

    def _start(self, name: str, args: list[str]) -> subprocess.Popen:
        with open(self.logs / f"{name}-{time.monotonic_ns()}.log", "wb") as log:
            return subprocess.Popen(
                [sys.executable, "-m", "dask", *args], stdout=log, stderr=subprocess.STDOUT, env=self.env
            )

    def add_worker(self) -> None:
        # No nanny: the process started here is the worker, so killing it loses the worker and
        # everything it held, as when a machine goes away.
        self.workers.append(
            self._start(
                "worker",
                [
                    "worker",
                    self.address,
                    "--host",
                    "127.0.0.1",
                    *LOOPBACK_HTTP,
                    "--no-nanny",
                    "--nthreads",
                    "1",
                    "--memory-limit",
                    "4GB",
                ],
            )
        )

    def processing(self) -> dict[int, list[str]]:
        """Keys each worker runs, by the worker's process id."""
        out = {}
        for address, keys in self.client.processing().items():
            if address not in self._pids:
                self._pids.update(self.client.run(os.getpid, workers=[address]))
            out[self._pids[address]] = [str(k) for k in keys]
        return out

    def listening(self) -> list[tuple[int, str, int]]:
        """``(pid, address, port)`` of every socket the scheduler and workers listen on."""
        import psutil

        out = []
        for p in [self.scheduler, *self.workers]:
            if p.poll() is not None:
                continue
            with contextlib.suppress(psutil.NoSuchProcess):
                proc = psutil.Process(p.pid)
                conns = proc.net_connections(kind="inet")
                out += [(p.pid, c.laddr.ip, c.laddr.port) for c in conns if c.status == psutil.CONN_LISTEN]
        return out

    def assert_loopback_only(self, started: bool = True) -> None:
        """Nothing of the cluster's listens beyond loopback (its comms, and the HTTP servers too).

        Args:
            started: The cluster has just started, so its sockets must be seen (a test may have
                stopped the processes since).
        """
        found = self.listening()
        assert found or not started, "no listening socket found: the check sees nothing"
        beyond = [s for s in found if s[1] not in ("127.0.0.1", "::1")]
        assert beyond == [], f"listening beyond loopback: {beyond}"

    def close(self) -> None:
        with contextlib.suppress(Exception):
            if self.client is not None:
                self.client.close(timeout=5)
        for p in [*self.workers, self.scheduler]:
            if p.poll() is None:
                p.kill()
            p.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path):
    c = Cluster(tmp_path)
    try:
        yield c
        # Workers added during the test too.
        c.assert_loopback_only(started=False)
    finally:
        c.close()


@pytest.fixture(scope="module")
def in_process(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("in_process")
    cfg = tmp / "mural.yaml"
    cfg.write_text(MURAL)
    out = tmp / "w0"
    assert main(["run", str(cfg), "--out", str(out), "-q", "--workers", "0"]) == 0
    return out


def _run_on(cluster: Cluster, tmp_path: Path, name: str) -> tuple[int, Path]:
    cfg = tmp_path / "mural.yaml"
    cfg.write_text(MURAL)
    out = tmp_path / name
    code = main(["run", str(cfg), "--out", str(out), "-q", "--scheduler", cluster.address])
    return code, out


def _assert_same_files(a: Path, b: Path) -> None:
    rows = compare(a, b)
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {r["file"] for r in rows} == set(names), "a kind of file is not compared"
    assert [r for r in rows if not r["same"]] == []


def test_a_real_cluster_writes_the_in_process_bytes(cluster, tmp_path, in_process):
    code, out = _run_on(cluster, tmp_path, "remote")
    assert code == 0
    man = json.loads((out / "manifest.json").read_text())
    assert (man["compute"]["kind"], man["compute"]["address"]) == ("remote", cluster.address)
    assert len(man["mural"]["tiles"]) >= 2
    _assert_same_files(in_process, out)


class _Killer(threading.Thread):
    """Watches the scheduler; on the first task of each stage named, acts on the worker running it."""

    def __init__(self, cluster: Cluster, prefixes: list[str], act):
        super().__init__(daemon=True)
        self.cluster, self.prefixes, self.act = cluster, list(prefixes), act
        self.hits: list[str] = []
        self.stop = threading.Event()

    def run(self) -> None:
        while self.prefixes and not self.stop.is_set():
            with contextlib.suppress(Exception):
                for pid, keys in self.cluster.processing().items():
                    hit = next((k for k in keys if k.startswith(self.prefixes[0])), None)
                    if hit is not None:
                        self.act(pid)
                        self.hits.append(hit)
                        self.prefixes.pop(0)
                        break
            time.sleep(0.02)


def test_killed_workers_cost_a_retry_not_the_job(cluster, tmp_path, in_process, caplog):
    caplog.set_level(logging.INFO, logger="stencil_cad.compute")

    def kill_and_replace(pid: int) -> None:
        os.kill(pid, signal.SIGKILL)
        cluster.add_worker()

    killer = _Killer(cluster, ["refine_tiles", "build-"], kill_and_replace)
    killer.start()
    try:
        code, out = _run_on(cluster, tmp_path, "killed")
    finally:
        killer.stop.set()
        killer.join()
    assert code == 0
    assert [h.split("-")[0] for h in killer.hits] == ["refine_tiles", "build"], killer.hits
    # A refinement task's input (a region of the picture, over 64 KB) lived on the killed worker
    # only: it was sent again.
    assert "refine tiles: task" in caplog.text and "sending both again" in caplog.text, caplog.text
    _assert_same_files(in_process, out)


def test_a_stopped_scheduler_ends_the_job_with_one_line_and_no_output(cluster, tmp_path, capsys):
    killer = _Killer(cluster, ["refine_tiles"], lambda pid: cluster.scheduler.send_signal(signal.SIGTERM))
    killer.start()
    t0 = time.monotonic()
    try:
        code, out = _run_on(cluster, tmp_path, "stopped")
    finally:
        killer.stop.set()
        killer.join()
    err = capsys.readouterr().err
    assert killer.hits, "the scheduler was not stopped during refinement"
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("stencil-cad: error: "), err
    assert "lost the connection to the Dask scheduler" in lines[0] and "dask scheduler" in lines[0], err
    assert "internal error" not in err and "15.00 seconds" not in err
    assert time.monotonic() - t0 < 120
    assert not out.exists(), sorted(p.name for p in out.iterdir())


def test_losing_every_worker_ends_the_job_naming_them(cluster, tmp_path, capsys, monkeypatch):
    from stencil_cad.compute import executors

    # Dask keeps tasks for a worker that may come back; the job waits this long for one.
    monkeypatch.setattr(executors, "WORKERLESS_SECONDS", 5.0)
    addresses = sorted(cluster.client.scheduler_info()["workers"])
    assert len(addresses) == 2

    def kill_both(pid: int) -> None:
        for w in cluster.workers:
            w.kill()

    killer = _Killer(cluster, ["refine_tiles"], kill_both)
    killer.start()
    t0 = time.monotonic()
    try:
        code, out = _run_on(cluster, tmp_path, "no_workers")
    finally:
        killer.stop.set()
        killer.join()
    err = capsys.readouterr().err
    assert killer.hits, "the workers were not killed during refinement"
    assert code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("stencil-cad: error: "), err
    assert "every worker of the Dask scheduler" in lines[0] and ", ".join(addresses) in lines[0], err
    assert f"dask worker {cluster.address}" in lines[0], err
    assert "cannot use None" not in err and "No valid workers" not in err
    assert time.monotonic() - t0 < 180
    assert not out.exists(), sorted(p.name for p in out.iterdir())
