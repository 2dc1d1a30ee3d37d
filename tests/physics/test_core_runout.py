"""The compiled run-out to rest (:mod:`vfs.physics.core_runout`) against its numpy reference
(``VFS_COMPILED=0``).

The kernel repeats the reference's arithmetic operation by operation.  The library
functions both evaluate are cos, sin, hypot, sqrt and atan; the first four round alike in
numpy's float64 loops and the C library here, numpy's arctan (its SIMD routine on AVX-512
machines) differs from the C library's atan by one ulp on ~0.15 % of arguments.  atan
enters only the lateral force of a rolling wheel, so:

* with every wheel locked the two paths agree bit for bit (steered or not, pairs too);
* otherwise every output agrees within :data:`vfs.physics.core_runout.AGREEMENT`
  (1e-9 m, rad; energies 1e-9 relative): an ulp of a damping (~1e-16 relative) moves a
  rest position by ~1e-13 m over the few thousand dissipative steps to rest, so the bound
  has three orders of margin and still catches a wrong term (which moves rest positions by
  millimetres at least).  Stop times, the at-rest flags and the secondary collisions must
  be equal: a vehicle would have to cross the stop speed within ~1e-15 m/s of it to stop
  one step earlier or later, which none of these fixed seeds does;
* most values are still bit-identical (the share is asserted: a kernel that merely
  approximated the reference would lose it).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from tests.generated import cases_of_every_type, with_random_wheel_inputs
from vfs.physics import runout
from vfs.physics.core_runout import AGREEMENT
from vfs.physics.numba_support import AVAILABLE, ENV_SWITCH
from vfs.physics.runout import RunoutMemo, RunoutParams, RunoutState, run_out, run_out_pair
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.simulation import CaseBatch, simulate_cases
from vfs.units import G

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="numba not installed")

#: Fields compared exactly (flags, stop times, sample times).
EXACT = ("time_to_rest", "at_rest", "path_t", "secondary_collision", "secondary_collision_time")
#: Energy fields (compared relative to their size).
ENERGY = ("kinetic_energy",)


def _both(monkeypatch: pytest.MonkeyPatch, run):  # noqa: ANN001, ANN202
    monkeypatch.setenv(ENV_SWITCH, "0")
    ref = run()
    monkeypatch.setenv(ENV_SWITCH, "1")
    return ref, run()


def _agree(ref: tuple, got: tuple) -> tuple[int, int]:
    """Assert the agreement of two run-out results; return (bit-identical, all) values."""
    same = total = 0
    for name, a, b in zip(ref._fields, ref, got, strict=True):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape, name
        if name in EXACT:
            np.testing.assert_array_equal(b, a, err_msg=name)
        elif name in ENERGY:
            np.testing.assert_allclose(b, a, rtol=AGREEMENT, atol=AGREEMENT, err_msg=name)
        else:
            np.testing.assert_allclose(b, a, rtol=0.0, atol=AGREEMENT, err_msg=name)
        if a.dtype.kind == "f":
            same += int(np.count_nonzero((a == b) | (np.isnan(a) & np.isnan(b))))
            total += a.size
    return same, total


def _vehicles(rng: np.random.Generator, n: int):  # noqa: ANN202
    return stack_vehicles([VehicleParams(mass=float(m), cg_height=float(h), yaw_inertia=float(i))
                           for m, h, i in zip(rng.uniform(900, 2500, n), rng.uniform(0.4, 0.7, n),
                                              rng.uniform(1200, 4500, n), strict=True)])


def _draw(seed: int, n: int) -> tuple:
    """Vehicles, states, friction and random wheel inputs: brake factors (a third of the
    wheels locked, some vehicles all four), extra drag, steer angles and onsets.
    """
    rng = np.random.default_rng(seed)
    cars = _vehicles(rng, n)
    state = RunoutState.from_arrays(rng.normal(0, 5, n), rng.normal(0, 5, n),
                                    rng.uniform(-3, 3, n), rng.normal(0, 12, n),
                                    rng.normal(0, 8, n), rng.normal(0, 3, n))
    state.vx[:5] = state.vy[:5] = state.yaw_rate[:5] = 0.0  # at rest from the start
    state.vx[5:10] = state.vy[5:10] = 0.0  # spinning in place
    brake = rng.uniform(0.0, 1.0, (n, 4))
    brake[rng.random((n, 4)) < 0.3] = 1.0
    brake[10:20] = 1.0
    wheels = {"wheel_drag": rng.uniform(0, 0.3, (n, 4)) * (rng.random((n, 1)) < 0.5),
              "steer": rng.uniform(-1.0, 1.0, n) * (rng.random(n) < 0.6),
              "steer_onset": rng.uniform(0, 2, n) * (rng.random(n) < 0.5)}
    return cars, state, rng.uniform(0.2, 1.0, n), brake, wheels


@pytest.mark.parametrize("load_transfer", [False, True])
def test_run_out_agrees_with_the_reference(monkeypatch: pytest.MonkeyPatch,
                                           load_transfer: bool) -> None:
    cars, state, mu, brake, wheels = _draw(3, 300)
    params = RunoutParams(load_transfer=load_transfer)
    ref, got = _both(monkeypatch, lambda: run_out(cars, state, mu, params, brake, **wheels))
    assert ref.at_rest.all() and (wheels["steer"] != 0).any()
    same, total = _agree(ref, got)
    assert same > 0.9 * total, same / total


def test_locked_wheels_are_bit_identical(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without a rolling wheel no atan is evaluated: every output equal, pairs too."""
    cars, state, mu, _, wheels = _draw(4, 200)
    for lt in (False, True):
        params = RunoutParams(load_transfer=lt)
        ref, got = _both(monkeypatch, lambda p=params: run_out(cars, state, mu, p,
                                                               (1, 1, 1, 1), **wheels))
        for name, a, b in zip(ref._fields, ref, got, strict=True):
            assert np.array_equal(a, b, equal_nan=True), name
    half = 100
    s1, s2 = (RunoutState(*(a[sl] for a in state)) for sl in (slice(0, half), slice(half, None)))
    s2 = s2._replace(x=s1.x + 2.0, y=s1.y + 1.0)  # close pairs: secondary collisions
    v1, v2 = cars.take(np.arange(half)), cars.take(np.arange(half, 2 * half))
    ref, got = _both(monkeypatch, lambda: run_out_pair(
        v1, v2, s1, s2, mu[:half], None, (1, 1, 1, 1), (1, 1, 1, 1),
        steer1=wheels["steer"][:half], steer2=wheels["steer"][half:],
        steer_onset1=wheels["steer_onset"][:half], steer_onset2=wheels["steer_onset"][half:]))
    assert ref.secondary_collision.any()
    for name, a, b in zip(ref._fields, ref, got, strict=True):
        assert np.array_equal(a, b, equal_nan=True), name


def test_pairs_agree_with_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """run_out_pair with the secondary-collision check: pairs close together, some
    overlapping at the start, some meeting again."""
    cars, state, mu, brake, wheels = _draw(6, 400)
    half = 200
    rng = np.random.default_rng(9)
    s1, s2 = (RunoutState(*(a[sl] for a in state)) for sl in (slice(0, half), slice(half, None)))
    s2 = s2._replace(x=s1.x + rng.normal(0, 3, half), y=s1.y + rng.normal(0, 3, half))
    v1, v2 = cars.take(np.arange(half)), cars.take(np.arange(half, 2 * half))
    ref, got = _both(monkeypatch, lambda: run_out_pair(
        v1, v2, s1, s2, mu[:half], None, brake[:half], brake[half:],
        wheels["wheel_drag"][:half], wheels["wheel_drag"][half:], wheels["steer"][:half],
        wheels["steer"][half:], wheels["steer_onset"][:half], wheels["steer_onset"][half:]))
    assert ref.secondary_collision.any() and not ref.secondary_collision.all()
    same, total = _agree(ref, got)
    assert same > 0.9 * total, same / total


def test_long_paths_and_the_time_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """Path samples every step (more columns than the first pass holds: the long run-outs
    run again) and a time limit that stops some vehicles while they still move.
    """
    cars, state, mu, brake, _ = _draw(5, 60)
    brake[:30] = 0.0  # rolling freely: only rolling resistance, long run-outs
    params = RunoutParams(dt=0.01, path_interval=0.01, max_time=2.0)
    ref, got = _both(monkeypatch, lambda: run_out(cars, state, mu, params, brake))
    assert (~ref.at_rest).any() and ref.at_rest.any() and ref.path.shape[1] > 64
    _agree(ref, got)
    half = 30
    s1, s2 = (RunoutState(*(a[sl] for a in state)) for sl in (slice(0, half), slice(half, None)))
    v1, v2 = cars.take(np.arange(half)), cars.take(np.arange(half, 2 * half))
    ref, got = _both(monkeypatch, lambda: run_out_pair(v1, v2, s1, s2, mu[:half], params,
                                                       brake[:half], brake[half:]))
    assert (~ref.at_rest).any() and ref.path.shape[2] > 64
    _agree(ref, got)


def test_monte_carlo_settings_and_the_memo(monkeypatch: pytest.MonkeyPatch) -> None:
    """The uncertainty model's settings (dt 20 ms, one path interval over the horizon), rest
    poses only, and the memo of the model-variant searches."""
    cars, state, mu, brake, wheels = _draw(7, 300)
    params = RunoutParams(dt=0.02, max_time=30.0, path_interval=30.0)
    _agree(*_both(monkeypatch, lambda: run_out(cars, state, mu, params, brake, **wheels)))
    _agree(*_both(monkeypatch, lambda: run_out(cars, state, mu, params, brake, paths=False,
                                               memo=RunoutMemo(), **wheels)))


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    """Generated cases of every accident type with random post-impact wheel inputs."""
    return with_random_wheel_inputs(cases_of_every_type(5, seed=31, near_miss_share=0.1),
                                    12)


def test_every_accident_type_agrees_with_the_reference(batch: CaseBatch,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """The product path: simulate_cases with the pair run-out of every collision; the
    pre-crash and impact outputs bit for bit, the run-out within the tolerance."""
    ref, got = _both(monkeypatch, lambda: simulate_cases(batch))
    assert np.isfinite(ref.runout.rest_x).any()
    for name, a, b in zip(ref._fields, ref, got, strict=True):
        if name != "runout":
            np.testing.assert_equal(b, a, err_msg=name)
    same, total = _agree(ref.runout, got.runout)
    assert same > 0.9 * total, same / total


def test_contacts_run_the_reference_and_say_so_once(monkeypatch: pytest.MonkeyPatch,
                                                    vfs_log: list[logging.LogRecord]) -> None:
    """RunoutParams(contact=True) is not compiled: the numpy path runs, with one log line."""
    cars, state, mu, brake, _ = _draw(8, 20)
    s1, s2 = (RunoutState(*(a[sl] for a in state)) for sl in (slice(0, 10), slice(10, None)))
    s2 = s2._replace(x=s1.x + 1.0, y=s1.y)
    v1, v2 = cars.take(np.arange(10)), cars.take(np.arange(10, 20))
    params = RunoutParams(contact=True)
    monkeypatch.setattr(runout, "_REPORTED", [])
    ref, got = _both(monkeypatch, lambda: run_out_pair(v1, v2, s1, s2, mu[:10], params))
    run_out_pair(v1, v2, s1, s2, mu[:10], params)
    for name, a, b in zip(ref._fields, ref, got, strict=True):
        assert np.array_equal(a, b, equal_nan=True), name
    lines = [r.getMessage() for r in vfs_log if "contacts solved" in r.getMessage()]
    assert len(lines) == 1, lines


def test_closed_form_slide(monkeypatch: pytest.MonkeyPatch) -> None:
    """A straight slide on locked wheels stops after v^2 / (2 mu g) on the compiled path."""
    monkeypatch.setenv(ENV_SWITCH, "1")
    car = stack_vehicles([VehicleParams()])
    res = run_out(car, RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0), 0.8,
                  wheel_brake=(1, 1, 1, 1))
    assert res.rest_x[0] == pytest.approx(10.0**2 / (2 * 0.8 * G), abs=0.01)
    assert res.rest_y[0] == 0.0 and res.rest_yaw[0] == 0.0
