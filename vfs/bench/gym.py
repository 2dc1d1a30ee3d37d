"""Benchmark of the AEB gymnasium environments (steps per second)."""

from __future__ import annotations

from typing import Any

import numpy as np


def _steps_per_second(step: Any, reset: Any, seconds: float,
                      warmup: int = 0) -> tuple[float, float]:
    """(steps/s of wall time, steps/s of CPU time) of ``step()`` calls over about ``seconds``
    after ``warmup`` steps (the CPU figure is the fairer one on a shared machine).
    """
    import time

    reset()
    for _ in range(warmup):
        step()
    n = 0
    t0, c0 = time.perf_counter(), time.process_time()
    while True:
        step()
        n += 1
        if n % 16 == 0 and time.perf_counter() - t0 >= seconds:
            break
    return n / (time.perf_counter() - t0), n / max(time.process_time() - c0, 1e-9)


def bench_gym_env(quick: bool) -> dict[str, Any]:
    """Environment steps/s: single env, gymnasium SyncVectorEnv, the native vector env at
    several sizes (after a warm-up of 700 steps, so that episodes end and restart at their
    steady rate), and highway-env's highway-fast-v0 if it is installed.  ``*_per_cpu_s``:
    the same per second of the process's CPU time.  ``observation_gap``: "compiled" where
    the observation's gap runs in the compiled kernel (:mod:`vfs.gym.compiled`).
    """
    import gymnasium as gym

    from vfs.gym.env import AEBEnv, AEBVectorEnv
    from vfs.physics.numba_support import enabled
    from vfs.simulation import SimulationParams

    seconds = 2.0 if quick else 5.0
    out: dict[str, Any] = {"dt_s": SimulationParams().precrash.dt,
                           "policy": "never-brake (action 0)",
                           "observation_gap": "compiled" if enabled() else "numpy"}
    env = AEBEnv(split="all")
    state = {"done": True}

    def single_step() -> None:
        if state["done"]:
            env.reset()
        _, _, term, trunc, _ = env.step(np.zeros(1))
        state["done"] = term or trunc

    env.reset(seed=0)
    # the first steps load the compiled pre-crash step (vfs.physics.core) from numba's cache
    rate, cpu = _steps_per_second(single_step, lambda: env.reset(seed=0), seconds, warmup=50)
    out["single_steps_per_s"] = rate
    out["single_steps_per_cpu_s"] = cpu
    out["single_simulated_s_per_s"] = rate * env.config.action_repeat * SimulationParams(
    ).precrash.dt
    sync = gym.vector.SyncVectorEnv([lambda: AEBEnv(split="all") for _ in range(8)])
    a8 = np.zeros((8, 1))
    rate, _ = _steps_per_second(lambda: sync.step(a8), lambda: sync.reset(seed=0), seconds)
    out["sync_vector_8_steps_per_s"] = rate * 8
    sizes = (1024, 4096) if quick else (1024, 8192, 32768)
    for n in sizes:
        venv = AEBVectorEnv(num_envs=n, split="all")
        acts = np.zeros((n, 1))
        rate, cpu = _steps_per_second(lambda v=venv, a=acts: v.step(a),
                                      lambda v=venv: v.reset(seed=0), seconds,
                                      warmup=100 if quick else 700)
        out[f"vector_{n}_steps_per_s"] = rate * n
        out[f"vector_{n}_steps_per_cpu_s"] = cpu * n
    try:
        import highway_env  # noqa: F401
    except ImportError:
        out["highway_fast_v0_steps_per_s"] = "not installed (pip install highway-env)"
    else:
        hw = gym.make("highway-fast-v0")
        hw.reset(seed=0)
        hstate = {"done": False}

        def hw_step() -> None:
            if hstate["done"]:
                hw.reset()
            _, _, term, trunc, _ = hw.step(hw.action_space.sample())
            hstate["done"] = term or trunc

        rate, _ = _steps_per_second(hw_step, lambda: hw.reset(seed=0), seconds)
        out["highway_fast_v0_steps_per_s"] = rate
        out["single_vs_highway_fast"] = out["single_steps_per_s"] / rate
    return out
