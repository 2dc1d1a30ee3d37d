"""The compiled AEB measurement (:mod:`vfs.adas.compiled`) against the numpy reference.

The kernels repeat numpy's operations in numpy's order (ties and NaN of ``maximum`` /
``minimum`` as numpy, the sampled sweeps over the same sets and groups of pairs, numpy's
``arctan2`` between the kernels), so the controller's decisions, its events and every
output of the runs must be equal bit for bit (NaN where NaN).  Only the controller is
switched here (the compiled step runs under both), so a difference names the
controller; ``tests/physics/test_core.py`` switches the whole core.
"""

from __future__ import annotations

import dataclasses
import zlib

import numpy as np
import pytest

from tests.generated import bit_differences, cases_of_every_type
from vfs.adas import compiled as compiled_module
from vfs.adas import controller as controller_module
from vfs.adas.controller import AEBController
from vfs.adas.definition import AEBSystem
from vfs.adas.params import AEBParams
from vfs.adas.systems import SYSTEM_NAMES, get_system
from vfs.physics.braking import BrakeActuatorParams, PrecrashObservation
from vfs.simulation import CaseBatch, SimulationParams, simulate_cases


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    """Cases of every accident type of the generator, a fifth of them near misses."""
    return cases_of_every_type(5, seed=37, near_miss_share=0.2)


def _system(name: str) -> AEBSystem:
    """The built-in system ``name`` (an :class:`AEBSystem`)."""
    system = get_system(name)
    assert isinstance(system, AEBSystem)
    return system


def _variants() -> dict[str, AEBSystem]:
    """Every built-in system, and variants that reach the other branches: the CA model,
    release by TTC and never, detection probability below 1 (the draws), a mounted and
    turned sensor, box margins, and the first-order actuator.
    """
    out = {name: _system(name) for name in (*SYSTEM_NAMES, "ideal-ctra")}
    three, ideal = _system("three-stage"), _system("ideal-ctra")
    three_aeb, ideal_aeb = three.aeb, ideal.aeb
    assert isinstance(three_aeb, AEBParams) and isinstance(ideal_aeb, AEBParams)
    sensor = dataclasses.replace(three_aeb.sensor, detection_probability=0.6, mount_x=-0.5,
                                 mount_y=0.4, mount_yaw=0.1, field_of_view=1.2)
    out["three-stage-ca-ttc"] = dataclasses.replace(three, aeb=dataclasses.replace(
        three_aeb, prediction="ca", release="ttc", sensor=sensor, box_margin_longitudinal=1.0,
        box_margin_lateral=0.4))
    out["ideal-ctrv-never-lag"] = dataclasses.replace(
        ideal, aeb=dataclasses.replace(ideal_aeb, prediction="ctrv", release="never",
                                       sensor=dataclasses.replace(ideal_aeb.sensor,
                                                                  latency=0.05,
                                                                  cycle_time=0.03)),
        brake=BrakeActuatorParams(model="first_order", time_constant=0.12,
                                  max_deceleration=9.0))
    return out


VARIANTS = _variants()


def _run_both(monkeypatch: pytest.MonkeyPatch, run):  # noqa: ANN001, ANN202
    """``run()`` with the controller's numpy path, then with its kernels."""
    monkeypatch.setattr(controller_module, "core_enabled", lambda: False)
    ref = run()
    monkeypatch.setattr(controller_module, "core_enabled", lambda: True)
    return ref, run()


@pytest.mark.parametrize("name", list(VARIANTS))
@pytest.mark.parametrize("equipped", [(True, True), (True, False)])
def test_every_system_equals_the_numpy_controller_bit_for_bit(
        name: str, equipped: tuple[bool, bool], batch: CaseBatch,
        monkeypatch: pytest.MonkeyPatch) -> None:
    system = VARIANTS[name]
    base = SimulationParams()
    params = dataclasses.replace(base, precrash=system.precrash_params(base.precrash))

    def run():  # noqa: ANN202
        controller = system.controller(batch, np.array(equipped))
        result = simulate_cases(batch, controller=controller, params=params,
                                rng=np.random.default_rng(4))
        return result, (controller.events() if controller is not None else {})

    (ref, ref_events), (got, got_events) = _run_both(monkeypatch, run)
    assert bit_differences(ref, got) == []
    assert bit_differences(ref_events, got_events) == []
    if name != "none":  # the systems act: the comparison is not vacuous
        assert np.isfinite(ref_events["full_time"]).any()


def _observation(rng: np.random.Generator, n: int) -> PrecrashObservation:
    """Random states of n case pairs: distances within the horizon's reach, any yaw,
    side slip, speeds with standstills, braking and accelerating, turning."""
    x = rng.uniform(-30.0, 30.0, (n, 2))
    y = rng.uniform(-15.0, 15.0, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, (n, 2))
    heading = yaw + rng.normal(0.0, 0.15, (n, 2))
    speed = np.where(rng.random((n, 2)) < 0.1, 0.0, rng.uniform(0.0, 30.0, (n, 2)))
    accel = rng.choice([0.0, -8.0, -3.0, 2.0], (n, 2))
    yaw_rate = np.where(rng.random((n, 2)) < 0.3, 0.0, rng.normal(0.0, 0.4, (n, 2)))
    return PrecrashObservation(rows=np.arange(n), t=0.0, x=x, y=y, yaw=yaw, heading=heading,
                               speed=speed, accel=accel, yaw_rate=yaw_rate,
                               deceleration=np.zeros((n, 2)),
                               road_friction=rng.uniform(0.3, 1.1, n))


def _measure_both(system: AEBSystem, batch: CaseBatch, obs: PrecrashObservation,
                  monkeypatch: pytest.MonkeyPatch, active: np.ndarray | None = None
                  ) -> np.ndarray:
    """One measurement of ``obs`` by the numpy path and by the kernels, from the stages
    ``active`` (default none); asserts equal decisions and TTCs, returns the TTCs [s].
    """
    n = batch.size
    states = []
    for compiled in (False, True):
        controller = system.controller(batch, np.array([True, True]))
        assert isinstance(controller, AEBController)
        controller.reset(n, np.random.default_rng(9))
        if active is not None:
            controller._stage[:] = active  # noqa: SLF001 -- a state mid-run
        controller._dt = 0.01  # noqa: SLF001
        monkeypatch.setattr(controller_module, "core_enabled", lambda c=compiled: c)
        controller._measure(obs)  # noqa: SLF001
        states.append((controller._stage.copy(), controller._ttc.copy()))  # noqa: SLF001
    (ref_stage, ref_ttc), (stage, ttc) = states
    assert np.array_equal(ref_stage, stage)
    assert np.array_equal(ref_ttc, ttc, equal_nan=True)
    return ref_ttc


@pytest.mark.parametrize("name", [n for n in VARIANTS if n != "none"])
def test_one_measurement_of_random_states_equals_the_numpy_path(
        name: str, batch: CaseBatch, monkeypatch: pytest.MonkeyPatch) -> None:
    """Many geometries per measurement (crossing, head-on, from behind, inside each
    other, standing), some stages already active: the decisions and TTCs of both paths
    are equal bit for bit.
    """
    system = VARIANTS[name]
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    n = batch.size
    found_any = False
    for _ in range(6):
        obs = _observation(rng, n)
        active = rng.random((n, 2, 3)) < 0.2
        ttc = _measure_both(system, batch, obs, monkeypatch, active)
        found_any |= bool(np.isfinite(ttc).any())
    assert found_any


def _far_observation(rng: np.random.Generator, n: int) -> PrecrashObservation:
    """Pairs 20-120 m apart that close in on each other: participant 2 ahead of
    participant 1 (crossing, head-on, from behind, with lateral offsets), at speeds that
    bring it within reach late in the horizon, so the sampled sweeps run over long
    stretches out of reach before the outlines meet or pass.
    """
    distance = rng.uniform(20.0, 120.0, n)
    bearing = rng.uniform(-0.4, 0.4, n)
    yaw1 = rng.uniform(-np.pi, np.pi, n)
    yaw2 = yaw1 + rng.choice([0.0, np.pi, 0.5 * np.pi, -0.5 * np.pi, 2.5], n)
    x = np.stack([np.zeros(n), distance * np.cos(yaw1 + bearing)], axis=1)
    y = np.stack([np.zeros(n), distance * np.sin(yaw1 + bearing)], axis=1)
    yaw = np.stack([yaw1, yaw2], axis=1)
    speed = np.stack([rng.uniform(5.0, 40.0, n), rng.uniform(0.0, 25.0, n)], axis=1)
    yaw_rate = np.where(rng.random((n, 2)) < 0.5, 0.0, rng.normal(0.0, 0.1, (n, 2)))
    return PrecrashObservation(rows=np.arange(n), t=0.0, x=x, y=y, yaw=yaw, heading=yaw,
                               speed=speed, accel=rng.choice([0.0, -4.0, 1.5], (n, 2)),
                               yaw_rate=yaw_rate, deceleration=np.zeros((n, 2)),
                               road_friction=rng.uniform(0.3, 1.1, n))


@pytest.mark.parametrize("name", ["ideal", "ideal-ctra", "ideal-ctrv-never-lag",
                                  "three-stage"])
def test_long_sweeps_out_of_reach_equal_the_numpy_path(
        name: str, batch: CaseBatch, monkeypatch: pytest.MonkeyPatch) -> None:
    """The kernels' sweeps leave out the intervals that cannot be within reach (the
    separation shrinks at most by the speed bound); the reference steps through every
    interval.  Over long approaches the decisions and TTCs stay equal bit for bit, and
    some contacts are found late in the horizon (the skip lands before them).
    """
    system = VARIANTS[name]
    rng = np.random.default_rng(zlib.crc32(b"far" + name.encode()))
    late = 0
    for _ in range(8):
        ttc = _measure_both(system, batch, _far_observation(rng, batch.size), monkeypatch)
        late += int(np.count_nonzero(np.isfinite(ttc) & (ttc > 1.5)))
    assert late > 0


@pytest.mark.parametrize("equipped", [(True, True), (True, False), (False, True)])
def test_compiled_pairs_equal_the_numpy_gather(equipped: tuple[bool, bool],
                                               batch: CaseBatch) -> None:
    """The compiled gather of egos and objects (:func:`vfs.adas.compiled.gather_pairs`)
    packs the same numbers as the controller's numpy gather, for a subset of running rows
    in shuffled order, standstills (heading replaced by the yaw) and box margins.
    """
    system = VARIANTS["three-stage-ca-ttc"]
    controller = system.controller(batch, np.array(equipped))
    assert isinstance(controller, AEBController)
    rng = np.random.default_rng(17)
    full = _observation(rng, batch.size)
    rows = rng.permutation(batch.size)[: batch.size // 2 + 1]
    obs = full._replace(rows=rows, **{f: getattr(full, f)[rows] for f in (
        "x", "y", "yaw", "heading", "speed", "accel", "yaw_rate", "deceleration",
        "road_friction")})
    ri, ji = np.nonzero(controller.equipped[rows])
    ref = controller._packed_pairs(obs, ri, ji)  # noqa: SLF001
    got = compiled_module.gather_pairs(obs.x, obs.y, obs.yaw, obs.heading, obs.speed,
                                       obs.accel, obs.yaw_rate,
                                       controller._outline, obs.rows, ri, ji)  # noqa: SLF001
    assert (obs.speed == 0.0).any()
    for r, g in zip(ref, got, strict=True):
        assert r.shape == g.shape == (10, ri.size)
        assert np.array_equal(r, g)
