"""The gym benchmark's measures: unnecessary braking, comfort and the score (vfs.gym.benchmark)."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.gym import benchmark as bm
from vfs.physics.braking import PrecrashObservation


class _Fixed:
    """A controller that demands nothing (the recorder only watches the observations)."""

    def reset(self, n_cases, rng):
        pass

    def demand(self, obs):
        return np.zeros((obs.rows.size, 2))


def _obs(t, decel, speed):
    n = 1
    z = np.zeros((n, 2))
    return PrecrashObservation(rows=np.array([0]), t=t, x=z, y=z, yaw=z, heading=z,
                               speed=np.array([[speed, 10.0]]), accel=z, yaw_rate=z,
                               deceleration=np.array([[decel, 0.0]]),
                               road_friction=np.ones(n))


@pytest.mark.parametrize("dt", [0.01, 0.002])
def test_recorder_aggregates_a_jerk_limited_brake_in_closed_form(dt):
    """Ramp at jerk J to D, hold, then stand: peak D, peak jerk J, time above 4 m/s^2
    (D - 4) / J + hold, speed taken = the integral of the deceleration (to one step).
    """
    jerk, top, hold, v0 = 40.0, 8.0, 1.0, 20.0
    rec = bm.ComfortRecorder(_Fixed(), 1)
    rec.reset(1, np.random.default_rng(0))
    t, decel, v = 0.0, 0.0, v0
    ramp = top / jerk
    while t < ramp + hold - 1e-12:
        rec.demand(_obs(t, decel, v))
        v -= decel * dt
        t += dt
        decel = min(top, jerk * t)
    for _ in range(30):  # standing with the brake held: neither felt nor counted
        rec.demand(_obs(t, top, 0.0))
        t += dt
    ev = rec.events()
    assert ev["peak_decel"][0, 0] == pytest.approx(top)
    assert ev["peak_jerk"][0, 0] == pytest.approx(jerk, rel=1e-6)
    assert ev["harsh_time"][0, 0] == pytest.approx((top - 4.0) / jerk + hold, abs=2 * dt)
    assert ev["brake_time"][0, 0] == pytest.approx(
        (top - bm.BRAKE_THRESHOLD) / jerk + hold, abs=2 * dt)
    taken = 0.5 * top * ramp + top * hold  # area under the deceleration
    assert ev["speed_taken"][0, 0] == pytest.approx(taken, abs=2 * top * dt)
    assert ev["start_speed"][0, 0] == v0
    assert ev["peak_decel"][0, 1] == 0.0 and ev["harsh_time"][0, 1] == 0.0


def test_recorder_leaves_the_runs_unchanged():
    from vfs.adas.systems import get_system
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, simulate_cases

    db = open_database("default")
    batch = CaseBatch.from_database(db.subset(db.case_ids[:12]))
    system = get_system("three-stage")
    eq = np.zeros((batch.size, 2), bool)
    eq[:, 0] = True
    plain = simulate_cases(batch, controller=system.controller(batch, eq),
                           rng=np.random.default_rng(3))
    wrapped = bm.ComfortSystem(system)
    rec = wrapped.controller(batch, eq)
    assert isinstance(rec, bm.SegmentableComfortRecorder)
    watched = simulate_cases(batch, controller=rec, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(plain.precrash.collided, watched.precrash.collided)
    np.testing.assert_array_equal(plain.impact.delta_v, watched.impact.delta_v)
    assert wrapped.name == system.name and wrapped.aeb == system.aeb
    events = rec.events()
    assert set(bm.COMFORT_KEYS) <= set(events) and "warning_time" in events


def test_score_formula():
    assert bm.benchmark_score(0.0, 0.0, 0.0) == 0.0
    assert bm.benchmark_score(0.5, 0.2, 1.0) == pytest.approx(
        0.5 - bm.UNNECESSARY_WEIGHT * 0.2 - bm.HARSH_WEIGHT * 1.0)
    assert str(bm.UNNECESSARY_WEIGHT).rstrip("0").rstrip(".") in bm.score_formula()


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    """Never, always and the ideal system on 30 test-split cases plus 12 passes."""
    from vfs.database import open_database
    from vfs.gym.env import split_case_ids
    from vfs.gym.evaluate import evaluate_policy, leaderboard

    base = open_database("default")
    test = split_case_ids(base.case_ids, "test")
    db = bm.with_passes(base.subset(test[:30]), n_cases=12)
    out = tmp_path_factory.mktemp("bench") / "eval"
    evaluate_policy(["never-brake", "always-brake", "aeb:ideal"], db, str(out), split="all",
                    engine="serial", n_boot=50)
    return leaderboard(out).set_index("policy")


def test_always_braking_is_worse_than_the_ideal_system_on_braking_and_comfort(board):
    always, ideal = board.loc["always-brake"], board.loc["ideal"]
    assert always["near_misses"] >= 12  # the passes are no-crash cases
    assert always["unnecessary_share"] > ideal["unnecessary_share"]
    assert always["unnecessary_speed_share"] > ideal["unnecessary_speed_share"]
    assert always["unnecessary_brake_time"] > ideal["unnecessary_brake_time"]
    assert always["harsh_time"] > ideal["harsh_time"]
    assert always["score"] < ideal["score"]


def test_never_braking_avoids_nothing_and_brakes_never(board):
    never = board.loc["never-brake"]
    assert never["avoided"] == 0.0 and never["new_crashes"] == 0
    for key in ("unnecessary", "unnecessary_share", "unnecessary_speed_share",
                "brakes_share", "peak_decel", "peak_jerk", "harsh_time"):
        assert never[key] == 0.0, key
    assert never["score"] == 0.0


def test_with_passes_adds_non_conflict_cases_with_offset_ids():
    from vfs.database import open_database

    base = open_database("default")
    small = base.subset(base.case_ids[:5])
    both = bm.with_passes(small, n_cases=4)
    assert both.n_cases == 9
    added = both.cases[both.cases["case_id"] >= bm.PASSING_ID_OFFSET]
    assert len(added) == 4 and not added["collision"].astype(bool).any()
    with pytest.raises(Exception, match="id_offset"):
        bm.with_passes(both, n_cases=4)
