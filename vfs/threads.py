"""The compute threads of one vfs process: the one setting and its one default.

vfs's own parallel work inside a process -- the compiled run-out to rest
(:mod:`vfs.physics.core_runout`, numba threads over vehicles and pairs) and each duckdb
connection of :mod:`vfs.database.io` -- runs on :func:`compute_threads` threads.  The
setting is the environment variable :data:`THREADS_VARIABLE` (``VFS_THREADS``), declared
once here (:class:`ComputeThreads`: its range and its default):

* absent or empty: one thread per core this process may use (``os.sched_getaffinity``,
  the cores a container or ``taskset`` leaves it);
* an integer in ``[1, MOST_THREADS]``; anything else is a
  :class:`vfs.errors.SettingsError` naming ``VFS_THREADS`` and the allowed range.

Why an environment variable and not a flag or a field of each job's settings: the thread
count belongs to a process, not to a job, and the study's worker processes must get 1 (a
worker is one single-threaded batch; W workers of one thread per core each would
oversubscribe the machine).  :func:`vfs.blas.single_threaded_workers` already sets
``VFS_THREADS=1`` (with the BLAS and OpenMP variables) in every process pool's fork server
and dask worker, and a variable reaches every process started from there, the command line,
a notebook and a test alike.  A value the user set is kept in the workers too (their
choice, as for ``OMP_NUM_THREADS``).

The upper bound is the size of numba's thread pool, fixed when numba is imported:
``NUMBA_NUM_THREADS`` where set, else the cores this process may use (numba's own default),
so a value in range can always be given to ``numba.set_num_threads``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from vfs.blas import COMPUTE_THREADS_VARIABLE
from vfs.errors import SettingProblem, SettingsError
from vfs.settings import declared, setting, validate

#: The environment variable of the setting (see the module docstring).
THREADS_VARIABLE = COMPUTE_THREADS_VARIABLE


def available_cores() -> int:
    """Cores this process may run on (``os.sched_getaffinity``; ``os.cpu_count`` where the
    platform has no affinity; at least 1).
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def _numba_pool() -> int:
    """The size numba gives its thread pool: ``NUMBA_NUM_THREADS`` where it is a positive
    integer (numba refuses anything else at its import), else :func:`available_cores`.
    """
    text = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    return int(text) if text.isdigit() and int(text) >= 1 else available_cores()


#: The most threads allowed [threads]: numba's pool (read once, at the import of vfs).
MOST_THREADS = _numba_pool()


@dataclass(frozen=True)
class ComputeThreads:
    """The declared compute-thread setting (:mod:`vfs.settings`); read it with
    :func:`compute_threads`.

    Attributes
    ----------
    threads : int or None
        Threads of the compiled run-out and of each duckdb connection [threads]; None: one
        per core this process may use.
    """

    threads: int | None = setting(
        None, "int", "threads of the compiled run-out (numba) and of each duckdb connection "
        f"(environment variable {THREADS_VARIABLE}; 1 in a study's worker processes)",
        lo=1, hi=MOST_THREADS, optional=True,
        optional_doc="one per core the process may use (os.sched_getaffinity)")

    def __post_init__(self) -> None:
        validate(self)


def _problem(value: object, what: str) -> SettingsError:
    allowed = declared(ComputeThreads)["threads"].allowed()
    return SettingsError(SettingProblem("environment", THREADS_VARIABLE, value, what, allowed))


def threads_setting(environ: os._Environ[str] | dict[str, str] | None = None
                    ) -> ComputeThreads:
    """The setting as the environment gives it (read at every call, so a test or a worker
    can change it).

    Raises
    ------
    SettingsError
        ``environment.VFS_THREADS: 0 is out of range (allowed: an integer in [1, 2], or
        absent)``.
    """
    env = os.environ if environ is None else environ
    text = env.get(THREADS_VARIABLE, "").strip()
    if not text:
        return ComputeThreads()
    try:
        value = int(text)
    except ValueError:
        raise _problem(text, "is not an integer") from None
    what = declared(ComputeThreads)["threads"].problem(value)
    if what is not None:
        raise _problem(value, what)
    return ComputeThreads(value)


def compute_threads(environ: os._Environ[str] | dict[str, str] | None = None) -> int:
    """The number of compute threads [threads]: ``VFS_THREADS``, else one per core this
    process may use (at most :data:`MOST_THREADS`).

    Raises
    ------
    SettingsError
        Where ``VFS_THREADS`` is not an integer in ``[1, MOST_THREADS]``.
    """
    threads = threads_setting(environ).threads
    return min(available_cores(), MOST_THREADS) if threads is None else threads


__all__ = ["MOST_THREADS", "THREADS_VARIABLE", "ComputeThreads", "available_cores",
           "compute_threads", "threads_setting"]
