"""Pre-crash tests written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): the scene turned, shifted and mirrored (the
other tests drive along +x), the vehicles exchanged, braking in any direction, and each
bound of the parameters.  Public behaviour only: closed forms and invariances.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.errors import ParameterError
from vfs.physics.paths import pack_paths
from vfs.physics.precrash import (
    BrakeActuatorParams,
    PrecrashParams,
    ScheduledBraking,
    SegmentedRandom,
    reset_controller,
    simulate_precrash,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

CAR = VehicleParams(mass=1500.0, length=4.5, width=1.8, wheelbase=2.7, cg_to_front_axle=1.2,
                    front_overhang=0.9)  # CG 2.1 m behind the front bumper, 2.4 m before the rear


def line(x0: float, y0: float, yaw: float, v: float, duration: float = 5.0, dt: float = 0.01):
    """A straight record: start (x0, y0) [m], heading yaw [rad], speed v [m/s]."""
    t = np.arange(0.0, duration + 1e-9, dt)
    return (t, x0 + v * np.cos(yaw) * t, y0 + v * np.sin(yaw) * t, np.full(t.size, yaw),
            np.full(t.size, v))


def pack(records):
    parts = [np.concatenate(c) for c in zip(*records, strict=True)]
    group = np.concatenate([np.full(len(r[0]), i) for i, r in enumerate(records)])
    return pack_paths(*parts, group=group)


def moved(rec, angle: float, dx: float, dy: float, mirror: bool = False):
    """A record mirrored (y -> -y) if asked, then turned by ``angle`` and shifted."""
    t, x, y, yaw, v = rec
    if mirror:
        y, yaw = -y, -yaw
    c, s = np.cos(angle), np.sin(angle)
    return t, c * x - s * y + dx, s * x + c * y + dy, yaw + angle, v


def scene():
    """Three cases: head-on with a lateral offset, a 60 deg crossing, a rear-end."""
    return [
        (line(0.0, 0.0, 0.0, 20.0), line(60.0, 0.8, np.pi, 10.0)),
        (line(0.0, 0.0, 0.0, 15.0), line(25.5, -19.5 * np.sqrt(3.0), np.radians(60.0), 13.0)),
        (line(0.0, 0.0, 0.0, 25.0), line(40.0, 0.3, 0.0, 10.0)),
    ]


def run(cases, controller=None, **kw):
    n = len(cases)
    paths = pack([c[0] for c in cases] + [c[1] for c in cases])
    v = stack_vehicles([CAR] * n)
    return simulate_precrash(v, v, paths, np.full(n, 0.8), controller=controller, **kw)


@pytest.mark.parametrize("angle, dx, dy, mirror", [(0.9, 30.0, -12.0, False),
                                                   (-2.4, -500.0, 80.0, False),
                                                   (0.0, 0.0, 0.0, True),
                                                   (2.0, 7.0, 7.0, True)])
def test_turning_shifting_and_mirroring_the_scene(angle, dx, dy, mirror) -> None:
    base = run(scene())
    assert base.collided.all()
    other = run([tuple(moved(r, angle, dx, dy, mirror) for r in c) for c in scene()])
    np.testing.assert_array_equal(other.collided, base.collided)
    np.testing.assert_allclose(other.contact_time, base.contact_time, atol=1e-6)
    np.testing.assert_allclose(other.impact_time, base.impact_time, atol=1e-6)
    np.testing.assert_allclose(other.overlap_area, base.overlap_area, rtol=1e-6, atol=1e-9)
    c, s = np.cos(angle), np.sin(angle)
    py = -base.poi[:, 1] if mirror else base.poi[:, 1]
    np.testing.assert_allclose(other.poi[:, 0], c * base.poi[:, 0] - s * py + dx, atol=1e-6)
    np.testing.assert_allclose(other.poi[:, 1], s * base.poi[:, 0] + c * py + dy, atol=1e-6)
    sign = -1.0 if mirror else 1.0
    d = np.mod(other.cp_angle - (sign * base.cp_angle + angle) + np.pi / 2, np.pi) - np.pi / 2
    np.testing.assert_allclose(d, 0.0, atol=1e-6)
    st, bt = other.impact_state, base.impact_state
    np.testing.assert_allclose(np.hypot(st.vx, st.vy), np.hypot(bt.vx, bt.vy), atol=1e-9)
    np.testing.assert_allclose(st.vx, c * bt.vx - s * sign * bt.vy, atol=1e-9)
    dyaw = np.mod(st.yaw - (sign * bt.yaw + angle) + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(dyaw, 0.0, atol=1e-9)


def test_contact_times_in_closed_form() -> None:
    base = run(scene())
    # head-on, fronts 60 - 4.2 m apart closing at 30 m/s; rear-end: 40 - 4.5 m at 15 m/s
    assert base.contact_time[0] == pytest.approx((60.0 - 4.2) / 30.0, abs=1e-3)
    assert base.contact_time[2] == pytest.approx((40.0 - 4.5) / 15.0, abs=1e-3)
    np.testing.assert_allclose(base.impact_time - base.contact_time, 0.030, atol=1e-9)
    # 30 ms of penetration: overlap length 0.9 m (head-on, 1.0 m of the width engaged)
    assert base.overlap_area[0] == pytest.approx(0.9 * 1.0, rel=0.03)
    assert base.overlap_area[2] == pytest.approx(0.45 * 1.5, rel=0.03)
    # the impact speeds are the recorded ones (no braking)
    np.testing.assert_allclose(np.hypot(base.impact_state.vx, base.impact_state.vy),
                               [[20.0, 10.0], [15.0, 13.0], [25.0, 10.0]], atol=1e-9)
    np.testing.assert_array_equal(base.speed_reduction, 0.0)
    assert np.isnan(base.brake_start).all()


def test_exchanging_the_vehicles() -> None:
    base = run(scene())
    swapped = run([(c[1], c[0]) for c in scene()])
    np.testing.assert_allclose(swapped.contact_time, base.contact_time, atol=1e-6)
    np.testing.assert_allclose(swapped.poi, base.poi, atol=1e-6)
    np.testing.assert_allclose(swapped.overlap_area, base.overlap_area, rtol=1e-6)
    np.testing.assert_allclose(swapped.impact_state.x, base.impact_state.x[:, ::-1], atol=1e-6)
    np.testing.assert_allclose(swapped.impact_state.vy, base.impact_state.vy[:, ::-1],
                               atol=1e-9)


@pytest.mark.parametrize("heading", [np.pi / 2, -2.5, np.pi])
def test_braking_in_any_direction_stops_at_the_same_distance(heading: float) -> None:
    mu, jerk, v0, t_b = 0.8, 40.0, 20.0, 1.0
    params = PrecrashParams(brake=BrakeActuatorParams(jerk=jerk, max_deceleration=20.0))
    ctl = ScheduledBraking([[t_b, np.nan]], [[50.0, 0.0]])
    far = moved(line(2000.0, 0.0, 0.0, 0.0, 8.0), heading, 0.0, 0.0)
    res = run([(line(0.0, 0.0, heading, v0, 8.0), far)], controller=ctl, params=params)
    assert not res.collided[0] and res.end_state.speed[0, 0] == 0.0
    travelled = np.hypot(res.end_state.x[0, 0], res.end_state.y[0, 0]) - v0 * t_b
    t_r = mu * G / jerk
    v1 = v0 - 0.5 * mu * G * t_r
    expected = v0 * t_r - jerk * t_r**3 / 6 + v1**2 / (2 * mu * G)
    assert travelled == pytest.approx(expected, rel=0.01)
    assert res.speed_reduction[0, 0] == v0  # the speed taken off, not the integrated dv
    assert res.speed_reduction[0, 1] == 0.0 and res.brake_start[0, 0] == pytest.approx(t_b)
    ang = np.arctan2(res.end_state.y[0, 0], res.end_state.x[0, 0])
    assert np.cos(ang - heading) == pytest.approx(1.0)


@pytest.mark.parametrize("field, ok, bad", [
    ("dt", (1e-4, 0.1), (0.99e-4, 0.1001)),
    ("penetration_time", (0.0, 0.5), (-1e-9, 0.5001)),
    ("extra_time", (0.0, 60.0), (-1e-9, 60.001)),
])
def test_parameter_bounds_are_closed(field: str, ok, bad) -> None:
    for value in ok:
        kw = {field: value}
        if field == "dt":
            kw["contact_tolerance"] = min(value, 5e-5)
        assert getattr(PrecrashParams(**kw), field) == value
    for value in bad:
        with pytest.raises(ParameterError, match=field):
            PrecrashParams(**{field: value})


def test_contact_tolerance_and_segmented_random() -> None:
    assert PrecrashParams(contact_tolerance=0.01).contact_tolerance == 0.01  # = dt
    for tol in (0.0, 0.0101):
        with pytest.raises(ParameterError, match="contact_tolerance"):
            PrecrashParams(contact_tolerance=tol)
    g = [np.random.default_rng(1), np.random.default_rng(2)]
    seg = SegmentedRandom.of([2, 3], g)
    assert seg.sizes == (2, 3) and len(seg.generators) == 2
    for sizes, gens in (([2], g), ([2, 0], g), ([1, 1, 1], g)):
        with pytest.raises(ParameterError, match="one generator per segment"):
            SegmentedRandom.of(sizes, gens)

    class Plain:
        def reset(self, n, rng):
            self.n, self.rng = n, rng

    class Segmented(Plain):
        def reset_segments(self, sizes, generators):
            self.sizes = sizes

    plain, segmented = Plain(), Segmented()
    reset_controller(plain, 4, None)
    assert plain.n == 4 and isinstance(plain.rng, np.random.Generator)
    reset_controller(segmented, 5, seg)
    assert segmented.sizes == (2, 3) and not hasattr(segmented, "n")
    with pytest.raises(ParameterError, match="reset_segments"):
        reset_controller(plain, 5, seg)
    with pytest.raises(ParameterError, match="covers 5 cases"):
        reset_controller(segmented, 6, seg)
    with pytest.raises(ParameterError, match="first_step"):
        run(scene()[:1], controller=ScheduledBraking([[1.0, np.nan]], [[5.0, 0.0]]),
            first_step=[0])
