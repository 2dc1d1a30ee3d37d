"""The AEB gymnasium environments: API conformance, reproducibility, physics equal to a study,
native vector environment equal to single environments, baselines and evaluate-policy."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import vfs  # noqa: F401  (registers vfs/AEB-v0)
from vfs.adas import get_system
from vfs.errors import ParameterError
from vfs.gym.env import (
    OBSERVATION_NAMES,
    PRIVILEGED_NAMES,
    AEBEnv,
    AEBVectorEnv,
    split_case_ids,
)
from vfs.gym.policies import ALWAYS_BRAKE, NEVER_BRAKE, AEBPolicy, load_policy


@pytest.fixture(scope="module")
def env() -> AEBEnv:
    return AEBEnv(split="test")


def run_episode(env: gym.Env, case_id: object, action_fn, seed: int = 0):
    """Play one case; returns (total reward, steps, last info, terminated)."""
    obs, info = env.reset(seed=seed, options={"case_id": case_id})
    total, steps = 0.0, 0
    while True:
        obs, r, term, trunc, info = env.step(action_fn(obs))
        total += r
        steps += 1
        if term or trunc:
            return total, steps, info, term


def ttc_brake(obs: np.ndarray) -> np.ndarray:
    """A simple sensor policy: full brake below 1.5 s TTC, half below 2.5 s."""
    ttc = np.asarray(obs, float).reshape(-1, len(OBSERVATION_NAMES))[:, 8]
    return np.where(ttc < 1.5, 1.0, np.where(ttc < 2.5, 0.5, 0.0))


def test_check_env_passes_without_warnings():
    from gymnasium.utils.env_checker import check_env

    made = gym.make("vfs/AEB-v0", split="test")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(made.unwrapped)
    priv = gym.make("vfs/AEB-v0", split="test", privileged=True, observe_friction=False)
    assert priv.observation_space.shape == (len(PRIVILEGED_NAMES),)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(priv.unwrapped)


def test_same_seed_same_episode(env):
    a = AEBEnv(split="test")
    ids = []
    for e in (env, a):
        obs, info = e.reset(seed=1234)
        ids.append(info["case_id"])
        trace = [obs]
        for _ in range(150):
            obs, r, term, trunc, _ = e.step(ttc_brake(obs))
            trace.append(np.r_[obs, r])
            if term or trunc:
                break
        ids.append(np.concatenate(trace))
    assert ids[0] == ids[2]
    np.testing.assert_array_equal(ids[1], ids[3])
    # different seeds pick different cases (almost surely over a few draws)
    picked = {env.reset(seed=s)[1]["case_id"] for s in range(8)}
    assert len(picked) > 3


def test_observation_is_the_documented_sensor_view(env):
    obs, info = env.reset(options={"case_id": env.core.split_ids[0]})
    assert obs.shape == (len(OBSERVATION_NAMES),) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    p = env.precrash_observation
    assert obs[0] == pytest.approx(p.speed[0, 0], rel=1e-6)  # ego speed
    seen = obs[2] == 1.0
    if seen:
        assert obs[3] > 0.0  # gap before contact
    else:
        np.testing.assert_array_equal(obs[3:8], 0.0)


@pytest.mark.parametrize("name", ["openpass-like", "ideal"])
def test_aeb_policy_in_env_equals_the_same_aeb_in_a_study(name, tmp_path):
    from vfs.database import load_database
    from vfs.database import resolve_database_path as database_path
    from vfs.study import run_study

    system = get_system(name)
    env = AEBEnv(split="test", brake=system.brake)
    policy = AEBPolicy(system).bind(env)
    ids = env.core.split_ids[:8]
    infos = []
    for cid in ids:
        obs, _ = env.reset(options={"case_id": cid})
        policy.reset(1, np.random.default_rng(0))
        while True:
            obs, _, term, trunc, info = env.step(policy.act(obs))  # float64 actions
            if term or trunc:
                break
        infos.append(info)
    db = load_database(database_path("default")).subset(ids)
    res = run_study(db, [system], tmp_path / "s", equip="1", engine="serial")
    table = res.table[res.table["system"] == name].set_index("case_id")
    assert sum(i["collided"] for i in infos) >= 2
    for info in infos:
        row = table.loc[info["case_id"]]
        assert bool(row["collided"]) == info["collided"]
        if info["collided"]:
            assert info["impact_speed"] == pytest.approx(row["impact_speed1"], rel=1e-9)
            assert info["delta_v"] == pytest.approx(row["delta_v1"], rel=1e-9)
            assert info["impact_type"] == row["impact_type"]


def test_native_vector_env_equals_single_envs(env):
    ids = env.core.split_ids[:6]
    single = [run_episode(env, cid, ttc_brake) for cid in ids]
    venv = AEBVectorEnv(num_envs=len(ids), split="test")
    obs, info = venv.reset(seed=0, options={"case_id": ids})
    np.testing.assert_array_equal(info["case_id"], ids)
    total = np.zeros(len(ids))
    done = np.zeros(len(ids), dtype=bool)
    outcome: dict[int, dict] = {}
    steps = np.zeros(len(ids), dtype=int)
    while not done.all():
        obs, r, term, trunc, info = venv.step(ttc_brake(obs)[:, None])
        live = ~done
        total[live] += r[live]
        steps[live] += 1
        for j in np.flatnonzero((term | trunc) & live):
            outcome[j] = {k: info[k][j] for k in ("collided", "delta_v", "impact_type", "time")}
        done |= term | trunc
    for j, (tot, n, inf, _) in enumerate(single):
        assert steps[j] == n
        assert total[j] == pytest.approx(tot, rel=1e-9, abs=1e-12)
        assert outcome[j]["collided"] == inf["collided"]
        assert outcome[j]["impact_type"] == inf["impact_type"]
        if inf["collided"]:
            assert outcome[j]["delta_v"] == pytest.approx(inf["delta_v"], rel=1e-9)


def test_vector_env_autoreset_next_step():
    venv = gym.make_vec("vfs/AEB-v0", num_envs=16, vectorization_mode="vector_entry_point",
                        split="test")
    obs, info = venv.reset(seed=5)
    ended = None
    for _ in range(3000):
        obs, r, term, trunc, info = venv.step(np.ones((16, 1)))
        if (term | trunc).any():
            ended = np.flatnonzero(term | trunc)
            assert info["_collided"][ended].all()
            break
    assert ended is not None
    before = info["case_id"][ended].copy()
    obs, r, term, trunc, info = venv.step(np.ones((16, 1)))
    # the next step starts new cases there: reward 0, not done, time 0
    np.testing.assert_array_equal(r[ended], 0.0)
    assert not (term[ended] | trunc[ended]).any()
    np.testing.assert_array_equal(info["t"][ended], 0.0)
    assert venv.single_observation_space.contains(obs[ended[0]])
    assert before.shape == info["case_id"][ended].shape


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_gymnasium_vector_wrappers(mode):
    venv = gym.make_vec("vfs/AEB-v0", num_envs=2, vectorization_mode=mode, split="test")
    try:
        obs, _ = venv.reset(seed=0)
        assert obs.shape == (2, len(OBSERVATION_NAMES))
        for _ in range(20):
            obs, r, term, trunc, _ = venv.step(np.full((2, 1), 0.2, np.float32))
        assert np.isfinite(r).all()
    finally:
        venv.close()


def test_rewards_never_brake_and_unnecessary_braking(env):
    core = env.core
    near = core.split_ids[~core.recorded_collision[:core.n_cases]]
    crash = core.split_ids[core.recorded_collision[:core.n_cases]]
    assert near.size and crash.size
    # a near miss without braking: no cost, no collision, truncated at the end of the case
    tot, _, info, term = run_episode(env, near[0], lambda o: NEVER_BRAKE.act(o[None]))
    assert tot == 0.0 and not info["collided"] and not info["avoided"]
    # braking in a near miss costs (unnecessary braking + comfort)
    tot_b, _, info_b, _ = run_episode(env, near[0], lambda o: ALWAYS_BRAKE.act(o[None]))
    assert tot_b < 0.0 and not info_b["collided"]
    # a recorded crash replayed: reward = - injury risk of the impact
    tot_c, _, info_c, term_c = run_episode(env, crash[0], lambda o: np.zeros(1))
    assert term_c and info_c["collided"]
    assert tot_c == pytest.approx(-info_c["injury_risk"], rel=1e-12)
    assert info_c["injury_risk"] > 0.0 and info_c["delta_v"] > 0.0


def test_split_is_a_partition():
    ids = np.arange(1, 101)
    test, train = split_case_ids(ids, "test"), split_case_ids(ids, "train")
    assert test.size == 20 and np.intersect1d(test, train).size == 0
    np.testing.assert_array_equal(np.union1d(test, train), ids)
    np.testing.assert_array_equal(split_case_ids(ids, "test", seed=0), test)
    assert not np.array_equal(split_case_ids(ids, "test", seed=1), test)


def test_bad_settings_are_clear():
    with pytest.raises(ParameterError, match="split"):
        AEBEnv(split="validation")
    with pytest.raises(ParameterError, match="unknown AEB environment setting"):
        AEBEnv(splt="test")
    with pytest.raises(ParameterError, match="policy"):
        load_policy("sometimes-brake")
    env = AEBEnv(split="test")
    with pytest.raises(ParameterError, match="not in split"):
        env.reset(options={"case_id": -1})


def test_evaluate_policy_cli_writes_the_effectiveness_report(tmp_path):
    from vfs.cli import main

    out = tmp_path / "evp"
    code = main(["evaluate-policy", "always-brake", "--db", "default", "--split", "test",
                 "--where", "case_id <= 60", "--out", str(out), "--engine", "serial",
                 "--bootstrap", "50"])
    assert code == 0
    assert (out / "report" / "report.md").exists()
    import pandas as pd

    runs = pd.read_parquet(out / "runs.parquet")
    assert set(runs["system"]) == {"baseline", "always-brake"}
    treat = runs[runs["system"] == "always-brake"]
    assert treat["collided"].sum() < runs[runs["system"] == "baseline"]["collided"].sum()


def test_every_nested_setting_may_be_a_dict():
    env = AEBEnv(split="test", simulation={"precrash": {"dt": 0.02, "brake": {"jerk": 30.0}},
                                           "impact": {"restitution": 0.2}},
                 reward={"risk_of": "ego"}, sensor={"range": 80.0}, brake={"jerk": 25.0})
    cfg = env.config
    assert cfg.simulation.precrash.dt == 0.02
    assert cfg.simulation.precrash.brake.jerk == 30.0
    assert cfg.simulation.impact.restitution == 0.2
    assert cfg.reward.risk_of == "ego" and cfg.sensor.range == 80.0 and cfg.brake.jerk == 25.0
    # the defaults of every field not given
    assert cfg.simulation.runout == type(cfg.simulation.runout)()
    # the environment runs on the dict settings: its step is 2 x 10 ms
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(1, np.float32))
    assert info.get("t", 0.02) == pytest.approx(0.02)
    with pytest.raises(ParameterError, match=r"simulation\.precrash: unknown setting.*'dtt'"):
        AEBEnv(simulation={"precrash": {"dtt": 0.02}})
    with pytest.raises(ParameterError, match="reward"):
        AEBEnv(reward=3)
