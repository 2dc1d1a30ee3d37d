"""The small kernels that exist once: CG-to-corner radius, rectangle distance, first contact
of moving rectangles, friction-limited deceleration, axial wrap, impact-type names, E and
delta-v.  Each is checked against a brute-force or closed-form reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.adas.threat import Motion
from vfs.physics.geometry import (
    first_contact,
    outline_corners,
    outline_distance,
    rectangle_distance,
)
from vfs.physics.impact import (
    IMPACT_TYPE_NAMES,
    ImpactParams,
    deformation_energy,
    ees_from_energy,
    impact_type_names,
    velocity_change,
)
from vfs.physics.precrash import PrecrashParams, friction_limited_deceleration
from vfs.physics.vehicle import corner_radius
from vfs.units import G, wrap_axial

_coord = st.floats(-8.0, 8.0)
_angle = st.floats(-math.pi, math.pi)
_half_length = st.floats(0.4, 3.0)
_half_width = st.floats(0.3, 1.5)


def _polygon(x: float, y: float, yaw: float, hl: float, hw: float) -> shapely.Polygon:
    c, s = math.cos(yaw), math.sin(yaw)
    return shapely.Polygon([(x + c * u - s * v, y + s * u + c * v)
                            for u, v in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])


# ----------------------------------------------------------------------------
# CG-to-corner radius
# ----------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(front=st.floats(0.1, 6.0), rear=st.floats(0.1, 6.0), width=st.floats(0.5, 3.0),
       yaw=_angle)
def test_corner_radius_is_the_farthest_corner(front, rear, width, yaw):
    corners = outline_corners([0.0], [0.0], [yaw], [front], [rear], [width])[0]
    brute = np.hypot(corners[:, 0], corners[:, 1]).max()
    assert corner_radius(front, rear, width) == pytest.approx(brute, rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(hl=_half_length, hw=_half_width, offset=st.floats(-1.0, 1.0))
def test_motion_circumradius_is_the_kernel_bit_for_bit(hl, hw, offset):
    one = np.array([0.0])
    m = Motion(one, one, one, one, one, one, one, np.array([hl]), np.array([hw]),
               np.array([offset]))
    # the formula the threat module used before the kernel existed
    assert m.circumradius[0] == np.hypot(abs(offset) + hl, hw)


# ----------------------------------------------------------------------------
# Distance between two rectangles
# ----------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(ax=_coord, ay=_coord, ayaw=_angle, ahl=_half_length, ahw=_half_width, bx=_coord,
       by=_coord, byaw=_angle, bhl=_half_length, bhw=_half_width)
def test_rectangle_distance_equals_shapely(ax, ay, ayaw, ahl, ahw, bx, by, byaw, bhl, bhw):
    ref = _polygon(ax, ay, ayaw, ahl, ahw).distance(_polygon(bx, by, byaw, bhl, bhw))
    got = rectangle_distance([ax], [ay], [ayaw], [ahl], [ahw], [bx], [by], [byaw], [bhl],
                             [bhw])[0]
    assert got == pytest.approx(ref, abs=1e-9)
    # the corner form is the same kernel
    oa = outline_corners([ax], [ay], [ayaw], [ahl], [ahl], [2 * ahw])
    ob = outline_corners([bx], [by], [byaw], [bhl], [bhl], [2 * bhw])
    assert outline_distance(oa, ob)[0] == pytest.approx(ref, abs=1e-9)


def test_crossing_rectangles_without_a_corner_inside_have_distance_zero():
    # a plus sign: no corner of either rectangle lies in the other, yet they overlap
    gap = rectangle_distance([0.0], [0.0], [0.0], [3.0], [0.5], [0.0], [0.0], [math.pi / 2],
                             [3.0], [0.5])
    assert gap[0] == 0.0


# ----------------------------------------------------------------------------
# First contact of two moving rectangles
# ----------------------------------------------------------------------------


def _bisect_first_contact(a: shapely.Polygon, b: shapely.Polygon, ddx: float, ddy: float,
                          samples: int = 400, steps: int = 60) -> float:
    """First s in [0, 1] at which b translated by s (ddx, ddy) touches a: a fine scan for
    the first touching sample, then bisection between it and the sample before."""
    def touches(s: float) -> bool:
        return a.intersects(shapely.affinity.translate(b, s * ddx, s * ddy))

    if touches(0.0):
        return 0.0
    grid = np.linspace(0.0, 1.0, samples + 1)
    hits = [s for s in grid if touches(float(s))]
    if not hits:
        return math.inf
    hi = float(hits[0])
    lo = hi - 1.0 / samples
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if touches(mid) else (mid, hi)
    return hi


@settings(max_examples=150, deadline=None)
@given(dx=_coord, dy=_coord, ddx=st.floats(-16.0, 16.0), ddy=st.floats(-16.0, 16.0),
       yaw_a=_angle, hl_a=_half_length, hw_a=_half_width, yaw_b=_angle, hl_b=_half_length,
       hw_b=_half_width)
def test_first_contact_equals_bisection_on_shapely(dx, dy, ddx, ddy, yaw_a, hl_a, hw_a, yaw_b,
                                                   hl_b, hw_b):
    import shapely.affinity  # noqa: F401  (used by the reference)

    a = _polygon(0.0, 0.0, yaw_a, hl_a, hw_a)
    b = _polygon(dx, dy, yaw_b, hl_b, hw_b)
    s = first_contact(np.array([dx]), np.array([dy]), np.array([ddx]), np.array([ddy]),
                      np.array([yaw_a]), np.array([hl_a]), np.array([hw_a]),
                      np.array([yaw_b]), np.array([hl_b]), np.array([hw_b]))[0]
    ref = _bisect_first_contact(a, b, ddx, ddy)
    move = math.hypot(ddx, ddy)
    if math.isinf(ref):
        # no sample touches: the kernel may still find a graze between samples
        assert math.isinf(s) or a.distance(shapely.affinity.translate(
            b, s * ddx, s * ddy)) <= 1e-9
        return
    assert np.isfinite(s)
    assert abs(s - ref) * move <= 1e-6 + move / 400  # within one scan sample [m]
    # at s the rectangles touch, shortly before they are apart
    assert a.distance(shapely.affinity.translate(b, s * ddx, s * ddy)) <= 1e-9
    if s > 1e-6:
        back = max(s - 1e-4, 0.0)
        assert a.distance(shapely.affinity.translate(b, back * ddx, back * ddy)) > 0.0


# ----------------------------------------------------------------------------
# Friction-limited deceleration
# ----------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(mu=st.floats(0.05, 1.5), a_max=st.floats(0.5, 15.0))
def test_friction_limited_deceleration_closed_form(mu, a_max):
    a = float(friction_limited_deceleration(mu, a_max))
    assert a == (mu * G if mu * G < a_max else a_max)
    # the stopping distance from 20 m/s is that of the weaker limit
    assert 20.0**2 / (2 * a) == pytest.approx(max(20.0**2 / (2 * mu * G), 20.0**2 / (2 * a_max)))


def test_friction_limited_deceleration_broadcasts():
    out = friction_limited_deceleration(np.array([0.2, 0.8, 1.0]), np.array([9.0]))
    np.testing.assert_array_equal(out, [0.2 * G, 0.8 * G, 9.0])


# ----------------------------------------------------------------------------
# Angles, names, energies
# ----------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(a=st.floats(-50.0, 50.0))
def test_wrap_axial_range_and_period(a):
    w = float(wrap_axial(a))
    assert -math.pi / 2 <= w < math.pi / 2
    turns = (a - w) / math.pi
    assert turns == pytest.approx(round(turns), abs=1e-9)


def test_impact_type_names_follow_the_one_constant():
    codes = np.array([2, 0, 1, 1])
    assert impact_type_names(codes).tolist() == [IMPACT_TYPE_NAMES[int(k)] for k in codes]


@settings(max_examples=200, deadline=None)
@given(mass=st.floats(500.0, 3000.0), ees=st.floats(0.0, 40.0), dvx=st.floats(-30.0, 30.0),
       dvy=st.floats(-30.0, 30.0))
def test_energy_and_delta_v_kernels(mass, ees, dvx, dvy):
    assert float(ees_from_energy(deformation_energy(mass, ees), mass)) == pytest.approx(
        ees, rel=1e-12, abs=1e-12)
    # sqrt(dvx^2 + dvy^2): equal to hypot up to rounding (squares underflow below 1e-154)
    assert float(velocity_change(dvx, dvy)) == pytest.approx(math.hypot(dvx, dvy), rel=1e-15,
                                                             abs=1e-12)


def test_penetration_time_default_lives_in_precrash():
    assert "penetration_time" not in ImpactParams.__dataclass_fields__
    with pytest.raises(TypeError):
        ImpactParams(penetration_time=0.05)  # type: ignore[call-arg]
    with pytest.warns(DeprecationWarning):
        assert ImpactParams().penetration_time == PrecrashParams().penetration_time
