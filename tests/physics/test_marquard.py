"""Marquard's relations (vfs.physics.marquard) against closed forms and the run-out model."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics.marquard import (
    ROTATION_FACTOR_MAX,
    post_impact_speed,
    reaches_rest,
    remaining_speed,
    rotation_factor,
    translation_factor,
)
from vfs.physics.runout import RunoutParams, RunoutState, run_out
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

pytestmark = pytest.mark.usefixtures("both_runout_paths")


def test_factors_at_the_limits():
    # no rotation: the whole energy goes into translation, k_s = 1 (eq. 3)
    assert translation_factor(0.0) == 1.0
    # the cubic as printed, at k = 1
    assert translation_factor(1.0) == pytest.approx(0.17 - 0.488 - 0.03 + 1)
    # k = |dphi| l / (2 s): a quarter turn of a 4.5 m car over 3 m
    assert rotation_factor(np.pi / 2, 4.5, 3.0) == pytest.approx(np.pi / 2 * 4.5 / 6.0)
    assert rotation_factor(-np.pi / 2, 4.5, 3.0) == rotation_factor(np.pi / 2, 4.5, 3.0)


def test_straight_slide_is_the_textbook_formula():
    s, mu = np.array([1.0, 10.0, 40.0]), np.array([0.3, 0.7, 1.0])
    np.testing.assert_allclose(post_impact_speed(s, 0.0, 4.5, mu), np.sqrt(2 * mu * G * s),
                               rtol=1e-15)
    # more rotation, less translation work for the same distance: a lower speed
    v = post_impact_speed(10.0, np.array([0.0, 0.5, 1.0, 2.0]), 4.5, 0.7)
    assert np.all(np.diff(v) < 0)


@pytest.mark.parametrize("brake", [1.0, 0.8, 0.5])
@pytest.mark.parametrize(("speed", "mu"), [(6.0, 0.8), (15.0, 0.5), (25.0, 0.9)])
def test_marquard_agrees_with_the_run_out_model_on_straight_slides(speed, mu, brake):
    # a straight run-out with every wheel braked by the factor b: the longitudinal force is
    # mu N on a locked wheel and (b mu + f_r) N on a rolling braked one (rolling resistance
    # f_r), so the work mu_used m g s = m v^2 / 2 with mu_used = braking_friction(...), and
    # Marquard must return the initial speed; the run-out's distance is within 1 % of the
    # closed form
    # (test_runout.test_locked_straight_slide_stops_after_v2_over_2_mu_g), hence the
    # speed within 0.5 %
    car = stack_vehicles([VehicleParams()])
    state = RunoutState.from_arrays(0.0, 0.0, 0.3, speed * np.cos(0.3), speed * np.sin(0.3), 0.0)
    res = run_out(car, state, mu, RunoutParams(), wheel_brake=(brake,) * 4)
    assert res.at_rest[0]
    s = np.hypot(res.rest_x[0], res.rest_y[0])
    from vfs.analysis.marquard import braking_friction

    used = braking_friction(np.array([mu]), np.full((1, 4), brake),
                            RunoutParams().rolling_resistance)[0]
    assert used == (mu if brake == 1.0 else brake * mu + 0.015)
    v = post_impact_speed(s, res.rest_yaw[0] - 0.3, car.length[0], used)
    assert v == pytest.approx(speed, rel=0.005)


def test_fitted_range_ends_where_the_translation_factor_stops_falling():
    # dk_s/dk = 0.51 k^2 - 0.976 k - 0.03 = 0 (eq. 3 differentiated), positive root
    k_star = (0.976 + np.sqrt(0.976**2 + 4 * 0.51 * 0.03)) / (2 * 0.51)
    assert ROTATION_FACTOR_MAX == pytest.approx(k_star, rel=1e-12)
    k = np.linspace(0.0, ROTATION_FACTOR_MAX, 2001)
    ks = translation_factor(k)
    # more rotation per metre, less translation braking: strictly falling, positive
    assert np.all(np.diff(ks) < 0) and ks.min() > 0.3
    # beyond the range the printed cubic would rise again (k_s(3) = 1.11 > k_s(1.5)):
    # vfs returns NaN there, the guard fires
    assert 0.17 * 27 - 0.488 * 9 - 0.09 + 1 > 1.1
    assert np.isnan(translation_factor([ROTATION_FACTOR_MAX + 1e-9, 2.5, 3.0])).all()
    assert np.isnan(post_impact_speed(1.0, np.pi, 4.5, 0.8))  # k = 7.1


def test_rotating_regime_speed_falls_with_rotation_and_is_bounded():
    # for a given distance, V' falls monotonically with rotation up to the range end and
    # never exceeds the straight slide's sqrt(2 mu g s) (k_s <= 1) nor falls below
    # sqrt(2 k_s(k*) mu g s)
    s, mu, length = 8.0, 0.7, 4.5
    dphi = np.linspace(0.0, ROTATION_FACTOR_MAX * 2 * s / length, 400)
    v = post_impact_speed(s, dphi, length, mu)
    assert np.isfinite(v).all() and np.all(np.diff(v) < 0)
    straight = np.sqrt(2 * mu * G * s)
    assert v[0] == pytest.approx(straight) and v[-1] >= np.sqrt(
        2 * translation_factor(ROTATION_FACTOR_MAX) * mu * G * s) * (1 - 1e-12)


def test_eq12_forward_and_eq13_acceptance_invert_the_backward_form():
    rng = np.random.default_rng(3)
    s = rng.uniform(1, 30, 200)
    length = rng.uniform(3.5, 5.0, 200)
    k = rng.uniform(0, ROTATION_FACTOR_MAX, 200)
    dphi = k * 2 * s / length
    mu = rng.uniform(0.3, 1.0, 200)
    v_post = post_impact_speed(s, dphi, length, mu)
    # the backward speed leaves nothing (eq. 12 with V_k = 0) ...
    np.testing.assert_allclose(remaining_speed(v_post, s, dphi, length, mu), 0.0, atol=1e-6)
    assert not reaches_rest(0.0)  # eq. 13's strict lower bound
    # ... and a speed that leaves V_k = 0.3 m/s is accepted by eq. 13, 0.6 m/s is not
    for v_k, accepted in ((0.3, True), (0.6, False)):
        v = np.sqrt(v_post**2 + v_k**2)
        left = remaining_speed(v, s, dphi, length, mu)
        np.testing.assert_allclose(left, v_k, rtol=1e-9)
        assert (reaches_rest(left) == accepted).all()


def test_rotating_run_out_against_marquard():
    # a locked-wheel run-out with a yaw rate: the tyre model dissipates the rotation
    # too, so Marquard (translation only, k_s < 1) is only approximate. The bound that
    # holds exactly: with locked wheels the tyre forces are mu N, never more, so the
    # translational kinetic energy m v^2 / 2 <= mu m g x (CG path length) and the CG
    # path >= the straight distance s: Marquard's V' with k_s <= 1 stays below
    # sqrt(2 mu g path); and within the fitted range it must be the right order (the
    # measured spread on the bundled database, docs/physics.md: 10-90 % 0.71-1.22)
    car = stack_vehicles([VehicleParams()])
    mu = 0.8
    for speed, yaw_rate in ((10.0, 1.5), (12.0, 2.5), (8.0, 3.0)):
        state = RunoutState.from_arrays(0.0, 0.0, 0.0, speed, 0.0, yaw_rate)
        res = run_out(car, state, mu, RunoutParams(), wheel_brake=(1.0,) * 4)
        assert res.at_rest[0]
        s = np.hypot(res.rest_x[0], res.rest_y[0])
        k = rotation_factor(res.rest_yaw[0], car.length[0], s)
        assert 0.1 < k < ROTATION_FACTOR_MAX
        v = post_impact_speed(s, res.rest_yaw[0], car.length[0], mu)
        assert 0.6 * speed < v < 1.3 * speed
