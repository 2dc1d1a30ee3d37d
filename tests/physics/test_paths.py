"""Recorded paths packed as arrays (vfs.physics.paths): packing, look-ups, extrapolation.

Oracles: closed forms on a circle and a straight line (chord lengths, chord directions,
mean curvature), numpy's own searchsorted / interp / gradient for the look-ups, and the
round trip take / concat.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.physics.paths import (
    KNOT_FIELDS,
    advance_index,
    concat_paths,
    find_index,
    pack_paths,
    pose_at_arclength,
    record_at_time,
)


def circle_record(radius: float, omega: float, n: int, dt: float = 0.1):
    """Samples of a CG moving counter-clockwise on a circle about the origin [m, rad/s, s]."""
    t = np.arange(n) * dt
    theta = omega * t
    x, y = radius * np.cos(theta), radius * np.sin(theta)
    yaw = theta + math.pi / 2
    speed = np.full(n, radius * omega)
    return t, x, y, yaw, speed


def two_paths():
    """A circle of 30 samples and a straight line of 12 (different lengths: padding)."""
    t1, x1, y1, yaw1, v1 = circle_record(20.0, 0.5, 30)
    t2 = np.arange(12) * 0.2 + 3.0
    x2, y2 = 5.0 + 8.0 * (t2 - 3.0), np.full(12, -2.0)
    yaw2, v2 = np.zeros(12), np.full(12, 8.0)
    group = np.r_[np.zeros(30, int), np.ones(12, int)]
    return pack_paths(np.r_[t1, t2], np.r_[x1, x2], np.r_[y1, y2], np.r_[yaw1, yaw2],
                      np.r_[v1, v2], group)


def test_arc_length_and_heading_are_the_chords_of_a_circle():
    r, omega, dt = 20.0, 0.5, 0.1
    p = pack_paths(*circle_record(r, omega, 30, dt), group=np.zeros(30, int))
    dtheta = omega * dt
    chord = 2 * r * math.sin(dtheta / 2)
    np.testing.assert_allclose(p.s[0], chord * np.arange(30), rtol=1e-12, atol=1e-12)
    # each segment moves along its chord: direction theta_i + dtheta / 2 + pi / 2
    theta = omega * dt * np.arange(29)
    np.testing.assert_allclose(p.heading[0, :-1], theta + dtheta / 2 + math.pi / 2,
                               rtol=0, atol=1e-12)
    # the mean d(yaw)/ds of the last second: dtheta per chord
    assert p.end_curvature[0] == pytest.approx(dtheta / chord, rel=1e-12)


def test_padding_repeats_the_last_sample_and_times_are_relative():
    p = two_paths()
    assert p.size == 2 and p.count.tolist() == [30, 12]
    assert p.knots.shape == (30, 2, len(KNOT_FIELDS))
    np.testing.assert_array_equal(p.x[1, 12:], p.x[1, 11])
    assert p.t0.tolist() == [0.0, 3.0]
    assert p.duration[1] == pytest.approx(11 * 0.2)
    assert p.last("x")[1] == pytest.approx(5.0 + 8.0 * 11 * 0.2)


def test_take_and_concat_are_inverse():
    p = two_paths()
    back = concat_paths(p.take([0]), p.take([1]))
    for a, b in zip(back, p, strict=True):
        np.testing.assert_array_equal(a, b)
    swapped = concat_paths(p.take([1]), p.take([0]))
    np.testing.assert_array_equal(swapped.knots[:12, 0], p.knots[:12, 1])
    assert swapped.count.tolist() == [12, 30]


def test_acceleration_is_the_record_or_the_speeds_central_difference():
    t = np.array([0.0, 0.5, 1.0, 2.0])
    v = np.array([10.0, 9.0, 7.0, 6.0])
    g = np.zeros(4, int)
    p = pack_paths(t, t * 5, 0 * t, 0 * t, v, g)
    np.testing.assert_allclose(p.accel[0], np.gradient(v) / np.gradient(t))
    given_accel = np.array([-1.0, np.nan, -3.0, np.nan])
    q = pack_paths(t, t * 5, 0 * t, 0 * t, v, g, accel=given_accel)
    expected = np.where(np.isnan(given_accel), np.gradient(v) / np.gradient(t), given_accel)
    np.testing.assert_allclose(q.accel[0], expected)


def test_a_standstill_segment_keeps_the_vehicle_yaw_as_heading():
    t = np.arange(4.0)
    x = np.array([0.0, 1.0, 1.0, 2.0])
    p = pack_paths(t, x, 0 * t, np.full(4, 0.3), [1.0, 0.0, 1.0, 1.0], np.zeros(4, int))
    assert p.heading[0, 1] == pytest.approx(0.3)
    assert p.heading[0, 0] == pytest.approx(0.0) and p.heading[0, 2] == pytest.approx(0.0)


@settings(max_examples=100, deadline=None)
@given(q=st.lists(st.floats(-1.0, 4.0), min_size=1, max_size=20))
def test_find_index_is_searchsorted_and_advance_index_agrees(q):
    p = two_paths()
    value = np.sort(np.asarray(q))
    for row, count in enumerate(p.count):
        rows = np.full(value.size, row)
        got = find_index(p, "t", value, rows)
        knots = p.t[row, :count]
        ref = np.clip(np.searchsorted(knots, value, side="right") - 1, 0, count - 2)
        np.testing.assert_array_equal(got, ref)
        # monotone queries: stepping forward from the previous index gives the same
        idx = np.zeros(1, dtype=np.int64)
        for k, v in enumerate(value):
            idx = advance_index(p, "t", idx, np.array([v]), np.array([row]))
            assert idx[0] == got[k]


def test_record_at_time_interpolates_inside_and_runs_on_at_constant_speed_beyond():
    p = two_paths()
    rows = np.array([0, 0, 1, 1])
    tau = np.array([0.73, 1.2, 0.5, 5.0])  # the last one beyond the straight record's end
    rec = record_at_time(p, rows, find_index(p, "t", tau, rows), tau)
    assert rec.s[0] == pytest.approx(np.interp(0.73, p.t[0], p.s[0]), rel=1e-12)
    assert rec.speed[1] == pytest.approx(10.0)
    t_end, s_end = p.duration[1], p.last("s")[1]
    assert rec.s[3] == pytest.approx(s_end + 8.0 * (5.0 - t_end), rel=1e-12)
    assert rec.speed[3] == 8.0 and rec.accel[3] == 0.0


def test_pose_reproduces_the_knots_and_continues_the_end_arc():
    p = two_paths()
    rows = np.zeros(30, int)
    s = p.s[0]
    pose = pose_at_arclength(p, rows, find_index(p, "s", s, rows), s)
    np.testing.assert_allclose(pose.x, p.x[0], atol=1e-12)
    np.testing.assert_allclose(pose.y, p.y[0], atol=1e-12)
    # beyond the end: an arc of the end curvature, tangent to the last heading
    k = p.end_curvature[0]
    extra = np.array([0.0, 3.0, 6.0, 9.0])
    s_beyond = p.last("s")[0] + extra + 1e-12
    rows4 = np.zeros(4, int)
    beyond = pose_at_arclength(p, rows4, find_index(p, "s", s_beyond, rows4), s_beyond)
    np.testing.assert_allclose(beyond.yaw - beyond.yaw[0], k * extra, atol=1e-9)
    heading_end = p.last("heading")[0]
    assert math.atan2(beyond.ty[0], beyond.tx[0]) == pytest.approx(heading_end, abs=1e-9)
    # the points lie on one circle of radius 1 / k through the end point
    centre = np.array([p.last("x")[0] - math.sin(heading_end) / k,
                       p.last("y")[0] + math.cos(heading_end) / k])
    radius = np.hypot(beyond.x - centre[0], beyond.y - centre[1])
    np.testing.assert_allclose(radius, 1.0 / k, rtol=1e-9)
    np.testing.assert_allclose(beyond.curvature, k)


def test_straight_extrapolation_keeps_line_and_yaw():
    p = two_paths()
    rows = np.ones(3, int)
    s = p.last("s")[1] + np.array([1.0, 2.0, 10.0])
    pose = pose_at_arclength(p, rows, find_index(p, "s", s, rows), s)
    np.testing.assert_allclose(pose.y, -2.0, atol=1e-12)
    np.testing.assert_allclose(pose.x, p.last("x")[1] + np.array([1.0, 2.0, 10.0]), rtol=1e-12)
    np.testing.assert_allclose(pose.yaw, 0.0, atol=1e-12)
