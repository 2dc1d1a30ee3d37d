"""``vfs study --db default --systems three-stage,ideal`` and ``vfs compare --db default``
give the same tables on the compiled core as on the numpy reference (``VFS_COMPILED=0``).

The compiled pre-crash core repeats the reference's arithmetic bit for bit
(tests/physics/test_core.py); the compiled run-out too, except for atan, which numpy (its
AVX-512 routine) and the C library round differently on ~0.15 % of arguments
(tests/physics/test_core_runout.py): rest poses then differ by ~1e-13 m.  So every column
is compared within :data:`vfs.physics.core_runout.AGREEMENT` (1e-9), absolute or relative:
the statistics of the comparison (means, standard deviations, t statistics, p-values) are
smooth in the rest poses and carry the ~1e-13 relative difference, four orders below the
bound; flags, counts and texts must be equal.  A subset of the bundled database keeps the
reference path's run short (its cases of every accident type there).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.compare import compare_database
from vfs.database import open_database
from vfs.physics.core_runout import AGREEMENT
from vfs.study import run_study

#: The first cases of the bundled database (collisions and avoidances with both systems).
WHERE = "case_id <= 20"


def test_study_runs_equal_the_reference(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    common = dict(where=WHERE, engine="serial", progress=False)
    monkeypatch.setenv("VFS_COMPILED", "0")
    ref = run_study("default", ["three-stage", "ideal"], tmp_path / "ref", **common)
    monkeypatch.setenv("VFS_COMPILED", "1")
    got = run_study("default", ["three-stage", "ideal"], tmp_path / "core", **common)
    a = pd.read_parquet(tmp_path / "ref" / "runs.parquet")
    b = pd.read_parquet(tmp_path / "core" / "runs.parquet")
    assert len(a) == 3 * a["case_id"].nunique() > 0
    assert a["collided"].any() and not a["collided"].all()
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=AGREEMENT, atol=AGREEMENT)
    pd.testing.assert_frame_equal(ref.table, got.table, check_exact=False, rtol=AGREEMENT,
                                  atol=AGREEMENT)


def test_compare_tables_equal_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    db = open_database("default")
    db = db.subset(np.asarray(db.case_ids)[:40])
    monkeypatch.setenv("VFS_COMPILED", "0")
    ref = compare_database(db)
    monkeypatch.setenv("VFS_COMPILED", "1")
    got = compare_database(db)
    frames = 0
    for f in dataclasses.fields(ref):
        a, b = getattr(ref, f.name), getattr(got, f.name)
        if isinstance(a, pd.DataFrame):
            frames += 1
            pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=AGREEMENT,
                                          atol=AGREEMENT, obj=f.name)
        elif dataclasses.is_dataclass(a) or isinstance(a, np.ndarray | float | int | str):
            assert repr(a) == repr(b), f.name
    assert frames >= 2
