"""The settings of one study, declared once: :class:`StudySpec`.

A frozen dataclass passed whole from the command line (``vfs study`` builds
it, :mod:`vfs.cli.study`) or the Python API (:func:`vfs.study.run_study`
takes one, or builds it from keyword arguments) down to the chunk runner.
Its checks are declared in two tables, :data:`RANGES` (numeric bounds) and
:data:`CHOICES` (string options as :class:`enum.StrEnum`, also the argparse
``choices``), and run in ``__post_init__``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from vfs.errors import ParameterError
from vfs.simulation import ImpactParameterSource, SimulationParams
from vfs.study.layout import DEFAULT_CHUNK_SIZE, Equip

#: Cases one task runs as one vectorised batch by default: several chunks of
#: :data:`DEFAULT_CHUNK_SIZE` together (each keeps its own file and random
#: stream), so that the per-step cost of the pre-crash loop is shared.
DEFAULT_TASK_CASES = 5_000

#: Bounds (inclusive; None = open) of the numeric settings, checked when set.
RANGES: dict[str, tuple[int | None, int | None]] = {
    "chunk_size": (1, None),
    "task_cases": (1, None),
    "workers": (1, None),
    "in_flight": (1, None),
    "max_chunks": (0, None),
}

#: String options and their enums (also the argparse ``choices``).
CHOICES: dict[str, type[StrEnum]] = {
    "equip": Equip,
    "impact_parameters": ImpactParameterSource,
}


def checked_int(name: str, value: object, low: int | None = 1, high: int | None = None) -> int:
    """``value`` as an int within [low, high], else :class:`ParameterError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer | float) \
            or int(value) != value:
        raise ParameterError(f"{name}={value!r} must be an integer")
    if (low is not None and value < low) or (high is not None and value > high):
        bounds = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ParameterError(f"{name}={value!r} must be {bounds}")
    return int(value)


def checked_choice(name: str, value: object, enum: type[StrEnum]) -> StrEnum:
    """``value`` as a member of ``enum``, else :class:`ParameterError` listing them."""
    try:
        return enum(str(value))
    except ValueError:
        raise ParameterError(f"{name}={value!r}; use one of "
                             f"{', '.join(m.value for m in enum)}") from None


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
    engine: str = "process"
    workers: int | None = None
    scheduler: str | None = None
    chunk_size: int = DEFAULT_CHUNK_SIZE
    task_cases: int = DEFAULT_TASK_CASES
    seed: int = 0
    where: str | None = None
    equip: Equip = Equip.BOTH
    resume: bool = False
    overwrite: bool = False
    params: SimulationParams = field(default_factory=SimulationParams)
    impact_parameters: ImpactParameterSource = ImpactParameterSource.RECONSTRUCTION
    registry: Any = None
    progress: bool | None = None
    dask_processes: bool = True
    max_chunks: int | None = None
    on_chunk: Callable[[int, int], None] | None = None
    dashboard: str | None = None
    in_flight: int | None = None

    def __post_init__(self) -> None:
        from vfs.study.executors import EXECUTORS

        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        from vfs.study.systems import split_systems

        systems = self.systems
        set_("systems", tuple(split_systems(systems)) if isinstance(systems, str | Sequence)
             else (systems,))
        set_("out", Path(self.out))
        for name, (low, high) in RANGES.items():
            value = getattr(self, name)
            if value is not None:
                set_(name, checked_int(name, value, low, high))
        for name, enum in CHOICES.items():
            set_(name, checked_choice(name, getattr(self, name), enum))
        set_("seed", checked_int("seed", self.seed, None, None))
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


__all__ = ["CHOICES", "DEFAULT_TASK_CASES", "RANGES", "Equip", "ImpactParameterSource",
           "StudySpec", "checked_choice", "checked_int"]
