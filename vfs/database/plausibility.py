"""Physical plausibility of a database: what the schema cannot see.

The schema (:mod:`vfs.database.validation`) checks types, ranges and keys column by
column.  A database can pass it and still be physically impossible: a trajectory that
jumps a kilometre between two samples, speeds written in km/h into a column in m/s, yaw
angles in degrees, a reconstruction whose impact time lies outside the recorded
trajectories.  :func:`check_plausibility` finds these, vectorised over all samples:

*Errors* (the data cannot be right; ``vfs db validate`` fails, loading with
validation rejects the database):

- every table empty;
- a position step that disagrees with the recorded speeds by more than
  :attr:`PlausibilityLimits.jump` (a jump);
- recorded speeds that are consistently a factor of about 3.6 above the speed from
  the positions (km/h in a m/s column), per participant;
- yaw angles that follow the direction of travel only after conversion from degrees;
- speeds above :attr:`PlausibilityLimits.speed_error`, accelerations above
  :attr:`PlausibilityLimits.accel_error`, yaw rates above
  :attr:`PlausibilityLimits.yaw_rate_error`;
- a reconstruction impact time outside a participant's trajectory.

*Warnings* (a real database can contain it; ``--strict`` makes them errors):

- position steps that disagree with the speeds by more than 5 m/s and 50 %;
- yaw that differs from the direction of travel by more than 45 deg in most moving
  samples (reversing, drifting, or a yaw reference other than the vehicle axis);
- speeds above :attr:`PlausibilityLimits.speed_warning`, accelerations above
  :attr:`PlausibilityLimits.accel_warning`, yaw rates above
  :attr:`PlausibilityLimits.yaw_rate_warning`, turn radii below
  :attr:`PlausibilityLimits.min_radius` at speed;
- reconstruction positions more than :attr:`PlausibilityLimits.impact_position`
  from the trajectories at the impact time.

Then the cross-field checks of :mod:`vfs.database.consistency` (recorded
acceleration vs the speed's derivative, mass vs footprint, wheelbase vs length,
yaw inertia vs m L1 L2, masses in pounds, fixed objects that move, overlapping
outlines at the start, the POI far from both vehicles, PDOF in radians).

Each problem names table, column, case and the limit.  docs/data-format.md lists the
limits and why.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vfs.errors import DataProblem
from vfs.units import KMH_PER_MS, wrap_angle


@dataclass(frozen=True)
class PlausibilityLimits:
    """Limits of the plausibility checks (SI units).

    Attributes
    ----------
    jump : float
        Position step beyond the speeds' travel that is an error [m]; default 10 m
        (GPS noise is metres, a jump is tens or hundreds).
    speed_mismatch : float
        Step speed vs recorded speed difference that is a warning [m/s] (and 50 %).
    speed_warning, speed_error : float
        Speed limits [m/s]: 60 m/s (216 km/h) warns, 100 m/s (360 km/h) is an error.
    accel_warning, accel_error : float
        |d speed / dt| limits [m/s^2]: 12 (about 1.2 g, the best tyres) warns, 30 (3 g,
        beyond any tyre-road contact) is an error.
    yaw_rate_warning, yaw_rate_error : float
        |d yaw / dt| limits [rad/s]: 3 warns (a spinning car), 10 is an error.
    min_radius : float
        Smallest turn radius at more than 5 m/s that does not warn [m] (5 m: the
        turning circle of a car).
    heading_tolerance : float
        Yaw vs direction of travel beyond which a sample counts as not following [rad]
        (45 deg).
    impact_position : float
        Reconstruction position vs trajectory at the impact time that warns [m] (the
        penetration and the reconstruction's own pose: a few tenths of a metre).
    """

    jump: float = 10.0
    speed_mismatch: float = 5.0
    speed_warning: float = 60.0
    speed_error: float = 100.0
    accel_warning: float = 12.0
    accel_error: float = 30.0
    yaw_rate_warning: float = 3.0
    yaw_rate_error: float = 10.0
    min_radius: float = 5.0
    heading_tolerance: float = math.radians(45.0)
    impact_position: float = 3.0


@dataclass(frozen=True)
class Plausibility:
    """Result of :func:`check_plausibility`: errors and warnings (each a DataProblem)."""

    errors: list[DataProblem] = field(default_factory=list)
    warnings: list[DataProblem] = field(default_factory=list)


#: Rows listed per check before a summary line.
MAX_LISTED = 20


def _add(out: list[DataProblem], table: str, column: str, case_ids: np.ndarray,
         messages: list[str] | str, summary: str) -> None:
    ids = np.asarray(case_ids)
    for k in range(min(ids.size, MAX_LISTED)):
        text = messages if isinstance(messages, str) else messages[k]
        value = ids[k].item() if hasattr(ids[k], "item") else ids[k]
        out.append(DataProblem(table, column, None, value, text))
    if ids.size > MAX_LISTED:
        out.append(DataProblem(table, column, None, None,
                               f"... and {ids.size - MAX_LISTED} more: {summary}"))


def check_plausibility(db: Any, limits: PlausibilityLimits | None = None, *,
                       require_cases: bool = True) -> Plausibility:
    """Physical plausibility of ``db`` (a schema-valid :class:`vfs.database.Database`).

    Parameters
    ----------
    db : Database
        Tables in SI units (as loaded).
    limits : PlausibilityLimits, optional
        The limits (defaults documented there).
    require_cases : bool
        An empty database is an error (default).  Loading with ``where`` passes False:
        a selection may match no case.

    Returns
    -------
    Plausibility
        ``errors`` and ``warnings``.
    """
    lim = limits or PlausibilityLimits()
    err: list[DataProblem] = []
    warn: list[DataProblem] = []
    tables = db.tables()
    if all(len(df) == 0 for df in tables.values()):
        if not require_cases:
            return Plausibility(err, warn)
        err.append(DataProblem("cases", "case_id", None, None,
                               "the database is empty: every table has 0 rows"))
        return Plausibility(err, warn)
    traj = db.trajectories
    needed = {"case_id", "participant", "t", "x", "y", "yaw", "speed"}
    if len(traj) and needed <= set(traj.columns):
        _check_trajectories(traj, lim, err, warn)
        _check_reconstruction(db, traj, lim, err, warn)
    from vfs.database.consistency import check_consistency

    more_err, more_warn = check_consistency(db, lim.accel_error)  # across columns and tables
    return Plausibility(err + more_err, warn + more_warn)


def _check_trajectories(traj: pd.DataFrame, lim: PlausibilityLimits,
                        err: list[DataProblem], warn: list[DataProblem]) -> None:
    cols = ["t", "x", "y", "yaw", "speed"]
    t, x, y, yaw, v = (pd.to_numeric(traj[c], errors="coerce").to_numpy(float) for c in cols)
    case = traj["case_id"].to_numpy()
    part = traj["participant"].to_numpy()
    same = np.zeros(len(traj), bool)
    same[1:] = (case[1:] == case[:-1]) & (part[1:] == part[:-1])
    i = np.flatnonzero(same)  # segment from i-1 to i
    dt = t[i] - t[i - 1]
    ok = dt > 0
    i, dt = i[ok], dt[ok]
    ds = np.hypot(x[i] - x[i - 1], y[i] - y[i - 1])
    v_mean = 0.5 * (v[i] + v[i - 1])
    v_step = ds / dt
    # jumps: far more distance than the speeds allow (or far less)
    excess = np.abs(ds - v_mean * dt)
    jump = excess > lim.jump
    _add(err, "trajectories", "x", case[i[jump]],
         [f"participant {part[k]}: position moves {d:.1f} m in {s:.3g} s before t={t[k]:g} s, "
          f"{e:.1f} m more or less than the recorded speeds allow (limit {lim.jump:g} m): "
          "a jump" for k, d, s, e in zip(i[jump][:MAX_LISTED], ds[jump][:MAX_LISTED],
                                          dt[jump][:MAX_LISTED], excess[jump][:MAX_LISTED],
                                          strict=True)],
         "position jumps")
    mismatch = ~jump & (np.abs(v_step - v_mean) > np.maximum(lim.speed_mismatch,
                                                              0.5 * v_mean))
    # per participant: one warning with the share of samples
    key = pd.MultiIndex.from_arrays([case[i], part[i]])
    _per_participant_warning(warn, "trajectories", "speed", key, mismatch,
                             f"speed from the positions differs from the recorded speed by "
                             f"more than {lim.speed_mismatch:g} m/s and 50 %")
    # km/h in the speed column: recorded / step speed about 3.6 while moving
    moving = v_step > 1.0
    ratio = pd.Series(np.where(moving, v_mean / np.maximum(v_step, 1e-9), np.nan), index=key)
    med = ratio.groupby(level=[0, 1]).median()
    kmh = med[(med > 0.75 * KMH_PER_MS) & (med < 1.25 * KMH_PER_MS)]
    for (cid, p), r in list(kmh.items())[:MAX_LISTED]:
        err.append(DataProblem("trajectories", "speed", None, _py(cid),
                               f"participant {p}: the recorded speed is {r:.2f} x the speed "
                               f"from the positions (median over moving samples): km/h "
                               f"in a column in m/s? (allowed ratio about 1)"))
    if len(kmh) > MAX_LISTED:
        err.append(DataProblem("trajectories", "speed", None, None,
                               f"... and {len(kmh) - MAX_LISTED} more participants with speeds "
                               "in km/h"))
    # yaw: follows the direction of travel where the vehicle moves
    fast = (v_step > 2.0) & (ds > 0.2)
    heading = np.arctan2(y[i] - y[i - 1], x[i] - x[i - 1])
    yaw_mid = yaw[i - 1] + 0.5 * wrap_angle(yaw[i] - yaw[i - 1])
    off = np.abs(wrap_angle(yaw_mid - heading)) > lim.heading_tolerance
    # read as degrees, the yaw must follow the travel closely (15 deg) to count as degrees
    off_deg = np.abs(wrap_angle(np.radians(yaw_mid) - heading)) > math.radians(15.0)
    grouped = pd.DataFrame({"off": off & fast, "off_deg": off_deg & fast, "fast": fast,
                            "big": np.abs(yaw_mid) > math.pi}, index=key).groupby(level=[0, 1])
    frame = grouped.sum()
    frame = frame[frame["fast"] >= 3]
    bad = frame["off"] > 0.5 * frame["fast"]
    # degrees: the values follow the travel only as degrees, and most are beyond pi (a yaw
    # in rad is within +-pi unless unwrapped over turns; a reversing car's is too)
    degrees = (bad & (frame["off_deg"] <= 0.1 * frame["fast"])
               & (frame["big"] > 0.5 * grouped.size().reindex(frame.index)))
    for (cid, p), _ in list(frame[degrees].iterrows())[:MAX_LISTED]:
        err.append(DataProblem("trajectories", "yaw", None, _py(cid),
                               f"participant {p}: yaw follows the direction of travel only if "
                               "read in degrees; yaw must be in rad"))
    for (cid, p), row in list(frame[bad & ~degrees].iterrows())[:MAX_LISTED]:
        warn.append(DataProblem("trajectories", "yaw", None, _py(cid),
                                f"participant {p}: yaw differs from the direction of travel by "
                                f"more than {math.degrees(lim.heading_tolerance):g} deg in "
                                f"{int(row['off'])} of {int(row['fast'])} moving samples "
                                "(reversing, drifting, or another yaw reference?)"))
    # limits of road vehicles
    _limit(err, warn, "speed", case, part, v, lim.speed_warning, lim.speed_error, "m/s")
    accel = np.abs(v[i] - v[i - 1]) / dt
    _limit(err, warn, "speed", case[i], part[i], accel, lim.accel_warning, lim.accel_error,
           "m/s^2", what="acceleration |d speed / dt|")
    yaw_rate = np.abs(wrap_angle(yaw[i] - yaw[i - 1])) / dt
    _limit(err, warn, "yaw", case[i], part[i], yaw_rate, lim.yaw_rate_warning,
           lim.yaw_rate_error, "rad/s", what="yaw rate |d yaw / dt|")
    with np.errstate(divide="ignore", invalid="ignore"):
        curvature = np.where((v_mean > 5.0) & (ds > 0.05),
                             np.abs(wrap_angle(yaw[i] - yaw[i - 1])) / ds, 0.0)
    tight = curvature > 1.0 / lim.min_radius
    _per_participant_warning(warn, "trajectories", "yaw", key, tight,
                             f"turn radius below {lim.min_radius:g} m at more than 5 m/s")


def _per_participant_warning(out: list[DataProblem], table: str, column: str,
                             key: pd.MultiIndex, mask: np.ndarray, text: str) -> None:
    if not mask.any():
        return
    counts = pd.Series(mask, index=key).groupby(level=[0, 1]).agg(["sum", "size"])
    counts = counts[counts["sum"] > 0]
    for (cid, p), row in list(counts.iterrows())[:MAX_LISTED]:
        out.append(DataProblem(table, column, None, _py(cid),
                               f"participant {p}: {text} in {int(row['sum'])} of "
                               f"{int(row['size'])} steps"))
    if len(counts) > MAX_LISTED:
        out.append(DataProblem(table, column, None, None,
                               f"... and {len(counts) - MAX_LISTED} more participants: {text}"))


def _limit(err: list[DataProblem], warn: list[DataProblem], column: str, case: np.ndarray,
           part: np.ndarray, value: np.ndarray, warning: float, error: float, unit: str,
           what: str = "speed") -> None:
    for target, limit, kind in ((err, error, "error"), (warn, warning, "warning")):
        mask = value > limit
        if kind == "warning":
            mask &= value <= error
        if not mask.any():
            continue
        frame = pd.DataFrame({"case": case[mask], "part": part[mask], "v": value[mask]})
        worst = frame.groupby(["case", "part"], sort=False)["v"].max()
        for (cid, p), v in list(worst.items())[:MAX_LISTED]:
            target.append(DataProblem("trajectories", column, None, _py(cid),
                                      f"participant {p}: {what} {v:.3g} {unit} above the "
                                      f"{kind} limit {limit:g} {unit} for road vehicles"))


def _check_reconstruction(db: Any, traj: pd.DataFrame, lim: PlausibilityLimits,
                          err: list[DataProblem], warn: list[DataProblem]) -> None:
    rec = db.reconstruction
    if not len(rec) or "t_impact" not in rec.columns:
        return
    span = traj.groupby(["case_id", "participant"])["t"].agg(["min", "max"])
    for p in (1, 2):
        idx = pd.MultiIndex.from_arrays([rec["case_id"], np.full(len(rec), p)])
        s = span.reindex(idx)
        t_imp = pd.to_numeric(rec["t_impact"], errors="coerce").to_numpy(float)
        lo, hi = s["min"].to_numpy(float), s["max"].to_numpy(float)
        outside = np.isfinite(lo) & ((t_imp < lo - 1e-6) | (t_imp > hi + 1e-6))
        ids = rec["case_id"].to_numpy()
        _add(err, "reconstruction", "t_impact", ids[outside],
             [f"t_impact={ti:g} s lies outside the trajectory of participant {p} "
              f"({a:g}-{b:g} s)" for ti, a, b in zip(t_imp[outside][:MAX_LISTED],
                                                    lo[outside][:MAX_LISTED],
                                                    hi[outside][:MAX_LISTED], strict=True)],
             "impact times outside the trajectories")
        if not {f"x{p}", f"y{p}"} <= set(rec.columns):
            continue
        inside = np.isfinite(lo) & ~outside & np.isfinite(t_imp)
        if not inside.any():
            continue
        px, py = _interpolate(traj, p, ids[inside], t_imp[inside])
        rx = pd.to_numeric(rec[f"x{p}"], errors="coerce").to_numpy(float)[inside]
        ry = pd.to_numeric(rec[f"y{p}"], errors="coerce").to_numpy(float)[inside]
        dist = np.hypot(px - rx, py - ry)
        far = dist > lim.impact_position
        _add(warn, "reconstruction", f"x{p}", ids[inside][far],
             [f"participant {p} is {d:.2f} m from its trajectory at t_impact (limit "
              f"{lim.impact_position:g} m)" for d in dist[far][:MAX_LISTED]],
             "reconstruction positions away from the trajectories")


def _interpolate(traj: pd.DataFrame, p: int, case_ids: np.ndarray,
                 times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of participant ``p`` of ``case_ids`` at ``times`` (linear in t) [m].

    Between the last sample at or before each time and the first at or after it (the
    as-of matches of ``pandas.merge_asof`` by case, backward and forward), by one sort of
    the samples and the queries together; NaN for a case without samples of ``p``.
    """
    mine = np.flatnonzero(np.asarray(traj["participant"] == p, dtype=bool))
    cases = pd.Index(traj["case_id"].to_numpy()[mine]).unique()
    g_data = cases.get_indexer(traj["case_id"].to_numpy()[mine])
    g_want = cases.get_indexer(np.asarray(case_ids))
    t_data = np.asarray(traj["t"], float)[mine]
    x_data = np.asarray(traj["x"], float)[mine]
    y_data = np.asarray(traj["y"], float)[mine]
    times = np.asarray(times, float)
    n, k = t_data.size, times.size
    group = np.concatenate([g_data, g_want])
    t_all = np.concatenate([t_data, times])
    found = []
    for backward in (True, False):
        # samples before queries at equal times for the backward match (t_sample <= t),
        # after them for the forward one (t_sample >= t)
        kind = np.concatenate([np.full(n, 0 if backward else 1), np.full(k, 1 if backward else 0)])
        order = np.lexsort((kind, t_all, group))
        is_data = order < n
        if backward:  # the last sample at or before each position of the sorted order
            last = np.maximum.accumulate(np.where(is_data, np.arange(order.size), -1))
        else:  # the first sample at or after it
            big = order.size
            last = np.minimum.accumulate(np.where(is_data, np.arange(order.size), big)[::-1])[::-1]
            last[last == big] = -1
        match = np.full(k, -1)
        query = ~is_data
        at = last[query]
        rows = np.where(at >= 0, order[np.maximum(at, 0)], -1)
        same = (rows >= 0) & (group[np.maximum(rows, 0)] == group[order[query]])
        match[order[query] - n] = np.where(same, rows, -1)
        ok = (match >= 0) & (g_want >= 0)
        pick = np.maximum(match, 0)
        found.append([np.where(ok, a[pick], np.nan) if n else np.full(k, np.nan)
                      for a in (t_data, x_data, y_data)])
    (t0, x0, y0), (t1, x1, y1) = found
    t = times
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(t1 > t0, (t - t0) / (t1 - t0), 0.0)
    w = np.nan_to_num(np.clip(w, 0.0, 1.0))
    return x0 + w * (x1 - x0), y0 + w * (y1 - y0)


def _py(value: Any) -> Any:
    return value.item() if hasattr(value, "item") else value


__all__ = ["Plausibility", "PlausibilityLimits", "check_plausibility"]
