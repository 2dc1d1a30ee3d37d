"""Marquard cross-check of the run-out: analytic post-impact speeds from the rest positions.

For every vehicle that ran out after an impact, :func:`marquard_check` puts the
post-impact speed of the simulation (the impulse model's output) beside the speed that
Marquard's energy relations (:mod:`vfs.physics.marquard`) infer from where the run-out
model brought the vehicle to rest: the distance of its centre of gravity from the
separation to the rest position, its rotation, its length, and the friction its
braking used (road friction x the mean brake factor of its wheels).  Where the two
agree, the tyre-model run-out dissipates energy as the reconstruction rule of thumb
assumes; where they disagree, a reconstruction that infers speeds from rest positions
with Marquard's relations would not recover the simulated speeds.  docs/physics.md
gives the figures on the bundled database.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from vfs.physics.marquard import post_impact_speed, rotation_factor, within_fitted_range


def braking_friction(road_friction: np.ndarray, wheel_brake: np.ndarray,
                     rolling_resistance: float) -> np.ndarray:
    """Friction coefficient the run-out's braking uses on a straight path [-].

    Per wheel: mu on a locked wheel (b >= 1, sliding: no rolling resistance), b mu + f_r
    on a rolling braked one (the run-out model's longitudinal force, with f_r the rolling
    resistance coefficient); the mean over the four wheels (equal loads on a straight
    path, the assumption of Marquard's relations too).
    """
    mu = np.asarray(road_friction, float)[:, None]
    b = np.asarray(wheel_brake, float)
    per_wheel = np.where(b >= 1.0, mu, b * mu + rolling_resistance)
    return np.asarray(per_wheel.mean(axis=1))


def marquard_check(batch: Any, results: Any, params: Any = None) -> pd.DataFrame:
    """Marquard's post-impact speed against the simulation's, per vehicle (SI units).

    Parameters
    ----------
    batch : vfs.simulation.CaseBatch
        The simulated cases.
    results : vfs.simulation.CaseResults
        Their results (:func:`vfs.simulation.simulate_cases`).
    params : vfs.physics.runout.RunoutParams, optional
        The run-out parameters of the simulation (rolling resistance); default
        ``RunoutParams()``.

    Returns
    -------
    pandas.DataFrame
        One row per vehicle of every case with an impact (fixed objects left out):
        ``case_id``, ``vehicle``, ``distance`` [m] (straight line from separation to
        rest), ``rotation`` [rad], ``rotation_factor`` k [-], ``friction`` [-] (used by
        the braking), ``speed_model`` and ``speed_marquard`` [m/s], ``ratio``
        (Marquard / model), ``secondary_collision``, ``at_rest`` and
        ``within_fitted_range`` (k <= :data:`vfs.physics.marquard.ROTATION_FACTOR_MAX`).
        Rows whose run-out did not reach rest, or whose k lies outside the range the
        cubic can describe, have NaN ``speed_marquard``.
    """
    from vfs.physics.runout import RunoutParams

    f_r = (params or RunoutParams()).rolling_resistance
    imp, pre, run = results.impact, results.precrash, results.runout
    hit = np.flatnonzero(imp.impact_type > 0)
    rows = []
    fixed = getattr(batch, "fixed_object", None)
    brake = np.asarray(results.wheel_brake, float)  # (N, 2, 4)
    for i, veh in enumerate((batch.vehicle1, batch.vehicle2)):
        x0, y0 = pre.impact_state.x[hit, i], pre.impact_state.y[hit, i]
        yaw0 = pre.impact_state.yaw[hit, i]
        vx = imp.vx_post[hit, i]
        vy = imp.vy_post[hit, i]
        dist = np.hypot(run.rest_x[hit, i] - x0, run.rest_y[hit, i] - y0)
        rot = run.rest_yaw[hit, i] - yaw0
        length = np.asarray(veh.length, float)[hit]
        mu = braking_friction(np.asarray(batch.road_friction, float)[hit], brake[hit, i], f_r)
        at_rest = np.asarray(run.at_rest, bool)[hit, i]
        v_m = np.where(at_rest, post_impact_speed(dist, rot, length, mu), np.nan)
        speed = np.hypot(vx, vy)
        keep = np.ones(hit.size, bool) if fixed is None else ~np.asarray(fixed, bool)[hit, i]
        with np.errstate(divide="ignore", invalid="ignore"):
            rows.append(pd.DataFrame({
                "case_id": np.asarray(batch.case_id)[hit], "vehicle": i + 1,
                "distance": dist, "rotation": rot,
                "rotation_factor": rotation_factor(rot, length, dist), "friction": mu,
                "within_fitted_range": within_fitted_range(rotation_factor(rot, length, dist)),
                "speed_model": speed, "speed_marquard": v_m, "ratio": v_m / speed,
                "secondary_collision": np.asarray(run.secondary_collision, bool)[hit],
                "at_rest": at_rest,
            })[keep])
    return pd.concat(rows, ignore_index=True).sort_values(["case_id", "vehicle"],
                                                           ignore_index=True)


def summarise(check: pd.DataFrame) -> pd.DataFrame:
    """Median ratio, its 10-90 % spread and the share within +-10 % and +-20 %, by
    rotation-factor band and secondary collision (rows with a finite ratio and a speed
    above 1 m/s).
    """
    ok = check[np.isfinite(check["ratio"]) & (check["speed_model"] > 1.0)].copy()
    ok["band"] = pd.cut(ok["rotation_factor"], [-np.inf, 0.1, 0.5, 1.0, np.inf],
                        labels=["k < 0.1", "0.1-0.5", "0.5-1", "k > 1"])
    out = []
    for (band, sec), g in ok.groupby(["band", "secondary_collision"], observed=True):
        r = g["ratio"].to_numpy()
        out.append({"rotation_factor": band, "secondary_collision": bool(sec), "n": r.size,
                    "median_ratio": float(np.median(r)), "p10": float(np.quantile(r, 0.1)),
                    "p90": float(np.quantile(r, 0.9)),
                    "within_10pct": float(np.mean(np.abs(r - 1) <= 0.1)),
                    "within_20pct": float(np.mean(np.abs(r - 1) <= 0.2))})
    return pd.DataFrame(out)


__all__ = ["braking_friction", "marquard_check", "summarise"]
