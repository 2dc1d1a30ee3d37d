"""Cross-field plausibility: values in range alone but impossible together.

The schema checks each column against its range; :mod:`vfs.database.plausibility`
checks the trajectories against themselves.  This module checks what physics ties
together across columns and tables, each named with the implied quantity:

- the recorded longitudinal acceleration (``trajectories.accel``) against the
  derivative of the recorded speed, and against the limit of tyre-road contact;
- the mass against the footprint (mass / (length x width), a road vehicle's
  "areal density"), the wheelbase against the length, the yaw inertia against
  m L1 L2 (the dynamic index);
- masses in pounds for part of the cases (a mass column bimodal by 2.2);
- fixed objects that move, both participants fixed, the two outlines overlapping
  at the first sample (participant 2 on participant 1's path);
- a point of impact outside both outlines by more than their size;
- PDOF in radians where degrees are specified (the PDOF implied by the
  reconstruction's delta-v matches only after reading the values as radians).

Thresholds (:class:`ConsistencyLimits`) come from published vehicle data, the
source is given with each; docs/data-format.md ("Checks") lists them.  Every
check is vectorised over rows; the per-case work (first-sample outlines) uses one
grouped pass over the trajectories.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from vfs.errors import DataProblem
from vfs.physics.geometry import outline_corners, outline_distance, to_vehicle_frame
from vfs.units import wrap_angle

#: Rows listed per check before a summary line.
MAX_LISTED = 20


@dataclass(frozen=True)
class ConsistencyLimits:
    """Bands of the cross-field checks (SI units) and their sources.

    Attributes
    ----------
    density_low, density_high : float
        Mass per footprint area, mass / (length x width) [kg/m^2], outside which a
        participant warns: 40 and 1,500.  Passenger cars lie at 120-350 kg/m^2
        (a Lotus Elise 900 kg on 3.8 x 1.72 m: 138; a Mercedes G-Class 2.5 t on
        4.8 x 1.93 m: 270; manufacturers' data sheets); a 40 t articulated lorry
        of the EU limits (Directive 96/53/EC: 40 t, 16.5 m, 2.55 m) about
        950 kg/m^2, a 60 t mobile crane (15 m x 2.75 m) about 1,450; bicycles
        with rider and motorcycles 50-150.  A 50,000 kg car of 4.6 x 1.8 m
        (6,000 kg/m^2) is impossible.
    wheelbase_ratio_low : float
        Wheelbase / length below which a participant warns: 0.2.  Cars have
        0.55-0.72 (Golf 2.64/4.26 m, Smart 1.87/2.69 m), buses and rigid lorries
        about 0.5, a tractor with semitrailer taken as one body (3.8 m of
        16.5 m) 0.23.
    dynamic_index_low, dynamic_index_high : float
        Band of the dynamic index I / (m L1 L2) (I yaw inertia, L1 and L2 the
        CG-to-axle distances): 0.5 and 2.0.  Measured passenger cars, vans and
        SUVs lie at 0.8-1.2 (Heydinger et al., "Measured vehicle inertial
        parameters - NHTSA's data through November 1998", SAE 1999-01-1336;
        Milliken and Milliken, "Race Car Vehicle Dynamics", 1995, chapter 5: the
        dynamic index k^2 / (a b)); the front-to-side energy balance paper uses
        I = m L1 L2 (index 1).  The band is wide enough for buses and loaded
        lorries with long overhangs.
    unit_ratio_lb : tuple of float
        Ratio of two mass clusters read as pounds in a kilogram column:
        2.2046 (1 kg = 2.2046 lb) +- 15 %.
    fixed_speed : float
        Recorded speed of a fixed object above which it "moves" [m/s]: 0.5
        (walking pace; GPS noise of a parked vehicle is below).
    fixed_travel : float
        Path length of a fixed object above which it moves [m]: 1.0.
    accel_mismatch : float
        Recorded acceleration vs d speed / dt difference that counts [m/s^2]: 2.0
        (and 50 % of the derivative); 0.2 g is more than road grade (10 %: 1 m/s^2)
        and pitch add to an accelerometer.
    accel_share : float
        Share of a participant's steps that must differ for a warning: 0.5.
    pdof_degrees : float
        PDOF as recorded vs as implied by delta-v [rad]: a value read as radians
        must match within 10 deg while the degrees disagree by more than 30 deg.
    min_delta_v : float
        Delta-v below which the PDOF is not compared [m/s]: 1.0 (its direction is
        noise).
    """

    density_low: float = 40.0
    density_high: float = 1500.0
    wheelbase_ratio_low: float = 0.2
    dynamic_index_low: float = 0.5
    dynamic_index_high: float = 2.0
    unit_ratio_lb: tuple[float, float] = (2.2046 / 1.15, 2.2046 * 1.15)
    fixed_speed: float = 0.5
    fixed_travel: float = 1.0
    accel_mismatch: float = 2.0
    accel_share: float = 0.5
    pdof_degrees: float = math.radians(10.0)
    min_delta_v: float = 1.0


def _py(value: Any) -> Any:
    return value.item() if hasattr(value, "item") else value


def _add(out: list[DataProblem], table: str, column: str, case_ids: np.ndarray,
         messages: list[str], summary: str) -> None:
    for cid, text in list(zip(np.asarray(case_ids), messages, strict=True))[:MAX_LISTED]:
        out.append(DataProblem(table, column, None, _py(cid), text))
    if len(messages) > MAX_LISTED:
        out.append(DataProblem(table, column, None, None,
                               f"... and {len(messages) - MAX_LISTED} more: {summary}"))


def _num(df: pd.DataFrame, name: str) -> np.ndarray:
    if name not in df.columns:
        return np.full(len(df), np.nan)
    return pd.to_numeric(df[name], errors="coerce").to_numpy(float)


def _fixed(parts: pd.DataFrame) -> np.ndarray:
    if "fixed_object" not in parts.columns:
        return np.zeros(len(parts), bool)
    col = parts["fixed_object"]
    if col.dtype == bool:
        return col.to_numpy()
    return col.astype(str).str.strip().str.lower().isin({"true", "1", "yes"}).to_numpy()


def check_consistency(db: Any, accel_error: float, limits: ConsistencyLimits | None = None
                      ) -> tuple[list[DataProblem], list[DataProblem]]:
    """The cross-field checks of the module description on a schema-valid database.

    Parameters
    ----------
    db : Database
        Tables in SI units (as loaded).
    accel_error : float
        |acceleration| that is an error [m/s^2]
        (:attr:`vfs.database.plausibility.PlausibilityLimits.accel_error`).
    limits : ConsistencyLimits, optional
        The bands (defaults documented there).

    Returns
    -------
    errors, warnings : list of DataProblem
    """
    lim = limits or ConsistencyLimits()
    err: list[DataProblem] = []
    warn: list[DataProblem] = []
    parts, traj = db.participants, db.trajectories
    if len(parts):
        _vehicle_values(parts, lim, warn)
        _mass_units(parts, lim, warn)
        _fixed_objects(parts, traj, lim, err, warn)
    if len(traj) and {"accel", "speed", "t"} <= set(traj.columns):
        _acceleration(traj, accel_error, lim, err, warn)
    if len(parts) and len(traj):
        _start_overlap(parts, traj, warn)
        if "collision" in db.cases.columns:
            _near_miss_contact(db.cases, parts, traj, warn)
    if len(db.reconstruction) and len(parts):
        _reconstruction(db.reconstruction, parts, lim, warn)
    return err, warn


def _vehicle_values(parts: pd.DataFrame, lim: ConsistencyLimits,
                    warn: list[DataProblem]) -> None:
    m, length, width = _num(parts, "mass"), _num(parts, "length"), _num(parts, "width")
    wb, l1, izz = _num(parts, "wheelbase"), _num(parts, "cg_to_front_axle"), \
        _num(parts, "yaw_inertia")
    ids, number = parts["case_id"].to_numpy(), _num(parts, "participant")
    fixed = _fixed(parts)
    with np.errstate(invalid="ignore", divide="ignore"):
        density = m / (length * width)
        odd = ~fixed & ((density < lim.density_low) | (density > lim.density_high))
        _add(warn, "participants", "mass", ids[odd],
             [f"participant {p:g}: mass {mi:g} kg on a footprint of {li:g} x {wi:g} m is "
              f"{d:.0f} kg/m^2, outside the {lim.density_low:g}-{lim.density_high:g} kg/m^2 of "
              "road vehicles (mass in another unit, or length/width wrong?)"
              for p, mi, li, wi, d in zip(number[odd], m[odd], length[odd], width[odd],
                                          density[odd], strict=True)],
             "mass vs footprint")
        ratio = wb / length
        short = ~fixed & (ratio < lim.wheelbase_ratio_low)
        _add(warn, "participants", "wheelbase", ids[short],
             [f"participant {p:g}: wheelbase {w:g} m is {r:.2f} of the length {li:g} m, below "
              f"the {lim.wheelbase_ratio_low:g} of road vehicles"
              for p, w, r, li in zip(number[short], wb[short], ratio[short], length[short],
                                     strict=True)],
             "wheelbase vs length")
        l2 = wb - l1
        index = izz / (m * l1 * l2)
        bad = ~fixed & np.isfinite(index) & ((index < lim.dynamic_index_low)
                                             | (index > lim.dynamic_index_high))
        _add(warn, "participants", "yaw_inertia", ids[bad],
             [f"participant {p:g}: yaw inertia {i:g} kg m^2 is {k:.3g} x m L1 L2 = "
              f"{mi * a * b:.4g} kg m^2 (dynamic index outside {lim.dynamic_index_low:g}-"
              f"{lim.dynamic_index_high:g} of measured vehicles)"
              for p, i, k, mi, a, b in zip(number[bad], izz[bad], index[bad], m[bad], l1[bad],
                                           l2[bad], strict=True)],
             "yaw inertia vs m L1 L2")


def _mass_units(parts: pd.DataFrame, lim: ConsistencyLimits, warn: list[DataProblem]) -> None:
    """Cars (footprint of a passenger car) whose areal densities fall in two clusters a
    factor of about 2.2 apart: pounds in part of a kilogram column.
    """
    m, length, width = _num(parts, "mass"), _num(parts, "length"), _num(parts, "width")
    # passenger-car footprints (3-5.6 m x 1.4-2.1 m), where the density band is narrow
    car = ~_fixed(parts) & (length >= 3.0) & (length <= 5.6) & (width >= 1.4) & (width <= 2.1)
    with np.errstate(invalid="ignore", divide="ignore"):
        logd = np.log(m / (length * width))
    keep = car & np.isfinite(logd)
    n = int(keep.sum())
    if n < 6:
        return
    values = np.sort(logd[keep])
    gaps = np.diff(values)
    k = int(np.argmax(gaps))  # the widest gap splits the two clusters
    low, high = values[:k + 1], values[k + 1:]
    if min(low.size, high.size) < max(2, 0.1 * n):
        return
    ratio = math.exp(float(np.median(high) - np.median(low)))
    spread = max(float(np.ptp(low)), float(np.ptp(high)))
    if not (lim.unit_ratio_lb[0] <= ratio <= lim.unit_ratio_lb[1]) or gaps[k] < 0.5 * spread:
        return
    cut = values[k]
    upper = keep & (logd > cut)
    ids, number = parts["case_id"].to_numpy(), _num(parts, "participant")
    _add(warn, "participants", "mass", ids[upper],
         [f"participant {p:g}: mass {mi:g} kg belongs to a cluster of cars {ratio:.2f} x "
          f"heavier per footprint than the other {low.size} (pounds in a column in kg? "
          "1 kg = 2.2046 lb)" for p, mi in zip(number[upper], m[upper], strict=True)],
         "masses in pounds?")


def _fixed_objects(parts: pd.DataFrame, traj: pd.DataFrame, lim: ConsistencyLimits,
                   err: list[DataProblem], warn: list[DataProblem]) -> None:
    fixed = _fixed(parts)
    if not fixed.any():
        return
    key = parts.loc[fixed, ["case_id", "participant"]]
    both = key.groupby("case_id").size()
    both = both[both >= 2]
    _add(err, "participants", "fixed_object", both.index.to_numpy(),
         ["both participants are fixed objects: nothing can move into a collision (one "
          "must be a vehicle)"] * len(both), "both participants fixed")
    if not {"speed", "x", "y"} <= set(traj.columns):
        return
    sub = traj.merge(key, on=["case_id", "participant"])
    if sub.empty:
        return
    step = np.hypot(sub.groupby(["case_id", "participant"])["x"].diff(),
                    sub.groupby(["case_id", "participant"])["y"].diff()).fillna(0.0)
    agg = pd.DataFrame({"case_id": sub["case_id"], "participant": sub["participant"],
                        "speed": pd.to_numeric(sub["speed"], errors="coerce"), "step": step}
                       ).groupby(["case_id", "participant"]).agg(
        vmax=("speed", "max"), travel=("step", "sum"))
    moving = agg[(agg["vmax"] > lim.fixed_speed) | (agg["travel"] > lim.fixed_travel)]
    _add(warn, "participants", "fixed_object", moving.index.get_level_values(0).to_numpy(),
         [f"participant {p}: marked as a fixed object but moves (speed up to {v:.3g} m/s, "
          f"{s:.3g} m travelled; limits {lim.fixed_speed:g} m/s, {lim.fixed_travel:g} m): "
          "a fixed object has infinite mass in the impact" for (_, p), v, s in
          zip(moving.index, moving["vmax"], moving["travel"], strict=True)],
         "fixed objects that move")


def _acceleration(traj: pd.DataFrame, accel_error: float, lim: ConsistencyLimits,
                  err: list[DataProblem], warn: list[DataProblem]) -> None:
    a = _num(traj, "accel")
    if not np.isfinite(a).any():
        return
    t, v = _num(traj, "t"), _num(traj, "speed")
    case, part = traj["case_id"].to_numpy(), traj["participant"].to_numpy()
    over = np.abs(a) > accel_error
    if over.any():
        worst = pd.Series(np.abs(a[over])).groupby([case[over], part[over]], sort=False).max()
        _add(err, "trajectories", "accel", worst.index.get_level_values(0).to_numpy(),
             [f"participant {p}: recorded acceleration {w:.4g} m/s^2 ({w / 9.80665:.3g} g) "
              f"above the error limit {accel_error:g} m/s^2 of tyre-road contact" for (_, p), w
              in worst.items()], "accelerations above the limit")
    same = np.zeros(len(traj), bool)
    same[1:] = (case[1:] == case[:-1]) & (part[1:] == part[:-1])
    i = np.flatnonzero(same)
    dt = t[i] - t[i - 1]
    ok = (dt > 0) & np.isfinite(a[i]) & np.isfinite(a[i - 1])
    i, dt = i[ok], dt[ok]
    if i.size == 0:
        return
    dvdt = (v[i] - v[i - 1]) / dt
    a_mid = 0.5 * (a[i] + a[i - 1])
    diff = np.abs(a_mid - dvdt)
    off = diff > np.maximum(lim.accel_mismatch, 0.5 * np.abs(dvdt))
    # per participant (rows are grouped by case and participant): bincount, not groupby
    group = np.cumsum(~same)[i] - 1
    n = np.bincount(group)
    share = np.bincount(group, off) / np.maximum(n, 1)
    mean = np.bincount(group, diff) / np.maximum(n, 1)
    flagged = np.flatnonzero((share > lim.accel_share) & (n >= 3))
    first = np.flatnonzero(~same)[flagged]  # a row of each flagged participant
    _add(warn, "trajectories", "accel", case[first],
         [f"participant {p}: recorded acceleration differs from d speed / dt by more than "
          f"{lim.accel_mismatch:g} m/s^2 in {sh:.0%} of the steps (mean {m:.3g} m/s^2); the "
          "AEB sees the recorded value" for p, sh, m in
          zip(part[first], share[flagged], mean[flagged], strict=True)],
         "acceleration vs the speed's derivative")


def _geometry(parts: pd.DataFrame) -> pd.DataFrame:
    """cg_to_front, cg_to_rear and width [m] by (case_id, participant)."""
    front = _num(parts, "cg_to_front_axle") + _num(parts, "front_overhang")
    return pd.DataFrame({"front": front, "rear": _num(parts, "length") - front,
                         "width": _num(parts, "width")},
                        index=pd.MultiIndex.from_arrays([parts["case_id"],
                                                         _num(parts, "participant")]))


def _start_overlap(parts: pd.DataFrame, traj: pd.DataFrame, warn: list[DataProblem]) -> None:
    """Outlines of participants 1 and 2 overlapping at the first sample of participant 2."""
    case, part = traj["case_id"].to_numpy(), traj["participant"].to_numpy()
    start = np.ones(len(traj), bool)  # first sample of each participant (rows grouped)
    start[1:] = (case[1:] != case[:-1]) | (part[1:] != part[:-1])
    first = traj.loc[start, ["case_id", "participant", "t", "x", "y", "yaw"]]
    first = first.drop_duplicates(["case_id", "participant"])
    first["participant"] = pd.to_numeric(first["participant"], errors="coerce")
    geo = _geometry(parts).reset_index()
    geo.columns = ["case_id", "participant", "front", "rear", "width"]
    poses = first.merge(geo, on=["case_id", "participant"])
    p1 = poses[poses["participant"] == 1].set_index("case_id")
    p2 = poses[poses["participant"] == 2].set_index("case_id")
    p1, p2 = p1.align(p2, join="inner", axis=0)
    if p1.empty:
        return
    # both at the first time of participant 2 when the starts agree (within a sample)
    same_start = np.abs(p1["t"].to_numpy(float) - p2["t"].to_numpy(float)) < 0.05
    c1 = outline_corners(p1["x"], p1["y"], p1["yaw"], p1["front"], p1["rear"], p1["width"])
    c2 = outline_corners(p2["x"], p2["y"], p2["yaw"], p2["front"], p2["rear"], p2["width"])
    overlap = same_start & (outline_distance(c1, c2) <= 0.0)
    _add(warn, "trajectories", "x", p1.index.to_numpy()[overlap],
         [f"the outlines of participants 1 and 2 overlap at the first sample (t={t:g} s, "
          f"centres {d:.2f} m apart): participant 2 on participant 1's path, a collision "
          "before the simulation starts" for t, d in
          zip(p2["t"].to_numpy(float)[overlap],
              np.hypot(p1["x"] - p2["x"], p1["y"] - p2["y"]).to_numpy(float)[overlap],
              strict=True)],
         "participants overlapping at the start")


def _near_miss_contact(cases: pd.DataFrame, parts: pd.DataFrame, traj: pd.DataFrame,
                       warn: list[DataProblem]) -> None:
    """Cases labelled near misses (``collision`` False) whose recorded outlines overlap.

    The outlines of both participants are compared at every time both records
    hold (sample times equal within 1 ms; records on other time grids are not
    compared); the first overlap is named.
    """
    label = cases["collision"]
    if label.dtype != bool:
        label = label.astype(str).str.strip().str.lower().isin({"true", "1", "yes"})
    near = cases.loc[~label.to_numpy(bool), "case_id"].to_numpy()
    if near.size == 0:
        return
    rows = traj[traj["case_id"].isin(near)][["case_id", "participant", "t", "x", "y", "yaw"]]
    rows = rows.assign(participant=pd.to_numeric(rows["participant"], errors="coerce"),
                       tick=np.round(rows["t"].to_numpy(float) * 1000.0))
    geo = _geometry(parts).reset_index()
    geo.columns = ["case_id", "participant", "front", "rear", "width"]
    rows = rows.merge(geo, on=["case_id", "participant"])
    one, two = rows[rows["participant"] == 1], rows[rows["participant"] == 2]
    both = one.merge(two, on=["case_id", "tick"], suffixes=("1", "2"))
    if both.empty:
        return
    c1 = outline_corners(both["x1"], both["y1"], both["yaw1"], both["front1"], both["rear1"],
                         both["width1"])
    c2 = outline_corners(both["x2"], both["y2"], both["yaw2"], both["front2"], both["rear2"],
                         both["width2"])
    hit = both[outline_distance(c1, c2) <= 0.0].drop_duplicates("case_id")
    _add(warn, "cases", "collision", hit["case_id"].to_numpy(),
         [f"labelled a near miss (collision=False) but the recorded outlines of participants "
          f"1 and 2 overlap at t={t:g} s: the label or the trajectories are wrong"
          for t in hit["t1"].to_numpy(float)],
         "near misses whose trajectories collide")


def _reconstruction(rec: pd.DataFrame, parts: pd.DataFrame, lim: ConsistencyLimits,
                    warn: list[DataProblem]) -> None:
    geo = _geometry(parts)
    ids = rec["case_id"].to_numpy()
    size = np.zeros(len(rec))
    gaps = []
    for p in (1, 2):
        g = geo.reindex(pd.MultiIndex.from_arrays([rec["case_id"], np.full(len(rec), float(p))]))
        front, rear, width = (g[c].to_numpy(float) for c in ("front", "rear", "width"))
        local = to_vehicle_frame(np.stack([_num(rec, "poi_x"), _num(rec, "poi_y")], axis=-1),
                                 _num(rec, f"x{p}"), _num(rec, f"y{p}"), _num(rec, f"yaw{p}"))
        dx = np.maximum.reduce([np.zeros(len(rec)), local[:, 0] - front, -rear - local[:, 0]])
        dy = np.maximum(0.0, np.abs(local[:, 1]) - 0.5 * width)
        gaps.append(np.hypot(dx, dy))
        size = np.maximum(size, front + rear)
    gap = np.minimum(gaps[0], gaps[1])
    far = gap > size
    _add(warn, "reconstruction", "poi_x", ids[far],
         [f"the point of impact is {d:.3g} m outside both outlines (more than their size "
          f"{s:.3g} m): POI, positions or yaw in another frame or unit?"
          for d, s in zip(gap[far], size[far], strict=True)], "POI far from both vehicles")
    for p in (1, 2):
        dvx = _num(rec, f"vx{p}_post") - _num(rec, f"vx{p}")
        dvy = _num(rec, f"vy{p}_post") - _num(rec, f"vy{p}")
        implied = wrap_angle(_num(rec, f"yaw{p}") - np.arctan2(-dvy, -dvx))  # as vfs.physics
        recorded = _num(rec, f"pdof{p}")  # rad, converted from the file's degrees
        as_radians = recorded * (180.0 / math.pi)  # the file's number read as radians
        with np.errstate(invalid="ignore"):
            valid = np.hypot(dvx, dvy) > lim.min_delta_v
            radians = (valid & (np.abs(wrap_angle(as_radians - implied)) < lim.pdof_degrees)
                       & (np.abs(wrap_angle(recorded - implied)) > 3.0 * lim.pdof_degrees))
        _add(warn, "reconstruction", f"pdof{p}", ids[radians],
             [f"pdof{p}={math.degrees(r):.4g} deg disagrees with the {math.degrees(i):.4g} deg "
              "implied by the delta-v, but matches it read as radians: pdof is specified in "
              "degrees" for r, i in zip(recorded[radians], implied[radians], strict=True)],
             "PDOF in radians?")


__all__ = ["ConsistencyLimits", "check_consistency"]
