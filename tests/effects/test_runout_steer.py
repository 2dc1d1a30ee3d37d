"""Steering after the impact as a diagnosis channel (issue 36, item 3): the run-out steer
channels ``runout_steer1``, ``runout_steer2``, ``runout_steer`` set the front-wheel steer
angle through the ``post_impact`` stage (:class:`vfs.physics.post_impact.PostImpactInputs`),
signed towards the impact side so that a mirrored scene steers mirrored.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.effects.base import Effect, apply_post_impact
from vfs.effects.learned import (
    CHANNEL_OUTPUTS,
    CHANNELS,
    RUNOUT_CHANNELS,
    STEER_CHANNELS,
    impact_sides,
    law_effect_class,
)
from vfs.errors import ParameterError
from vfs.physics.post_impact import POST_IMPACT_RANGES, PostImpactInputs
from vfs.physics.precrash_result import KinematicState
from vfs.scenarios.generator import generate_database
from vfs.simulation import (
    CaseBatch,
    ImpactInputs,
    SimulationParams,
    impact_stage_inputs,
    open_cases,
    precrash_stage,
    runout_stage,
    simulate_cases,
)


def law(channel: str, form: str = "constant", coefficients=(0.3,), feature="closing_speed"):
    return law_effect_class({"name": f"t_{channel}", "channel": channel, "feature": feature,
                             "form": form, "coefficients": list(coefficients)})()


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    db, _ = generate_database("default", n_cases=24, seed=11)
    return CaseBatch.from_database(db)


def test_steer_channels_are_declared_in_rad_inside_the_post_impact_range():
    lo, hi = POST_IMPACT_RANGES["steer_angle"]
    for name in STEER_CHANNELS:
        ch = CHANNELS[name]
        assert ch.unit == "rad" and ch.stage == "post_impact" and ch.mode == "set"
        assert lo <= ch.lo < 0.0 < ch.hi <= hi and ch.physical == (False, False)
        assert name in RUNOUT_CHANNELS
        assert CHANNEL_OUTPUTS[name] == ("rest_position", "rest_yaw", "runout_distance")


@pytest.mark.parametrize("channel", STEER_CHANNELS)
def test_steer_law_at_zero_is_bit_identical_and_away_from_zero_moves_only_its_vehicles(
        batch, channel):
    base = simulate_cases(batch)
    zero = simulate_cases(batch, params=SimulationParams(effects=(law(channel, coefficients=(
        0.0,)),)))
    for a, b in zip(base.runout, zero.runout, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(base.impact, zero.impact, strict=True):
        np.testing.assert_array_equal(a, b)
    steered = simulate_cases(batch, params=SimulationParams(effects=(law(channel),)))
    # the impact is the default model's (a run-out channel acts after separation only)
    for a, b in zip(base.impact, steered.impact, strict=True):
        np.testing.assert_array_equal(a, b)
    moved = np.hypot(steered.runout.rest_x - base.runout.rest_x,
                     steered.runout.rest_y - base.runout.rest_y)  # (N, 2)
    hit = np.isfinite(moved).all(axis=1)
    on = {"runout_steer1": (0,), "runout_steer2": (1,), "runout_steer": (0, 1)}[channel]
    for j in (0, 1):
        if j in on:
            assert np.nanmax(moved[hit, j]) > 0.5, (channel, j)
        else:
            np.testing.assert_array_equal(moved[hit, j], 0.0)


def _mirrored(pre: ImpactInputs) -> ImpactInputs:
    """The impact of the scene mirrored at the x axis (y, yaw, v_y, yaw rate, POI y and the
    contact plane's angle negated)."""
    s = pre.impact_state
    state = KinematicState(s.x, -s.y, -s.yaw, s.vx, -s.vy, -s.yaw_rate, s.speed)
    poi = np.stack([pre.poi[:, 0], -pre.poi[:, 1]], axis=1)
    return ImpactInputs(state, poi, -pre.cp_angle, pre.contact_time, pre.impact_time)


def _impact_and_runout(batch, pre, hit, opened, params):
    config, result, inputs = impact_stage_inputs(
        opened.batch, pre, hit, opened.restitution, opened.contact_friction, params)
    st = KinematicState(*(a[hit] for a in pre.impact_state))
    ro = runout_stage(batch.vehicle1.take(hit), batch.vehicle2.take(hit), st, result,
                      batch.road_friction[hit], params.runout, inputs.brake[:, 0],
                      inputs.brake[:, 1], secondary_collisions=False, paths=False,
                      post_impact=inputs)
    return config, inputs, ro


@pytest.mark.parametrize("channel", STEER_CHANNELS)
def test_a_mirrored_scene_steers_mirrored_and_comes_to_rest_mirrored(batch, channel):
    # a law of unsigned features (closing speed, impact angle) gives the same value in
    # the mirrored scene; the angle it sets, towards the impact side, flips with the side,
    # and the rest poses are the mirror images
    params = SimulationParams(effects=(law(channel, "linear", (0.05, 0.015)),))
    opened = open_cases(batch, params)
    pre = precrash_stage(opened, params)
    hit = np.flatnonzero(pre.collided)
    config, inputs, ro = _impact_and_runout(batch, pre, hit, opened, params)
    m_config, m_inputs, m_ro = _impact_and_runout(batch, _mirrored(pre), hit, opened, params)
    np.testing.assert_array_equal(impact_sides(m_config), -impact_sides(config))
    assert np.abs(inputs.steer()).max() > 0.1  # it steers
    np.testing.assert_allclose(m_inputs.steer(), -inputs.steer(), atol=1e-12)
    np.testing.assert_allclose(m_ro.rest_x, ro.rest_x, atol=1e-6)
    np.testing.assert_allclose(m_ro.rest_y, -ro.rest_y, atol=1e-6)
    np.testing.assert_allclose(np.sin(m_ro.rest_yaw), -np.sin(ro.rest_yaw), atol=1e-6)


def test_steer_is_towards_the_side_of_the_point_of_impact(batch):
    # a positive law value turns each car's front wheels towards the side its POI lies on
    params = SimulationParams(effects=(law("runout_steer", coefficients=(0.25,)),))
    opened = open_cases(batch, params)
    pre = precrash_stage(opened, params)
    hit = np.flatnonzero(pre.collided)
    config, inputs, _ = _impact_and_runout(batch, pre, hit, opened, params)
    side = impact_sides(config)
    assert (side != 0).all()
    np.testing.assert_array_equal(inputs.steer(), 0.25 * side)
    # the POI in vehicle j's frame: y > 0 (left) where the side is +1
    dx = config.poi_x[:, None] - config.x
    dy = config.poi_y[:, None] - config.y
    lateral = -np.sin(config.yaw) * dx + np.cos(config.yaw) * dy
    np.testing.assert_array_equal(np.sign(lateral), side)


def test_steer_laws_compose_and_leave_brakes_alone():
    # runout_steer1 then runout_steer2: each sets its own vehicle; a brake hook of the
    # earlier (brake1, brake2) form still runs and keeps the steer angles
    class OldBrakes(Effect):
        name = "old_brakes"

        def post_impact(self, ctx, config, result, brake1, brake2):  # the earlier form
            return np.full_like(brake1, 0.5), brake2

    n = 3
    config = _config(n)
    inputs = PostImpactInputs.unknown(n).with_brakes(np.full((n, 4), 0.8),
                                                     np.full((n, 4), 0.8))
    out = apply_post_impact((law("runout_steer1", coefficients=(0.2,)),
                             law("runout_steer2", coefficients=(-0.1,)), OldBrakes()),
                            _Ctx(n), config, None, inputs)
    side = impact_sides(config)
    np.testing.assert_allclose(out.steer(), np.stack([0.2 * side[:, 0], -0.1 * side[:, 1]], 1))
    np.testing.assert_array_equal(out.brake[:, 0], 0.5)
    np.testing.assert_array_equal(out.brake[:, 1], 0.8)


def test_a_post_impact_hook_returning_the_wrong_type_is_rejected():
    class Bad(Effect):
        name = "bad_post"

        def post_impact(self, ctx, config, result, inputs):
            return inputs.brake

    n = 2
    inputs = PostImpactInputs.unknown(n).with_brakes(np.zeros((n, 4)), np.zeros((n, 4)))
    with pytest.raises(ParameterError, match="PostImpactInputs"):
        apply_post_impact((Bad(),), _Ctx(n), _config(n), None, inputs)


def test_with_steer_checks_the_range():
    inputs = PostImpactInputs.unknown(2)
    with pytest.raises(ParameterError, match="steer_angle"):
        inputs.with_steer(1, [0.1, 2.0])
    with pytest.raises(ParameterError, match="vehicle"):
        inputs.with_steer(3, 0.1)
    out = inputs.with_steer(2, [0.1, -0.2], onset=[0.0, 0.5])
    np.testing.assert_array_equal(out.steer(), [[0.0, 0.1], [0.0, -0.2]])
    np.testing.assert_array_equal(out.onset(), [[0.0, 0.0], [0.0, 0.5]])
    assert out.wheels_given and not inputs.wheels_given


class _Ctx:
    """The context a constant law of the closing speed reads."""

    def __init__(self, n: int) -> None:
        self.state = None
        self.relative_speed = np.full(n, 10.0)
        self.size = n


def _config(n: int):
    from vfs.physics.impact import ImpactConfig

    # vehicle 1 at the origin heading +x, POIs to its left front, right front, left rear;
    # vehicle 2 beside it heading +y
    poi = np.array([[1.5, 0.6], [1.5, -0.6], [-1.0, 0.7]])[:n]
    return ImpactConfig.from_arrays(
        m=1500.0, izz=2500.0, x=np.tile([0.0, 1.0], (n, 1)), y=np.tile([0.0, 3.0], (n, 1)),
        yaw=np.tile([0.0, np.pi / 2], (n, 1)), vx=0.0, vy=0.0, yaw_rate=0.0,
        poi_x=poi[:, 0], poi_y=poi[:, 1], cp_angle=0.0, restitution=0.1,
        contact_friction=0.5)
