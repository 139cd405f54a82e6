import logging

import numpy as np
import pytest

from stencil_cad import compute
from stencil_cad.cli import main
from stencil_cad.compute import executors, planning
from stencil_cad.config import JobConfig
from stencil_cad.config.compute import ComputeConfig, parse_memory, with_command_line
from stencil_cad.config.io import parse_config
from stencil_cad.errors import ConfigError, UserError


def test_memory_sizes_parse():
    assert parse_memory(2) == 2e9
    assert parse_memory("1.5 GB") == 1.5e9
    assert parse_memory("512MB") == 512e6
    assert parse_memory("4 GiB") == 4 * 2**30
    with pytest.raises(ValueError, match="size such as"):
        parse_memory("lots")
    cfg = parse_config({"compute": {"memory_per_task": "512 MB"}})
    assert cfg.compute.memory_per_task == pytest.approx(0.512)
    assert cfg.compute.memory_per_task_bytes == 512_000_000


def test_bad_compute_values_name_the_key():
    with pytest.raises(ConfigError, match=r"compute\.scheduler: .*tcp://HOST:8786"):
        parse_config({"compute": {"scheduler": "localhost:8786"}})
    with pytest.raises(ConfigError, match=r"compute\.memory_per_task"):
        parse_config({"compute": {"memory_per_task": "much"}})
    with pytest.raises(ConfigError, match=r"compute\.workers"):
        parse_config({"compute": {"workers": -1}})
    with pytest.raises(ConfigError, match=r"^--workers: "):
        with_command_line(ComputeConfig(), -2, None)


def test_small_jobs_stay_in_process_big_ones_start_a_cluster(monkeypatch):
    monkeypatch.setattr(planning, "cores", lambda: 3)
    monkeypatch.setattr(planning, "available_memory", lambda: 64e9)
    cfg = JobConfig().compute
    small = compute.plan(cfg, 2_000_000)
    assert small.kind == "in_process" and "not more than" in small.reason
    big = compute.plan(cfg, 10_000_000)
    assert (big.kind, big.workers) == ("local", 3)
    assert compute.plan(ComputeConfig(workers=0), 10**9).kind == "in_process"
    assert compute.plan(ComputeConfig(workers=2), 10).workers == 2
    remote = compute.plan(ComputeConfig(workers=2, scheduler="tcp://10.1.2.3:8786"), 10)
    assert (remote.kind, remote.address) == ("remote", "tcp://10.1.2.3:8786")


def test_a_long_tiled_mural_shares_the_cores_a_short_one_stays(monkeypatch):
    monkeypatch.setattr(planning, "available_memory", lambda: 64e9)
    monkeypatch.setattr(planning, "cores", lambda: 2)
    cfg = JobConfig().compute
    long_mural = compute.plan(cfg, 1_000_000, mural_seconds=planning.MURAL_CLUSTER_SECONDS + 1)
    assert (long_mural.kind, long_mural.workers) == ("local", 2) and "mural" in long_mural.reason
    assert compute.plan(cfg, 1_000_000, mural_seconds=planning.MURAL_CLUSTER_SECONDS).kind == "in_process"
    assert compute.plan(cfg, 1_000_000).kind == "in_process"  # not a mural
    assert compute.plan(ComputeConfig(workers=0), 1_000_000, mural_seconds=1e6).kind == "in_process"
    # One core (or memory for one worker): a cluster would only add its start.
    monkeypatch.setattr(planning, "cores", lambda: 1)
    assert compute.plan(cfg, 1_000_000, mural_seconds=1e6).kind == "in_process"


def test_a_task_that_cannot_fit_is_refused_with_its_need():
    cfg = ComputeConfig(memory_per_task=0.1)
    compute.check_fits("a tile", 0.09e9, cfg)
    with pytest.raises(
        compute.TaskMemoryError,
        match=r"a tile needs about 0\.25 GB, more than the 0\.1 GB .* at least 0\.3 GB",
    ):
        compute.check_fits("a tile", 0.25e9, cfg)


def test_memory_per_task_too_small_for_a_decomposition_tile_exits_2(tmp_path, capsys):
    cfg = tmp_path / "job.yaml"
    cfg.write_text("compute:\n  memory_per_task: 0.001\n")
    image = tmp_path / "img.png"
    from PIL import Image

    rng = np.random.default_rng(0)
    Image.fromarray((rng.random((400, 600, 3)) * 255).astype(np.uint8)).save(image)
    out = tmp_path / "out"
    code = main(["run", str(cfg), "--image", str(image), "--out", str(out), "-q", "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 2
    assert (
        "compute.memory_per_task: a decomposition tile of" in err and "raise compute.memory_per_task" in err
    )
    assert not out.exists()


def test_unreachable_scheduler_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", "1s")
    with pytest.raises(
        UserError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9.*dask scheduler"
    ):
        with compute.executor(ComputeConfig(scheduler="tcp://127.0.0.1:9"), 10):
            pass


def _square(x):
    return x * x


def test_in_process_map_keeps_order_and_counts_tasks():
    ex = compute.Executor(compute.Plan("in_process"), quiet=True)
    assert list(ex.map(_square, range(5), "squares")) == [0, 1, 4, 9, 16]
    assert list(ex.map(_square, iter(range(3)), "more", count=3)) == [0, 1, 4]
    assert ex.tasks == 8
    ex.close()


@pytest.mark.slow
def test_local_cluster_map_matches_in_process(monkeypatch):
    logging.getLogger("stencil_cad").setLevel(logging.WARNING)
    # (An earlier cluster in this process may have put Dask's value into os.environ.)
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with compute.executor(ComputeConfig(workers=2), 10, quiet=True) as ex:
        assert isinstance(ex, compute.DaskExecutor) and ex.workers == 2
        # More tasks than the in-flight window, so submission refills as results arrive.
        assert list(ex.map(_square, range(23), "squares")) == [i * i for i in range(23)]
        assert ex.tasks == 23
        # The workers run without Dask's stack sampler (it cost plate builds about 5 % of their CPU)
        # and with the slower housekeeping of executors._LOCAL_DASK_CONFIG.
        assert set(ex.client.run(_profiling).values()) == {False}
        assert list(ex.client.run(_housekeeping).values()) == [executors._LOCAL_DASK_CONFIG] * 2
        # Nor with Dask's malloc trim threshold, which made numpy-heavy tasks about 1.7x slower.
        assert set(ex.client.run(_trim_threshold).values()) == {None}
        # Small inputs travel inside their tasks, large ones are scattered to the least busy
        # worker; either way both workers get tasks and the results come back in order.
        scatter, sent_to = ex.client.scatter, []

        def recording_scatter(item, **kw):
            sent_to.append(kw.get("workers"))
            return scatter(item, **kw)

        monkeypatch.setattr(ex.client, "scatter", recording_scatter)
        for inline in (executors.INLINE_BYTES, 0):
            monkeypatch.setattr(executors, "INLINE_BYTES", inline)
            items = [np.full(64, i, dtype=np.float64) for i in range(12)]
            out = list(ex.map(_total_and_worker, items, "totals"))
            assert [t for t, _ in out] == [64.0 * i for i in range(12)]
            assert len({w for _, w in out}) == 2, inline
            if inline:
                assert sent_to == []
        # Every large input went to one chosen worker, both workers in turn while equally busy.
        assert len(sent_to) == 12 and all(w is not None and len(w) == 1 for w in sent_to)
        assert sent_to[0] != sent_to[1]
        # A worker the nanny restarts (after running out of memory, say) keeps the settings.
        ex.client.restart()
        assert list(ex.client.run(_housekeeping).values()) == [executors._LOCAL_DASK_CONFIG] * 2


class _FakeClient:
    def __init__(self, workers, gone=()):
        self.workers, self.gone, self.sent = workers, set(gone), []

    def scheduler_info(self):
        return {"workers": {a: {"status": st} for a, st in self.workers.items()}}

    def scatter(self, items, hash=True, workers=None):
        if workers and workers[0] in self.gone:
            raise KeyError(workers[0])
        self.sent.append(workers)
        return list(items)


def test_large_inputs_go_to_the_least_busy_running_worker():
    ex = object.__new__(compute.DaskExecutor)
    ex.client = _FakeClient({"tcp://b": "running", "tcp://a": "running", "tcp://p": "paused"})
    ex._seen = set()
    load: dict = {}
    assert ex._scatter("x1", load) == ("x1", "tcp://a")
    assert ex._scatter("x2", load) == ("x2", "tcp://b")
    assert load == {"tcp://a": 1, "tcp://b": 1}  # the paused worker gets nothing
    load["tcp://b"] -= 1  # its task finished: b is now the least busy
    assert ex._scatter("x3", load)[1] == "tcp://b"
    # b left and d joined: d starts at 0, b is forgotten.
    ex.client.workers = {"tcp://a": "running", "tcp://d": "running"}
    assert ex._scatter("x4", load)[1] == "tcp://d" and "tcp://b" not in load
    # The chosen worker went away after the question: the scheduler picks one.
    ex.client.gone = {"tcp://d"}
    load["tcp://a"] = 5
    assert ex._scatter("x5", load) == ("x5", None) and ex.client.sent[-1] is None
    # No running worker at all: the scheduler picks one (and waits for one).
    ex.client.workers = {}
    assert ex._scatter("x6", load) == ("x6", None) and load == {}


def _profiling(dask_worker):
    import dask

    return (
        dask.config.get("distributed.worker.profile.enabled")
        or "profile-cycle" in dask_worker.periodic_callbacks
    )


def _trim_threshold():
    import os

    return os.environ.get("MALLOC_TRIM_THRESHOLD_")


def _housekeeping(dask_worker):
    import dask

    return {k: dask.config.get(k) for k in executors._LOCAL_DASK_CONFIG}


def _total_and_worker(a):
    import time

    from distributed import get_worker

    time.sleep(0.1)
    return float(a.sum()), get_worker().address


def _files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.name != "manifest.json"}


@pytest.mark.slow
def test_tiled_decomposition_on_two_workers_writes_the_in_process_bytes(tmp_path, monkeypatch):
    """The bundled example's decomposition, forced into 128 px tiles, on a local cluster of two
    workers and in this process: every file byte for byte the same."""
    import json

    from stencil_cad.decompose import tiled

    monkeypatch.setattr(tiled, "WHOLE_MAX_PX", 0)
    monkeypatch.setattr(tiled, "COARSE_PX", 128)
    monkeypatch.setattr(tiled, "TILE_PX", 128)
    outs = {}
    for workers in ("0", "2"):
        out = tmp_path / f"w{workers}"
        assert main(["decompose", "--out", str(out), "-q", "--workers", workers]) == 0
        outs[workers] = out
    manifests = {w: json.loads((o / "manifest.json").read_text()) for w, o in outs.items()}
    assert manifests["0"]["compute"]["kind"] == "in_process"
    assert manifests["2"]["compute"] == {**manifests["2"]["compute"], "kind": "local", "workers": 2}
    assert manifests["2"]["compute"]["tasks"] == manifests["2"]["decompose"]["tiled"]["tiles"] >= 6
    assert _files(outs["0"]) == _files(outs["2"])
    rows = {w: {r["name"]: r["sha256"] for r in m["files"]} for w, m in manifests.items()}
    assert rows["0"] == rows["2"]


def test_workers_are_cut_to_the_cores_and_the_memory(monkeypatch, caplog):
    monkeypatch.setattr(planning, "cores", lambda: 2)
    monkeypatch.setattr(planning, "available_memory", lambda: 64e9)
    with caplog.at_level(logging.WARNING, logger="stencil_cad.compute"):
        p = compute.plan(ComputeConfig(workers=1000), 10)
    assert p.workers == 2 and "1000 workers asked, starting 2" in p.reason and "2 core(s)" in caplog.text
    # 6 GB free at 2 GB per task plus the start-up size: 2 workers of the 8 cores.
    monkeypatch.setattr(planning, "cores", lambda: 8)
    monkeypatch.setattr(planning, "available_memory", lambda: 6e9)
    p = compute.plan(ComputeConfig(workers=8), 10)
    assert p.workers == 2 and "6.0 GB of free memory" in p.reason and "memory_per_task" in p.reason
    # The automatic count (a big picture) is cut too; never below one worker.
    monkeypatch.setattr(planning, "available_memory", lambda: 1e9)
    assert compute.plan(ComputeConfig(), 10**9).workers == 1
    assert compute.plan(ComputeConfig(workers=1), 10).reason == "compute.workers is 1"


def test_a_refused_connection_fails_at_once(monkeypatch):
    import socket
    import time

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # closed again: nothing listens there
    t0 = time.monotonic()
    with pytest.raises(
        UserError, match=rf"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:{port}.*refused"
    ):
        with compute.executor(ComputeConfig(scheduler=f"tcp://127.0.0.1:{port}"), 10):
            pass
    assert time.monotonic() - t0 < 5


def _scaled(item, shared):
    return item * shared


def test_started_tasks_run_when_collected_in_process():
    ex = compute.Executor(compute.Plan("in_process"), quiet=True)
    ran = []
    started = ex.start(lambda i: ran.append(i) or i * i, range(4), "squares")
    assert ran == [] and ex.tasks == 4
    assert started.results() == [0, 1, 4, 9] and started.results() == [0, 1, 4, 9] and ran == [0, 1, 2, 3]
    assert ex.start(_scaled, [1, 2], "scaled", shared=10).results() == [10, 20]
    ex.close()


@pytest.mark.slow
def test_started_tasks_on_a_local_cluster_match_in_process(monkeypatch):
    logging.getLogger("stencil_cad").setLevel(logging.WARNING)
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    shared = np.arange(300_000, dtype=np.float64)
    with compute.executor(ComputeConfig(workers=2), 10, quiet=True) as ex:
        started = ex.start(_scaled, range(5), "scaled", shared=shared)
        # A map asked for meanwhile runs beside the started tasks.
        assert list(ex.map(_square, range(6), "squares")) == [i * i for i in range(6)]
        got = started.results()
        assert all(np.array_equal(g, i * shared) for i, g in enumerate(got))
        assert ex.start(_square, range(3), "squares").results() == [0, 1, 4]
        dropped = ex.start(_square, range(3), "squares")
        dropped.cancel()
