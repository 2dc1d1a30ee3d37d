"""Unit constants and angle helpers (vfs.units)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.units import wrap_axial


@settings(max_examples=300, deadline=None)
@given(a=st.floats(-50.0, 50.0))
def test_wrap_axial_range_and_period(a):
    w = float(wrap_axial(a))
    assert -math.pi / 2 <= w < math.pi / 2
    turns = (a - w) / math.pi
    assert turns == pytest.approx(round(turns), abs=1e-9)
