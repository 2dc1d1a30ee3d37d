"""Render modes of the AEB environment and the stable-baselines3 integration."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vfs  # noqa: F401  (registers vfs/AEB-v0)
from vfs.errors import ParameterError
from vfs.gym.env import AEBEnv


def test_rgb_array_frames_have_the_declared_shape_and_change_between_steps():
    env = AEBEnv(render_mode="rgb_array", split="test", action_repeat=10)
    env.reset(seed=2)
    first = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    frames = [first]
    for _ in range(5):
        _, _, term, trunc, _ = env.step(np.array([0.0], np.float32))
        frames.append(env.render())
        if term or trunc:
            break
    assert all(f.shape == first.shape for f in frames)
    # the vehicles move (action repeat 10 = 0.1 s per frame): every frame differs
    assert all(np.any(a != b) for a, b in zip(frames, frames[1:], strict=False))
    assert env.metadata["render_fps"] == pytest.approx(10.0)


def test_ansi_reports_the_state_and_no_render_mode_renders_nothing():
    env = AEBEnv(render_mode="ansi", split="test")
    _, info = env.reset(seed=0)
    line = env.render()
    assert line.startswith(f"case {info['case_id']} t=  0.00 s") and line.endswith("\n")
    speed = float(line.split("ego")[1].split("km/h")[0])
    assert speed == pytest.approx(env.trace.speed[0] * 3.6, abs=0.06)
    plain = AEBEnv(split="test")
    plain.reset(seed=0)
    assert plain.render() is None and plain.trace is None
    with pytest.raises(ParameterError, match="render_mode"):
        AEBEnv(render_mode="human")


def test_the_episode_trace_follows_the_simulation():
    # the trace's ego speed after full braking falls at the delivered deceleration
    env = AEBEnv(render_mode="ansi", split="test", action_repeat=1)
    env.reset(seed=4)
    for _ in range(60):
        _, _, term, trunc, _ = env.step(np.array([1.0], np.float32))
        if term or trunc:
            break
    tr = env.trace
    dt = np.diff(tr.t)
    dv = np.diff(tr.speed)
    moving = np.array(tr.speed[1:]) > 0.5
    # v(k+1) - v(k) = -decel x dt within the integration's step (semi-implicit update)
    decel = np.array(tr.decel[1:])
    np.testing.assert_allclose(dv[moving], -(decel * dt)[moving], atol=0.3 * 0.01 * 20 + 1e-9)


def test_sb3_make_vec_env_and_check_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env
    from stable_baselines3.common.env_util import make_vec_env

    venv = make_vec_env("vfs/AEB-v0", n_envs=3, env_kwargs={"split": "test"})
    obs = venv.reset()
    assert obs.shape == (3, 10)
    obs, rew, done, infos = venv.step(np.zeros((3, 1), np.float32))
    assert rew.shape == (3,) and len(infos) == 3
    assert venv.render().ndim == 3  # make_vec_env asks for rgb_array
    check_env(gym.make("vfs/AEB-v0", split="test").unwrapped)


def test_sb3_adapter_gives_the_same_transitions_as_single_envs():
    pytest.importorskip("stable_baselines3")
    from vfs.gym.sb3 import AEBVecEnv

    n = 4
    vec = AEBVecEnv(n, split="test", action_repeat=5)
    vec.reset()
    cases = np.sort(vec.venv.core.split_ids)[:n]
    obs_v, _ = vec.venv.reset(options={"case_id": cases})
    singles = [AEBEnv(split="test", action_repeat=5) for _ in range(n)]
    obs_s = np.stack([e.reset(options={"case_id": c})[0] for e, c in zip(singles, cases,
                                                                             strict=True)])
    np.testing.assert_array_equal(obs_v, obs_s)
    rng = np.random.default_rng(0)
    live = np.ones(n, bool)
    ended_seen = 0
    for _ in range(400):
        actions = rng.uniform(0.0, 1.0, (n, 1)).astype(np.float32)
        vec.step_async(actions)
        obs, rew, done, infos = vec.step_wait()
        for i in np.flatnonzero(live):
            o, r, term, trunc, info = singles[i].step(actions[i])
            assert rew[i] == pytest.approx(r, rel=1e-6, abs=1e-9)
            assert done[i] == (term or trunc)
            if done[i]:
                np.testing.assert_array_equal(infos[i]["terminal_observation"], o)
                assert infos[i]["TimeLimit.truncated"] == (trunc and not term)
                assert infos[i]["collided"] == info["collided"]
                assert infos[i]["case_id"] == cases[i]
                # same-step autoreset: obs[i] is the next case's first observation
                core = vec.venv.core
                nxt = core.case_id(int(core.slot_row[i]))
                fresh = AEBEnv(split="test", action_repeat=5)
                np.testing.assert_array_equal(obs[i], fresh.reset(options={"case_id": nxt})[0])
                live[i] = False
                ended_seen += 1
            else:
                np.testing.assert_array_equal(obs[i], o)
        if not live.any():
            break
    assert ended_seen == n


class _TTCPolicy:
    """Full brake below 1.5 s TTC, half below 2.5 s; counts the rows it was asked for."""

    name = "ttc-brake"

    def __init__(self):
        self.asked = 0

    def reset(self, n, rng):
        return None

    def act(self, obs):
        obs = np.asarray(obs, float).reshape(-1, 10)
        self.asked += obs.shape[0]
        ttc = obs[:, 8]
        return np.where(ttc < 1.5, 1.0, np.where(ttc < 2.5, 0.5, 0.0))


@pytest.mark.parametrize("repeat", [1, 5])
def test_evaluation_asks_the_policy_as_often_as_the_environment(repeat, tmp_path):
    # a policy evaluated as a study (evaluate-policy) sees the same decisions as in the
    # environment it was trained in: same outcomes, one query per action_repeat steps
    from vfs.gym.evaluate import evaluate_policy

    env = AEBEnv(split="test", action_repeat=repeat)
    ids = env.core.split_ids[:8]
    pol = _TTCPolicy()
    infos, steps = [], 0
    for cid in ids:
        obs, _ = env.reset(options={"case_id": cid})
        while True:
            obs, _, term, trunc, info = env.step(pol.act(obs))
            steps += 1
            if term or trunc:
                break
        infos.append(info)
    assert sum(i["collided"] for i in infos) >= 2
    study_pol = _TTCPolicy()
    res = evaluate_policy(study_pol, "default", str(tmp_path / "s"), split="all",
                          where=f"case_id IN ({', '.join(str(int(c)) for c in ids)})",
                          engine="serial", report=False, env_kwargs={"action_repeat": repeat})
    table = res.table[res.table["system"] == "ttc-brake"].set_index("case_id")
    for info in infos:
        row = table.loc[info["case_id"]]
        assert bool(row["collided"]) == info["collided"]
        if info["collided"]:
            assert info["impact_speed"] == pytest.approx(row["impact_speed1"], rel=1e-9)
    if repeat > 1:
        # a policy that never brakes leaves the runs unchanged: with action repeat R it
        # is asked at steps 0, R, 2R, ... of each case, i.e. ceil(n / R) times for n steps
        counts = {}
        for r in (1, repeat):
            zero = _TTCPolicy()
            zero.act = lambda obs, z=zero: (setattr(z, "asked", z.asked + len(obs)),
                                            np.zeros(len(obs)))[1]
            evaluate_policy(zero, "default", str(tmp_path / f"z{r}"), split="all",
                            where=f"case_id IN ({', '.join(str(int(c)) for c in ids)})",
                            engine="serial", report=False, env_kwargs={"action_repeat": r})
            counts[r] = zero.asked
        assert counts[1] / repeat <= counts[repeat] <= counts[1] / repeat + len(ids) * 2


def test_evaluate_policy_loads_an_sb3_model_with_its_settings(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    import json

    from stable_baselines3 import PPO

    from vfs.cli import main as vfs_main
    from vfs.gym.policies import SB3_SETTINGS_SUFFIX, load_policy
    from vfs.gym.sb3 import AEBVecEnv

    env = AEBVecEnv(8, seed=0, split="train", action_repeat=10)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=0,
                device="cpu")
    model.learn(256)
    path = tmp_path / "model"
    model.save(path)
    (tmp_path / ("model" + SB3_SETTINGS_SUFFIX)).write_text(
        json.dumps({"env_kwargs": {"action_repeat": 10}}))
    pol = load_policy(f"sb3:{path}")
    assert pol.env_kwargs == {"action_repeat": 10}
    obs = np.zeros((3, 10), np.float32)
    a = pol.act(obs)
    assert a.shape == (3,) and np.all((a >= 0) & (a <= 1))
    out = tmp_path / "eval"
    code = vfs_main(["evaluate-policy", f"sb3:{path}", "never-brake", "--db", "default",
                     "--where", "case_id <= 60", "--split", "all", "--out", str(out),
                     "--engine", "serial", "--bootstrap", "50",
                     "--env-kwargs", '{"sensor": {"range": 120.0}}'])
    assert code == 0
    text = capsys.readouterr().out
    assert "sb3:model" in text and "never-brake" in text
    assert (out / "report" / "report.md").is_file()


def test_animation_has_the_stated_number_of_frames(tmp_path):
    import dataclasses

    from PIL import Image

    from vfs.gym.animation import animate_traces, play_traces

    env = AEBEnv(split="test")
    case = env.core.split_ids[0]
    base, treated = play_traces("default", case, "three-stage")
    assert base.case_id == treated.case_id == case

    def head(tr, k):
        return dataclasses.replace(tr, **{f: getattr(tr, f)[:k] for f in (
            "t", "x", "y", "yaw", "speed", "decel", "demand", "ttc", "gap", "seen")})

    n = animate_traces([head(base, 12), head(treated, 7)], ["a", "b"], tmp_path / "a.gif",
                       fps=10)
    assert n == 12
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 12
    with pytest.raises(ParameterError, match="gif"):
        animate_traces([base], ["a"], tmp_path / "a.avi")
