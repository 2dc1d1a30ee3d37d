"""Replaying chosen cases of a finished study, with their time traces.

A study stores one row per (case, system) and no time series.  The case pages
of ``vfs report effectiveness`` show, for a few cases, the speed and brake
traces of the baseline and of every system; :func:`replay_study_cases`
re-simulates those cases with the study's database, systems, equip rule,
impact parameters and seed, recording their traces (:mod:`vfs.study.traces`).

Exactness: the cases are first run together as one small batch.  A system
without randomness gives the study's numbers this way (a case's result never
depends on the other cases of its batch).  A system that draws random numbers
(driver reactions, detection) draws them for the whole chunk, so a case's
draws depend on its chunk: where the small batch does not give the study's
outcome (:data:`CHECK_COLUMNS`), the case's whole chunk is run again with the
chunk's generator ``default_rng([seed, chunk, system index])``, recording only
the wanted cases.  The cost is therefore that of the wanted cases plus, for
random systems, one chunk run per chunk that holds a wanted case (at most the
study itself).  Every replayed run says whether it reproduced the study's row.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import database_location
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.progress import progress
from vfs.simulation import CaseBatch, CaseResults, SimulationParams
from vfs.study.layout import BASELINE, CASES_FILE, DEFAULT_CHUNK_SIZE, equipped_flags
from vfs.study.manifest import StudyResult, load_study
from vfs.study.systems import SystemRegistry, resolve_system
from vfs.study.tasks import RunTask, error_text, load_chunk, run_batch
from vfs.study.traces import RunTrace

#: Outcome columns that must agree with the study's row for a replay to count as
#: reproduced (relative tolerance 1e-6; NaN equals NaN).
CHECK_COLUMNS: tuple[str, ...] = (
    "collided", "contact_time", "impact_time", "impact_speed1", "impact_speed2", "delta_v1",
    "delta_v2", "min_distance", "speed_reduction1", "speed_reduction2",
)


@dataclass(frozen=True)
class CaseRun:
    """One replayed run (a case with the baseline or one system).

    Attributes
    ----------
    case_id : object
    system : str
        ``"baseline"`` or the system's name.
    batch : CaseBatch or None
        The batch it ran in (None when it failed).
    results : CaseResults or None
        Its results (:func:`vfs.simulation.simulate_cases`).
    index : int
        The case's position in ``batch``.
    trace : RunTrace or None
        Speeds, brake demand and poses per step.
    row : pandas.Series or None
        The run's :func:`vfs.simulation.results_table` row with the controller's
        events (SI units).
    reproduced : bool or None
        The replay gives the study's outcome (:data:`CHECK_COLUMNS`); None where the
        study has no row to compare with.
    error : str
        Why the run failed or could not be replayed (empty when fine).
    """

    case_id: Any
    system: str
    batch: CaseBatch | None
    results: CaseResults | None
    index: int
    trace: RunTrace | None
    row: pd.Series | None
    reproduced: bool | None
    error: str = ""


def same_outcome(replayed: pd.Series, stored: pd.Series | None) -> bool | None:
    """Whether a replayed run gives the stored run's outcome (:data:`CHECK_COLUMNS`)."""
    if stored is None:
        return None
    for col in CHECK_COLUMNS:
        if col not in stored.index or col not in replayed.index:
            continue
        a, b = replayed[col], stored[col]
        if pd.isna(a) and pd.isna(b):
            continue
        if pd.isna(a) or pd.isna(b):
            return False
        if not np.isclose(float(a), float(b), rtol=1e-6, atol=1e-9):
            return False
    return True


def _stored_rows(table: pd.DataFrame | None, system: str) -> dict[Any, pd.Series]:
    if table is None:
        return {}
    sub = table[table["system"] == system]
    return {cid: row for cid, row in zip(sub["case_id"], (r for _, r in sub.iterrows()),
                                         strict=True)}


def _run(batch: CaseBatch, system: Any, equip: str, params: SimulationParams,
         rng_key: list[int], positions: np.ndarray
         ) -> tuple[pd.DataFrame, CaseResults, dict[int, RunTrace]]:
    return run_batch(batch, system, equipped_flags(equip, batch.size), params,
                     np.random.default_rng(rng_key), record=positions)


def replay_study_cases(study: str | os.PathLike[str] | StudyResult, case_ids: Sequence[Any],
                       *, registry: SystemRegistry | None = None,
                       say: Callable[[str], None] | None = None
                       ) -> dict[Any, list[CaseRun]]:
    """Re-simulate cases of a finished study with traces (baseline and every system).

    Parameters
    ----------
    study : path or StudyResult
        The study folder (or :func:`load_study` of it).
    case_ids : sequence
        Cases of the study to replay (others are ignored).
    registry : mapping or callable, optional
        System lookup (default :func:`vfs.adas.get_system`).
    say : callable, optional
        Progress lines.

    Returns
    -------
    dict
        Per case id (in study order) its runs: the baseline first, then the systems in
        the study's order.

    Raises
    ------
    DataError
        The study ran on an in-memory database, its database folder is gone, or the
        study folder has no cases table.
    """
    res = study if isinstance(study, StudyResult) else load_study(study)
    m = res.manifest
    # what the study's workers resolved (bundled name, URL or absolute folder); older
    # manifests have only the folder
    db_ref = str(m.get("db_reference") or m.get("db", ""))
    where = database_location(db_ref) if db_ref and not db_ref.startswith("<") else ""
    if not where or ("://" not in where and not Path(where).exists()):
        raise DataError(DataProblem("study.json", "db", None, None,
                                    f"the study's database {db_ref or '(none)'} is not a "
                                    "folder or URL that exists here; its cases cannot be "
                                    "re-simulated"))
    if not (res.path / CASES_FILE).is_file():
        raise DataError(DataProblem(CASES_FILE, "", None, None,
                                    f"{res.path} has no {CASES_FILE}; not a folder written "
                                    "by vfs study"))
    order = pd.read_parquet(res.path / CASES_FILE, columns=["case_id"])["case_id"].to_numpy()
    position = {cid: k for k, cid in enumerate(order.tolist())}
    wanted = sorted({c for c in case_ids if c in position}, key=position.__getitem__)
    if not wanted:
        return {}
    chunk_size = int(m.get("chunk_size", DEFAULT_CHUNK_SIZE))
    seed, equip = int(m.get("seed", 0)), str(m.get("equip", "both"))
    impact_parameters = str(m.get("impact_parameters", "reconstruction"))
    params = SimulationParams()
    names = [BASELINE, *m.get("system_names", [])]

    def task(ids: Sequence[Any]) -> RunTask:
        return RunTask(chunk=-1, case_ids=np.asarray(ids), system_index=0, system=None,
                       db=db_ref, db_format=str(m.get("db_format", "parquet")),
                       batch=None, equip=equip, seed=seed, params=params,
                       impact_parameters=impact_parameters)

    batch = load_chunk(task(wanted))
    out: dict[Any, list[CaseRun]] = {cid: [] for cid in wanted}
    with progress(len(names), f"re-simulating {len(wanted)} case(s) for their pages",
                  "system") as shown:
        for j, name in enumerate(names):
            try:
                stored = _stored_rows(res.table, name)
                try:
                    system = None if name == BASELINE else resolve_system(name, registry)
                except ParameterError as exc:
                    for cid in wanted:
                        out[cid].append(CaseRun(cid, name, None, None, -1, None, None, None,
                                                f"cannot replay: {exc}"))
                    continue
                runs = _replay_system(batch, wanted, system, name, equip, params, seed, j, stored)
                redo = [cid for cid, run in runs.items() if run.reproduced is False or
                        (run.error and not stored.get(cid, pd.Series(dtype=object)).get("error"))]
                if redo:
                    chunks: dict[int, list[Any]] = {}
                    for cid in redo:
                        chunks.setdefault(position[cid] // chunk_size, []).append(cid)
                    if say is not None:
                        # plain words: a case whose sensor noise or driver reaction was drawn
                        # together with the other cases of its chunk comes out differently alone
                        say(f"  {name}: {len(redo)} of {len(wanted)} case(s) come out differently "
                            f"when simulated alone (their random draws, such as sensor noise, were "
                            f"made together with the other cases of the study's batch); simulating "
                            f"those {len(chunks)} batch(es) again as the study did")
                    for k, cids in chunks.items():
                        ids = order[k * chunk_size:(k + 1) * chunk_size]
                        full = load_chunk(task(ids))
                        pos = {cid: p for p, cid in enumerate(ids.tolist())}
                        try:
                            table, results, traces = _run(full, system, equip, params, [seed, k, j],
                                                          np.array([pos[c] for c in cids]))
                        except Exception:  # a failing case in the chunk: keep the small-batch runs
                            continue
                        for cid in cids:
                            p = pos[cid]
                            row = table.iloc[p]
                            runs[cid] = CaseRun(cid, name, full, results, p, traces[p], row,
                                                same_outcome(row, stored.get(cid)))
                for cid in wanted:
                    out[cid].append(runs[cid])
            finally:
                shown.update()
    return out


def _replay_system(batch: CaseBatch, wanted: list[Any], system: Any, name: str, equip: str,
                   params: SimulationParams, seed: int, j: int,
                   stored: dict[Any, pd.Series]) -> dict[Any, CaseRun]:
    """The wanted cases as one batch with one system; one by one where the batch fails."""
    runs: dict[Any, CaseRun] = {}
    positions = np.arange(batch.size)
    try:
        table, results, traces = _run(batch, system, equip, params, [seed, j], positions)
    except Exception:
        for p, cid in enumerate(wanted):
            one = batch.take([p])
            try:
                t1, r1, tr1 = _run(one, system, equip, params, [seed, j], np.array([0]))
            except Exception as exc:  # recorded on the page, like the study's failed runs
                runs[cid] = CaseRun(cid, name, one, None, 0, None, None, None, error_text(exc))
                continue
            row = t1.iloc[0]
            runs[cid] = CaseRun(cid, name, one, r1, 0, tr1[0], row,
                                same_outcome(row, stored.get(cid)))
        return runs
    for p, cid in enumerate(wanted):
        row = table.iloc[p]
        runs[cid] = CaseRun(cid, name, batch, results, p, traces[p], row,
                            same_outcome(row, stored.get(cid)))
    return runs


__all__ = ["CHECK_COLUMNS", "CaseRun", "replay_study_cases", "same_outcome"]
