"""Post-crash run-out: closed forms, invariances, energy, convergence, secondary collisions.

Oracles: the straight locked slide (v^2 / (2 mu g)), the free roll (v^2 / (2 f_r g)),
the pure spin of a symmetric car (constant friction torque), mirror symmetry,
kinetic energy never rising, batch = single, time-step convergence, and a
brute-force overlap check of the recorded paths for the secondary collisions.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.errors import ParameterError
from vfs.physics.geometry import AREA_TOLERANCE, overlap, vehicle_outline
from vfs.physics.runout import (
    REST_FIELDS,
    PairRunoutResult,
    RunoutMemo,
    RunoutParams,
    RunoutResult,
    RunoutState,
    distinct_rows,
    kinetic_energy,
    row_table,
    run_out,
    run_out_pair,
    static_wheel_loads,
    wheel_positions,
)
from vfs.physics.vehicle import VehicleArrays, VehicleParams, stack_vehicles, vehicle_arrays
from vfs.units import G

pytestmark = pytest.mark.usefixtures("both_runout_paths")

LOCKED = (1.0, 1.0, 1.0, 1.0)
FREE = (0.0, 0.0, 0.0, 0.0)
#: brake factor columns swapped left <-> right (FL, FR, RL, RR -> FR, FL, RR, RL)
MIRROR_WHEELS = [1, 0, 3, 2]


def car(**over) -> VehicleArrays:
    return stack_vehicles([VehicleParams(**over)])


def cars(n: int, **over) -> VehicleArrays:
    return stack_vehicles([VehicleParams(**over)] * n)


def random_vehicles(rng: np.random.Generator, n: int) -> VehicleArrays:
    """Car-like vehicles: 3.6-5.2 m long, CG 38-50 % of the wheelbase behind the front axle."""
    length = rng.uniform(3.6, 5.2, n)
    width = rng.uniform(1.6, 1.95, n)
    wheelbase = length * rng.uniform(0.56, 0.62, n)
    lf = wheelbase * rng.uniform(0.38, 0.5, n)
    overhang = (length - wheelbase) * rng.uniform(0.5, 0.6, n)
    return vehicle_arrays(rng.uniform(900, 2300, n), length, width, wheelbase, lf, overhang,
                          width * rng.uniform(0.82, 0.88, n), rng.uniform(0.45, 0.65, n))


def random_states(rng: np.random.Generator, n: int) -> RunoutState:
    """Post-crash states: speeds 0-20 m/s in any direction, yaw rates up to 3 rad/s."""
    speed = rng.uniform(0.0, 20.0, n)
    course = rng.uniform(-np.pi, np.pi, n)
    return RunoutState.from_arrays(
        rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), rng.uniform(-np.pi, np.pi, n),
        speed * np.cos(course), speed * np.sin(course), rng.uniform(-3.0, 3.0, n))


def random_inputs(seed: int, n: int) -> tuple[VehicleArrays, RunoutState, np.ndarray, np.ndarray]:
    """n random vehicles, post-crash states, friction coefficients and brake factors."""
    rng = np.random.default_rng(seed)
    vehicles, s = random_vehicles(rng, n), random_states(rng, n)
    return vehicles, s, rng.uniform(0.3, 1.0, n), rng.choice([0.0, 0.5, 1.0], (n, 4))


def rest_change(a: RunoutResult, b: RunoutResult) -> np.ndarray:
    return np.hypot(a.rest_x - b.rest_x, a.rest_y - b.rest_y)


# ----------------------------------------------------------------------------
# Closed forms
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("load_transfer", [False, True])
@pytest.mark.parametrize(("speed", "mu"), [(5.0, 0.8), (12.0, 0.5), (20.0, 0.9), (8.0, 0.2)])
def test_locked_straight_slide_stops_after_v2_over_2_mu_g(speed, mu, load_transfer):
    heading = 0.7
    state = RunoutState.from_arrays(1.0, -2.0, heading, speed * np.cos(heading),
                                    speed * np.sin(heading), 0.0)
    res = run_out(car(), state, mu, RunoutParams(load_transfer=load_transfer),
                  wheel_brake=LOCKED)
    expected = speed**2 / (2.0 * mu * G)  # friction work mu m g s = m v^2 / 2
    dx, dy = res.rest_x[0] - 1.0, res.rest_y[0] + 2.0
    along = dx * np.cos(heading) + dy * np.sin(heading)
    across = -dx * np.sin(heading) + dy * np.cos(heading)
    assert res.at_rest[0]
    assert abs(along - expected) <= 0.01 * expected
    assert abs(across) < 1e-6  # straight along the initial velocity
    assert abs(res.rest_yaw[0] - heading) < 1e-9  # no rotation
    assert abs(res.distance[0] - expected) <= 0.01 * expected
    assert abs(res.time_to_rest[0] - speed / (mu * G)) <= 0.01 * speed / (mu * G) + 0.01


@pytest.mark.parametrize("course", [np.pi / 2, 2.0, -2.5])
def test_locked_slide_in_any_direction_is_straight(course):
    """Sideways or oblique: the friction forces act at the load-weighted wheel centre, the CG."""
    speed, mu = 10.0, 0.7
    state = RunoutState.from_arrays(0.0, 0.0, 0.0, speed * np.cos(course),
                                    speed * np.sin(course), 0.0)
    res = run_out(car(), state, mu, wheel_brake=LOCKED)
    expected = speed**2 / (2.0 * mu * G)
    along = res.rest_x[0] * np.cos(course) + res.rest_y[0] * np.sin(course)
    across = -res.rest_x[0] * np.sin(course) + res.rest_y[0] * np.cos(course)
    assert abs(along - expected) <= 0.01 * expected
    assert abs(across) < 1e-6
    assert abs(res.rest_yaw[0]) < 1e-9


def test_pure_spin_decays_without_translating():
    """CG midway between the axles: all wheels carry mg/4 at lever d, torque mu m g d."""
    vehicle = car(wheelbase=2.7, cg_to_front_axle=1.35)
    rate, mu = 2.0, 0.8
    params = RunoutParams(path_interval=0.005)  # every step
    res = run_out(vehicle, RunoutState.from_arrays(0, 0, 0, 0, 0, rate), mu, params,
                  wheel_brake=LOCKED)
    assert res.at_rest[0]
    assert np.hypot(res.rest_x[0], res.rest_y[0]) < 0.01
    assert np.abs(res.path[0, :, :2]).max() < 0.01
    increments = np.diff(res.path[0, :, 2])  # dt (r_k + r_k+1) / 2
    assert (increments >= 0.0).all()  # never turns back
    assert (np.diff(increments) <= 1e-15).all()  # yaw rate decreasing
    assert (np.diff(res.kinetic_energy[0]) <= 0.0).all()
    d = float(np.hypot(1.35, 0.5 * vehicle.track_width[0]))
    decel = mu * vehicle.mass[0] * G * d / vehicle.yaw_inertia[0]  # [rad/s^2]
    assert abs(res.rest_yaw[0] - rate**2 / (2 * decel)) <= 0.01 * rate**2 / (2 * decel)
    assert abs(res.time_to_rest[0] - rate / decel) <= 0.01 * rate / decel + 0.005


def test_free_rolling_decelerates_by_rolling_resistance_only():
    speed, f_r = 3.0, 0.015
    params = RunoutParams(rolling_resistance=f_r)
    res = run_out(car(), RunoutState.from_arrays(0, 0, 0, speed, 0, 0), 0.8, params,
                  wheel_brake=FREE)
    expected = speed**2 / (2.0 * f_r * G)
    assert res.at_rest[0]
    assert abs(res.rest_x[0] - expected) <= 0.02 * expected
    assert abs(res.rest_y[0]) < 1e-9


def test_static_loads_carry_the_weight_at_the_cg():
    v = car()
    loads = static_wheel_loads(v)
    pos = wheel_positions(v)
    assert loads.sum() == pytest.approx(v.mass[0] * G)
    assert (loads[0] * pos[0, :, 0]).sum() == pytest.approx(0.0, abs=1e-9)
    assert (loads[0] * pos[0, :, 1]).sum() == pytest.approx(0.0, abs=1e-9)


# ----------------------------------------------------------------------------
# Invariances and energy
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("load_transfer", [False, True])
def test_mirror_image_gives_mirrored_rest_positions(load_transfer):
    rng = np.random.default_rng(11)
    n = 24
    vehicles = random_vehicles(rng, n)
    s = random_states(rng, n)
    brake = rng.choice([0.0, 0.3, 0.8, 1.0], (n, 4))
    mu = rng.uniform(0.3, 1.0, n)
    params = RunoutParams(load_transfer=load_transfer)
    mirror = RunoutState(s.x, -s.y, -s.yaw, s.vx, -s.vy, -s.yaw_rate)
    a = run_out(vehicles, s, mu, params, wheel_brake=brake)
    b = run_out(vehicles, mirror, mu, params, wheel_brake=brake[:, MIRROR_WHEELS])
    scale = 1e-9 * np.maximum(1.0, np.abs(np.stack([a.rest_x, a.rest_y, a.rest_yaw])))
    assert (np.abs(b.rest_x - a.rest_x) <= scale[0]).all()
    assert (np.abs(b.rest_y + a.rest_y) <= scale[1]).all()
    assert (np.abs(b.rest_yaw + a.rest_yaw) <= scale[2]).all()
    assert np.array_equal(a.at_rest, b.at_rest)


def test_rigid_translation_and_rotation_of_the_scene():
    """Moving and turning the whole scene moves and turns the rest positions alike."""
    rng = np.random.default_rng(5)
    n = 16
    vehicles, s = random_vehicles(rng, n), random_states(rng, n)
    mu = rng.uniform(0.3, 1.0, n)
    turn, shift = 0.9, np.array([30.0, -12.0])
    c, si = np.cos(turn), np.sin(turn)
    moved = RunoutState(shift[0] + c * s.x - si * s.y, shift[1] + si * s.x + c * s.y,
                        s.yaw + turn, c * s.vx - si * s.vy, si * s.vx + c * s.vy, s.yaw_rate)
    a = run_out(vehicles, s, mu)
    b = run_out(vehicles, moved, mu)
    np.testing.assert_allclose(b.rest_x, shift[0] + c * a.rest_x - si * a.rest_y, atol=1e-6)
    np.testing.assert_allclose(b.rest_y, shift[1] + si * a.rest_x + c * a.rest_y, atol=1e-6)
    np.testing.assert_allclose(b.rest_yaw, a.rest_yaw + turn, atol=1e-9)


BRAKE_MODES = {
    "free": FREE,
    "partial": (0.5, 0.5, 0.5, 0.5),
    "locked": LOCKED,
    "mixed": (1.0, 1.0, 0.3, 0.0),
}


@settings(max_examples=30, deadline=None)
@given(
    speed=st.floats(0.0, 20.0), course=st.floats(-np.pi, np.pi), yaw=st.floats(-np.pi, np.pi),
    yaw_rate=st.floats(-3.0, 3.0), mu=st.floats(0.1, 1.2), load_transfer=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_kinetic_energy_never_rises(speed, course, yaw, yaw_rate, mu, load_transfer, seed):
    """All four wheel modes at once; energy sampled after every step."""
    rng = np.random.default_rng(seed)
    k = len(BRAKE_MODES)
    vehicles = random_vehicles(rng, k)
    state = RunoutState.from_arrays(0.0, 0.0, yaw, speed * np.cos(course),
                                    speed * np.sin(course), yaw_rate)
    state = RunoutState(*(np.repeat(a, k) for a in state))
    params = RunoutParams(load_transfer=load_transfer, path_interval=0.005, max_time=4.0)
    res = run_out(vehicles, state, mu, params, wheel_brake=np.array(list(BRAKE_MODES.values())))
    energy = res.kinetic_energy
    initial = kinetic_energy(vehicles, state)
    started = ~(res.time_to_rest == 0.0)  # the others are frozen at t = 0 with zero energy
    np.testing.assert_allclose(energy[started, 0], initial[started], rtol=1e-12)
    assert (energy[~started] == 0.0).all()
    rise = np.diff(energy, axis=1, prepend=energy[:, :1]).max(axis=1)
    assert (rise <= 1e-9 * initial + 1e-9).all(), dict(zip(BRAKE_MODES, rise, strict=True))


def test_batch_equals_single():
    rng = np.random.default_rng(3)
    n = 10
    vehicles, s = random_vehicles(rng, n), random_states(rng, n)
    mu = rng.uniform(0.3, 1.0, n)
    brake = rng.choice([0.0, 0.5, 0.8, 1.0], (n, 4))
    params = RunoutParams(load_transfer=True)
    batch = run_out(vehicles, s, mu, params, wheel_brake=brake)
    for i in range(n):
        one = run_out(vehicles.take([i]), RunoutState(*(a[[i]] for a in s)), mu[i], params,
                      wheel_brake=brake[i])
        # elementwise IEEE arithmetic: the batch size must not change a single bit
        assert one.rest_x[0] == batch.rest_x[i]
        assert one.rest_y[0] == batch.rest_y[i]
        assert one.rest_yaw[0] == batch.rest_yaw[i]
        assert one.time_to_rest[0] == batch.time_to_rest[i] or not batch.at_rest[i]


def test_repeated_vehicles_run_once_and_get_the_same_result():
    # a batch of model variants repeats most vehicles: run_out runs each distinct one
    # once; the copies must equal, bit for bit, the batch without repetitions
    n = 7
    vehicles, s, mu, brake = random_inputs(8, n)
    params = RunoutParams(load_transfer=True)
    alone = run_out(vehicles, s, mu, params, wheel_brake=brake)
    index = np.array([3, 0, 3, 6, 1, 0, 2, 5, 4, 3, 6])
    rep = run_out(vehicles.take(index), RunoutState(*(a[index] for a in s)), mu[index],
                  params, wheel_brake=brake[index])
    for name in RunoutResult._fields:
        got, want = getattr(rep, name), getattr(alone, name)
        if name == "path_t":
            assert np.array_equal(got, want)
        else:
            assert np.array_equal(got, want[index], equal_nan=True), name
    # one changed number makes a vehicle distinct
    brake2 = brake[index].copy()
    brake2[2, 0] = 0.25
    first, inverse = distinct_rows(row_table(*vehicles.take(index), *(a[index] for a in s),
                                             mu[index], brake2))
    assert first.size == n + 1 and np.array_equal(first[inverse][[1, 5]], [1, 1])
    assert inverse[0] != inverse[2] and inverse[0] == inverse[9]


def test_run_out_without_path_samples_keeps_every_other_field():
    n = 9
    vehicles, s, mu, brake = random_inputs(12, n)
    index = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 2, 2, 5])  # repeated vehicles too
    args = (vehicles.take(index), RunoutState(*(a[index] for a in s)), mu[index],
            RunoutParams(load_transfer=True))
    full = run_out(*args, wheel_brake=brake[index])
    bare = run_out(*args, wheel_brake=brake[index], paths=False)
    assert full.path.shape[1] > 1 and bare.path.shape == (index.size, 0, 3)
    assert bare.kinetic_energy.shape == (index.size, 0) and bare.path_t.size == 0
    for name in REST_FIELDS:
        assert np.array_equal(getattr(bare, name), getattr(full, name), equal_nan=True), name


def test_memo_gives_vehicles_run_before_their_results_bit_for_bit():
    # calls that meet vehicles of earlier calls (the model variants of a search) take
    # their rest results from the memo: equal, bit for bit, to running them
    n = 8
    vehicles, s, mu, brake = random_inputs(13, n)
    params = RunoutParams(load_transfer=True)
    memo = RunoutMemo()

    def call(index, use_memo):
        return run_out(vehicles.take(index), RunoutState(*(a[index] for a in s)), mu[index],
                       params, wheel_brake=brake[index], paths=False,
                       memo=memo if use_memo else None)

    for index in (np.array([0, 1, 2, 2]), np.array([2, 3, 0, 4, 4]), np.arange(n)[::-1]):
        got, want = call(index, True), call(index, False)
        for name in REST_FIELDS:
            assert np.array_equal(getattr(got, name), getattr(want, name), equal_nan=True)
    assert (memo.misses, memo.hits) == (n, 0 + 2 + 5)  # distinct per call: 3, 4, 8
    with pytest.raises(ParameterError, match="paths=False"):
        run_out(vehicles, s, mu, params, wheel_brake=brake, memo=memo)
    small = RunoutMemo(max_vehicles=2)
    run_out(vehicles, s, mu, params, wheel_brake=brake, paths=False, memo=small)
    assert small.misses == n and len(small._index) == 2  # noqa: SLF001 - the bound


def test_time_step_convergence():
    """Halving dt moves realistic rest positions by less than 5 cm (second-order step)."""
    rng = np.random.default_rng(2024)
    n = 60
    vehicles, s = random_vehicles(rng, n), random_states(rng, n)
    mu = rng.uniform(0.3, 1.0, n)
    for brake in (None, LOCKED):
        coarse = run_out(vehicles, s, mu, RunoutParams(dt=0.005), wheel_brake=brake)
        fine = run_out(vehicles, s, mu, RunoutParams(dt=0.0025), wheel_brake=brake)
        assert coarse.at_rest.all() and fine.at_rest.all()
        assert rest_change(coarse, fine).max() < 0.05


# ----------------------------------------------------------------------------
# Result bookkeeping
# ----------------------------------------------------------------------------


def test_path_samples_and_padding():
    params = RunoutParams(path_interval=0.1)
    state = RunoutState.from_arrays(0, 0, 0, [2.0, 10.0], 0, [0.0, 1.0])
    res = run_out(cars(2), state, 0.8, params, wheel_brake=LOCKED)
    k = res.path_t.shape[0]
    assert res.path.shape == (2, k, 3) and res.kinetic_energy.shape == (2, k)
    np.testing.assert_allclose(np.diff(res.path_t), 0.1)
    assert res.path_t[-1] >= np.nanmax(res.time_to_rest)
    np.testing.assert_array_equal(res.path[:, 0, 0], [0.0, 0.0])
    after = res.path_t > res.time_to_rest[0]
    assert (res.path[0, after, 0] == res.rest_x[0]).all()
    assert (res.kinetic_energy[0, after] == 0.0).all()
    np.testing.assert_array_equal(res.path[:, -1], np.stack(
        [res.rest_x, res.rest_y, res.rest_yaw], axis=-1))


def test_vehicle_at_rest_from_the_start():
    res = run_out(car(), RunoutState.from_arrays(3.0, 4.0, 1.0, 0.01, 0.0, 0.001), 0.8)
    assert res.at_rest[0] and res.time_to_rest[0] == 0.0
    assert (res.rest_x[0], res.rest_y[0], res.rest_yaw[0]) == (3.0, 4.0, 1.0)
    assert res.distance[0] == 0.0


def test_max_time_guard_reports_moving_vehicles():
    params = RunoutParams(max_time=1.0)
    state = RunoutState.from_arrays(0, 0, 0, [15.0, 1.0], 0, 0)
    res = run_out(cars(2), state, 0.8, params, wheel_brake=np.array([FREE, LOCKED]))
    assert not res.at_rest[0] and np.isnan(res.time_to_rest[0])
    assert res.at_rest[1] and res.time_to_rest[1] < 0.2
    assert res.path_t[-1] == pytest.approx(1.0)
    assert 14.0 < res.rest_x[0] < 15.0  # still rolling at t = 1 s


def test_empty_batch():
    empty = VehicleArrays(*(np.zeros(0) for _ in VehicleArrays._fields))
    res = run_out(empty, RunoutState.from_arrays(*([np.zeros(0)] * 6)), 0.8)
    assert res.rest_x.shape == (0,) and res.path.shape[0] == 0


# ----------------------------------------------------------------------------
# Pairs and secondary collisions
# ----------------------------------------------------------------------------


def test_secondary_collision_when_pushed_together_again():
    """Vehicle 2 leaves ahead on locked wheels and stops; vehicle 1 rolls freely into it."""
    v = car()
    length = float(v.length[0])
    s1 = RunoutState.from_arrays(0.0, 0.0, 0.0, 6.0, 0.0, 0.0)
    s2 = RunoutState.from_arrays(length - 0.2, 0.0, 0.0, 8.0, 0.0, 0.0)  # 0.2 m overlap
    res = run_out_pair(v, v, s1, s2, 0.8, wheel_brake1=FREE, wheel_brake2=LOCKED)
    assert res.secondary_collision[0]
    t = res.secondary_collision_time[0]
    assert 0.1 < t < res.time_to_rest[0, 1] + 1.0
    # apart at some earlier sample, overlapping again at the end (they pass through)
    gap = res.path[0, 1, :, 0] - res.path[0, 0, :, 0] - length
    assert (gap > 0).any()


@pytest.mark.parametrize("course2", [0.0, 0.8])
def test_no_secondary_collision_when_drifting_apart(course2):
    v = car()
    s1 = RunoutState.from_arrays(0.0, 0.0, 0.0, -6.0, 0.5, 0.3)
    s2 = RunoutState.from_arrays(4.3, 0.3, 0.2, 7.0 * np.cos(course2), 7.0 * np.sin(course2),
                                 -0.5)
    res = run_out_pair(v, v, s1, s2, 0.8)
    assert not res.secondary_collision[0] and np.isnan(res.secondary_collision_time[0])
    assert res.at_rest[0].all()


def test_no_secondary_collision_without_separation():
    """Outlines overlapping until both stop never separated: no secondary collision."""
    v = car()
    s1 = RunoutState.from_arrays(0.0, 0.0, 0.0, 1.0, 0.0, 0.0)
    s2 = RunoutState.from_arrays(2.0, 0.0, 0.0, 1.0, 0.0, 0.0)
    res = run_out_pair(v, v, s1, s2, 0.8)
    assert not res.secondary_collision[0]


def brute_force_secondary(v1, v2, res: PairRunoutResult):
    """Overlap area of every recorded pose pair (path_interval = dt), then the rule."""
    n, k = res.path.shape[0], res.path.shape[2]
    rep = np.repeat(np.arange(n), k)
    p1, p2 = res.path[:, 0].reshape(-1, 3), res.path[:, 1].reshape(-1, 3)
    area = overlap(vehicle_outline(v1.take(rep), *p1.T), vehicle_outline(v2.take(rep), *p2.T)).area
    over = (area > AREA_TOLERANCE).reshape(n, k)
    hit, when = np.zeros(n, bool), np.full(n, np.nan)
    for i in range(n):
        apart = np.flatnonzero(~over[i])
        if apart.size:
            again = np.flatnonzero(over[i, apart[0]:])
            if again.size:
                hit[i], when[i] = True, res.path_t[apart[0] + again[0]]
    return hit, when


def test_secondary_collisions_match_brute_force_overlap():
    """The broad phase, the separating axes and the corner test never change the answer."""
    rng = np.random.default_rng(8)
    n = 80
    v1, v2 = random_vehicles(rng, n), random_vehicles(rng, n)
    s1 = random_states(rng, n)
    gap = rng.uniform(-1.0, 4.0, n)  # start overlapping or a few metres apart
    ahead = v1.corner_radius * 0.5 + v2.corner_radius * 0.5 + gap
    side = rng.uniform(-np.pi, np.pi, n)
    s1 = s1._replace(x=np.zeros(n), y=np.zeros(n))
    s2 = random_states(rng, n)._replace(x=ahead * np.cos(side), y=ahead * np.sin(side))
    # aim vehicle 2 at vehicle 1 for half of the cases
    aim = rng.random(n) < 0.5
    speed = np.hypot(s2.vx, s2.vy)
    s2 = s2._replace(vx=np.where(aim, -speed * np.cos(side), s2.vx),
                     vy=np.where(aim, -speed * np.sin(side), s2.vy))
    mu = rng.uniform(0.3, 1.0, n)
    params = RunoutParams(path_interval=0.005, max_time=8.0)
    res = run_out_pair(v1, v2, s1, s2, mu, params)
    hit, when = brute_force_secondary(v1, v2, res)
    assert hit.any() and not hit.all()
    np.testing.assert_array_equal(res.secondary_collision, hit)
    np.testing.assert_allclose(res.secondary_collision_time, when, rtol=0, atol=1e-9)


def test_overlap_phases_agree_with_clipping_near_touching():
    """Circle, separating-axis and corner-depth phases give the clipping answer exactly.

    Random poses plus nose-to-tail pairs whose gap is a hair either side of zero
    (overlap slivers below and above AREA_TOLERANCE).
    """
    from vfs.physics.runout import _SecondaryCollisions

    rng = np.random.default_rng(21)
    n = 20000
    v = random_vehicles(rng, 2 * n)
    x, y = np.zeros(2 * n), np.zeros(2 * n)
    x[n:], y[n:] = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n)
    yaw = rng.uniform(-np.pi, np.pi, 2 * n)
    k = n // 4
    yaw[n:n + k] = yaw[:k] + rng.choice([0.0, 1e-7, np.pi / 2], k)
    gap = rng.choice([-1e-3, -1e-8, -1e-11, 0.0, 1e-11, 1e-6], k)
    ahead = v.cg_to_front[:k] + v.cg_to_rear[n:n + k] + gap
    x[n:n + k], y[n:n + k] = ahead * np.cos(yaw[:k]), ahead * np.sin(yaw[:k])
    tracker = _SecondaryCollisions(v, x, y, yaw)
    first, second = np.arange(n), np.arange(n, 2 * n)
    area = overlap(vehicle_outline(v.take(first), x[:n], y[:n], yaw[:n]),
                   vehicle_outline(v.take(second), x[n:], y[n:], yaw[n:])).area
    np.testing.assert_array_equal(~tracker.separated, area > AREA_TOLERANCE)
    assert 0.2 < (area > AREA_TOLERANCE).mean() < 0.8


def test_pair_results_equal_single_run_outs():
    rng = np.random.default_rng(4)
    n = 6
    v1, v2 = random_vehicles(rng, n), random_vehicles(rng, n)
    s1, s2 = random_states(rng, n), random_states(rng, n)
    res = run_out_pair(v1, v2, s1, s2, 0.7, wheel_brake2=LOCKED)
    alone1 = run_out(v1, s1, 0.7)
    alone2 = run_out(v2, s2, 0.7, wheel_brake=LOCKED)
    for j, alone in enumerate((alone1, alone2)):
        for name in REST_FIELDS:
            np.testing.assert_array_equal(getattr(res, name)[:, j], getattr(alone, name))
        # the pair's path runs until both vehicles rest: the single one's samples come first
        k = alone.path_t.size
        np.testing.assert_array_equal(res.path_t[:k], alone.path_t)
        np.testing.assert_array_equal(res.path[:, j, :k], alone.path)
        np.testing.assert_array_equal(res.kinetic_energy[:, j, :k], alone.kinetic_energy)
    assert res.rest_x.shape == (n, 2) and res.path.shape[:2] == (n, 2)


# ----------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs", [
    {"dt": 0.0}, {"dt": -0.001}, {"dt": float("nan")}, {"dt": 0.1},
    {"wheel_brake": (1.0, 1.0, 1.0)}, {"wheel_brake": (0.5, 0.5, 0.5, 1.5)},
    {"wheel_brake": (0.5, 0.5, -0.1, 0.5)}, {"wheel_brake": "lock"},
    {"rolling_resistance": -0.01}, {"rolling_resistance": 0.6},
    {"cornering_stiffness": 0.0}, {"cornering_stiffness": float("inf")},
    {"v_stop": 0.0}, {"max_time": 0.0}, {"max_time": 0.001},
    {"path_interval": 0.0}, {"path_interval": 0.0071}, {"path_interval": 0.001},
    {"load_transfer": "yes"}, {"dt": True},
])
def test_invalid_params_raise(kwargs):
    with pytest.raises(ParameterError):
        RunoutParams(**kwargs)


def test_defaults_are_valid_and_documented():
    p = RunoutParams()
    assert (p.dt, p.wheel_brake, p.v_stop, p.max_time) == (0.005, (0.8,) * 4, 0.05, 30.0)
    assert p.steps_per_sample == 10 and p.max_steps == 6000


def test_invalid_inputs_raise():
    state = RunoutState.from_arrays(0, 0, 0, 5.0, 0, 0)
    v = car()
    with pytest.raises(ParameterError, match="road_friction"):
        run_out(v, state, 0.0)
    with pytest.raises(ParameterError, match="road_friction"):
        run_out(v, state, [0.5, 0.5])
    with pytest.raises(ParameterError, match="wheel_brake"):
        run_out(v, state, 0.8, wheel_brake=(1.0, 1.0))
    with pytest.raises(ParameterError, match="wheel_brake"):
        run_out(v, state, 0.8, wheel_brake=(1.0, 1.0, 2.0, 1.0))
    with pytest.raises(ParameterError, match="vehicles"):
        run_out(cars(2), state, 0.8)
    with pytest.raises(ParameterError, match="not finite"):
        run_out(v, state._replace(vx=np.array([np.nan])), 0.8)
    with pytest.raises(ParameterError, match="RunoutState"):
        run_out(v, (0, 0, 0, 5.0, 0, 0), 0.8)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="params"):
        run_out(v, state, 0.8, params={"dt": 0.01})  # type: ignore[arg-type]
    bad = v._replace(cg_to_front_axle=np.array([3.0]))
    with pytest.raises(ParameterError, match="between the axles"):
        run_out(bad, state, 0.8)
    with pytest.raises(ParameterError, match="state2"):
        run_out_pair(v, cars(2), state, RunoutState.from_arrays(0, 0, 0, [1, 2], 0, 0), 0.8)
