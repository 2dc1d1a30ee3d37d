"""Pre-crash re-simulation: exact replay, braking in closed form, contact detection."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.errors import ParameterError
from vfs.physics.geometry import outline_corners, outline_distance
from vfs.physics.paths import concat_paths, pack_paths
from vfs.physics.precrash import (
    UNUSED_VEHICLE_FIELDS,
    BrakeActuatorParams,
    PrecrashParams,
    ScheduledBraking,
    friction_limited_deceleration,
    simulate_precrash,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

CAR = VehicleParams(mass=1500.0, length=4.5, width=1.8, wheelbase=2.7, cg_to_front_axle=1.2,
                    front_overhang=0.9)  # CG 2.1 m behind the front bumper


def record(x, y, yaw, speed, dt=0.01):
    """Samples of one path as arrays."""
    t = np.arange(len(x)) * dt
    return t, np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float), \
        np.asarray(speed, float)


def pack(records):
    """Pack a list of (t, x, y, yaw, speed) records (participant 1s then 2s)."""
    parts = [np.concatenate(c) for c in zip(*records, strict=True)]
    group = np.concatenate([np.full(len(r[0]), i) for i, r in enumerate(records)])
    return pack_paths(*parts, group=group)


def straight(x0, v, yaw, duration=5.0, y0=0.0, dt=0.01):
    t = np.arange(0.0, duration + 1e-9, dt)
    return record(x0 + v * np.cos(yaw) * t, y0 + v * np.sin(yaw) * t, np.full(t.size, yaw),
                  np.full(t.size, v), dt)


def cars(n):
    return stack_vehicles([CAR] * n), stack_vehicles([CAR] * n)


def test_head_on_contact_time_and_impact_configuration():
    # fronts start 100 m apart (CGs 104.2 m), closing at 30 m/s: contact at 100/30 s
    paths = pack([straight(0.0, 20.0, 0.0), straight(104.2, 10.0, np.pi)])
    v1, v2 = cars(1)
    res = simulate_precrash(v1, v2, paths, [0.8])
    assert res.collided[0]
    assert res.contact_time[0] == pytest.approx(100.0 / 30.0, abs=1e-3)
    assert res.impact_time[0] - res.contact_time[0] == pytest.approx(0.030)
    # 30 ms of penetration at 30 m/s closing speed: 0.9 m overlap of the full width
    assert res.overlap_area[0] == pytest.approx(0.9 * 1.8, rel=0.02)
    assert res.impact_state.vx[0, 0] == pytest.approx(20.0)
    assert res.impact_state.vx[0, 1] == pytest.approx(-10.0)
    np.testing.assert_allclose(res.poi[0], [20.0 * res.impact_time[0] + 2.1 - 0.45, 0.0],
                               atol=0.02)


def test_replay_reproduces_curved_record_within_1cm():
    # vehicle 1 on a circle of radius 60 m with varying speed; the replay at
    # the record's own times must give back the recorded positions
    dt = 0.01
    t = np.arange(0.0, 5.0 + 1e-9, dt)
    speed = 15.0 + 2.0 * np.sin(t)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    ang = s / 60.0
    rec1 = record(60.0 * np.sin(ang), 60.0 * (1 - np.cos(ang)), ang, speed, dt)
    # vehicle 2 parked far away: no contact, the horizon covers the record
    rec2 = record(np.full(t.size, 500.0), np.full(t.size, 500.0), np.zeros(t.size),
                  np.zeros(t.size), dt)
    paths = pack([rec1, rec2])
    v1, v2 = cars(1)
    res = simulate_precrash(v1, v2, paths, [0.8], params=PrecrashParams(extra_time=0.0))
    assert not res.collided[0]
    # the horizon ends at the record's end, where the replay is the last sample
    assert res.end_state.x[0, 0] == pytest.approx(rec1[1][-1], abs=0.01)
    assert res.end_state.y[0, 0] == pytest.approx(rec1[2][-1], abs=0.01)
    # exact replay at intermediate times: compare with the kinematics look-up
    from vfs.physics.precrash_contact import kinematics_at

    for tau in (0.0, 1.234, 2.5, 4.99):
        st = kinematics_at(paths, np.array([0]), tau, np.zeros((1, 2)), np.zeros((1, 2)))
        x_rec = np.interp(tau, rec1[0], rec1[1])
        y_rec = np.interp(tau, rec1[0], rec1[2])
        assert abs(st.x[0, 0] - x_rec) < 0.01 and abs(st.y[0, 0] - y_rec) < 0.01
        assert st.speed[0, 0] == pytest.approx(np.interp(tau, rec1[0], rec1[4]), abs=1e-9)
        # yaw rate = curvature x speed = v / R
        assert st.yaw_rate[0, 0] == pytest.approx(st.speed[0, 0] / 60.0, rel=1e-3)


def braking_distance(v0: float, decel: float, jerk: float) -> float:
    """Closed form: linear build-up to ``decel`` at ``jerk``, then constant deceleration."""
    t_r = decel / jerk
    if v0 <= 0.5 * decel * t_r:  # stops during the build-up
        t_stop = np.sqrt(2 * v0 / jerk)
        return v0 * t_stop - jerk * t_stop**3 / 6
    v1 = v0 - 0.5 * decel * t_r
    return v0 * t_r - jerk * t_r**3 / 6 + v1**2 / (2 * decel)


@pytest.mark.parametrize("v0,mu,jerk", [(20.0, 0.8, 40.0), (30.0, 0.5, 25.0),
                                        (8.0, 1.0, 60.0), (1.0, 0.8, 10.0)])
def test_straight_full_braking_stops_at_closed_form_distance(v0, mu, jerk):
    paths = pack([straight(0.0, v0, 0.0, duration=8.0), straight(2000.0, 0.0, 0.0, 8.0)])
    v1, v2 = cars(1)
    t_b = 1.0
    ctl = ScheduledBraking([[t_b, np.nan]], [[50.0, 0.0]])  # demand above the road limit
    params = PrecrashParams(brake=BrakeActuatorParams(jerk=jerk, max_deceleration=20.0))
    res = simulate_precrash(v1, v2, paths, [mu], controller=ctl, params=params)
    assert not res.collided[0]
    assert res.end_state.speed[0, 0] == 0.0  # never below standstill, stays stopped
    travelled = res.end_state.x[0, 0] - v0 * t_b
    expected = braking_distance(v0, mu * G, jerk)
    assert travelled == pytest.approx(expected, rel=0.01)
    assert res.brake_start[0, 0] == pytest.approx(t_b)


def test_first_order_actuator_and_latency_ordering():
    paths = pack([straight(0.0, 20.0, 0.0, 8.0), straight(2000.0, 0.0, 0.0, 8.0)])
    v1, v2 = cars(1)
    ctl = ScheduledBraking([[1.0, np.nan]], [[8.0, 0.0]])
    ends = {}
    for name, brake in (("step", BrakeActuatorParams(jerk=1e6)),
                        ("jerk", BrakeActuatorParams(jerk=20.0)),
                        ("first_order", BrakeActuatorParams(model="first_order",
                                                            time_constant=0.3))):
        res = simulate_precrash(v1, v2, paths, [1.0], controller=ctl,
                                params=PrecrashParams(brake=brake))
        ends[name] = res.end_state.x[0, 0]
    # build-up costs distance: a slower build-up stops farther
    assert ends["step"] < ends["jerk"] and ends["step"] < ends["first_order"]
    assert ends["step"] - 20.0 == pytest.approx(20.0**2 / 16.0, rel=0.01)
    # first order d = a (1 - exp(-t / tau)): x(t) = v0 t - a t^2 / 2 + a tau t
    # - a tau^2 (1 - exp(-t / tau)); at the stop (exp ~ 0) this is v0 tau - a tau^2 / 2
    # farther than the step response: 20 * 0.3 - 8 * 0.09 / 2 = 5.64 m
    assert ends["first_order"] - ends["step"] == pytest.approx(20.0 * 0.3 - 8.0 * 0.09 / 2,
                                                               rel=0.03)


def test_braking_avoids_and_reports_closest_approach():
    # vehicle 2 stands still 40 m ahead; vehicle 1 brakes hard at t = 0.5 s
    paths = pack([straight(0.0, 15.0, 0.0, 5.0), straight(44.2, 0.0, 0.0, 5.0)])
    v1, v2 = cars(1)
    ctl = ScheduledBraking([[0.5, np.nan]], [[9.0, 0.0]])
    res = simulate_precrash(v1, v2, paths, [0.9], controller=ctl)
    assert not res.collided[0]
    stop = 0.5 * 15.0 + braking_distance(15.0, 0.9 * G, 40.0)
    gap = 44.2 - 2.4 - 2.1  # front of 1 (CG + 2.1) to rear of 2 (CG - 2.4)
    assert res.min_distance[0] == pytest.approx(gap - stop, abs=0.05)
    # without braking it hits at t = (gap / 15)
    res0 = simulate_precrash(v1, v2, paths, [0.9])
    assert res0.collided[0] and res0.contact_time[0] == pytest.approx(gap / 15.0, abs=1e-3)


def test_batch_equals_single():
    rng = np.random.default_rng(3)
    records1, records2, starts = [], [], []
    for _ in range(6):
        v_a, v_b = rng.uniform(8, 25, 2)
        off = rng.uniform(-1.5, 1.5)
        records1.append(straight(0.0, v_a, 0.0))
        records2.append(straight(4.2 + 4.0 * (v_a + v_b), v_b, np.pi, y0=off))
        starts.append(rng.uniform(2.5, 4.5))
    paths = pack(records1 + records2)
    v1, v2 = cars(6)
    dec = np.c_[np.full(6, 9.0), np.zeros(6)]
    st = np.c_[starts, np.full(6, np.nan)]
    batch = simulate_precrash(v1, v2, paths, np.full(6, 0.8),
                              controller=ScheduledBraking(st, dec))
    for k in range(6):
        one = simulate_precrash(v1.take([k]), v2.take([k]),
                                concat_paths(paths.take([k]), paths.take([k + 6])), [0.8],
                                controller=ScheduledBraking(st[k:k + 1], dec[k:k + 1]))
        for a, b in ((one.contact_time, batch.contact_time[k:k + 1]),
                     (one.impact_state.x, batch.impact_state.x[k:k + 1]),
                     (one.min_distance, batch.min_distance[k:k + 1]),
                     (one.poi, batch.poi[k:k + 1])):
            np.testing.assert_array_equal(a, b)


def head_on_pairs(rng: np.random.Generator, n: int = 5):
    """n head-on pairs at 8-25 m/s meeting 4 s after their start (lateral offsets up to
    1.5 m): their paths and vehicles."""
    recs1, recs2 = [], []
    for _ in range(n):
        v_a, v_b = rng.uniform(8, 25, 2)
        recs1.append(straight(0.0, v_a, 0.0))
        recs2.append(straight(4.2 + 4.0 * (v_a + v_b), v_b, np.pi, y0=rng.uniform(-1.5, 1.5)))
    v1, v2 = cars(n)
    return pack(recs1 + recs2), v1, v2


def test_vehicle_data_the_precrash_ignores_leave_it_bit_for_bit():
    # the fields of UNUSED_VEHICLE_FIELDS scaled: the pre-crash phase (replayed and braked,
    # the penetration included) is the same to the last bit; the length, which it reads,
    # is the control
    rng = np.random.default_rng(11)
    paths, v1, v2 = head_on_pairs(rng)
    ctl = ScheduledBraking(np.c_[rng.uniform(2.5, 4.0, 5), np.full(5, np.nan)],
                           np.c_[np.full(5, 8.0), np.zeros(5)])
    base = simulate_precrash(v1, v2, paths, np.full(5, 0.8), controller=ctl)
    assert base.collided.any()

    def scaled(v, fields, k):
        return v._replace(**{f: getattr(v, f) * k for f in fields})

    changed = simulate_precrash(scaled(v1, UNUSED_VEHICLE_FIELDS, 1.9),
                                scaled(v2, UNUSED_VEHICLE_FIELDS, 0.6), paths,
                                np.full(5, 0.8), controller=ctl)
    for name in ("contact_time", "min_distance", "poi", "collided"):
        np.testing.assert_array_equal(getattr(changed, name), getattr(base, name))
    for name in ("x", "y", "yaw", "vx", "vy", "yaw_rate"):
        np.testing.assert_array_equal(getattr(changed.impact_state, name),
                                      getattr(base.impact_state, name))
    longer = simulate_precrash(scaled(v1, ("length", "front_overhang"), 1.2), v2, paths,
                               np.full(5, 0.8), controller=ctl)
    assert not np.array_equal(longer.contact_time, base.contact_time, equal_nan=True)


def test_outline_distance_closed_form():
    a = outline_corners([0.0], [0.0], [0.0], [2.0], [2.0], [2.0])
    b = outline_corners([7.0], [3.0], [0.0], [2.0], [2.0], [2.0])
    # corner (2, 1) to corner (5, 2): sqrt(9 + 1)
    assert outline_distance(a, b)[0] == pytest.approx(np.sqrt(10.0))
    c = outline_corners([7.0], [0.5], [0.0], [2.0], [2.0], [2.0])
    assert outline_distance(a, c)[0] == pytest.approx(3.0)


def test_parameter_validation():
    with pytest.raises(ParameterError):
        PrecrashParams(dt=0.5)
    with pytest.raises(ParameterError):
        BrakeActuatorParams(model="magic")
    paths = pack([straight(0.0, 10.0, 0.0), straight(50.0, 0.0, 0.0)])
    v1, v2 = cars(2)
    with pytest.raises(ParameterError):
        simulate_precrash(v1, v2, paths, [0.8, 0.8])


def test_a_case_does_not_depend_on_the_other_cases_of_its_batch():
    """Each case ends at its own horizon (record + extra time), whatever else is batched."""
    from vfs.database import bundled_database_path, load_database
    from vfs.simulation import CaseBatch, simulate_cases

    db = load_database(bundled_database_path(), where="case_id <= 24")
    batch = CaseBatch.from_database(db)
    n = batch.size
    durations = np.maximum(batch.paths.duration[:n], batch.paths.duration[n:])
    assert np.ptp(durations) > 0.2  # records of different lengths
    brake = ScheduledBraking(np.c_[np.full(n, 2.0), np.full(n, 2.0)], np.full((n, 2), 8.0))
    whole = simulate_cases(batch, controller=brake)
    assert (~whole.precrash.collided).sum() >= 5
    for i in range(0, n, 3):
        one = simulate_cases(batch.take([i]), controller=ScheduledBraking(
            [[2.0, 2.0]], [[8.0, 8.0]]))
        a, b = whole.precrash, one.precrash
        np.testing.assert_array_equal(a.collided[i], b.collided[0])
        np.testing.assert_allclose(a.speed_reduction[i], b.speed_reduction[0], rtol=1e-12)
        np.testing.assert_allclose(a.min_distance[i], b.min_distance[0], rtol=1e-12)
        np.testing.assert_allclose(a.end_state.x[i], b.end_state.x[0], rtol=1e-12)


def test_staggered_starts_equal_a_common_start():
    """PrecrashRun with cases (re)started at different steps (the vector environment's
    resets) gives each case exactly the result of a plain run: every case on its own clock."""
    from vfs.database import bundled_database_path, load_database
    from vfs.physics.precrash import PrecrashRun
    from vfs.simulation import CaseBatch

    db = load_database(bundled_database_path(), where="case_id <= 30")
    batch = CaseBatch.from_database(db)
    n = batch.size
    args = (batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction)
    demand = 6.0  # [m/s^2] on participant 1 from 2.5 s (local time) on

    def brake(obs_t: np.ndarray, m: int) -> np.ndarray:
        d = np.zeros((m, 2))
        d[:, 0] = np.where(np.asarray(obs_t) >= 2.5 - 1e-9, demand, 0.0)
        return d

    plain = PrecrashRun(*args)
    while not plain.done:
        obs = plain.observation()
        plain.advance(brake(np.broadcast_to(obs.t, obs.rows.shape), obs.rows.size))
    ref = plain.result()

    first = np.arange(0, n, 2)
    later = {37: np.arange(1, n, 2)}  # started 37 steps later
    run = PrecrashRun(*args, start=first, open_ended=True)
    again = first[:3]  # ... and three cases run twice: restarted when they end
    restarted: set[int] = set()
    results: dict[int, object] = {}
    for _ in range(5000):
        obs = run.observation()
        assert isinstance(obs.t, float) == run.common_clock  # array t on mixed clocks
        t = run.local_time(obs.rows)
        new = later.pop(run.k + 1, np.zeros(0, np.int64))
        for r in run.finished:
            results[int(r)] = run.result([r])
        redo = [int(r) for r in run.finished if r in again and r not in restarted]
        restarted.update(redo)
        run.advance(brake(t, obs.rows.size), start=np.concatenate([new, redo]).astype(int))
        if not run.rows.size and not later:
            for r in run.finished:
                results[int(r)] = run.result([r])
            break
    assert sorted(results) == list(range(n)) and restarted == set(map(int, again))
    for i, res in results.items():
        for name in ("collided", "contact_time", "impact_time", "poi", "cp_angle",
                     "min_distance", "time_closest", "brake_start", "speed_reduction"):
            np.testing.assert_array_equal(getattr(res, name)[0], getattr(ref, name)[i],
                                          err_msg=f"case {i} {name}")
        for a, b in zip(res.impact_state, ref.impact_state, strict=True):
            np.testing.assert_array_equal(a[0], b[i])


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


def test_replay_started_before_contact_reaches_the_same_impact_bit_for_bit():
    # without a controller a case follows its record until contact: started at any step
    # before it, it reaches the same contact and impact to the last bit
    rng = np.random.default_rng(12)
    paths, v1, v2 = head_on_pairs(rng)
    mu = np.full(5, 0.8)
    whole = simulate_precrash(v1, v2, paths, mu)
    assert whole.collided.all()
    dt = PrecrashParams().dt
    last = np.floor(whole.contact_time / dt).astype(np.int64) - 1
    for first in (last, last // 2, np.zeros(5, np.int64)):
        late = simulate_precrash(v1, v2, paths, mu, first_step=first)
        for name in ("collided", "contact_time", "impact_time", "poi", "cp_angle",
                     "overlap_area", "min_distance", "time_closest"):
            np.testing.assert_array_equal(getattr(late, name), getattr(whole, name), name)
        for a, b in zip(late.impact_state, whole.impact_state, strict=True):
            np.testing.assert_array_equal(a, b)
    # the control: started after its contact, a case no longer meets it there
    after = simulate_precrash(v1, v2, paths, mu, first_step=last + 40)
    assert not np.array_equal(after.contact_time, whole.contact_time, equal_nan=True)
    with pytest.raises(ParameterError, match="controller"):
        simulate_precrash(v1, v2, paths, mu, first_step=last,
                          controller=ScheduledBraking(np.full((5, 2), np.nan), np.zeros((5, 2))))
