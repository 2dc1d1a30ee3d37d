"""Where a database comes from: a bundled name, a folder in any format, or memory.

:func:`open_database` is the one way in for users and commands alike::

    db = open_database("default")                         # the bundled database
    db = open_database("path/to/folder", where="accident_type = 241")

Bundled databases ship inside the package (``vfs/data/<name>``) and are
found with :mod:`importlib.resources`, so they work from any install.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from vfs.database.database import Database
from vfs.database.io import load_csv_folder, load_database, select_cases
from vfs.database.pcm import import_pcm
from vfs.errors import DataError, DataProblem, ParameterError

#: Databases shipped with vfs: ``--db NAME`` -> folder below ``vfs/data``.
BUNDLED_DATABASES: dict[str, str] = {
    "default": "default",
    "crash-tests": "crash-tests",  # vfs/data/crash-tests/README.md
}

#: Folder formats :func:`load_any` reads.
FORMATS: tuple[str, ...] = ("parquet", "csv", "pcm")

#: Value of :attr:`DatabaseSelection.fmt` for an in-memory database.
MEMORY = "memory"


def data_path(*parts: str) -> Path:
    """A file or folder of the package data (``vfs/data/...``) as a path."""
    return Path(str(resources.files("vfs").joinpath("data", *parts)))


def bundled_database_path(name: str = "default") -> Path:
    """The folder of the bundled database ``name`` (:data:`BUNDLED_DATABASES`).

    Raises
    ------
    ParameterError
        For an unknown name.
    """
    if name not in BUNDLED_DATABASES:
        raise ParameterError(f"unknown bundled database {name!r}; known: "
                             f"{', '.join(BUNDLED_DATABASES)}")
    return data_path(BUNDLED_DATABASES[name])


def resolve_database_path(source: str | os.PathLike[str]) -> Path:
    """A ``--db`` value as a folder: a bundled name (``"default"``) or a path."""
    text = os.fspath(source)
    if text in BUNDLED_DATABASES:
        return bundled_database_path(text)
    return Path(text)


def detect_format(path: str | os.PathLike[str]) -> str:
    """Format of a database folder: ``"parquet"``, ``"csv"`` or ``"pcm"``.

    Raises
    ------
    DataError
        If the folder holds none of them.
    """
    folder = Path(path)
    names = {p.name.lower() for p in folder.iterdir()} if folder.is_dir() else set()
    if "cases.parquet" in names:
        return "parquet"
    if "cases.csv" in names:
        return "csv"
    if "participant_data.csv" in names:
        return "pcm"
    raise DataError(DataProblem(
        "meta", "", None, None,
        f"{folder} is not a database folder (no cases.parquet, cases.csv or "
        "participant_data.csv)",
    ))


def load_any(
    path: str | os.PathLike[str], *, fmt: str | None = None, validate: bool = True
) -> Database:
    """Load a database folder in any supported format (detected when ``fmt`` is None).

    Parameters
    ----------
    path : path
        Folder.
    fmt : {"parquet", "csv", "pcm"}, optional
        Format; default :func:`detect_format`.
    validate : bool
        Validate and raise :class:`DataError` listing every problem.

    Returns
    -------
    Database
    """
    fmt = detect_format(path) if fmt is None else fmt
    if fmt == "parquet":
        return load_database(path, validate=validate)
    if fmt == "csv":
        return load_csv_folder(path, validate=validate)
    if fmt == "pcm":
        return import_pcm(path, validate=validate)
    raise DataError(DataProblem("meta", "", None, None,
                                f"unknown format {fmt!r} (known: {', '.join(FORMATS)})"))


@dataclass(frozen=True)
class DatabaseSelection:
    """A selected database and where it came from (workers reload from ``folder``).

    Attributes
    ----------
    database : Database
        The selected cases.
    folder : str or None
        Resolved folder; None for an in-memory database.
    fmt : str
        ``"parquet"``, ``"csv"``, ``"pcm"`` or ``"memory"``.
    """

    database: Database
    folder: str | None
    fmt: str


def select_database(source: str | os.PathLike[str] | Database, where: str | None = None,
                    *, validate: bool = True) -> DatabaseSelection:
    """Open ``source`` (bundled name, folder or :class:`Database`) and select cases.

    Parameters
    ----------
    source : str, path or Database
        ``"default"`` (or another bundled name), a folder in any format, or
        a database in memory.
    where : str, optional
        SQL predicate on the cases table (duckdb); on Parquet folders it is
        evaluated on the files, so only the selected cases are read.
    validate : bool
        Validate what is loaded.

    Returns
    -------
    DatabaseSelection

    Raises
    ------
    ParameterError
        ``source`` is neither a path nor a Database.
    DataError
        Unreadable or invalid data, or an invalid predicate.
    """
    if isinstance(source, Database):
        return DatabaseSelection(select_cases(source, where) if where else source, None,
                                 MEMORY)
    if not isinstance(source, str | os.PathLike):
        raise ParameterError(f"db must be a folder, a bundled name or a Database, got "
                             f"{type(source).__name__}")
    folder = resolve_database_path(source).resolve()
    fmt = detect_format(folder)
    if fmt == "parquet":
        loaded = load_database(folder, where=where, validate=validate)
    else:
        loaded = load_any(folder, fmt=fmt, validate=validate)
        if where:
            loaded = select_cases(loaded, where)
    return DatabaseSelection(loaded, str(folder), fmt)


def open_database(source: str | os.PathLike[str] | Database = "default",
                  where: str | None = None, *, validate: bool = True) -> Database:
    """Open a database: ``"default"`` (bundled), a folder (Parquet, CSV, PCM) or a Database.

    Parameters
    ----------
    source : str, path or Database
        Bundled name (:data:`BUNDLED_DATABASES`), folder, or database in memory.
    where : str, optional
        SQL predicate on the cases table selecting cases, e.g.
        ``"accident_type IN (241, 242)"``.
    validate : bool
        Validate and raise :class:`DataError` listing every problem.

    Returns
    -------
    Database

    Examples
    --------
    >>> db = open_database("default", where="accident_type = 601")
    >>> int(db.cases["accident_type"].unique()[0])
    601
    """
    return select_database(source, where, validate=validate).database


__all__ = [
    "BUNDLED_DATABASES",
    "FORMATS",
    "MEMORY",
    "DatabaseSelection",
    "bundled_database_path",
    "data_path",
    "detect_format",
    "load_any",
    "open_database",
    "resolve_database_path",
    "select_database",
]
