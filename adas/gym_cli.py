"""``vfs evaluate-policy``: a brake policy on a split of the cases, as a study + report."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from vfs.errors import ParameterError


def evaluate_policy(policy: str | Any, db: Any, out: str, *, split: str = "test",
                    test_share: float = 0.2, split_seed: int = 0, where: str | None = None,
                    ego: int = 1, engine: str = "process", workers: int | None = None,
                    seed: int = 0, resume: bool = False, overwrite: bool = False,
                    env_kwargs: dict[str, Any] | None = None, report: bool = True,
                    n_boot: int = 2000) -> Any:
    """Run ``policy`` (spec or object) on the cases of ``split`` as a study in ``out``.

    The baseline is the recorded behaviour; the treatment brakes vehicle
    ``ego`` with the policy through the environment's observation and brake
    actuator (:class:`adas.policies.PolicySystem`); an ``aeb:NAME`` policy
    runs that AEB system exactly as ``vfs study --equip EGO`` would.  With
    ``report`` the effectiveness report is written to ``out/report``.

    Returns
    -------
    vfs.study.StudyResult
    """
    from adas.gym_env import make_config, split_case_ids
    from adas.policies import PolicySystem, load_policy
    from adas.systems import AEBSystem
    from vfs.study import _load_selection, run_study

    obj = load_policy(policy) if isinstance(policy, str) else policy
    cfg = make_config(db=db, split=split, test_share=test_share, split_seed=split_seed,
                      where=where, ego=ego, **(env_kwargs or {}))
    database, _, _ = _load_selection(db, where)
    ids = split_case_ids(database.case_ids, split, test_share, split_seed)
    if ids.size == 0:
        raise ParameterError(f"no case in split {split!r}")
    system = obj if isinstance(obj, AEBSystem) else PolicySystem(obj, cfg)
    result = run_study(database.subset(ids), [system], out, engine=engine, workers=workers,
                       seed=seed, equip=str(ego), resume=resume, overwrite=overwrite,
                       impact_parameters=cfg.impact_parameters, params=cfg.simulation)
    if report and result.complete:
        from vfs.effectiveness import write_effectiveness_report

        write_effectiveness_report(out, n_boot=n_boot, seed=seed)
    return result


def cmd_evaluate_policy(args: argparse.Namespace) -> int:
    """``vfs evaluate-policy POLICY --db DIR --split test --out results/NAME``."""
    started = time.perf_counter()
    try:
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
