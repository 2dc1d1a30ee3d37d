"""The settings of one study, declared once: :class:`StudySpec`.

A frozen dataclass passed whole from the command line (``vfs study`` builds
it, :mod:`vfs.cli.study`) or the Python API (:func:`vfs.study.run_study`
takes one, or builds it from keyword arguments) down to the chunk runner.
Each of its settings is declared once with :func:`vfs.settings.setting` (bounds,
default, choices as :class:`enum.StrEnum`, one line of doc); the checks of
``__post_init__``, the command line's choices, defaults and help and the table of
docs/study.md are derived from the declarations.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from vfs.errors import ParameterError
from vfs.settings import declared, setting, validate
from vfs.simulation import ImpactParameterSource, SimulationParams
from vfs.study.layout import DEFAULT_CHUNK_SIZE, Equip

#: Cases one task runs as one vectorised batch by default: several chunks of
#: :data:`DEFAULT_CHUNK_SIZE` together (each keeps its own file and random
#: stream), so that the per-step cost of the pre-crash loop is shared.
DEFAULT_TASK_CASES = 5_000

@dataclass(frozen=True)
class StudySpec:
    """Everything a study is run with (see :func:`vfs.study.run_study` for each setting).

    Attributes
    ----------
    db : path, URL, ``"default"`` or Database
        The database.
    systems : tuple of str or system objects
        AEB systems (a comma-separated string is split).
    out : Path
        Study folder.
    engine : str
        Executor name (:data:`vfs.study.executors.EXECUTORS`).
    workers : int, optional
        Parallel workers (>= 1); default min(CPUs, tasks).
    scheduler : str, optional
        Dask scheduler address.
    chunk_size : int
        Cases per chunk file and random stream (>= 1).
    task_cases : int
        Most cases one task runs as one batch, whole chunks (>= 1; at least one
        chunk); with workers the plan sizes tasks by cost (:mod:`vfs.study.plan`).
    seed : int
        Seed of all random draws.
    where : str, optional
        SQL predicate selecting the cases.
    equip : Equip
        Which vehicles carry the system.
    resume, overwrite : bool
        Continue the study in ``out`` / replace it.
    params : SimulationParams
        Base simulation settings.
    impact_parameters : ImpactParameterSource
        Restitution and contact friction source.
    registry : mapping or callable, optional
        System lookup.
    progress : bool, optional
        Progress bar on stderr (None: when it is a terminal).
    dask_processes : bool
        Local dask cluster with processes (True) or threads.
    max_chunks : int, optional
        Run at most this many chunks now (>= 0).
    on_chunk : callable, optional
        ``on_chunk(chunk_index, cases_done)`` after each chunk file.
    dashboard : str, optional
        Dashboard address of the local dask cluster.
    in_flight : int, optional
        Tasks submitted and not yet written (>= 1).
    """

    db: str | os.PathLike[str] | Any
    systems: tuple[Any, ...]
    out: Path
    engine: str = setting("process", "text", "executor: serial, local processes, dask, or one "
                          "registered with vfs.study.register_executor or by an installed "
                          "package (entry-point group vfs.executors)")
    workers: int | None = setting(None, "int", "parallel workers", lo=1, optional=True,
                                  optional_doc="min(CPUs, tasks)")
    scheduler: str | None = setting(None, "text", "dask scheduler address, e.g. "
                                    "tcp://host:8786 (engine dask); its workers need the "
                                    "same vfs and numpy", optional=True,
                                    optional_doc="a local cluster")
    chunk_size: int = setting(DEFAULT_CHUNK_SIZE, "int", "cases per chunk file, the unit of "
                              "resume and of the random streams", lo=1)
    task_cases: int = setting(DEFAULT_TASK_CASES, "int", "most cases one task simulates as "
                              "one batch: whole chunks, each with its own random stream, so "
                              "results do not depend on it; larger batches share the per-step "
                              "cost (with workers the tasks are sized by their estimated cost)",
                              lo=1)
    seed: int = setting(0, "int", "seed of all random draws")
    where: str | None = setting(None, "text", "SQL predicate on the cases table",
                                optional=True, optional_doc="every case")
    equip: Equip = setting(Equip.BOTH, "text", "vehicles carrying the system in the "
                           "treatment runs", choices=Equip)
    resume: bool = setting(False, "bool", "continue an interrupted study in out (same "
                           "inputs)")
    overwrite: bool = setting(False, "bool", "replace an existing study in out")
    params: SimulationParams = field(default_factory=SimulationParams)
    impact_parameters: ImpactParameterSource = setting(
        ImpactParameterSource.RECONSTRUCTION, "text", "restitution and contact friction: "
        "the reconstruction's where the database has them, or the model defaults for every "
        "case", choices=ImpactParameterSource)
    registry: Any = None
    progress: bool | None = setting(None, "bool", "progress bar on stderr", optional=True,
                                    optional_doc="when stderr is a terminal")
    dask_processes: bool = setting(True, "bool", "a local dask cluster of processes (true) "
                                   "or threads")
    max_chunks: int | None = setting(None, "int", "run at most this many chunks now", lo=0,
                                     optional=True, optional_doc="all")
    on_chunk: Callable[[int, int], None] | None = None
    dashboard: str | None = setting(None, "text", "dashboard address of the local dask "
                                    "cluster, e.g. :8787 (needs bokeh)", optional=True,
                                    optional_doc="off")
    in_flight: int | None = setting(None, "int", "tasks submitted and not yet written",
                                    lo=1, optional=True, optional_doc="twice the workers")

    def __post_init__(self) -> None:
        from vfs.study.executors import EXECUTORS

        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        from vfs.study.systems import split_systems

        systems = self.systems
        set_("systems", tuple(split_systems(systems)) if isinstance(systems, str | Sequence)
             else (systems,))
        set_("out", Path(self.out))
        for name, s in declared(self).items():  # equip=1 means "1"
            if s.choices is not None and isinstance(getattr(self, name), int):
                set_(name, str(getattr(self, name)))
        validate(self)
        for name, s in declared(self).items():
            value = getattr(self, name)
            if s.quantity == "int" and value is not None:
                set_(name, int(value))
            elif s.choices is not None:
                set_(name, s.choices(value))
        set_("params", self.params if self.params is not None else SimulationParams())
        EXECUTORS.get(self.engine)  # an unknown engine: ParameterError listing the known
        if self.dashboard is not None and (self.engine != "dask" or self.scheduler):
            raise ParameterError("dashboard: only for the local cluster of engine 'dask' (a "
                                 "running scheduler serves its own dashboard)")

    @classmethod
    def of(cls, db: Any, systems: Any = None, out: Any = None, **options: Any) -> StudySpec:
        """A spec from :func:`vfs.study.run_study`'s arguments (an unknown option raises)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ParameterError(f"unknown study settings: {', '.join(unknown)}")
        if systems is None or out is None:
            raise ParameterError("a study needs systems and out")
        return cls(db, systems, out, **options)


__all__ = ["DEFAULT_TASK_CASES", "Equip", "ImpactParameterSource", "StudySpec"]
