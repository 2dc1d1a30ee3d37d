"""Train a PPO brake policy on the train split of the bundled database; evaluate on the test split.

The recipe of docs/gym.md, "Training" (stable-baselines3, ``pip install -e ".[rl]"`` in a clone):

- the native batched environment through the SB3 adapter (:class:`vfs.gym.sb3.AEBVecEnv`,
  many sub-environments in one process), action repeat 10 (one decision every 0.1 s),
- the sensor view with the threat entries (``threat_features``: yaw rates, the
  constant-velocity miss distance, the constant-turn-rate TTC of the outlines), normalised
  by ``VecNormalize`` (rewards left as they are: they are already risks of order 1),
- near misses drawn more often (``near_miss_weight``), unnecessary braking priced
  higher (``reward.unnecessary_brake_weight``) and braking at all in a near miss priced
  once (``reward.false_activation_weight``), so that the policy learns where braking is
  not needed; a small cost of any collision (``reward.collision_weight``).  These
  settings were chosen on a validation share of the train split (docs/gym.md,
  "Training"),
- PPO with discount 0.99 per decision (a horizon of about 10 s), short rollouts over many
  sub-environments, a budget of CPU time on one core (``torch.set_num_threads(1)``),
- the model, its normalisation statistics and its environment settings saved together, so
  that ``vfs evaluate-policy sb3:PATH`` evaluates exactly what was trained.

Usage::

    nice -n 10 python examples/train_ppo.py --out results/ppo
    vfs evaluate-policy sb3:results/ppo/model aeb:three-stage never-brake always-brake \\
        --db default --split test --out results/ppo-eval --overwrite

``--validation 0.2`` holds out a seeded fifth of the train split (trains on the rest, and
``--evaluate`` then evaluates on the held-out cases instead of the test split): the way the
recipe's settings were chosen without looking at the test split.

The script writes ``learning_curve.csv`` and ``learning_curve.png`` (per rollout: mean
episode reward, the share of recorded crashes still crashing, the share of near misses in
which the policy braked) and, with ``--evaluate``, runs the evaluation itself.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core: no BLAS thread pools

import argparse  # noqa: E402
import csv  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import shlex  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

#: Environment settings of the recipe (saved beside the model, except the case selection).
ENV_KWARGS: dict[str, Any] = {
    "action_repeat": 10,
    "threat_features": True,
    "near_miss_weight": 4.0,
    "reward": {"unnecessary_brake_weight": 0.5, "false_activation_weight": 2.0,
               "collision_weight": 0.3},
}
#: PPO settings of the recipe.
PPO_KWARGS: dict[str, Any] = {
    "n_steps": 32, "batch_size": 2048, "n_epochs": 5, "learning_rate": 3e-4, "gamma": 0.99,
    "gae_lambda": 0.95, "ent_coef": 0.0, "clip_range": 0.2,
}
#: Settings that select cases (not saved with the model: evaluation picks its own cases).
_SELECTION = ("db", "split", "where", "test_share", "split_seed")


def cpu_seconds() -> float:
    """CPU time [s] (user + system) of this process and its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    """``base`` updated by ``extra``, nested dicts merged key by key."""
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def case_selection(validation: float, seed: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """Environment settings of the training cases and of the evaluation cases.

    Without ``validation``: the train split, and the test split.  With it: the train
    split less a share ``validation`` of it (drawn with ``seed``), and that share.
    """
    if validation <= 0.0:
        return {"db": "default", "split": "train"}, {"split": "test", "where": None}
    from vfs.database import open_database
    from vfs.gym.env import split_case_ids

    train = split_case_ids(open_database("default").case_ids, "train")
    held = split_case_ids(train, "test", validation, seed)
    fit = np.setdiff1d(train, held)

    def where(ids: np.ndarray) -> str:
        return f"case_id IN ({', '.join(str(int(i)) for i in ids)})"

    return ({"db": "default", "split": "all", "where": where(fit)},
            {"split": "all", "where": where(held)})


def plot_curve(curve: list[dict[str, float]], path: Path) -> None:
    """The learning curve (three panels over the training steps) as a PNG."""
    from vfs.report.figures import new_figure, save_figure

    fig = new_figure((12.0, 3.4), layout="constrained")
    axes = fig.subplots(1, 3)
    steps = np.array([c["steps"] for c in curve]) / 1e6
    panels = (("mean_episode_reward", "mean episode reward"),
              ("crash_share", "recorded crashes still crashing"),
              ("near_miss_brake_share", "near misses braked in"))
    for ax, (key, label) in zip(axes, panels, strict=True):
        ax.plot(steps, [c[key] for c in curve], lw=1.2)
        ax.set_xlabel("training steps [million]")
        ax.set_title(label, fontsize=10)
        ax.grid(alpha=0.3)
    save_figure(fig, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cpu-minutes", type=float, default=14.0,
                    help="training budget in CPU minutes of this process (one core)")
    ap.add_argument("--steps", type=int, default=20_000_000, help="at most this many steps")
    ap.add_argument("--envs", type=int, default=256, help="sub-environments")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--net", default="64,64", help="hidden layer sizes of policy and value")
    ap.add_argument("--log-std-init", type=float, default=0.0,
                    help="initial log standard deviation of the Gaussian actions")
    ap.add_argument("--ppo-kwargs", default="{}", help="PPO settings over PPO_KWARGS (JSON)")
    ap.add_argument("--validation", type=float, default=0.0,
                    help="hold out this share of the train split (choosing settings)")
    ap.add_argument("--validation-seed", type=int, default=1)
    ap.add_argument("--passes", type=int, default=0,
                    help="add this many generated passes without a conflict to the training "
                    "cases (vfs.gym.benchmark.with_passes; the benchmark evaluates others)")
    ap.add_argument("--passes-seed", type=int, default=2,
                    help="seed of the generated training passes (the benchmark's is 1)")
    ap.add_argument("--wall-minutes", type=float, default=float("inf"),
                    help="also stop after this many wall-clock minutes (a loaded machine)")
    ap.add_argument("--out", default="results/ppo")
    ap.add_argument("--evaluate", action="store_true",
                    help="evaluate on the test split (on the held-out cases with --validation)")
    ap.add_argument("--env-kwargs", default="{}",
                    help='environment settings over ENV_KWARGS as JSON, e.g. \'{"reward": '
                    '{"unnecessary_brake_weight": 1.0}}\'')
    args = ap.parse_args()
    started_cpu, started = cpu_seconds(), time.perf_counter()
    env_kwargs = deep_merge(ENV_KWARGS, json.loads(args.env_kwargs))
    ppo_kwargs = {**PPO_KWARGS, **json.loads(args.ppo_kwargs)}
    train_cases, eval_cases = case_selection(args.validation, args.validation_seed)
    if args.passes > 0:
        from vfs.database import open_database
        from vfs.gym.benchmark import PASSING_SEED, with_passes
        from vfs.gym.env import split_case_ids

        if args.passes_seed == PASSING_SEED:
            ap.error(f"--passes-seed {PASSING_SEED} is the benchmark's own passes")
        base = open_database("default", train_cases.get("where"))
        ids = split_case_ids(base.case_ids, train_cases["split"])
        train_cases = {"db": with_passes(base.subset(ids), args.passes, args.passes_seed),
                       "split": "all"}

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
                                            **{**env_kwargs, **train_cases})),
                       norm_obs=True, norm_reward=False, clip_obs=10.0)
    net = [int(n) for n in args.net.split(",")]
    model = PPO("MlpPolicy", env, policy_kwargs={"net_arch": net,
                                                 "log_std_init": args.log_std_init},
                seed=args.seed, device="cpu", verbose=0, **ppo_kwargs)
    budget = 60.0 * args.cpu_minutes
    curve: list[dict[str, float]] = []

    class Budget(BaseCallback):
        """Stops at the CPU budget; records the learning curve per rollout."""

        def _init_callback(self) -> None:
            self.ended: list[tuple[bool, bool, bool]] = []

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", []):
                if "recorded_collision" in info:
                    self.ended.append((bool(info["recorded_collision"]),
                                       bool(info["collided"]),
                                       bool(np.isfinite(info["brake_start"]))))
            return (cpu_seconds() - started_cpu < budget
                    and time.perf_counter() - started < 60.0 * args.wall_minutes)

        def _on_rollout_end(self) -> None:
            eps = list(self.model.ep_info_buffer)
            e = np.array(self.ended, dtype=bool).reshape(-1, 3)
            crash, near = e[e[:, 0]], e[~e[:, 0]]
            curve.append({
                "steps": self.num_timesteps,
                "cpu_seconds": round(cpu_seconds() - started_cpu, 1),
                "mean_episode_reward": float(np.mean([x["r"] for x in eps]))
                if eps else float("nan"),
                "crash_share": float(crash[:, 1].mean()) if crash.size else float("nan"),
                "near_miss_brake_share": float(near[:, 2].mean()) if near.size
                else float("nan"),
                "episodes": int(e.shape[0])})
            self.ended = []

    model.learn(total_timesteps=args.steps, callback=Budget())
    cpu = cpu_seconds() - started_cpu
    seconds = time.perf_counter() - started
    model.save(out / "model")
    env.save(str(out / "model") + SB3_NORMALIZE_SUFFIX)
    saved = {k: v for k, v in env_kwargs.items() if k not in _SELECTION}
    settings = {"env_kwargs": saved,
                "trained": {"steps": int(model.num_timesteps), "cpu_seconds": round(cpu, 1),
                            "wall_seconds": round(seconds, 1),
                            "steps_per_cpu_s": round(model.num_timesteps / cpu),
                            "envs": args.envs, "seed": args.seed, "net": net,
                            "log_std_init": args.log_std_init, "ppo": ppo_kwargs,
                            "cases": ("train split" if args.validation <= 0 else
                                      f"train split less a {args.validation} validation share "
                                      f"(seed {args.validation_seed})")
                            + (f" + {args.passes} generated passes (seed {args.passes_seed})"
                               if args.passes > 0 else ""),
                            "command": "python examples/train_ppo.py "
                            + " ".join(shlex.quote(a) for a in sys.argv[1:])}}
    (out / ("model" + SB3_SETTINGS_SUFFIX)).write_text(json.dumps(settings, indent=2))
    with open(out / "learning_curve.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(curve[0]) if curve else ["steps"])
        w.writeheader()
        w.writerows(curve)
    if curve:
        plot_curve(curve, out / "learning_curve.png")
    print(f"{model.num_timesteps} steps in {cpu:.0f} CPU s ({seconds:.0f} s wall, "
          f"{model.num_timesteps / cpu:.0f} steps per CPU s) -> {out / 'model.zip'}")
    if args.evaluate:
        from vfs.gym.evaluate import evaluate_policy

        result = evaluate_policy(
            [f"sb3:{out / 'model'}", "aeb:three-stage", "never-brake", "always-brake"],
            "default", str(out / "evaluation"), overwrite=True, engine="serial",
            **eval_cases)
        print(result.summary())


if __name__ == "__main__":
    main()
