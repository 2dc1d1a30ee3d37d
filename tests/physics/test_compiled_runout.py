"""The optional compiled run-out kernel agrees with the numpy reference integrator.

The kernel repeats the reference's arithmetic operation by operation; only
the transcendental functions (atan, hypot, cos, sin) may round differently
(numpy's SIMD routines vs the C library, each within about one ulp).  One ulp
of a velocity of ~10 m/s is ~2e-15 m/s; the step is dissipative (energy never
rises), so such a difference is not amplified over the few thousand steps to
rest: it moves a rest position by about steps x dt x 1 ulp ~ 1e-12 m.  The
tolerance 1e-9 m (and 1e-9 rad, 1e-6 J for energies of ~1e5 J) leaves three
orders of margin and still catches any real deviation (a wrong term moves
rest positions by millimetres at least).  Where the two round differently a
vehicle whose speed crosses the stop speed within rounding of the threshold
could stop one step earlier or later; the random batches below contain no
such case (the stop times must agree exactly), which the fixed seeds make
reproducible.
"""

from __future__ import annotations

import numpy as np
import pytest

from vfs.physics import compiled_runout
from vfs.physics.runout import RunoutParams, RunoutState, run_out
from vfs.physics.vehicle import VehicleParams, stack_vehicles
from vfs.units import G

pytestmark = pytest.mark.skipif(not compiled_runout.AVAILABLE, reason="numba not installed")


def _batch(seed: int, n: int) -> tuple:
    rng = np.random.default_rng(seed)
    cars = stack_vehicles([VehicleParams(mass=float(m), cg_height=float(h))
                           for m, h in zip(rng.uniform(900, 2500, n), rng.uniform(0.4, 0.7, n),
                                           strict=True)])
    state = RunoutState.from_arrays(rng.normal(0, 5, n), rng.normal(0, 5, n),
                                    rng.uniform(-3, 3, n), rng.normal(0, 12, n),
                                    rng.normal(0, 8, n), rng.normal(0, 3, n))
    # a few vehicles already at rest, a few spinning in place
    state.vx[:5] = state.vy[:5] = state.yaw_rate[:5] = 0.0
    state.vx[5:10] = state.vy[5:10] = 0.0
    mu = rng.uniform(0.2, 1.0, n)
    brake = rng.uniform(0.0, 1.0, (n, 4))
    brake[rng.random((n, 4)) < 0.3] = 1.0  # locked wheels, also mixed within a vehicle
    brake[10:20] = 1.0  # all four locked
    return cars, state, mu, brake


def _both(monkeypatch: pytest.MonkeyPatch, *args: object) -> tuple:
    monkeypatch.setenv(compiled_runout.RUNOUT_SWITCH, "0")
    assert not compiled_runout.runout_enabled()
    ref = run_out(*args)  # type: ignore[arg-type]
    monkeypatch.setenv(compiled_runout.RUNOUT_SWITCH, "1")
    assert compiled_runout.runout_enabled()
    fast = run_out(*args)  # type: ignore[arg-type]
    return ref, fast


def _agree(ref: tuple, fast: tuple) -> None:
    np.testing.assert_array_equal(fast.at_rest, ref.at_rest)
    np.testing.assert_array_equal(fast.time_to_rest, ref.time_to_rest)
    np.testing.assert_array_equal(fast.path_t, ref.path_t)
    assert fast.path.shape == ref.path.shape
    for name in ("rest_x", "rest_y", "rest_yaw", "distance", "path"):
        np.testing.assert_allclose(getattr(fast, name), getattr(ref, name), rtol=0.0,
                                   atol=1e-9, err_msg=name)
    np.testing.assert_allclose(fast.kinetic_energy, ref.kinetic_energy, rtol=0.0, atol=1e-6)


@pytest.mark.parametrize("load_transfer", [False, True])
def test_compiled_runout_matches_reference(monkeypatch: pytest.MonkeyPatch,
                                           load_transfer: bool) -> None:
    cars, state, mu, brake = _batch(3, 400)
    params = RunoutParams(load_transfer=load_transfer)
    _agree(*_both(monkeypatch, cars, state, mu, params, brake))


def test_compiled_runout_long_paths_and_time_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """Path samples every step (more columns than the first pass holds: the long run-outs
    run again) and a time limit that stops some vehicles while they still move.
    """
    cars, state, mu, brake = _batch(5, 60)
    brake[:30] = 0.0  # rolling freely: only rolling resistance, long run-outs
    params = RunoutParams(dt=0.01, path_interval=0.01, max_time=2.0)
    ref, fast = _both(monkeypatch, cars, state, mu, params, brake)
    assert (~ref.at_rest).any() and ref.at_rest.any()
    assert ref.path.shape[1] > 64
    _agree(ref, fast)


def test_compiled_runout_monte_carlo_settings(monkeypatch: pytest.MonkeyPatch) -> None:
    """The uncertainty model's settings: dt 20 ms, one path interval over the horizon."""
    cars, state, mu, brake = _batch(7, 300)
    params = RunoutParams(dt=0.02, max_time=30.0, path_interval=30.0)
    _agree(*_both(monkeypatch, cars, state, mu, params, brake))


def test_compiled_runout_closed_form(monkeypatch: pytest.MonkeyPatch) -> None:
    """A straight slide on locked wheels stops after v^2 / (2 mu g) in both paths."""
    monkeypatch.setenv(compiled_runout.RUNOUT_SWITCH, "1")
    car = stack_vehicles([VehicleParams()])
    res = run_out(car, RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0), 0.8,
                  wheel_brake=(1, 1, 1, 1))
    assert res.rest_x[0] == pytest.approx(10.0**2 / (2 * 0.8 * G), abs=0.01)
    assert res.rest_y[0] == 0.0 and res.rest_yaw[0] == 0.0
