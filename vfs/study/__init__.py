"""AEB effectiveness studies: baseline and treatment runs of every case of a database.

:func:`run_study` runs (or resumes) a study into a folder, :func:`load_study`
reads one.  The parts: :mod:`~vfs.study.layout` (names, files, columns),
:mod:`~vfs.study.systems` (what a system is, lookup by name),
:mod:`~vfs.study.inputs` (what the client reads of the database),
:mod:`~vfs.study.tasks` (one chunk with one system), :mod:`~vfs.study.executors`
(serial, processes, dask, registered ones), :mod:`~vfs.study.orphans` (workers
end with the study process), :mod:`~vfs.study.manifest` (the folder, resume,
reading), :mod:`~vfs.study.spec` (the settings of a study, checked once) and
:mod:`~vfs.study.run`.  See docs/study.md.
"""

from vfs.adas.contract import System
from vfs.study.executors import EXECUTORS, ExecutorOptions, cpu_count, register_executor
from vfs.study.layout import (
    BASELINE,
    CASES_FILE,
    CHUNK_DIR,
    DEFAULT_CHUNK_SIZE,
    EQUIP_RULES,
    MANIFEST_FILE,
    RUNS_FILE,
    equipped_flags,
)
from vfs.study.manifest import (
    StudyResult,
    case_ids_hash,
    combine_chunks,
    data_hash,
    load_study,
    read_manifest,
    read_runs,
)
from vfs.study.run import run_study
from vfs.study.spec import DEFAULT_TASK_CASES, Equip, ImpactParameterSource, StudySpec
from vfs.study.systems import resolve_system, resolve_systems, split_systems
from vfs.study.tasks import RunTask, assemble_chunk, normalise_runs, run_task

__all__ = [
    "BASELINE",
    "CASES_FILE",
    "CHUNK_DIR",
    "DEFAULT_CHUNK_SIZE",
    "DEFAULT_TASK_CASES",
    "EQUIP_RULES",
    "EXECUTORS",
    "MANIFEST_FILE",
    "RUNS_FILE",
    "System",
    "Equip",
    "ExecutorOptions",
    "ImpactParameterSource",
    "RunTask",
    "StudyResult",
    "StudySpec",
    "assemble_chunk",
    "case_ids_hash",
    "combine_chunks",
    "cpu_count",
    "data_hash",
    "equipped_flags",
    "load_study",
    "normalise_runs",
    "read_manifest",
    "read_runs",
    "register_executor",
    "resolve_system",
    "resolve_systems",
    "split_systems",
    "run_study",
    "run_task",
]
