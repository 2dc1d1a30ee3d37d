"""Threat kernels of the AEB systems (vfs.adas.threat)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.adas.threat import Motion

_half_length = st.floats(0.4, 3.0)
_half_width = st.floats(0.3, 1.5)


@settings(max_examples=200, deadline=None)
@given(hl=_half_length, hw=_half_width, offset=st.floats(-1.0, 1.0))
def test_motion_circumradius_is_the_kernel_bit_for_bit(hl, hw, offset):
    one = np.array([0.0])
    m = Motion(one, one, one, one, one, one, one, np.array([hl]), np.array([hw]),
               np.array([offset]))
    # the formula the threat module used before the kernel existed
    assert m.circumradius[0] == np.hypot(abs(offset) + hl, hw)
