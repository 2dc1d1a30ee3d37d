"""Run-out with steered front wheels and extra rolling drag per wheel.

Oracles: the kinematic bicycle (steered rolling wheels at low speed: the rear-axle midpoint
follows the circle of radius wheelbase / tan(delta)); a free-rolling car with extra drag f_d
on every wheel stops after v^2 / (2 (f_r + f_d) g); locked wheels ignore the steer angle
(v^2 / (2 mu g)); mirror symmetry of +delta and -delta; straight motion before the steer
onset; kinetic energy never rising (hypothesis); convergence in dt.  Every test runs on
the compiled run-out and on its numpy reference (``both_runout_paths``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.errors import ParameterError
from vfs.physics.runout import (
    RunoutParams,
    RunoutState,
    kinetic_energy,
    run_out,
    run_out_pair,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

pytestmark = pytest.mark.usefixtures("both_runout_paths")

LOCKED = (1.0, 1.0, 1.0, 1.0)
FREE = (0.0, 0.0, 0.0, 0.0)


def car(**over):
    return stack_vehicles([VehicleParams(**over)])


def fitted_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle (centre x, centre y, radius) through the points [m]."""
    a = np.c_[2.0 * x, 2.0 * y, np.ones_like(x)]
    cx, cy, c = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
    return float(cx), float(cy), math.sqrt(c + cx * cx + cy * cy)


@pytest.mark.parametrize(("delta", "track", "tolerance"), [
    (0.05, 0.3, 0.005), (0.15, 0.3, 0.005), (-0.3, 0.3, 0.005),
    # a real track with parallel (not Ackermann) steering: the inner and outer wheel
    # want atan(L / (R -+ track/2)); the compromise widens the circle by ~(track / R)^2
    (0.15, 1.55, 0.01), (-0.3, 1.55, 0.03),
])
def test_steered_rolling_car_at_low_speed_follows_the_kinematic_circle(delta, track, tolerance):
    """Kinematic bicycle: no slip at walking pace, rear-axle midpoint on R = L / tan(delta)."""
    vehicle = car(track_width=track)
    lr = float(vehicle.cg_to_rear_axle[0])
    params = RunoutParams(rolling_resistance=0.0, max_time=12.0, path_interval=0.05)
    res = run_out(vehicle, RunoutState.from_arrays(0, 0, 0, 1.0, 0, 0), 0.8, params,
                  wheel_brake=FREE, steer=delta)
    path = res.path[0]
    xr = path[:, 0] - lr * np.cos(path[:, 2])
    yr = path[:, 1] - lr * np.sin(path[:, 2])
    cx, cy, radius = fitted_circle(xr, yr)
    expected = float(vehicle.wheelbase[0]) / math.tan(abs(delta))
    assert abs(radius - expected) <= tolerance * expected
    # the centre lies on the rear axle's line at the start (x = -L2), on the side steered to
    assert abs(cx + lr) <= 0.01 * expected and cy * delta > 0
    # the heading turns with the path: yaw change = arc length / R
    turned = path[-1, 2] - path[0, 2]
    arc = np.sum(np.hypot(np.diff(xr), np.diff(yr)))
    assert abs(turned - math.copysign(arc / expected, delta)) <= tolerance * abs(turned)


@pytest.mark.parametrize("drag", [0.02, 0.1, 0.3])
def test_extra_drag_of_every_wheel_adds_to_the_rolling_resistance(drag):
    speed, f_r = 6.0, 0.015
    params = RunoutParams(rolling_resistance=f_r)
    res = run_out(car(), RunoutState.from_arrays(0, 0, 0, speed, 0, 0), 0.8, params,
                  wheel_brake=FREE, wheel_drag=(drag,) * 4)
    expected = speed**2 / (2.0 * (f_r + drag) * G)
    assert res.at_rest[0]
    assert abs(res.rest_x[0] - expected) <= 0.02 * expected
    assert abs(res.rest_y[0]) < 1e-9


def test_drag_on_one_side_turns_the_car_towards_that_side():
    res = run_out(car(), RunoutState.from_arrays(0, 0, 0, 8.0, 0, 0), 0.8,
                  wheel_brake=FREE, wheel_drag=(0.3, 0.0, 0.3, 0.0))  # left wheels drag
    assert res.rest_yaw[0] > 0.01 and res.rest_y[0] > 0.0


@pytest.mark.parametrize("delta", [0.2, -0.5])
def test_locked_wheels_slide_straight_whatever_the_steer_angle(delta):
    speed, mu = 10.0, 0.8
    res = run_out(car(), RunoutState.from_arrays(0, 0, 0, speed, 0, 0), mu,
                  wheel_brake=LOCKED, steer=delta)
    expected = speed**2 / (2.0 * mu * G)
    assert abs(res.rest_x[0] - expected) <= 0.01 * expected
    assert abs(res.rest_y[0]) < 1e-6 and abs(res.rest_yaw[0]) < 1e-9


def test_plus_and_minus_steer_give_mirror_images():
    state = RunoutState.from_arrays(0, 0, 0, 12.0, 0, 0)
    left = run_out(car(), state, 0.8, steer=0.2)
    right = run_out(car(), state, 0.8, steer=-0.2)
    assert left.rest_y[0] > 0.5
    np.testing.assert_allclose(left.rest_x, right.rest_x, rtol=1e-12)
    np.testing.assert_allclose(left.rest_y, -right.rest_y, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(left.rest_yaw, -right.rest_yaw, rtol=1e-12, atol=1e-12)


def test_before_the_onset_the_car_runs_straight():
    state = RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0)
    params = RunoutParams(path_interval=0.05)
    straight = run_out(car(), state, 0.8, params, wheel_brake=FREE)
    late = run_out(car(), state, 0.8, params, wheel_brake=FREE, steer=0.3, steer_onset=1.0)
    k = int(round(1.0 / 0.05))  # the samples up to the onset
    # the same motion (the steered solver rounds differently), exactly straight
    np.testing.assert_allclose(straight.path[0, :k], late.path[0, :k], rtol=1e-12, atol=1e-12)
    assert (late.path[0, :k, 1:] == 0.0).all()
    assert abs(late.rest_yaw[0]) > 0.5


def test_zero_steer_and_drag_change_nothing_bit_for_bit():
    rng = np.random.default_rng(5)
    n = 6
    vehicles = stack_vehicles([VehicleParams()] * n)
    speed = rng.uniform(2, 15, n)
    course = rng.uniform(-np.pi, np.pi, n)
    s = RunoutState.from_arrays(0, 0, rng.uniform(-3, 3, n), speed * np.cos(course),
                                speed * np.sin(course), rng.uniform(-2, 2, n))
    brake = rng.choice([0.0, 0.5, 1.0], (n, 4))
    a = run_out(vehicles, s, 0.7, wheel_brake=brake)
    b = run_out(vehicles, s, 0.7, wheel_brake=brake, wheel_drag=np.zeros((n, 4)),
                steer=np.zeros(n), steer_onset=np.zeros(n))
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


@settings(max_examples=25, deadline=None)
@given(speed=st.floats(0.0, 20.0), course=st.floats(-np.pi, np.pi),
       yaw_rate=st.floats(-3.0, 3.0), mu=st.floats(0.1, 1.2),
       delta=st.floats(-1.0, 1.0), onset=st.floats(0.0, 1.0), drag=st.floats(0.0, 1.0),
       brake=st.sampled_from([0.0, 0.5, 0.8, 1.0]), load_transfer=st.booleans())
def test_kinetic_energy_never_rises_with_steer_and_drag(speed, course, yaw_rate, mu, delta,
                                                         onset, drag, brake, load_transfer):
    vehicle = car()
    state = RunoutState.from_arrays(0.0, 0.0, 0.3, speed * np.cos(course),
                                    speed * np.sin(course), yaw_rate)
    params = RunoutParams(load_transfer=load_transfer, path_interval=0.005, max_time=4.0)
    res = run_out(vehicle, state, mu, params, wheel_brake=(brake, brake, 0.0, brake),
                  wheel_drag=(drag, 0.0, 0.0, drag / 2), steer=delta, steer_onset=onset)
    energy = res.kinetic_energy[0]
    initial = float(kinetic_energy(vehicle, state)[0])
    rise = np.diff(energy).max(initial=0.0)
    assert rise <= 1e-9 * initial + 1e-9


def test_time_step_convergence_with_steered_wheels():
    """Halving dt moves the rest positions of steered post-crash states less and less."""
    rng = np.random.default_rng(11)
    n = 30
    vehicles = stack_vehicles([VehicleParams()] * n)
    speed = rng.uniform(2, 20, n)
    course = rng.uniform(-np.pi, np.pi, n)
    s = RunoutState.from_arrays(0, 0, rng.uniform(-np.pi, np.pi, n), speed * np.cos(course),
                                speed * np.sin(course), rng.uniform(-3, 3, n))
    kw = dict(wheel_brake=rng.choice([0.0, 0.3, 0.8, 1.0], (n, 4)),
              steer=rng.uniform(-0.6, 0.6, n), steer_onset=rng.uniform(0, 0.5, n),
              wheel_drag=rng.uniform(0, 0.2, (n, 4)))
    runs = [run_out(vehicles, s, 0.8, RunoutParams(dt=dt), **kw)
            for dt in (0.005, 0.0025, 0.00125)]
    assert all(r.at_rest.all() for r in runs)
    change = [np.hypot(a.rest_x - b.rest_x, a.rest_y - b.rest_y)
              for a, b in zip(runs[:-1], runs[1:], strict=True)]
    # a car spinning on steered wheels is sensitive to where the onset falls in a step:
    # at 5 ms within 0.5 % of its path, at 2.5 ms within 5 cm
    assert (change[0] < 0.05 + 0.005 * runs[0].distance).all()
    assert change[1].max() < 0.05


def test_pair_run_out_takes_each_vehicles_wheels():
    v = car()
    s1 = RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0)
    s2 = RunoutState.from_arrays(0, 30, 0, 10.0, 0, 0)
    pair = run_out_pair(v, v, s1, s2, 0.8, steer1=0.2, wheel_drag2=(0.1,) * 4)
    one = run_out(v, s1, 0.8, steer=0.2)
    two = run_out(v, s2, 0.8, wheel_drag=(0.1,) * 4)
    assert pair.rest_x[0, 0] == one.rest_x[0] and pair.rest_yaw[0, 0] == one.rest_yaw[0]
    # vehicle 2 runs in a batch with a steered car and still gets its own result, bit for bit
    assert pair.rest_x[0, 1] == two.rest_x[0] and pair.rest_yaw[0, 1] == two.rest_yaw[0]
    assert pair.rest_x[0, 1] < run_out(v, s2, 0.8).rest_x[0] - 0.5  # its drag stops it early


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"steer": 2.0}, r"steer\[0\]"), ({"steer_onset": -1.0}, "steer_onset"),
    ({"wheel_drag": (0, 0, 0, 1.5)}, "wheel_drag"), ({"wheel_drag": (0.1, 0.1)}, "shape"),
    ({"steer": np.nan}, "steer"),
])
def test_invalid_wheel_inputs_raise(kwargs, match):
    with pytest.raises(ParameterError, match=match):
        run_out(car(), RunoutState.from_arrays(0, 0, 0, 5.0, 0, 0), 0.8, **kwargs)
