"""Confidence intervals that behave at the edges: Wilson for shares, BCa for skewed statistics.

Re-exported by :mod:`vfs.analysis.stats`; the reasons and measured coverage are in
``docs/statistics.md`` ("Intervals at the edges").
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError


def _sps() -> Any:
    """:mod:`scipy.stats`, imported on first use (it costs about 0.5 s; the command line and
    the study import this module without needing it).
    """
    from scipy import stats

    return stats

def _check_level(confidence: float) -> None:
    """Raise ParameterError unless ``confidence`` lies in (0, 1)."""
    try:
        ok = 0.0 < float(confidence) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ParameterError(f"confidence={confidence!r} must lie in the open interval (0, 1)")


def wilson_interval(successes: npt.ArrayLike, n: npt.ArrayLike, confidence: float = 0.95,
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval of a share p = successes / n (vectorised).

    ``low, high = (p + z^2/(2n) -+ z sqrt(p(1-p)/n + z^2/(4n^2))) / (1 + z^2/n)`` with z the
    two-sided normal quantile of ``confidence``.  Unlike the Wald or percentile-bootstrap
    interval it does not collapse to a point at 0 or 100 %: 0 successes of n give
    [0, z^2 / (n + z^2)].  Weighted data enter through an effective n (e.g. Kish's
    (sum w)^2 / sum w^2) and ``successes = p n``; non-integer values are allowed.

    Parameters
    ----------
    successes, n : array_like
        Counts (broadcast together), 0 <= successes <= n.  Where n <= 0 or a value is NaN
        the interval is NaN.
    confidence : float, optional
        Level of the interval in (0, 1) (default 0.95).

    Returns
    -------
    low, high : ndarray
        Interval ends in [0, 1].

    Raises
    ------
    ParameterError
        confidence outside (0, 1), or successes outside [0, n].

    Examples
    --------
    >>> low, high = wilson_interval(0, 10)
    >>> float(low), round(float(high), 4)
    (0.0, 0.2775)
    """
    _check_level(confidence)
    k = np.asarray(successes, float)
    m = np.asarray(n, float)
    k, m = np.broadcast_arrays(k, m)
    ok = np.isfinite(k) & np.isfinite(m) & (m > 0)
    tol = 1e-9 * np.where(ok, m, 1.0)
    if np.any(ok & ((k < -tol) | (k > m + tol))):
        bad = int(np.flatnonzero(ok & ((k < -tol) | (k > m + tol)))[0])
        raise ParameterError(f"wilson_interval: successes {float(k.flat[bad]):g} outside "
                             f"[0, n = {float(m.flat[bad]):g}]")
    z = float(_sps().norm.ppf(0.5 * (1.0 + confidence)))
    with np.errstate(divide="ignore", invalid="ignore"):
        mm = np.where(ok, m, 1.0)
        p = np.clip(np.where(ok, k, 0.0) / mm, 0.0, 1.0)
        centre = (p + z * z / (2 * mm)) / (1 + z * z / mm)
        half = z * np.sqrt(p * (1 - p) / mm + z * z / (4 * mm * mm)) / (1 + z * z / mm)
    low = np.where(ok, np.clip(centre - half, 0.0, 1.0), np.nan)
    high = np.where(ok, np.clip(centre + half, 0.0, 1.0), np.nan)
    # exact ends at the boundary (the formula gives them up to rounding)
    low = np.where(ok & (p == 0.0), 0.0, low)
    high = np.where(ok & (p == 1.0), 1.0, high)
    return low, high


def bca_interval(boot: npt.ArrayLike, estimate: float, jackknife: npt.ArrayLike,
                 confidence: float = 0.95) -> tuple[float, float]:
    """Bias-corrected and accelerated (BCa) bootstrap interval (Efron 1987).

    ``z0 = Phi^-1(share of replicates below the estimate, ties counted half)``,
    acceleration ``a = sum d^3 / (6 (sum d^2)^1.5)`` with ``d = mean(jack) - jack_i``; the
    interval ends are the replicate quantiles at ``Phi(z0 + (z0 + z) / (1 - a (z0 + z)))`` for
    ``z = Phi^-1((1 -+ confidence) / 2)``.  It corrects the percentile interval for the bias
    and skewness of a statistic such as a ratio of sums.  Falls back to the percentile
    interval where z0 or a is undefined (all replicates on one side of the estimate, or a
    constant jackknife).

    Parameters
    ----------
    boot : array_like (B,)
        Bootstrap replicates of the statistic; non-finite ones are dropped.
    estimate : float
        The statistic on the data.
    jackknife : array_like (n,)
        Leave-one-case-out values of the statistic; non-finite ones are dropped.
    confidence : float, optional
        Level in (0, 1) (default 0.95).

    Returns
    -------
    low, high : float
        NaN if there is no finite replicate.
    """
    _check_level(confidence)
    b = np.asarray(boot, float).ravel()
    b = b[np.isfinite(b)]
    if b.size == 0 or not np.isfinite(estimate):
        return math.nan, math.nan
    alphas = np.array([0.5 * (1 - confidence), 0.5 * (1 + confidence)])
    below = (np.count_nonzero(b < estimate) + 0.5 * np.count_nonzero(b == estimate)) / b.size
    jack = np.asarray(jackknife, float).ravel()
    jack = jack[np.isfinite(jack)]
    d = jack.mean() - jack if jack.size else jack
    ss = float(np.sum(d * d))
    if 0.0 < below < 1.0 and ss > 0.0:
        z0 = float(_sps().norm.ppf(below))
        a = float(np.sum(d ** 3)) / (6.0 * ss ** 1.5)
        zq = _sps().norm.ppf(alphas)
        alphas = _sps().norm.cdf(z0 + (z0 + zq) / (1.0 - a * (z0 + zq)))
    lo, hi = np.quantile(b, np.clip(alphas, 0.0, 1.0), method="inverted_cdf")
    return float(lo), float(hi)


__all__ = ["bca_interval", "wilson_interval"]
