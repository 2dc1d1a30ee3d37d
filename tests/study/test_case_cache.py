"""The case batches kept per process (:mod:`vfs.study.case_cache`): the same study with
and without them, a rewritten database never served from them, the bounds kept.
"""

from __future__ import annotations

import os
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from vfs.bench.study import generated_database
from vfs.database import load_database
from vfs.simulation import CaseBatch, SimulationParams
from vfs.study import inputs as study_inputs
from vfs.study import run as study_run
from vfs.study import run_study
from vfs.study import tasks as study_tasks
from vfs.study.case_cache import (
    BlockCache,
    CaseCache,
    batch_bytes,
    folder_key,
    folder_stamp,
)
from vfs.study.inputs import study_input
from vfs.study.tasks import RunTask, load_chunk


def _task(db: Path, ids: np.ndarray) -> RunTask:
    return RunTask(chunk=0, case_ids=ids, system_index=0, system=None, db=str(db),
                   db_format="parquet", batch=None, equip="both", seed=0,
                   params=SimulationParams(), impact_parameters="reconstruction")


def _fields_equal(a: object, b: object) -> bool:
    """Whether two batches hold the same arrays (NaN equal to NaN, dtypes equal)."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and \
            np.array_equal(a, b, equal_nan=a.dtype.kind in "fc")
    if isinstance(a, tuple):
        return isinstance(b, tuple) and len(a) == len(b) and \
            all(_fields_equal(x, y) for x, y in zip(a, b, strict=True))
    if hasattr(a, "__dataclass_fields__"):
        return type(a) is type(b) and all(_fields_equal(getattr(a, f), getattr(b, f))
                                          for f in a.__dataclass_fields__)
    return a == b


@pytest.fixture(scope="module")
def database(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return generated_database(tmp_path_factory.mktemp("cache") / "db", 60)


def test_study_equals_the_uncached_study(database: Path, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    common = dict(engine="serial", progress=False, chunk_size=20)
    cache = CaseCache()
    monkeypatch.setattr(study_tasks, "CASES", cache)
    run_study(str(database), ["three-stage", "ideal"], tmp_path / "cached", **common)
    # one load per chunk set, two hits (the two systems) on each
    assert cache.misses >= 1 and cache.hits == 2 * cache.misses
    # the validated blocks of the client (two here) serve the tasks: they read no file
    blocks = BlockCache()
    monkeypatch.setattr(study_tasks, "BLOCKS", blocks)
    monkeypatch.setattr(study_inputs, "BLOCKS", blocks)
    monkeypatch.setattr(study_run, "study_input", partial(study_input, block_cases=25))
    read = []
    monkeypatch.setattr(study_tasks, "load_database", lambda *a, **k: read.append(a))
    monkeypatch.setattr(study_tasks, "CASES", CaseCache())
    run_study(str(database), ["three-stage", "ideal"], tmp_path / "blocks", **common)
    assert blocks.hits == 1 and not read
    monkeypatch.undo()
    # neither cache: every task reads its cases from the files
    monkeypatch.setattr(study_tasks, "CASES", CaseCache(entries=0))
    monkeypatch.setattr(study_tasks, "BLOCKS", BlockCache(max_bytes=0))
    monkeypatch.setattr(study_inputs, "BLOCKS", BlockCache(max_bytes=0))
    run_study(str(database), ["three-stage", "ideal"], tmp_path / "plain", **common)
    a = pd.read_parquet(tmp_path / "cached" / "runs.parquet")
    b = pd.read_parquet(tmp_path / "plain" / "runs.parquet")
    assert len(a) == 3 * 60 and a["collided"].any()
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "blocks" / "runs.parquet"), b,
                                  check_exact=True)


def test_blocks_give_the_batch_of_the_files(database: Path) -> None:
    blocks = BlockCache()
    ids = np.arange(1, 61)
    for part in (ids[:25], ids[25:50], ids[50:]):
        blocks.put(folder_key(str(database)), part,
                   load_database(database, where=_where(part)))
    wanted = np.arange(20, 56)[::-1]  # three blocks, in another order
    db = blocks.covering(str(database), wanted)
    assert db is not None and blocks.hits == 1
    assert _fields_equal(CaseBatch.from_database(db, wanted),
                         CaseBatch.from_database(load_database(database, where=_where(wanted)),
                                                 wanted))
    assert blocks.covering(str(database), np.arange(55, 62)) is None  # 61 is in none
    (database / "meta.json").touch()  # another stamp: not these blocks any more
    assert blocks.covering(str(database), wanted) is None


def _where(ids: np.ndarray) -> str:
    return "case_id IN (" + ", ".join(str(int(i)) for i in ids) + ")"


def test_a_rewritten_database_is_loaded_again(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    db = generated_database(tmp_path / "db", 12, seed=1)
    cache = CaseCache()
    monkeypatch.setattr(study_tasks, "CASES", cache)
    ids = np.arange(1, 13)
    first = load_chunk(_task(db, ids))
    assert load_chunk(_task(db, ids)) is first and cache.hits == 1
    stamp = folder_stamp(db)
    generated_database(db, 12, seed=2)  # the same folder and case ids, other data
    for file in db.iterdir():  # even with the old modification times, a size differs
        old = {name: t for name, _, t in stamp}
        if file.name in old:
            os.utime(file, ns=(old[file.name], old[file.name]))
    assert folder_stamp(db) != stamp
    second = load_chunk(_task(db, ids))
    assert second is not first and cache.misses == 2
    monkeypatch.setattr(study_tasks, "CASES", CaseCache(entries=0))
    fresh = load_chunk(_task(db, ids))
    assert _fields_equal(second, fresh)
    assert not _fields_equal(first, fresh)


def test_cached_batches_are_read_only(database: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(study_tasks, "CASES", CaseCache())
    batch = load_chunk(_task(database, np.arange(1, 11)))
    with pytest.raises(ValueError, match="read-only"):
        batch.road_friction[0] = 0.0


def test_the_bounds_are_kept(database: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache = CaseCache(entries=2)
    monkeypatch.setattr(study_tasks, "CASES", cache)
    sets = [np.arange(1, 11), np.arange(11, 21), np.arange(21, 31)]
    for ids in sets:
        load_chunk(_task(database, ids))
    assert len(cache) == 2 and cache.misses == 3
    load_chunk(_task(database, sets[0]))  # the oldest was dropped
    assert cache.misses == 4
    big = load_chunk(_task(database, np.arange(1, 61)))
    small = CaseCache(max_bytes=batch_bytes(big) - 1)
    monkeypatch.setattr(study_tasks, "CASES", small)
    load_chunk(_task(database, np.arange(1, 61)))
    assert len(small) == 0 and small.size_bytes == 0
