"""Brake policies on a split of the cases, evaluated as one study with its effectiveness report."""

from __future__ import annotations

import os
import pickle
from collections.abc import Sequence
from typing import Any

from vfs.adas.systems import AEBSystem
from vfs.database import Database, open_database
from vfs.errors import ParameterError
from vfs.gym.config import make_config
from vfs.gym.env import split_case_ids
from vfs.gym.policies import PolicySystem, load_policy
from vfs.report.effectiveness import write_effectiveness_report
from vfs.study import StudyResult, run_study


def _picklable(obj: Any) -> bool:
    try:
        pickle.dumps(obj)
    except Exception:  # noqa: BLE001 - any failure means: not for worker processes
        return False
    return True


def evaluate_policy(policy: str | Any | Sequence[str | Any],
                    db: str | os.PathLike[str] | Database, out: str, *,
                    split: str = "test", test_share: float = 0.2, split_seed: int = 0,
                    where: str | None = None, ego: int = 1, engine: str = "process",
                    workers: int | None = None, seed: int = 0, resume: bool = False,
                    overwrite: bool = False, env_kwargs: dict[str, Any] | None = None,
                    report: bool = True, n_boot: int = 2000) -> StudyResult:
    """Run one or several policies on the cases of ``split`` as one study in ``out``.

    The baseline is the recorded behaviour; each treatment brakes vehicle
    ``ego`` with a policy through the environment's observation, brake actuator
    and action repeat (:class:`vfs.gym.policies.PolicySystem`: the policy is asked
    every ``action_repeat`` simulation steps, as in training); an ``aeb:NAME``
    policy runs that AEB system exactly as ``vfs study --equip EGO`` would.  The
    environment settings are ``env_kwargs`` over those a policy carries
    (``SB3Policy.env_kwargs``: what it was trained with); policies with different
    settings are evaluated each with its own.  With ``report`` the effectiveness
    report (all policies side by side) is written to ``out/report``.

    Returns
    -------
    StudyResult
    """
    specs = [policy] if isinstance(policy, str) or not isinstance(policy, Sequence) \
        else list(policy)
    if not specs:
        raise ParameterError("evaluate_policy: no policy given")
    database = open_database(db, where)
    ids = split_case_ids(database.case_ids, split, test_share, split_seed)
    if ids.size == 0:
        raise ParameterError(f"no case in split {split!r}")
    systems: list[Any] = []
    base_cfg = None
    for spec in specs:
        obj = load_policy(spec) if isinstance(spec, str) else spec
        kwargs = {**getattr(obj, "env_kwargs", {}), **(env_kwargs or {})}
        cfg = make_config(db=db, split=split, test_share=test_share, split_seed=split_seed,
                          where=where, ego=ego, **kwargs)
        if base_cfg is None:
            base_cfg = cfg
        elif (cfg.simulation, cfg.impact_parameters) != (base_cfg.simulation,
                                                         base_cfg.impact_parameters):
            raise ParameterError("evaluate_policy: the policies need different simulation "
                                 "settings; evaluate them in separate studies")
        systems.append(obj if isinstance(obj, AEBSystem) else PolicySystem(obj, cfg))
    names = [s.name for s in systems]
    if len(set(names)) != len(names):
        raise ParameterError(f"evaluate_policy: policy names repeat: {names}")
    if engine == "process" and not all(_picklable(s) for s in systems):
        engine = "serial"  # e.g. a torch model: run in this process
    if base_cfg is None:  # pragma: no cover - specs is not empty
        raise ParameterError("evaluate_policy: no policy given")
    result = run_study(database.subset(ids), systems, out, engine=engine, workers=workers,
                       seed=seed, equip=str(ego), resume=resume, overwrite=overwrite,
                       impact_parameters=base_cfg.impact_parameters,
                       params=base_cfg.simulation)
    if report and result.complete:
        # no case pages: the policies are not registered systems a replay could look up
        write_effectiveness_report(out, n_boot=n_boot, seed=seed, case_pages=False)
    return result


__all__ = ["evaluate_policy"]
