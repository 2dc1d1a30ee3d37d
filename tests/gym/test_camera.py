"""The rendered top view frames both vehicles (vfs.gym.render.view_box)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from vfs.gym.render import VIEW_HALF_WIDTH, view_box

coord = st.floats(-500.0, 500.0, allow_nan=False)


@given(coord, coord, st.floats(0.0, 2 * math.pi), st.floats(0.0, 8 * VIEW_HALF_WIDTH - 20.0))
def test_both_vehicles_inside_the_view_up_to_the_framing_distance(ex, ey, angle, dist):
    ox, oy = ex + dist * math.cos(angle), ey + dist * math.sin(angle)
    cx, cy, half = view_box((ex, ey), (ox, oy))
    for x, y in ((ex, ey), (ox, oy)):  # 5 m of margin around each centre at least
        assert abs(x - cx) <= half - 5.0 + 1e-9 and abs(y - cy) <= half - 5.0 + 1e-9
    assert 0.5 * VIEW_HALF_WIDTH <= half <= 4 * VIEW_HALF_WIDTH


def test_far_apart_the_view_follows_the_ego():
    cx, cy, half = view_box((10.0, -3.0), (10.0 + 400.0, -3.0))
    assert (cx, cy) == (10.0, -3.0) and half == 4 * VIEW_HALF_WIDTH


def test_close_vehicles_keep_the_minimum_zoom():
    cx, cy, half = view_box((0.0, 0.0), (4.0, 0.0))
    assert half == 0.5 * VIEW_HALF_WIDTH and np.isclose(cx, 2.0)
