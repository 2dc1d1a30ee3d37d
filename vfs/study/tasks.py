"""One chunk of a study: load its cases, run them with one system, the runs table.

Tasks run in worker processes (or dask workers); they get the database
*reference* (a bundled name such as ``"default"``, an fsspec URL or an absolute
folder: :func:`vfs.database.database_reference`) and the case ids, not arrays,
and load their cases themselves: each worker resolves the reference with its
own install (:func:`vfs.database.database_location`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.adas.contract import ReportsEvents, Segmentable, System
from vfs.database import Database, database_location, load_any, load_database
from vfs.errors import ParameterError, SimulationError
from vfs.physics.precrash import SegmentedRandom
from vfs.simulation import (
    CaseBatch,
    CaseResults,
    SimulationParams,
    results_table,
    simulate_cases,
)
from vfs.study.case_cache import BLOCKS, CASES, batch_key
from vfs.study.layout import (
    BASELINE,
    BOOL_COLUMNS,
    EQUIP_RULES,
    INT_COLUMNS,
    KEY_COLUMNS,
    equipped_flags,
)
from vfs.study.traces import RunTrace, simulate_with_traces


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
    db : str or None
        Database reference the worker loads the cases from: a bundled name
        (``"default"``), an fsspec URL or an absolute folder
        (:func:`vfs.database.database_reference`), resolved on the worker.
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
    group : tuple of (int, int)
        Several chunks run as one batch: (chunk number, cases) of each, in
        the order of ``case_ids`` (``chunk`` is the first); empty: the one
        chunk ``chunk``.  Each chunk keeps its own random stream
        (:class:`vfs.physics.precrash.SegmentedRandom`), so the runs are
        those of the chunks run one by one; the table holds the chunks' rows
        in this order.
    """

    chunk: int
    case_ids: np.ndarray
    system_index: int
    system: System | None
    db: str | None
    db_format: str
    batch: CaseBatch | None
    equip: str
    seed: int
    params: SimulationParams
    impact_parameters: str
    group: tuple[tuple[int, int], ...] = ()

    @property
    def parts(self) -> tuple[tuple[int, int], ...]:
        """(chunk number, cases) of each chunk of the task, in row order."""
        return self.group if self.group else ((self.chunk, len(self.case_ids)),)

    @property
    def system_name(self) -> str:
        """Value of the ``system`` column."""
        return BASELINE if self.system is None else str(self.system.name)


@lru_cache(maxsize=2)
def _whole_database(path: str, fmt: str, stamp: float) -> Database:
    """A whole non-Parquet database, loaded once per worker process."""
    return load_any(path, fmt=fmt, validate=False)


def load_chunk(task: RunTask) -> CaseBatch:
    """The chunk's cases as a batch, in the task's order.

    Parquet databases are read case-selectively (duckdb on the files, or
    pyarrow with a ``case_id`` filter for a URL: only the chunk's rows); CSV
    and PCM folders are loaded whole once per process.  The batches of a
    database folder are kept for the next tasks of the same cases (the other
    systems of the chunk set) in :data:`vfs.study.case_cache.CASES`, keyed by
    the folder's files and their modification times (read-only arrays).
    """
    if task.batch is not None:
        return task.batch
    if task.db is None:
        raise ParameterError("a chunk task needs a database reference or a batch")
    location = database_location(task.db)  # this worker's own install for "default"
    ids = np.asarray(task.case_ids)
    key = batch_key(location, task.db_format, ids, task.impact_parameters)
    if key is None:
        return _load_batch(location, task.db_format, ids, task.impact_parameters)
    return CASES.get(key, lambda: _load_batch(location, task.db_format, ids,
                                              task.impact_parameters))


def _load_batch(location: str, fmt: str, ids: np.ndarray, impact_parameters: str
                ) -> CaseBatch:
    """The cases ``ids`` of the database at ``location`` as a batch (no cache)."""
    if fmt == "parquet":
        db = BLOCKS.covering(location, ids)  # validated by this process's study already
        if db is None:
            where = "case_id IN (" + ", ".join(str(int(i)) for i in ids) + ")"
            db = load_database(location, where=where, validate=False)
    else:
        stamp = max(p.stat().st_mtime for p in Path(location).iterdir())
        db = _whole_database(location, fmt, stamp)
    return CaseBatch.from_database(db, ids, impact_parameters=impact_parameters)


def error_text(exc: BaseException) -> str:
    """The message recorded for a failed run: ``"TypeName: message"`` (one line)."""
    text = f"{type(exc).__name__}: {exc}".replace("\n", " ").strip()
    return text if len(text) <= 500 else text[:497] + "..."


def _events_columns(controller: object, n: int) -> dict[str, np.ndarray]:
    """``controller.events()`` as columns ``<key>1``, ``<key>2`` (NaN where never); none
    for a controller that does not report events (:class:`vfs.adas.contract.ReportsEvents`).
    """
    if not isinstance(controller, ReportsEvents):
        return {}
    cols: dict[str, np.ndarray] = {}
    for key, values in dict(controller.events()).items():
        arr = np.asarray(values, dtype=float)
        if arr.shape != (n, 2):
            raise SimulationError(f"controller event {key!r} has shape {arr.shape}, "
                                  f"expected ({n}, 2)")
        cols[f"{key}1"], cols[f"{key}2"] = arr[:, 0], arr[:, 1]
    return cols


def run_batch(batch: CaseBatch, system: System | None, equipped: np.ndarray,
              params: SimulationParams, rng: np.random.Generator | SegmentedRandom,
              record: npt.ArrayLike | None = None
              ) -> tuple[pd.DataFrame, CaseResults, dict[int, RunTrace]]:
    """One vectorised run of ``batch`` (baseline when ``system`` is None).

    Parameters
    ----------
    batch : CaseBatch
    system : System or None
    equipped : ndarray of bool (N, 2)
        Vehicles carrying the system.
    params : SimulationParams
        Base parameters; the system replaces the pre-crash part.
    rng : numpy.random.Generator or SegmentedRandom
    record : array_like of int, optional
        Batch positions whose pre-crash traces are recorded
        (:mod:`vfs.study.traces`; the results do not change).

    Returns
    -------
    table : pandas.DataFrame
        :func:`results_table` with the controller's events (``<key>1``, ``<key>2``).
    results : CaseResults
    traces : dict of int to RunTrace
        By batch position (empty without ``record``).
    """
    controller = None
    if system is not None:
        params = dataclasses.replace(params,
                                     precrash=system.precrash_params(params.precrash))
        controller = system.controller(batch, equipped)
    traces: dict[int, RunTrace] = {}
    if record is None:
        res = simulate_cases(batch, controller=controller, params=params, rng=rng)
    else:
        if isinstance(rng, SegmentedRandom):
            raise ParameterError("traces are recorded for one random stream only")
        res, traces = simulate_with_traces(batch, controller, params, rng, record)
    table = results_table(batch, res)
    for name, values in _events_columns(controller, batch.size).items():
        table[name] = values
    return table, res, traces


def _run_guarded(batch: CaseBatch, system: System | None, equipped: np.ndarray,
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
            table = run_batch(sub, system, equipped[start:stop], params, rng)[0]
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


def _segmentable(system: System | None, batch: CaseBatch, equipped: np.ndarray) -> bool:
    """Whether the system's controller can run several chunks as one batch
    (:class:`vfs.adas.contract.Segmentable`; the baseline can).
    """
    if system is None:
        return True
    return isinstance(system.controller(batch.take(np.arange(1)), equipped[:1]), Segmentable)


def _run_parts(task: RunTask, batch: CaseBatch, equipped: np.ndarray
               ) -> tuple[list[pd.DataFrame], dict[int, str]]:
    """The task's chunks as one batch with a random stream per chunk; chunk by chunk
    (:func:`_run_guarded`) if that batch raises or the controller cannot segment.

    The ``_pos`` columns and the error keys are positions in ``batch``.
    """
    seed, j = int(task.seed), int(task.system_index)
    parts = task.parts
    if len(parts) == 1:
        return _run_guarded(batch, task.system, equipped, task.params, [seed, parts[0][0], j])
    if _segmentable(task.system, batch, equipped):
        rng = SegmentedRandom.of([size for _, size in parts],
                                 [np.random.default_rng([seed, k, j]) for k, _ in parts])
        try:
            table = run_batch(batch, task.system, equipped, task.params, rng)[0]
        except Exception:  # noqa: BLE001 - isolated chunk by chunk below
            pass
        else:
            table.insert(0, "_pos", np.arange(batch.size))
            return [table], {}
    tables: list[pd.DataFrame] = []
    errors: dict[int, str] = {}
    start = 0
    for k, size in parts:
        sub = batch.take(np.arange(start, start + size))
        t, e = _run_guarded(sub, task.system, equipped[start:start + size], task.params,
                            [seed, k, j])
        for table in t:
            table["_pos"] += start
        tables += t
        errors.update({start + p: text for p, text in e.items()})
        start += size
    return tables, errors


def run_task(task: RunTask) -> pd.DataFrame:
    """Simulate the chunk's cases with one system (or the baseline) as one batch.

    Returns one row per case in the task's order: case_id, system, error
    (empty when fine), equipped1/2, the :func:`results_table` columns and
    the controller's events; failed runs have an error text and NaN
    outcomes.  Case metadata (accident type, weight) is added by the caller.
    """
    batch = load_chunk(task)
    equipped = equipped_flags(task.equip, batch.size)
    tables, errors = _run_parts(task, batch, equipped)
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


def assemble_chunks(chunks: Sequence[Sequence[pd.DataFrame]],
                    cases: pd.DataFrame | None = None) -> list[pd.DataFrame]:
    """:func:`assemble_chunk` of several chunks at once (one concatenation and one
    :func:`normalise_runs` for all: the per-call cost is paid once), the same tables.

    Chunks whose runs do not all have the same columns are assembled one by one (a
    chunk's table must not gain the columns of another).
    """
    if len(chunks) < 2:
        return [assemble_chunk(parts, cases) for parts in chunks]
    columns = [list(part.columns) for part in chunks[0]]
    if any([list(part.columns) for part in parts] != columns for parts in chunks[1:]):
        return [assemble_chunk(parts, cases) for parts in chunks]
    frames = []
    for c, parts in enumerate(chunks):
        for j, part in enumerate(parts):
            frames.append(part.assign(_pos=np.arange(len(part)), _sys=j, _chunk=c))
    out = pd.concat(frames, ignore_index=True)
    out = out.sort_values(["_chunk", "_pos", "_sys"], kind="stable")
    bounds = np.searchsorted(out["_chunk"].to_numpy(), np.arange(len(chunks) + 1))
    out = normalise_runs(out.drop(columns=["_pos", "_sys", "_chunk"]).reset_index(drop=True),
                         cases)
    return [out.iloc[a:b].reset_index(drop=True) for a, b in zip(bounds[:-1], bounds[1:],
                                                                  strict=True)]


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



__all__ = ["RunTask", "assemble_chunk", "assemble_chunks", "error_text", "load_chunk",
           "normalise_runs", "run_batch", "run_task"]
