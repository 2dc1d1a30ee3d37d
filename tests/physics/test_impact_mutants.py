"""Tests of the impact model written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): an independent reference solver in the global
frame, conservation laws per body, invariances of the scene (rotation with translation,
mirror, exchange of the vehicles, a common velocity), the range bounds of the inputs, the
energy split, the deformation energies, the POI velocity and the block of 65,536 impacts.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.errors import ParameterError
from vfs.physics import impact
from vfs.physics.impact import (
    CONFIG_COLUMNS,
    CONFIG_RANGES,
    IMPACT_FULL,
    IMPACT_NONE,
    IMPACT_SLIDING,
    ImpactConfig,
    ImpactParams,
    angle_between,
    config_problems,
    contact_frame,
    deformation_energies,
    describe_range,
    energy_split,
    fixed_object,
    impact_type_names,
    inverse_mass,
    poi_relative_velocity,
    solve_impact,
    with_outcome,
)


def scene(rng: np.random.Generator, n: int) -> ImpactConfig:
    """Random configurations in every direction (vehicles anywhere, any heading)."""
    m1, m2 = rng.uniform(600, 4000, (2, n))
    k1, k2 = rng.uniform(0.8, 2.0, (2, n))
    return ImpactConfig.from_columns(
        m1=m1, izz1=m1 * k1**2, x1=rng.uniform(-5, 5, n), y1=rng.uniform(-5, 5, n),
        yaw1=rng.uniform(-np.pi, np.pi, n), vx1=rng.uniform(-30, 30, n),
        vy1=rng.uniform(-30, 30, n), yaw_rate1=rng.uniform(-2, 2, n),
        m2=m2, izz2=m2 * k2**2, x2=rng.uniform(-5, 5, n), y2=rng.uniform(-5, 5, n),
        yaw2=rng.uniform(-np.pi, np.pi, n), vx2=rng.uniform(-30, 30, n),
        vy2=rng.uniform(-30, 30, n), yaw_rate2=rng.uniform(-2, 2, n),
        poi_x=rng.uniform(-5, 5, n), poi_y=rng.uniform(-5, 5, n),
        cp_angle=rng.uniform(-np.pi, np.pi, n), restitution=rng.uniform(0, 1, n),
        contact_friction=rng.uniform(0.05, 1.2, n))


def cross(ax, ay, bx, by):
    return ax * by - ay * bx


def reference(c: ImpactConfig, k: int, normal_mode: bool = False) -> dict[str, np.ndarray]:
    """One impact solved with 2x2 matrices in the global frame (np.linalg.solve).

    u = v1_P - v2_P; du = K S with K = (1/m1 + 1/m2) 1 + sum r_i^perp r_i^perp^T / I_i,
    r^perp = (-r_y, r_x).  Full impact: u + K S_c = 0; it holds where |S_c . t| <= mu S_c . n,
    else sliding: S_c = lam (n + s mu t) with n . (u + K S_c) = 0.  S = (1 + eps) S_c.
    """
    m, izz = c.m[k], c.izz[k]
    poi = np.array([c.poi_x[k], c.poi_y[k]])
    r = [poi - np.array([c.x[k, i], c.y[k, i]]) for i in (0, 1)]
    perp = [np.array([-ri[1], ri[0]]) for ri in r]
    v = [np.array([c.vx[k, i], c.vy[k, i]]) + c.yaw_rate[k, i] * perp[i] for i in (0, 1)]
    u = v[0] - v[1]
    kmat = (1 / m[0] + 1 / m[1]) * np.eye(2) + sum(
        np.outer(perp[i], perp[i]) / izz[i] for i in (0, 1))
    phi = c.cp_angle[k]
    n = np.array([-np.sin(phi), np.cos(phi)])
    cg = np.array([c.x[k, 0] - c.x[k, 1], c.y[k, 0] - c.y[k, 1]])
    if n @ cg < 0:
        n = -n
    t = np.array([n[1], -n[0]])
    eps, mu = c.restitution[k], c.contact_friction[k]
    if u @ n >= 0:
        s_total = np.zeros(2)
        kind = IMPACT_NONE
    else:
        target = u + (eps * (u @ n)) * n if normal_mode else u
        sc = np.linalg.solve(kmat, -target)
        if abs(sc @ t) <= mu * (sc @ n):
            kind = IMPACT_FULL
        else:
            kind = IMPACT_SLIDING
            d = n + np.sign(sc @ t) * mu * t
            lam = -(target @ n) / (n @ kmat @ d)
            sc = lam * d
        s_total = sc if normal_mode else (1 + eps) * sc
    dv = [s_total / m[0], -s_total / m[1]]
    dw = [cross(*r[0], *s_total) / izz[0], -cross(*r[1], *s_total) / izz[1]]
    return {"kind": kind, "impulse": s_total, "n": n,
            "v_post": [np.array([c.vx[k, i], c.vy[k, i]]) + dv[i] for i in (0, 1)],
            "w_post": [c.yaw_rate[k, i] + dw[i] for i in (0, 1)]}


def kinetic(c: ImpactConfig, vx, vy, w) -> np.ndarray:
    return 0.5 * (c.m * (vx**2 + vy**2) + c.izz * w**2).sum(axis=1)


@pytest.mark.parametrize("mode", ["impulse", "normal"])
def test_solver_matches_a_global_frame_reference(mode: str) -> None:
    c = scene(np.random.default_rng(11), 400)
    res = solve_impact(c, restitution_mode=mode)
    kinds = set()
    fallbacks = 0
    for k in range(c.size):
        ref = reference(c, k, normal_mode=mode == "normal")
        if mode == "normal" and gained(c, k, ref) > 1e-9 * gained(c, k, None):
            ref = reference(c, k)  # Kane's paradox: the impulse mode instead
            fallbacks += 1
        scale = 1e-9 * (1.0 + np.abs(ref["impulse"]).max())
        kinds.add(ref["kind"])
        assert res.impact_type[k] == ref["kind"], k
        np.testing.assert_allclose([res.impulse_x[k], res.impulse_y[k]], ref["impulse"],
                                   atol=scale * 1e3, rtol=1e-8)
        np.testing.assert_allclose([res.normal_x[k], res.normal_y[k]], ref["n"], atol=1e-12)
        for i in (0, 1):
            np.testing.assert_allclose([res.vx_post[k, i], res.vy_post[k, i]],
                                       ref["v_post"][i], rtol=1e-8, atol=1e-8)
            assert res.yaw_rate_post[k, i] == pytest.approx(ref["w_post"][i], rel=1e-8,
                                                            abs=1e-8)
    assert kinds == {IMPACT_NONE, IMPACT_FULL, IMPACT_SLIDING}
    assert fallbacks < c.size // 10


def gained(c: ImpactConfig, k: int, ref: dict | None) -> float:
    """Kinetic energy after minus before of row k under ``ref`` (None: the energy before)."""
    def energy(v, w):
        return sum(0.5 * c.m[k, i] * (v[i] @ v[i]) + 0.5 * c.izz[k, i] * w[i] ** 2
                   for i in (0, 1))
    before = energy([np.array([c.vx[k, i], c.vy[k, i]]) for i in (0, 1)], c.yaw_rate[k])
    return before if ref is None else energy(ref["v_post"], ref["w_post"]) - before


@pytest.mark.parametrize("mode", ["impulse", "normal"])
def test_energy_loss_is_the_kinetic_energy_difference_and_split_by_mass(mode: str) -> None:
    c = scene(np.random.default_rng(12), 500)
    r = solve_impact(c, restitution_mode=mode)
    e0 = kinetic(c, c.vx, c.vy, c.yaw_rate)
    e1 = kinetic(c, r.vx_post, r.vy_post, r.yaw_rate_post)
    np.testing.assert_allclose(r.energy_loss, e0 - e1, rtol=1e-9, atol=1e-6)
    assert (r.energy_loss >= 0).all() and (r.energy_loss[r.impact_type != 0] > 0).any()
    e1_, e2_ = deformation_energies(c, r)
    np.testing.assert_allclose(e1_ + e2_, r.energy_loss, rtol=1e-9, atol=1e-6)
    # stiffness proportional to mass: E1 / E2 = m2 / m1, i.e. m1 E1 = m2 E2
    np.testing.assert_allclose(c.m[:, 0] * e1_, c.m[:, 1] * e2_, rtol=1e-9, atol=1e-3)
    # delta-v and the angle between the velocity vectors, from the post velocities
    dvx, dvy = r.vx_post - c.vx, r.vy_post - c.vy
    np.testing.assert_allclose(r.delta_vx, dvx, atol=1e-12)
    np.testing.assert_allclose(r.delta_vy, dvy, atol=1e-12)
    np.testing.assert_allclose(r.delta_v, np.hypot(dvx, dvy), rtol=1e-12, atol=1e-12)
    cos = (c.vx * r.vx_post + c.vy * r.vy_post) / (np.hypot(c.vx, c.vy)
                                                   * np.hypot(r.vx_post, r.vy_post))
    np.testing.assert_allclose(np.cos(r.velocity_angle_change), cos, atol=1e-9)


def test_each_body_keeps_its_angular_momentum_about_the_poi() -> None:
    c = scene(np.random.default_rng(13), 300)
    r = solve_impact(c)
    for i in (0, 1):
        rx, ry = c.poi_x - c.x[:, i], c.poi_y - c.y[:, i]
        before = c.izz[:, i] * c.yaw_rate[:, i] - c.m[:, i] * cross(rx, ry, c.vx[:, i], c.vy[:, i])
        after = (c.izz[:, i] * r.yaw_rate_post[:, i]
                 - c.m[:, i] * cross(rx, ry, r.vx_post[:, i], r.vy_post[:, i]))
        np.testing.assert_allclose(after, before, rtol=1e-9, atol=1e-6 * np.abs(before).max())
    # the impulse on vehicle 1: m1 dv1 = S = -m2 dv2
    np.testing.assert_allclose(c.m[:, 0] * r.delta_vx[:, 0], r.impulse_x, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(-c.m[:, 1] * r.delta_vy[:, 1], r.impulse_y, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(r.impulse_x, r.impulse_t * r.normal_y + r.impulse_n * r.normal_x,
                               rtol=1e-9, atol=1e-6)


def poi_velocity_components(c: ImpactConfig, r) -> tuple[np.ndarray, ...]:
    """(u_t, u_n) before and after from poi_relative_velocity, in the result's frame."""
    tx, ty, nx, ny = r.normal_y, -r.normal_x, r.normal_x, r.normal_y
    ux0, uy0 = poi_relative_velocity(c, c.vx[:, 0], c.vy[:, 0], c.yaw_rate[:, 0],
                                     c.vx[:, 1], c.vy[:, 1], c.yaw_rate[:, 1])
    ux1, uy1 = poi_relative_velocity(c, r.vx_post[:, 0], r.vy_post[:, 0],
                                     r.yaw_rate_post[:, 0], r.vx_post[:, 1], r.vy_post[:, 1],
                                     r.yaw_rate_post[:, 1])
    return ux0 * tx + uy0 * ty, ux0 * nx + uy0 * ny, ux1 * tx + uy1 * ty, ux1 * nx + uy1 * ny


def test_poi_relative_velocity_before_and_after() -> None:
    """Full impact: u' = -eps u in both directions; sliding: u_n' = -eps u_n."""
    c = scene(np.random.default_rng(14), 600)
    r = solve_impact(c)
    ut0, un0, ut1, un1 = poi_velocity_components(c, r)
    np.testing.assert_allclose(r.sliding_speed, ut0, atol=1e-9)
    np.testing.assert_allclose(r.closing_speed, -un0, atol=1e-9)
    eps = c.restitution
    full, sliding = r.impact_type == IMPACT_FULL, r.impact_type == IMPACT_SLIDING
    assert full.sum() > 20 and sliding.sum() > 20
    np.testing.assert_allclose(un1[full | sliding], -eps[full | sliding] * un0[full | sliding],
                               atol=1e-8)
    np.testing.assert_allclose(ut1[full], -eps[full] * ut0[full], atol=1e-8)
    none = r.impact_type == IMPACT_NONE
    np.testing.assert_array_equal(un0[none] >= 0, True)
    np.testing.assert_array_equal(r.impulse_n[none], 0.0)
    # a single vehicle turning about its CG: v_P = v + w x r, the POI velocity directly
    one = ImpactConfig.from_arrays(m=1000.0, izz=1500.0, x=[1.0, 9.0], y=[2.0, 9.0],
                                   yaw=0.0, vx=0.0, vy=0.0, yaw_rate=0.0, poi_x=4.0,
                                   poi_y=6.0, cp_angle=0.0, restitution=0.1,
                                   contact_friction=0.5)
    ux, uy = poi_relative_velocity(one, np.array([3.0]), np.array([-1.0]), np.array([0.5]),
                                   np.array([0.25]), np.array([2.0]), np.array([-2.0]))
    # r1 = (3, 4), r2 = (-5, -3): v1_P = (3 - 0.5 * 4, -1 + 0.5 * 3) = (1, 0.5);
    # v2_P = (0.25 - 2 * 3, 2 + 2 * 5) = (-5.75, -8)... with w2 = -2: (0.25 - 6, 2 + 10)
    assert ux[0] == pytest.approx(1.0 - (0.25 + (-2.0) * 3.0))
    assert uy[0] == pytest.approx(0.5 - (2.0 + (-2.0) * -5.0))


def test_normal_mode_stops_the_slip_or_slides_on_the_cone() -> None:
    c = scene(np.random.default_rng(15), 600)
    r = solve_impact(c, restitution_mode="normal")
    ut0, un0, ut1, un1 = poi_velocity_components(c, r)
    full, sliding = r.impact_type == IMPACT_FULL, r.impact_type == IMPACT_SLIDING
    impulse_mode = solve_impact(c)
    # a full impact stops the slip unless it fell back to the impulse mode (Kane's paradox)
    stopped = np.abs(ut1) <= 1e-8 * (1.0 + np.abs(ut0))
    fallback = np.all(np.isclose(r.vx_post, impulse_mode.vx_post, rtol=1e-12, atol=1e-12),
                      axis=1)
    assert (stopped | fallback)[full].all()
    assert stopped[full].sum() > 0.8 * full.sum() and full.sum() > 50
    np.testing.assert_allclose(un1[full | sliding], -c.restitution[full | sliding]
                               * un0[full | sliding], atol=1e-8)
    np.testing.assert_allclose(np.abs(r.impulse_t[sliding]),
                               c.contact_friction[sliding] * r.impulse_n[sliding], rtol=1e-9)


def test_normal_mode_falls_back_where_it_would_create_energy() -> None:
    """Kane's paradox: the kinematic restitution gains energy for some coupled
    configurations; there the result is the impulse mode's, row for row."""
    c = scene(np.random.default_rng(16), 1500)
    normal = solve_impact(c, restitution_mode="normal")
    plain = solve_impact(c)
    e0 = kinetic(c, c.vx, c.vy, c.yaw_rate)
    e1 = kinetic(c, normal.vx_post, normal.vy_post, normal.yaw_rate_post)
    np.testing.assert_array_less(e1 - e0, 1e-9 * e0)  # never gains energy
    paradox = np.array([gained(c, k, reference(c, k, normal_mode=True)) > 1e-6 * e0[k]
                        for k in range(c.size)])
    assert 1 <= paradox.sum() < 0.2 * c.size
    for name in ("vx_post", "vy_post", "yaw_rate_post", "impulse_t", "energy_loss", "ees"):
        np.testing.assert_allclose(getattr(normal, name)[paradox], getattr(plain, name)[paradox],
                                   rtol=1e-12, atol=1e-9, err_msg=name)
    hit = (normal.impact_type == IMPACT_FULL) & ~paradox & (c.restitution > 0.05)
    assert not np.isclose(normal.impulse_n[hit], plain.impulse_n[hit], rtol=1e-6).any()


def rotated(c: ImpactConfig, angle: float, dx: float, dy: float, mirror: bool) -> ImpactConfig:
    """The scene mirrored (y -> -y) if asked, then rotated by ``angle`` and shifted."""
    d = c._asdict()
    if mirror:
        d.update(y=-d["y"], vy=-d["vy"], poi_y=-d["poi_y"], yaw=-d["yaw"],
                 yaw_rate=-d["yaw_rate"], cp_angle=-d["cp_angle"])
    co, si = np.cos(angle), np.sin(angle)
    for x, y, shift in (("x", "y", True), ("vx", "vy", False), ("poi_x", "poi_y", True)):
        a, b = d[x], d[y]
        d[x] = co * a - si * b + (dx if shift else 0.0)
        d[y] = si * a + co * b + (dy if shift else 0.0)
    d["yaw"] = d["yaw"] + angle
    d["cp_angle"] = d["cp_angle"] + angle
    return ImpactConfig(**d)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(-np.pi, np.pi),
       dx=st.floats(-500, 500), dy=st.floats(-500, 500), mirror=st.booleans())
def test_rotating_translating_and_mirroring_the_scene(seed, angle, dx, dy, mirror) -> None:
    c = scene(np.random.default_rng(seed), 64)
    r, s = solve_impact(c), solve_impact(rotated(c, angle, dx, dy, mirror))
    np.testing.assert_array_equal(r.impact_type, s.impact_type)
    sign = -1.0 if mirror else 1.0
    for name in ("delta_v", "ees", "energy_loss", "closing_speed", "impulse_n",
                 "velocity_angle_change"):
        np.testing.assert_allclose(getattr(s, name), getattr(r, name), rtol=1e-7, atol=1e-6,
                                   err_msg=name)
    for name in ("impulse_t", "sliding_speed", "yaw_rate_post"):
        np.testing.assert_allclose(getattr(s, name), sign * getattr(r, name), rtol=1e-7,
                                   atol=1e-6, err_msg=name)
    hit = r.impact_type != IMPACT_NONE
    d_pdof = np.mod(s.pdof[hit] - sign * r.pdof[hit] + np.pi, 2 * np.pi) - np.pi
    np.testing.assert_allclose(d_pdof, 0.0, atol=1e-6)
    # vectors turn with the scene
    co, si = np.cos(angle), np.sin(angle)
    vy = sign * r.vy_post
    np.testing.assert_allclose(s.vx_post, co * r.vx_post - si * vy, rtol=1e-7, atol=1e-6)
    np.testing.assert_allclose(s.vy_post, si * r.vx_post + co * vy, rtol=1e-7, atol=1e-6)
    ny = sign * r.normal_y
    np.testing.assert_allclose(s.normal_x, co * r.normal_x - si * ny, atol=1e-9)


def test_exchanging_the_vehicles_and_a_common_velocity() -> None:
    c = scene(np.random.default_rng(17), 300)
    r, s = solve_impact(c), solve_impact(c.swapped())
    np.testing.assert_array_equal(r.impact_type, s.impact_type)
    for name in ("delta_v", "ees", "vx_post", "yaw_rate_post", "pdof", "pdof_clock"):
        np.testing.assert_allclose(getattr(s, name), getattr(r, name)[:, ::-1], rtol=1e-9,
                                   atol=1e-6, err_msg=name)
    for name in ("impulse_t", "impulse_n", "closing_speed", "sliding_speed", "energy_loss"):
        np.testing.assert_allclose(getattr(s, name), getattr(r, name), rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(s.normal_x, -r.normal_x, atol=1e-12)
    np.testing.assert_allclose(s.impulse_y, -r.impulse_y, rtol=1e-9, atol=1e-6)
    # Galilean: the same velocity added to both bodies changes no velocity change
    g = c._replace(vx=c.vx + 7.0, vy=c.vy - 3.0)
    q = solve_impact(g)
    for name in ("delta_vx", "delta_vy", "energy_loss", "yaw_rate_post", "impulse_t"):
        np.testing.assert_allclose(getattr(q, name), getattr(r, name), rtol=1e-8, atol=1e-6)


def test_pdof_closed_forms_for_a_turned_vehicle() -> None:
    """Vehicle 1 heading 30 deg is hit by a slow particle-like body 2: from ahead (pdof 0,
    12 o'clock), from its right (pi/2, 3 o'clock), from its left (-pi/2, 9 o'clock) and
    from behind (pi, 6 o'clock)."""
    yaw = np.radians(30.0)
    fwd = np.array([np.cos(yaw), np.sin(yaw)])
    right = np.array([np.sin(yaw), -np.cos(yaw)])
    for side, pdof, clock in ((fwd, 0.0, 12), (right, np.pi / 2, 3), (-right, -np.pi / 2, 9),
                              (-fwd, np.pi, 6)):
        poi = 2.0 * side
        cg2 = 4.0 * side
        phi = np.arctan2(side[1], side[0]) + np.pi / 2  # plane perpendicular to the line
        c = ImpactConfig.from_arrays(
            m=[1500.0, 1000.0], izz=[1e9, 1e9], x=[0.0, cg2[0]], y=[0.0, cg2[1]],
            yaw=[yaw, 0.3], vx=[0.0, -5.0 * side[0]], vy=[0.0, -5.0 * side[1]],
            yaw_rate=0.0, poi_x=poi[0], poi_y=poi[1], cp_angle=phi, restitution=0.2,
            contact_friction=0.5)
        r = solve_impact(c)
        assert r.impact_type[0] == IMPACT_FULL
        d = np.mod(r.pdof[0, 0] - pdof + np.pi, 2 * np.pi) - np.pi
        assert abs(d) < 1e-6 and r.pdof_clock[0, 0] == clock
        # central impact along the line: delta-v closed form m2 (1 + eps) w / (m1 + m2)
        assert r.delta_v[0, 0] == pytest.approx(1000.0 * 1.2 * 5.0 / 2500.0, rel=1e-6)
        assert r.delta_v[0, 1] == pytest.approx(1500.0 * 1.2 * 5.0 / 2500.0, rel=1e-6)
    # a separating pair: no impact, no pdof, clock 0, velocities unchanged
    sep = c._replace(vx=-c.vx, vy=-c.vy)
    r = solve_impact(sep)
    assert r.impact_type[0] == IMPACT_NONE and np.isnan(r.pdof).all()
    assert (r.pdof_clock == 0).all() and (r.delta_v == 0).all()
    assert impact_type_names(r.impact_type).tolist() == ["none"]
    assert r.impact_type_name.tolist() == ["none"]


def test_contact_frame_orientation_and_the_degenerate_plane() -> None:
    base = dict(m=1000.0, izz=1500.0, yaw=0.0, yaw_rate=0.0, restitution=0.1,
                contact_friction=0.5)
    # CG 1 left of CG 2, plane vertical: n points towards vehicle 1 (-x), whatever cp_angle's
    # orientation
    for phi in (np.pi / 2, -np.pi / 2, 3 * np.pi / 2):
        c = ImpactConfig.from_arrays(x=[0.0, 4.0], y=[1.0, 1.0], vx=[10.0, 0.0], vy=0.0,
                                     poi_x=2.0, poi_y=1.0, cp_angle=phi, **base)
        f = contact_frame(c)
        assert f.nx[0] == pytest.approx(-1.0) and f.ny[0] == pytest.approx(0.0, abs=1e-12)
        assert (f.tx[0], f.ty[0]) == pytest.approx((f.ny[0], -f.nx[0]))
        assert f.u_n[0] == pytest.approx(-10.0) and f.u_t[0] == pytest.approx(0.0, abs=1e-12)
    # CGs on the plane line (side = 0): n against the relative POI velocity
    for vy1, expected in ((3.0, -1.0), (-3.0, 1.0)):
        c = ImpactConfig.from_arrays(x=[0.0, 4.0], y=[0.0, 0.0], vx=0.0, vy=[vy1, 0.0],
                                     poi_x=2.0, poi_y=0.0, cp_angle=0.0, **base)
        f = contact_frame(c)
        assert f.ny[0] == pytest.approx(expected) and f.u_n[0] == pytest.approx(-3.0)
    # nearly on the line: 1e-9 of the CG distance decides
    c = ImpactConfig.from_arrays(x=[0.0, 4000.0], y=[2e-6, 0.0], vx=0.0, vy=[3.0, 0.0],
                                 poi_x=2.0, poi_y=0.0, cp_angle=0.0, **base)
    assert contact_frame(c).ny[0] == pytest.approx(-1.0)
    c = c._replace(y=np.array([[6e-6, 0.0]]))
    assert contact_frame(c).ny[0] == pytest.approx(1.0)
    # CGs closer than 1 m: the tolerance is 1e-9 m, not 1e-9 of the distance
    c = ImpactConfig.from_arrays(x=[0.0, 1.0], y=[1.5e-9, 0.0], vx=0.0, vy=[3.0, 0.0],
                                 poi_x=0.5, poi_y=0.0, cp_angle=0.0, **base)
    assert contact_frame(c).ny[0] == pytest.approx(1.0)  # side 1.5e-9 > 1e-9: by the CGs
    c = c._replace(y=np.array([[0.5e-9, 0.0]]))
    assert contact_frame(c).ny[0] == pytest.approx(-1.0)  # within: against u


def test_energy_split_rules_and_fixed_objects() -> None:
    e1, e2 = energy_split(900.0, 1000.0, 2000.0)
    assert (float(e1), float(e2)) == pytest.approx((600.0, 300.0))  # E1 / E2 = m2 / m1
    e1, e2 = energy_split([900.0, 900.0, 900.0], 1000.0, 2000.0, [0.5, np.nan, 2.0])
    # k1 / k2 = 0.5: E1 / E2 = k2 / k1 = 2; NaN: the mass rule; 2: E1 / E2 = 1 / 2
    np.testing.assert_allclose(e1, [600.0, 600.0, 300.0])
    np.testing.assert_allclose(e2, [300.0, 300.0, 600.0])
    e1, e2 = energy_split([100.0, 100.0], [np.inf, 1000.0], [1000.0, np.inf])
    np.testing.assert_array_equal(e1, [0.0, 100.0])
    np.testing.assert_array_equal(e2, [100.0, 0.0])
    assert inverse_mass(np.inf) == 0.0 and inverse_mass(4.0) == 0.25
    np.testing.assert_array_equal(fixed_object([np.inf, np.inf, 1.0], [np.inf, 1.0, np.inf]),
                                  [True, False, False])


def test_stiffness_ratio_follows_the_impacts_across_blocks() -> None:
    """A per-impact stiffness ratio beyond the first block of CHUNK impacts stays with its
    impact: the EES of row k equals that of row k solved alone."""
    n = impact.CHUNK + 40
    base = scene(np.random.default_rng(18), 40)
    reps = -(-n // 40)
    c = ImpactConfig(*(np.concatenate([a] * reps)[:n] for a in base))
    ratio = np.geomspace(0.25, 4.0, n)
    r = solve_impact(c, ratio)
    for k in (0, 7, impact.CHUNK - 1, impact.CHUNK, impact.CHUNK + 11, n - 1):
        one = solve_impact(ImpactConfig(*(a[k:k + 1] for a in c)), ratio[k:k + 1])
        np.testing.assert_array_equal(r.ees[k], one.ees[0])
        np.testing.assert_array_equal(r.vx_post[k], one.vx_post[0])
    # E1 / E2 = k2 / k1 = 1 / ratio wherever there is an impact
    e1, e2 = deformation_energies(c, r)
    hit = r.energy_loss > 1.0
    np.testing.assert_allclose(e1[hit] * ratio[hit], e2[hit], rtol=1e-9)
    assert hit[impact.CHUNK:].sum() > 5


def test_deformation_energies_and_with_outcome() -> None:
    c = scene(np.random.default_rng(19), 200)
    r = solve_impact(c)
    e1, e2 = deformation_energies(c, r)
    np.testing.assert_allclose(e1, 0.5 * c.m[:, 0] * r.ees[:, 0] ** 2, rtol=1e-12)
    np.testing.assert_allclose(e2, 0.5 * c.m[:, 1] * r.ees[:, 1] ** 2, rtol=1e-12)
    # with_outcome: the same velocities give the same result; other ones their delta-v
    same = with_outcome(c, r, vx=r.vx_post, vy=r.vy_post, yaw_rate=r.yaw_rate_post)
    for name in r._fields:
        np.testing.assert_allclose(getattr(same, name), getattr(r, name), rtol=1e-12,
                                   atol=1e-12, err_msg=name)
    vx, vy = r.vx_post * 0.5, r.vy_post + 1.0
    energy = np.stack([e1 * 2.0, e2 * 0.5], axis=1)
    new = with_outcome(c, r, vx=vx, vy=vy, yaw_rate=r.yaw_rate_post * 0, energy=energy)
    np.testing.assert_allclose(new.delta_vx, vx - c.vx)
    np.testing.assert_allclose(new.delta_v, np.hypot(vx - c.vx, vy - c.vy))
    np.testing.assert_allclose(new.velocity_angle_change, angle_between(c.vx, c.vy, vx, vy))
    hit = r.impact_type != IMPACT_NONE
    np.testing.assert_allclose(new.ees[hit, 0], np.sqrt(2.0) * r.ees[hit, 0], rtol=1e-9)
    np.testing.assert_array_equal(new.ees[~hit], r.ees[~hit])
    np.testing.assert_array_equal(new.impulse_x, r.impulse_x)
    assert (new.yaw_rate_post == 0).all()
    # a fixed object: infinite mass, EES 0 and energy 0
    fixed = c._replace(m=np.stack([c.m[:, 0], np.full(200, np.inf)], axis=1),
                       izz=np.stack([c.izz[:, 0], np.full(200, np.inf)], axis=1))
    fr = solve_impact(fixed)
    f1, f2 = deformation_energies(fixed, fr)
    np.testing.assert_array_equal(f2, 0.0)
    np.testing.assert_allclose(f1, fr.energy_loss, rtol=1e-9, atol=1e-9)


def test_angle_between_closed_form_and_the_short_vector_threshold() -> None:
    a = angle_between(np.array([1.0, 1.0, 0.0, 0.9999e-3, 1.0001e-3]),
                      np.array([0.0, 0.0, 2.0, 0.0, 0.0]), np.array([0.0, -3.0, 0.0, 1.0, 1.0]),
                      np.array([5.0, 0.0, -1.0, 0.0, 0.0]))
    np.testing.assert_allclose(a[:3], [np.pi / 2, np.pi, np.pi])
    assert np.isnan(a[3]) and a[4] == 0.0  # below 1 mm/s: short


def good_row() -> dict[str, float]:
    return dict(m1=1500.0, izz1=2500.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=20.0, vy1=0.0,
                yaw_rate1=0.0, m2=1000.0, izz2=1600.0, x2=4.0, y2=0.0, yaw2=np.pi, vx2=-10.0,
                vy2=0.0, yaw_rate2=0.0, poi_x=2.0, poi_y=0.0, cp_angle=np.pi / 2,
                restitution=0.2, contact_friction=0.5)


@pytest.mark.parametrize("name", CONFIG_COLUMNS)
def test_range_bounds_are_closed_and_exact(name: str) -> None:
    """Each bound of CONFIG_RANGES is allowed; the next float beyond it is flagged."""
    lo, hi = CONFIG_RANGES[name]
    values = [lo, hi, np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf), np.nan]
    cols = {k: np.full(len(values), v) for k, v in good_row().items()}
    cols[name] = np.array(values)
    bad = config_problems(ImpactConfig.from_columns(**cols))
    assert list(bad) == [name]
    np.testing.assert_array_equal(bad[name], [False, False, True, True, True])
    assert config_problems(ImpactConfig.from_columns(**good_row())) == {}
    text = describe_range(name)
    assert text.startswith("finite") and (f"{hi:g}" in text)


def test_fixed_object_is_exempt_from_the_mass_bounds_only_alone() -> None:
    cols = {k: np.full(4, v) for k, v in good_row().items()}
    inf = np.inf
    cols["m1"] = np.array([inf, 1500.0, inf, inf])
    cols["izz1"] = np.array([inf, 2500.0, 2500.0, inf])
    cols["m2"] = np.array([1000.0, inf, 1000.0, inf])
    cols["izz2"] = np.array([1600.0, inf, 1600.0, inf])
    bad = config_problems(ImpactConfig.from_columns(**cols))
    # row 0: vehicle 1 fixed; row 1: vehicle 2 fixed; row 2: mass inf, inertia finite;
    # row 3: both fixed
    np.testing.assert_array_equal(bad["m1"], [False, False, True, True])
    np.testing.assert_array_equal(bad["izz1"], [False, False, False, True])
    np.testing.assert_array_equal(bad["m2"], [False, False, False, True])
    np.testing.assert_array_equal(bad["izz2"], [False, False, False, True])
    assert "fixed object" in describe_range("m2")
    assert describe_range("unknown_field") == "finite"


@pytest.mark.parametrize("restitution, ok", [(0.0, True), (1.0, True), (-1e-12, False),
                                              (1.0 + 1e-12, False)])
def test_impact_params_bounds(restitution: float, ok: bool) -> None:
    if ok:
        assert ImpactParams(restitution=restitution).restitution == restitution
    else:
        with pytest.raises(ParameterError, match="restitution"):
            ImpactParams(restitution=restitution)
    assert ImpactParams(contact_friction=0.0).contact_friction == 0.0
    for mu in (-1e-12, np.inf, np.nan):
        with pytest.raises(ParameterError, match="contact_friction"):
            ImpactParams(contact_friction=mu)


def test_config_construction_round_trips_and_errors() -> None:
    c = ImpactConfig.from_columns(**good_row())
    cols = c.columns()
    assert list(cols) == list(CONFIG_COLUMNS)
    assert all(np.array_equal(a, b)
               for a, b in zip(ImpactConfig.from_columns(**cols), c, strict=True))
    arr = ImpactConfig.from_arrays(m=[1500.0, 1000.0], izz=[2500.0, 1600.0], x=[0.0, 4.0],
                                   y=0.0, yaw=[0.0, np.pi], vx=[[20.0, -10.0]] * 3, vy=0.0,
                                   yaw_rate=0.0, poi_x=2.0, poi_y=0.0, cp_angle=np.pi / 2,
                                   restitution=0.2, contact_friction=[0.5, 0.5, 0.5])
    assert arr.size == 3 and arr.m.shape == (3, 2)
    np.testing.assert_array_equal(arr.m[2], [1500.0, 1000.0])
    np.testing.assert_array_equal(arr.swapped().m[1], [1000.0, 1500.0])
    np.testing.assert_array_equal(arr.swapped().poi_x, arr.poi_x)
    for k in range(3):
        for f in arr._fields:
            np.testing.assert_array_equal(getattr(arr, f)[k], getattr(c, f)[0])
    with pytest.raises(ParameterError, match="unknown"):
        ImpactConfig.from_arrays(m1=1.0)
    with pytest.raises(ParameterError, match="missing"):
        ImpactConfig.from_arrays(m=1.0)
    with pytest.raises(ParameterError, match="missing"):
        ImpactConfig.from_columns(m1=1.0)
    with pytest.raises(ParameterError, match="per-vehicle"):
        ImpactConfig.from_arrays(**{**{f: 1.0 for f in ImpactConfig._fields},
                                    "m": np.ones((2, 3))})
    res_cols = solve_impact(c).columns()
    assert res_cols["delta_v1"].shape == (1,) and "energy_loss" in res_cols
    assert res_cols["delta_v2"][0] == solve_impact(c).delta_v[0, 1]


def test_deprecated_numbered_aliases_name_the_right_vehicle() -> None:
    c = ImpactConfig.from_columns(**good_row())
    r = solve_impact(c)
    with pytest.warns(DeprecationWarning, match=r"delta_v\[:, 1\]"):
        assert r.delta_v2[0] == r.delta_v[0, 1]
    with pytest.warns(DeprecationWarning):
        assert r.vx1_post[0] == r.vx_post[0, 0] and r.ees2[0] == r.ees[0, 1]
    with pytest.warns(DeprecationWarning):
        assert c.m1[0] == 1500.0 and c.izz2[0] == 1600.0


def test_the_documented_input_ranges() -> None:
    """CONFIG_RANGES as its comment documents them: masses up to 200 t, yaw inertias up to
    1e7 kg m^2 (both > 0), positions within 1,000 km, angles within +-1,000 rad, speeds up
    to 150 m/s, yaw rates up to 50 rad/s, restitution in [0, 1], friction in [0, 10]."""
    tiny = np.nextafter(0.0, 1.0)
    expected = {**{f"m{i}": (tiny, 2.0e5) for i in (1, 2)},
                **{f"izz{i}": (tiny, 1.0e7) for i in (1, 2)},
                **{k: (-1e6, 1e6) for k in ("x1", "y1", "x2", "y2", "poi_x", "poi_y")},
                **{k: (-1e3, 1e3) for k in ("yaw1", "yaw2", "cp_angle")},
                **{k: (-150.0, 150.0) for k in ("vx1", "vy1", "vx2", "vy2")},
                **{k: (-50.0, 50.0) for k in ("yaw_rate1", "yaw_rate2")},
                "restitution": (0.0, 1.0), "contact_friction": (0.0, 10.0)}
    assert CONFIG_RANGES == expected
    assert set(CONFIG_RANGES) == set(CONFIG_COLUMNS)
