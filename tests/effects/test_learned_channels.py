"""The channels of the learned laws (:data:`vfs.effects.learned.CHANNELS`) against what their
physics and the model's symmetries ask of them: physical bounds exactly where the physics has
one, ranges that swapping the vehicles or mirroring the scene map onto themselves, the model's
own value where a law gives none, the run-out steer angle mirrored with the scene, and the
inputs of a hook left untouched.  Written against the mutants a mutation run of
``learned.py`` left alive (benchmarks/mutation.py, docs/testing.md).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from tests.effects.test_learned_mutants import law_of, scene
from vfs.effects.learned import (
    CHANNELS,
    MAX_LAW_STEER,
    STEER_CHANNELS,
    Channel,
    impact_sides,
    law_effect_class,
)
from vfs.physics.impact import energy_split, solve_impact
from vfs.physics.post_impact import PostImpactInputs
from vfs.physics.vehicle import VehicleParams, stack_vehicles

#: Channels whose lower bound is a limit of the physics: a restitution, a friction
#: coefficient, a penetration time, a speed lost to the tyres and a brake factor (free
#: rolling) are at least 0.
NON_NEGATIVE = ("restitution", "contact_friction", "penetration_time", "tyre_impulse",
                "runout_brake1", "runout_brake2", "runout_brake", "corner_brake")
#: Brake factors are at most 1 (locked wheels).
BRAKES = ("runout_brake1", "runout_brake2", "runout_brake", "corner_brake")


def test_physical_bounds_exactly_where_the_physics_has_them() -> None:
    for name, ch in CHANNELS.items():
        assert ch.lo < ch.hi, name
        assert ch.physical == (name in NON_NEGATIVE, name in BRAKES), name
        if name in NON_NEGATIVE:
            assert ch.lo == 0.0, name
        if name in BRAKES:
            assert ch.hi == 1.0 and ch.mode == "set", name
    # a channel declared without saying is bounded by its scan only
    assert Channel("x", "-", 0.0, 1.0, "set", "impact_parameters", "").physical == (False, False)


def test_ranges_map_onto_themselves_under_the_symmetries() -> None:
    # a shift (0 = no change) and a steer angle towards the impact side have ranges symmetric
    # about 0: mirroring the scene turns +d into -d (the tangent and the normal of a mirrored
    # contact plane flip one of their senses, the steer side flips)
    for name, ch in CHANNELS.items():
        if ch.mode == "shift" and name != "tyre_impulse":
            assert ch.lo == -ch.hi, name
    for name in STEER_CHANNELS:
        assert (CHANNELS[name].lo, CHANNELS[name].hi) == (-MAX_LAW_STEER, MAX_LAW_STEER)
    # swapping the vehicles turns the stiffness ratio k1 / k2 into k2 / k1: the range is
    # symmetric on the log scale it is scanned on
    ees = CHANNELS["ees_stiffness_ratio"]
    assert ees.log_grid and ees.lo * ees.hi == 1.0


def test_where_a_law_gives_no_value_the_model_keeps_its_own() -> None:
    """A law that is NaN everywhere (0 x inf) leaves each channel at the model's value: the
    mass-proportional energy split, the brake factors as they were."""
    ctx, config = scene()
    n = config.size
    nan = {"form": "exponential", "coefficients": (0.0, 1000.0)}
    res = solve_impact(config)
    e1, e2 = np.full(n, 300.0), np.full(n, 600.0)
    m1, m2 = config.m[:, 0], config.m[:, 1]
    assert not np.allclose(m1, m2)
    s1, s2 = law_of("ees_stiffness_ratio", **nan)().energy_split(ctx, config, res, e1, e2)
    d1, d2 = energy_split(e1 + e2, m1, m2)  # E1 / E2 = m2 / m1
    np.testing.assert_allclose(s1, d1, rtol=1e-12)
    np.testing.assert_allclose(s2, d2, rtol=1e-12)
    brake1, brake2 = np.full((n, 4), 0.2), np.full((n, 4), 0.4)
    inputs = PostImpactInputs.unknown(n).with_brakes(brake1, brake2)
    # one law for both vehicles: its neutral value is the mean factor of both
    both = law_of("runout_brake", **nan)().post_impact(ctx, config, res, inputs)
    np.testing.assert_allclose(both.brake, 0.3)


def test_the_corner_brake_law_leaves_its_inputs_alone() -> None:
    ctx, config = scene()
    n = config.size
    car = stack_vehicles([VehicleParams(mass=1500.0, length=4.5, width=1.8, wheelbase=2.7,
                                        cg_to_front_axle=1.2, front_overhang=0.9)] * n)
    ctx = SimpleNamespace(**{**vars(ctx), "vehicle1": car, "vehicle2": car})
    inputs = PostImpactInputs.unknown(n).with_brakes(np.full((n, 4), 0.2), np.full((n, 4), 0.4))
    before = inputs.brake.copy()
    out = law_of("corner_brake", "constant", [1.0])().post_impact(ctx, config,
                                                                   solve_impact(config), inputs)
    np.testing.assert_array_equal(inputs.brake, before)
    assert (out.brake == 1.0).sum() == 2 * n  # one wheel of each vehicle locked


def mirrored(config):
    """The scene mirrored about the x axis."""
    return config._replace(y=-config.y, vy=-config.vy, yaw=-config.yaw, yaw_rate=-config.yaw_rate,
                           poi_y=-config.poi_y, cp_angle=-config.cp_angle)


def test_the_steer_law_turns_towards_the_impact_side_and_mirrors_with_the_scene() -> None:
    ctx, config = scene()
    n = config.size
    res = solve_impact(config)
    inputs = PostImpactInputs.unknown(n)
    side = impact_sides(config)
    assert (side[:, 1] != 0).all()
    for angle in (0.3, 0.0):
        law = law_of("runout_steer2", "constant", [angle])()
        here = law.post_impact(ctx, config, res, inputs).steer_angle[:, 1]
        there = law.post_impact(ctx, mirrored(config), solve_impact(mirrored(config)),
                                inputs).steer_angle[:, 1]
        np.testing.assert_array_equal(impact_sides(mirrored(config)), -side)
        np.testing.assert_array_equal(here, angle * side[:, 1])
        np.testing.assert_array_equal(there, -here)
    # a zero angle is +0.0 on either side: the mirrored scene's inputs are bit for bit
    # those of the scene, not a -0.0 that an exact comparison (or copysign) tells apart
    assert not np.signbit(here).any() and not np.signbit(there).any()


def test_a_table_law_is_the_table_at_its_default_strength() -> None:
    ctx, config = scene()
    table = {"x": [0.0, 20.0], "y": [0.6, 0.2]}
    effect = law_effect_class({"name": "t", "channel": "restitution", "feature": "closing_speed",
                               "form": "table", "table": table})()
    np.testing.assert_allclose(effect.value(ctx, config, np.full(config.size, 0.1)),
                               0.6 - 0.02 * ctx.relative_speed)
