"""Run-out tests written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): each bound of the parameters (closed or open
as documented), the wheel geometry and static loads in closed form, the kinetic energy,
the row tables of the memo, and rigid motions of the scene with the pair run-out.
Public behaviour only: closed forms and invariances.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vfs.errors import ParameterError
from vfs.physics.runout import (
    RunoutParams,
    RunoutState,
    distinct_rows,
    kinetic_energy,
    row_table,
    run_out,
    static_wheel_loads,
    wheel_positions,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

pytestmark = pytest.mark.usefixtures("both_runout_paths")


@pytest.mark.parametrize("field, lo, hi, lo_open", [
    ("dt", 0.0, 0.05, True),
    ("rolling_resistance", 0.0, 0.5, False),
    ("cornering_stiffness", 0.0, 100.0, True),
    ("v_stop", 0.0, 1.0, True),
])
def test_parameter_bounds(field: str, lo: float, hi: float, lo_open: bool) -> None:
    extra = {"path_interval": 0.05} if field == "dt" else {}
    assert getattr(RunoutParams(**{field: hi}, **extra), field) == hi
    inside = lo + 0.01 * (hi - lo) if field != "dt" else 0.005
    assert getattr(RunoutParams(**{field: inside}), field) == inside
    if lo_open:
        with pytest.raises(ParameterError, match=field):
            RunoutParams(**{field: lo})
    else:
        assert getattr(RunoutParams(**{field: lo}), field) == lo
    with pytest.raises(ParameterError, match=field):
        RunoutParams(**{field: math.nextafter(hi, math.inf)})
    with pytest.raises(ParameterError, match=field):
        RunoutParams(**{field: math.nextafter(lo, -math.inf)})
    for bad in (math.nan, math.inf, True, "x"):
        with pytest.raises(ParameterError, match=field):
            RunoutParams(**{field: bad})


def test_brake_times_and_intervals() -> None:
    assert RunoutParams(wheel_brake=(0.0, 1.0, 0.5, 1.0)).wheel_brake == (0.0, 1.0, 0.5, 1.0)
    for brake in ((0.8, 0.8, 0.8), "abcd", (0.8, 0.8, 0.8, 1.01), (0.8, -0.01, 0.8, 0.8)):
        with pytest.raises(ParameterError, match="wheel_brake"):
            RunoutParams(wheel_brake=brake)
    with pytest.raises(ParameterError, match="load_transfer"):
        RunoutParams(load_transfer=1)
    # path interval: a whole multiple of dt, at least dt
    p = RunoutParams(dt=0.01, path_interval=0.03, max_time=0.1)
    assert p.steps_per_sample == 3
    assert p.max_steps == 4 * 3  # 0.1 s rounded up to whole 0.03 s intervals: 4
    assert RunoutParams(dt=0.01, path_interval=0.01, max_time=0.1).max_steps == 10
    for interval in (0.025, 0.005):
        with pytest.raises(ParameterError, match="path_interval"):
            RunoutParams(dt=0.01, path_interval=interval)
    with pytest.raises(ParameterError, match="max_time"):
        RunoutParams(dt=0.01, path_interval=0.01, max_time=0.005)
    assert RunoutParams(max_time=3600.0).max_time == 3600.0
    with pytest.raises(ParameterError, match="max_time"):
        RunoutParams(max_time=3600.5)


def vehicles(**over):
    v = VehicleParams(**{**dict(mass=1600.0, length=4.6, width=1.8, wheelbase=2.8,
                                cg_to_front_axle=1.2, front_overhang=0.9, track_width=1.55),
                         **over})
    return stack_vehicles([v])


def test_wheel_geometry_and_static_loads_in_closed_form() -> None:
    v = vehicles()
    pos = wheel_positions(v)[0]
    np.testing.assert_allclose(pos, [[1.2, 0.775], [1.2, -0.775], [-1.6, 0.775],
                                     [-1.6, -0.775]])
    loads = static_wheel_loads(v)[0]
    # N_f = m g L2 / (2 L), N_r = m g L1 / (2 L); they carry the weight, moments balance
    np.testing.assert_allclose(loads, [1600 * G * 1.6 / 5.6] * 2 + [1600 * G * 1.2 / 5.6] * 2)
    assert loads.sum() == pytest.approx(1600 * G)
    assert (loads * pos[:, 0]).sum() == pytest.approx(0.0, abs=1e-9)
    state = RunoutState.from_arrays(1.0, 2.0, 0.3, 3.0, -4.0, 0.5)
    assert kinetic_energy(v, state)[0] == pytest.approx(
        0.5 * 1600 * 25.0 + 0.5 * v.yaw_inertia[0] * 0.25)


def test_row_tables_keep_the_first_order() -> None:
    t = row_table(np.array([3.0, 1.0, 3.0, 2.0, 1.0]), np.array([[0, 1], [0, 0], [0, 1],
                                                               [5, 5], [0, 0]]))
    assert t.shape == (5, 3) and t.flags["C_CONTIGUOUS"] and t.dtype == np.float64
    first, inverse = distinct_rows(t)
    np.testing.assert_array_equal(first, [0, 1, 3])
    np.testing.assert_array_equal(inverse, [0, 1, 0, 2, 1])
    np.testing.assert_array_equal(t[first][inverse], t)
    # -0.0 and 0.0 are different bits: different rows
    first, _ = distinct_rows(row_table(np.array([0.0, -0.0])))
    assert first.tolist() == [0, 1]
    assert row_table(np.zeros(0)).shape == (0, 1)


@pytest.mark.parametrize("angle, dx, dy", [(1.1, 40.0, -7.0), (-2.6, -300.0, 12.0)])
def test_braked_rolling_run_out_turns_with_the_scene(angle: float, dx: float, dy: float) -> None:
    """A spinning, sliding vehicle with rolling braked wheels: rest pose turns and shifts
    with the initial state; distance, time and energy do not change."""
    v = vehicles()
    heading, course, speed, rate = 0.4, 1.0, 14.0, 1.2
    state = RunoutState.from_arrays(2.0, -1.0, heading, speed * np.cos(course),
                                    speed * np.sin(course), rate)
    res = run_out(v, state, 0.8)
    c, s = np.cos(angle), np.sin(angle)
    turned = RunoutState.from_arrays(c * 2.0 + s * 1.0 + dx, s * 2.0 - c * 1.0 + dy,
                                     heading + angle, speed * np.cos(course + angle),
                                     speed * np.sin(course + angle), rate)
    other = run_out(v, turned, 0.8)
    assert res.at_rest[0] and other.at_rest[0]
    np.testing.assert_allclose(other.rest_x[0], c * res.rest_x[0] - s * res.rest_y[0] + dx,
                               atol=1e-6)
    np.testing.assert_allclose(other.rest_y[0], s * res.rest_x[0] + c * res.rest_y[0] + dy,
                               atol=1e-6)
    assert other.rest_yaw[0] == pytest.approx(res.rest_yaw[0] + angle, abs=1e-7)
    assert other.distance[0] == pytest.approx(res.distance[0], rel=1e-9)
    assert other.time_to_rest[0] == pytest.approx(res.time_to_rest[0], abs=1e-9)
    # friction stops it: ends well short of the locked-wheel slide of v^2 / (2 mu g)? no -
    # braked rolling wheels (0.8 mu) slide farther than locked ones, never less
    locked = run_out(v, state, 0.8, wheel_brake=(1.0, 1.0, 1.0, 1.0))
    assert res.distance[0] > locked.distance[0]
    assert locked.distance[0] == pytest.approx(speed**2 / (2 * 0.8 * G), rel=0.15)
