"""``vfs evaluate-policy``: a brake policy on a split of the cases, as a study + report."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

from vfs.cli.common import add_figure_options, add_input_option, out_folder, out_option


def cmd_evaluate_policy(args: argparse.Namespace) -> int:
    """``vfs evaluate-policy POLICY --db DIR --split test --out results/NAME``."""
    started = time.perf_counter()
    try:
        from vfs.gym.evaluate import evaluate_policy

        env_kwargs = _env_kwargs(args.env_kwargs)
        out_folder(args, "evaluate-policy", args.db)
        result = evaluate_policy(
            args.policy, args.db, args.out, split=args.split, test_share=args.test_share,
            split_seed=args.split_seed, where=args.where, ego=args.ego, engine=args.engine,
            workers=args.workers, seed=args.seed, resume=args.resume,
            overwrite=args.overwrite, n_boot=args.bootstrap, env_kwargs=env_kwargs)
    except KeyboardInterrupt:
        print(f"interrupted; continue with the same command and --resume ({args.out})",
              file=sys.stderr)
        return 130
    print(result.summary())
    if result.complete:
        from vfs.gym.evaluate import LEADERBOARD_FILE

        board = result.path / f"{LEADERBOARD_FILE}.md"
        if board.is_file():
            print(board.read_text(encoding="utf-8"), end="")
        print(f"report -> {result.path / 'report' / 'report.md'}, leaderboard -> {board} "
              f"({time.perf_counter() - started:.1f} s)")
    return 0


def _env_kwargs(text: str | None) -> dict[str, Any] | None:
    """``--env-kwargs``: a JSON object, or the path of a JSON file holding one."""
    from vfs.errors import ParameterError

    if not text:
        return None
    source = text
    if not text.lstrip().startswith("{"):
        path = Path(text)
        if not path.is_file():
            raise ParameterError(f"--env-kwargs {text!r}: neither a JSON object nor a file")
        source = path.read_text(encoding="utf-8")
    try:
        value = json.loads(source)
    except json.JSONDecodeError as exc:
        raise ParameterError(f"--env-kwargs: not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise ParameterError("--env-kwargs: expected a JSON object of environment settings")
    return value


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs evaluate-policy``."""
    p = subparsers.add_parser(
        "evaluate-policy", help="evaluate a brake policy on a split of the cases (study + "
        "effectiveness report)",
        description="Run POLICY on the ego vehicle of every case of the split, with the "
        "observation and brake actuator of the vfs/AEB-v0 environment, against the recorded "
        "baseline; writes a study folder, its effectiveness report with every POLICY side "
        "by side, and OUT/leaderboard.md|csv (crashes avoided, MAIS3+ risk and delta-v "
        "reduction with intervals, new crashes, braking in near misses). POLICY: "
        "never-brake, always-brake, aeb:NAME (a generic AEB system), sb3:PATH (a saved "
        "stable-baselines3 model; its training settings from PATH.vfs.json "
        "and observation normalisation from PATH.vecnormalize.pkl when present) or "
        "MODULE:ATTRIBUTE. The policy is asked every action_repeat simulation steps, as in "
        "training. See docs/gym.md.")
    add_figure_options(p)  # draws figures
    p.add_argument("policy", nargs="+",
                   help="never-brake | always-brake | aeb:NAME | sb3:PATH | MODULE:ATTRIBUTE "
                   "(several: one study, one report)")
    p.add_argument("--env-kwargs", metavar="JSON|FILE",
                   help='environment settings as in gymnasium.make, e.g. \'{"action_repeat": '
                   '10, "privileged": true, "sensor": {"range": 100}}\' (over those a saved '
                   'policy carries)')
    add_input_option(p, help="database folder or 'default'")  # reads a database
    from vfs.gym.config import EnvConfig, Split  # gymnasium: a dependency, loaded with vfs
    from vfs.study import EXECUTORS

    env_defaults = {f.name: f.default for f in dataclasses.fields(EnvConfig)}
    p.add_argument("--split", choices=[m.value for m in Split], default=Split.TEST.value,
                   help="cases of the environment's split (default test)")
    p.add_argument("--test-share", type=float, default=env_defaults["test_share"],
                   help=f"share of test cases (default {env_defaults['test_share']})")
    p.add_argument("--split-seed", type=int, default=env_defaults["split_seed"],
                   help=f"seed of the split (default {env_defaults['split_seed']})")
    p.add_argument("--where", help="SQL predicate on the cases table first")
    p.add_argument("--ego", type=int, choices=(1, 2), default=1,
                   help="participant braked by the policy (default 1)")
    out_option(p, "study folder", "evaluate-policy-<db>")
    p.add_argument("--engine", choices=EXECUTORS.names(), default="process",
                   help="executor (default process; serial for policies that cannot be pickled)")
    p.add_argument("--workers", type=int, help="parallel workers")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--bootstrap", type=int, default=2000,
                   help="bootstrap resamples of the report (default 2000)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true", help="continue an interrupted run")
    group.add_argument("--overwrite", action="store_true", help="replace --out")
    p.set_defaults(func=cmd_evaluate_policy)
