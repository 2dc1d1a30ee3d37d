"""Learned-law effects written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): each closed form at hand-computed points, the
table law and its strength, the clip to the channel's range and the shift channels, the
features of a turned scene, the validation messages, the coefficient bounds, and each
hook applied where (and only where) its channel asks.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from vfs.effects.base import Effect
from vfs.effects.learned import (
    CHANNELS,
    FORMS,
    LAW_FEATURES,
    check_law,
    evaluate_law,
    feature_values,
    law_effect_class,
    law_text,
    normal_closing_speed,
)
from vfs.errors import ParameterError
from vfs.physics.impact import ImpactConfig, contact_frame, solve_impact
from vfs.physics.post_impact import PostImpactInputs
from vfs.physics.precrash import PrecrashParams

X = np.array([-1.0, 0.0, 0.5, 2.0, 10.0])


def test_closed_forms_at_hand_computed_points() -> None:
    def law(form: str, *coef: float) -> np.ndarray:
        return evaluate_law({"form": form, "coefficients": list(coef)}, X)

    np.testing.assert_allclose(law("constant", 0.3), 0.3)
    np.testing.assert_allclose(law("linear", 0.5, -2.0), 0.5 - 2.0 * X)
    np.testing.assert_allclose(law("power", 2.0, 0.5)[2:], 2.0 * np.sqrt(X[2:]))
    # power clamps x at 1e-9 (no NaN for x <= 0)
    np.testing.assert_allclose(law("power", 2.0, 0.5)[:2], 2.0 * np.sqrt(1e-9))
    np.testing.assert_allclose(law("exponential", 3.0, -0.5), 3.0 * np.exp(-0.5 * X))
    # saturating: a + b (1 - exp(-max(x, 0) / c)); c = 0 is clamped to 1e-9
    np.testing.assert_allclose(law("saturating", 1.0, 2.0, 4.0),
                               1.0 + 2.0 * (1.0 - np.exp(-np.maximum(X, 0.0) / 4.0)))
    np.testing.assert_allclose(law("saturating", 1.0, 2.0, 0.0), [1.0, 1.0, 3.0, 3.0, 3.0])
    # step: a + b where x >= c (inclusive)
    np.testing.assert_allclose(law("step", 0.3, -0.2, 0.5), [0.3, 0.3, 0.1, 0.1, 0.1])
    # coefficients passed explicitly override the law's
    got = evaluate_law({"form": "linear", "coefficients": [0.0, 0.0]}, X, [1.0, 1.0])
    np.testing.assert_allclose(got, 1.0 + X)
    table = {"form": "table", "table": {"x": [0.0, 2.0, 4.0], "y": [1.0, 3.0, 2.0]}}
    np.testing.assert_allclose(evaluate_law(table, X), [1.0, 1.0, 1.5, 3.0, 2.0])


def test_law_validation_messages() -> None:
    good = {"name": "r_of_v", "channel": "restitution", "feature": "closing_speed",
            "form": "linear", "coefficients": [0.3, -0.01]}
    assert check_law(good) == good and check_law(good) is not good
    for key in ("name", "channel", "feature", "form"):
        with pytest.raises(ParameterError, match=f"missing key '{key}'"):
            check_law({k: v for k, v in good.items() if k != key})
    with pytest.raises(ParameterError, match="unknown channel"):
        check_law({**good, "channel": "mass"})
    with pytest.raises(ParameterError, match="unknown feature"):
        check_law({**good, "feature": "colour"})
    with pytest.raises(ParameterError, match="letters, digits"):
        check_law({**good, "name": "1 bad"})
    with pytest.raises(ParameterError, match="needs 2 coefficients"):
        check_law({**good, "coefficients": [0.3]})
    with pytest.raises(ParameterError, match="law form"):
        check_law({**good, "form": "cubic"})


def test_law_text_and_the_generated_class() -> None:
    law = {"name": "r_step", "channel": "restitution", "feature": "closing_speed",
           "form": "step", "coefficients": [0.3, -0.2, 12.0]}
    assert law_text(law) == ("restitution = 0.3 + -0.2 [x >= 12]; x = closing_speed "
                             f"[{LAW_FEATURES['closing_speed']}]")
    table = {"name": "t", "channel": "restitution", "feature": "overlap", "form": "table",
             "table": {"x": [0.0, 1.0, 2.0], "y": [0.1, 0.2, 0.3]}}
    assert law_text(table) == "restitution = table(overlap, 3 knots)"
    cls = law_effect_class(law)
    assert cls.__name__ == "Law_r_step" and cls.name == "r_step"
    params = {p.name: p for p in cls.parameters}
    # default bounds: +-10 times the magnitude, at least +-1, always holding the value
    assert (params["a"].lo, params["a"].hi) == (-3.0, 3.0)
    assert (params["b"].lo, params["b"].hi) == (-2.0, 2.0)
    assert (params["c"].lo, params["c"].hi) == (-120.0, 120.0)
    small = law_effect_class({**law, "coefficients": [0.01, 0.0, 0.05]})
    assert all((p.lo, p.hi) == (-1.0, 1.0) for p in small.parameters)
    given = law_effect_class(law, {"a": (0.0, 0.2)})
    assert {p.name: (p.lo, p.hi) for p in given.parameters}["a"] == (0.0, 0.3)  # holds 0.3
    const = law_effect_class({**law, "form": "constant", "coefficients": [0.5]})
    ch = CHANNELS["restitution"]
    assert [(p.lo, p.hi) for p in const.parameters] == [(ch.lo, ch.hi)]
    t = law_effect_class(table)
    assert [p.name for p in t.parameters] == ["strength"]
    # only the channel's own hook is overridden; the others are Effect's (no-ops)
    assert cls.impact_parameters is not Effect.impact_parameters
    for hook in ("penetration", "impact_configuration", "contact_impulse", "energy_split",
                 "post_impact"):
        assert getattr(cls, hook) is getattr(Effect, hook), hook


def scene(n: int = 6, heading: float = 0.7) -> tuple[SimpleNamespace, ImpactConfig]:
    """A duck-typed hook context and an impact configuration: vehicle 1 heading
    ``heading`` at 10..20 m/s into a slower vehicle 2 ahead of it."""
    rng = np.random.default_rng(7)
    v1 = np.linspace(10.0, 20.0, n)
    c, s = np.cos(heading), np.sin(heading)
    yaw = np.stack([np.full(n, heading), np.full(n, heading + 0.4)], axis=1)
    vx = np.stack([v1 * c, 3.0 * np.cos(heading + 0.4) * np.ones(n)], axis=1)
    vy = np.stack([v1 * s, 3.0 * np.sin(heading + 0.4) * np.ones(n)], axis=1)
    state = SimpleNamespace(yaw=yaw, vx=vx, vy=vy)
    m1, m2 = np.full(n, 1500.0), rng.uniform(800, 2000, n)
    ctx = SimpleNamespace(state=state, size=n, relative_speed=np.linspace(5.0, 15.0, n),
                          swept_overlap=np.linspace(0.2, 1.0, n),
                          vehicle1=SimpleNamespace(mass=m1), vehicle2=SimpleNamespace(mass=m2),
                          road_friction=np.full(n, 0.8))
    config = ImpactConfig.from_arrays(
        m=np.stack([m1, m2], 1), izz=np.stack([m1, m2], 1) * 1.6,
        x=np.stack([np.zeros(n), np.full(n, 4.0 * c)], 1),
        y=np.stack([np.zeros(n), np.full(n, 4.0 * s)], 1), yaw=yaw, vx=vx, vy=vy,
        yaw_rate=0.0, poi_x=2.0 * c, poi_y=2.0 * s, cp_angle=heading + np.pi / 2,
        restitution=0.1, contact_friction=0.5)
    return ctx, config


def test_features_of_a_turned_scene() -> None:
    ctx, config = scene()
    np.testing.assert_allclose(feature_values(ctx, config, "closing_speed"), ctx.relative_speed)
    np.testing.assert_allclose(feature_values(ctx, config, "overlap"), ctx.swept_overlap)
    np.testing.assert_allclose(feature_values(ctx, config, "mass_ratio"),
                               ctx.vehicle1.mass / ctx.vehicle2.mass)
    np.testing.assert_allclose(feature_values(ctx, config, "impact_angle"), 0.4)
    np.testing.assert_allclose(feature_values(ctx, config, "impact_speed1"),
                               np.linspace(10.0, 20.0, 6))
    np.testing.assert_allclose(feature_values(ctx, config, "impact_speed2"), 3.0)
    np.testing.assert_allclose(feature_values(ctx, config, "road_friction"), 0.8)
    # the impact angle is the unsigned relative heading, wrapped: 0.4 either way round
    turned = SimpleNamespace(**{**vars(ctx), "state": SimpleNamespace(
        **{**vars(ctx.state), "yaw": ctx.state.yaw[:, ::-1] + 2 * np.pi})})
    np.testing.assert_allclose(feature_values(turned, config, "impact_angle"), 0.4)
    # normal closing speed: -u_n of the contact frame, >= 0; the closing speed without config
    ncs = feature_values(ctx, config, "normal_closing_speed")
    np.testing.assert_allclose(ncs, np.maximum(-contact_frame(config).u_n, 0.0))
    np.testing.assert_allclose(ncs, solve_impact(config).closing_speed)
    assert (ncs > 0).all()
    apart = config._replace(vx=-config.vx, vy=-config.vy)
    np.testing.assert_array_equal(normal_closing_speed(apart), 0.0)
    np.testing.assert_allclose(feature_values(ctx, None, "normal_closing_speed"),
                               ctx.relative_speed)
    with pytest.raises(ParameterError, match="unknown law feature"):
        feature_values(ctx, config, "colour")


def law_of(channel: str, form: str = "linear", coefficients=(0.0, 0.0), feature="closing_speed",
           **extra):
    return law_effect_class({"name": f"l_{channel}", "channel": channel, "feature": feature,
                             "form": form, "coefficients": list(coefficients), **extra})


def test_value_clips_to_the_channel_and_keeps_the_base_where_not_finite() -> None:
    ctx, config = scene()
    effect = law_of("restitution", coefficients=(-0.5, 0.1))()  # -0.5 + 0.1 x, x in 5..15
    base = np.full(6, 0.25)
    got = effect.value(ctx, config, base)
    ch = CHANNELS["restitution"]
    np.testing.assert_allclose(got, np.clip(-0.5 + 0.1 * ctx.relative_speed, ch.lo, ch.hi))
    assert got.min() == ch.lo and got.max() == ch.hi and 0 < got[2] < ch.hi
    # NaN from the law keeps the model's value
    nan_law = law_of("restitution", form="exponential", coefficients=(0.0, 1000.0))()  # 0 inf
    np.testing.assert_array_equal(nan_law.value(ctx, config, base), base)
    # a shift channel adds the (clipped) value to the base
    shift = law_of("cp_angle", coefficients=(0.1, 0.0))()
    np.testing.assert_allclose(shift.value(ctx, config, base), base + 0.1)
    big = law_of("cp_angle", coefficients=(3.0, 0.0))()
    np.testing.assert_allclose(big.value(ctx, config, base), base + CHANNELS["cp_angle"].hi)


def test_table_law_strength_scales_towards_the_neutral_value() -> None:
    ctx, config = scene()
    table = {"x": [0.0, 20.0], "y": [0.6, 0.6]}
    base = np.full(6, 0.2)
    for strength, expected in ((1.0, 0.6), (0.5, 0.4), (0.0, 0.2)):
        effect = law_effect_class({"name": "t", "channel": "restitution",
                                   "feature": "closing_speed", "form": "table",
                                   "table": table})(strength=strength)
        np.testing.assert_allclose(effect.value(ctx, config, base), expected)
    # shift channel: neutral 0, so half strength halves the shift
    effect = law_effect_class({"name": "t", "channel": "poi_along", "feature": "overlap",
                               "form": "table", "table": {"x": [0, 1], "y": [0.4, 0.4]}}
                              )(strength=0.5)
    np.testing.assert_allclose(effect.value(ctx, config, np.zeros(6)), 0.2)


def test_each_hook_applies_its_channel() -> None:
    ctx, config = scene()
    n = config.size
    # restitution and contact friction
    r = law_of("restitution", "constant", [0.4])().impact_parameters(ctx, config)
    np.testing.assert_allclose(r.restitution, 0.4)
    np.testing.assert_array_equal(r.contact_friction, config.contact_friction)
    f = law_of("contact_friction", "constant", [0.9])().impact_parameters(ctx, config)
    np.testing.assert_allclose(f.contact_friction, 0.9)
    np.testing.assert_array_equal(f.restitution, config.restitution)
    # POI shifts along the tangent / the normal of the contact frame; plane turn; inertia
    frame = contact_frame(config)
    a = law_of("poi_along", "constant", [0.5])().impact_configuration(ctx, config)
    np.testing.assert_allclose(a.poi_x - config.poi_x, 0.5 * frame.tx)
    np.testing.assert_allclose(a.poi_y - config.poi_y, 0.5 * frame.ty)
    b = law_of("poi_across", "constant", [-0.3])().impact_configuration(ctx, config)
    np.testing.assert_allclose(b.poi_x - config.poi_x, -0.3 * frame.nx)
    np.testing.assert_allclose(b.poi_y - config.poi_y, -0.3 * frame.ny)
    c = law_of("cp_angle", "constant", [0.2])().impact_configuration(ctx, config)
    np.testing.assert_allclose(c.cp_angle, config.cp_angle + 0.2)
    d = law_of("yaw_inertia_factor", "constant", [2.0])().impact_configuration(ctx, config)
    np.testing.assert_allclose(d.izz, 2.0 * config.izz)
    # channels of other hooks leave the configuration alone
    same = law_of("restitution", "constant", [0.4])()
    assert ChannelLawCall(same, "impact_configuration", ctx, config) is config
    assert ChannelLawCall(law_of("poi_along", "constant", [0.5])(), "impact_parameters",
                          ctx, config) is config
    # penetration time: NaN input means the model's default before the law
    p = law_of("penetration_time", "linear", [0.0, 1.0], feature="road_friction")()
    got = p.penetration(ctx, np.array([np.nan, 0.05, 0.1, np.nan, 0.0, 0.2]))
    np.testing.assert_allclose(got, CHANNELS["penetration_time"].hi)  # 0.8 clipped to 0.2
    shift_free = law_of("restitution", "constant", [0.4])()
    t = np.array([np.nan, 0.05, 0.1, np.nan, 0.0, 0.2])
    np.testing.assert_array_equal(ChannelLawCall(shift_free, "penetration", ctx, t), t)
    table_pen = law_effect_class({"name": "tp", "channel": "penetration_time",
                                  "feature": "overlap", "form": "table",
                                  "table": {"x": [0, 1], "y": [0.1, 0.1]}})(strength=0.0)
    np.testing.assert_allclose(table_pen.penetration(ctx, t),
                               np.where(np.isnan(t), PrecrashParams.penetration_time, t))
    # energy split by the stiffness ratio k1 / k2 = 2: E1 = E / 3
    res = solve_impact(config)
    e1, e2 = np.full(n, 300.0), np.full(n, 600.0)
    s1, s2 = law_of("ees_stiffness_ratio", "constant", [2.0])().energy_split(
        ctx, config, res, e1, e2)
    np.testing.assert_allclose(s1, 300.0)
    np.testing.assert_allclose(s2, 600.0)
    s1, s2 = law_of("ees_stiffness_ratio", "constant", [0.5])().energy_split(
        ctx, config, res, e1, e2)
    np.testing.assert_allclose(s1, 600.0)
    np.testing.assert_allclose(s2, 300.0)
    assert ChannelLawCall(same, "energy_split", ctx, config, res, e1, e2) == (e1, e2)
    # brake factors of one vehicle's four wheels
    brake1, brake2 = np.full((n, 4), 0.2), np.full((n, 4), 0.3)
    inputs = PostImpactInputs.unknown(n).with_brakes(brake1, brake2)
    out = law_of("runout_brake1", "constant", [0.9])().post_impact(ctx, config, res, inputs)
    np.testing.assert_allclose(out.brake[:, 0], 0.9)
    np.testing.assert_array_equal(out.brake[:, 1], brake2)
    out = law_of("runout_brake2", "constant", [0.7])().post_impact(ctx, config, res, inputs)
    np.testing.assert_array_equal(out.brake[:, 0], brake1)
    np.testing.assert_allclose(out.brake[:, 1], 0.7)
    assert np.isnan(out.steer_angle).all()  # a brake law steers no wheel
    # a linear brake law of the mean old factor is not needed: constant suffices above
    zero = ChannelLawCall(same, "contact_impulse", ctx, config, res)
    np.testing.assert_array_equal(np.asarray(zero), 0.0)
    lost = law_of("tyre_impulse", "constant", [1.0])().contact_impulse(ctx, config, res)
    assert np.abs(np.asarray(lost)).max() > 0.1


def ChannelLawCall(effect, hook: str, *args):  # noqa: N802
    """Call a hook of ChannelLaw itself (the generated class drops the foreign hooks)."""
    from vfs.effects.learned import ChannelLaw

    return getattr(ChannelLaw, hook)(effect, *args)


def test_every_form_is_named_in_the_law_text() -> None:
    for form, (_, names, text) in FORMS.items():
        law = {"name": "x", "channel": "restitution", "feature": "overlap", "form": form,
               "coefficients": [0.25 + i for i in range(len(names))]}
        out = law_text(law)
        assert out.startswith("restitution = ") and out.endswith("x = overlap [-]")
        for i, n in enumerate(names):
            assert f"{0.25 + i:.4g}" in out, (form, n)
        assert len(names) == sum(f"{0.25 + i:.4g}" in out for i in range(len(names)))
        assert text  # every form documents its formula
