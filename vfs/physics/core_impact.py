"""Compiled (numba) kernel of the momentum impact: one loop over the impacts.

:func:`vfs.physics.impact.solve_impact` runs this kernel by default; its numpy block
solver (``VFS_COMPILED=0``, :func:`vfs.physics.core.enabled`) is the tests' reference.
The numpy solver makes about a hundred passes over arrays of a block of impacts, each
writing a temporary array; the kernel solves each impact in registers, in one pass.

The kernel repeats the reference's arithmetic operation by operation and in the same
order of evaluation (the contact frame, the impact matrix K, the full impact
K S_C = -u of the Reconstruction chapter eq. 24, the sliding impact |T| = mu N, the
total impulse S = (1 + eps) S_C of eqs. 25-26, the momentum balances of the Collision
Calculation Uncertainty paper eqs. 6-11, the energy loss -(S.u + S^T K S / 2), the energy
split, EES, delta-v, PDOF and the velocity-angle change), with ``x * x`` where numpy
squares, Python's float remainder (numpy's sign rule) for ``np.mod``, and no
fast-math, so no fused multiply-add.  Square roots are correctly rounded in both.  The
four arctangents of an impact (the velocity-angle changes and the PDOFs) are left to
one call of numpy's ``arctan2`` over the batch, because numpy's SIMD routine and the C
library's ``atan2`` differ in the last bit for a few per cent of arguments on some
machines; sin and cos round alike in both (``tests/physics/test_core.py``).  So the
results are bit-identical (``tests/physics/test_core_impact.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_kernel: Any = None


def _wrap(a: float) -> float:
    """:func:`vfs.units.wrap_angle` of one angle [rad]: np.mod(a + pi, 2 pi) - pi, -pi -> pi."""
    # Python's float remainder is numpy's: fmod, then the sign of the divisor
    m = (a + np.pi) % (2.0 * np.pi)
    w = m - np.pi
    if w == -np.pi:
        return np.pi
    return w


def _solve_one(m1: float, m2: float, i1: float, i2: float, x1: float, x2: float,
               y1: float, y2: float, vx1: float, vx2: float, vy1: float, vy2: float,
               w1: float, w2: float, poi_x: float, poi_y: float, cp: float, eps: float,
               mu: float, normal_only: bool, out: np.ndarray) -> bool:
    """Solve one impact into ``out`` (26 values: type code, normal, closing and sliding
    speeds, impulse (t, n, x, y), then vx', vy', yaw rate', delta vx, delta vy, delta v
    of vehicles 1 and 2 in turn, the energy loss, and the arguments (y, x) of the
    arctangents of both velocity-angle changes); return whether
    the normal-only restitution created energy (the caller then solves it again with
    the impulse restitution, as the reference does).
    """
    # contact frame (vfs.physics.impact.contact_frame)
    nx0, ny0 = -math.sin(cp), math.cos(cp)
    r1x, r1y = poi_x - x1, poi_y - y1
    r2x, r2y = poi_x - x2, poi_y - y2
    u_x = (vx1 - w1 * r1y) - (vx2 - w2 * r2y)
    u_y = (vy1 + w1 * r1x) - (vy2 + w2 * r2x)
    dx, dy = x1 - x2, y1 - y2
    side = nx0 * dx + ny0 * dy
    scale = math.sqrt(dx * dx + dy * dy)
    if abs(side) <= 1e-9 * max(scale, 1.0):
        sign = 1.0 if nx0 * u_x + ny0 * u_y <= 0.0 else -1.0
    else:
        sign = 1.0 if side > 0.0 else -1.0
    nx, ny = sign * nx0, sign * ny0
    tx, ty = ny, -nx
    u_t = u_x * tx + u_y * ty
    u_n = u_x * nx + u_y * ny
    approaching = u_n < 0.0

    # impact matrix and the full impact (the Reconstruction chapter, eq. 24)
    r1t, r1n = r1x * tx + r1y * ty, r1x * nx + r1y * ny
    r2t, r2n = r2x * tx + r2y * ty, r2x * nx + r2y * ny
    inv_m = 1.0 / m1 + 1.0 / m2
    k_tt = inv_m + r1n * r1n / i1 + r2n * r2n / i2
    k_nn = inv_m + r1t * r1t / i1 + r2t * r2t / i2
    k_tn = -(r1t * r1n / i1 + r2t * r2n / i2)
    det = k_tt * k_nn - k_tn * k_tn
    un_eff = (1.0 + eps) * u_n if normal_only else u_n
    sc_t = -(k_nn * u_t - k_tn * un_eff) / det
    sc_n = -(-k_tn * u_t + k_tt * un_eff) / det
    full = abs(sc_t) <= mu * sc_n
    # sliding impact: |T| = mu N with the sign of the full-impact T
    s = 1.0 if sc_t >= 0.0 else -1.0
    denom = k_nn + s * mu * k_tn
    jam = (not full) and denom <= 1e-12 * k_nn
    full = full or jam
    if full:
        comp_t, comp_n = sc_t, sc_n
    else:
        lam = -un_eff / denom
        comp_t, comp_n = s * mu * lam, lam
    # total impulse S = (1 + eps) S_C (the Reconstruction chapter, eqs. 25-26)
    if approaching:
        gain = 1.0 if normal_only else 1.0 + eps
    else:
        gain = 0.0
    s_t, s_n = gain * comp_t, gain * comp_n
    impulse_x = s_t * tx + s_n * nx
    impulse_y = s_t * ty + s_n * ny

    # momentum balances (the Collision Calculation Uncertainty paper, eqs. 6-11)
    vx1p = vx1 + impulse_x / m1
    vy1p = vy1 + impulse_y / m1
    vx2p = vx2 - impulse_x / m2
    vy2p = vy2 - impulse_y / m2
    w1p = w1 + (r1x * impulse_y - r1y * impulse_x) / i1
    w2p = w2 - (r2x * impulse_y - r2y * impulse_x) / i2

    k_s_t = k_tt * s_t + k_tn * s_n
    k_s_n = k_tn * s_t + k_nn * s_n
    loss = -(s_t * u_t + s_n * u_n + 0.5 * (s_t * k_s_t + s_n * k_s_n))
    created = normal_only and approaching and (
        loss < -1e-12 * (abs(s_t * u_t) + abs(s_n * u_n)))
    if loss < 0.0:
        loss = 0.0

    dvx1, dvy1 = vx1p - vx1, vy1p - vy1
    dvx2, dvy2 = vx2p - vx2, vy2p - vy2
    out[0] = 0.0 if not approaching else (1.0 if full else 2.0)
    out[1], out[2], out[3], out[4] = nx, ny, -u_n, u_t
    out[5], out[6], out[7], out[8] = s_t, s_n, impulse_x, impulse_y
    out[9], out[10], out[11], out[12], out[13], out[14] = vx1p, vx2p, vy1p, vy2p, w1p, w2p
    out[15], out[16], out[17], out[18] = dvx1, dvx2, dvy1, dvy2
    out[19] = math.sqrt(dvx1 * dvx1 + dvy1 * dvy1)
    out[20] = math.sqrt(dvx2 * dvx2 + dvy2 * dvy2)
    out[21] = loss
    # the velocity-angle changes atan2(|a x b|, a.b) (vfs.physics.impact.angle_between)
    # are left to numpy's arctan2: their arguments, NaN where a speed is below 1 mm/s
    out[22] = abs(vx1 * vy1p - vy1 * vx1p)
    out[23] = vx1 * vx1p + vy1 * vy1p
    out[24] = abs(vx2 * vy2p - vy2 * vx2p)
    out[25] = vx2 * vx2p + vy2 * vy2p
    if vx1 * vx1 + vy1 * vy1 < 1e-6 or vx1p * vx1p + vy1p * vy1p < 1e-6:
        out[22] = np.nan
    if vx2 * vx2 + vy2 * vy2 < 1e-6 or vx2p * vx2p + vy2p * vy2p < 1e-6:
        out[24] = np.nan
    return created


def _energy_shares(m1: float, m2: float, ratio: float) -> float:
    """Share of the energy loss of vehicle 1 (:func:`vfs.physics.impact.energy_split`)."""
    share1 = m2 / (m1 + m2)
    if m2 == np.inf:
        share1 = 1.0
    elif m1 == np.inf:
        share1 = 0.0
    if not math.isnan(ratio):
        share1 = 1.0 / (1.0 + ratio)
    return share1


def _ees(energy: float, mass: float) -> float:
    """:func:`vfs.physics.impact.ees_from_energy` of one vehicle [m/s] (NaN stays NaN)."""
    e = 0.0 if energy < 0.0 else energy
    return math.sqrt(2.0 * e / mass)


def _finish(angles: np.ndarray, yaw: np.ndarray, itype: np.ndarray, pair: np.ndarray,
            clocks: np.ndarray) -> None:
    """Velocity-angle changes, PDOF [rad] and clock directions from the arctangents
    ``angles`` (N, 4) (:func:`vfs.physics.impact._pdof`: wrap(yaw - atan2(-S)), the clock
    rint(6 pdof / pi) mod 12 with 0 -> 12; NaN and clock 0 where there is no impact).
    """
    for k in range(angles.shape[0]):
        pair[7, k, 0], pair[7, k, 1] = angles[k, 0], angles[k, 1]
        none = itype[k] == 0
        for j in range(2):
            pdof = _wrap(yaw[k, j] - angles[k, 2 + j])
            clock = np.int64(np.rint(pdof * (6.0 / np.pi))) % 12
            pair[8, k, j] = np.nan if none else pdof
            clocks[k, j] = 0 if none else (12 if clock == 0 else clock)


def _solve_all(m: np.ndarray, izz: np.ndarray, x: np.ndarray, y: np.ndarray,
               yaw: np.ndarray, vx: np.ndarray, vy: np.ndarray, yaw_rate: np.ndarray,
               poi_x: np.ndarray, poi_y: np.ndarray, cp: np.ndarray, eps: np.ndarray,
               mu: np.ndarray, ratio: np.ndarray, normal_only: bool,
               real: np.ndarray, pair: np.ndarray, itype: np.ndarray,
               atan_y: np.ndarray, atan_x: np.ndarray) -> None:
    """Solve every impact: ``real`` (9, N) gets the impact-wide values, ``pair``
    (9, N, 2) the per-vehicle ones (one contiguous array per field), ``itype`` (N,) the
    impact type code, ``atan_y`` and ``atan_x`` (N, 4) the arguments of the four
    arctangents (both velocity-angle changes, both PDOFs).
    """
    out = np.empty(26)
    for k in range(m.shape[0]):
        args = (m[k, 0], m[k, 1], izz[k, 0], izz[k, 1], x[k, 0], x[k, 1], y[k, 0],
                y[k, 1], vx[k, 0], vx[k, 1], vy[k, 0], vy[k, 1], yaw_rate[k, 0],
                yaw_rate[k, 1], poi_x[k], poi_y[k], cp[k], eps[k], mu[k])
        created = _solve_one(*args, normal_only, out)
        if created:  # Kane's paradox: the Poisson split, as the reference falls back
            _solve_one(*args, False, out)
        m1, m2 = m[k, 0], m[k, 1]
        share1 = _energy_shares(m1, m2, ratio[k])
        loss = out[21]
        e1, e2 = loss * share1, loss * (1.0 - share1)
        itype[k] = np.int64(out[0])
        real[0, k] = loss
        for j in range(1, 9):
            real[j, k] = out[j]
        for j in range(6):  # vx', vy', yaw rate', delta vx, delta vy, delta v
            pair[j, k, 0], pair[j, k, 1] = out[9 + 2 * j], out[10 + 2 * j]
        pair[6, k, 0] = _ees(e1, m1)
        pair[6, k, 1] = _ees(e2, m2)
        atan_y[k, 0], atan_x[k, 0] = out[22], out[23]
        atan_y[k, 1], atan_x[k, 1] = out[24], out[25]
        # PDOF: the direction the force comes from, atan2(-S) for vehicle 1, atan2(S) for 2
        atan_y[k, 2], atan_x[k, 2] = -out[8], -out[7]
        atan_y[k, 3], atan_x[k, 3] = out[8], out[7]


def _compiled() -> Any:
    """The compiled kernel (compiled, or loaded from numba's cache, at the first call)."""
    global _kernel
    if _kernel is None:
        import numba

        opts = {"cache": True, "nogil": True, "error_model": "numpy"}
        g = globals()
        for name in ("_wrap", "_solve_one", "_energy_shares", "_ees"):
            g[name] = numba.njit(**opts)(g[name])
        _kernel = (numba.njit(**opts)(_solve_all), numba.njit(**opts)(_finish))
    return _kernel


def _column(a: np.ndarray, n: int, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` as a C-contiguous float64 array of ``shape`` (broadcast where needed)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=np.float64), shape))


def solve_compiled(config: Any, stiffness_ratio: np.ndarray | None,
                   normal_only: bool) -> dict[str, np.ndarray]:
    """Solve the impacts of an :class:`~vfs.physics.impact.ImpactConfig` with the kernel.

    Parameters
    ----------
    config : ImpactConfig
        Configurations (N,), SI units (checked by the caller).
    stiffness_ratio : ndarray (N,) or None
        k1 / k2 of the energy split; NaN or None: the mass rule.
    normal_only : bool
        The normal-only (Brach) restitution instead of the impulse restitution.

    Returns
    -------
    dict
        The fields of :class:`~vfs.physics.impact.ImpactResult` by name.
    """
    c = config
    n = int(np.shape(c.poi_x)[0])
    two, one = (n, 2), (n,)
    ratio = (np.full(n, np.nan) if stiffness_ratio is None
             else _column(stiffness_ratio, n, one))
    real = np.empty((9, n))
    pair = np.empty((9, n, 2))
    itype = np.empty(n, dtype=np.int64)
    clocks = np.empty((n, 2), dtype=np.int64)
    atan_y, atan_x = np.empty((n, 4)), np.empty((n, 4))
    solve, finish = _compiled()
    solve(
        _column(c.m, n, two), _column(c.izz, n, two), _column(c.x, n, two),
        _column(c.y, n, two), _column(c.yaw, n, two), _column(c.vx, n, two),
        _column(c.vy, n, two), _column(c.yaw_rate, n, two), _column(c.poi_x, n, one),
        _column(c.poi_y, n, one), _column(c.cp_angle, n, one),
        _column(c.restitution, n, one), _column(c.contact_friction, n, one), ratio,
        bool(normal_only), real, pair, itype, atan_y, atan_x)
    # numpy's arctan2, as in the reference (its SIMD routines and the C library's atan2
    # differ in the last bit for a few per cent of arguments on some machines)
    finish(np.arctan2(atan_y, atan_x), _column(c.yaw, n, two), itype, pair, clocks)
    return {
        "impact_type": itype, "normal_x": real[1], "normal_y": real[2],
        "closing_speed": real[3], "sliding_speed": real[4], "impulse_t": real[5],
        "impulse_n": real[6], "impulse_x": real[7], "impulse_y": real[8],
        "vx_post": pair[0], "vy_post": pair[1], "yaw_rate_post": pair[2],
        "delta_vx": pair[3], "delta_vy": pair[4], "delta_v": pair[5],
        "energy_loss": real[0], "ees": pair[6], "velocity_angle_change": pair[7],
        "pdof": pair[8], "pdof_clock": clocks,
    }


__all__ = ["solve_compiled"]
