"""The optional compiled overlap kernel agrees with the numpy reference.

The kernel repeats the reference's arithmetic pair by pair; only the order
of the additions in the shoelace sums differs (numpy sums each row pairwise,
the compiled loop sequentially).  With at most K + 4 = 8 summands of size
|x| |y| <= ~25 m^2, the rounding difference is bounded by a few ulp of that
scale: 8 * 25 m^2 * 2**-52 ~ 4.4e-14 m^2, so 1e-12 m^2 (area) and 1e-12 m
(centroid, area 0.1 m^2 and more) leave margin and still catch any real
deviation (a wrong crossing point moves the area by millimetres squared).
The clipped vertices involve no sums and must agree bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics import compiled
from vfs.physics.geometry import outline_corners, overlap
from vfs.scenarios.random import random_outline_pairs

pytestmark = pytest.mark.skipif(not compiled.AVAILABLE, reason="numba not installed")


def _check(o1: np.ndarray, o2: np.ndarray) -> None:
    ref = overlap(o1, o2)
    fast = compiled.overlap_compiled(o1, o2)
    np.testing.assert_array_equal(fast.polygon.nonempty, ref.polygon.nonempty)
    live = ref.polygon.nonempty
    np.testing.assert_array_equal(fast.polygon.vertices[live], ref.polygon.vertices[live])
    np.testing.assert_allclose(fast.area, ref.area, rtol=0.0, atol=1e-12)
    big = ref.area > 0.1
    np.testing.assert_array_equal(np.isnan(fast.centroid), np.isnan(ref.centroid))
    np.testing.assert_allclose(fast.centroid[big], ref.centroid[big], rtol=0.0, atol=1e-12)


def test_compiled_overlap_matches_reference_on_random_pairs() -> None:
    o1, o2 = random_outline_pairs(np.random.default_rng(11), 5_000)
    _check(o1, o2)


def test_compiled_overlap_closed_forms() -> None:
    """Identical rectangles overlap fully; disjoint ones not; a half shift halves the area."""
    x = np.array([0.0, 0.0, 2.0, 30.0])
    two, one = np.full(4, 2.0), np.full(4, 2.0)
    o1 = outline_corners(np.zeros(4), np.zeros(4), np.zeros(4), two, two, one)
    o2 = outline_corners(x, np.zeros(4), np.array([0.0, np.pi, 0.0, 0.0]), two, two, one)
    fast = compiled.overlap_compiled(o1, o2)
    np.testing.assert_allclose(fast.area, [8.0, 8.0, 4.0, 0.0], atol=1e-12)
    assert not fast.polygon.nonempty[3]
    np.testing.assert_allclose(fast.centroid[2], [1.0, 0.0], atol=1e-12)
    _check(o1, o2)
