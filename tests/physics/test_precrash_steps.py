"""The step loop of the pre-crash run (:class:`vfs.physics.precrash.PrecrashRun`) in closed
form: braking into a standing car (contact and impact states between the steps), the speed
profile under a known deceleration, the closest approach of a pass that is nearest away
from the moment of the smallest CG distance, instant impacts, and the open-ended run's
``start`` and ``stop``.  Every braking test runs on both paths, the numpy reference
(``VFS_COMPILED=0``) and the compiled step (:mod:`vfs.physics.core`).

The step-deceleration model: a demand ``a`` seen at time ``t_b`` (on the step grid) with a
step build-up (jerk 1e6 m/s^3) is delivered from the next step on; over the first step the
actuator output is averaged, so the deceleration ramps linearly from 0 to ``a`` over
``[t_b, t_b + dt]`` and the speed taken off is ``dv(t) = a (t - t_b - dt / 2)`` from
``t_b + dt`` on, exactly; the arc length lost, integrated by the trapezoidal rule (exact for
a linear dv), is ``ds(t) = a (t - t_b - dt / 2)^2 / 2 + a dt^2 / 8`` on the steps.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.errors import ParameterError
from vfs.physics.paths import pack_paths
from vfs.physics.precrash import (
    BrakeActuatorParams,
    PrecrashParams,
    PrecrashRun,
    ScheduledBraking,
    SegmentedRandom,
    simulate_precrash,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles

CAR = VehicleParams(mass=1500.0, length=4.5, width=1.8, wheelbase=2.7, cg_to_front_axle=1.2,
                    front_overhang=0.9)  # CG 2.1 m behind the front bumper, 2.4 m before the rear
DT = 0.01
STEP = BrakeActuatorParams(jerk=1e6)  # the demand delivered within one step


@pytest.fixture(params=["0", "1"], ids=["numpy", "compiled"])
def path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Both implementations of the step: the numpy reference and the compiled core."""
    monkeypatch.setenv("VFS_COMPILED", request.param)
    return request.param


def line(x0: float, y0: float, yaw: float, v: float, duration: float = 6.0):
    """A straight record: start (x0, y0) [m], heading yaw [rad], speed v [m/s]."""
    t = np.arange(0.0, duration + 1e-9, DT)
    return (t, x0 + v * np.cos(yaw) * t, y0 + v * np.sin(yaw) * t, np.full(t.size, yaw),
            np.full(t.size, v))


def moved(rec, angle: float, dx: float, dy: float):
    """A record turned by ``angle`` [rad] about the origin, then shifted by (dx, dy) [m]."""
    t, x, y, yaw, v = rec
    c, s = np.cos(angle), np.sin(angle)
    return t, c * x - s * y + dx, s * x + c * y + dy, yaw + angle, v


def pack(records):
    parts = [np.concatenate(c) for c in zip(*records, strict=True)]
    group = np.concatenate([np.full(len(r[0]), i) for i, r in enumerate(records)])
    return pack_paths(*parts, group=group)


def inputs(cases, vehicle2: VehicleParams = CAR):
    """Vehicles and paths of ``cases`` (pairs of records)."""
    n = len(cases)
    paths = pack([c[0] for c in cases] + [c[1] for c in cases])
    return stack_vehicles([CAR] * n), stack_vehicles([vehicle2] * n), paths


def run(cases, controller=None, **kw):
    v1, v2, paths = inputs(cases)
    return simulate_precrash(v1, v2, paths, np.full(len(cases), 0.8), controller=controller,
                             **kw)


# braking into a standing car: v0 [m/s], demand a [m/s^2] from t_b [s], front-to-rear gap D [m]
V0, A, T_B, GAP = 20.0, 6.0, 0.5, 35.0


def travelled(t: np.ndarray | float) -> np.ndarray:
    """Arc length [m] of the braking car at time t >= t_b + dt (closed form, module doc)."""
    u = np.asarray(t) - T_B - DT / 2
    return V0 * np.asarray(t) - 0.5 * A * u**2 - A * DT**2 / 8


def rear_end(angle: float = 0.0, dx: float = 0.0, dy: float = 0.0, swap: bool = False):
    """The braking car behind a standing one (turned and shifted), and its controller."""
    case = (moved(line(0.0, 0.0, 0.0, V0), angle, dx, dy),
            moved(line(GAP + 2.1 + 2.4, 0.0, 0.0, 0.0), angle, dx, dy))
    start = [[T_B, np.nan]]
    if swap:
        case, start = case[::-1], [[np.nan, T_B]]
    return [case], ScheduledBraking(start, [[A, A]])


def test_braking_into_a_standing_car_in_closed_form(path: str) -> None:
    cases, ctl = rear_end()
    res = run(cases, ctl, params=PrecrashParams(brake=STEP))
    assert res.collided[0] and res.brake_start[0, 0] == pytest.approx(T_B)
    assert np.isnan(res.brake_start[0, 1])
    # contact: front (CG + 2.1 m) at the rear of the standing car, travelled(t_c) = GAP;
    # the root of a quadratic, u = t - t_b - dt/2
    c = V0 * (T_B + DT / 2) - A * DT**2 / 8 - GAP
    u = (V0 - np.sqrt(V0**2 + 2.0 * A * c)) / A
    t_c = u + T_B + DT / 2
    assert res.contact_time[0] == pytest.approx(t_c, abs=1e-4)
    # between the steps dv is interpolated linearly: exact for the linear dv
    t_c, t_i = res.contact_time[0], res.impact_time[0]
    assert t_i - t_c == pytest.approx(0.030, abs=1e-12)
    assert res.contact_state.speed[0, 0] == pytest.approx(V0 - A * (t_c - T_B - DT / 2),
                                                          abs=1e-9)
    assert res.impact_state.speed[0, 0] == pytest.approx(V0 - A * (t_i - T_B - DT / 2),
                                                         abs=1e-9)
    assert res.impact_state.speed[0, 1] == 0.0
    # positions: ds interpolated linearly between the steps (error <= a dt^2 / 8)
    assert res.contact_state.x[0, 0] == pytest.approx(travelled(t_c), abs=2e-4)
    assert res.impact_state.x[0, 0] == pytest.approx(travelled(t_i), abs=2e-4)
    assert res.speed_reduction[0, 0] == pytest.approx(A * (t_i - T_B - DT / 2), abs=1e-9)
    assert res.speed_reduction[0, 1] == 0.0
    assert res.min_distance[0] == 0.0 and res.time_closest[0] == res.contact_time[0]


def test_turning_shifting_and_swapping_a_braking_scene(path: str) -> None:
    cases, ctl = rear_end()
    base = run(cases, ctl, params=PrecrashParams(brake=STEP))
    angle = 2.3
    for kw in ({"angle": angle, "dx": -40.0, "dy": 300.0}, {"swap": True}):
        cases, ctl = rear_end(**kw)
        other = run(cases, ctl, params=PrecrashParams(brake=STEP))
        cols = slice(None, None, -1) if kw.get("swap") else slice(None)
        for name in ("contact_time", "impact_time", "overlap_area"):
            np.testing.assert_allclose(getattr(other, name), getattr(base, name), atol=1e-6)
        np.testing.assert_allclose(other.impact_state.speed[:, cols], base.impact_state.speed,
                                   atol=1e-9)
        np.testing.assert_allclose(other.speed_reduction[:, cols], base.speed_reduction,
                                   atol=1e-9)
        np.testing.assert_allclose(other.brake_start[:, cols], base.brake_start)
    # the turned scene: positions turned, then shifted
    c, s = np.cos(angle), np.sin(angle)
    bt = base.impact_state
    cases, ctl = rear_end(angle, -40.0, 300.0)
    turned = run(cases, ctl, params=PrecrashParams(brake=STEP)).impact_state
    np.testing.assert_allclose(turned.x, c * bt.x - s * bt.y - 40.0, atol=1e-6)
    np.testing.assert_allclose(turned.y, s * bt.x + c * bt.y + 300.0, atol=1e-6)
    np.testing.assert_allclose(turned.vx, c * bt.vx - s * bt.vy, atol=1e-9)


class Recorder:
    """Scheduled braking that keeps what the controller saw: time, speed, deceleration."""

    def __init__(self, inner: ScheduledBraking) -> None:
        self.inner, self.seen = inner, []

    def reset(self, n: int, rng: np.random.Generator) -> None:
        self.inner.reset(n, rng)

    def demand(self, obs):  # noqa: ANN001, ANN201
        self.seen.append((float(obs.t), obs.speed[0, 0], obs.deceleration[0, 0],
                          obs.accel[0, 0]))
        return self.inner.demand(obs)


def test_speed_profile_under_a_known_deceleration(path: str) -> None:
    far = line(5000.0, 0.0, 0.0, 0.0)
    ctl = Recorder(ScheduledBraking([[T_B, np.nan]], [[A, 0.0]]))
    res = run([(line(0.0, 0.0, 0.0, V0), far)], ctl, params=PrecrashParams(brake=STEP))
    t, speed, decel, accel = (np.array(c) for c in zip(*ctl.seen, strict=True))
    before = t <= T_B + 1e-9
    np.testing.assert_array_equal(speed[before], V0)
    np.testing.assert_array_equal(decel[before], 0.0)
    stop = T_B + DT / 2 + V0 / A
    braking = (t >= T_B + DT - 1e-9) & (t < stop - DT)
    np.testing.assert_allclose(speed[braking], V0 - A * (t[braking] - T_B - DT / 2),
                               atol=1e-9)
    np.testing.assert_allclose(decel[braking], A)
    np.testing.assert_allclose(accel[braking], -A)
    np.testing.assert_array_equal(speed[t > stop], 0.0)  # stopped, never backwards
    # the stop: v0^2 / (2 a) from the middle of the build-up step, plus dt^2 a / 8 less
    assert res.end_state.x[0, 0] == pytest.approx(
        V0 * (T_B + DT / 2) + V0**2 / (2 * A) - A * DT**2 / 8, abs=2e-3)


def test_closest_approach_away_from_the_smallest_cg_distance(path: str) -> None:
    """A long car standing at 10 deg with its CG 2 m behind its front: a car passing on a
    parallel lane comes nearest to its far rear corner, 5.7 m before the CG distance is
    smallest, and the distance there is smaller by 0.94 m."""
    long_car = VehicleParams(mass=9000.0, length=10.0, width=1.8, wheelbase=6.0,
                             cg_to_front_axle=1.0, front_overhang=1.0)
    yaw, lateral = np.radians(10.0), 3.5
    cases = [(line(0.0, 0.0, 0.0, 10.0), line(40.0, lateral, yaw, 0.0))]
    v1, v2, paths = inputs(cases, long_car)
    res = simulate_precrash(v1, v2, paths, [0.8],
                            controller=ScheduledBraking([[np.nan, np.nan]], [[0.0, 0.0]]))
    assert not res.collided[0]
    corner_y = lateral - 8.0 * np.sin(yaw) - 0.9 * np.cos(yaw)  # rear right corner
    assert res.min_distance[0] == pytest.approx(corner_y - 0.9, abs=1e-9)
    # first reached when the front of the passing car (CG + 2.1 m) is below the corner
    corner_x = 40.0 - 8.0 * np.cos(yaw) + 0.9 * np.sin(yaw)
    assert res.time_closest[0] == pytest.approx((corner_x - 2.1) / 10.0, abs=DT + 1e-9)


def test_instant_impact_from_a_penetration_rule(path: str) -> None:
    cases, ctl = rear_end()
    seen = []

    def zero(rows: np.ndarray, state) -> np.ndarray:  # noqa: ANN001
        seen.append(rows.copy())
        return np.zeros(rows.shape[0])

    res = run(cases, ctl, params=PrecrashParams(brake=STEP), penetration=zero)
    assert [r.tolist() for r in seen] == [[0]]
    assert res.impact_time[0] == res.contact_time[0]
    # the speed taken off at the contact itself (dv linear in time, module doc)
    assert res.speed_reduction[0, 0] == pytest.approx(A * (res.contact_time[0] - T_B - DT / 2),
                                                      abs=1e-9)
    for a, b in zip(res.impact_state, res.contact_state, strict=True):
        np.testing.assert_array_equal(a, b)
    res0 = run(cases, ctl, params=PrecrashParams(brake=STEP, penetration_time=0.0))
    for a, b in zip(res0.impact_state, res.impact_state, strict=True):
        np.testing.assert_array_equal(a, b)
    # the bounds of the rule's times are closed: 0.5 s runs, beyond raises
    late = run(cases, ctl, params=PrecrashParams(brake=STEP),
               penetration=lambda rows, st: np.full(rows.shape[0], 0.5))
    assert late.impact_time[0] - late.contact_time[0] == pytest.approx(0.5)
    for bad in (-1e-9, 0.5001):
        with pytest.raises(ParameterError, match="penetration times"):
            run(cases, ctl, params=PrecrashParams(brake=STEP),
                penetration=lambda rows, st, b=bad: np.full(rows.shape[0], b))
    with pytest.raises(ParameterError, match="penetration times"):
        run(cases, ctl, params=PrecrashParams(brake=STEP),
            penetration=lambda rows, st: np.zeros(rows.shape[0] + 1))


def two_cases():
    """Case 0 hits after about 1.2 s, case 1 never (5 s records, 3 s extra time)."""
    cases = [(line(0.0, 0.0, 0.0, 20.0, 5.0), line(28.5, 0.0, 0.0, 0.0, 5.0)),
             (line(0.0, 0.0, 0.0, 10.0, 5.0), line(0.0, 50.0, 0.0, 10.0, 5.0))]
    v1, v2, paths = inputs(cases)
    return v1, v2, paths, np.full(2, 0.8)


def test_start_and_stop_of_an_open_ended_run(path: str) -> None:
    args = two_cases()
    ref = simulate_precrash(*args)
    assert ref.collided.tolist() == [True, False]
    with pytest.raises(ParameterError, match="open-ended"):
        PrecrashRun(*args, start=[1]).start([0])
    run = PrecrashRun(*args, open_ended=True)
    assert run.running.tolist() == [True, True]
    while 0 not in run.finished:
        run.advance()
    assert run.running.tolist() == [False, True]
    first = run.result([0])
    assert first.contact_time[0] == ref.contact_time[0]
    k_end = run.k
    run.start([0])  # a same-step restart: case 0 from its own time 0, case 1 goes on
    assert run.running.tolist() == [True, True] and run.finished.tolist() == [0]
    assert run.local_time(np.array([0, 1])).tolist() == [0.0, k_end * DT]
    with pytest.raises(ParameterError, match="not running"):
        run.start([1])
    assert run.rows.tolist() == [1, 0]  # the refused start left the run as it was
    run.advance()
    while 0 not in run.finished:
        run.advance()
    again = run.result([0])
    for name in ("contact_time", "impact_time", "poi", "cp_angle", "overlap_area"):
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name), name)
    # stop case 1 without its state (an abandoned episode): it can start again
    run.stop([1])
    assert not run.running.any() and run.rows.size == 0
    run.start([1])
    assert run.running.tolist() == [False, True]
    # stopped with its state: ended as at its horizon, at the pose of the stop
    for _ in range(100):
        run.advance()
    x_now = run.state.x[0, 0]
    run.stop([1], keep_state=True)
    res = run.result([1])
    assert not res.collided[0] and res.end_state.x[0, 0] == x_now == 10.0 * 100 * DT
    assert res.min_distance[0] == pytest.approx(50.0 - 1.8)
    with pytest.raises(ParameterError, match="not running"):
        run.stop([1])


def test_a_run_that_has_ended_takes_no_step(path: str) -> None:
    run = PrecrashRun(*two_cases())
    while not run.done:
        run.advance()
    assert run.time == pytest.approx(8.0) and not run.running.any()
    with pytest.raises(ParameterError, match="ended"):
        run.advance()


def test_segments_of_one_case() -> None:
    g = [np.random.default_rng(1), np.random.default_rng(2)]
    assert SegmentedRandom.of([1, 1], g).sizes == (1, 1)


@pytest.mark.parametrize("v0, a", [(20.0, 6.0), (5.0, 7.5)])
def test_a_stop_takes_off_exactly_the_speed(path: str, v0: float, a: float) -> None:
    """A braked car that stops has had its recorded speed v0 taken off, no more: the
    reduction is v_rec - v, whatever the deceleration integrated after the stop."""
    far = line(5000.0, 0.0, 0.0, 0.0)
    ctl = ScheduledBraking([[T_B, np.nan]], [[a, 0.0]])
    res = run([(line(0.0, 0.0, 0.0, v0), far)], ctl, params=PrecrashParams(brake=STEP))
    assert not res.collided[0] and res.end_state.speed[0, 0] == 0.0
    assert res.speed_reduction[0].tolist() == [v0, 0.0]
    # into a standing car: stopped before the impact of a car pushed into it later
    stopped = (line(0.0, 0.0, 0.0, v0), line(v0**2 / (2 * a) + v0 * T_B + 5.0, 0.0, 0.0, 0.0))
    pusher = line(-60.0, 0.0, 0.0, 25.0, 8.0)  # hits the stopped car from behind
    res = run([(stopped[0], pusher)], ScheduledBraking([[T_B, np.nan]], [[a, 0.0]]),
              params=PrecrashParams(brake=STEP))
    assert res.collided[0] and res.impact_state.speed[0, 0] == 0.0
    assert res.speed_reduction[0].tolist() == [v0, 0.0]
    res = run([(stopped[0], pusher)], ScheduledBraking([[T_B, np.nan]], [[a, 0.0]]),
              params=PrecrashParams(brake=STEP, penetration_time=0.0))
    assert res.collided[0] and res.speed_reduction[0].tolist() == [v0, 0.0]


def test_first_steps_below_zero_are_refused() -> None:
    args = two_cases()
    for steps in ([0, -1], [-1, 0], -1):
        with pytest.raises(ParameterError, match="first_step"):
            simulate_precrash(*args, first_step=steps)
    assert simulate_precrash(*args, first_step=[0, 3]).collided.tolist() == [True, False]


def test_a_shorter_case_ends_at_its_own_horizon_in_a_batch(path: str) -> None:
    """Records of 5 s and 7 s (3 s extra time): the first case ends at 8 s, batched or alone,
    where a car at constant speed keeps going past the end of its record."""
    def case(duration: float):
        return (line(0.0, 0.0, 0.0, 10.0, duration), line(0.0, 100.0, 0.0, 0.0, duration))

    ctl = ScheduledBraking([[np.nan, np.nan]] * 2, [[0.0, 0.0]] * 2)
    both = run([case(5.0), case(7.0)], ctl)
    alone = run([case(5.0)], ScheduledBraking([[np.nan, np.nan]], [[0.0, 0.0]]))
    assert both.end_state.x[0, 0] == alone.end_state.x[0, 0]
    assert both.end_state.x[:, 0].tolist() == pytest.approx([80.0, 100.0], abs=1e-9)


def test_case_instances_within_the_cases_only() -> None:
    args = two_cases()
    res = simulate_precrash(*args, case_of=[1, 0, 0])
    assert res.collided.tolist() == [False, True, True]
    for bad in ([0, 2], [-1, 1]):
        with pytest.raises(ParameterError, match="case_of"):
            simulate_precrash(*args, case_of=bad)


@pytest.mark.parametrize("lateral", [3.5, 20.0], ids=["within-close-range", "beyond"])
def test_a_constant_distance_is_nearest_at_its_first_step(path: str, lateral: float) -> None:
    """Two cars side by side on parallel lanes at the same speed keep one distance, the gap
    between the lanes less the width (the CG distance exactly constant: equal arc lengths
    on equal records): the closest approach is the first time of the smallest distance,
    the start, both where the outlines are measured each step (within CLOSE_RANGE) and
    where the pose of the smallest CG distance is kept and measured at the end."""
    cases = [(line(0.0, 0.0, 0.0, 10.0), line(0.0, lateral, 0.0, 10.0))]
    res = run(cases, ScheduledBraking([[np.nan, np.nan]], [[0.0, 0.0]]))
    assert not res.collided[0]
    assert res.min_distance[0] == pytest.approx(lateral - 1.8, abs=1e-9)
    assert res.time_closest[0] == 0.0


def test_a_grazing_contact_holds_the_reductions_of_its_first_contact(path: str) -> None:
    """The braking car's front left corner is clipped by the rear of a car crossing at
    20 m/s, whose rear is 0.6 m over the braking car's left side when the front reaches it:
    the outlines part again within the penetration time (0.2 s), so the impact is taken at
    the largest overlap in between, with the speed and arc length taken off held at their
    values at first contact (precrash_contact.largest_overlap): the braking car's speed at
    the impact is that at the contact, and it has moved on at its recorded speed."""
    x2, u = 40.0, 20.0
    # contact when the front (CG + 2.1 m) reaches the crossing car's right side (x2 - 0.9):
    # travelled(t_c) = x2 - 3.0, the root of the quadratic of the closed form
    c = V0 * (T_B + DT / 2) - A * DT**2 / 8 - (x2 - 3.0)
    t_c = (V0 - np.sqrt(V0**2 + 2.0 * A * c)) / A + T_B + DT / 2
    y2 = 0.9 - 0.6 + 2.4 - u * t_c  # its rear (CG - 2.4 m) 0.6 m over y = 0.9 then
    cases = [(line(0.0, 0.0, 0.0, V0), line(x2, y2, np.pi / 2, u))]
    res = run(cases, ScheduledBraking([[T_B, np.nan]], [[A, A]]),
              params=PrecrashParams(brake=STEP, penetration_time=0.2))
    assert res.collided[0]
    assert res.contact_time[0] == pytest.approx(t_c, abs=1e-4)
    t_c, t_i = res.contact_time[0], res.impact_time[0]
    assert t_c < t_i < t_c + 0.2 - DT  # moved to the largest overlap: a graze
    v_c = V0 - A * (t_c - T_B - DT / 2)
    assert res.contact_state.speed[0, 0] == pytest.approx(v_c, abs=1e-9)
    assert res.impact_state.speed[0, 0] == pytest.approx(v_c, abs=1e-9)
    ds_c = V0 * t_c - travelled(t_c)  # taken off the record's arc length at the contact
    assert res.impact_state.x[0, 0] == pytest.approx(V0 * t_i - ds_c, abs=2e-4)
    assert res.impact_state.x[0, 1] == pytest.approx(x2, abs=1e-9)
    assert res.impact_state.y[0, 1] == pytest.approx(y2 + u * t_i, abs=1e-9)
