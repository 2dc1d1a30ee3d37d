"""Kudlich-Slibar impact model: closed forms, conservation laws, invariances.

Oracles: the collinear central impact (delta-v1 = (1 + eps) m2 / (m1 + m2) v_rel),
momentum and angular momentum balances, the energy never rising, the
friction-cone conditions, and rigid-motion / vehicle-swap invariance.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.errors import ParameterError
from vfs.physics.impact import (
    IMPACT_FULL,
    IMPACT_NONE,
    IMPACT_SLIDING,
    IMPACT_TYPE_NAMES,
    ImpactConfig,
    ImpactParams,
    deformation_energy,
    ees_from_energy,
    energy_split,
    impact_type_names,
    solve_impact,
    velocity_change,
)
from vfs.physics.precrash import PrecrashParams


def config(**over) -> ImpactConfig:
    base = dict(m1=1500.0, izz1=2500.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=20.0, vy1=0.0,
                yaw_rate1=0.0, m2=1000.0, izz2=1600.0, x2=4.0, y2=0.0, yaw2=np.pi, vx2=-10.0,
                vy2=0.0, yaw_rate2=0.0, poi_x=2.0, poi_y=0.0, cp_angle=np.pi / 2,
                restitution=0.2, contact_friction=0.5)
    base.update(over)
    return ImpactConfig.from_columns(**base)


def close(actual, expected, tol) -> None:
    """Element-wise |actual - expected| <= tol with array-valued tolerances."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    bad = ~(np.abs(actual - expected) <= tol)
    assert not bad.any(), f"{bad.sum()} mismatches, worst {np.max(np.abs(actual - expected))}"


def momentum(c: ImpactConfig, vx1, vy1, vx2, vy2):
    return c.m[:, 0] * vx1 + c.m[:, 1] * vx2, c.m[:, 0] * vy1 + c.m[:, 1] * vy2


def assert_momentum_conserved(c: ImpactConfig, r) -> np.ndarray:
    """Linear momentum of the pair before and after the impact equal to 1e-9 of the
    momentum magnitudes (the impulses on the two vehicles are opposite); returns that
    scale, the sum of the momentum magnitudes [kg m/s]."""
    px0, py0 = momentum(c, c.vx[:, 0], c.vy[:, 0], c.vx[:, 1], c.vy[:, 1])
    px1, py1 = momentum(c, r.vx_post[:, 0], r.vy_post[:, 0], r.vx_post[:, 1], r.vy_post[:, 1])
    scale = (c.m * np.hypot(c.vx, c.vy)).sum(axis=1)
    np.testing.assert_array_less(np.abs(px1 - px0), 1e-9 * scale)
    np.testing.assert_array_less(np.abs(py1 - py0), 1e-9 * scale)
    return scale


def angular_momentum(c: ImpactConfig, vx1, vy1, w1, vx2, vy2, w2):
    """About the global origin [kg m^2/s]."""
    return (c.izz[:, 0] * w1 + c.m[:, 0] * (c.x[:, 0] * vy1 - c.y[:, 0] * vx1)
            + c.izz[:, 1] * w2 + c.m[:, 1] * (c.x[:, 1] * vy2 - c.y[:, 1] * vx2))


def kinetic(c: ImpactConfig, vx1, vy1, w1, vx2, vy2, w2):
    return (0.5 * c.m[:, 0] * (vx1**2 + vy1**2) + 0.5 * c.izz[:, 0] * w1**2
            + 0.5 * c.m[:, 1] * (vx2**2 + vy2**2) + 0.5 * c.izz[:, 1] * w2**2)


@pytest.mark.parametrize("eps", [0.0, 0.1, 0.5, 1.0])
def test_collinear_central_impact_closed_form(eps):
    c = config(restitution=eps)
    r = solve_impact(c)
    v_rel = 30.0
    assert r.impact_type[0] == IMPACT_FULL
    assert r.delta_v[0, 0] == pytest.approx((1 + eps) * 1000 / 2500 * v_rel, rel=1e-12)
    assert r.delta_v[0, 1] == pytest.approx((1 + eps) * 1500 / 2500 * v_rel, rel=1e-12)
    mu_red = 1500 * 1000 / 2500
    assert r.energy_loss[0] == pytest.approx(0.5 * mu_red * v_rel**2 * (1 - eps**2), rel=1e-12,
                                             abs=1e-12 * 0.5 * mu_red * v_rel**2)
    # mass rule: E1 = E m2 / (m1 + m2); EES from E = m EES^2 / 2
    e1 = r.energy_loss[0] * 1000 / 2500
    assert r.ees[0, 0] == pytest.approx(np.sqrt(2 * e1 / 1500), rel=1e-12, abs=1e-5)
    assert r.yaw_rate_post[0, 0] == pytest.approx(0.0, abs=1e-12)
    # frontal impulse on both: PDOF 0, 12 o'clock; velocity reversed for 2
    assert r.pdof[0, 0] == pytest.approx(0.0, abs=1e-12) and r.pdof_clock[0, 0] == 12
    assert r.pdof[0, 1] == pytest.approx(0.0, abs=1e-12) and r.pdof_clock[0, 1] == 12


def test_eps_zero_full_impact_gives_equal_poi_velocities():
    c = config(restitution=0.0, poi_y=0.6, vy2=2.0, yaw_rate1=0.3, contact_friction=5.0)
    r = solve_impact(c)
    assert r.impact_type[0] == IMPACT_FULL
    r1 = np.array([c.poi_x[0] - c.x[0, 0], c.poi_y[0] - c.y[0, 0]])
    r2 = np.array([c.poi_x[0] - c.x[0, 1], c.poi_y[0] - c.y[0, 1]])
    v1p = np.array([r.vx_post[0, 0] - r.yaw_rate_post[0, 0] * r1[1],
                    r.vy_post[0, 0] + r.yaw_rate_post[0, 0] * r1[0]])
    v2p = np.array([r.vx_post[0, 1] - r.yaw_rate_post[0, 1] * r2[1],
                    r.vy_post[0, 1] + r.yaw_rate_post[0, 1] * r2[0]])
    np.testing.assert_allclose(v1p, v2p, atol=1e-10)


def test_separating_configuration_is_no_impact():
    r = solve_impact(config(vx1=-5.0, vx2=5.0))
    assert r.impact_type[0] == IMPACT_NONE
    assert r.delta_v[0, 0] == 0.0 and r.energy_loss[0] == 0.0 and np.isnan(r.pdof[0, 0])


def test_side_impact_pdof_clock():
    # vehicle 1 heading east hits vehicle 2 (heading north) from the west,
    # i.e. on its left side: 9 o'clock, PDOF about -90 deg
    c = config(x2=3.0, y2=0.0, yaw2=np.pi / 2, vx2=0.0, vy2=5.0, poi_x=2.0, poi_y=0.0,
               cp_angle=np.pi / 2)
    r = solve_impact(c)
    assert r.pdof_clock[0, 0] == 12 and r.pdof_clock[0, 1] == 9
    assert np.degrees(r.pdof[0, 1]) == pytest.approx(-90.0, abs=15.0)
    # mirrored: vehicle 2 heading south is struck on its right side, 3 o'clock
    r = solve_impact(config(x2=3.0, y2=0.0, yaw2=-np.pi / 2, vx2=0.0, vy2=-5.0, poi_x=2.0,
                            poi_y=0.0, cp_angle=np.pi / 2))
    assert r.pdof_clock[0, 1] == 3 and np.degrees(r.pdof[0, 1]) == pytest.approx(90.0, abs=15.0)


def test_params_validation():
    with pytest.raises(ParameterError, match="restitution"):
        ImpactParams(restitution=1.5)
    with pytest.raises(ParameterError, match="contact_friction"):
        ImpactParams(contact_friction=-0.1)


def test_energy_split_rules():
    e1, e2 = energy_split(1000.0, 1000.0, 2000.0)
    assert e1 == pytest.approx(2000 / 3) and e2 == pytest.approx(1000 / 3)
    # stiffness ratio k1/k2 = 3: E1/E2 = 1/3
    e1, e2 = energy_split(1000.0, 1000.0, 2000.0, stiffness_ratio=3.0)
    assert e1 == pytest.approx(250.0) and e2 == pytest.approx(750.0)


# ----------------------------------------------------------------------------
# Random configurations over wide ranges
# ----------------------------------------------------------------------------


def random_configs(rng: np.random.Generator, n: int, wide: bool = True) -> ImpactConfig:
    m1, m2 = rng.uniform(100, 40_000, (2, n)) if wide else rng.uniform(800, 2600, (2, n))
    k1, k2 = rng.uniform(0.3, 3.0, (2, n))
    reach = 6.0 if wide else 3.0
    return ImpactConfig.from_columns(
        m1=m1, izz1=m1 * k1**2, x1=rng.uniform(-reach, reach, n), y1=rng.uniform(-reach, reach, n),
        yaw1=rng.uniform(-np.pi, np.pi, n), vx1=rng.uniform(-40, 40, n),
        vy1=rng.uniform(-40, 40, n), yaw_rate1=rng.uniform(-3, 3, n),
        m2=m2, izz2=m2 * k2**2, x2=rng.uniform(-reach, reach, n), y2=rng.uniform(-reach, reach, n),
        yaw2=rng.uniform(-np.pi, np.pi, n), vx2=rng.uniform(-40, 40, n),
        vy2=rng.uniform(-40, 40, n), yaw_rate2=rng.uniform(-3, 3, n),
        poi_x=rng.uniform(-reach, reach, n), poi_y=rng.uniform(-reach, reach, n),
        cp_angle=rng.uniform(-2 * np.pi, 2 * np.pi, n), restitution=rng.uniform(0, 1, n),
        contact_friction=rng.uniform(0, 3 if wide else 1, n),
    )


seeds = st.integers(0, 2**32 - 1)


@given(seed=seeds, wide=st.booleans())
def test_momentum_and_angular_momentum_conserved(seed, wide):
    c = random_configs(np.random.default_rng(seed), 256, wide)
    r = solve_impact(c)
    scale = assert_momentum_conserved(c, r)
    l0 = angular_momentum(c, *pre_velocities(c))
    l1 = angular_momentum(c, *post_velocities(r))
    lscale = (c.izz[:, 0] * np.abs(c.yaw_rate[:, 0]) + c.izz[:, 1] * np.abs(c.yaw_rate[:, 1])
              + scale * (np.hypot(c.x[:, 0], c.y[:, 0]) + np.hypot(c.x[:, 1], c.y[:, 1]) + 1.0))
    np.testing.assert_array_less(np.abs(l1 - l0), 1e-9 * lscale)
    # both impact types are exercised
    assert {IMPACT_FULL, IMPACT_SLIDING} <= set(np.unique(r.impact_type))


@given(seed=seeds, wide=st.booleans())
def test_energy_never_gained_and_loss_consistent(seed, wide):
    c = random_configs(np.random.default_rng(seed), 256, wide)
    r = solve_impact(c)
    e0 = kinetic(c, *pre_velocities(c))
    e1 = kinetic(c, *post_velocities(r))
    np.testing.assert_array_less(e1 - e0, 1e-9 * e0)
    np.testing.assert_allclose(e0 - e1, r.energy_loss, atol=1e-9 * e0.max())
    assert (r.ees[:, 0] >= 0).all() and (r.ees[:, 1] >= 0).all()


def pre_velocities(c):
    """vx1, vy1, w1, vx2, vy2, w2 before the impact [m/s, rad/s]."""
    return (c.vx[:, 0], c.vy[:, 0], c.yaw_rate[:, 0], c.vx[:, 1], c.vy[:, 1],
            c.yaw_rate[:, 1])


def post_velocities(r):
    """vx1, vy1, w1, vx2, vy2, w2 after the impact [m/s, rad/s] (the ImpactConfig order)."""
    return (r.vx_post[:, 0], r.vy_post[:, 0], r.yaw_rate_post[:, 0], r.vx_post[:, 1],
            r.vy_post[:, 1], r.yaw_rate_post[:, 1])


def relative_poi_velocity(c: ImpactConfig, r, post: bool):
    if post:
        v = post_velocities(r)
    else:
        v = pre_velocities(c)
    r1x, r1y = c.poi_x - c.x[:, 0], c.poi_y - c.y[:, 0]
    r2x, r2y = c.poi_x - c.x[:, 1], c.poi_y - c.y[:, 1]
    ux = (v[0] - v[2] * r1y) - (v[3] - v[5] * r2y)
    uy = (v[1] + v[2] * r1x) - (v[4] + v[5] * r2x)
    return ux, uy


@given(seed=seeds, wide=st.booleans())
def test_friction_cone_and_sliding_conditions(seed, wide):
    c = random_configs(np.random.default_rng(seed), 256, wide)
    r = solve_impact(c)
    full = r.impact_type == IMPACT_FULL
    sliding = r.impact_type == IMPACT_SLIDING
    mu = c.contact_friction
    size = np.hypot(r.impulse_t, r.impulse_n) + 1e-12
    # full: inside the cone; sliding: on it
    assert (np.abs(r.impulse_t[full]) <= mu[full] * r.impulse_n[full] + 1e-9 * size[full]).all()
    np.testing.assert_allclose(np.abs(r.impulse_t[sliding]), mu[sliding] * r.impulse_n[sliding],
                               rtol=1e-9, atol=1e-9)
    assert (r.impulse_n[full | sliding] >= 0).all()
    # sliding: at the end of compression the normal POI velocities agree and
    # the tangential impulse opposes the slip that remains
    eps = c.restitution
    ux, uy = relative_poi_velocity(c, r, post=False)
    uxp, uyp = relative_poi_velocity(c, r, post=True)
    # POI velocities are affine in the impulse: the compression state is the
    # (1 / (1 + eps)) point between before and after
    w = 1.0 / (1.0 + eps)
    ucx, ucy = ux + w * (uxp - ux), uy + w * (uyp - uy)
    tx, ty = r.normal_y, -r.normal_x
    un_c = ucx * r.normal_x + ucy * r.normal_y
    ut_c = ucx * tx + ucy * ty
    speed = np.hypot(ux, uy) + 1e-9
    np.testing.assert_allclose(un_c[sliding | full] / speed[sliding | full], 0.0, atol=1e-9)
    assert (r.impulse_t[sliding] * ut_c[sliding] <= 1e-9 * speed[sliding] * size[sliding]).all()
    # full: no tangential slip at the end of compression
    np.testing.assert_allclose(ut_c[full] / speed[full], 0.0, atol=1e-8)
    # no impact exactly where the POI velocities separate or are at rest
    un = ux * r.normal_x + uy * r.normal_y
    np.testing.assert_array_equal(r.impact_type == IMPACT_NONE, un >= 0)


def rotate(c: ImpactConfig, angle: float, dx: float, dy: float) -> ImpactConfig:
    co, si = np.cos(angle), np.sin(angle)
    d = c._asdict()
    x, y = d["x"], d["y"]  # (N, 2): both vehicles
    d["x"], d["y"] = co * x - si * y + dx, si * x + co * y + dy
    vx, vy = d["vx"], d["vy"]
    d["vx"], d["vy"] = co * vx - si * vy, si * vx + co * vy
    d["yaw"] = d["yaw"] + angle
    px, py = d["poi_x"], d["poi_y"]
    d["poi_x"], d["poi_y"] = co * px - si * py + dx, si * px + co * py + dy
    d["cp_angle"] = d["cp_angle"] + angle
    return ImpactConfig(**d)


@given(seed=seeds, angle=st.floats(-np.pi, np.pi), dx=st.floats(-1e3, 1e3),
       dy=st.floats(-1e3, 1e3), flip=st.booleans())
def test_rigid_motion_invariance(seed, angle, dx, dy, flip):
    c = random_configs(np.random.default_rng(seed), 128, wide=False)
    moved = rotate(c, angle, dx, dy)
    if flip:  # the contact plane's orientation must not matter
        moved = moved._replace(cp_angle=moved.cp_angle + np.pi)
    r, s = solve_impact(c), solve_impact(moved)
    scale = np.hypot(c.vx[:, 0], c.vy[:, 0]) + np.hypot(c.vx[:, 1], c.vy[:, 1]) + 1.0
    np.testing.assert_array_equal(r.impact_type, s.impact_type)
    for a, b in ((r.delta_v, s.delta_v), (r.ees, s.ees)):
        np.testing.assert_allclose(a, b, atol=1e-7 * scale.max())
    co, si = np.cos(angle), np.sin(angle)
    close(s.vx_post[:, 0], co * r.vx_post[:, 0] - si * r.vy_post[:, 0], 1e-7 * scale)
    close(s.yaw_rate_post[:, 1], r.yaw_rate_post[:, 1], 1e-7 * scale)
    close(s.impulse_t, r.impulse_t, 1e-7 * np.abs(r.impulse_t) + 1e-6 * scale * c.m[:, 0])
    d_pdof = np.mod(s.pdof[:, 0] - r.pdof[:, 0] + np.pi, 2 * np.pi) - np.pi
    close(np.nan_to_num(d_pdof), 0.0, 1e-6)


@given(seed=seeds, wide=st.booleans())
def test_swapping_vehicles(seed, wide):
    c = random_configs(np.random.default_rng(seed), 256, wide)
    r, s = solve_impact(c), solve_impact(c.swapped())
    np.testing.assert_array_equal(r.impact_type, s.impact_type)
    scale = np.hypot(c.vx[:, 0], c.vy[:, 0]) + np.hypot(c.vx[:, 1], c.vy[:, 1]) + 1.0
    close(s.vx_post[:, 0], r.vx_post[:, 1], 1e-9 * scale)
    close(s.vy_post[:, 1], r.vy_post[:, 0], 1e-9 * scale)
    close(s.yaw_rate_post[:, 0], r.yaw_rate_post[:, 1], 1e-9 * scale)
    close(s.delta_v[:, 0], r.delta_v[:, 1], 1e-9 * scale)
    close(s.ees[:, 1], r.ees[:, 0], 1e-9 * scale)
    np.testing.assert_allclose(s.energy_loss, r.energy_loss, rtol=1e-9, atol=1e-6)
    close(s.impulse_x, -r.impulse_x, 1e-9 * scale * (c.m[:, 0] + c.m[:, 1]))


def test_single_and_batch_identical():
    c = random_configs(np.random.default_rng(0), 20_000)
    batch = solve_impact(c)
    for k in (0, 8191, 8192, 19_999):
        one = solve_impact(ImpactConfig(*(a[k:k + 1] for a in c)))
        for name in ("vx_post", "yaw_rate_post", "ees", "energy_loss", "pdof"):
            np.testing.assert_array_equal(getattr(one, name), getattr(batch, name)[k:k + 1])


# ----------------------------------------------------------------------------
# Normal-only restitution (Brach's convention)
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("eps", [0.0, 0.3, 1.0])
def test_normal_restitution_oblique_particle_impact_closed_form(eps):
    # two "particles" (POI at both CGs, no lever): K = (1/m1 + 1/m2) 1.  Brach: with
    # enough friction the tangential relative velocity is stopped (u_t' = 0) and the
    # normal one reversed by eps; the loss is m_eff (u_t^2 + (1 - eps^2) u_n^2) / 2
    m1, m2 = 1500.0, 1000.0
    c = config(x1=0.0, y1=0.0, x2=0.0, y2=0.0, poi_x=0.0, poi_y=0.0, cp_angle=np.pi / 2,
               vx1=20.0, vy1=3.0, vx2=-10.0, vy2=-4.0, m1=m1, m2=m2, restitution=eps,
               contact_friction=5.0)
    # x2 = x1: the normal is undefined by the CG rule, so give vehicle 2 an offset along n
    c = c._replace(x=np.array([[0.0, 1e-9]]))
    r = solve_impact(c, restitution_mode="normal")
    ux, uy = relative_poi_velocity(c, r, post=False)
    uxp, uyp = relative_poi_velocity(c, r, post=True)
    n = np.array([r.normal_x[0], r.normal_y[0]])
    t = np.array([n[1], -n[0]])
    u_n, u_t = ux[0] * n[0] + uy[0] * n[1], ux[0] * t[0] + uy[0] * t[1]
    assert uxp[0] * t[0] + uyp[0] * t[1] == pytest.approx(0.0, abs=1e-9)
    assert uxp[0] * n[0] + uyp[0] * n[1] == pytest.approx(-eps * u_n, abs=1e-9)
    m_eff = m1 * m2 / (m1 + m2)
    assert r.energy_loss[0] == pytest.approx(0.5 * m_eff * (u_t**2 + (1 - eps**2) * u_n**2),
                                             rel=1e-12)
    # the impulse ratio is Brach's critical one: |S_t / S_n| = |u_t| / ((1 + eps) |u_n|)
    assert abs(r.impulse_t[0] / r.impulse_n[0]) == pytest.approx(
        abs(u_t) / ((1 + eps) * abs(u_n)), rel=1e-12)


@given(seed=seeds, wide=st.booleans())
def test_normal_restitution_stops_sliding_inside_the_cone(seed, wide):
    c = random_configs(np.random.default_rng(seed), 256, wide)
    r = solve_impact(c, restitution_mode="normal")
    ux, uy = relative_poi_velocity(c, r, post=False)
    uxp, uyp = relative_poi_velocity(c, r, post=True)
    tx, ty = r.normal_y, -r.normal_x
    un = ux * r.normal_x + uy * r.normal_y
    unp, utp = uxp * r.normal_x + uyp * r.normal_y, uxp * tx + uyp * ty
    speed = np.hypot(ux, uy) + 1e-9
    # sliding impacts are the same in both conventions (|S_t| = mu S_n and the normal
    # compression impulse times (1 + eps) either way); full ones differ.  Where Newton's
    # restitution would create energy (Kane's paradox) a full impact falls back to the
    # default Poisson split: those rows equal the default mode's, and they are few
    default = solve_impact(c)
    fields = ("vx_post", "vy_post", "yaw_rate_post")
    same = np.all([np.isclose(getattr(r, f), getattr(default, f), rtol=1e-12, atol=1e-12)
                   .all(axis=1) for f in fields], axis=0)
    sliding = r.impact_type == IMPACT_SLIDING
    # (the slip direction comes from each mode's stick solution and may differ where the
    # normal and tangential directions are strongly coupled)
    both_sliding = (sliding & (default.impact_type == IMPACT_SLIDING)
                    & (np.sign(r.impulse_t) == np.sign(default.impulse_t)))
    np.testing.assert_array_equal(same[both_sliding], True)
    full = (r.impact_type == IMPACT_FULL) & ~same
    fell_back = (r.impact_type == IMPACT_FULL) & same & (c.restitution > 1e-6)
    assert fell_back.mean() < 0.15 and full.any() and sliding.any()
    hit = full | sliding
    # kinematic restitution of the normal velocity
    np.testing.assert_allclose((unp + c.restitution * un)[hit] / speed[hit], 0.0, atol=1e-8)
    # inside the friction cone: no tangential velocity at separation (critical ratio)
    np.testing.assert_allclose(utp[full] / speed[full], 0.0, atol=1e-8)
    size = np.hypot(r.impulse_t, r.impulse_n) + 1e-12
    assert (np.abs(r.impulse_t[full]) <= c.contact_friction[full] * r.impulse_n[full]
            + 1e-9 * size[full]).all()
    # momentum is conserved and energy never gained, as in the default mode
    assert_momentum_conserved(c, r)
    e0 = kinetic(c, *pre_velocities(c))
    e1 = kinetic(c, *post_velocities(r))
    np.testing.assert_array_less(e1 - e0, 1e-9 * e0)


def test_normal_restitution_is_continuous_at_the_critical_ratio():
    # at mu = the critical impulse ratio the full and the sliding solution coincide
    c = config(vy1=4.0, restitution=0.3)
    crit = solve_impact(c._replace(contact_friction=np.array([10.0])),
                        restitution_mode="normal")
    mu_c = abs(crit.impulse_t[0] / crit.impulse_n[0])
    above = solve_impact(c._replace(contact_friction=np.array([mu_c * (1 + 1e-9)])),
                         restitution_mode="normal")
    below = solve_impact(c._replace(contact_friction=np.array([mu_c * (1 - 1e-9)])),
                         restitution_mode="normal")
    assert above.impact_type[0] == IMPACT_FULL and below.impact_type[0] == IMPACT_SLIDING
    for f, j in (("vx_post", 0), ("vy_post", 0), ("yaw_rate_post", 0), ("vx_post", 1),
                 ("vy_post", 1)):
        assert getattr(below, f)[0, j] == pytest.approx(getattr(above, f)[0, j], rel=1e-6,
                                                        abs=1e-6)


def test_the_two_conventions_differ_only_through_restitution():
    c = random_configs(np.random.default_rng(5), 200)
    for mode in ("impulse", "normal"):
        # eps = 0 in either convention: the normal POI velocities are equal after the impact
        a = solve_impact(c._replace(restitution=np.zeros(200)), restitution_mode=mode)
        hit = a.impact_type != 0
        ux, uy = relative_poi_velocity(c, a, post=True)
        un = ux * a.normal_x + uy * a.normal_y
        speed = np.hypot(*relative_poi_velocity(c, a, post=False))
        assert hit.sum() > 50
        np.testing.assert_allclose(un[hit] / speed[hit], 0.0, atol=1e-9)
    # eps = 0: identical (no restitution to distribute)
    a = solve_impact(c._replace(restitution=np.zeros(200)))
    b = solve_impact(c._replace(restitution=np.zeros(200)), restitution_mode="normal")
    np.testing.assert_allclose(a.delta_v[:, 0], b.delta_v[:, 0], rtol=1e-12, atol=1e-12)
    assert ImpactParams().restitution_mode == "impulse"
    with pytest.raises(ParameterError, match="restitution_mode"):
        ImpactParams(restitution_mode="tangential")
    with pytest.raises(ParameterError, match="restitution_mode"):
        solve_impact(c, restitution_mode="both")


# ----------------------------------------------------------------------------
# Names, energies, delta-v kernels
# ----------------------------------------------------------------------------


def test_impact_type_names_follow_the_one_constant():
    codes = np.array([2, 0, 1, 1])
    assert impact_type_names(codes).tolist() == [IMPACT_TYPE_NAMES[int(k)] for k in codes]


@settings(max_examples=200, deadline=None)
@given(mass=st.floats(500.0, 3000.0), ees=st.floats(0.0, 40.0), dvx=st.floats(-30.0, 30.0),
       dvy=st.floats(-30.0, 30.0))
def test_energy_and_delta_v_kernels(mass, ees, dvx, dvy):
    assert float(ees_from_energy(deformation_energy(mass, ees), mass)) == pytest.approx(
        ees, rel=1e-12, abs=1e-12)
    # sqrt(dvx^2 + dvy^2): equal to hypot up to rounding (squares underflow below 1e-154)
    assert float(velocity_change(dvx, dvy)) == pytest.approx(math.hypot(dvx, dvy), rel=1e-15,
                                                             abs=1e-12)


def test_penetration_time_default_lives_in_precrash():
    assert "penetration_time" not in ImpactParams.__dataclass_fields__
    with pytest.raises(TypeError):
        ImpactParams(penetration_time=0.05)  # type: ignore[call-arg]
    with pytest.warns(DeprecationWarning):
        assert ImpactParams().penetration_time == PrecrashParams().penetration_time
