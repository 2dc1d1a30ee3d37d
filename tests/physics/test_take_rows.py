"""``take_rows`` (the row gathers of the pre-crash step and the AEB controller) selects
exactly what fancy indexing selects, and refuses what it refuses."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics.precrash_contact import take_rows


@pytest.mark.parametrize("shape", [(7,), (7, 2), (7, 2, 3)])
@pytest.mark.parametrize("dtype", [np.float64, np.int64, np.bool_])
def test_take_rows_equals_fancy_indexing(shape: tuple[int, ...], dtype: type) -> None:
    rng = np.random.default_rng(5)
    a = (rng.standard_normal(shape) * 3).astype(dtype)
    for index in (rng.random(7) < 0.5, np.zeros(7, dtype=bool), np.array([6, 0, 3, 3, -1]),
                  np.zeros(0, dtype=np.int64)):
        got, want = take_rows(a, index), a[index]
        assert got.dtype == want.dtype and got.shape == want.shape
        assert np.array_equal(got, want)


def test_take_rows_refuses_what_indexing_refuses() -> None:
    a = np.zeros((4, 2))
    with pytest.raises(IndexError):
        take_rows(a, np.ones(3, dtype=bool))  # a mask of the wrong length
    with pytest.raises(IndexError):
        take_rows(a, np.array([4]))  # a row that is not there
