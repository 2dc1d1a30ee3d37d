"""Threat entries of the AEB observation (miss distance, CTRV TTC) and near-miss oversampling."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.adas.threat import Motion, time_to_collision
from vfs.errors import ParameterError
from vfs.gym.env import OBSERVATION_NAMES, AEBEnv, AEBVectorEnv
from vfs.gym.observation import THREAT_NAMES, TTC_NONE, miss_distance_cv
from vfs.physics.geometry import first_contact, rectangle_distance


def test_miss_distance_of_a_straight_pass_is_the_lateral_clearance():
    # B (half width 0.9) drives along -x, 2.5 m to the left of A (half width 0.8):
    # its outline passes 2.5 - 0.8 - 0.9 = 0.8 m beside A's, at t = dx / speed
    for dy, speed in ((2.5, 10.0), (-2.5, 3.0), (1.0, 10.0)):
        miss, t = miss_distance_cv(np.array([30.0]), np.array([dy]), np.array([-speed]),
                                   np.array([0.0]), np.array([0.0]), np.array([2.3]),
                                   np.array([0.8]), np.array([np.pi]), np.array([2.2]),
                                   np.array([0.9]), np.array([28.0]))
        assert miss[0] == pytest.approx(abs(dy) - 1.7, abs=1e-12)
        assert t[0] == pytest.approx(30.0 / speed, rel=1e-12)


def test_miss_distance_is_invariant_under_rotation_and_matches_swept_contact():
    rng = np.random.default_rng(3)
    n = 4000
    rx, ry = rng.uniform(-30, 30, n), rng.uniform(-30, 30, n)
    vx, vy = rng.uniform(-20, 20, n), rng.uniform(-20, 20, n)
    ya, yb = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi, np.pi, n)
    hla, hwa, hlb, hwb = (rng.uniform(0.5, 3.0, n) for _ in range(4))
    gap = rectangle_distance(np.zeros(n), np.zeros(n), ya, hla, hwa, rx, ry, yb, hlb, hwb)
    miss, t = miss_distance_cv(rx, ry, vx, vy, ya, hla, hwa, yb, hlb, hwb, gap)
    phi = 0.7
    c, s = np.cos(phi), np.sin(phi)
    miss_r, t_r = miss_distance_cv(c * rx - s * ry, s * rx + c * ry, c * vx - s * vy,
                                   s * vx + c * vy, ya + phi, hla, hwa, yb + phi, hlb, hwb,
                                   gap)
    np.testing.assert_allclose(miss_r, miss, atol=1e-9)
    np.testing.assert_allclose(t_r, t, atol=1e-9)
    # the outlines touch on the infinite straight path exactly when the miss is < 0:
    # sweep far into the past and the future and compare (away from grazing passes)
    approaching = (t > 0) & (gap > 0) & (np.abs(miss) > 1e-6)
    s_contact = first_contact(rx - 100 * vx, ry - 100 * vy, 200 * vx, 200 * vy,
                              ya, hla, hwa, yb, hlb, hwb)
    np.testing.assert_array_equal(np.isfinite(s_contact)[approaching],
                                  (miss < 0)[approaching])
    # a clear pass: the smallest sampled distance along the path equals the miss distance
    clear = np.flatnonzero(approaching & (miss > 0.05))[:200]
    # the distance is convex along the path; sample +-20 m of travel around the centres'
    # closest approach
    reach = 20.0 / np.hypot(vx[clear], vy[clear])
    taus = t[clear][None, :] + np.linspace(-1.0, 1.0, 8001)[:, None] * reach[None, :]
    d = rectangle_distance(np.zeros(clear.size * taus.shape[0]),
                           np.zeros(clear.size * taus.shape[0]),
                           np.tile(ya[clear], taus.shape[0]), np.tile(hla[clear], taus.shape[0]),
                           np.tile(hwa[clear], taus.shape[0]),
                           (rx[clear] + taus * vx[clear]).ravel(),
                           (ry[clear] + taus * vy[clear]).ravel(),
                           np.tile(yb[clear], taus.shape[0]), np.tile(hlb[clear], taus.shape[0]),
                           np.tile(hwb[clear], taus.shape[0])).reshape(taus.shape)
    np.testing.assert_allclose(d.min(axis=0), miss[clear], atol=2e-3)
    # receding or standing: the miss distance is the present gap
    receding = t <= 0
    np.testing.assert_array_equal(miss[receding], gap[receding])


@pytest.fixture(scope="module")
def pair() -> tuple[AEBEnv, AEBEnv]:
    return AEBEnv(split="test"), AEBEnv(split="test", threat_features=True)


def test_threat_entries_extend_the_sensor_view(pair):
    plain, threat = pair
    d = len(OBSERVATION_NAMES)
    assert threat.observation_space.shape == (d + len(THREAT_NAMES),)
    assert threat.config.observation_names == OBSERVATION_NAMES + THREAT_NAMES
    case = int(plain.core.split_ids[3])
    o1, _ = plain.reset(options={"case_id": case})
    o2, _ = threat.reset(options={"case_id": case})
    names = threat.config.observation_names
    seen_steps = 0
    while True:
        np.testing.assert_array_equal(o2[:d], o1)  # the first entries are unchanged
        assert threat.observation_space.contains(o2)
        entry = dict(zip(names, o2.tolist(), strict=True))
        if entry["object_seen"] < 0.5:  # what is not seen is not reported
            assert entry["obj_yaw_rate"] == entry["miss_cv"] == entry["t_closest"] == 0.0
            assert entry["ttc_ctrv"] == TTC_NONE
        else:
            seen_steps += 1
            # the CTRV TTC is the AEB systems' kernel on the simulation state
            p = threat.precrash_observation
            dims = threat.core.dims.take(p.rows)
            heading = np.where(p.speed > 0.0, p.heading, p.yaw)
            m = [Motion(p.x[:, k], p.y[:, k], p.yaw[:, k], heading[:, k], p.speed[:, k],
                        p.accel[:, k], p.yaw_rate[:, k], 0.5 * (f + r), 0.5 * w, 0.5 * (f - r))
                 for k, (f, r, w) in ((0, dims[:3]), (1, dims[3:]))]
            ttc = min(float(time_to_collision(m[0], m[1], TTC_NONE, "ctrv")[0]), TTC_NONE)
            assert entry["ttc_ctrv"] == pytest.approx(ttc, rel=1e-5, abs=1e-5)
        a = np.array([0.3])
        o1, r1, t1, u1, _ = plain.step(a)
        o2, r2, t2, u2, _ = threat.step(a)
        assert (r1, t1, u1) == (r2, t2, u2)  # same dynamics and reward
        if t1 or u1:
            break
    assert seen_steps > 10


def test_near_miss_weight_draws_near_misses_in_proportion():
    env = AEBEnv(split="train", near_miss_weight=5.0)
    core = env.core
    near = ~core.recorded_collision
    n_near, n = int(near.sum()), near.size
    expected = 5.0 * n_near / (5.0 * n_near + (n - n_near))
    rng = np.random.default_rng(0)
    draws = core.draw(np.zeros(4000, np.int64), rng)
    share = float(near[draws].mean())
    sd = np.sqrt(expected * (1 - expected) / 4000)
    assert abs(share - expected) < 4 * sd
    assert share > 2.5 * n_near / n  # clearly oversampled against the uniform draw
    # the vector environment: the near misses among the cases started
    venv = AEBVectorEnv(num_envs=64, split="train", near_miss_weight=5.0)
    started = []
    for seed in range(40):
        venv.reset(seed=seed)
        started.append(venv.core.slot_row.copy())
    rows = np.concatenate(started)
    vn = ~venv.core.recorded_collision
    share_v = float(vn[rows].mean())
    assert abs(share_v - expected) < 4 * np.sqrt(expected * (1 - expected) / rows.size) + 0.03
    # weight 1 keeps the uniform draw of earlier versions, bit for bit
    a, b = AEBEnv(split="train"), AEBEnv(split="train", near_miss_weight=1.0)
    assert [a.reset(seed=s)[1]["case_id"] for s in range(20)] == \
        [b.reset(seed=s)[1]["case_id"] for s in range(20)]
    with pytest.raises(ParameterError, match="near_miss_weight"):
        AEBEnv(split="test", near_miss_weight=0.0)


def test_leaderboard_counts_braking_in_near_misses(tmp_path, capsys):
    import pandas as pd

    from vfs.cli import main

    out = tmp_path / "board"
    assert main(["evaluate-policy", "never-brake", "always-brake", "--db", "default",
                 "--split", "test", "--where", "case_id <= 100", "--out", str(out),
                 "--engine", "serial", "--bootstrap", "50"]) == 0
    assert "brakes in no-crash cases" in capsys.readouterr().out
    board = pd.read_csv(out / "leaderboard.csv").set_index("policy")
    runs = pd.read_parquet(out / "runs.parquet")
    base = runs[runs["system"] == "baseline"].set_index("case_id")
    near = int((~base["collided"].astype(bool)).sum())
    assert near > 0
    assert (board["near_misses"] == near).all()
    assert board.loc["never-brake", "near_miss_brakes"] == 0  # the recorded drivers do not brake
    assert board.loc["always-brake", "near_miss_brakes"] == near
    treat = runs[runs["system"] == "always-brake"].set_index("case_id")
    avoided = (base["collided"].astype(bool) & ~treat["collided"].astype(bool)).sum()
    assert board.loc["always-brake", "avoided"] == pytest.approx(
        100.0 * avoided / base["collided"].astype(bool).sum())
    assert board.loc["never-brake", "avoided"] == 0.0
    assert (board["avoided_low"] <= board["avoided"]).all()
    text = (out / "leaderboard.md").read_text()
    assert text.count("| never-brake |") == 2  # the benefit table and the braking/comfort one
    assert "score =" in text


def test_false_activation_and_collision_costs():
    """A braked near miss costs the activation weight once, a crash the collision weight."""
    plain = AEBEnv(split="test", action_repeat=5)
    priced = AEBEnv(split="test", action_repeat=5,
                    reward={"false_activation_weight": 0.7, "collision_weight": 0.3})
    near = plain.core.recorded_collision
    near_case = plain.core.case_id(int(np.flatnonzero(~near)[0]))
    crash_case = plain.core.case_id(int(np.flatnonzero(near)[0]))
    for case, brake, extra in ((near_case, 1.0, -0.7), (near_case, 0.0, 0.0),
                               (crash_case, 1.0, None), (crash_case, 0.0, -0.3)):
        totals, crashed = [], []
        for env in (plain, priced):
            env.reset(options={"case_id": case})
            total, done = 0.0, False
            while not done:
                _, r, term, trunc, info = env.step(np.array([brake]))
                total += r
                done = term or trunc
            totals.append(total)
            crashed.append(info["collided"])
        assert crashed[0] == crashed[1]
        if extra is None:  # full braking from the start: -0.3 if it still crashes
            extra = -0.3 if crashed[0] else 0.0
        assert totals[1] - totals[0] == pytest.approx(extra, abs=1e-12)
