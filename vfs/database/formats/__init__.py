"""Database folder formats: how a folder is recognised, read and written.

A :class:`DatabaseFormat` names the file that marks a folder of its format, a
reader and (optionally) a writer.  The formats are kept in :data:`DATABASE_FORMATS`:

* the modules of this package register theirs when it is imported (``parquet``,
  ``csv``, ``pcm``): a new format in vfs is one new module here, its test and its docs;
* another package adds one through the entry-point group ``vfs.database_formats``
  (its object a :class:`DatabaseFormat`), without editing vfs.

:func:`vfs.database.source.detect_format` tries them in the order of their
``priority`` (then registration); :func:`vfs.database.source.load_any` and
``vfs db convert --to`` use their ``load`` and ``save``.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from vfs.errors import ParameterError
from vfs.registry import Registry

if TYPE_CHECKING:
    import pandas as pd

    from vfs.database.database import Database


@dataclass(frozen=True)
class DatabaseFormat:
    """One database folder format.

    Attributes
    ----------
    name : str
        ``--to`` value and :attr:`vfs.database.source.DatabaseSelection.fmt`.
    doc : str
        One line for help and docs.
    marker : str
        A file (lower-case name) whose presence marks a folder of this format.
    load : callable
        ``load(path, validate) -> Database``.
    save : callable, optional
        ``save(db, path) -> Path`` (None: read only).
    priority : int
        Detection order (lower first) where a folder holds several markers.
    """

    name: str
    doc: str
    marker: str
    load: Callable[[str | os.PathLike[str], bool], Database]
    save: Callable[[Database, str | os.PathLike[str]], Path] | None = None
    priority: int = 100


def _check_format(name: str, fmt: DatabaseFormat) -> None:
    if not isinstance(fmt, DatabaseFormat):
        raise ParameterError(f"database format {name!r} must be a DatabaseFormat, got "
                             f"{type(fmt).__name__}")
    if fmt.name != name:
        raise ParameterError(f"database format {fmt.name!r} registered as {name!r}")


#: Database formats by name; entry-point group ``vfs.database_formats``.
DATABASE_FORMATS: Registry[DatabaseFormat] = Registry(
    "database format", entry_point_group="vfs.database_formats", check=_check_format)


def table_folder_format(name: str, doc: str, suffix: str,
                        read: Callable[[Path, str], pd.DataFrame],
                        write: Callable[[pd.DataFrame, Path], None],
                        priority: int = 100) -> DatabaseFormat:
    """A format of one file ``<table><suffix>`` per table plus ``meta.json``.

    Parameters
    ----------
    name, doc, priority
        As :class:`DatabaseFormat`; the marker is ``cases<suffix>``.
    suffix : str
        File ending (``".feather"``).
    read : callable
        ``read(file, table) -> DataFrame`` in the file units of the schema.
    write : callable
        ``write(frame, file)``.
    """
    from vfs.database.io import (
        META_FILE,
        check_before_write,
        finish_loading,
        meta_text,
        read_meta,
        tables_for_writing,
        write_folder_atomically,
    )
    from vfs.database.schema import TABLE_NAMES, empty_table
    from vfs.errors import DataError, DataProblem

    def load(path: str | os.PathLike[str], validate: bool) -> Database:
        folder = Path(path)
        if not folder.is_dir():
            raise DataError(DataProblem("meta", "", None, None,
                                        f"{name} folder {folder} does not exist"))
        meta, problems = read_meta(folder)
        frames = {}
        for table in TABLE_NAMES:
            file = folder / f"{table}{suffix}"
            try:
                frames[table] = read(file, table)
            except (OSError, ValueError) as exc:
                problems.append(DataProblem(table, "", None, None, f"cannot read {file}: {exc}"))
                frames[table] = empty_table(table)
        return finish_loading(frames, meta, problems, validate)

    def save(db: Database, path: str | os.PathLike[str]) -> Path:
        norm = check_before_write(db, True)

        def write_all(folder: Path) -> None:
            for table, df in tables_for_writing(norm).items():
                write(df, folder / f"{table}{suffix}")
            (folder / META_FILE).write_text(meta_text(norm.meta), encoding="utf-8")

        return write_folder_atomically(path, write_all, [META_FILE, f"cases{suffix}"])

    return DatabaseFormat(name, doc, f"cases{suffix}", load, save, priority)


def register_format(fmt: DatabaseFormat) -> DatabaseFormat:
    """Add ``fmt`` to :data:`DATABASE_FORMATS` under its name and return it."""
    return DATABASE_FORMATS.add(fmt.name, fmt)


def formats_by_priority() -> list[DatabaseFormat]:
    """The registered formats in detection order."""
    return sorted(DATABASE_FORMATS.values(), key=lambda f: f.priority)


for _module in sorted(m.name for m in pkgutil.iter_modules([os.path.dirname(__file__)])):
    importlib.import_module(f"{__name__}.{_module}")

__all__ = ["DATABASE_FORMATS", "DatabaseFormat", "formats_by_priority", "register_format",
           "table_folder_format"]
