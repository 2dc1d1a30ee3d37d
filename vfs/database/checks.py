"""The one input check of every command that reads a database.

``vfs db validate``, ``vfs study``, ``run-case``, ``compare``, ``diagnose``, the
gym environment and every other reader go through the same loaders
(:func:`vfs.database.load_database`, :func:`vfs.database.load_csv_folder`,
:func:`vfs.database.import_pcm`), and those end here:

* :func:`check_database` gives the schema problems
  (:func:`vfs.database.validation.validate_database`) and, on schema-valid
  data, the physical plausibility errors and warnings
  (:func:`vfs.database.plausibility.check_plausibility`, which includes the
  cross-field checks of :mod:`vfs.database.consistency`);
* :func:`settle` raises :class:`vfs.errors.DataError` on the errors and emits
  each warning as a :class:`vfs.errors.DataWarning` (the command line prints
  it as one ``warning:`` line); inside :func:`strict_input` (``--strict``) the
  warnings are errors too.

So every command prints the same errors and the same warnings for the same
data.
"""

from __future__ import annotations

import contextvars
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from vfs.database.plausibility import Plausibility, check_plausibility
from vfs.database.validation import validate_database
from vfs.errors import DataError, DataProblem, DataWarning

_STRICT: contextvars.ContextVar[bool] = contextvars.ContextVar("vfs_strict_input", default=False)


@contextmanager
def strict_input(strict: bool = True) -> Iterator[None]:
    """Inside this block, plausibility warnings of loaded data are errors (``--strict``).

    Parameters
    ----------
    strict : bool
        True: warnings raise :class:`vfs.errors.DataError`; False: they are
        emitted as :class:`vfs.errors.DataWarning` (the default outside).
    """
    token = _STRICT.set(bool(strict))
    try:
        yield
    finally:
        _STRICT.reset(token)


def is_strict() -> bool:
    """True inside :func:`strict_input`."""
    return _STRICT.get()


def check_database(db: Any, *, require_cases: bool = False) -> Plausibility:
    """Every error and warning of ``db``: schema, then physics on schema-valid data.

    Parameters
    ----------
    db : Database
        Tables in SI units (as loaded).
    require_cases : bool
        An empty database is an error (``vfs db validate``); loaders pass False
        (a selection may match no case).

    Returns
    -------
    Plausibility
        ``errors`` (schema and physics) and ``warnings`` (physics; empty when
        the schema already fails).
    """
    errors = validate_database(db, plausibility=False)
    if errors:
        return Plausibility(errors, [])
    found = check_plausibility(db, require_cases=require_cases)
    return Plausibility(list(found.errors), list(found.warnings))


def settle(errors: Sequence[DataProblem], found_warnings: Sequence[DataProblem], *,
           header: str = "") -> None:
    """Raise on ``errors`` (and, when strict, on warnings); emit the warnings otherwise.

    Parameters
    ----------
    errors, found_warnings : sequence of DataProblem
        What :func:`check_database` found (plus reading problems).
    header : str
        First line of the error message (default: the problem count).

    Raises
    ------
    DataError
        Any error, or any warning inside :func:`strict_input`.
    """
    if is_strict() and found_warnings:
        errors = [*errors, *(_as_strict(p) for p in found_warnings)]
    if errors:
        raise DataError(list(errors), header=header)
    for problem in found_warnings:
        warnings.warn(DataWarning(problem), stacklevel=3)


def _as_strict(problem: DataProblem) -> DataProblem:
    return DataProblem(problem.table, problem.column, problem.row, problem.case_id,
                       f"{problem.message} [a plausibility warning, an error under --strict]")


__all__ = ["check_database", "is_strict", "settle", "strict_input"]
