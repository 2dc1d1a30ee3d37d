"""The fast paths of the gym environments equal their numpy reference bit for bit.

The sensor observation runs in a compiled kernel (:func:`vfs.gym.compiled.sensor_kernel`)
that repeats :func:`vfs.gym.observation.observe_reference` operation by operation in
float32 (the gap and TTC in float64, as there); numpy computes every cos, sin and arctan2
for both, so nothing but the order of evaluation could differ, and it does not.  Two
checks that can fail on any difference in any bit (float32 words compared as integers,
so that -0.0 and 0.0 or two NaN payloads differ):

- ``observe`` and ``observe_reference`` on the same simulation states, along whole
  episodes of generated cases of every accident type, for several sensors (a mounting
  yaw, a narrow and an all-around field of view, a short range that leaves many objects
  at the edge of the exact test), both egos, with and without friction;
- whole episodes of the single and the vector environment with ``VFS_COMPILED=0`` (the
  numpy pre-crash step and observation) and with the compiled paths: observations,
  rewards, terminations, truncations and the episode outcome in ``info``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest

from tests.generated import bit_differences
from vfs.adas.params import SensorParams
from vfs.gym.env import AEBEnv, AEBVectorEnv, clear_shared_cases
from vfs.gym.observation import observe, observe_reference
from vfs.physics import numba_support
from vfs.scenarios.generator import generate_database, get_preset
from vfs.scenarios.scenes import SCENARIO_TYPES

pytestmark = pytest.mark.skipif(not numba_support.AVAILABLE, reason="numba not installed")


@pytest.fixture(scope="module")
def generated_db() -> Any:
    """Three generated cases of every accident type, a third of them near misses."""
    preset = dataclasses.replace(get_preset("default"),
                                 type_shares={code: 1.0 for code in SCENARIO_TYPES},
                                 near_miss_share=0.3, hidden=())
    db, _ = generate_database(preset, n_cases=3 * len(SCENARIO_TYPES), seed=11)
    return db


SENSORS = {
    "default": None,
    "mounted_yaw": SensorParams(range=60.0, field_of_view=0.6, mount_x=-0.5, mount_y=0.4,
                                mount_yaw=0.2),
    "all_around": SensorParams(range=30.0, field_of_view=2.0 * math.pi),
    "short": SensorParams(range=20.0, field_of_view=0.8),
}


def _words(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


@pytest.mark.parametrize("sensor", list(SENSORS))
@pytest.mark.parametrize("ego", [1, 2])
def test_observe_equals_reference_along_episodes(generated_db: Any, sensor: str,
                                                 ego: int) -> None:
    kwargs: dict[str, Any] = {"db": generated_db, "split": "all", "ego": ego,
                              "observe_friction": ego == 1}
    if SENSORS[sensor] is not None:
        kwargs["sensor"] = SENSORS[sensor]
    venv = AEBVectorEnv(num_envs=24, **kwargs)
    venv.reset(seed=ego)
    core = venv.core
    rng = np.random.default_rng(5)
    seen = 0
    for _ in range(250):
        brake = rng.uniform(0.0, 1.0, (24, 1)) * (rng.uniform(size=(24, 1)) < 0.2)
        venv.step(brake)
        p = core.run.observation()
        fast = observe(p, core.dims, core.config)
        ref = observe_reference(p, core.dims, core.config)
        assert fast.dtype == ref.dtype and fast.shape == ref.shape
        np.testing.assert_array_equal(_words(fast), _words(ref))
        seen += int(ref[:, 2].sum())
    # the object was in view, so that the gap, relative motion and TTC were compared (the
    # narrow sensors of participant 2 face away from the object in these cases)
    assert seen > 0 or (ego == 2 and sensor in ("mounted_yaw", "short"))


def _single_episodes(kwargs: dict[str, Any], episodes: int) -> list[Any]:
    env = AEBEnv(**kwargs)
    rng = np.random.default_rng(2)
    trace: list[Any] = []
    obs, info = env.reset(seed=4)
    trace.append((_words(obs), info))
    for _ in range(episodes):
        done = False
        while not done:
            act = np.array([rng.uniform(0.0, 1.0) if rng.uniform() < 0.3 else 0.0])
            obs, reward, term, trunc, info = env.step(act)
            trace.append((_words(obs), reward, term, trunc, info))
            done = term or trunc
        obs, info = env.reset()
        trace.append((_words(obs), info))
    return trace


def _vector_steps(kwargs: dict[str, Any], n: int, steps: int) -> list[Any]:
    venv = AEBVectorEnv(num_envs=n, **kwargs)
    rng = np.random.default_rng(3)
    obs, info = venv.reset(seed=6)
    trace: list[Any] = [(_words(obs), info)]
    for _ in range(steps):
        act = rng.uniform(0.0, 1.0, (n, 1)) * (rng.uniform(size=(n, 1)) < 0.3)
        obs, reward, term, trunc, info = venv.step(act)
        trace.append((_words(obs), reward, term, trunc, info))
    return trace


def _differences(ref: list[Any], got: list[Any]) -> list[str]:
    assert len(ref) == len(got)
    out = []
    for k, (a, b) in enumerate(zip(ref, got, strict=True)):
        for j, (x, y) in enumerate(zip(a, b, strict=True)):
            if isinstance(x, dict):
                assert x.keys() == y.keys()
                for key in x:
                    xv, yv = np.asarray(x[key]), np.asarray(y[key])
                    if xv.dtype == object:
                        if xv.tolist() != yv.tolist():
                            out.append(f"step {k} info {key}")
                    else:
                        out += [f"step {k} info {key}" for _ in bit_differences(xv, yv)]
            else:
                out += [f"step {k} item {j}" for _ in bit_differences(x, y)]
    return out


@pytest.mark.parametrize("ego", [1, 2])
def test_environments_equal_reference_path(generated_db: Any, ego: int,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    kwargs = {"db": generated_db, "split": "all", "ego": ego, "sensor": SENSORS["mounted_yaw"]}
    runs = []
    for switch in ("0", "1"):
        monkeypatch.setenv(numba_support.ENV_SWITCH, switch)
        clear_shared_cases()  # the replay of the records on the same path as the steps
        runs.append((_single_episodes(kwargs, 6), _vector_steps(kwargs, 16, 300)))
    (single_ref, vector_ref), (single_fast, vector_fast) = runs
    ended = sum(1 for s in single_ref if len(s) == 5 and (s[2] or s[3]))
    assert ended == 6
    assert any(s[2] for s in single_ref[1:] if len(s) == 5)  # a collision was compared
    assert _differences(single_ref, single_fast) == []
    assert _differences(vector_ref, vector_fast) == []
