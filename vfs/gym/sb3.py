"""The native vector environment as a stable-baselines3 ``VecEnv``.

:class:`AEBVecEnv` runs ``num_envs`` AEB episodes as rows of one batched simulation
(:class:`vfs.gym.env.AEBVectorEnv`) and speaks SB3's VecEnv API: ``step_wait`` returns
(obs, rewards, dones, infos) with the same-step autoreset SB3 expects (an ended
sub-environment's final observation in ``infos[i]["terminal_observation"]``, the next
case's first observation in ``obs[i]``, ``"TimeLimit.truncated"`` set for episodes cut
at the end of their case).  So PPO trains on thousands of sub-environments at once::

    from stable_baselines3 import PPO
    from vfs.gym.sb3 import AEBVecEnv

    env = AEBVecEnv(1024, split="train", action_repeat=10)
    PPO("MlpPolicy", env, n_steps=16, batch_size=4096).learn(200_000)

stable-baselines3 is an optional dependency (``pip install "vfs-accident[rl]"``); this module
imports it, the rest of vfs does not.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from vfs.gym.env import AEBVectorEnv

#: Per-episode keys copied into the info dict of a sub-environment whose episode ended.
_SKIP = ("case_id", "t")


class AEBVecEnv(VecEnv):
    """``num_envs`` AEB environments as one SB3 VecEnv (keyword arguments: EnvConfig fields).

    Parameters
    ----------
    num_envs : int
        Number of sub-environments.
    seed : int, optional
        Seed of the case draws (also settable by SB3's ``seed()`` before ``reset()``).
    **kwargs
        Settings of the environment (:class:`vfs.gym.config.EnvConfig`; dicts for nested
        settings).
    """

    def __init__(self, num_envs: int, seed: int | None = None, **kwargs: Any) -> None:
        self.venv = AEBVectorEnv(num_envs=num_envs, **kwargs)
        super().__init__(num_envs, self.venv.single_observation_space,
                         self.venv.single_action_space)
        self._seed = seed
        self._actions = np.zeros((num_envs, 1), np.float32)

    @property
    def config(self) -> Any:
        """The environment's settings (:class:`vfs.gym.config.EnvConfig`)."""
        return self.venv.config

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seed the case draws of the next ``reset()``."""
        self._seed = seed
        return [seed] * self.num_envs

    def reset(self) -> VecEnvObs:
        """Start an episode in every sub-environment; returns the observations (n, d)."""
        obs, info = self.venv.reset(seed=self._seed)
        self._seed = None
        self.reset_infos = [{"case_id": c} for c in info["case_id"].tolist()]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the actions (n, 1) of the next :meth:`step_wait`."""
        self._actions = np.asarray(actions, np.float32).reshape(self.num_envs, -1)

    def step_wait(self) -> VecEnvStepReturn:
        """One step of every sub-environment, with SB3's same-step autoreset."""
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(done)
        if ended.size:
            keys = [k for k in info if not k.startswith("_") and k not in _SKIP]
            case_ids = info["case_id"]
            for i in ended.tolist():  # only the ended ones: a few per step
                d = {k: (info[k][i].item() if hasattr(info[k][i], "item") else info[k][i])
                     for k in keys}
                d["case_id"] = case_ids[i].item() if hasattr(case_ids[i], "item") \
                    else case_ids[i]
                d["terminal_observation"] = obs[i].copy()
                d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                infos[i] = d
            obs = obs.copy()
            obs[ended] = self.venv.restart(ended)
        return obs, reward.astype(np.float32), done, infos

    def close(self) -> None:
        """Nothing to release (one process)."""

    def render(self, mode: str | None = None) -> Any:
        """Not drawn for the batched environment: use a single environment's render."""
        return None

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The attribute of the (shared) environment, once per index."""
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the shared environment."""
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """Call a method of the shared environment, once per index."""
        method = getattr(self.venv, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper],
                       indices: VecEnvIndices = None) -> list[bool]:
        """The sub-environments are not gymnasium-wrapped."""
        return [False for _ in self._get_indices(indices)]


__all__ = ["AEBVecEnv"]
