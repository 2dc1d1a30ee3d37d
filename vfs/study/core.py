"""AEB effectiveness studies: baseline and treatment runs of every case of a database.

A study re-simulates every selected case of an accident database once without
a system (``system = "baseline"``: the recorded behaviour) and once per AEB
system (the treatment: the system acts on the equipped vehicle(s)), each run
from the start of the records through impact or avoidance to rest
(:func:`vfs.simulation.simulate_cases`).  The outcome is one tidy table with a
row per (case, system), ``runs.parquet``, read by the effectiveness report
(:mod:`vfs.analysis.effectiveness`).

Work is split into chunks of ``chunk_size`` cases in database order.  Every
(chunk, system) pair, the baseline included, is one task: one vectorised
batch run of the chunk's cases.  A task loads its cases itself from the
database folder (it gets the path and the case ids, not arrays) and returns
its table; when all runs of a chunk are in, the main process writes the
chunk atomically to ``chunks/chunk_000123.parquet``.  Chunks on disk are
never redone (``resume``).  A case that makes a batch raise is isolated by
bisection and recorded with its error message.  Chunk ``k`` and system index
``j`` (0 = baseline, 1.. = the systems in the order given) draw their random
numbers from ``numpy.random.default_rng([seed, k, j])``, so the results do not
depend on the executor (serial, local processes, dask) nor on the order in
which tasks finish.  (Tasks per system rather than per chunk balance the load
when systems differ in cost.)

Layout of a study folder::

    study.json             manifest (inputs, hashes, versions, status, summary)
    cases.parquet          the selected rows of the database's cases table
    chunks/chunk_*.parquet one table per chunk (kept for --resume)
    runs.parquet           all chunks combined (written when every chunk is done)

See ``docs/study.md`` for the columns, units and the command line.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import json
import multiprocessing
import os
import platform
import shutil
import sys
import time
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from vfs.database import select_database
from vfs.errors import DataError, DataProblem, ParameterError, SimulationError
from vfs.physics.precrash import BrakeController, PrecrashParams
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases

#: Value of the ``system`` column for the runs without a system (recorded behaviour).
BASELINE = "baseline"

#: Which vehicles carry the system: ``--equip`` value -> equipped flags of (vehicle 1, 2).
EQUIP_RULES: dict[str, tuple[bool, bool]] = {
    "1": (True, False),
    "2": (False, True),
    "both": (True, True),
}

#: Default number of cases per chunk.
DEFAULT_CHUNK_SIZE = 200

MANIFEST_FILE = "study.json"
CASES_FILE = "cases.parquet"
RUNS_FILE = "runs.parquet"
CHUNK_DIR = "chunks"
#: Value of ``study.json["format"]``; identifies a study folder.
MANIFEST_FORMAT = "vfs-study"
MANIFEST_VERSION = 1

#: Manifest entries that must match for ``resume`` (the inputs that determine the results).
RESUME_KEYS: tuple[str, ...] = ("data_hash", "case_ids_hash", "system_names",
                                "system_definitions", "equip", "seed", "chunk_size",
                                "impact_parameters", "params")

#: Columns every runs table starts with (then those of :func:`results_table`, then events).
KEY_COLUMNS: tuple[str, ...] = ("case_id", "system", "accident_type", "weight", "error",
                                "equipped1", "equipped2")

#: Integer columns; stored as pandas' nullable ``Int64`` (NA for failed runs).
INT_COLUMNS: tuple[str, ...] = ("cp_rule",)

#: Boolean columns; stored as pandas' nullable ``boolean`` (NA for failed runs).
BOOL_COLUMNS: tuple[str, ...] = ("collided", "avoided", "at_rest1", "at_rest2",
                                 "secondary_collision", "equipped1", "equipped2")


class AEBSystem(Protocol):
    """What a study needs from an AEB system (``vfs.adas.get_system(name)`` returns one).

    It must be picklable (it is sent to the worker processes).
    """

    name: str
    description: str

    def controller(self, batch: CaseBatch, equipped: np.ndarray) -> BrakeController | None:
        """Controller for the cases of ``batch``; ``equipped`` (N, 2) bool."""

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """Pre-crash settings with this system's brake actuator."""


SystemRegistry = Mapping[str, Any] | Callable[[str], Any]


def resolve_system(name: str, registry: SystemRegistry | None = None) -> AEBSystem:
    """Look up an AEB system by name.

    Parameters
    ----------
    name : str
        System name, e.g. ``"three-stage"``.
    registry : mapping or callable, optional
        Where to look: a ``{name: system}`` mapping or a ``name -> system``
        function; default :func:`vfs.adas.get_system`.

    Returns
    -------
    AEBSystem

    Raises
    ------
    ParameterError
        Unknown name, or the systems package is not installed.
    """
    if registry is None:
        from vfs.adas import get_system

        registry = get_system
    if isinstance(registry, Mapping):
        if name not in registry:
            raise ParameterError(f"unknown system {name!r}; known: {', '.join(registry)}")
        system = registry[name]
    else:
        try:
            system = registry(name)
        except KeyError:
            raise ParameterError(f"unknown system {name!r}") from None
    for attr in ("name", "controller", "precrash_params"):
        if not hasattr(system, attr):
            raise ParameterError(f"system {name!r} ({type(system).__name__}) has no {attr!r}")
    return system


def _resolve_systems(systems: Sequence[str | Any] | str,
                     registry: SystemRegistry | None) -> list[Any]:
    if isinstance(systems, str):
        systems = [s.strip() for s in systems.split(",") if s.strip()]
    resolved = [resolve_system(s, registry) if isinstance(s, str) else s for s in systems]
    if not resolved:
        raise ParameterError("no system given: name at least one, e.g. 'three-stage'")
    for s in resolved:
        if not (isinstance(getattr(s, "name", None), str)
                and callable(getattr(s, "controller", None))
                and callable(getattr(s, "precrash_params", None))):
            raise ParameterError(f"{s!r} is not an AEB system: it needs a name, controller() "
                                 "and precrash_params()")
    names = [s.name for s in resolved]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ParameterError(f"system(s) given twice: {', '.join(dupes)}")
    if BASELINE in names:
        raise ParameterError(f"{BASELINE!r} is reserved for the runs without a system")
    return resolved


def equipped_flags(equip: str | int, n: int) -> np.ndarray:
    """Equipped vehicles (N, 2) bool for an ``equip`` rule (:data:`EQUIP_RULES`)."""
    key = str(equip)
    if key not in EQUIP_RULES:
        raise ParameterError(f"equip={equip!r}; use one of {', '.join(EQUIP_RULES)}")
    return np.tile(np.asarray(EQUIP_RULES[key], dtype=bool), (n, 1))


# ----------------------------------------------------------------------------
# One chunk (runs in the workers)
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class RunTask:
    """One vectorised run: the cases of one chunk with one system (small; pickled).

    Attributes
    ----------
    chunk : int
        Chunk number k (position in the study, from 0).
    case_ids : ndarray (n,)
        The chunk's cases in database order.
    system_index : int
        j: 0 for the baseline, 1.. for the systems in the study's order.
    system : object or None
        The AEB system; None for the baseline.
    db_path : str or None
        Database folder the worker loads the cases from.
    db_format : str
        ``"parquet"``, ``"csv"`` or ``"pcm"`` (``"memory"`` with ``batch``).
    batch : CaseBatch or None
        The cases themselves when the study runs on an in-memory database
        (no folder).
    equip : str
        Key of :data:`EQUIP_RULES`.
    seed : int
        Study seed; the run draws from ``default_rng([seed, chunk, system_index])``.
    params : SimulationParams
        Base simulation parameters (a system adapts the pre-crash part).
    impact_parameters : str
        ``"reconstruction"`` or ``"default"`` (:meth:`CaseBatch.from_database`).
    """

    chunk: int
    case_ids: np.ndarray
    system_index: int
    system: Any | None
    db_path: str | None
    db_format: str
    batch: CaseBatch | None
    equip: str
    seed: int
    params: SimulationParams
    impact_parameters: str

    @property
    def system_name(self) -> str:
        """Value of the ``system`` column."""
        return BASELINE if self.system is None else str(self.system.name)


@lru_cache(maxsize=2)
def _whole_database(path: str, fmt: str, stamp: float) -> Any:
    """A whole non-Parquet database, loaded once per worker process."""
    from vfs.database import load_any

    return load_any(path, fmt=fmt, validate=False)


def load_chunk(task: RunTask) -> CaseBatch:
    """The chunk's cases as a batch, in the task's order.

    Parquet databases are read case-selectively (duckdb on the files, only
    the chunk's rows); CSV and PCM folders are loaded whole once per process.
    """
    if task.batch is not None:
        return task.batch
    if task.db_path is None:
        raise ParameterError("a chunk task needs a database path or a batch")
    ids = np.asarray(task.case_ids)
    if task.db_format == "parquet":
        from vfs.database import load_database

        where = "case_id IN (" + ", ".join(str(int(i)) for i in ids) + ")"
        db = load_database(task.db_path, where=where, validate=False)
    else:
        stamp = max(p.stat().st_mtime for p in Path(task.db_path).iterdir())
        db = _whole_database(task.db_path, task.db_format, stamp)
    return CaseBatch.from_database(db, ids, impact_parameters=task.impact_parameters)


def error_text(exc: BaseException) -> str:
    """The message recorded for a failed run: ``"TypeName: message"`` (one line)."""
    text = f"{type(exc).__name__}: {exc}".replace("\n", " ").strip()
    return text if len(text) <= 500 else text[:497] + "..."


def _events_columns(controller: object, n: int) -> dict[str, np.ndarray]:
    """``controller.events()`` as columns ``<key>1``, ``<key>2`` (NaN where never)."""
    events = getattr(controller, "events", None)
    if controller is None or not callable(events):
        return {}
    cols: dict[str, np.ndarray] = {}
    for key, values in dict(events()).items():
        arr = np.asarray(values, dtype=float)
        if arr.shape != (n, 2):
            raise SimulationError(f"controller event {key!r} has shape {arr.shape}, "
                                  f"expected ({n}, 2)")
        cols[f"{key}1"], cols[f"{key}2"] = arr[:, 0], arr[:, 1]
    return cols


def _run_batch(batch: CaseBatch, system: Any | None, equipped: np.ndarray,
               params: SimulationParams, rng: np.random.Generator) -> pd.DataFrame:
    """One vectorised run of ``batch`` (baseline when ``system`` is None) as a table."""
    controller = None
    if system is not None:
        params = dataclasses.replace(params,
                                     precrash=system.precrash_params(params.precrash))
        controller = system.controller(batch, equipped)
    res = simulate_cases(batch, controller=controller, params=params, rng=rng)
    table = results_table(batch, res)
    for name, values in _events_columns(controller, batch.size).items():
        table[name] = values
    return table


def _run_guarded(batch: CaseBatch, system: Any | None, equipped: np.ndarray,
                 params: SimulationParams, key: list[int]
                 ) -> tuple[list[pd.DataFrame], dict[int, str]]:
    """Run the batch; if it raises, bisect to isolate the failing cases.

    Returns the tables of the parts that ran (each with a ``_pos`` column:
    the case's position in ``batch``) and ``{position: error text}``.
    Sub-batches draw from ``default_rng(key + [first position, size])``.
    """

    def attempt(start: int, stop: int) -> tuple[list[pd.DataFrame], dict[int, str]]:
        whole = start == 0 and stop == batch.size
        sub = batch if whole else batch.take(np.arange(start, stop))
        rng = np.random.default_rng(key if whole else [*key, start, stop - start])
        try:
            table = _run_batch(sub, system, equipped[start:stop], params, rng)
        except Exception as exc:  # recorded per case; the study goes on
            if stop - start == 1:
                return [], {start: error_text(exc)}
            mid = (start + stop) // 2
            t1, e1 = attempt(start, mid)
            t2, e2 = attempt(mid, stop)
            return t1 + t2, {**e1, **e2}
        table.insert(0, "_pos", np.arange(start, stop))
        return [table], {}

    return attempt(0, batch.size)


def run_task(task: RunTask) -> pd.DataFrame:
    """Simulate the chunk's cases with one system (or the baseline) as one batch.

    Returns one row per case in the task's order: case_id, system, error
    (empty when fine), equipped1/2, the :func:`results_table` columns and
    the controller's events; failed runs have an error text and NaN
    outcomes.  Case metadata (accident type, weight) is added by the caller.
    """
    batch = load_chunk(task)
    equipped = equipped_flags(task.equip, batch.size)
    tables, errors = _run_guarded(batch, task.system, equipped, task.params,
                                  [int(task.seed), int(task.chunk), int(task.system_index)])
    if errors:
        pos = np.fromiter(errors, dtype=np.int64)
        tables.append(pd.DataFrame({"_pos": pos, "case_id": batch.case_id[pos],
                                    "error": list(errors.values())}))
    out = pd.concat(tables, ignore_index=True) if len(tables) > 1 else tables[0]
    out = out.sort_values("_pos", kind="stable").drop(columns="_pos")
    out.insert(1, "system", task.system_name)
    if "error" not in out.columns:
        out["error"] = ""
    out["error"] = out["error"].fillna("").astype(object)
    flags = EQUIP_RULES[task.equip] if task.system is not None else (False, False)
    out["equipped1"], out["equipped2"] = flags
    return out.reset_index(drop=True)


def assemble_chunk(parts: Sequence[pd.DataFrame], cases: pd.DataFrame | None = None
                   ) -> pd.DataFrame:
    """One chunk's table from its runs (baseline first): rows case by case, then system."""
    frames = []
    for j, part in enumerate(parts):
        frames.append(part.assign(_pos=np.arange(len(part)), _sys=j))
    out = pd.concat(frames, ignore_index=True)
    out = out.sort_values(["_pos", "_sys"], kind="stable").drop(columns=["_pos", "_sys"])
    return normalise_runs(out.reset_index(drop=True), cases)


def normalise_runs(df: pd.DataFrame, cases: pd.DataFrame | None = None) -> pd.DataFrame:
    """Column order and dtypes of a runs table (also used for each chunk).

    Adds ``accident_type`` and ``weight`` from ``cases`` (weight NaN -> 1),
    puts :data:`KEY_COLUMNS` first, makes :data:`BOOL_COLUMNS` nullable
    booleans, ``impact_type`` text with NA for failed runs and ``error`` text
    (empty when the run was fine).
    """
    out = df.copy()
    if cases is not None:
        meta = cases.drop_duplicates("case_id").set_index("case_id")
        ids = out["case_id"].to_numpy()
        if "accident_type" in meta.columns:
            out["accident_type"] = meta["accident_type"].reindex(ids).to_numpy()
        weight = meta["weight"].reindex(ids).to_numpy(float) if "weight" in meta.columns \
            else np.ones(len(out))
        out["weight"] = np.where(np.isfinite(weight), weight, 1.0)
    for col in KEY_COLUMNS:
        if col not in out.columns:
            out[col] = "" if col == "error" else np.nan
    out["error"] = out["error"].fillna("").astype(str).astype(object)
    for col in BOOL_COLUMNS:
        if col in out.columns:
            out[col] = out[col].astype("boolean")
    for col in INT_COLUMNS:
        if col in out.columns:
            out[col] = out[col].astype("Int64")
    if "impact_type" in out.columns:
        out["impact_type"] = out["impact_type"].astype(object).where(
            out["impact_type"].notna(), None)
    rest = [c for c in out.columns if c not in KEY_COLUMNS]
    return out[list(KEY_COLUMNS) + rest]


# ----------------------------------------------------------------------------
# Executors (registry)
# ----------------------------------------------------------------------------

OnResult = Callable[[RunTask, pd.DataFrame], None]


@dataclass(frozen=True)
class ExecutorOptions:
    """Settings of an executor.

    Attributes
    ----------
    workers : int
        Number of parallel workers (processes or dask workers).
    scheduler : str or None
        Address of a running dask scheduler (``tcp://host:8786``); None
        starts a local cluster.
    dask_processes : bool
        Local dask cluster with worker processes (True) or threads (False).
    """

    workers: int
    scheduler: str | None = None
    dask_processes: bool = True


Executor = Callable[[Sequence[RunTask], OnResult, ExecutorOptions], None]


def _run_serial(tasks: Sequence[RunTask], on_result: OnResult,
                options: ExecutorOptions) -> None:
    for task in tasks:
        on_result(task, run_task(task))


def _mp_context() -> Any:
    # not "fork": the parent may hold threads (dask, BLAS); forkserver
    # imports vfs once in its server, workers fork from there
    methods = multiprocessing.get_all_start_methods()
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["vfs.study.core"])
        return ctx
    return multiprocessing.get_context("spawn")


def _run_processes(tasks: Sequence[RunTask], on_result: OnResult,
                   options: ExecutorOptions) -> None:
    pool = ProcessPoolExecutor(max_workers=options.workers, mp_context=_mp_context())
    try:
        futures = {pool.submit(run_task, task): task for task in tasks}
        for future in as_completed(futures):
            on_result(futures[future], future.result())
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def _run_dask(tasks: Sequence[RunTask], on_result: OnResult,
              options: ExecutorOptions) -> None:
    import logging

    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError as exc:
        raise ParameterError(f"engine 'dask' needs dask.distributed ({exc})") from None
    cluster = None
    if options.scheduler:
        client = Client(options.scheduler)
    else:
        cluster = LocalCluster(n_workers=options.workers, threads_per_worker=1,
                               processes=options.dask_processes, dashboard_address=None,
                               silence_logs=logging.ERROR)
        client = Client(cluster)
    try:
        token = uuid.uuid4().hex[:8]
        futures = {client.submit(run_task, task, pure=False,
                                 key=f"vfs-study-{token}-{task.chunk}-{task.system_index}"): task
                   for task in tasks}
        for future in dask_completed(list(futures)):
            on_result(futures[future], future.result())
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: Executors by name (``--engine``); add one with :func:`register_executor`.
EXECUTORS: dict[str, Executor] = {
    "serial": _run_serial,
    "process": _run_processes,
    "dask": _run_dask,
}


def register_executor(name: str, executor: Executor, *, replace: bool = False) -> None:
    """Add an executor ``executor(tasks, on_result, options)`` to :data:`EXECUTORS`."""
    if name in EXECUTORS and not replace:
        raise ParameterError(f"an executor named {name!r} is already registered")
    EXECUTORS[name] = executor


def cpu_count() -> int:
    """CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


# ----------------------------------------------------------------------------
# Manifest, hashes, files
# ----------------------------------------------------------------------------


def _sha256(parts: Iterable[bytes]) -> str:
    h = hashlib.sha256()
    for part in parts:
        h.update(part)
    return h.hexdigest()


def case_ids_hash(case_ids: Sequence[object] | np.ndarray) -> str:
    """SHA-256 of the case ids in order (JSON of the list)."""
    ids = [v.item() if isinstance(v, np.generic) else v for v in np.asarray(case_ids).tolist()]
    return _sha256([json.dumps(ids).encode()])


def data_hash(db: Any) -> str:
    """SHA-256 of the contents of a database's four tables (format independent)."""
    parts = []
    for name, df in db.tables().items():
        parts.append(name.encode())
        parts.append(",".join(map(str, df.columns)).encode())
        parts.append(pd.util.hash_pandas_object(df, index=False).to_numpy().tobytes())
    return _sha256(parts)


def _versions() -> dict[str, str]:
    import pyarrow

    import vfs

    versions = {"vfs": vfs.__version__, "python": platform.python_version(),
                "numpy": np.__version__, "pandas": pd.__version__,
                "pyarrow": pyarrow.__version__, "platform": platform.platform()}
    return versions


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _json_default(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.tmp-{uuid.uuid4().hex}")


def write_json_atomic(data: Mapping[str, Any], path: Path) -> None:
    """Write JSON through a temporary file and :func:`os.replace`."""
    tmp = _tmp_path(path)
    try:
        tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n",
                       encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_parquet_atomic(df: pd.DataFrame, path: Path) -> None:
    """Write a table as Parquet through a temporary file and :func:`os.replace`."""
    tmp = _tmp_path(path)
    try:
        df.to_parquet(tmp, index=False)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def read_manifest(folder: str | os.PathLike[str]) -> dict[str, Any]:
    """``study.json`` of a study folder.

    Raises
    ------
    DataError
        If the folder holds no study manifest.
    """
    file = Path(folder) / MANIFEST_FILE
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{folder} is not a study folder (no {MANIFEST_FILE})")
                        ) from None
    except (OSError, ValueError) as exc:
        raise DataError(DataProblem("study", "", None, None,
                                    f"cannot read {file}: {exc}")) from None
    if not isinstance(manifest, dict) or manifest.get("format") != MANIFEST_FORMAT:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{file} is not a vfs study manifest"))
    return manifest


def chunk_path(folder: Path, index: int) -> Path:
    """File of chunk ``index`` in a study folder."""
    return folder / CHUNK_DIR / f"chunk_{index:06d}.parquet"


def _prepare_folder(out: Path, manifest: dict[str, Any], resume: bool,
                    overwrite: bool) -> dict[str, Any]:
    """Check / create the output folder; return the manifest to use."""
    has_study = (out / MANIFEST_FILE).exists()
    non_empty = out.exists() and (not out.is_dir() or any(out.iterdir()))
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    if non_empty and not has_study:
        raise ParameterError(f"{out} is a non-empty folder that is not a study; choose another "
                             "--out (nothing is overwritten there)")
    if resume and has_study:
        old = read_manifest(out)
        diffs = [k for k in RESUME_KEYS if old.get(k) != manifest.get(k)]
        if diffs:
            lines = [f"  {k}: study has {old.get(k)!r}, now {manifest.get(k)!r}" for k in diffs]
            raise ParameterError(f"cannot resume {out}: the study was started with other "
                                 "inputs:\n" + "\n".join(lines)
                                 + "\n(use --overwrite to start over)")
        merged = {**manifest, "created": old.get("created", manifest["created"])}
        merged["history"] = [*old.get("history", []), {"resumed": _now()}]
        for tmp in [*out.glob(".*.tmp-*"), *(out / CHUNK_DIR).glob(".*.tmp-*")]:
            tmp.unlink(missing_ok=True)  # leftovers of an interrupted write
        return merged
    if has_study and not overwrite:
        raise ParameterError(f"{out} already holds a study; use --resume to continue it or "
                             "--overwrite to replace it")
    if has_study:
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    return manifest


# ----------------------------------------------------------------------------
# The study
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class StudyResult:
    """Outcome of :func:`run_study` (or :func:`load_study`).

    Attributes
    ----------
    path : Path
        Study folder.
    table : pandas.DataFrame or None
        ``runs.parquet``: one row per (case, system); None while the study is
        incomplete.
    manifest : dict
        Contents of ``study.json``.
    """

    path: Path
    table: pd.DataFrame | None
    manifest: dict[str, Any]

    @property
    def complete(self) -> bool:
        """All chunks done and ``runs.parquet`` written."""
        return self.manifest.get("status") == "complete" and self.table is not None

    def summary(self) -> str:
        """A few lines for people: cases, systems, crashes avoided, time."""
        m = self.manifest
        s = m.get("summary", {})
        lines = [f"study {self.path}: {m.get('n_cases')} cases, systems "
                 f"{', '.join(m.get('system_names', []))} (equip {m.get('equip')}), "
                 f"status {m.get('status')}"]
        if not self.complete:
            lines.append(f"  {s.get('chunks_done', 0)} of {m.get('n_chunks')} chunks done; "
                         "continue with --resume")
        for name, row in s.get("systems", {}).items():
            lines.append(f"  {name:>16s}: {row['crashes']} crashes of {row['cases']} cases"
                         + (f", {row['avoided']} of {row['baseline_crashes']} baseline crashes "
                            "avoided" if name != BASELINE else "")
                         + (f", {row['errors']} failed" if row["errors"] else ""))
        if "elapsed_s" in s:
            lines.append(f"  {s['cases_run']} cases simulated in {s['elapsed_s']:.1f} s "
                         f"({s['cases_per_s']:.0f} cases/s, "
                         f"{len(m.get('system_names', [])) + 1} runs per case)")
        return "\n".join(lines)


def _counts_summary(runs: pd.DataFrame, names: Sequence[str]) -> dict[str, Any]:
    """Crashes and avoided crashes per system (cases where both runs succeeded)."""
    base = runs[runs["system"] == BASELINE].set_index("case_id")
    out: dict[str, Any] = {}
    for name in (BASELINE, *names):
        t = runs[runs["system"] == name].set_index("case_id")
        ok = (t["error"] == "") & (base["error"].reindex(t.index) == "")
        b_crash = base["collided"].reindex(t.index).fillna(False).to_numpy(bool) & ok.to_numpy()
        t_crash = t["collided"].fillna(False).to_numpy(bool) & ok.to_numpy()
        out[name] = {"cases": int(ok.sum()), "errors": int((t["error"] != "").sum()),
                     "crashes": int(t_crash.sum()), "baseline_crashes": int(b_crash.sum()),
                     "avoided": int((b_crash & ~t_crash).sum())}
    return out


def run_study(
    db: str | os.PathLike[str] | Any,
    systems: Sequence[str | Any] | str,
    out: str | os.PathLike[str],
    *,
    engine: str = "process",
    workers: int | None = None,
    scheduler: str | None = None,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
    seed: int = 0,
    where: str | None = None,
    equip: str | int = "both",
    resume: bool = False,
    overwrite: bool = False,
    params: SimulationParams | None = None,
    impact_parameters: str = "reconstruction",
    registry: SystemRegistry | None = None,
    progress: bool | None = None,
    dask_processes: bool = True,
    max_chunks: int | None = None,
    on_chunk: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """Run (or resume) an AEB effectiveness study and write its folder.

    Parameters
    ----------
    db : path, ``"default"`` or Database
        Database folder (Parquet, CSV or PCM), ``"default"`` for the bundled
        database, or an in-memory :class:`vfs.database.Database` (its chunks
        are then pickled to the workers).
    systems : sequence of str or system objects, or "a,b"
        AEB systems; names are looked up with :func:`resolve_system`.
    out : path
        Study folder (created).
    engine : {"serial", "process", "dask"}
        Executor (:data:`EXECUTORS`); default local processes.
    workers : int, optional
        Parallel workers; default ``min(cpu count, tasks to run)`` (a task = one
        chunk with one system).
    scheduler : str, optional
        Dask scheduler address (engine "dask"); default a local cluster.
    chunk_size : int
        Cases per chunk (default 200).
    seed : int
        Seed of all random draws (systems with noise or reaction times).
    where : str, optional
        SQL predicate on the cases table selecting the cases (duckdb).
    equip : {"1", "2", "both"}
        Which vehicles carry the system in the treatment runs; default both.
    resume : bool
        Continue the study in ``out``: chunks on disk are kept; refused if
        the inputs differ (:data:`RESUME_KEYS`).  An absent or empty ``out``
        starts a new study.
    overwrite : bool
        Replace an existing study in ``out`` (never a folder of another kind).
    params : SimulationParams, optional
        Base simulation settings; each system replaces the pre-crash part
        with ``system.precrash_params(params.precrash)``.
    impact_parameters : {"reconstruction", "default"}
        Restitution and contact friction of the reconstruction where present
        (default) or the model defaults.
    registry : mapping or callable, optional
        System lookup instead of :func:`vfs.adas.get_system`.
    progress : bool, optional
        Progress bar on stderr; default when stderr is a terminal and the
        environment variable CI is not set.
    dask_processes : bool
        Local dask cluster with processes (True) or threads.
    max_chunks : int, optional
        Run at most this many chunks now, then return an incomplete study
        (to be resumed); for tests and staged runs.
    on_chunk : callable, optional
        ``on_chunk(chunk_index, cases_done)`` after each chunk file is written.

    Returns
    -------
    StudyResult

    Raises
    ------
    ParameterError
        Bad arguments, an existing study without resume/overwrite, or a
        resume with other inputs.
    DataError
        The database cannot be read or ``where`` is invalid.
    """
    started = time.perf_counter()
    if engine not in EXECUTORS:
        raise ParameterError(f"engine {engine!r}; use one of {', '.join(EXECUTORS)}")
    if isinstance(chunk_size, bool) or int(chunk_size) != chunk_size or chunk_size < 1:
        raise ParameterError(f"chunk_size={chunk_size!r} must be a positive integer")
    if workers is not None and (int(workers) != workers or workers < 1):
        raise ParameterError(f"workers={workers!r} must be a positive integer")
    if impact_parameters not in ("reconstruction", "default"):
        raise ParameterError(f"impact_parameters={impact_parameters!r}; use 'reconstruction' "
                             "or 'default'")
    equip = str(equip)
    equipped_flags(equip, 0)  # validates
    seed = int(seed)
    chunk_size = int(chunk_size)
    params = params or SimulationParams()
    system_objs = _resolve_systems(systems, registry)
    names = [str(s.name) for s in system_objs]

    selection = select_database(db, where)
    database, folder, fmt = selection.database, selection.folder, selection.fmt
    ids = database.case_ids
    if ids.size == 0:
        raise DataError(DataProblem("cases", "", None, None,
                                    "no case selected" + (f" by {where!r}" if where else "")))
    chunks = [ids[i:i + chunk_size] for i in range(0, ids.size, chunk_size)]
    out_dir = Path(out)
    manifest: dict[str, Any] = {
        "format": MANIFEST_FORMAT, "format_version": MANIFEST_VERSION, "status": "running",
        "created": _now(), "updated": _now(),
        "db": folder if folder is not None else "<in-memory database>",
        "db_format": fmt, "db_name": str(database.meta.get("name", "")),
        "where": where, "data_hash": data_hash(database), "case_ids_hash": case_ids_hash(ids),
        "n_cases": int(ids.size), "chunk_size": chunk_size, "n_chunks": len(chunks),
        "system_names": names,
        "systems": [{"name": n, "description": str(getattr(s, "description", "")),
                     "brake": repr(getattr(s, "brake", None))}
                    for n, s in zip(names, system_objs, strict=True)],
        "system_definitions": [repr(s) for s in system_objs],
        "equip": equip, "equipped": list(EQUIP_RULES[equip]), "seed": seed,
        "rng": "numpy.random.default_rng([seed, chunk, system index]); baseline index 0",
        "impact_parameters": impact_parameters, "params": repr(params),
        "engine": engine, "versions": _versions(),
    }
    manifest = _prepare_folder(out_dir, manifest, resume, overwrite)
    (out_dir / CHUNK_DIR).mkdir(exist_ok=True)
    write_json_atomic(manifest, out_dir / MANIFEST_FILE)
    cases_meta = database.cases.reset_index(drop=True)
    write_parquet_atomic(cases_meta, out_dir / CASES_FILE)

    todo = [k for k in range(len(chunks)) if not chunk_path(out_dir, k).exists()]
    if max_chunks is not None:
        todo = todo[:max(0, int(max_chunks))]
    batch_all = None
    if folder is None:
        batch_all = CaseBatch.from_database(database, impact_parameters=impact_parameters)
    runners: list[Any | None] = [None, *system_objs]
    tasks = []
    for k in todo:
        start = k * chunk_size
        sub = None if batch_all is None else batch_all.take(
            np.arange(start, start + chunks[k].size))
        for j, system in enumerate(runners):
            tasks.append(RunTask(
                chunk=k, case_ids=chunks[k], system_index=j, system=system, db_path=folder,
                db_format=fmt, batch=sub, equip=equip, seed=seed, params=params,
                impact_parameters=impact_parameters))
    n_workers = 1 if engine == "serial" else (
        int(workers) if workers else max(1, min(cpu_count(), len(tasks))))
    show = progress if progress is not None else (sys.stderr.isatty()
                                                  and not os.environ.get("CI"))
    cases_run = 0
    pending: dict[int, dict[int, pd.DataFrame]] = {}

    from tqdm import tqdm

    bar = tqdm(total=sum(chunks[k].size for k in todo), unit="case", desc="vfs study",
               disable=not show, smoothing=0.1, file=sys.stderr,
               bar_format="{l_bar}{bar}| {n:.0f}/{total_fmt} [{elapsed}<{remaining}, "
                          "{rate_fmt}]")

    def on_result(task: RunTask, table: pd.DataFrame) -> None:
        # collect the runs of a chunk; write the chunk file when all are in
        nonlocal cases_run
        n = len(task.case_ids)
        if len(table) != n:
            raise SimulationError(f"chunk {task.chunk}, system {task.system_name}: "
                                  f"{len(table)} rows for {n} cases")
        parts = pending.setdefault(task.chunk, {})
        parts[task.system_index] = table
        bar.update(n / len(runners))
        if len(parts) < len(runners):
            return
        del pending[task.chunk]
        chunk_table = assemble_chunk([parts[j] for j in range(len(runners))], cases_meta)
        write_parquet_atomic(chunk_table, chunk_path(out_dir, task.chunk))
        cases_run += n
        if on_chunk is not None:
            on_chunk(task.chunk, cases_run)

    try:
        if tasks:
            EXECUTORS[engine](tasks, on_result,
                              ExecutorOptions(n_workers, scheduler, dask_processes))
    except BaseException as exc:
        # chunks written so far stay; the study can be resumed
        manifest.update(status="interrupted" if isinstance(exc, KeyboardInterrupt) else "failed",
                        updated=_now(), error=error_text(exc))
        write_json_atomic(manifest, out_dir / MANIFEST_FILE)
        raise
    finally:
        bar.close()
    manifest.pop("error", None)

    elapsed = time.perf_counter() - started
    done = [k for k in range(len(chunks)) if chunk_path(out_dir, k).exists()]
    summary: dict[str, Any] = {"chunks_done": len(done), "cases_run": cases_run,
                               "elapsed_s": elapsed,
                               "cases_per_s": cases_run / elapsed if elapsed > 0 else 0.0,
                               "workers": n_workers}
    table = None
    if len(done) == len(chunks):
        write_parquet_atomic(combine_chunks(out_dir, ids, [BASELINE, *names]),
                             out_dir / RUNS_FILE)
        table = pd.read_parquet(out_dir / RUNS_FILE)  # dtypes exactly as load_study gives
        summary["systems"] = _counts_summary(table, names)
        manifest["status"] = "complete"
    else:
        manifest["status"] = "incomplete"
    manifest.update(updated=_now(), summary=summary)
    write_json_atomic(manifest, out_dir / MANIFEST_FILE)
    return StudyResult(out_dir, table, manifest)


def combine_chunks(folder: Path, case_ids: np.ndarray, systems: Sequence[str]) -> pd.DataFrame:
    """The runs table from the chunk files, checked for completeness and duplicates."""
    files = sorted((folder / CHUNK_DIR).glob("chunk_*.parquet"))
    frames = [pd.read_parquet(f) for f in files]
    table = normalise_runs(pd.concat(frames, ignore_index=True), None)
    expected = pd.MultiIndex.from_product([pd.Index(case_ids, name="case_id"),
                                           pd.Index(list(systems), name="system")])
    got = pd.MultiIndex.from_frame(table[["case_id", "system"]])
    if got.has_duplicates or len(got) != len(expected) or not got.equals(expected):
        dup = int(got.duplicated().sum())
        missing = len(expected.difference(got))
        raise SimulationError(f"chunks in {folder / CHUNK_DIR} do not add up to the study: "
                              f"{dup} duplicate and {missing} missing (case, system) rows")
    return table.reset_index(drop=True)


def load_study(folder: str | os.PathLike[str]) -> StudyResult:
    """Read a study folder (manifest and, if complete, ``runs.parquet``).

    Raises
    ------
    DataError
        If the folder is not a study.
    """
    path = Path(folder)
    manifest = read_manifest(path)
    runs = path / RUNS_FILE
    table = pd.read_parquet(runs) if runs.exists() and manifest.get("status") == "complete" \
        else None
    return StudyResult(path, table, manifest)


__all__ = [
    "BASELINE",
    "EQUIP_RULES",
    "EXECUTORS",
    "AEBSystem",
    "RunTask",
    "ExecutorOptions",
    "StudyResult",
    "case_ids_hash",
    "combine_chunks",
    "data_hash",
    "equipped_flags",
    "load_study",
    "read_manifest",
    "register_executor",
    "resolve_system",
    "assemble_chunk",
    "run_task",
    "run_study",
]
