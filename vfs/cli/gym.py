"""``vfs evaluate-policy``: a brake policy on a split of the cases, as a study + report."""

from __future__ import annotations

import argparse
import sys
import time


def cmd_evaluate_policy(args: argparse.Namespace) -> int:
    """``vfs evaluate-policy POLICY --db DIR --split test --out results/NAME``."""
    started = time.perf_counter()
    try:
        from vfs.gym.evaluate import evaluate_policy

        result = evaluate_policy(
            args.policy, args.db, args.out, split=args.split, test_share=args.test_share,
            split_seed=args.split_seed, where=args.where, ego=args.ego, engine=args.engine,
            workers=args.workers, seed=args.seed, resume=args.resume,
            overwrite=args.overwrite, n_boot=args.bootstrap)
    except KeyboardInterrupt:
        print(f"interrupted; continue with the same command and --resume ({args.out})",
              file=sys.stderr)
        return 130
    print(result.summary())
    if result.complete:
        print(f"report -> {result.path / 'report' / 'report.md'} "
              f"({time.perf_counter() - started:.1f} s)")
    return 0


def add_parsers(subparsers: argparse._SubParsersAction) -> None:
    """Add ``vfs evaluate-policy``."""
    p = subparsers.add_parser(
        "evaluate-policy", help="evaluate a brake policy on a split of the cases (study + "
        "effectiveness report)",
        description="Run POLICY on the ego vehicle of every case of the split, with the "
        "observation and brake actuator of the vfs/AEB-v0 environment, against the recorded "
        "baseline; writes a study folder and its effectiveness report. POLICY: never-brake, "
        "always-brake, aeb:NAME (a generic AEB system) or MODULE:ATTRIBUTE. See docs/gym.md.")
    p.add_argument("policy", help="never-brake | always-brake | aeb:NAME | MODULE:ATTRIBUTE")
    p.add_argument("--db", required=True, help="database folder or 'default'")
    p.add_argument("--split", choices=("train", "test", "all"), default="test",
                   help="cases of the environment's split (default test)")
    p.add_argument("--test-share", type=float, default=0.2,
                   help="share of test cases (default 0.2)")
    p.add_argument("--split-seed", type=int, default=0, help="seed of the split (default 0)")
    p.add_argument("--where", help="SQL predicate on the cases table first")
    p.add_argument("--ego", type=int, choices=(1, 2), default=1,
                   help="participant braked by the policy (default 1)")
    p.add_argument("--out", required=True, help="study folder, e.g. results/NAME")
    p.add_argument("--engine", choices=("serial", "process", "dask"), default="process",
                   help="executor (serial for policies that cannot be pickled)")
    p.add_argument("--workers", type=int, help="parallel workers")
    p.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    p.add_argument("--bootstrap", type=int, default=2000,
                   help="bootstrap resamples of the report (default 2000)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true", help="continue an interrupted run")
    group.add_argument("--overwrite", action="store_true", help="replace --out")
    p.set_defaults(func=cmd_evaluate_policy)
