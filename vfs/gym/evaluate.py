"""Brake policies on a split of the cases, evaluated as one study with its effectiveness report."""

from __future__ import annotations

import os
import pickle
from collections.abc import Sequence
from typing import Any

import numpy as np

from vfs.adas.definition import AEBSystem
from vfs.database import Database, open_database
from vfs.errors import ParameterError
from vfs.gym.benchmark import ComfortSystem, benchmark_measures
from vfs.gym.config import make_config
from vfs.gym.env import split_case_ids
from vfs.gym.policies import PolicySystem, load_policy
from vfs.report.effectiveness import write_effectiveness_report
from vfs.study import StudyResult, run_study
from vfs.units import KMH_PER_MS

#: File of the leaderboard table in an evaluation folder (``.csv`` and ``.md``).
LEADERBOARD_FILE = "leaderboard"


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
    settings are evaluated each with its own.  Every system runs as a
    :class:`vfs.gym.benchmark.ComfortSystem` (same runs; its braking and comfort recorded
    in ``runs.parquet``).  With ``report`` the effectiveness report (all policies side by
    side) is written to ``out/report``, and the leaderboard (:func:`leaderboard`) to
    ``out/leaderboard.csv|md``.

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
        systems.append(ComfortSystem(obj if isinstance(obj, AEBSystem)
                                     else PolicySystem(obj, cfg)))
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
        write_leaderboard(out, ego)
    return result


def leaderboard(out: str | os.PathLike[str], ego: int = 1) -> Any:
    """The leaderboard of an evaluation folder (docs/gym.md), one row per policy.

    Columns: crashes avoided (share of the baseline crashes), MAIS3+ risk reduction
    (relative reduction of the expected MAIS3+ injured drivers) and delta-v reduction
    per baseline crash [km/h], each with its interval from the effectiveness report
    (``OUT/report/metrics.csv``: Wilson for the share, bootstrap for the others); new
    crashes; ``near_miss_brakes``: in how many of the near misses (cases without a
    crash in the baseline) the ego brakes at all (any delivered deceleration of the
    system's brake), of ``near_misses``; and the measures of
    :func:`vfs.gym.benchmark.benchmark_measures`: unnecessary braking (share of the
    near misses braked in at or above ``BRAKE_THRESHOLD``, speed lost [km/h] and time
    braked [s] there), comfort (peak deceleration [m/s^2] and jerk [m/s^3] where the
    system brakes, time above ``HARSH_DECELERATION`` per case [s]) and the ``score``.

    Returns
    -------
    pandas.DataFrame
    """
    from pathlib import Path

    import pandas as pd

    from vfs.study import BASELINE, load_study

    runs = load_study(out).table
    metrics_file = Path(out) / "report" / "metrics.csv"
    if runs is None or not metrics_file.is_file():
        raise ParameterError(f"{out}: no complete evaluation with its report")
    metrics = pd.read_csv(metrics_file)
    metrics = metrics[metrics["group"] == "all"].set_index(["system", "metric"])
    base = runs[runs["system"] == BASELINE].set_index("case_id")
    near = base.index[~base["collided"].astype("boolean").fillna(True).to_numpy(bool)]
    rows = []
    for name in [s for s in runs["system"].unique() if s != BASELINE]:
        sys_runs = runs[runs["system"] == name].set_index("case_id")
        row: dict[str, Any] = {"policy": name}
        for key, metric, scale in (("avoided", "avoided_share", 100.0),
                                   ("mais3_reduction", "risk_MAIS3+_reduction", 100.0),
                                   ("delta_v_reduction_kmh", "dv_reduction_all", KMH_PER_MS)):
            m = metrics.loc[(name, metric)]
            row[key] = float(m["estimate"]) * scale
            row[f"{key}_low"] = float(m["low"]) * scale
            row[f"{key}_high"] = float(m["high"]) * scale
        row["new_crashes"] = int(round(float(metrics.loc[(name, "crashes_new"), "estimate"])))
        start = sys_runs.reindex(near)[f"brake_start{ego}"].to_numpy(float)
        row["near_miss_brakes"] = int(np.isfinite(start).sum())
        row["near_misses"] = int(near.size)
        measures = benchmark_measures(runs, name, ego, BASELINE)
        for key in ("unnecessary", "unnecessary_share", "unnecessary_speed_loss_kmh",
                    "unnecessary_speed_share",
                    "unnecessary_brake_time", "brakes_share", "peak_decel", "peak_jerk",
                    "peak_decel_max", "harsh_time", "net_avoided_share", "score"):
            row[key] = measures[key]
        rows.append(row)
    return pd.DataFrame(rows)


def leaderboard_markdown(table: Any) -> str:
    """The leaderboard as two Markdown tables: benefit (percentages and km/h with their
    intervals), then unnecessary braking, comfort and the score.
    """
    from vfs.gym.benchmark import BRAKE_THRESHOLD, HARSH_DECELERATION, score_formula

    def cell(row: Any, key: str, fmt: str) -> str:
        return (f"{row[key]:{fmt}} [{row[key + '_low']:{fmt}}, {row[key + '_high']:{fmt}}]")

    lines = ["| policy | crashes avoided [%] | MAIS3+ risk reduction [%] | "
             "delta-v reduction [km/h] | new crashes | brakes in no-crash cases |",
             "|---|---|---|---|---|---|"]
    for _, row in table.iterrows():
        lines.append(f"| {row['policy']} | {cell(row, 'avoided', '.1f')} | "
                     f"{cell(row, 'mais3_reduction', '.1f')} | "
                     f"{cell(row, 'delta_v_reduction_kmh', '.1f')} | {row['new_crashes']} | "
                     f"{row['near_miss_brakes']} / {row['near_misses']} |")
    lines += ["", f"| policy | unnecessary braking (>= {BRAKE_THRESHOLD:g} m/s^2) | "
              "speed taken there [km/h] (share) | braking time there [s] | "
              "peak deceleration [m/s^2] | peak jerk [m/s^3] | "
              f"time above {HARSH_DECELERATION:g} m/s^2 per case [s] | score |",
              "|---|---|---|---|---|---|---|---|"]
    for _, row in table.iterrows():
        lines.append(f"| {row['policy']} | {int(row['unnecessary'])} / {row['near_misses']} | "
                     f"{row['unnecessary_speed_loss_kmh']:.1f} "
                     f"({100 * row['unnecessary_speed_share']:.0f} %) | "
                     f"{row['unnecessary_brake_time']:.2f} | {row['peak_decel']:.1f} | "
                     f"{row['peak_jerk']:.0f} | {row['harsh_time']:.2f} | "
                     f"{row['score']:.3f} |")
    lines += ["", score_formula() + "; peak deceleration and jerk: means over the cases "
              "where the system brakes."]
    return "\n".join(lines) + "\n"


def write_leaderboard(out: str | os.PathLike[str], ego: int = 1) -> Any:
    """Write ``OUT/leaderboard.csv`` and ``OUT/leaderboard.md`` (:func:`leaderboard`)."""
    from pathlib import Path

    from vfs.atomic import write_text

    table = leaderboard(out, ego)
    write_text(Path(out) / f"{LEADERBOARD_FILE}.csv", table.to_csv(index=False))
    write_text(Path(out) / f"{LEADERBOARD_FILE}.md", leaderboard_markdown(table))
    return table


__all__ = ["LEADERBOARD_FILE", "evaluate_policy", "leaderboard", "leaderboard_markdown",
           "write_leaderboard"]
