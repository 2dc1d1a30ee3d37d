"""Studies on a cluster: database references resolved by the workers, URL databases, results
released as soon as written, worker version check, dashboard, executors from entry points and
the Ray example, and no orphan processes after the study process is killed."""

from __future__ import annotations

import importlib.util
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import fsspec
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import vfs.study.executors as executors
from vfs.cli import main
from vfs.database import (
    Database,
    bundled_database_path,
    database_location,
    database_reference,
    open_database,
    save_database,
)
from vfs.errors import ClusterError, DataError, ParameterError
from vfs.physics.precrash import PrecrashParams
from vfs.physics.runout import RunoutParams
from vfs.simulation import SimulationParams
from vfs.study import EXECUTORS, ExecutorOptions, RunTask, register_executor, run_task
from vfs.study import run_study as _run_study
from vfs.study.inputs import study_input
from vfs.study.manifest import data_hash

ROOT = Path(__file__).resolve().parents[2]
WHERE = "case_id <= 24"
CHUNK = 6  # -> 4 chunks, 8 tasks with one system
SYSTEMS = ["three-stage"]
#: Coarse time steps: the cluster machinery is under test here, not the physics.
FAST = SimulationParams(precrash=PrecrashParams(dt=0.02, extra_time=1.0, contact_tolerance=0.001),
                        runout=RunoutParams(dt=0.025))


def run_study(db, out, **kwargs):  # noqa: ANN001, ANN003, ANN201
    kwargs.setdefault("params", FAST)
    kwargs.setdefault("progress", False)
    kwargs.setdefault("where", WHERE)
    kwargs.setdefault("chunk_size", CHUNK)
    return _run_study(db, SYSTEMS, out, **kwargs)


def runs_table(result):  # noqa: ANN001, ANN201
    return pq.read_table(result.path / "runs.parquet")


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201
    result = run_study("default", tmp_path_factory.mktemp("serial") / "s", engine="serial")
    assert result.complete
    return result


@pytest.fixture
def memory_db():  # noqa: ANN201
    """The bundled database copied into fsspec's in-memory file system."""
    fs = fsspec.filesystem("memory")
    root = f"/vfs-test-{os.getpid()}-{time.monotonic_ns()}"
    fs.put(str(bundled_database_path()), root, recursive=True)
    yield f"memory://{root}"
    fs.rm(root, recursive=True)


# ------------------------------------------------------------ database references


def test_tasks_carry_the_reference_not_the_clients_install_path(tmp_path, monkeypatch):
    seen: list[RunTask] = []

    def recording(tasks, on_result, options):  # noqa: ANN001, ANN202
        seen.extend(tasks)
        executors.EXECUTORS["serial"](tasks, on_result, options)

    register_executor("recording", recording, replace=True)
    try:
        run_study("default", tmp_path / "s", engine="recording", max_chunks=1)
    finally:
        EXECUTORS.remove("recording")
    install = str(bundled_database_path())
    assert seen and {t.db for t in seen} == {"default"}
    assert install.encode() not in pickle.dumps(seen[0])  # nothing of this machine's paths
    # a worker with vfs installed elsewhere finds its own copy
    elsewhere = tmp_path / "other-install" / "default"
    elsewhere.parent.mkdir()
    os.symlink(install, elsewhere)
    monkeypatch.setattr("vfs.database.source.bundled_database_path", lambda name: elsewhere)
    assert database_location("default") == str(elsewhere)
    table = run_task(seen[0])
    assert list(table["case_id"]) == list(seen[0].case_ids)
    # paths become absolute (a worker's working directory differs), URLs stay as given
    monkeypatch.chdir(tmp_path)
    assert database_reference("db") == str(tmp_path / "db")
    assert database_reference("memory://db") == "memory://db"


def test_the_client_reads_the_cases_table_validates_in_blocks_and_hashes_in_batches(tmp_path):
    whole = open_database("default", where="accident_type IN (241, 601)")
    got = study_input("default", "accident_type IN (241, 601)", block_cases=61)
    assert got.database is None and got.reference == "default"
    pd.testing.assert_frame_equal(got.cases, whole.cases, check_exact=True)
    assert got.data_hash == data_hash(whole)  # as if the whole selection were loaded
    # an invalid case in a later block is found as in a whole load
    db = open_database("default", where="case_id <= 150")
    bad = db.participants.copy()
    bad.loc[bad["case_id"] == 140, "mass"] = -1.0
    folder = save_database(Database(db.cases, bad, db.trajectories, db.reconstruction,
                                    meta=db.meta), tmp_path / "bad", validate=False)
    with pytest.raises(DataError, match=r"case_id 140.*mass|mass.*case_id 140"):
        study_input(folder, block_cases=100)
    with pytest.raises(DataError, match="no case selected"):
        study_input(folder, "case_id < 0")


# ------------------------------------------------------------ URL databases on dask


def test_file_url_on_a_local_cluster_equals_the_serial_run(serial, tmp_path):
    url = "file://" + str(bundled_database_path())
    result = run_study(url, tmp_path / "f", engine="dask", workers=2, dask_processes=True)
    assert result.manifest["db"] == url and result.manifest["db_reference"] == url
    assert runs_table(result).equals(runs_table(serial))
    pd.testing.assert_frame_equal(result.table, serial.table, check_exact=True)


def test_memory_url_with_threads_equals_serial_and_releases_results(serial, memory_db,
                                                                    tmp_path):
    from distributed import default_client

    held: list[tuple[int, int]] = []

    def on_chunk(chunk: int, done: int) -> None:
        client = default_client()
        on_workers = client.run(lambda dask_worker: len(dask_worker.data))
        held.append((len(client.futures), sum(on_workers.values())))

    result = run_study(memory_db, tmp_path / "m", engine="dask", workers=2,
                       dask_processes=False, in_flight=2, on_chunk=on_chunk)
    assert runs_table(result).equals(runs_table(serial))
    # 8 tasks in all (all 8 held at the end when futures are kept); never more than the 2 in
    # flight plus releases on their way (asynchronous) referenced by the client or kept by the
    # workers
    assert len(held) == 4
    assert max(n for n, _ in held) <= 3 and max(n for _, n in held) <= 4, held


def test_run_windowed_bounds_the_tasks_in_flight():
    tasks = [RunTask(chunk=k, case_ids=np.array([k]), system_index=0, system=None, db="default",
                     db_format="parquet", batch=None, equip="both", seed=0, params=FAST,
                     impact_parameters="reconstruction") for k in range(20)]
    outstanding, most, lock = [0], [0], threading.Lock()

    def work(task: RunTask) -> pd.DataFrame:
        time.sleep(0.002)
        return pd.DataFrame({"case_id": task.case_ids})

    def submit(task):  # noqa: ANN001, ANN202
        with lock:
            outstanding[0] += 1
            most[0] = max(most[0], outstanding[0])
        return pool.submit(work, task)

    got = []

    def on_result(task: RunTask, table: pd.DataFrame) -> None:
        with lock:
            outstanding[0] -= 1
        got.append(task.chunk)

    with ThreadPoolExecutor(4) as pool:
        executors.run_windowed(submit, tasks, on_result, limit=3)
    assert sorted(got) == list(range(20)) and most[0] == 3
    assert ExecutorOptions(4).max_in_flight() == 8
    assert ExecutorOptions(4).max_in_flight(slots=10) == 20
    assert ExecutorOptions(4, in_flight=5).max_in_flight(10) == 5


# ------------------------------------------------------------ versions and dashboard


def test_workers_with_another_vfs_are_refused():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        executors.check_worker_versions(client)  # the same: fine
        other = {**executors.worker_versions(), "vfs": "0.0.0-other"}
        with pytest.raises(ClusterError, match=r"1 of 1 dask worker\(s\) do not run the "
                           r"client's vfs 0\.0\.0-other.*inproc://.*\(vfs ") as info:
            executors.check_worker_versions(client, other)
        assert str(cluster.workers[0].address) in str(info.value)


def test_a_version_mismatch_stops_the_study_before_any_task(tmp_path, monkeypatch):
    # the workers (other processes) report the real version, the client a patched one
    monkeypatch.setattr(executors, "__version__", "0.0.0-client")
    with pytest.raises(ClusterError, match="0.0.0-client"):
        run_study("default", tmp_path / "v", engine="dask", workers=1, dask_processes=True)
    assert not list((tmp_path / "v" / "chunks").glob("*.parquet"))


def test_dashboard_is_off_by_default_and_printed_when_asked(tmp_path, capsys):
    run_study("default", tmp_path / "a", engine="dask", workers=1, dask_processes=False,
              max_chunks=1)
    assert "dashboard" not in capsys.readouterr().err
    run_study("default", tmp_path / "b", engine="dask", workers=1, dask_processes=False,
              max_chunks=1, dashboard="127.0.0.1:0")
    err = capsys.readouterr().err
    if importlib.util.find_spec("bokeh") is None:
        assert "dask dashboard: not available, the bokeh package is not installed" in err
    else:
        assert "dask dashboard: http://127.0.0.1:" in err
    with pytest.raises(ParameterError, match="dashboard"):
        run_study("default", tmp_path / "c", engine="process", dashboard=":8787")
    code = main(["study", "--db", "default", "--systems", "three-stage", "--out",
                 str(tmp_path / "d"), "--engine", "dask", "--scheduler", "tcp://127.0.0.1:1",
                 "--dashboard", ":8787"])
    assert code == 2


# ------------------------------------------------------------ executors from elsewhere


def test_an_executor_of_another_package_is_an_engine_choice(tmp_path, monkeypatch, capsys):
    (tmp_path / "vfs_fake_executor.py").write_text(textwrap.dedent("""
        from vfs.study.executors import EXECUTORS

        CALLS = []

        def run_fake(tasks, on_result, options):
            CALLS.append(len(tasks))
            EXECUTORS["serial"](tasks, on_result, options)
    """))
    info = tmp_path / "vfs_fake_executor-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: vfs-fake-executor\n"
                                   "Version: 1.0\n")
    (info / "entry_points.txt").write_text("[vfs.executors]\nfake = vfs_fake_executor:run_fake\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(EXECUTORS, "_entry_points_loaded", False)
    try:
        with pytest.raises(SystemExit):
            main(["study", "--help"])
        assert "fake" in capsys.readouterr().out
        out = tmp_path / "s"
        assert main(["study", "--db", "default", "--systems", "three-stage", "--where",
                     "case_id <= 3", "--engine", "fake", "--out", str(out)]) == 0
        assert sys.modules["vfs_fake_executor"].CALLS == [2]
    finally:
        EXECUTORS.remove("fake")


class FakeRay:
    """The part of Ray's API that examples/ray_executor.py uses, run in this process."""

    def __init__(self) -> None:
        self.initialized = False
        self.most_pending = 0
        self.pending: set[int] = set()

    def is_initialized(self) -> bool:
        return self.initialized

    def init(self, **kwargs) -> None:  # noqa: ANN003
        self.initialized = True
        self.kwargs = kwargs

    def shutdown(self) -> None:
        self.initialized = False

    def cluster_resources(self) -> dict[str, float]:
        return {"CPU": 1.0}

    def remote(self, fn):  # noqa: ANN001, ANN201
        ray = self

        class Ref:
            def __init__(self, args: tuple) -> None:
                self.args = args
                ray.pending.add(id(self))
                ray.most_pending = max(ray.most_pending, len(ray.pending))

        class Remote:
            def remote(self, *args):  # noqa: ANN002, ANN202
                return Ref(args)

        self.ref_type = Ref
        self.fn = fn
        return Remote()

    def wait(self, refs, num_returns=1):  # noqa: ANN001, ANN201
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref):  # noqa: ANN001, ANN201
        self.pending.discard(id(ref))
        return self.fn(*ref.args)


def test_ray_example_implements_the_executor_interface(serial, tmp_path, monkeypatch):
    fake = FakeRay()
    monkeypatch.setitem(sys.modules, "ray", fake)
    spec = importlib.util.spec_from_file_location("ray_executor_example",
                                                  ROOT / "examples" / "ray_executor.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    try:
        assert EXECUTORS.get("ray") is module.run_ray
        result = run_study("default", tmp_path / "r", engine="ray", workers=1)
        assert runs_table(result).equals(runs_table(serial))
        assert fake.kwargs == {"num_cpus": 1} and not fake.initialized
        assert fake.most_pending == 2  # max_in_flight of 1 CPU
    finally:
        EXECUTORS.remove("ray")


# ------------------------------------------------------------ no orphans


def _children(pid: int) -> set[int]:
    """All descendants of ``pid`` (from /proc)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier} - found
        found |= frontier
    return found


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux)")
def test_a_killed_process_engine_study_leaves_no_worker_alive(tmp_path):
    marker = tmp_path / "first-chunk"
    script = textwrap.dedent(f"""
        from pathlib import Path
        from vfs.physics.precrash import PrecrashParams
        from vfs.simulation import SimulationParams
        from vfs.study import run_study

        def on_chunk(chunk, done):
            Path({str(marker)!r}).touch()

        run_study("default", ["three-stage"], {str(tmp_path / "s")!r}, engine="process",
                  workers=2, chunk_size=4, progress=False, on_chunk=on_chunk,
                  params=SimulationParams(precrash=PrecrashParams(dt=0.02)))
    """)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    study = subprocess.Popen([sys.executable, "-c", script], env=env)
    children: set[int] = set()
    try:
        deadline = time.monotonic() + 120
        while not marker.exists() and study.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert study.poll() is None, "the study ended before it could be killed"
        children = _children(study.pid)
        workers = [p for p in children if "python" in Path(f"/proc/{p}/comm").read_text()]
        assert len(workers) >= 2, children  # the fork server and the pool's workers
        study.send_signal(signal.SIGKILL)
        study.wait()
        deadline = time.monotonic() + 10
        while any(_running(p) for p in children) and time.monotonic() < deadline:
            time.sleep(0.1)
        alive = sorted(p for p in children if _running(p))
        assert not alive, f"orphans still alive 10 s after the study was killed: {alive}"
    finally:
        if study.poll() is None:
            study.kill()
            study.wait()
        for pid in children:  # never leave our own orphans behind, even if the test fails
            if _running(pid):
                os.kill(pid, signal.SIGKILL)
