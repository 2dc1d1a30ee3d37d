"""The motion of a case's two vehicles to export: as recorded, or re-simulated with a system.

A study stores one row of figures per (case, system) (``runs.parquet``), not
the vehicles' motion.  The AEB-treated motion is therefore re-simulated with
the simulation API a study uses (:func:`vfs.simulation.simulate_cases` with
the system's controller and brake actuator, as in
:mod:`vfs.study.tasks`), recording the state of both vehicles at every step:

* :func:`study_motion` replays the case exactly as a study ran it: the same
  database selection (checked by its hash), the whole chunk the case was in,
  the chunk's random numbers (``default_rng([seed, chunk, system index])``)
  and the study's equip rule; the replay's collision and impact time are
  compared with the study's row;
* :func:`simulated_motion` runs one case afresh (seed 0 by default).

Motion is pre-crash: it ends at the impact (or, without a collision, at the
end of the simulated horizon, the longer record plus
:attr:`vfs.physics.precrash.PrecrashParams.extra_time`).  Units: s, m, rad, m/s.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import Database, select_database
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.simulation import CaseBatch, SimulationParams, simulate_cases
from vfs.study.layout import EQUIP_RULES, RUNS_FILE, chunk_path, equipped_flags
from vfs.study.manifest import data_hash, read_manifest
from vfs.study.systems import SystemRegistry, resolve_system

__all__ = [
    "MOTION_STEP",
    "CaseMotion",
    "ParticipantMotion",
    "find_case",
    "recorded_motion",
    "simulated_motion",
    "study_motion",
]

#: Spacing of the exported samples of a simulated motion [s] (the final state is added).
MOTION_STEP = 0.05


@dataclass(frozen=True)
class ParticipantMotion:
    """Samples of one vehicle's motion (CG, global frame).

    Attributes
    ----------
    t : ndarray (n,)
        Time on the record's time axis [s], strictly increasing.
    x, y : ndarray (n,)
        CG position [m].
    yaw : ndarray (n,)
        Yaw angle [rad].
    speed : ndarray (n,)
        CG speed [m/s].
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray


@dataclass(frozen=True)
class CaseMotion:
    """The motion of both vehicles of one case.

    Attributes
    ----------
    case_id : object
        Case identifier.
    participants : tuple of ParticipantMotion
        Participant 1, participant 2.
    source : str
        ``"recorded"`` or ``"system NAME"``.
    collided : bool
        The motion ends in a collision.
    impact_time : float
        Time of the impact [s] (record time axis); NaN without a collision.
    notes : tuple of str
        How the motion was obtained (study, seed, checks), for the file header.
    """

    case_id: object
    participants: tuple[ParticipantMotion, ParticipantMotion]
    source: str
    collided: bool
    impact_time: float = math.nan
    notes: tuple[str, ...] = ()


def find_case(db: Database, case_id: object) -> object:
    """The case id of ``db`` equal to ``case_id`` (also given as text, e.g. from a CLI).

    Raises
    ------
    DataError
        No such case.
    """
    ids = db.case_ids
    for cid in ids:
        if cid == case_id or str(cid) == str(case_id):
            return cid.item() if hasattr(cid, "item") else cid
    raise DataError(DataProblem("cases", "case_id", None, case_id,
                                f"no such case; the database has {len(ids)} cases (first: "
                                f"{[c.item() if hasattr(c, 'item') else c for c in ids[:5]]})"))


def recorded_motion(db: Database, case_id: object) -> CaseMotion:
    """The recorded trajectories of a case (``trajectories`` table).

    Parameters
    ----------
    db : Database
    case_id : object
        Case identifier (:func:`find_case`).
    """
    cid = find_case(db, case_id)
    parts = []
    for number in (1, 2):
        tr = db.trajectory(cid, number).sort_values("t", kind="stable")
        parts.append(ParticipantMotion(*(tr[c].to_numpy(float).copy()
                                         for c in ("t", "x", "y", "yaw", "speed"))))
    row = db.cases.set_index("case_id").loc[cid]
    return CaseMotion(cid, (parts[0], parts[1]), "recorded", bool(row["collision"]))


class _Recorder:
    """A brake controller that passes the demand of ``inner`` through and records the
    observed state of one case (row of the batch) at every step.
    """

    def __init__(self, inner: Any, row: int) -> None:
        self.inner, self.row = inner, row
        self.samples: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []

    def reset(self, n_cases: int, rng: np.random.Generator) -> None:
        if self.inner is not None:
            self.inner.reset(n_cases, rng)

    def demand(self, obs: Any) -> Any:
        hit = np.flatnonzero(np.asarray(obs.rows) == self.row)
        if hit.size:
            i = int(hit[0])
            t = float(np.asarray(obs.t, dtype=float).reshape(-1)[0 if np.ndim(obs.t) == 0
                                                                    else i])
            self.samples.append((t, obs.x[i].copy(), obs.y[i].copy(),
                                 obs.yaw[i].copy(), obs.speed[i].copy()))
        return None if self.inner is None else self.inner.demand(obs)

    def __getattr__(self, name: str) -> Any:  # events() etc. of the inner controller
        return getattr(self.inner, name)


def _record_run(batch: CaseBatch, system: Any, equipped: np.ndarray,
                params: SimulationParams, rng: np.random.Generator, row: int,
                step: float) -> tuple[tuple[ParticipantMotion, ParticipantMotion], bool, float]:
    """Run ``batch`` with ``system`` as a study task does (:mod:`vfs.study.tasks`) and
    return the sampled motion of case ``row``, its collision flag and impact time
    (record time axis).
    """
    params = dataclasses.replace(params, precrash=system.precrash_params(params.precrash))
    recorder = _Recorder(system.controller(batch, equipped), row)
    res = simulate_cases(batch, controller=recorder, params=params, rng=rng)
    pre = res.precrash
    t0 = float(batch.paths.t0[row])
    if not recorder.samples:
        raise ParameterError(f"case {batch.case_id[row]}: the simulation recorded no step")
    t = np.array([s[0] for s in recorder.samples])
    values = [np.stack([s[k] for s in recorder.samples]) for k in range(1, 5)]  # (n, 2)
    keep = np.abs(t / step - np.round(t / step)) < 1e-6
    keep[0] = True
    collided = bool(pre.collided[row])
    state = pre.impact_state if collided else pre.end_state
    t_end = float(pre.impact_time[row]) if collided else float(t[-1] + params.precrash.dt)
    end = [np.array([getattr(state, name)[row, 0], getattr(state, name)[row, 1]])
           for name in ("x", "y", "yaw", "speed")]
    t_out = np.concatenate([t[keep], [t_end]])
    cols = [np.concatenate([v[keep], e[None, :]]) for v, e in zip(values, end, strict=True)]
    if t_out.size > 1 and t_out[-1] - t_out[-2] < 1e-6:  # the end falls on a sample
        t_out = np.delete(t_out, -2)
        cols = [np.delete(c, -2, axis=0) for c in cols]
    motions = tuple(ParticipantMotion(t_out + t0, *(c[:, j] for c in cols)) for j in (0, 1))
    return (motions[0], motions[1]), collided, (t_end + t0) if collided else math.nan


def simulated_motion(db: Database, case_id: object, system: str | Any, *,
                     equip: str = "both", seed: int = 0, params: SimulationParams | None = None,
                     impact_parameters: str = "reconstruction",
                     registry: SystemRegistry | None = None,
                     step: float = MOTION_STEP) -> CaseMotion:
    """Re-simulate one case with an AEB system and record both vehicles' motion.

    Parameters
    ----------
    db : Database
    case_id : object
    system : str or AEB system
        Name (:func:`vfs.study.systems.resolve_system`) or object.
    equip : {"1", "2", "both"}
        Vehicles carrying the system.
    seed : int
        The run draws from ``default_rng(seed)``.
    params : SimulationParams, optional
    impact_parameters : {"reconstruction", "default"}
    registry : optional
        System lookup (default :func:`vfs.adas.get_system`).
    step : float
        Sample spacing of the exported motion [s].
    """
    cid = find_case(db, case_id)
    sys_obj = resolve_system(system, registry) if isinstance(system, str) else system
    batch = CaseBatch.from_database(db, np.asarray([cid]), impact_parameters=impact_parameters)
    motions, collided, t_imp = _record_run(
        batch, sys_obj, equipped_flags(equip, 1), params or SimulationParams(),
        np.random.default_rng(seed), 0, step)
    return CaseMotion(cid, motions, f"system {sys_obj.name}", collided, t_imp,
                      (f"re-simulated with system {sys_obj.name} (equip {equip}, seed {seed})",))


def _study_row(folder: Path, chunk: int, case_id: object, system: str) -> pd.Series | None:
    """The study's row of (case, system), from its chunk file or runs table."""
    for file in (chunk_path(folder, chunk), folder / RUNS_FILE):
        if file.exists():
            table = pd.read_parquet(file, columns=["case_id", "system", "collided",
                                                   "impact_time", "error"])
            hit = table[(table["case_id"] == case_id) & (table["system"] == system)]
            if len(hit):
                return hit.iloc[0]
    return None


def study_motion(study: str | os.PathLike[str], db: str | os.PathLike[str] | Database,
                 case_id: object, system: str, *, registry: SystemRegistry | None = None,
                 step: float = MOTION_STEP) -> CaseMotion:
    """The motion of a case with a system exactly as a study simulated it.

    Re-runs the case's whole chunk with the study's random numbers and
    settings and records the case.

    Parameters
    ----------
    study : path
        Study folder (``study.json``).
    db : path, ``"default"`` or Database
        The database the study ran on (checked against the study's data hash).
    case_id : object
    system : str
        One of the study's systems.
    registry : optional
        System lookup (default :func:`vfs.adas.get_system`).
    step : float
        Sample spacing of the exported motion [s].

    Raises
    ------
    ParameterError
        Unknown system, another database, or settings that cannot be replayed
        (simulation parameters other than the defaults, a system definition
        that changed since the study).
    DataError
        The case is not in the study.
    """
    folder = Path(study)
    manifest = read_manifest(folder)
    names = [str(n) for n in manifest.get("system_names", [])]
    if system not in names:
        raise ParameterError(f"study {folder} has no system {system!r}; its systems: "
                             f"{', '.join(names) or 'none'}")
    selection = select_database(db, manifest.get("where"))
    database = selection.database
    if data_hash(database) != manifest.get("data_hash"):
        raise ParameterError(f"the database {selection.folder or 'given'} is not the one study "
                             f"{folder} ran on (its contents differ: data hash mismatch); give "
                             f"the study's database, {manifest.get('db')}")
    params = SimulationParams()
    if repr(params) != manifest.get("params"):
        raise ParameterError(f"study {folder} ran with simulation parameters other than the "
                             "defaults; its motion cannot be replayed from the manifest")
    j = names.index(system) + 1
    sys_obj = resolve_system(system, registry)
    definitions = manifest.get("system_definitions", [])
    if j - 1 < len(definitions) and repr(sys_obj) != definitions[j - 1]:
        raise ParameterError(f"system {system!r} is defined differently now than when study "
                             f"{folder} ran; its motion cannot be replayed")
    ids = database.case_ids
    cid = find_case(database, case_id)
    pos = int(np.flatnonzero(ids == cid)[0])
    size = int(manifest["chunk_size"])
    chunk = pos // size
    chunk_ids = ids[chunk * size:(chunk + 1) * size]
    batch = CaseBatch.from_database(database, chunk_ids,
                                    impact_parameters=manifest.get("impact_parameters",
                                                                   "reconstruction"))
    equip = str(manifest.get("equip", "both"))
    if equip not in EQUIP_RULES:
        raise ParameterError(f"study {folder}: unknown equip rule {equip!r}")
    seed = int(manifest.get("seed", 0))
    motions, collided, t_imp = _record_run(
        batch, sys_obj, equipped_flags(equip, batch.size), params,
        np.random.default_rng([seed, chunk, j]), pos - chunk * size, step)
    notes = [f"replayed from study {folder.name} (chunk {chunk}, seed {seed}, equip {equip})"]
    row = _study_row(folder, chunk, cid, system)
    if row is None:
        notes.append("the study has no result for this case yet")
    elif str(row["error"]):
        notes.append(f"the study's run failed: {row['error']}")
    else:
        same = bool(row["collided"]) == collided and (
            not collided or abs(float(row["impact_time"]) - (t_imp - float(batch.paths.t0[
                pos - chunk * size]))) < 1e-6)
        notes.append("the replay matches the study's result" if same else
                     f"WARNING: the replay differs from the study's result (study: collided "
                     f"{bool(row['collided'])}, impact at {float(row['impact_time']):.4f} s; "
                     f"replay: collided {collided}) -- vfs changed since the study?")
    return CaseMotion(cid, motions, f"system {system}", collided, t_imp, tuple(notes))
