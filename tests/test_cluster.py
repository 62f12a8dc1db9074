"""Workers: local processes and a real Dask cluster give the same bytes as one process.

The cluster is a Dask scheduler and two workers started here as separate processes on
127.0.0.1 (``dask scheduler --scheduler-file``, ``dask worker --scheduler-file``), as on a
real cluster; ``--dask FILE`` connects through the scheduler file.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from spinemesh.cluster import Workers, available_cores, open_workers

from conftest import EXAMPLES, memory_files_left, shared_memory_segments, unavailable

DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo"


def tree_bytes(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` by relative path, with the SHA-256 of its bytes."""
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _square(x):
    return x * x


def _fail(x):
    raise ValueError(f"task {x} failed")


def test_available_cores_follows_the_affinity_mask():
    assert available_cores() == len(os.sched_getaffinity(0))


def test_local_workers_shorten_the_thread_switch_interval_while_they_run():
    """The dispatcher thread waits for the GIL at most DISPATCH_SWITCH_INTERVAL; restored after."""
    from spinemesh.cluster import DISPATCH_SWITCH_INTERVAL

    before = sys.getswitchinterval()
    with open_workers(2) as workers:
        assert sys.getswitchinterval() == pytest.approx(min(before, DISPATCH_SWITCH_INTERVAL))
        assert workers.submit(abs, -3).result() == 3
    assert sys.getswitchinterval() == before


@pytest.mark.parametrize("jobs", [1, 2])
def test_local_workers_stream_results_and_raise_task_errors(jobs):
    with open_workers(jobs) as w:
        futures = [w.submit(_square, i) for i in range(20)]
        assert sorted(f.result() for f in w.as_completed(futures)) == [i * i for i in range(20)]
        with pytest.raises(ValueError, match="task 3 failed"):
            w.submit(_fail, 3).result()
    assert type(w) is Workers if jobs == 1 else type(w) is not Workers


def _spinemesh(*args, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=dict(os.environ, COLUMNS="200"))


@pytest.fixture(scope="module")
def scheduler_file(tmp_path_factory):
    """A Dask scheduler and two single-threaded workers, each its own process, on 127.0.0.1."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        unavailable("Dask is not installed (pip install 'spinemesh[cluster]')")
    folder = tmp_path_factory.mktemp("dask")
    file = folder / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    log = open(folder / "cluster.log", "w")
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(file)], stdout=log, stderr=subprocess.STDOUT)]
    try:
        deadline = time.monotonic() + 60
        while not file.is_file() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert file.is_file(), (folder / "cluster.log").read_text()[-3000:]
        for _ in range(2):
            procs.append(subprocess.Popen([*dask, "worker", "--scheduler-file", str(file), "--nthreads", "1",
                                           "--no-dashboard", "--host", "127.0.0.1"],
                                          stdout=log, stderr=subprocess.STDOUT))
        from distributed import Client

        with Client(scheduler_file=str(file), timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield file
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()


def test_dask_scheduler_file_is_what_the_cli_reads(scheduler_file):
    address = json.loads(scheduler_file.read_text())["address"]
    assert address.startswith("tcp://127.0.0.1:")


def test_upgrade_on_a_dask_cluster_gives_the_same_bytes(scheduler_file, tmp_path):
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    r = _spinemesh("upgrade", DEMO, "--out", local, "--jobs", "1")
    assert r.returncode == 0, r.stderr
    r = _spinemesh("upgrade", DEMO, "--out", cluster, "--dask", scheduler_file)
    assert r.returncode == 0, r.stderr
    assert tree_bytes(local) == tree_bytes(cluster)
    assert any(name.endswith(".skel") for name in tree_bytes(cluster))


def test_upgrade_pack_on_a_dask_cluster_gives_the_same_bytes(scheduler_file, tmp_path):
    """--pack runs its fills and pages on the cluster too: the same atlas and pages as one process."""
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    r = _spinemesh("upgrade", DEMO, "--out", local, "--jobs", "1", "--pack", "--pages", "any")
    assert r.returncode == 0, r.stderr
    r = _spinemesh("upgrade", DEMO, "--out", cluster, "--dask", scheduler_file, "--pack", "--pages", "any")
    assert r.returncode == 0, r.stderr
    assert tree_bytes(local) == tree_bytes(cluster)


def test_library_upgrade_on_a_dask_cluster_gives_the_same_bytes(scheduler_file, examples, tmp_path):
    """Two real projects in a folder tree, upgraded as one library, local and on the cluster."""
    import shutil

    library = tmp_path / "library"
    shutil.copytree(EXAMPLES / "4.2" / "owl", library / "birds" / "owl")
    shutil.copytree(EXAMPLES / "4.2" / "coin", library / "coin")
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    r = _spinemesh("upgrade", library, "--out", local, "--jobs", "2", "--report", tmp_path / "local.json")
    assert r.returncode == 0, r.stderr
    r = _spinemesh("upgrade", library, "--out", cluster, "--dask", scheduler_file,
                   "--report", tmp_path / "cluster.json")
    assert r.returncode == 0, r.stderr
    files = tree_bytes(local)
    assert files == tree_bytes(cluster)
    assert {"birds/owl/owl-pro.json", "birds/owl/owl-pro.skel", "coin/coin-pro.json"} <= set(files)
    rows = json.loads((tmp_path / "cluster.json").read_text())["attachments"]
    assert {r["skeleton"].split("/")[0] for r in rows} == {"birds", "coin"}
    assert all(r["status"] in ("meshed", "kept") for r in rows)  # kept: the mesher's keep rule, with a reason
    assert sum(r["status"] == "meshed" for r in rows) > len(rows) // 2


def test_dask_local_cluster_gives_the_same_bytes(tmp_path):
    try:
        import distributed  # noqa: F401
    except ImportError:
        unavailable("Dask is not installed (pip install 'spinemesh[cluster]')")
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    assert _spinemesh("upgrade", DEMO, "--out", local, "--jobs", "1").returncode == 0
    r = _spinemesh("upgrade", DEMO, "--out", cluster, "--dask", "local", "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert tree_bytes(local) == tree_bytes(cluster)


def test_unreachable_scheduler_is_one_clear_line(tmp_path):
    try:
        import distributed  # noqa: F401
    except ImportError:
        unavailable("Dask is not installed (pip install 'spinemesh[cluster]')")
    r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(DEMO), "--out", str(tmp_path / "out"),
                        "--dask", "tcp://127.0.0.1:9"], capture_output=True, text=True, timeout=120,
                       env=dict(os.environ, DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="2s"))
    assert r.returncode != 0
    assert "Traceback" not in r.stderr and "Dask scheduler" in r.stderr


def test_dataset_on_a_dask_cluster_gives_the_same_bytes(scheduler_file, examples, tmp_path):
    import shutil

    corpus = tmp_path / "corpus"
    shutil.copytree(EXAMPLES / "4.2" / "owl", corpus / "owl")
    shutil.copytree(EXAMPLES / "4.2" / "coin", corpus / "coin")
    local, cluster = tmp_path / "local", tmp_path / "cluster"
    r = _spinemesh("dataset", corpus, "--out", local, "--jobs", "1")
    assert r.returncode == 0, r.stderr
    r = _spinemesh("dataset", corpus, "--out", cluster, "--dask", scheduler_file)
    assert r.returncode == 0, r.stderr
    files = tree_bytes(local)
    assert files == tree_bytes(cluster)
    assert any(name.startswith("shards/") for name in files) and "index.jsonl" in files


def _page_like(n):
    import numpy as np

    from spinemesh.cluster import shared_array

    return shared_array(np.full((512, 256, 4), n, np.uint8))


def test_a_local_worker_hands_a_large_array_back_through_memory_that_is_freed_at_once():
    """The parent gets the worker's texels, read-only, out of an anonymous memory file (not
    through the pipe); nothing of it is left: no mapping, no descriptor, nothing in /dev/shm."""
    import numpy as np

    from spinemesh.cluster import SharedArray

    if not hasattr(os, "memfd_create"):
        unavailable("this system has no anonymous memory files (memfd_create): arrays go through the pipe")
    answer = _page_like(3)
    assert isinstance(answer, SharedArray)  # what a worker answers with
    answer.close()
    shm = shared_memory_segments()
    with open_workers(2) as w:
        arrays = [f.result() for f in [w.submit(_page_like, i) for i in range(6)]]
        for i, a in enumerate(arrays):
            assert type(a) is np.ndarray and a.shape == (512, 256, 4) and a.dtype == np.uint8 and (a == i).all()
            assert not a.flags.writeable
            with pytest.raises(ValueError):
                a.flags.writeable = True  # the worker's texels, shared by whoever cuts from them
        left = memory_files_left()
        assert len(left) == 6 and all(" r" in m for m in left)  # one mapping each, no descriptor kept
        del arrays, a
        assert memory_files_left() == []
    assert shared_memory_segments() == shm


def _nap(x):
    time.sleep(0.05)
    return x


def test_tasks_submitted_first_run_before_those_already_waiting():
    with open_workers(2) as w:
        waiting = [w.submit(_nap, i) for i in range(20)]  # 0.5 s of work for two workers
        first = w.submit(_nap, -1, first=True)
        assert first.result() == -1
        # before it, at most the tasks the two workers held when it came (and none waiting)
        assert sum(f.done() for f in waiting) <= 4
        assert [f.result() for f in waiting] == list(range(20))
