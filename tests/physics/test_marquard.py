"""Marquard's relations (vfs.physics.marquard) against closed forms and the run-out model."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics.marquard import correction_factors, post_impact_speed, rotation_factor
from vfs.physics.runout import RunoutParams, RunoutState, run_out
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G


def test_factors_at_the_limits():
    # no rotation: the whole energy goes into translation, k_s = 1, k_phi = 0 (eqs. 3-4)
    ks, kphi = correction_factors(0.0)
    assert ks == 1.0 and kphi == 0.0
    # the cubics as printed, at k = 1
    ks, kphi = correction_factors(1.0)
    assert ks == pytest.approx(0.17 - 0.488 - 0.03 + 1) and kphi == pytest.approx(
        0.328 - 0.772 + 1.072)
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
