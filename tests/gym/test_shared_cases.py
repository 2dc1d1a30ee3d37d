"""Environments of one configuration share the loaded, prepared and replayed cases
(vfs.gym.env.shared_cases): built once, read by all, and the same episodes as a fresh build."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import vfs  # noqa: F401  (registers vfs/AEB-v0)
from vfs.database import open_database
from vfs.gym import env as env_module

WHERE = "case_id <= 40"


def _episode(env, seed: int) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for k in range(200):
        obs, reward, term, trunc, _ = env.step(np.array([(k % 7) / 7.0], dtype=np.float32))
        out.append(np.append(obs, reward))
        if term or trunc:
            break
    return out


def test_a_second_env_reuses_the_shared_cases_and_runs_the_same_episodes():
    env_module.clear_shared_cases()
    first = gym.make("vfs/AEB-v0", db="default", where=WHERE, split="all")
    shared = next(iter(env_module._SHARED.values()))
    second = gym.make("vfs/AEB-v0", db="default", where=WHERE, split="all")
    assert len(env_module._SHARED) == 1
    assert second.unwrapped.core.batch is shared.batch is first.unwrapped.core.batch
    a, b = _episode(first, 5), _episode(second, 5)
    env_module.clear_shared_cases()
    fresh = _episode(gym.make("vfs/AEB-v0", db="default", where=WHERE, split="all"), 5)
    for x, y, z in zip(a, b, fresh, strict=True):
        np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(x, z)


def test_a_database_object_is_shared_only_while_it_is_the_same_object():
    env_module.clear_shared_cases()
    db = open_database("default", WHERE)
    one = gym.make("vfs/AEB-v0", db=db, split="all").unwrapped.core.batch
    assert gym.make("vfs/AEB-v0", db=db, split="all").unwrapped.core.batch is one
    other = open_database("default", WHERE)
    assert gym.make("vfs/AEB-v0", db=other, split="all").unwrapped.core.batch is not one
    assert len(env_module._SHARED) <= env_module.SHARED_CACHE_SIZE
