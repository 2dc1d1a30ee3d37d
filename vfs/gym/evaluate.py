"""A brake policy on a split of the cases, evaluated as a study with its effectiveness report."""

from __future__ import annotations

import os
from typing import Any

from vfs.adas.systems import AEBSystem
from vfs.database import Database, open_database
from vfs.errors import ParameterError
from vfs.gym.env import make_config, split_case_ids
from vfs.gym.policies import PolicySystem, load_policy
from vfs.report.effectiveness import write_effectiveness_report
from vfs.study import StudyResult, run_study


def evaluate_policy(policy: str | Any, db: str | os.PathLike[str] | Database, out: str, *,
                    split: str = "test", test_share: float = 0.2, split_seed: int = 0,
                    where: str | None = None, ego: int = 1, engine: str = "process",
                    workers: int | None = None, seed: int = 0, resume: bool = False,
                    overwrite: bool = False, env_kwargs: dict[str, Any] | None = None,
                    report: bool = True, n_boot: int = 2000) -> StudyResult:
    """Run ``policy`` (spec or object) on the cases of ``split`` as a study in ``out``.

    The baseline is the recorded behaviour; the treatment brakes vehicle
    ``ego`` with the policy through the environment's observation and brake
    actuator (:class:`vfs.gym.policies.PolicySystem`); an ``aeb:NAME`` policy
    runs that AEB system exactly as ``vfs study --equip EGO`` would.  With
    ``report`` the effectiveness report is written to ``out/report``.

    Returns
    -------
    StudyResult
    """
    obj = load_policy(policy) if isinstance(policy, str) else policy
    cfg = make_config(db=db, split=split, test_share=test_share, split_seed=split_seed,
                      where=where, ego=ego, **(env_kwargs or {}))
    database = open_database(db, where)
    ids = split_case_ids(database.case_ids, split, test_share, split_seed)
    if ids.size == 0:
        raise ParameterError(f"no case in split {split!r}")
    system = obj if isinstance(obj, AEBSystem) else PolicySystem(obj, cfg)
    result = run_study(database.subset(ids), [system], out, engine=engine, workers=workers,
                       seed=seed, equip=str(ego), resume=resume, overwrite=overwrite,
                       impact_parameters=cfg.impact_parameters, params=cfg.simulation)
    if report and result.complete:
        write_effectiveness_report(out, n_boot=n_boot, seed=seed)
    return result


__all__ = ["evaluate_policy"]
