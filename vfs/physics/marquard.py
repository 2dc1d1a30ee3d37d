"""Marquard's energy relations: the post-impact speed from the run-out to rest.

A reconstruction works backwards from the rest positions: a vehicle that slid a
distance s [m] to rest while turning by dphi [rad] had, just after the impact, the
speed V' for which the work of the tyre forces over the run-out used up its kinetic
energy.  Marquard's relations with empirical correction factors, as printed in
"Analysis of uncertainty in vehicle collision calculation methods" (eqs. 3-5, and
eq. 12 at rest, V_k = 0)::

    k      = |dphi| l / (2 s)                          rotation factor (eq. 5)
    k_s    = 0.17 k^3 - 0.488 k^2 - 0.03 k + 1         translation factor (eq. 3)
    k_phi  = 0.328 k^3 - 0.772 k^2 + 1.072 k           rotation share (eq. 4)
    V'     = sqrt(2 k_s mu g s)                        (eq. 12 with V_k = 0)

with l the vehicle length [m] and mu the friction coefficient *used* by the braking
(road friction x the utilisation of the braking forces: 1 for four locked wheels).
The printed eq. 5 reads "|(dphi - 1) / (2 s)|" in our copy of the paper, and its
legend defines l, the vehicle length, which the formula then does not use; the
dimensionless rotation factor needs a length over a length, so we read it as
dphi l / (2 s) (rotation path of the vehicle's ends, l dphi / 2, over the
translation s).  For a straight slide (dphi = 0) it is the textbook
V' = sqrt(2 mu g s).

vfs integrates the run-out with a tyre model (:mod:`vfs.physics.runout`); these
relations are the analytic cross-check (:func:`vfs.analysis.marquard.marquard_check`),
not the model.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from vfs.units import G


def rotation_factor(rotation: npt.ArrayLike, length: npt.ArrayLike,
                    distance: npt.ArrayLike) -> np.ndarray:
    """Marquard's rotation factor k = |dphi| l / (2 s) [-] (eq. 5).

    Parameters
    ----------
    rotation : array_like
        Yaw change dphi from separation to rest [rad].
    length : array_like
        Vehicle length l [m].
    distance : array_like
        Distance s of the centre of gravity from separation to rest [m] (> 0).
    """
    s = np.asarray(distance, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(np.asarray(rotation, float)) * np.asarray(length, float) / (2.0 * s)


def correction_factors(k: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Marquard's translation factor k_s (eq. 3) and rotation share k_phi (eq. 4) [-]."""
    k = np.asarray(k, float)
    k_s = 0.17 * k**3 - 0.488 * k**2 - 0.03 * k + 1.0
    k_phi = 0.328 * k**3 - 0.772 * k**2 + 1.072 * k
    return k_s, k_phi


def post_impact_speed(distance: npt.ArrayLike, rotation: npt.ArrayLike,
                      length: npt.ArrayLike, friction: npt.ArrayLike) -> np.ndarray:
    """Post-impact speed V' [m/s] of a vehicle that ran out to rest (eq. 12, V_k = 0).

    Parameters
    ----------
    distance : array_like
        Distance s of the centre of gravity from separation to rest [m].
    rotation : array_like
        Yaw change dphi from separation to rest [rad].
    length : array_like
        Vehicle length l [m].
    friction : array_like
        Friction coefficient used by the braking, mu [-] (road friction x
        utilisation of the braking forces).

    Returns
    -------
    ndarray
        V' [m/s]; NaN where the factor k_s is not positive (k beyond the range the
        empirical cubic was fitted for).

    Examples
    --------
    A straight slide of 6.37 m on locked wheels, mu = 0.8: V' = sqrt(2 mu g s).

    >>> round(float(post_impact_speed(6.37, 0.0, 4.5, 0.8)), 2)
    10.0
    """
    s = np.asarray(distance, float)
    k = np.where(s > 0.0, rotation_factor(rotation, length, np.where(s > 0, s, 1.0)), 0.0)
    k_s, _ = correction_factors(k)
    with np.errstate(invalid="ignore"):
        return np.where(k_s > 0.0, np.sqrt(2.0 * np.maximum(k_s, 0.0)
                                           * np.asarray(friction, float) * G * s), np.nan)


__all__ = ["correction_factors", "post_impact_speed", "rotation_factor"]
