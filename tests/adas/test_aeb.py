"""Generic AEB systems (adas): registry, kernels, and Euro NCAP-like CCRs runs.

Oracles: brute-force time stepping with the Sutherland-Hodgman overlap of
vfs.physics.geometry (TTC), shapely (sensor sector), closed forms (head-on TTC,
jerk-limited stopping distance, impact speed after braking from the first
moment), ScheduledBraking (latency and build-up), and invariants (monotone
impact speed, identical replay without AEB, reproducibility).
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest
import shapely
from hypothesis import assume, given
from hypothesis import strategies as st

from vfs.adas import (
    EVENT_KEYS,
    SYSTEM_NAMES,
    AEBParams,
    AEBSystem,
    DriverParams,
    SensorParams,
    get_system,
    register_system,
    system_names,
)
from vfs.adas.sensor import sector_distance
from vfs.adas.threat import Motion, braked_contact, time_to_collision, ttc_cv
from vfs.errors import ParameterError
from vfs.physics.geometry import outline_corners, outline_distance, overlap
from vfs.physics.paths import concat_paths, pack_paths
from vfs.physics.precrash import (
    BrakeActuatorParams,
    PrecrashParams,
    ScheduledBraking,
)
from vfs.physics.vehicle import vehicle_arrays
from vfs.simulation import CaseBatch, SimulationParams, simulate_cases
from vfs.units import G

DT = 0.01
SPEEDS_KMH = np.arange(10.0, 50.1, 5.0)  # Euro NCAP CCRs AEB test speeds


# ----------------------------------------------------------------------------
# Case builders
# ----------------------------------------------------------------------------


def cars(n: int):
    """n identical cars: 4.5 x 1.8 m, CG 2.1 m behind the front bumper."""
    return vehicle_arrays(mass=np.full(n, 1500.0), length=4.5, width=1.8, wheelbase=2.7,
                          cg_to_front_axle=1.2, front_overhang=0.9, track_width=1.55,
                          cg_height=0.55)


def batch_from_records(t, x1, y1, yaw1, v1, x2, y2, yaw2, v2, mu) -> CaseBatch:
    """A batch from records (n, M) of both participants sampled at times t (M,)."""
    n, m = x1.shape
    group = np.repeat(np.arange(n), m)

    def pack(x, y, yaw, v):
        return pack_paths(np.tile(t, n), x.ravel(), y.ravel(), yaw.ravel(), v.ravel(), group)

    nan = np.full(n, np.nan)
    return CaseBatch(np.arange(n), cars(n), cars(n),
                     concat_paths(pack(x1, y1, yaw1, v1), pack(x2, y2, yaw2, v2)),
                     np.broadcast_to(np.asarray(mu, float), (n,)).copy(), nan, nan.copy())


def ccrs_batch(speeds_kmh, mu: float = 0.8, t_contact=4.005, duration: float = 6.0,
               offset: float = 0.0) -> CaseBatch:
    """Car-to-car rear stationary: subject at constant speed on a straight road, 100 %
    overlap, its recorded path going through the standing target; unbraked first contact at
    ``t_contact`` [s] (off the 10 ms grid by default, so no step starts exactly touching)."""
    v = np.asarray(speeds_kmh, float) / 3.6
    n = v.size
    t = np.arange(0.0, duration + 1e-9, DT)
    tc = np.broadcast_to(np.asarray(t_contact, float), (n,))
    front, rear = 2.1, 2.4  # CG to front / rear bumper of cars()
    x1 = (-rear - front - v * tc)[:, None] + v[:, None] * t[None, :]
    zeros = np.zeros((n, t.size))
    return batch_from_records(t, x1, zeros, zeros, np.repeat(v[:, None], t.size, 1),
                              zeros, zeros + offset, zeros, zeros, mu)


def run(system: AEBSystem, batch: CaseBatch, equipped=(True, False), seed: int = 1):
    """Simulate ``batch`` with ``system``; returns (results, controller)."""
    controller = system.controller(batch, equipped)
    params = SimulationParams(precrash=system.precrash_params(PrecrashParams()))
    return simulate_cases(batch, controller, params, rng=np.random.default_rng(seed)), controller


def impact_speed(res) -> np.ndarray:
    """Impact speed of participant 1 [m/s], 0 where avoided."""
    return np.where(res.precrash.collided, res.precrash.impact_state.speed[:, 0], 0.0)


def single_stage(ttc: float = 1.5, deceleration: float = 6.0, latency: float = 0.0,
                 cycle: float = 0.05, **sensor) -> AEBSystem:
    """One full-braking stage held to the end, jerk-limited 40 m/s^3 actuator."""
    return AEBSystem(
        name="test-single", description="test",
        aeb=AEBParams(sensor=SensorParams(cycle_time=cycle, latency=latency, **sensor),
                      full_ttc=ttc, full_deceleration=deceleration, release="never"),
        driver=None, brake=BrakeActuatorParams(jerk=40.0, release_jerk=40.0))


def deterministic_driver(system: AEBSystem) -> AEBSystem:
    """``system`` with a driver who always brakes, after 1 s, at 6.4 m/s^2."""
    return dataclasses.replace(system, name=system.name + "-fixed-driver", driver=DriverParams(
        reaction_time=1.0, brake_share=1.0, deceleration_sd=0.0))


@pytest.fixture(scope="module")
def ccrs_runs():
    """Every preset on the CCRs grid, dry (mu 0.8) and slippery (mu 0.3)."""
    out = {}
    for mu in (0.8, 0.3):
        batch = ccrs_batch(SPEEDS_KMH, mu=mu)
        for name in SYSTEM_NAMES:
            out[name, mu] = run(get_system(name), batch)
        fixed = deterministic_driver(get_system("three-stage"))
        out["three-stage-fixed-driver", mu] = run(fixed, batch)
        out["baseline", mu] = (simulate_cases(batch), None)
    return out


# ----------------------------------------------------------------------------
# Registry and parameters
# ----------------------------------------------------------------------------


def test_registry_and_presets():
    assert SYSTEM_NAMES == ("none", "openpass-like", "three-stage", "ideal")
    assert system_names()[:5] == SYSTEM_NAMES + ("ideal-ctra",)
    for name in SYSTEM_NAMES:
        system = get_system(name)
        assert system.name == name and system.description
        base = PrecrashParams(dt=0.005)
        params = system.precrash_params(base)
        assert params.brake == system.brake and params.dt == 0.005
    assert get_system("none").aeb is None
    assert get_system("none").controller(ccrs_batch([30.0]), True) is None
    with pytest.raises(ParameterError, match="openpass-like"):
        get_system("nonexistent")
    mine = dataclasses.replace(get_system("three-stage"), name="test-registry-system")
    assert register_system(mine) is mine
    assert get_system("test-registry-system") is mine and "test-registry-system" in system_names()
    assert register_system(mine) is mine  # the same system again is fine
    with pytest.raises(ParameterError, match="already registered"):
        register_system(dataclasses.replace(get_system("ideal"), name="three-stage"))
    three = get_system("three-stage")
    assert three.aeb.thresholds == (2.6, 1.6, 0.6)
    assert three.driver == DriverParams()
    for name in SYSTEM_NAMES:  # sent to worker processes by vfs study
        assert pickle.loads(pickle.dumps(get_system(name))) == get_system(name)


def test_parameter_validation():
    for bad in (dict(range=0.0), dict(field_of_view=7.0), dict(cycle_time=-0.1),
                dict(latency=5.0), dict(detection_probability=1.5), dict(mount_x=np.nan)):
        with pytest.raises(ParameterError):
            SensorParams(**bad)
    for bad in (dict(prediction="ctrva"), dict(release="soon"), dict(ttc_horizon=0.0),
                dict(full_ttc=-1.0), dict(release_factor=0.5), dict(min_speed=5.0, max_speed=1.0),
                dict(full_ttc=None), dict(box_margin_lateral=-1.0), dict(ctrv_tolerance=0.0)):
        with pytest.raises(ParameterError):
            AEBParams(**bad)
    for bad in (dict(brake_share=1.2), dict(reaction_rate=0.0), dict(deceleration_min=7.0),
                dict(brake_lag=-0.1), dict(reaction_time=-1.0)):
        with pytest.raises(ParameterError):
            DriverParams(**bad)
    batch = ccrs_batch([30.0, 40.0])
    with pytest.raises(ParameterError, match="broadcast"):
        get_system("three-stage").controller(batch, np.ones((3, 2), bool))
    controller = get_system("three-stage").controller(batch, True)
    with pytest.raises(ParameterError, match="2 cases"):
        controller.reset(5, np.random.default_rng(0))


# ----------------------------------------------------------------------------
# Threat assessment kernels
# ----------------------------------------------------------------------------


def motion(x, y, yaw, heading, speed, yaw_rate=0.0, length=4.5, width=1.8, front=2.1,
           accel=0.0):
    """Motion of n vehicles (scalars broadcast)."""
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, float)) for a in (
        x, y, yaw, heading, speed, accel, yaw_rate, length, width, front)))
    x, y, yaw, heading, speed, accel, yaw_rate, length, width, front = arrays
    return Motion(x, y, yaw, heading, speed, accel, yaw_rate, 0.5 * length, 0.5 * width,
                  front - 0.5 * length)


def test_head_on_ttc_closed_form():
    # fronts 50 m apart, closing at 15 + 10 m/s: TTC = gap / closing speed = 2 s
    a = motion(0.0, 0.0, 0.0, 0.0, 15.0)
    b = motion(2.1 + 50.0 + 2.1, 0.0, np.pi, np.pi, 10.0)
    assert ttc_cv(a, b, 5.0)[0] == pytest.approx(2.0, abs=1e-12)
    assert time_to_collision(a, b, 5.0, "ctrv")[0] == pytest.approx(2.0, abs=1e-12)
    assert np.isinf(ttc_cv(a, b, 1.9)[0])  # beyond the horizon
    # a lateral offset of more than one width: no contact; overlapping: 0
    assert np.isinf(ttc_cv(a, motion(54.2, 1.81, np.pi, np.pi, 10.0), 5.0)[0])
    assert ttc_cv(a, motion(3.0, 0.5, 0.3, 0.3, 1.0), 5.0)[0] == 0.0


def brute_force_contact(a: Motion, b: Motion, horizon: float, step: float, ctrv: bool):
    """First sample time with positive overlap area (inf if none) and the smallest outline
    distance over the samples, by stepping the exact CV / CTRV poses."""
    t = np.arange(0.0, horizon + 1e-12, step)

    def poses(m: Motion):
        w = m.yaw_rate[0] if ctrv else 0.0
        v, h = m.speed[0], m.heading[0]
        if abs(w) < 1e-12:
            x, y = m.x[0] + v * t * np.cos(h), m.y[0] + v * t * np.sin(h)
        else:
            x = m.x[0] + v / w * (np.sin(h + w * t) - np.sin(h))
            y = m.y[0] - v / w * (np.cos(h + w * t) - np.cos(h))
        yaw = m.yaw[0] + w * t
        front = m.centre_offset[0] + m.half_length[0]
        return outline_corners(x, y, yaw, front, 2 * m.half_length[0] - front,
                               2 * m.half_width[0])

    oa, ob = poses(a), poses(b)
    hit = overlap(oa, ob).area > 1e-9
    first = t[np.argmax(hit)] if hit.any() else np.inf
    return first, float(outline_distance(oa, ob).min())


@given(st.floats(-12, 12), st.floats(-12, 12), st.floats(-np.pi, np.pi),
       st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi), st.floats(0, 25), st.floats(0, 25),
       st.floats(-0.3, 0.3), st.floats(3.0, 6.0), st.floats(1.5, 2.5))
def test_cv_ttc_matches_brute_force(x, y, yaw_a, yaw_b, heading_b, va, vb, slip, length,
                                    width):
    a = motion(0.0, 0.0, yaw_a, yaw_a + slip, va)
    b = motion(x, y, yaw_b, heading_b, vb, length=length, width=width, front=0.55 * length)
    horizon, step = 2.0, 1e-3
    ttc = ttc_cv(a, b, horizon)[0]
    first, closest = brute_force_contact(a, b, horizon, step, ctrv=False)
    closing = np.hypot(va * np.cos(yaw_a + slip) - vb * np.cos(heading_b),
                       va * np.sin(yaw_a + slip) - vb * np.sin(heading_b))
    if np.isfinite(first):
        # the overlap area must exceed 1e-9 m^2 to count: a corner contact needs a few
        # micrometres of penetration, which may take the brute force one more sample
        assert ttc <= first + 1e-9
        assert ttc >= first - 2 * step - 1e-9
    elif np.isfinite(ttc):
        # a graze between samples (or a touch without overlap area)
        assert closest <= closing * step + 1e-6


def test_ctrv_ttc_on_a_circle_matches_brute_force():
    # ego on a circle of radius 25 m at 10 m/s; stationary target straddling the circle
    # 60 deg ahead; a second, crossing target on the tangent
    radius, v = 25.0, 10.0
    ang = np.radians(60.0)
    a = motion(0.0, 0.0, 0.0, 0.0, v, yaw_rate=v / radius)
    b = motion(radius * np.sin(ang), radius * (1 - np.cos(ang)), ang + 0.5, ang + 0.5, 0.0)
    first, _ = brute_force_contact(a, b, 4.0, 1e-3, ctrv=True)
    ttc = time_to_collision(a, b, 4.0, "ctrv", tolerance=0.01)[0]
    assert np.isfinite(first) and ttc == pytest.approx(first, abs=0.01)
    # CV misses the target on the circle: the tangent runs outside it
    assert np.isinf(ttc_cv(a, b, 4.0)[0])
    c = motion(12.0, -6.0, np.pi / 2, np.pi / 2, 4.0, yaw_rate=-0.2)
    first, _ = brute_force_contact(a, c, 4.0, 1e-3, ctrv=True)
    assert time_to_collision(a, c, 4.0, "ctrv", tolerance=0.01)[0] == pytest.approx(
        first, abs=0.01)


def test_constant_acceleration_ttc_closed_form():
    # lead 20 m ahead of the subject's front at 10 m/s braking at 5 m/s^2 (stops after 2 s and
    # 10 m), subject at 15 m/s: 15 t = 20 + 10 t - 2.5 t^2 -> t = 2 s (CV: 20 / 5 = 4 s)
    a = motion(0.0, 0.0, 0.0, 0.0, 15.0)
    b = motion(2.1 + 20.0 + 2.4, 0.0, 0.0, 0.0, 10.0, accel=-5.0)
    assert ttc_cv(a, b, 5.0)[0] == pytest.approx(4.0)
    for model in ("ca", "ctra"):
        assert time_to_collision(a, b, 5.0, model, tolerance=0.01)[0] == pytest.approx(
            2.0, abs=1e-3)
    # once stopped the lead stays: 20 m + 10 m at 15 m/s with the lead braking at 10 m/s^2
    b = b._replace(accel=np.array([-10.0]))
    assert time_to_collision(a, b, 5.0, "ca", tolerance=0.01)[0] == pytest.approx(
        25.0 / 15.0, abs=1e-3)
    # accelerating subject from standstill: 5 m/s^2 over 20 m -> t = sqrt(8) s
    c = motion(0.0, 0.0, 0.0, 0.0, 0.0, accel=5.0)
    d = motion(2.1 + 20.0 + 2.4, 0.0, 0.0, 0.0, 0.0)
    assert time_to_collision(c, d, 5.0, "ca", tolerance=0.01)[0] == pytest.approx(
        np.sqrt(8.0), abs=1e-3)
    assert np.isinf(ttc_cv(c, d, 5.0)[0])


def test_braked_contact_is_exact_for_a_stationary_target():
    # fronts 20 m apart: braking at a after the delay d stops after v d + v^2 / (2 a)
    v, a_dec = 14.0, 8.0
    ego = motion(np.zeros(4), 0.0, 0.0, 0.0, v)
    target = motion(np.full(4, 2.1 + 20.0 + 2.4), 0.0, 0.0, 0.0, 0.0, front=2.1)
    stop = v**2 / (2 * a_dec)
    delay = (20.0 - stop) / v + np.array([-0.01, -0.001, 0.001, 0.01])
    hit = braked_contact(ego, target, delay, np.full(4, a_dec), horizon=4.0)
    np.testing.assert_array_equal(hit, [False, False, True, True])


# ----------------------------------------------------------------------------
# Sensor
# ----------------------------------------------------------------------------


@given(st.floats(-20, 20), st.floats(-20, 20), st.floats(-np.pi, np.pi), st.floats(1.0, 5.0),
       st.floats(0.5, 2.0), st.floats(-np.pi, np.pi), st.floats(0.05, 2 * np.pi))
def test_sector_distance_matches_shapely(cx, cy, yaw, length, width, boresight, fov):
    half = 0.5 * fov
    ours = sector_distance(np.zeros(1), np.zeros(1), np.array([boresight]), half,
                           np.array([cx]), np.array([cy]), np.array([yaw]),
                           np.array([0.5 * length]), np.array([0.5 * width]))[0]
    corners = outline_corners([cx], [cy], [yaw], [0.5 * length], [0.5 * length], [width])[0]
    rect = shapely.Polygon(corners)
    apex = shapely.Point(0.0, 0.0)
    # a sensor on the outline's edge touches it at one point, where shapely's intersection
    # with the wedge is empty or not by rounding: that case has its own test below
    assume(apex.distance(rect) > 1e-9)
    if fov >= 2 * np.pi - 1e-12:
        expected = apex.distance(rect)
    else:
        arc = boresight + np.linspace(-half, half, 721)
        wedge = shapely.Polygon(np.vstack([[0.0, 0.0], 1e3 * np.c_[np.cos(arc), np.sin(arc)]]))
        part = rect.intersection(wedge)
        expected = np.inf if part.is_empty else apex.distance(part)
    if np.isfinite(expected) or np.isfinite(ours):
        assert ours == pytest.approx(expected, abs=1e-6)


def test_an_outline_through_the_sensor_is_at_distance_zero():
    # the example hypothesis found: the outline's edge x = 0 passes through the sensor,
    # which looks away from it (boresight 3 rad, half-angle 0.5 rad); it touches the sensor
    args = (np.zeros(1), np.zeros(1), np.array([3.0]), 0.5, np.array([0.5]),
            np.array([0.25]), np.array([-np.pi]), np.array([0.5]), np.array([0.5]))
    assert sector_distance(*args)[0] == 0.0
    far = args[:4] + (np.array([0.6]),) + args[5:]  # 0.1 m away, behind the sensor
    assert sector_distance(*far)[0] == np.inf


def test_visibility_range_and_field_of_view():
    # a car 30 m straight ahead, seen by a 0.35 rad sensor with 150 m range ...
    args = (np.zeros(3), np.zeros(3), np.zeros(3), 0.175, np.array([32.25, 32.25, 10.0]),
            np.array([0.0, 0.0, 6.0]), np.zeros(3), np.full(3, 2.25), np.full(3, 0.9))
    d = sector_distance(*args)
    assert d[0] == pytest.approx(30.0) and d[1] == pytest.approx(30.0)
    # ... but not 6 m to the left at 10 m (bearing 31 deg; corners at >= 24 deg)
    assert np.isinf(d[2])


# ----------------------------------------------------------------------------
# CCRs: Euro NCAP-like car-to-car rear stationary grid
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("mu", [0.8, 0.3])
def test_none_changes_nothing(ccrs_runs, mu):
    base, _ = ccrs_runs["baseline", mu]
    res, controller = ccrs_runs["none", mu]
    assert controller is None
    for a, b in zip(base.precrash, res.precrash, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_array_equal(base.impact.delta_v[:, 0], res.impact.delta_v[:, 0])
    assert base.precrash.collided.all()
    # an AEB fitted to nobody changes nothing either
    batch = ccrs_batch(SPEEDS_KMH, mu=mu)
    quiet, _ = run(get_system("three-stage"), batch, equipped=False)
    for a, b in zip(base.precrash, quiet.precrash, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


# the stock three-stage system draws a different driver for every case, so on the slippery
# road (where the driver matters) monotonicity is checked with one fixed driver for all
@pytest.mark.parametrize("name, mu", [
    (name, mu) for mu in (0.8, 0.3)
    for name in ("none", "openpass-like", "three-stage", "three-stage-fixed-driver", "ideal")
    if (name, mu) != ("three-stage", 0.3)])
def test_impact_speed_monotone_in_test_speed(ccrs_runs, name, mu):
    res, _ = ccrs_runs[name, mu]
    speed = impact_speed(res)
    assert np.all(np.diff(speed) >= -1e-9), speed * 3.6
    assert np.all(speed <= SPEEDS_KMH / 3.6 + 1e-9)
    # the target stands still; the subject never speeds up
    assert np.all(res.precrash.speed_reduction[:, 0] >= -1e-12)
    assert np.isnan(res.precrash.brake_start[:, 1]).all()  # unequipped target: no braking


@pytest.mark.parametrize("mu", [0.8, 0.3])
def test_ideal_avoids_at_the_last_moment(ccrs_runs, mu):
    res, controller = ccrs_runs["ideal", mu]
    pre = res.precrash
    v = SPEEDS_KMH / 3.6
    assert not pre.collided.any()
    # it stopped less than one step's travel before the target (the last possible moment)
    assert np.all(pre.min_distance <= v * DT + 1e-3)
    assert np.all(pre.min_distance >= 0.0)
    ev = controller.events()
    np.testing.assert_array_equal(ev["full_time"][:, 0], pre.brake_start[:, 0])
    # TTC at the trigger ~ (stopping distance + half a step's travel) / v = v / (2 a) + dt
    a = mu * G
    np.testing.assert_allclose(ev["ttc_at_trigger"][:, 0], v / (2 * a) + DT, atol=1.01 * DT)


def test_ideal_brakes_from_the_first_moment_when_unavoidable():
    # 50 km/h, 0.5 ... 1.2 s before contact: the stopping distance 12.3 m (mu 0.8) fits
    # into the gap only from 0.9 s on; otherwise braking from t = 0 (acting from dt/2 as
    # the simulation averages the step) gives v_impact^2 = v^2 - 2 a (gap - v dt / 2)
    t_contact = np.array([0.505, 0.705, 0.905, 1.205])
    v, mu = 50.0 / 3.6, 0.8
    res, _ = run(get_system("ideal"), ccrs_batch(np.full(4, 50.0), mu=mu, t_contact=t_contact))
    a = mu * G
    gap = v * t_contact
    unavoidable = v**2 / (2 * a) + v * DT / 2 > gap
    np.testing.assert_array_equal(res.precrash.collided, unavoidable)
    expected = np.sqrt(np.maximum(v**2 - 2 * a * (gap - v * DT / 2), 0.0))
    contact_speed = res.precrash.contact_state.speed[:, 0]  # impact: 30 ms later, still braking
    np.testing.assert_allclose(contact_speed[unavoidable], expected[unavoidable], atol=0.02)
    np.testing.assert_allclose(res.precrash.brake_start[unavoidable, 0], 0.0)
    assert np.all(res.precrash.min_distance[~unavoidable] <= v * DT + 1e-3)


def test_three_stage_avoids_low_speeds_and_mitigates_50(ccrs_runs):
    res, controller = ccrs_runs["three-stage", 0.8]
    speed = impact_speed(res)
    low = SPEEDS_KMH <= 20.0
    assert not res.precrash.collided[low].any()
    assert speed[-1] < 50.0 / 3.6 - 5.0  # at least 18 km/h off at 50 km/h
    # the AEB alone (no driver reaction) as well
    alone, _ = run(dataclasses.replace(get_system("three-stage"), name="x", driver=None),
                   ccrs_batch(SPEEDS_KMH))
    assert not alone.precrash.collided[low].any()
    assert impact_speed(alone)[-1] < 50.0 / 3.6 - 5.0
    assert res.precrash.collided.sum() <= alone.precrash.collided.sum()


def test_three_stage_events(ccrs_runs):
    res, controller = ccrs_runs["three-stage", 0.8]
    ev = controller.events()
    assert set(ev) == set(EVENT_KEYS)
    for key in EVENT_KEYS:
        assert ev[key].shape == (SPEEDS_KMH.size, 2)
        assert np.isnan(ev[key][:, 1]).all()  # the target is not equipped
    warning, partial = ev["warning_time"][:, 0], ev["partial_time"][:, 0]
    # contact at 4.005 s: TTC 2.6 at 1.405 s, first measured on the 50 ms grid at 1.45 s,
    # acting 0.1 s later; partial braking at TTC 1.6 -> 2.45 + 0.1 s
    np.testing.assert_allclose(warning, 1.55, atol=1e-9)
    driver_first = ev["driver_brake_time"][:, 0] < 2.55
    np.testing.assert_allclose(partial[~driver_first], 2.55, atol=1e-9)
    # a driver who brakes before TTC 1.6 s may keep the TTC above it for good
    assert np.all(np.isnan(partial) <= driver_first)
    np.testing.assert_allclose(ev["ttc_at_trigger"][:, 0], 4.005 - 1.45, atol=1e-6)
    brakes = ~np.isnan(ev["driver_reaction_time"][:, 0])
    react = ev["driver_reaction_time"][:, 0][brakes]
    assert np.all((react > 0.0) & (react < 5.0))
    decel = ev["driver_deceleration"][:, 0][brakes]
    assert np.all((decel >= 3.0) & (decel <= 9.0))
    # the driver's demand starts on the first step at or after warning + reaction + lag
    started = ~np.isnan(ev["driver_brake_time"][:, 0])
    assert np.all(started <= brakes)
    planned = warning + ev["driver_reaction_time"][:, 0] + 0.2
    delay = ev["driver_brake_time"][:, 0][started] - planned[started]
    assert np.all((delay >= -1e-9) & (delay < DT + 1e-9))
    # braking started with the partial stage or the driver, whichever came first
    first = np.fmin(partial, ev["driver_brake_time"][:, 0])
    np.testing.assert_allclose(res.precrash.brake_start[:, 0], first, atol=1e-9)


def test_openpass_like_single_stage(ccrs_runs):
    res, controller = ccrs_runs["openpass-like", 0.8]
    ev = controller.events()
    assert np.isnan(ev["warning_time"]).all() and np.isnan(ev["partial_time"]).all()
    assert not res.precrash.collided.any()
    # outlines enlarged by 4 m: it triggers at TTC 2 s of the enlarged boxes, i.e. 4 m
    # (both boxes 2 m longer at each end) earlier than the real outlines would
    v = SPEEDS_KMH / 3.6
    true_ttc = 4.005 - ev["full_time"][:, 0]
    np.testing.assert_allclose(true_ttc, 2.0 + 4.0 / v, atol=DT + 1e-9)
    # it stops short of the target by more than the 2 m margin of each box
    assert np.all(res.precrash.min_distance > 2.0)


# ----------------------------------------------------------------------------
# Latency, cycle and build-up
# ----------------------------------------------------------------------------


def test_latency_delays_the_brake_start_by_exactly_the_latency():
    batch = ccrs_batch([30.0, 40.0])
    starts = {}
    for latency in (0.0, 0.07, 0.1, 0.25):
        res, controller = run(single_stage(latency=latency), batch)
        starts[latency] = res.precrash.brake_start[:, 0]
        np.testing.assert_array_equal(controller.events()["full_time"][:, 0], starts[latency])
    for latency, start in starts.items():
        np.testing.assert_allclose(start - starts[0.0], latency, atol=1e-9)
    # the trigger is the first 50 ms measurement with TTC <= 1.5 s: 2.505 s -> 2.55 s
    np.testing.assert_allclose(starts[0.0], 2.55, atol=1e-9)


def test_aeb_equals_scheduled_braking_with_the_same_actuator():
    # the AEB adds nothing to the braking but its start: the same actuator driven by
    # ScheduledBraking from the AEB's brake start gives identical results
    batch = ccrs_batch([30.0, 50.0], mu=0.5)
    system = single_stage(latency=0.1)
    res, controller = run(system, batch)
    start = controller.events()["full_time"]
    demand = np.minimum(6.0, 0.5 * G)
    scheduled = ScheduledBraking(start, np.where(np.isnan(start), 0.0, demand))
    ref = simulate_cases(batch, scheduled,
                         SimulationParams(precrash=system.precrash_params(PrecrashParams())))
    for name in ("collided", "contact_time", "brake_start", "speed_reduction", "min_distance"):
        np.testing.assert_array_equal(getattr(res.precrash, name), getattr(ref.precrash, name))
    np.testing.assert_array_equal(res.precrash.impact_state.speed, ref.precrash.impact_state.speed)


def test_jerk_limited_build_up_stopping_distance_closed_form():
    # from the brake start the subject stops after v t_r - J t_r^3 / 6 + (v - a t_r / 2)^2 / (2 a)
    # (t_r = a / J: the ramp of the 40 m/s^3 actuator; docs/physics.md section 4)
    v_kmh = np.array([30.0, 40.0])
    v = v_kmh / 3.6
    res, _ = run(single_stage(ttc=2.0, latency=0.1), ccrs_batch(v_kmh))
    pre = res.precrash
    assert not pre.collided.any()
    a, jerk = 6.0, 40.0
    t_r = a / jerk
    closed = v * t_r - jerk * t_r**3 / 6 + (v - a * t_r / 2) ** 2 / (2 * a)
    x_start = (-2.4 - 2.1 - v * 4.005) + v * pre.brake_start[:, 0]
    np.testing.assert_allclose(pre.end_state.x[:, 0] - x_start, closed, atol=0.01)


# ----------------------------------------------------------------------------
# Sensor in the loop
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("sensor", [dict(range=0.01), dict(mount_yaw=np.pi),
                                    dict(detection_probability=0.0),
                                    dict(field_of_view=0.35, mount_y=-5.0, mount_yaw=-0.5)])
def test_no_trigger_without_detection(sensor):
    res, controller = run(single_stage(**sensor), ccrs_batch([20.0, 40.0]))
    assert res.precrash.collided.all()
    assert np.isnan(res.precrash.brake_start).all()
    for key in ("full_time", "ttc_at_trigger"):
        assert np.isnan(controller.events()[key]).all()


def test_detection_probability_delays_and_is_reproducible():
    batch = ccrs_batch(np.full(8, 30.0))
    sure, _ = run(single_stage(), batch)
    res_a, ctrl_a = run(single_stage(detection_probability=0.3), batch, seed=5)
    res_b, ctrl_b = run(single_stage(detection_probability=0.3), batch, seed=5)
    res_c, _ = run(single_stage(detection_probability=0.3), batch, seed=6)
    start = res_a.precrash.brake_start[:, 0]
    np.testing.assert_array_equal(start, res_b.precrash.brake_start[:, 0])
    assert np.all(start >= sure.precrash.brake_start[:, 0] - 1e-9)
    assert np.any(start > sure.precrash.brake_start[:, 0] + 1e-9)
    assert not np.array_equal(start, res_c.precrash.brake_start[:, 0])


def test_reproducible_for_the_same_seed(ccrs_runs):
    batch = ccrs_batch(SPEEDS_KMH)
    system = get_system("three-stage")
    again, ctrl = run(system, batch, seed=1)
    first, ctrl_first = ccrs_runs["three-stage", 0.8]
    for a, b in zip(first.precrash, again.precrash, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    for key, value in ctrl_first.events().items():
        np.testing.assert_array_equal(value, ctrl.events()[key])
    _, other = run(system, batch, seed=2)
    assert not np.array_equal(np.nan_to_num(other.events()["driver_reaction_time"]),
                              np.nan_to_num(ctrl.events()["driver_reaction_time"]))


# ----------------------------------------------------------------------------
# A turning object: where the prediction model matters
# ----------------------------------------------------------------------------


def turning_batch(radius: float = 10.0, v_ego: float = 14.0, v_obj: float = 5.0,
                  t_contact: float = 4.0) -> CaseBatch:
    """The object drives ahead in the left lane (y = 3.5 m) and turns right across the
    subject's lane on an arc of ``radius``; the subject hits its side at ``t_contact``."""
    t = np.arange(0.0, 6.0 + 1e-9, DT)
    phi_c = np.arccos((radius - 3.5) / radius)  # turn angle where it crosses y = 0
    s = v_obj * (t - t_contact) + phi_c * radius  # arc length since the start of the turn
    quarter = 0.5 * np.pi * radius
    phi = np.clip(s / radius, 0.0, 0.5 * np.pi)
    x0 = -radius * np.sin(phi_c)
    x = np.where(s < 0, x0 + s, np.where(s > quarter, x0 + radius, x0 + radius * np.sin(phi)))
    y = np.where(s < 0, 3.5, np.where(s > quarter, 3.5 - radius - (s - quarter),
                                      3.5 - radius + radius * np.cos(phi)))
    x_ego = -0.9 - 2.1 + v_ego * (t - t_contact)
    zeros = np.zeros((1, t.size))
    return batch_from_records(t, x_ego[None, :], zeros, zeros, zeros + v_ego, x[None, :],
                              y[None, :], -phi[None, :], zeros + v_obj, 0.8)


def test_ideal_needs_ctrv_for_a_turning_object():
    batch = turning_batch()
    assert simulate_cases(batch).precrash.collided[0]
    ideal = get_system("ideal")
    outcome = {}
    for model in ("cv", "ctrv"):
        system = dataclasses.replace(ideal, name=f"ideal-{model}",
                                     aeb=dataclasses.replace(ideal.aeb, prediction=model))
        res, controller = run(system, batch)
        outcome[model] = res.precrash, controller.events()
    # the straight-line prediction sees the turning object too late ...
    assert outcome["cv"][0].collided[0]
    # ... the turn-rate prediction brakes earlier and just avoids the contact
    assert not outcome["ctrv"][0].collided[0]
    assert outcome["ctrv"][0].min_distance[0] < 0.5
    assert outcome["ctrv"][1]["full_time"][0, 0] < outcome["cv"][1]["full_time"][0, 0]


def ccrb_batch(headway: float = 12.0, v_kmh: float = 50.0, decel: float = 6.0,
               t_brake: float = 1.0) -> CaseBatch:
    """Euro NCAP CCRb-like: subject and target at the same speed, ``headway`` [m] between the
    bumpers; the target brakes at ``decel`` from ``t_brake`` to standstill."""
    v = v_kmh / 3.6
    t = np.arange(0.0, 6.0 + 1e-9, DT)
    braking = np.clip(t - t_brake, 0.0, v / decel)
    x2 = v * np.minimum(t, t_brake) + v * braking - 0.5 * decel * braking**2
    v2 = v - decel * braking
    x1 = -headway - 4.5 + v * t
    zeros = np.zeros((1, t.size))
    return batch_from_records(t, x1[None, :], zeros, zeros, zeros + v, x2[None, :], zeros,
                              zeros, v2[None, :], 0.8)


def test_ideal_with_acceleration_handles_a_braking_lead():
    # CV takes the braking lead for one that keeps its current speed and brakes too late
    batch = ccrb_batch()
    assert simulate_cases(batch).precrash.collided[0]
    cv, _ = run(get_system("ideal"), batch)
    ctra, _ = run(get_system("ideal-ctra"), batch)
    assert cv.precrash.collided[0]
    assert not ctra.precrash.collided[0]
    assert ctra.precrash.min_distance[0] < 0.2  # still the last moment


def test_ideal_does_not_brake_for_a_vehicle_from_behind():
    # the target (participant 2) runs into the equipped participant 1 from behind: braking
    # cannot avoid that and would only make it worse, so the ideal system does not brake
    v = np.array([20.0, 30.0])[:, None] / 3.6
    closing, t_contact = 10.0 / 3.6, 4.005
    t = np.arange(0.0, 6.0 + 1e-9, DT)[None, :]
    zeros = np.zeros((2, t.size))
    lead = v * t  # participant 1 ahead, slower; its rear 2.4 m behind its CG
    chaser = lead - 4.5 - closing * (t_contact - t)  # front 2.1 m ahead of its CG
    batch = batch_from_records(t[0], lead, zeros, zeros, zeros + v, chaser, zeros, zeros,
                               zeros + v + closing, 0.8)
    assert simulate_cases(batch).precrash.collided.all()
    res, controller = run(get_system("ideal"), batch)
    assert res.precrash.collided.all()
    assert np.isnan(res.precrash.brake_start[:, 0]).all()
    assert np.isnan(controller.events()["full_time"]).all()
