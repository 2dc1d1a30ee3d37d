"""What a study reads of its database on the client, without holding the whole database.

The client of a study needs the selected cases table (case ids, chunks, the
study's ``cases.parquet``), the data hash of the manifest
(:func:`vfs.study.manifest.data_hash`, for ``--resume``) and the assurance that
the selected data are valid; the workers load their chunks themselves
(:mod:`vfs.study.tasks`).  For a Parquet database (folder or fsspec URL)
:func:`study_input` therefore

* reads only the cases table (:func:`vfs.database.io.load_cases`),
* validates the selected cases in blocks of :data:`VALIDATION_BLOCK` cases
  (:func:`vfs.database.load_database` with ``validate=True`` on each block; every
  check of the schema is per case, so blocks find what the whole would), and
* computes the data hash table by table in batches of rows
  (:func:`vfs.database.io.iter_table`), which gives exactly the hash of the
  whole selection;

so the client's memory does not grow with the size of the database's
trajectories.  In-memory databases and CSV or PCM folders are loaded whole, as
before.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import (
    Database,
    database_location,
    database_reference,
    detect_format,
    load_database,
    select_database,
)
from vfs.database.io import is_url, iter_table, load_cases, orphan_problems, read_meta
from vfs.database.schema import TABLE_NAMES
from vfs.database.validation import validate_table
from vfs.errors import DataError, DataProblem
from vfs.study.case_cache import BLOCKS, folder_key
from vfs.study.manifest import data_hash

#: Cases validated at a time on the client (Parquet databases).
VALIDATION_BLOCK = 2000


@dataclass(frozen=True)
class StudyInput:
    """The selected cases of a study's database, as the client holds them.

    Attributes
    ----------
    cases : pandas.DataFrame
        The selected rows of the cases table (SI units, database order).
    meta : dict
        ``meta.json`` of the database.
    data_hash : str
        :func:`vfs.study.manifest.data_hash` of the selected cases' four tables;
        empty while not computed (``study_input(..., validate=False, hash=False)``).
    fmt : str
        ``"parquet"``, ``"csv"``, ``"pcm"`` or ``"memory"``.
    folder : str or None
        The database's folder (or URL) on this machine; None in memory.
    reference : str or None
        What the workers resolve (:func:`vfs.database.database_reference`).
    database : Database or None
        The whole selection, only for an in-memory database (its chunks
        then travel inside the tasks).
    validated : bool
        Whether the selected cases have been validated; False after
        ``study_input(..., validate=False)``: :func:`validate_selection` must
        pass (and, with ``data_hash`` empty, :func:`selection_hash` give the
        hash) before any result is written.
    """

    cases: pd.DataFrame
    meta: dict[str, Any]
    data_hash: str
    fmt: str
    folder: str | None
    reference: str | None
    database: Database | None = field(default=None, repr=False)
    validated: bool = True

    @property
    def case_ids(self) -> np.ndarray:
        """Selected case ids in database order."""
        return self.cases["case_id"].to_numpy()


def _ids_predicate(ids: np.ndarray) -> str:
    return "case_id IN (" + ", ".join(str(int(i)) for i in ids) + ")"


def streamed_data_hash(location: str, case_ids: np.ndarray) -> str:
    """:func:`vfs.study.manifest.data_hash` of the cases ``case_ids`` of a Parquet
    database, read table by table in batches of rows (never a whole table).
    """
    h = hashlib.sha256()
    for name in TABLE_NAMES:
        parts: Iterator[pd.DataFrame] = iter_table(location, name, case_ids)
        first = next(parts)
        h.update(name.encode())
        h.update(",".join(map(str, first.columns)).encode())
        for part in itertools.chain([first], parts):  # one batch at a time
            h.update(pd.util.hash_pandas_object(part, index=False).to_numpy().tobytes())
    return h.hexdigest()


def study_input(source: str | os.PathLike[str] | Database, where: str | None = None,
                *, block_cases: int = VALIDATION_BLOCK, validate: bool = True,
                hash: bool = True, keep: bool = False) -> StudyInput:
    """Open a study's database and select its cases (see the module's description).

    Parameters
    ----------
    source : str, path or Database
        Bundled name, folder (Parquet, CSV, PCM), fsspec URL of a Parquet
        database, or a database in memory.
    where : str, optional
        SQL predicate on the cases table (duckdb).
    block_cases : int
        Cases validated at a time (Parquet).
    validate : bool
        Validate the selected cases of a Parquet database now (default); with
        False the cases table is still checked, and the blocks are left to
        :func:`validate_selection` (a parallel study runs it while its workers
        start on the tasks; it is most of the client's time before them).
    hash : bool
        Compute the data hash of a Parquet selection now (default); with False
        ``data_hash`` is left empty for :func:`selection_hash` (a new parallel
        study computes it with the validation).
    keep : bool
        Keep the validated blocks for the tasks of this process
        (:func:`validate_selection`; a serial study).

    Returns
    -------
    StudyInput

    Raises
    ------
    DataError
        Unreadable or invalid data, an invalid predicate, or no case selected.
    """
    fmt = None
    if not isinstance(source, Database):
        reference = database_reference(source)
        location = database_location(reference)
        fmt = detect_format(location)
    if fmt != "parquet":
        selection = select_database(source, where)
        db = selection.database
        if db.n_cases == 0:
            raise _nothing_selected(where)
        return StudyInput(db.cases, dict(db.meta), data_hash(db), selection.fmt,
                          selection.folder, selection.reference,
                          db if selection.folder is None else None)
    cases = load_cases(location, where)
    # what validate checks beyond the blocks: the case ids themselves (text, NaN,
    # duplicates) and rows of cases that are not in the cases table (a block never loads them)
    problems = validate_table("cases", cases) or orphan_problems(location)
    if problems:
        raise DataError(problems)
    ids = cases["case_id"].to_numpy()
    if ids.size == 0:
        raise _nothing_selected(where)
    meta, _ = read_meta(location)
    folder = location if is_url(location) else str(Path(location).resolve())
    chosen = StudyInput(cases, meta, "", fmt, folder, reference, validated=False)
    if validate:  # before the hash reads every row: the data are known to be readable
        validate_selection(chosen, block_cases, keep=keep)
        chosen = dataclasses.replace(chosen, validated=True)
    if hash:
        chosen = dataclasses.replace(chosen, data_hash=streamed_data_hash(location, ids))
    return chosen


def selection_hash(selection: StudyInput) -> str:
    """The selection's data hash: ``data_hash``, computed now where left empty."""
    if selection.data_hash or selection.folder is None:
        return selection.data_hash
    return streamed_data_hash(selection.folder, selection.case_ids)


def validate_selection(selection: StudyInput, block_cases: int = VALIDATION_BLOCK,
                       keep: bool = False) -> None:
    """Validate the selected cases of a Parquet database in blocks of ``block_cases``.

    :func:`vfs.database.load_database` with ``validate=True`` on each block (every
    check of the schema is per case, so blocks find what the whole would); nothing
    to do for a selection already validated.  With ``keep`` the validated blocks
    stay in :data:`vfs.study.case_cache.BLOCKS` (within its byte bound) for the
    tasks of a serial study, which then read no file again.

    Raises
    ------
    DataError
        Listing the problems of the first block that has any.
    """
    if selection.validated or selection.folder is None:
        return
    ids = selection.case_ids
    for start in range(0, ids.size, max(1, int(block_cases))):
        block = ids[start:start + block_cases]
        key = folder_key(selection.folder) if keep else None
        db = load_database(selection.folder, where=_ids_predicate(block), validate=True)
        BLOCKS.put(key, block, db)


def _nothing_selected(where: str | None) -> DataError:
    return DataError(DataProblem("cases", "", None, None,
                                 "no case selected" + (f" by {where!r}" if where else "")))


__all__ = ["VALIDATION_BLOCK", "StudyInput", "selection_hash", "streamed_data_hash",
           "study_input", "validate_selection"]
