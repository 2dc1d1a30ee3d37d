"""Running a study: baseline and treatment runs of every case of a database.

A study re-simulates every selected case of an accident database once without
a system (``system = "baseline"``: the recorded behaviour) and once per AEB
system (the treatment: the system acts on the equipped vehicle(s)), each run
from the start of the records through impact or avoidance to rest
(:func:`vfs.simulation.simulate_cases`).  The outcome is one tidy table with a
row per (case, system), ``runs.parquet``, read by the effectiveness analysis
(:mod:`vfs.analysis.effectiveness`).

Work is split into chunks of ``chunk_size`` cases in database order. A task
(:class:`vfs.study.tasks.RunTask`) runs consecutive chunks of one system (the
baseline included) as one vectorised batch of up to ``task_cases`` cases; the
plan (:func:`vfs.study.plan.plan_tasks`) sizes the tasks by their estimated
cost, so that few tasks pay the fixed per-step overhead and the workers end
together, and submits the longest first. When all runs of a chunk are in, the
main process writes the chunk atomically to ``chunks/chunk_000123.parquet``;
chunks on disk are never redone (``resume``). A case that makes a batch raise
is isolated by bisection and recorded with its error message. Chunk ``k`` and
system index ``j`` (0 = baseline, 1.. = the systems in the order given) draw
their random numbers from ``numpy.random.default_rng([seed, k, j])`` (also
inside a group), so the results do not depend on the executor
(:mod:`vfs.study.executors`), on the grouping nor on the order in which tasks
finish. The settings are one :class:`vfs.study.spec.StudySpec`. The folder
layout is described in :mod:`vfs.study.manifest`; the columns and the command
line in docs/study.md.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.adas.contract import System
from vfs.adas.describe import describe_system
from vfs.atomic import write_json, write_table
from vfs.database import Database
from vfs.database.metadata import field_metadata
from vfs.errors import ParameterError, SimulationError
from vfs.simulation import CaseBatch
from vfs.study.case_cache import release as release_cases
from vfs.study.executors import EXECUTORS, ExecutorOptions, cpu_count
from vfs.study.faults import record_fault
from vfs.study.inputs import StudyInput, selection_hash, study_input, validate_selection
from vfs.study.layout import (
    BASELINE,
    CASES_FILE,
    CHUNK_DIR,
    EQUIP_RULES,
    MANIFEST_FILE,
    MANIFEST_FORMAT,
    MANIFEST_VERSION,
    RUNS_FILE,
    chunk_path,
)
from vfs.study.manifest import (
    StudyResult,
    case_ids_hash,
    combine_chunks,
    counts_summary,
    environment_versions,
    now,
    prepare_folder,
)
from vfs.study.orphans import pid_alive
from vfs.study.plan import plan_tasks, runner_cost, task_groups
from vfs.study.spec import ImpactParameterSource, StudySpec
from vfs.study.systems import resolve_systems
from vfs.study.tasks import RunTask, assemble_chunks, error_text
from vfs.version import source_commit

#: Where restitution and contact friction come from (:meth:`CaseBatch.from_database`).
IMPACT_PARAMETER_SOURCES: tuple[str, ...] = tuple(m.value for m in ImpactParameterSource)


def _new_manifest(plan: _Plan) -> dict[str, Any]:
    """``study.json`` of a study about to start (status ``running``)."""
    spec, selection, systems = plan.spec, plan.selection, plan.systems
    ids = selection.case_ids
    names = plan.names
    equip = str(spec.equip)
    return {
        "format": MANIFEST_FORMAT, "format_version": MANIFEST_VERSION, "status": "running",
        "created": now(), "updated": now(),
        "db": selection.folder if selection.folder is not None else "<in-memory database>",
        "db_reference": selection.reference, "db_format": selection.fmt,
        "db_name": str(selection.meta.get("name", "")),
        "db_description": str(selection.meta.get("description", "")),
        "db_created_by": str(selection.meta.get("created_by", "")),
        "where": spec.where, "data_hash": selection.data_hash,
        "case_ids_hash": case_ids_hash(ids),
        "n_cases": int(ids.size), "chunk_size": spec.chunk_size, "n_chunks": len(plan.chunks),
        "system_names": names,
        "systems": [{"name": n, "description": str(getattr(s, "description", "")),
                     "parameters": describe_system(s),
                     "brake": repr(getattr(s, "brake", None))}
                    for n, s in zip(names, systems, strict=True)],
        "system_definitions": [repr(s) for s in systems],
        "equip": equip, "equipped": list(EQUIP_RULES[equip]), "seed": spec.seed,
        "rng": "numpy.random.default_rng([seed, chunk, system index]); baseline index 0",
        "impact_parameters": str(spec.impact_parameters), "params": repr(spec.params),
        "engine": spec.engine, "versions": environment_versions(),
        "commit": source_commit(),
    }


@dataclass
class _ChunkWriter:
    """Collects the runs of each chunk and writes the chunk file when all are in."""

    out: Path
    runners: int
    cases: pd.DataFrame
    progress: Any
    on_chunk: Callable[[int, int], None] | None
    cases_run: int = 0
    pending: dict[int, dict[int, pd.DataFrame]] = field(default_factory=dict)
    gate: Callable[[], None] | None = None  # called before the first chunk file is written

    def __call__(self, task: RunTask, table: pd.DataFrame) -> None:
        n = len(task.case_ids)
        if len(table) != n:
            raise SimulationError(f"chunk {task.chunk}, system {task.system_name}: "
                                  f"{len(table)} rows for {n} cases")
        complete: list[tuple[int, list[pd.DataFrame]]] = []
        start = 0
        for chunk, size in task.parts:  # a task's table holds its chunks' rows in order
            part = table if len(task.parts) == 1 else \
                table.iloc[start:start + size].reset_index(drop=True)
            start += size
            runs = self._add(chunk, task.system_index, part)
            if runs is not None:
                complete.append((chunk, runs))
        if not complete:
            return
        if self.gate is not None:
            self.gate()
            self.gate = None
        # the chunks this task completed, assembled at once (near the end of a parallel
        # study the last tasks complete most chunks), then written one by one
        tables = assemble_chunks([runs for _, runs in complete], self.cases)
        for (chunk, runs), chunk_table in zip(complete, tables, strict=True):
            write_table(chunk_path(self.out, chunk), chunk_table,
                        field_metadata(chunk_table.columns))
            self.cases_run += len(runs[0])
            if self.on_chunk is not None:
                self.on_chunk(chunk, self.cases_run)

    def _add(self, chunk: int, system_index: int, table: pd.DataFrame
             ) -> list[pd.DataFrame] | None:
        """Keep a chunk's runs of one system; all its runs once the last is in."""
        parts = self.pending.setdefault(chunk, {})
        parts[system_index] = table
        self.progress.update(len(table) / self.runners)
        if len(parts) < self.runners:
            return None
        del self.pending[chunk]
        return [parts[j] for j in range(self.runners)]


#: Exit code of ``vfs study`` for a study that ended incomplete (resume it).
EXIT_INCOMPLETE = 3


def lock_path(out: Path) -> Path:
    """The lock file of study folder ``out`` (beside it: ``--overwrite`` replaces the folder)."""
    return out.parent / f".{out.name}.lock"


def acquire_lock(out: Path) -> Path:
    """Claim study folder ``out`` for this process: a lock file with pid, host and time.

    A lock of a process that no longer runs on this host is stale and taken over; a live
    one (or one from another host) is refused with a message naming its owner.
    """
    import json
    import socket

    lock = lock_path(out)
    lock.parent.mkdir(parents=True, exist_ok=True)
    me = {"pid": os.getpid(), "host": socket.gethostname(), "started": now()}
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                owner = json.loads(lock.read_text() or "{}")
            except (OSError, ValueError):
                owner = {}
            pid, host = owner.get("pid"), owner.get("host")
            if host == me["host"] and isinstance(pid, int) and not pid_alive(pid):
                lock.unlink(missing_ok=True)  # stale: its process is gone
                continue
            raise ParameterError(
                f"study folder {out} is in use by process {pid} on {host} (since "
                f"{owner.get('started')}); wait for it, or delete {lock} if that process is "
                "gone") from None
        with os.fdopen(fd, "w") as fh:
            json.dump(me, fh)
        return lock
    raise ParameterError(f"could not lock study folder {out} ({lock})")


def _progress_bar(total: int, show: bool | None) -> Any:
    """The study's progress (:mod:`vfs.progress`): a bar on a terminal, lines when piped."""
    from vfs.progress import progress

    return progress(total, "simulating the cases", "case", bar=show)


def run_study(db: str | os.PathLike[str] | Database | StudySpec,
              systems: Sequence[str | System] | str | None = None,
              out: str | os.PathLike[str] | None = None, **options: Any) -> StudyResult:
    """Run (or resume) an AEB effectiveness study and write its folder.

    Call it with a :class:`StudySpec` (``run_study(spec)``) or with the
    spec's fields (``run_study(db, systems, out, engine="serial", ...)``);
    each setting and its check is declared once, on :class:`StudySpec`.

    Parameters
    ----------
    db : path, URL, ``"default"``, Database or StudySpec
        Database folder (Parquet, CSV or PCM), ``"default"`` for the bundled
        database (each worker finds its own copy), the fsspec URL of a Parquet
        database (``file:///shared/db``, ``s3://bucket/db``; ``memory://db``
        only with workers in this process: serial, or dask with threads), or
        an in-memory :class:`vfs.database.Database` (its chunks are then
        pickled to the workers); or the whole spec.
    systems : sequence of str or system objects, or "a,b"
        AEB systems; names are looked up with :func:`resolve_system`.
    out : path
        Study folder (created).
    **options
        The other fields of :class:`StudySpec`:

        engine : str
            Executor (:data:`vfs.study.executors.EXECUTORS`): ``"serial"``,
            ``"process"`` (default: local processes), ``"dask"`` or one
            registered from Python or by an installed package.
        workers : int, optional
            Parallel workers; default ``min(cpu count, tasks to run)``.
        scheduler : str, optional
            Dask scheduler address (engine "dask"); default a local cluster.
        chunk_size : int
            Cases per chunk (default 200): the unit of the chunk files, of
            resume and of the random streams.
        task_cases : int
            Cases a task runs as one vectorised batch (default
            :data:`DEFAULT_TASK_CASES`; whole chunks, each with its own
            random stream, so the results do not depend on it); with workers
            the tasks are sized by cost (:func:`vfs.study.plan.plan_tasks`).
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
            Progress bar on stderr (True), lines through the ``vfs`` logger (False);
            default: the bar when stderr is a terminal and the environment variable CI is
            not set (:func:`vfs.progress.bar_wanted`).
        dask_processes : bool
            Local dask cluster with processes (True) or threads.
        max_chunks : int, optional
            Run at most this many chunks now, then return an incomplete study
            (to be resumed); for tests and staged runs.
        on_chunk : callable, optional
            ``on_chunk(chunk_index, cases_done)`` after each chunk file is written.
        dashboard : str, optional
            Serve the dashboard of the local dask cluster at this address
            (``":8787"``; needs bokeh); default none.  Not with ``scheduler`` (a
            running scheduler serves its own).
        in_flight : int, optional
            Tasks submitted to the workers and not yet written at any time
            (default 2 per worker).

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
    if isinstance(db, StudySpec):
        if systems is not None or out is not None or options:
            raise ParameterError("run_study(spec) takes no further arguments")
        spec = db
    else:
        spec = StudySpec.of(db, systems, out, **options)
    system_objs = resolve_systems(list(spec.systems), spec.registry)
    # every input check runs here, before any task is started: a worker never simulates
    # data that failed validation (a record in milliseconds would run for ever); with
    # workers only a new study's data hash is computed while they run (_Validation)
    defer = spec.engine != "serial"
    resuming = spec.resume and (spec.out / MANIFEST_FILE).exists()
    # a serial study's tasks run here: they take their cases from the validated blocks
    # (vfs.study.case_cache), which are let go when the study ends
    try:
        selection = study_input(spec.db, spec.where, validate=True,
                                hash=not defer or resuming, keep=not defer)
        ids = selection.case_ids  # never empty (study_input refuses)
        size = spec.chunk_size
        plan = _Plan(spec, selection, [ids[i:i + size] for i in range(0, ids.size, size)],
                     system_objs, [str(s.name) for s in system_objs], started)
        lock = acquire_lock(spec.out)
        try:
            return _run_locked(plan)
        finally:
            lock.unlink(missing_ok=True)
    finally:
        release_cases()


@dataclass(frozen=True)
class _Plan:
    """A study about to run: its spec and what follows from it."""

    spec: StudySpec
    selection: StudyInput
    chunks: list[np.ndarray]
    systems: list[System]
    names: list[str]
    started: float


def _run_locked(plan: _Plan) -> StudyResult:
    """The study in its locked folder (see :func:`run_study`)."""
    spec = plan.spec
    out_dir = spec.out
    manifest = prepare_folder(out_dir, _new_manifest(plan), spec.resume, spec.overwrite)
    try:
        return _run_chunks(plan, manifest)
    except BaseException as exc:
        # whatever failed (a full disk included), the manifest must not say "running"
        if manifest.get("status") == "running":
            manifest.update(status="interrupted" if isinstance(exc, KeyboardInterrupt)
                            else "failed", updated=now(), error=error_text(exc))
            record_fault(out_dir / MANIFEST_FILE, manifest)  # in place on a full disk
        raise


class _Validation:
    """:func:`selection_hash` of a new parallel study in a thread of this process,
    while the workers run.

    The selection is validated before any task starts (:func:`run_study`: a
    worker never simulates data that failed a check; a record in milliseconds
    would run for ever); only the data hash, which reads every row and decides
    nothing about the run, is left to this thread.  :meth:`wait` joins the
    thread, raises what it met, and puts the hash into the manifest (written
    again); the chunk writer calls it before the first chunk file.
    """

    def __init__(self, selection: StudyInput, manifest: dict[str, Any], path: Path) -> None:
        self.selection = selection
        self.manifest, self.path = manifest, path
        self.error: BaseException | None = None
        self.thread: threading.Thread | None = None
        self.hash = selection.data_hash
        self.done = selection.validated and bool(selection.data_hash or
                                                 selection.folder is None)

    def _run(self) -> None:
        try:
            validate_selection(self.selection)
            self.hash = selection_hash(self.selection)
        except BaseException as exc:  # noqa: BLE001 - raised in the study's thread by wait()
            self.error = exc

    def start(self) -> None:
        if not self.done and self.thread is None:
            self.thread = threading.Thread(target=self._run, name="vfs-study-validation",
                                           daemon=True)
            self.thread.start()

    def wait(self, cause: BaseException | None = None) -> None:
        """Join the validation (run it here if never started); raise what it found."""
        if self.done:
            return
        if self.thread is None:
            self._run()
        else:
            self.thread.join()
        self.done = True
        if self.error is not None:
            raise self.error from cause
        if self.manifest.get("data_hash") != self.hash:
            self.manifest["data_hash"] = self.hash
            write_json(self.path, self.manifest)


def _run_chunks(plan: _Plan, manifest: dict[str, Any]) -> StudyResult:
    """Write the folder's inputs, run the chunks still to do, combine them."""
    spec, selection, chunks = plan.spec, plan.selection, plan.chunks
    out_dir = spec.out
    ids = selection.case_ids
    write_json(out_dir / MANIFEST_FILE, manifest)  # first: a folder with chunks/ is a study
    (out_dir / CHUNK_DIR).mkdir(exist_ok=True)
    cases_meta = selection.cases.reset_index(drop=True)
    write_table(out_dir / CASES_FILE, cases_meta,
                field_metadata(cases_meta.columns, table="cases"))

    todo = [k for k in range(len(chunks)) if not chunk_path(out_dir, k).exists()]
    if spec.max_chunks is not None:
        todo = todo[:spec.max_chunks]
    batch_all = None
    if selection.database is not None:  # in memory: the tasks carry their cases
        batch_all = CaseBatch.from_database(selection.database,
                                            impact_parameters=spec.impact_parameters)
    runners: list[System | None] = [None, *plan.systems]
    n_tasks_max = len(todo) * len(runners)
    n_workers = 1 if spec.engine == "serial" else (
        spec.workers if spec.workers else max(1, min(cpu_count(), n_tasks_max)))
    planned = plan_tasks(todo, [int(chunks[k].size) for k in todo],
                         [runner_cost(r) for r in runners], n_workers, spec.chunk_size,
                         spec.task_cases)
    tasks = []
    for item in planned:
        group = list(item.chunks)
        case_ids = np.concatenate([chunks[k] for k in group])
        parts = tuple((k, int(chunks[k].size)) for k in group) if len(group) > 1 else ()
        sub = None if batch_all is None else batch_all.take(np.concatenate(
            [np.arange(k * spec.chunk_size, k * spec.chunk_size + chunks[k].size)
             for k in group]))
        j = item.system_index
        tasks.append(RunTask(
            chunk=group[0], case_ids=case_ids, system_index=j, system=runners[j],
            db=selection.reference, db_format=selection.fmt, batch=sub,
            equip=str(spec.equip), seed=spec.seed, params=spec.params,
            impact_parameters=str(spec.impact_parameters), group=parts))
    bar = _progress_bar(sum(chunks[k].size for k in todo), spec.progress)
    validation = _Validation(selection, manifest, out_dir / MANIFEST_FILE)
    writer = _ChunkWriter(out_dir, len(runners), cases_meta, bar, spec.on_chunk,
                          gate=validation.wait if tasks else None)
    # no more processes than tasks
    options = ExecutorOptions(max(1, min(n_workers, len(tasks))), spec.scheduler,
                              spec.dask_processes, spec.dashboard, spec.in_flight)
    try:  # chunks written so far stay; the study can be resumed
        if tasks:
            validation.start()
            try:
                EXECUTORS.get(spec.engine)(tasks, writer, options)
            except Exception as exc:  # invalid data may be why a task failed: say so
                validation.wait(cause=exc)
                raise
            validation.wait()
        else:
            validation.wait()
    finally:
        bar.close()
    manifest.pop("error", None)

    elapsed = time.perf_counter() - plan.started
    done = [k for k in range(len(chunks)) if chunk_path(out_dir, k).exists()]
    summary: dict[str, Any] = {"chunks_done": len(done), "cases_run": writer.cases_run,
                               "elapsed_s": elapsed,
                               "cases_per_s": writer.cases_run / elapsed if elapsed > 0 else 0.0,
                               "workers": n_workers}
    table = None
    if len(done) == len(chunks):
        runs = combine_chunks(out_dir, ids, [BASELINE, *plan.names])
        write_table(out_dir / RUNS_FILE, runs, field_metadata(runs.columns))
        del runs  # one copy of the runs table at a time
        table = pd.read_parquet(out_dir / RUNS_FILE)  # dtypes exactly as load_study gives
        summary["systems"] = counts_summary(table, plan.names)
        manifest["status"] = "complete"
    else:
        manifest["status"] = "incomplete"
    manifest.update(updated=now(), summary=summary)
    write_json(out_dir / MANIFEST_FILE, manifest)
    return StudyResult(out_dir, table, manifest)


__all__ = ["EXIT_INCOMPLETE", "IMPACT_PARAMETER_SOURCES", "StudySpec", "acquire_lock",
           "lock_path", "run_study", "task_groups"]
