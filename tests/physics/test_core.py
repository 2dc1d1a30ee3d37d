"""The compiled pre-crash core against the numpy reference (``VFS_COMPILED=0``).

:mod:`vfs.physics.core` repeats the reference's arithmetic operation by operation
(the same look-ups, interpolations, corner order, clipping stages and the shoelace sum
in numpy's pairwise order), and the only library functions both evaluate, cos, sin
and hypot, round alike in numpy's float64 loops and the C library here.  So every
output must be equal bit for bit (NaN where NaN): the replay (per-case loop) and every
built-in system (the compiled step under the Python controller), with the impact after
them, on generated cases of every accident type and near misses.  The run-out after them
(:mod:`vfs.physics.core_runout`) evaluates atan, where numpy and the C library differ by
an ulp now and then: its outputs agree within :data:`vfs.physics.core_runout.AGREEMENT`
(tests/physics/test_core_runout.py says why), its flags and stop times exactly.
Should a platform's library round one of those functions differently, an ulp in a CG
distance could move a tie of the closest approach by one step; these tests would then
fail and name the field.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

from tests.generated import bit_differences, cases_of_every_type
from vfs.adas.systems import SYSTEM_NAMES, get_system
from vfs.physics import precrash
from vfs.physics.core_runout import AGREEMENT
from vfs.physics.precrash import PrecrashParams, ScheduledBraking, simulate_precrash
from vfs.simulation import CaseBatch, SimulationParams, simulate_cases


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    """Cases of every accident type of the generator, a fifth of them near misses."""
    return cases_of_every_type(4, seed=21, near_miss_share=0.2)


def _end_to_end_differences(ref: tuple, got: tuple) -> list[str]:
    """:func:`tests.generated.bit_differences` of two ``simulate_cases`` results, the
    run-out's positions, headings, lengths and energies within AGREEMENT (m, rad; energies
    relative).
    """
    out = bit_differences(ref._replace(runout=None), got._replace(runout=None))
    for name, a, b in zip(ref.runout._fields, ref.runout, got.runout, strict=True):
        x, y = np.asarray(a), np.asarray(b)
        if x.dtype.kind != "f" or name in ("time_to_rest", "path_t",
                                           "secondary_collision_time"):
            ok = x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")
        else:
            rtol = AGREEMENT if name == "kinetic_energy" else 0.0
            ok = x.shape == y.shape and np.allclose(x, y, rtol=rtol, atol=AGREEMENT,
                                                    equal_nan=True)
        if not ok:
            out.append("runout." + name)
    return out


def _both(monkeypatch: pytest.MonkeyPatch, run):  # noqa: ANN001, ANN202
    monkeypatch.setenv("VFS_COMPILED", "0")
    ref = run()
    monkeypatch.setenv("VFS_COMPILED", "1")
    return ref, run()


def test_replay_equals_the_reference_bit_for_bit(batch: CaseBatch,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    ref, got = _both(monkeypatch, lambda: simulate_precrash(
        batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction))
    assert ref.collided.any() and not ref.collided.all()  # contacts and near misses
    assert bit_differences(ref, got) == []


def test_replay_of_instances_and_late_starts_equals_the_reference(
        batch: CaseBatch, monkeypatch: pytest.MonkeyPatch) -> None:
    n = batch.size
    case_of = np.r_[np.arange(n), np.arange(0, n, 3)]
    first = np.r_[np.zeros(n, dtype=np.int64), np.arange(0, n, 3) % 7 * 40]
    params = PrecrashParams(penetration_time=0.0)  # the instant-impact branch as well
    for kwargs in ({"case_of": case_of}, {"case_of": case_of, "first_step": first},
                   {"params": params}):
        ref, got = _both(monkeypatch, lambda kw=kwargs: simulate_precrash(
            batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction, **kw))
        assert bit_differences(ref, got) == [], kwargs


@pytest.mark.parametrize("name", [*SYSTEM_NAMES, "ideal-ctra"])
def test_every_system_equals_the_reference_end_to_end(name: str, batch: CaseBatch,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    system = get_system(name)
    base = SimulationParams()
    params = dataclasses.replace(base, precrash=system.precrash_params(base.precrash))

    def run():  # noqa: ANN202
        controller = system.controller(batch, np.array([True, True]))
        return simulate_cases(batch, controller=controller, params=params,
                              rng=np.random.default_rng(4))

    ref, got = _both(monkeypatch, run)
    assert _end_to_end_differences(ref, got) == []


def test_a_python_controller_runs_between_compiled_steps_and_says_so_once(
        batch: CaseBatch, monkeypatch: pytest.MonkeyPatch,
        vfs_log: list[logging.LogRecord]) -> None:
    """A controller the kernel cannot call (any Python object with ``reset`` and
    ``demand``) still works: it runs in Python between the compiled steps, with one log
    line per process and kind of controller.
    """
    n = batch.size
    start = np.where(np.arange(n)[:, None] % 2 == 0, 3.0, np.nan) * np.ones((1, 2))
    controller = ScheduledBraking(start, np.full((n, 2), 6.0))
    monkeypatch.setattr(precrash, "_REPORTED", set())
    ref, got = _both(monkeypatch, lambda: simulate_precrash(
        batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction,
        controller=controller))
    simulate_precrash(batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction,
                      controller=controller)
    assert bit_differences(ref, got) == []
    assert np.isfinite(got.brake_start[::2]).any()
    lines = [r.getMessage() for r in vfs_log if "ScheduledBraking" in r.getMessage()]
    assert len(lines) == 1, lines
