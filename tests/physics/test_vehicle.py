"""Vehicle parameters and derived quantities (vfs.physics.vehicle)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.physics.geometry import outline_corners
from vfs.physics.vehicle import corner_radius

_angle = st.floats(-math.pi, math.pi)


@settings(max_examples=200, deadline=None)
@given(front=st.floats(0.1, 6.0), rear=st.floats(0.1, 6.0), width=st.floats(0.5, 3.0),
       yaw=_angle)
def test_corner_radius_is_the_farthest_corner(front, rear, width, yaw):
    corners = outline_corners([0.0], [0.0], [yaw], [front], [rear], [width])[0]
    brute = np.hypot(corners[:, 0], corners[:, 1]).max()
    assert corner_radius(front, rear, width) == pytest.approx(brute, rel=1e-12)
