"""Fixed-object impacts (barrier, wall, pole): the impulse model's limit 1/m = 0.

Oracles:

* the limit itself: a fixed object (m = I = inf) gives the same outcome as a
  vehicle of mass M = 1e9 kg up to the terms the finite mass adds to the
  compliance matrix K (relative size m1 / M + m1 |r2|^2 / I2, derived below);
* the invariant of the free vehicle: its linear momentum is not conserved (the
  object takes the impulse S), but its angular momentum about the (fixed) POI
  P is.  With r1 = P - CG1, L_P = I1 w1 - r1 x (m1 v1); the impulse changes
  v1 by S / m1 and w1 by (r1 x S) / I1, so dL_P = r1 x S - r1 x S = 0;
* the collinear central barrier impact: v1' = -eps v1 (the velocity ratio
  equals the impulse ratio when the other body cannot move);
* energy is never gained and all of the loss is the free vehicle's EES.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.physics.impact import (
    FIXED_OBJECT_MASS,
    IMPACT_FULL,
    IMPACT_NONE,
    ImpactConfig,
    config_problems,
    fixed_object,
    inverse_mass,
    solve_impact,
)

INF = FIXED_OBJECT_MASS


def barrier_config(**over: object) -> ImpactConfig:
    """Vehicle 1 (heading +x at 15.64 m/s) into a wall at x = 2.3 m (participant 2)."""
    base: dict[str, object] = dict(
        m1=1703.0, izz1=2771.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=15.64, vy1=0.0, yaw_rate1=0.0,
        m2=INF, izz2=INF, x2=3.3, y2=0.0, yaw2=0.0, vx2=0.0, vy2=0.0, yaw_rate2=0.0,
        poi_x=2.3, poi_y=0.0, cp_angle=np.pi / 2, restitution=0.19, contact_friction=0.6)
    base.update(over)
    return ImpactConfig.from_columns(**base)


def test_inverse_mass_of_fixed_object_is_exactly_zero():
    assert inverse_mass(INF)[()] == 0.0
    assert inverse_mass(np.array([2.0, INF])).tolist() == [0.5, 0.0]
    assert fixed_object([INF, INF, 1000.0], [INF, 2000.0, INF]).tolist() == [True, False, False]


@pytest.mark.parametrize("eps", [0.0, 0.19, 1.0])
def test_central_barrier_impact_rebounds_with_minus_eps_v(eps):
    c = barrier_config(restitution=eps)
    r = solve_impact(c)
    np.testing.assert_allclose(r.vx_post[:, 0], -eps * 15.64, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.vy_post[:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(r.yaw_rate_post[:, 0], 0.0, atol=1e-12)
    # the object does not move, and all the loss is vehicle 1's deformation energy
    assert r.vx_post[0, 1] == 0.0 and r.yaw_rate_post[0, 1] == 0.0 and r.ees[0, 1] == 0.0
    loss = 0.5 * 1703.0 * 15.64**2 * (1.0 - eps**2)
    np.testing.assert_allclose(r.energy_loss, loss, rtol=1e-12)
    np.testing.assert_allclose(0.5 * 1703.0 * r.ees[:, 0]**2, loss, rtol=1e-12)


def test_fixed_object_may_be_either_participant():
    c = barrier_config(x1=3.3, x2=0.0, m1=INF, izz1=INF, vx1=0.0, m2=1703.0, izz2=2771.0,
                       vx2=15.64, restitution=0.3)
    r = solve_impact(c)
    np.testing.assert_allclose(r.vx_post[:, 1], -0.3 * 15.64, atol=1e-12)
    assert r.vx_post[0, 0] == 0.0 and r.ees[0, 0] == 0.0


def test_config_problems_accept_one_fixed_object_only():
    assert config_problems(barrier_config()) == {}
    both = barrier_config(m1=INF, izz1=INF)
    assert set(config_problems(both)) == {"m1", "m2", "izz1", "izz2"}
    half = barrier_config(izz2=5000.0)  # infinite mass but finite inertia: not an object
    assert set(config_problems(half)) == {"m2"}


configs = st.fixed_dictionaries(dict(
    m1=st.floats(600.0, 3000.0), izz1=st.floats(500.0, 6000.0),
    yaw1=st.floats(-np.pi, np.pi), vx1=st.floats(-30.0, 30.0), vy1=st.floats(-30.0, 30.0),
    yaw_rate1=st.floats(-2.0, 2.0), poi_x=st.floats(-2.5, 2.5), poi_y=st.floats(-1.5, 1.5),
    cp_angle=st.floats(-np.pi, np.pi), restitution=st.floats(0.0, 1.0),
    contact_friction=st.floats(0.0, 1.2),
    x2=st.floats(-4.0, 4.0), y2=st.floats(-4.0, 4.0),
))


def _with_object(d: dict[str, float], m2: float, izz2: float) -> ImpactConfig:
    return ImpactConfig.from_columns(x1=0.0, y1=0.0, m2=m2, izz2=izz2, yaw2=0.0, vx2=0.0,
                                    vy2=0.0, yaw_rate2=0.0, **d)


@settings(max_examples=300, deadline=None)
@given(configs)
def test_angular_momentum_of_free_vehicle_about_poi_is_conserved(d):
    c = _with_object(d, INF, INF)
    r = solve_impact(c)
    r1x, r1y = c.poi_x - c.x[:, 0], c.poi_y - c.y[:, 0]

    def l_poi(vx, vy, w):  # I1 w1 - r1 x (m1 v1), about the fixed POI [kg m^2/s]
        return c.izz[:, 0] * w - c.m[:, 0] * (r1x * vy - r1y * vx)

    before = l_poi(c.vx[:, 0], c.vy[:, 0], c.yaw_rate[:, 0])
    after = l_poi(r.vx_post[:, 0], r.vy_post[:, 0], r.yaw_rate_post[:, 0])
    scale = c.m[:, 0] * (np.abs(c.vx[:, 0]) + np.abs(c.vy[:, 0])
                         + 3.0 * np.abs(c.yaw_rate[:, 0]) + 1.0) * 5.0
    assert np.all(np.abs(after - before) <= 1e-10 * scale)
    # linear momentum is not conserved: it changes by exactly the impulse
    assert np.all(np.abs(c.m[:, 0] * (r.vx_post[:, 0] - c.vx[:, 0]) - r.impulse_x)
                  <= 1e-9 * (1.0 + np.abs(r.impulse_x)))
    # the object stays at rest, energy is never gained
    assert np.all(r.vx_post[:, 1] == 0.0) and np.all(r.yaw_rate_post[:, 1] == 0.0)
    ke0 = (0.5 * c.m[:, 0] * (c.vx[:, 0]**2 + c.vy[:, 0]**2)
           + 0.5 * c.izz[:, 0] * c.yaw_rate[:, 0]**2)
    ke1 = (0.5 * c.m[:, 0] * (r.vx_post[:, 0]**2 + r.vy_post[:, 0]**2)
           + 0.5 * c.izz[:, 0] * r.yaw_rate_post[:, 0]**2)
    assert np.all(ke1 <= ke0 * (1 + 1e-12) + 1e-9)
    active = r.impact_type != IMPACT_NONE
    assert np.all(np.abs(np.where(active, ke0 - ke1 - r.energy_loss, 0.0))
                  <= 1e-8 * (1.0 + ke0))


HEAVY_MASS = 1e9  # [kg]
HEAVY_INERTIA = 1e12  # [kg m^2]: a 1e9 kg body with 32 m radius of gyration


@pytest.mark.parametrize("eps", [0.0, 0.19, 0.7])
def test_central_barrier_limit_of_1e9_kg_vehicle(eps):
    """Central collinear impact on a body of mass M at rest: delta-v1 = (1 + eps) v M /
    (m1 + M), so the fixed object's (1 + eps) v differs by exactly m1 / (m1 + M)."""
    fixed = solve_impact(barrier_config(restitution=eps))
    heavy = solve_impact(barrier_config(restitution=eps, m2=HEAVY_MASS, izz2=HEAVY_INERTIA))
    rel = (fixed.delta_v[:, 0] - heavy.delta_v[:, 0]) / fixed.delta_v[:, 0]
    np.testing.assert_allclose(rel, 1703.0 / (1703.0 + HEAVY_MASS), rtol=1e-6)


@settings(max_examples=400, deadline=None)
@given(configs)
def test_fixed_object_equals_1e9_kg_vehicle_to_1e_6(d):
    """Full impact: S = -(1 + eps) K^-1 u.  The finite body adds dK = I/M + r2p r2p^T / I2
    to K, so |dS| / |S| <= |K^-1| |dK| <= m1 (1/M + |r2|^2 / I2) (K >= I / m1).  For
    m1 <= 1000 kg, M = 1e9 kg, I2 = 1e12 kg m^2 and |r2| <= hypot(6.5, 5.5) = 8.52 m (the
    strategy's extreme POI and CG) this is <= 1.08e-6.
    Sliding impacts divide by k_nn + s mu k_tn, which can be small (near jamming), so
    they are only tested to 1e-4."""
    d = dict(d, m1=min(d["m1"], 1000.0))
    fixed = solve_impact(_with_object(d, INF, INF))
    heavy = solve_impact(_with_object(d, HEAVY_MASS, HEAVY_INERTIA))
    if fixed.impact_type[0] == IMPACT_NONE:
        assert heavy.impact_type[0] == IMPACT_NONE or heavy.closing_speed[0] < 1e-9
        return
    r2 = np.hypot(d["poi_x"] - d["x2"], d["poi_y"] - d["y2"])
    bound = d["m1"] * (1.0 / HEAVY_MASS + r2**2 / HEAVY_INERTIA)
    assert bound <= 1.08e-6
    full = fixed.impact_type[0] == IMPACT_FULL and heavy.impact_type[0] == IMPACT_FULL
    tol = bound * (1 + 1e-6) + 1e-12 if full else 1e-4
    size = np.hypot(fixed.impulse_x, fixed.impulse_y)[0]
    diff = np.hypot(fixed.impulse_x - heavy.impulse_x, fixed.impulse_y - heavy.impulse_y)[0]
    assert diff <= tol * size
    # vehicle 1's velocity change is S / m1: the same relative difference
    dv = np.hypot(fixed.vx_post[0, 0] - heavy.vx_post[0, 0],
                  fixed.vy_post[0, 0] - heavy.vy_post[0, 0])
    assert dv <= tol * fixed.delta_v[0, 0] + 1e-15
