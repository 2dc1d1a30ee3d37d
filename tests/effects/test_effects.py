"""Effect plugins: registry, parameters, neutral values, physics of each built-in effect."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.effects import (
    BUILTIN_EFFECTS,
    Effect,
    EffectParameter,
    VelocityChange,
    get_effect,
    parse_effect,
    register_effect,
    registered_effects,
    unregister_effect,
)
from vfs.effects import base as effects_base
from vfs.errors import ParameterError
from vfs.scenarios.random import synthetic_case_batch
from vfs.simulation import SimulationParams, simulate_cases


@pytest.fixture(scope="module")
def batch():
    b = synthetic_case_batch(60, np.random.default_rng(11))
    rng = np.random.default_rng(3)
    return b._replace(restitution=rng.uniform(0.05, 0.25, b.size),
                      contact_friction=rng.uniform(0.4, 0.8, b.size))


@pytest.fixture(scope="module")
def baseline(batch):
    return simulate_cases(batch)


def run(batch, *effects):
    return simulate_cases(batch, params=SimulationParams(effects=tuple(effects)))


OUTCOMES = ("delta_v1", "delta_v2", "ees1", "ees2", "vx1_post", "vy1_post", "yaw_rate1_post")


def outcome(res, name):
    """A table column of the impact result (``delta_v1``, ``ees2``, ...)."""
    return res.impact.columns()[name]


def rest(res):
    ro = res.runout
    return np.stack([ro.rest_x[:, 0], ro.rest_y[:, 0], ro.rest_x[:, 1], ro.rest_y[:, 1]], axis=1)


# ----------------------------------------------------------------- registry


def test_builtin_effects_are_registered_with_documented_parameters():
    effects = registered_effects()
    assert set(BUILTIN_EFFECTS) <= set(effects)
    for name in BUILTIN_EFFECTS:
        cls = effects[name]
        # every built-in effect cites its source (a paper or chapter of docs/references.md)
        doc = cls.__doc__ or ""
        assert any(w in doc for w in ("paper", "chapter", "references.md")), name
        assert cls.stages(), name
        assert cls.parameters and cls.summary and cls.outputs
        for p in cls.parameters:
            assert p.lo <= p.default <= p.hi and p.unit


def test_parse_effect_forms_and_errors():
    e = parse_effect("restitution_speed")
    assert e["exponent"] == 0.8
    assert parse_effect("restitution_speed=1.5")["exponent"] == 1.5
    e = parse_effect("penetration_depth:overlap_factor=0.5,depth=0.7")
    assert (e["overlap_factor"], e["depth"], e["speed_exponent"]) == (0.5, 0.7, 1.3)
    with pytest.raises(ParameterError, match="known: .*restitution_speed"):
        parse_effect("no_such_effect")
    with pytest.raises(ParameterError, match=r"is out of range \(allowed: \[0, 3\]\)"):
        parse_effect("restitution_speed=7")
    with pytest.raises(ParameterError, match="unknown parameter"):
        parse_effect("tyre_impulse:speed=3")
    with pytest.raises(ParameterError, match="not a number"):
        parse_effect("tyre_impulse=fast")


def test_effects_are_immutable_and_compare_by_value():
    a, b = get_effect("tyre_impulse")(), get_effect("tyre_impulse")(duration=0.1)
    assert a == b and hash(a) == hash(b)
    assert a.replace(duration=0.2) != a
    with pytest.raises(AttributeError):
        a.x = 1  # type: ignore[attr-defined]
    v = a.vector()
    assert type(a).from_vector(v) == a
    with pytest.raises(ParameterError, match="listed twice"):
        SimulationParams(effects=(a, b))


def test_user_effect_registers_and_runs(batch, baseline):
    @register_effect
    class DoubleYawRate(Effect):
        """Test effect: post-impact yaw rates scaled by a factor (no source; a test)."""

        name = "test_double_yaw_rate"
        parameters = (EffectParameter("factor", 2.0, 0.0, 5.0, "-", "scale", 1.0),)
        summary = "test"
        outputs = ("yaw_rate_post",)

        def contact_impulse(self, ctx, config, result):
            zero = np.zeros((config.size, 2))
            f = self["factor"] - 1.0
            return VelocityChange(zero, zero, f * result.yaw_rate_post)

    try:
        assert get_effect("test_double_yaw_rate") is DoubleYawRate
        res = run(batch, parse_effect("test_double_yaw_rate=3"))
        hit = baseline.precrash.collided
        np.testing.assert_allclose(res.impact.yaw_rate_post[hit, 0],
                                   3 * baseline.impact.yaw_rate_post[hit, 0], rtol=1e-12)
        with pytest.raises(ParameterError, match="already registered"):
            register_effect(type("DoubleYawRate", (DoubleYawRate,), {"__module__": "other"}))
    finally:
        unregister_effect("test_double_yaw_rate")
    with pytest.raises(ParameterError, match="overrides no stage"):
        register_effect(type("Nothing", (Effect,), {"name": "nothing"}))


def test_entry_point_effects_are_loaded(monkeypatch):
    class FakeEntryPoint:
        name = "test_ep_effect"
        value = "somewhere:Cls"

        def load(self):
            class EpEffect(Effect):
                """Test."""

                name = "test_ep_effect"

                def impact_parameters(self, ctx, config):
                    return config

            return EpEffect

    import vfs.registry

    monkeypatch.setattr(effects_base.EFFECTS, "_entry_points_loaded", False)
    monkeypatch.setattr(vfs.registry.metadata, "entry_points",
                        lambda group: [FakeEntryPoint()] if group == "vfs.effects" else [])
    try:
        assert get_effect("test_ep_effect").name == "test_ep_effect"
    finally:
        unregister_effect("test_ep_effect")


# ------------------------------------------------------- neutral = no effect


@pytest.mark.parametrize("name", BUILTIN_EFFECTS)
def test_neutral_parameters_change_nothing(name, batch, baseline):
    cls = get_effect(name)
    neutral = {p.name: p.neutral for p in cls.parameters if p.neutral is not None}
    if name == "penetration_depth":  # d0 = 0.6 m, a = 1, c = 0 is the fixed 30 ms
        neutral = {"overlap_factor": 0.0, "speed_exponent": 1.0, "depth": 0.6}
    res = run(batch, cls(**neutral))
    hit = baseline.precrash.collided
    assert hit.sum() > 30
    np.testing.assert_array_equal(res.precrash.collided, hit)
    for field in OUTCOMES:
        np.testing.assert_allclose(outcome(res, field)[hit], outcome(baseline, field)[hit],
                                   rtol=1e-9, atol=1e-9, err_msg=f"{name}: {field}")
    np.testing.assert_allclose(rest(res)[hit], rest(baseline)[hit], atol=1e-6)


@pytest.mark.parametrize("name", BUILTIN_EFFECTS)
def test_nominal_strength_changes_its_outputs(name, batch, baseline):
    res = run(batch, get_effect(name)())
    hit = baseline.precrash.collided
    changed = {
        "delta_v": np.abs(res.impact.delta_v[:, 0] - baseline.impact.delta_v[:, 0])[hit].max(),
        "ees": np.abs(res.impact.ees[:, 0] - baseline.impact.ees[:, 0])[hit].max(),
        "rest": np.abs(rest(res) - rest(baseline))[hit].max(),
    }
    expect = {
        "restitution_speed": {"delta_v", "ees", "rest"},
        "tyre_impulse": {"delta_v", "rest"},
        "body_friction": {"ees"},
        "penetration_depth": {"delta_v", "ees", "rest"},
        "structure_poi": {"delta_v", "ees", "rest"},
        "wheel_lock": {"rest"},
        "ees_stiffness": {"ees"},
        "yaw_inertia": {"delta_v", "ees", "rest"},
    }[name]
    for key, value in changed.items():
        if key in expect:
            assert value > 1e-3, f"{name} should change {key}"
        else:
            assert value < 1e-9, f"{name} must not change {key} ({value})"


# ------------------------------------------------------- physics per effect


def test_restitution_falls_with_closing_speed(batch, baseline):
    res = run(batch, get_effect("restitution_speed")(exponent=1.0, reference_speed=15.0,
                                                     cap=0.8))
    hit = baseline.precrash.collided
    v_c = np.maximum(res.impact.closing_speed[hit], 2.0)
    expected = np.minimum(batch.restitution[hit] * 15.0 / v_c, 0.8)
    np.testing.assert_allclose(res.restitution[hit], expected, rtol=1e-12)
    # the recorded input is untouched for cases without a collision
    np.testing.assert_array_equal(res.restitution[~hit], batch.restitution[~hit])
    # the default cap is the top of the 0.1-0.3 range for real deformations
    capped = run(batch, get_effect("restitution_speed")(exponent=1.0, reference_speed=15.0))
    np.testing.assert_allclose(capped.restitution[hit], np.minimum(expected, 0.3), rtol=1e-12)
    assert (capped.restitution[hit] == 0.3).any()


def test_tyre_impulse_slows_but_never_reverses(batch, baseline):
    res = run(batch, get_effect("tyre_impulse")(duration=0.4, brake_factor=1.0))
    hit = baseline.precrash.collided
    new, old = res.impact, baseline.impact
    for j in (0, 1):
        b = np.hypot(old.vx_post[:, j], old.vy_post[:, j])[hit]
        e = np.hypot(new.vx_post[:, j], new.vy_post[:, j])[hit]
        assert np.all(e <= b + 1e-12)
        # the change is at most b mu g T
        change = np.hypot(new.vx_post[:, j] - old.vx_post[:, j],
                          new.vy_post[:, j] - old.vy_post[:, j])[hit]
        assert np.all(change <= batch.road_friction[hit] * 9.80665 * 0.4 + 1e-9)
    # the impulse exchange itself (EES, energy loss, impact type) is unchanged
    np.testing.assert_allclose(res.impact.ees[hit, 0], baseline.impact.ees[hit, 0], rtol=1e-12)
    np.testing.assert_array_equal(res.impact.impact_type, baseline.impact.impact_type)


def test_body_friction_only_lowers_ees(batch, baseline):
    res = run(batch, get_effect("body_friction")(share=1.0))
    hit = baseline.precrash.collided
    e_base = 0.5 * batch.vehicle1.mass * baseline.impact.ees[:, 0]**2 + \
        0.5 * batch.vehicle2.mass * baseline.impact.ees[:, 1]**2
    e_new = 0.5 * batch.vehicle1.mass * res.impact.ees[:, 0]**2 + \
        0.5 * batch.vehicle2.mass * res.impact.ees[:, 1]**2
    assert np.all(e_new[hit] <= e_base[hit] + 1e-6)
    assert np.all(e_new[hit] >= 0)
    # sliding impacts dissipate tangential work: some energy is removed there
    sliding = hit & (baseline.impact.impact_type == 2)
    assert sliding.any() and np.all(e_new[sliding] < e_base[sliding])
    # the split ratio between the vehicles stays the mass rule
    ratio_b = baseline.impact.ees[hit, 0] / baseline.impact.ees[hit, 1]
    ratio_n = res.impact.ees[hit, 0] / res.impact.ees[hit, 1]
    ok = np.isfinite(ratio_n)
    np.testing.assert_allclose(ratio_n[ok], ratio_b[ok], rtol=1e-9)


def test_ees_stiffness_keeps_the_total_and_reduces_to_the_mass_rule(batch, baseline):
    hit = baseline.precrash.collided
    res = run(batch, get_effect("ees_stiffness")(mass_exponent=0.0, side_factor=1.0))
    m1, m2 = batch.vehicle1.mass, batch.vehicle2.mass
    total = 0.5 * m1 * res.impact.ees[:, 0]**2 + 0.5 * m2 * res.impact.ees[:, 1]**2
    np.testing.assert_allclose(total[hit], baseline.impact.energy_loss[hit], rtol=1e-9)
    # equal stiffness: equal energies
    np.testing.assert_allclose((0.5 * m1 * res.impact.ees[:, 0]**2)[hit],
                               (0.5 * m2 * res.impact.ees[:, 1]**2)[hit], rtol=1e-9)


def test_penetration_depth_grows_with_small_overlap(batch, baseline):
    res = run(batch, get_effect("penetration_depth")(overlap_factor=2.0, speed_exponent=1.0,
                                                     depth=0.6))
    hit = baseline.precrash.collided
    t_pen = (res.precrash.impact_time - res.precrash.contact_time)[hit]
    assert np.all(t_pen >= 0.03 - 1e-12) and np.all(t_pen <= 0.15 + 1e-12)
    assert np.any(t_pen > 0.035)
    np.testing.assert_allclose(res.precrash.contact_time[hit],
                               baseline.precrash.contact_time[hit])


def _head_on_context(angle_deg: float, offset: float):
    from vfs.effects.context import ImpactContext
    from vfs.physics.impact import ImpactConfig
    from vfs.physics.precrash import KinematicState
    from vfs.physics.vehicle import VehicleParams, stack_vehicles

    v = stack_vehicles([VehicleParams()])
    front = float(v.cg_to_front[0])
    a = np.radians(angle_deg)
    yaw2 = np.pi + a
    x2 = 2 * front - 0.3  # penetrated 0.3 m
    state = KinematicState(*(np.array([[p, q]], float) for p, q in (
        (0, x2), (0, offset), (0, yaw2), (15, -15 * np.cos(a)), (0, -15 * np.sin(a)), (0, 0),
        (15, 15))))
    ctx = ImpactContext(np.array([0]), v, v, state, np.array([0.8]), np.array([0.0]),
                        np.array([0.03]))
    c = ctx.overlap.centroid[0]
    config = ImpactConfig.from_columns(
        m1=1500, izz1=2500, x1=0, y1=0, yaw1=0, vx1=15, vy1=0, yaw_rate1=0, m2=1500, izz2=2500,
        x2=x2, y2=offset, yaw2=yaw2, vx2=state.vx[0, 1], vy2=state.vy[0, 1], yaw_rate2=0,
        poi_x=c[0], poi_y=c[1], cp_angle=np.radians(60), restitution=0.1, contact_friction=0.6)
    return ctx, config, v


def test_structure_poi_moves_to_the_rails_and_the_plane_to_the_fronts():
    eff = get_effect("structure_poi")
    # offset = one rail spacing: the left rails of both cars meet at y = 0.6 w / 2
    ctx, config, v = _head_on_context(0.0, 0.6 * 1.8)
    same = eff(strength=0.0, poi_share=0.0).impact_configuration(ctx, config)
    assert all(np.array_equal(a, b) for a, b in zip(same, config, strict=True))
    full = eff(strength=1.0, poi_share=1.0).impact_configuration(ctx, config)
    assert full.poi_y[0] == pytest.approx(0.6 * 0.9, abs=1e-12)
    assert full.poi_x[0] == pytest.approx(config.poi_x[0], abs=1e-12)
    assert np.degrees(full.cp_angle[0]) % 180 == pytest.approx(90.0, abs=1e-9)
    half = eff(strength=0.5, poi_share=0.5).impact_configuration(ctx, config)
    assert half.poi_y[0] == pytest.approx(0.5 * (config.poi_y[0] + 0.54), abs=1e-12)
    assert np.degrees(half.cp_angle[0]) == pytest.approx(75.0, abs=1e-9)
    # a 10 deg relative angle: the plane is the mean of the two bumper lines
    ctx, config, _ = _head_on_context(10.0, 1.1)
    full = eff(strength=1.0).impact_configuration(ctx, config)
    assert np.degrees(full.cp_angle[0]) % 180 == pytest.approx(95.0, abs=1e-9)


def test_wheel_lock_locks_front_wheels_of_deep_frontal_damage(batch, baseline):
    res = run(batch, get_effect("wheel_lock")(depth=0.3))
    hit = baseline.precrash.collided
    b = res.wheel_brake[hit]
    locked = b[:, :, 0] == 1.0
    assert locked.any() and (~locked).any()
    np.testing.assert_array_equal(b[:, :, 0], b[:, :, 1])  # both front wheels
    np.testing.assert_array_equal(b[:, :, 2:], 0.8)  # rear wheels keep the default


def test_yaw_inertia_scales_only_unknown_inertias(batch):
    eff = get_effect("yaw_inertia")(factor=1.5)
    known = np.zeros((batch.size, 2), dtype=bool)
    known[::2, 0] = True
    b = eff.vehicles(batch._replace(yaw_inertia_known=known))
    np.testing.assert_allclose(b.vehicle1.yaw_inertia,
                               np.where(known[:, 0], 1.0, 1.5) * batch.vehicle1.yaw_inertia)
    np.testing.assert_allclose(b.vehicle2.yaw_inertia, 1.5 * batch.vehicle2.yaw_inertia)


def test_all_effects_together_are_mirror_symmetric(batch):
    from tests.test_simulation import mirrored

    effects = tuple(get_effect(n)() for n in BUILTIN_EFFECTS)
    a = run(batch, *effects)
    b = run(mirrored(batch), *effects)
    hit = a.precrash.collided
    np.testing.assert_array_equal(hit, b.precrash.collided)
    np.testing.assert_array_equal(a.impact.impact_type, b.impact.impact_type)
    for f in ("delta_v1", "delta_v2", "ees1", "ees2"):
        np.testing.assert_allclose(outcome(a, f)[hit], outcome(b, f)[hit], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(a.runout.rest_y[hit, 0], -b.runout.rest_y[hit, 0],
                               atol=1e-4)
