"""Where a database comes from: a bundled name, a folder in any format, a URL, or memory.

:func:`open_database` is the one way in for users and commands alike::

    db = open_database("default")                         # the bundled database
    db = open_database("path/to/folder", where="accident_type = 241")

Bundled databases are the folders ``scenarios/databases/<name>`` of the catalogue
(:mod:`vfs.catalog`: the repository's folder in a clone, the copy inside the package of a
wheel, read with :mod:`importlib.resources`), so they work from any install.  A Parquet
database can also be named by an fsspec URL (``file:///data/db``, ``memory://db``,
``s3://bucket/db``; :func:`vfs.database.io.is_url`).

A ``--db`` value has two forms: its *reference* (:func:`database_reference`:
the bundled name, the URL, or the absolute folder), which is what study tasks
carry to the workers, and its *location* on one machine
(:func:`database_location`), which each worker derives from the reference with
its own install, so ``--db default`` works on workers that have vfs installed
elsewhere.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from vfs.catalog import catalog_path
from vfs.database.database import Database
from vfs.database.formats import DATABASE_FORMATS, formats_by_priority
from vfs.database.io import (
    is_url,
    load_database,
    select_cases,
    url_filesystem,
)
from vfs.errors import DataError, DataProblem, ParameterError

#: Databases shipped with vfs: ``--db NAME`` -> folder below ``scenarios/databases``.
BUNDLED_DATABASES: dict[str, str] = {
    "default": "default",
    "crash-tests": "crash-tests",  # scenarios/databases/crash-tests/README.md
    "euro-ncap-c2c": "euro-ncap-c2c",  # Euro NCAP 2026; built by vfs.scenarios.euro_ncap
    "euro-ncap-c2c-2023": "euro-ncap-c2c-2023",  # Euro NCAP 2023; likewise
}

#: Folder formats :func:`load_any` reads, built in (:data:`DATABASE_FORMATS` holds them and
#: those of installed packages).
FORMATS: tuple[str, ...] = tuple(f.name for f in formats_by_priority())

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
    return catalog_path("scenarios", "databases", BUNDLED_DATABASES[name])


def resolve_database_path(source: str | os.PathLike[str]) -> Path:
    """A ``--db`` value as a folder: a bundled name (``"default"``) or a path."""
    text = os.fspath(source)
    if text in BUNDLED_DATABASES:
        return bundled_database_path(text)
    return Path(text)


def database_reference(source: str | os.PathLike[str]) -> str:
    """A ``--db`` value as workers on any machine resolve it.

    A bundled name stays the name and a URL stays the URL (each worker
    finds them itself, :func:`database_location`); a path becomes absolute.

    >>> database_reference("default"), database_reference("memory://db")
    ('default', 'memory://db')
    """
    text = os.fspath(source)
    if text in BUNDLED_DATABASES or is_url(text):
        return text
    return str(Path(text).resolve())


def database_location(reference: str | os.PathLike[str]) -> str:
    """Where a ``--db`` value (or a :func:`database_reference`) is on this machine.

    A bundled name becomes the folder of this install, a URL stays the URL,
    a path is returned as given.
    """
    text = os.fspath(reference)
    if is_url(text):
        return text
    return str(resolve_database_path(text))


def detect_format(path: str | os.PathLike[str]) -> str:
    """Format of a database folder: the first of :data:`DATABASE_FORMATS` (by priority)
    whose marker file it holds (``"parquet"``, ``"csv"``, ``"pcm"``, ...).

    A database given by URL (:func:`vfs.database.io.is_url`) must be Parquet.

    Raises
    ------
    DataError
        If the folder holds none of them, or a URL holds no Parquet database.
    """
    if is_url(path):
        fs, root = url_filesystem(os.fspath(path))
        names = {str(p).rsplit("/", 1)[-1].lower() for p in fs.ls(root, detail=False)} \
            if fs.isdir(root) else set()
        if "cases.parquet" in names:
            return "parquet"
        raise DataError(DataProblem(
            "meta", "", None, None,
            f"{os.fspath(path)} is not a Parquet database (no cases.parquet); a database "
            "given by URL must be Parquet (convert a folder with vfs db convert)"))
    folder = Path(path)
    names = {p.name.lower() for p in folder.iterdir()} if folder.is_dir() else set()
    formats = formats_by_priority()
    for fmt in formats:
        if fmt.marker in names:
            return fmt.name
    raise DataError(DataProblem(
        "meta", "", None, None,
        f"{folder} is not a database folder (no "
        + ", ".join(f.marker for f in formats[:-1]) + f" or {formats[-1].marker})",
    ))


def load_any(
    path: str | os.PathLike[str], *, fmt: str | None = None, validate: bool = True
) -> Database:
    """Load a database folder in any supported format (detected when ``fmt`` is None).

    Parameters
    ----------
    path : path
        Folder.
    fmt : str, optional
        A name of :data:`DATABASE_FORMATS` ("parquet", "csv", "pcm", ...); default
        :func:`detect_format`.
    validate : bool
        Validate and raise :class:`DataError` listing every problem.

    Returns
    -------
    Database
    """
    fmt = detect_format(path) if fmt is None else fmt
    if fmt not in DATABASE_FORMATS:
        raise DataError(DataProblem("meta", "", None, None, f"unknown format {fmt!r} (known: "
                                    f"{', '.join(DATABASE_FORMATS)})"))
    return DATABASE_FORMATS.get(fmt).load(path, validate)


@dataclass(frozen=True)
class DatabaseSelection:
    """A selected database and where it came from (workers reload from ``reference``).

    Attributes
    ----------
    database : Database
        The selected cases.
    folder : str or None
        Resolved folder (or URL) on this machine; None for an in-memory database.
    fmt : str
        ``"parquet"``, ``"csv"``, ``"pcm"`` or ``"memory"``.
    reference : str or None
        What a worker resolves with :func:`database_location`: the bundled
        name, the URL or the absolute folder (:func:`database_reference`);
        None for an in-memory database.
    """

    database: Database
    folder: str | None
    fmt: str
    reference: str | None = None


def select_database(source: str | os.PathLike[str] | Database, where: str | None = None,
                    *, validate: bool = True) -> DatabaseSelection:
    """Open ``source`` (bundled name, folder or :class:`Database`) and select cases.

    Parameters
    ----------
    source : str, path or Database
        ``"default"`` (or another bundled name), a folder in any format, the
        fsspec URL of a Parquet database (``file://``, ``memory://``,
        ``s3://``, ...), or a database in memory.
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
    reference = database_reference(source)
    if is_url(reference):
        fmt = detect_format(reference)
        return DatabaseSelection(load_database(reference, where=where, validate=validate),
                                 reference, fmt, reference)
    folder = resolve_database_path(source).resolve()
    fmt = detect_format(folder)
    if fmt == "parquet":
        loaded = load_database(folder, where=where, validate=validate)
    else:
        loaded = load_any(folder, fmt=fmt, validate=validate)
        if where:
            loaded = select_cases(loaded, where)
    return DatabaseSelection(loaded, str(folder), fmt, reference)


def open_database(source: str | os.PathLike[str] | Database = "default",
                  where: str | None = None, *, validate: bool = True) -> Database:
    """Open a database: ``"default"`` (bundled), a folder (Parquet, CSV, PCM) or a Database.

    Parameters
    ----------
    source : str, path or Database
        Bundled name (:data:`BUNDLED_DATABASES`), folder, fsspec URL of a
        Parquet database, or database in memory.
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
    "database_location",
    "database_reference",
    "detect_format",
    "load_any",
    "open_database",
    "resolve_database_path",
    "select_database",
]
