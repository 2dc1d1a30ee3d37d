"""Train a PPO brake policy on the train split of the bundled database; evaluate on the test split.

The recipe of docs/gym.md, "Training" (stable-baselines3, ``pip install "vfs[rl]"``):

- the native batched environment through the SB3 adapter (:class:`vfs.gym.sb3.AEBVecEnv`,
  many sub-environments in one process), action repeat 10 (one decision every 0.1 s),
- observation normalisation (``VecNormalize``, rewards left as they are: they are already
  risks of order 1),
- PPO with discount 0.99 per decision (a horizon of about 10 s), short rollouts over many
  sub-environments, a wall-time budget,
- the model, its normalisation statistics and its environment settings saved together, so
  that ``vfs evaluate-policy sb3:PATH`` evaluates exactly what was trained.

Usage::

    python examples/train_ppo.py --minutes 15 --out results/ppo
    vfs evaluate-policy sb3:results/ppo/model aeb:three-stage never-brake always-brake \\
        --db default --split test --out results/ppo-eval --overwrite

The script writes ``learning_curve.csv`` (mean episode reward and crash share per rollout)
and, with ``--evaluate``, runs that evaluation itself.
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np

#: Environment settings of the recipe (saved beside the model).
ENV_KWARGS = {"db": "default", "split": "train", "action_repeat": 10}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=15.0, help="training wall-time budget")
    ap.add_argument("--steps", type=int, default=5_000_000, help="at most this many steps")
    ap.add_argument("--envs", type=int, default=256, help="sub-environments")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="results/ppo")
    ap.add_argument("--evaluate", action="store_true", help="evaluate on the test split")
    ap.add_argument("--env-kwargs", default="{}",
                    help='further environment settings as JSON, e.g. \'{"reward": '
                    '{"unnecessary_brake_weight": 1.0}}\'')
    args = ap.parse_args()
    extra = json.loads(args.env_kwargs)

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from vfs.gym.policies import SB3_NORMALIZE_SUFFIX, SB3_SETTINGS_SUFFIX
    from vfs.gym.sb3 import AEBVecEnv

    torch.set_num_threads(1)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    env = VecNormalize(VecMonitor(AEBVecEnv(args.envs, seed=args.seed,
                                            **{**ENV_KWARGS, **extra})),
                       norm_obs=True, norm_reward=False, clip_obs=10.0)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=2048, n_epochs=5,
                learning_rate=3e-4, gamma=0.99, gae_lambda=0.95, ent_coef=0.0,
                clip_range=0.2, policy_kwargs={"net_arch": [64, 64]}, seed=args.seed,
                device="cpu", verbose=0)

    started = time.perf_counter()
    curve: list[dict[str, float]] = []

    class Budget(BaseCallback):
        def _on_step(self) -> bool:
            return time.perf_counter() - started < 60.0 * args.minutes

        def _on_rollout_end(self) -> None:
            eps = [e for e in self.model.ep_info_buffer]
            crashes = [i.get("collided", np.nan) for i in self.locals.get("infos", [])
                       if "collided" in i]
            curve.append({"steps": self.num_timesteps,
                          "seconds": round(time.perf_counter() - started, 1),
                          "mean_episode_reward": float(np.mean([e["r"] for e in eps]))
                          if eps else float("nan"),
                          "crash_share_last_step": float(np.mean(crashes))
                          if crashes else float("nan")})

    model.learn(total_timesteps=args.steps, callback=Budget())
    seconds = time.perf_counter() - started
    model.save(out / "model")
    env.save(str(out / "model") + SB3_NORMALIZE_SUFFIX)
    settings = {"env_kwargs": {"action_repeat": ENV_KWARGS["action_repeat"], **extra},
                "trained": {"steps": int(model.num_timesteps), "seconds": round(seconds, 1),
                            "steps_per_s": round(model.num_timesteps / seconds),
                            "envs": args.envs, "seed": args.seed, "split": "train"}}
    (out / ("model" + SB3_SETTINGS_SUFFIX)).write_text(json.dumps(settings, indent=2))
    with open(out / "learning_curve.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(curve[0]) if curve else ["steps"])
        w.writeheader()
        w.writerows(curve)
    print(f"{model.num_timesteps} steps in {seconds:.0f} s "
          f"({model.num_timesteps / seconds:.0f} steps/s) -> {out / 'model.zip'}")
    if args.evaluate:
        from vfs.gym.evaluate import evaluate_policy

        result = evaluate_policy(
            [f"sb3:{out / 'model'}", "aeb:three-stage", "never-brake", "always-brake"],
            "default", str(out / "evaluation"), split="test", overwrite=True)
        print(result.summary())


if __name__ == "__main__":
    main()
