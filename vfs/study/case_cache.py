"""The case batches of a worker process, loaded once and reused by its tasks.

A study runs every chunk once per system (the baseline included), and the
tasks of one chunk set carry the same case ids (:mod:`vfs.study.plan`).  On one
core (``--engine serial``) all of them run in the study's process, and a
process worker often gets several systems of one chunk set; loading and packing
the cases (:func:`vfs.study.tasks.load_chunk`: the Parquet read, the paths of
the trajectories, :meth:`vfs.simulation.CaseBatch.from_database`) cost as much
per task as the baseline's simulation of a few hundred cases.  :class:`CaseCache`
keeps the last batches of the process:

* keyed by the database folder, its format, the case ids in their order, the
  impact-parameter source and the *stamp* of the folder (name, size and
  modification time in nanoseconds of every file in it): a database rewritten
  in place is loaded again, never served from the cache;
* bounded in entries and in bytes (:data:`CACHE_ENTRIES`, :data:`CACHE_BYTES`;
  a batch larger than the byte bound is not kept);
* holding the batches read-only (``ndarray.flags.writeable`` off), so a run
  cannot change what the next one gets; the simulation never writes to its batch.

Databases at an fsspec URL have no cheap stamp and are not cached; in-memory
databases travel inside the tasks (nothing to load).

A serial study also keeps the blocks its client validated
(:func:`vfs.study.inputs.validate_selection` with ``keep``) in :data:`BLOCKS`
(:class:`BlockCache`, the same key and byte bound): the tasks, which run in
the same process, take their cases from them instead of reading the files a
second time.  :func:`release` empties both caches (the end of a study).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.database import Database
from vfs.database.schema import TABLE_NAMES
from vfs.simulation import CaseBatch

#: Batches a process keeps at most.
CACHE_ENTRIES = 4
#: Bytes of array data a process keeps at most (a larger batch is not kept) [B].
CACHE_BYTES = 512 * 2**20


def folder_stamp(folder: str | os.PathLike[str]) -> tuple[tuple[str, int, int], ...]:
    """(relative path, size [B], modification time [ns]) of every file under ``folder``.

    Any rewrite of a database file changes its size or its modification time
    (both are compared), so a changed database gets another key.
    """
    out = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in files:
            path = os.path.join(root, name)
            st = os.stat(path)
            out.append((os.path.relpath(path, folder), int(st.st_size), int(st.st_mtime_ns)))
    return tuple(sorted(out))


def ids_digest(case_ids: np.ndarray) -> str:
    """SHA-256 of the case ids in their order (as int64 where integral)."""
    ids = np.asarray(case_ids)
    data = ids.astype(np.int64).tobytes() if ids.dtype.kind in "iub" else \
        "\x1f".join(map(str, ids.tolist())).encode()
    return hashlib.sha256(data).hexdigest()


def _arrays(value: Any) -> list[np.ndarray]:
    """The numpy arrays inside a batch (named tuples and dataclasses, recursively)."""
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, tuple):
        return [a for item in value for a in _arrays(item)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return [a for f in dataclasses.fields(value) for a in _arrays(getattr(value, f.name))]
    return []


def batch_bytes(batch: CaseBatch) -> int:
    """Bytes of the array data of ``batch`` [B]."""
    return sum(int(a.nbytes) for a in _arrays(batch))


def _read_only(batch: CaseBatch) -> CaseBatch:
    for a in _arrays(batch):
        a.flags.writeable = False
    return batch


class CaseCache:
    """A small least-recently-used cache of case batches (see the module's description).

    Parameters
    ----------
    entries : int
        Batches kept at most.
    max_bytes : int
        Array bytes kept at most [B]; a batch larger than this is never kept.
    """

    def __init__(self, entries: int = CACHE_ENTRIES, max_bytes: int = CACHE_BYTES) -> None:
        self.entries, self.max_bytes = int(entries), int(max_bytes)
        self._items: OrderedDict[Hashable, tuple[CaseBatch, int]] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    @property
    def size_bytes(self) -> int:
        """Array bytes held now [B]."""
        return sum(n for _, n in self._items.values())

    def __len__(self) -> int:
        return len(self._items)

    def clear(self) -> None:
        """Drop every batch."""
        with self._lock:
            self._items.clear()

    def get(self, key: Hashable, load: Callable[[], CaseBatch]) -> CaseBatch:
        """The batch of ``key``: the kept one, or ``load()`` (kept when it fits)."""
        with self._lock:
            item = self._items.get(key)
            if item is not None:
                self._items.move_to_end(key)
                self.hits += 1
                return item[0]
        batch = load()
        self.misses += 1
        size = batch_bytes(batch)
        if self.entries < 1 or size > self.max_bytes:
            return batch
        batch = _read_only(batch)
        with self._lock:
            self._items[key] = (batch, size)
            self._items.move_to_end(key)
            while len(self._items) > self.entries or self.size_bytes > self.max_bytes:
                self._items.popitem(last=False)
        return batch


#: The cache of this process (:func:`vfs.study.tasks.load_chunk`).
CASES = CaseCache()


def folder_key(location: str) -> tuple[str, str] | None:
    """(resolved folder, stamp) of a database folder; None for a URL (never cached).
    Taken before the files are read: a file rewritten while they are read then gives
    another key at the next look-up, and what was read is never served for it.
    """
    folder = Path(location)
    if not folder.is_dir():
        return None
    return str(folder.resolve()), repr(folder_stamp(folder))


def batch_key(location: str, fmt: str, case_ids: np.ndarray, impact_parameters: str
              ) -> tuple[str, ...] | None:
    """The cache key of a chunk's batch; None where the database is not cached (a URL)."""
    folder = folder_key(location)
    if folder is None:
        return None
    return (*folder, fmt, impact_parameters, ids_digest(case_ids))


def database_bytes(db: Database) -> int:
    """Bytes of the four tables of ``db`` (columns' data, not the Python objects) [B]."""
    return sum(int(df.memory_usage(index=False, deep=False).sum())
               for df in db.tables().values())


class BlockCache:
    """Validated blocks of a Parquet database's selection (see the module's description).

    Parameters
    ----------
    max_bytes : int
        Table bytes kept at most [B] (:func:`database_bytes`); a block that would
        exceed them is not kept.
    """

    def __init__(self, max_bytes: int = CACHE_BYTES) -> None:
        self.max_bytes = int(max_bytes)
        self._blocks: list[tuple[tuple[str, str], np.ndarray, Database, int]] = []
        self._lock = threading.Lock()
        self.hits = 0

    def __len__(self) -> int:
        return len(self._blocks)

    def clear(self) -> None:
        """Drop every block."""
        with self._lock:
            self._blocks.clear()

    def put(self, key: tuple[str, str] | None, case_ids: np.ndarray, db: Database) -> None:
        """Keep block ``db`` (the cases ``case_ids`` as :func:`vfs.database.load_database`
        gave them from the folder of ``key``, :func:`folder_key` taken before reading),
        where it fits; nothing for a None key (a URL).
        """
        if key is None:
            return
        size = database_bytes(db)
        with self._lock:
            if size + sum(b[3] for b in self._blocks) <= self.max_bytes:
                self._blocks.append((key, np.asarray(case_ids).copy(), db, size))

    def covering(self, location: str, case_ids: np.ndarray) -> Database | None:
        """The kept blocks that hold the cases ``case_ids``, as one database (their rows in
        the blocks' order, which is the files'); None unless every case is in a block of
        the database's current files.
        """
        key = folder_key(location)
        if key is None:
            return None
        ids = np.asarray(case_ids)
        with self._lock:
            chosen = [b for b in self._blocks if b[0] == key and np.isin(b[1], ids).any()]
        if not chosen or not np.isin(ids, np.concatenate([b[1] for b in chosen])).all():
            return None
        self.hits += 1
        if len(chosen) == 1:
            return chosen[0][2]
        tables = {name: pd.concat([getattr(b[2], name) for b in chosen], ignore_index=True)
                  for name in TABLE_NAMES}
        return Database(**tables, meta=dict(chosen[0][2].meta))


#: The validated blocks of a serial study's client (:func:`vfs.study.inputs.validate_selection`).
BLOCKS = BlockCache()


def release() -> None:
    """Empty :data:`CASES` and :data:`BLOCKS` (the memory they hold goes back)."""
    CASES.clear()
    BLOCKS.clear()


__all__ = ["BLOCKS", "CACHE_BYTES", "CACHE_ENTRIES", "CASES", "BlockCache", "CaseCache",
           "batch_bytes", "batch_key", "database_bytes", "folder_key", "folder_stamp", "ids_digest",
           "release"]
