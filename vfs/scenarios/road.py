"""Roads and manoeuvres of scene participants, and the sampled paths that follow them.

A road is a straight line or a circular arc (curvilinear coordinates u along, l to the left
of the centreline); a manoeuvre is a heading offset to the road along the distance before
the impact; with the speed profile they give the trajectory samples.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vfs.scenarios.speed_profile import IDLE_DECEL, IDLE_JERK, NO_BRAKE, longitudinal_motion

#: Lane width [m].
LANE_WIDTH = 3.5

#: Per-participant parameters of a scene, in the order of the arrays of a batch.
PART_FIELDS = (
    "v_travel", "brake_time", "jerk", "decel",
    "road_x", "road_y", "road_theta", "road_k", "direction", "u_star", "l_star",
    "ramp_angle", "ramp_dist", "bump_angle", "bump_start", "bump_dist",
    "turn_curv", "turn_dist",
)
PART_DEFAULTS = {"brake_time": NO_BRAKE, "jerk": IDLE_JERK, "decel": IDLE_DECEL,
                 "direction": 1.0, "ramp_dist": 1.0, "bump_dist": 1.0}


def new_part(n: int) -> dict[str, np.ndarray]:
    """Parameters (:data:`PART_FIELDS`) of n participants, filled with the defaults."""
    return {f: np.full(n, PART_DEFAULTS.get(f, 0.0)) for f in PART_FIELDS}


def heading_offset(p: Mapping[str, np.ndarray], sigma: np.ndarray) -> np.ndarray:
    """Heading offset to the road [rad] at distances ``sigma`` [m] before the impact.

    Sum of a raised-cosine ramp (amplitude ``ramp_angle`` reached at the impact, built
    over ``ramp_dist`` [m], held after the impact), a sin^2 bump (``bump_angle`` between
    ``bump_start`` and ``bump_start + bump_dist`` [m] before the impact) and a turning arc
    (curvature ``turn_curv`` [1/m] over the last ``turn_dist`` [m] before the impact,
    continued after it up to a heading change of 90 deg).
    """
    x = np.clip(sigma / np.maximum(p["ramp_dist"], 1e-6), 0.0, 1.0)
    phi = p["ramp_angle"] * 0.5 * (1.0 + np.cos(np.pi * x))
    xb = (sigma - p["bump_start"]) / np.maximum(p["bump_dist"], 1e-6)
    phi = phi + np.where((xb > 0.0) & (xb < 1.0), p["bump_angle"] * np.sin(np.pi * xb) ** 2,
                         0.0)
    curv = p["turn_curv"]
    with np.errstate(divide="ignore", invalid="ignore"):
        quarter = np.where(curv > 0.0, 0.5 * np.pi / curv, 0.0)
    arc = np.clip(p["turn_dist"] - sigma, 0.0, quarter)
    return phi + curv * arc


def road_point(k: np.ndarray, u: np.ndarray, l: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Road-frame point (x, y) [m] and road direction [rad] at curvilinear (u, l) [m].

    The centreline passes the origin in direction +x with curvature k [1/m] (positive =
    left); l is measured along its left normal.  Stable for k -> 0.
    """
    ku = k * u
    cx = u * np.sinc(ku / np.pi)  # sin(ku) / k
    cy = u * np.sin(0.5 * ku) * np.sinc(ku / (2.0 * np.pi))  # (1 - cos(ku)) / k
    return cx - l * np.sin(ku), cy + l * np.cos(ku), ku


def road_coords(k: np.ndarray, x: np.ndarray, y: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Curvilinear (u, l) [m] of road-frame points (x, y) [m] (inverse of road_point)."""
    straight = np.abs(k) < 1e-9
    kk = np.where(straight, 1.0, k)
    sign = np.sign(kk)
    rx, ry = x, y - 1.0 / kk
    rho = np.hypot(rx, ry)
    l = 1.0 / kk - sign * rho
    u = np.arctan2(rx * sign, -ry * sign) / kk
    return np.where(straight, x, u), np.where(straight, y, l)


def _cumtrapz(values: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of values d(sigma) along axis 1 (0 at column 0)."""
    out = np.zeros_like(values)
    np.cumsum(0.5 * (values[:, 1:] + values[:, :-1]) * np.diff(sigma, axis=1), axis=1,
              out=out[:, 1:])
    return out


def build_paths(p: Mapping[str, np.ndarray], k_star: np.ndarray, m: int,
                dt: float) -> dict[str, np.ndarray]:
    """Samples x, y [m], yaw [rad], speed [m/s], accel [m/s^2] of n paths, shape (n, m).

    Sample j is at t = j dt; the impact is at sample ``k_star``.
    """
    n = k_star.shape[0]
    col = {name: p[name][:, None] for name in PART_FIELDS}
    tau = (np.arange(m)[None, :] - k_star[:, None]) * dt
    pos, speed, accel = longitudinal_motion(tau, col["v_travel"], col["brake_time"], col["jerk"],
                                col["decel"])
    pos0 = longitudinal_motion(np.zeros((n, 1)), col["v_travel"], col["brake_time"], col["jerk"],
                   col["decel"])[0]
    sigma = pos0 - pos
    phi = heading_offset(col, sigma)
    rows = np.arange(n)
    d, k = col["direction"], col["road_k"]
    f = _cumtrapz(np.sin(phi), sigma)
    l = col["l_star"] - d * (f - f[rows, k_star][:, None])
    f = _cumtrapz(np.cos(phi) / (1.0 - k * l), sigma)
    u = col["u_star"] - d * (f - f[rows, k_star][:, None])
    xr, yr, theta = road_point(k, u, l)
    c0, s0 = np.cos(col["road_theta"]), np.sin(col["road_theta"])
    x = col["road_x"] + c0 * xr - s0 * yr
    y = col["road_y"] + s0 * xr + c0 * yr
    yaw = col["road_theta"] + theta + np.where(d < 0.0, np.pi, 0.0) + phi
    return {"x": x, "y": y, "yaw": yaw, "speed": speed, "accel": accel}
