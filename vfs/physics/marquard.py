"""Marquard's energy relations: the post-impact speed from the run-out to rest.

A reconstruction works backwards from the rest positions: a vehicle that slid a
distance s [m] to rest while turning by dphi [rad] had, just after the impact, the
speed V' for which the work of the tyre forces over the run-out used up its kinetic
energy.  Marquard's relations with empirical correction factors, as printed in
"Analysis of uncertainty in vehicle collision calculation methods" (eqs. 3, 5, 12
and 13)::

    k      = |dphi| l / (2 s)                          rotation factor (eq. 5)
    k_s    = 0.17 k^3 - 0.488 k^2 - 0.03 k + 1         translation factor (eq. 3)
    V_k    = sqrt(V'^2 - 2 k_s mu g s)                 speed left after s (eq. 12)
    0 < V_k < 0.5 m/s                                  "at rest" (eq. 13)

so at rest (V_k = 0) V' = sqrt(2 k_s mu g s), with l the vehicle length [m] and mu
the friction coefficient *used* by the braking (road friction x the utilisation of
the braking forces: 1 for four locked wheels).  The printed eq. 5 reads
"|(dphi - 1) / (2 s)|" in our copy of the paper, and its legend defines l, the
vehicle length, which the formula then does not use; the dimensionless rotation
factor needs a length over a length, so we read it as dphi l / (2 s) (rotation path
of the vehicle's ends, l dphi / 2, over the translation s).  For a straight slide
(dphi = 0) it is the textbook V' = sqrt(2 mu g s).

**Range.**  The paper prints the cubic without the range of k it was fitted on, and
no other source of ours gives one.  The cubic itself bounds where it can describe the
physics: the more the vehicle turns per metre, the smaller the share of the tyre
work that brakes the translation, so k_s must fall with k.  It does so from k = 0
(k_s = 1) to its minimum at :data:`ROTATION_FACTOR_MAX` ~= 1.944 (k_s ~= 0.346), the
root of dk_s/dk = 0.51 k^2 - 0.976 k - 0.03; beyond it the cubic rises again
(k_s(3) ~= 1.11: a spinning car would need *more* speed than a straight slide of the
same length), which no physics supports.  vfs therefore treats k > ROTATION_FACTOR_MAX
as outside the fit and returns NaN there (no clamping: at the edge k_s is still
falling, so the edge value would overstate V' for any larger k); use the run-out
model (:mod:`vfs.physics.runout`) for such spins.

The paper's eq. 4 (a "rotation share" k_phi = 0.328 k^3 - 0.772 k^2 + 1.072 k) enters
none of its equations, and the paper does not say what it multiplies; vfs leaves it
out rather than guess.

vfs integrates the run-out with a tyre model (:mod:`vfs.physics.runout`); these
relations are the analytic cross-check (:func:`vfs.analysis.marquard.marquard_check`),
not the model.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from vfs.units import G

#: Coefficients of k_s(k) (eq. 3), highest power first [-].
TRANSLATION_FACTOR_COEFFICIENTS: tuple[float, float, float, float] = (0.17, -0.488, -0.03, 1.0)


def _falling_range_end() -> float:
    """The k >= 0 where dk_s/dk = 0: the end of the range where k_s falls with k [-]."""
    roots = np.roots(np.polyder(np.array(TRANSLATION_FACTOR_COEFFICIENTS)))
    return float(max(r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0.0))


#: Largest rotation factor k [-] within which the fitted k_s falls with k (module
#: docstring, "Range"): ~= 1.944.
ROTATION_FACTOR_MAX: float = _falling_range_end()
#: Eq. 13: a run-out has reached rest when the speed left is below this [m/s].
REST_SPEED = 0.5


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


def within_fitted_range(k: npt.ArrayLike) -> np.ndarray:
    """True where 0 <= k <= :data:`ROTATION_FACTOR_MAX` (module docstring, "Range")."""
    k = np.asarray(k, float)
    return (k >= 0.0) & (k <= ROTATION_FACTOR_MAX)


def translation_factor(k: npt.ArrayLike) -> np.ndarray:
    """Marquard's translation factor k_s [-] (eq. 3); NaN outside the fitted range.

    Parameters
    ----------
    k : array_like
        Rotation factor [-] (:func:`rotation_factor`).
    """
    k = np.asarray(k, float)
    return np.where(within_fitted_range(k),
                    np.polyval(np.array(TRANSLATION_FACTOR_COEFFICIENTS), k), np.nan)


def _k(distance: np.ndarray, rotation: npt.ArrayLike, length: npt.ArrayLike) -> np.ndarray:
    return np.where(distance > 0.0, rotation_factor(rotation, length,
                                                    np.where(distance > 0, distance, 1.0)), 0.0)


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
        V' [m/s]; NaN where the rotation factor k exceeds
        :data:`ROTATION_FACTOR_MAX` (outside the range the cubic can describe).

    Examples
    --------
    A straight slide of 6.37 m on locked wheels, mu = 0.8: V' = sqrt(2 mu g s).

    >>> round(float(post_impact_speed(6.37, 0.0, 4.5, 0.8)), 2)
    10.0
    """
    s = np.asarray(distance, float)
    k_s = translation_factor(_k(s, rotation, length))
    return np.sqrt(2.0 * k_s * np.asarray(friction, float) * G * s)


def remaining_speed(post_speed: npt.ArrayLike, distance: npt.ArrayLike,
                    rotation: npt.ArrayLike, length: npt.ArrayLike,
                    friction: npt.ArrayLike) -> np.ndarray:
    """Speed V_k [m/s] left after the run-out s, dphi from V' (eq. 12, forward form).

    The forward form the paper's Monte-Carlo script uses: V_k = sqrt(V'^2 - 2 k_s mu g
    s); 0 where the tyre work exceeds the kinetic energy (the vehicle stopped before s),
    NaN outside the fitted range of k.

    Parameters
    ----------
    post_speed : array_like
        Post-impact speed V' [m/s].
    distance, rotation, length, friction
        As in :func:`post_impact_speed` [m, rad, m, -].
    """
    s = np.asarray(distance, float)
    k_s = translation_factor(_k(s, rotation, length))
    left = np.asarray(post_speed, float) ** 2 - 2.0 * k_s * np.asarray(friction, float) * G * s
    return np.where(np.isnan(left), np.nan, np.sqrt(np.maximum(left, 0.0)))


def reaches_rest(remaining: npt.ArrayLike) -> np.ndarray:
    """Eq. 13: 0 < V_k < 0.5 m/s, the paper's criterion for an accepted speed pair.

    The paper's strict lower bound rejects V_k = 0 (the vehicle would have stopped
    before reaching its rest position: too little speed); NaN is never accepted.

    Parameters
    ----------
    remaining : array_like
        V_k [m/s] (:func:`remaining_speed`).
    """
    v = np.asarray(remaining, float)
    return (v > 0.0) & (v < REST_SPEED)


__all__ = ["REST_SPEED", "ROTATION_FACTOR_MAX", "TRANSLATION_FACTOR_COEFFICIENTS",
           "post_impact_speed", "reaches_rest", "remaining_speed", "rotation_factor",
           "translation_factor", "within_fitted_range"]
