"""Robust fits of one channel against one feature, the regressions of :mod:`vfs.diagnosis.learn`.

* Closed forms (:data:`vfs.effects.learned.FORMS`): the linear coefficients by weighted
  least squares (normal equations), the nonlinear one by a grid and nested grids around
  its best point (:func:`zoom_minimum`; the step's threshold: the midpoints between the
  data values around the best grid point); robustly (:func:`fit_form`) an M-estimate,
  iteratively reweighted least squares with Huber's, then Tukey's biweight weights of the
  standardised residuals sqrt(w) (y - f(x)), scale their normal-consistent MAD.
* Smoothing splines (:func:`scipy.interpolate.make_smoothing_spline`, smoothness by
  generalised cross-validation, :func:`gcv_smoothing`); robustly (:func:`robust_spline`)
  with Tukey's biweight weights of the residuals from a running median along the feature.

Units: x in the feature's, y in the channel's; weights w = 1 / sigma^2 of the identified
values.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from vfs.effects.learned import FORMS, evaluate_law

#: Tuning constants of the robust fits: Huber's and Tukey's biweight (95 % efficiency
#: for normal errors), in units of the robust scale of the standardised residuals.
HUBER_C = 1.345
BIWEIGHT_C = 4.685
#: Most reweighting iterations of each stage of a robust fit of a closed form (:func:`irls`).
ROBUST_ITERATIONS = 10
#: Half-width (in cases, ranked by the feature) of the running median against which a
#: smoothing spline's robust weights are taken: a window of 2 k + 1 neighbours.
RUNNING_MEDIAN_HALF_WIDTH = 5


def wls(cols: Sequence[np.ndarray], y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least-squares coefficients of the basis columns ``cols`` (each (n,))."""
    a = np.stack(cols, axis=1) * np.sqrt(w)[:, None]
    coef, *_ = np.linalg.lstsq(a, y * np.sqrt(w), rcond=None)
    return np.asarray(coef, float)


def fit_form_ls(form: str, x: np.ndarray, y: np.ndarray, w: np.ndarray,
                 near: float | None = None) -> list[float]:
    """Weighted least-squares coefficients of a closed form (:data:`FORMS`); ``near``
    restricts the search of the nonlinear coefficient to the grid cells around it.
    """
    one = np.ones_like(x)
    if form == "constant":
        return [float(np.sum(w * y) / np.sum(w))]
    if form == "linear":
        return [float(v) for v in wls([one, x], y, w)]

    sw, swy = float(np.sum(w)), w * y
    sy = float(np.sum(swy))

    def basis(c: np.ndarray) -> np.ndarray:
        # the basis function of each nonlinear coefficient c (..., 1) at the cases
        with np.errstate(over="ignore", invalid="ignore"):
            if form == "power":
                return np.asarray(np.maximum(x, 1e-9) ** c)
            if form == "exponential":
                return np.exp(c * x)
            if form == "saturating":
                return 1.0 - np.exp(-np.maximum(x, 0.0) / np.maximum(c, 1e-9))
            return (x >= c).astype(float)  # step

    def sse_many(cs: np.ndarray) -> np.ndarray:
        # the weighted SSE of :func:`inner` for many nonlinear coefficients at once (the
        # same normal equations; inf where inner would give inf or its lstsq fallback)
        b = basis(np.asarray(cs, float)[:, None])  # (g, n)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            wb = w * b
            sbb, sby = np.sum(wb * b, axis=1), wb @ y
            if form in ("power", "exponential"):
                pred = (sby / sbb)[:, None] * b
                ok = sbb > 0
            else:
                sb = np.sum(wb, axis=1)
                det = sw * sbb - sb * sb
                ok = det > 1e-12 * sw * sbb
                a0, a1 = (sbb * sy - sb * sby) / det, (sw * sby - sb * sy) / det
                pred = a0[:, None] + a1[:, None] * b
            sse = ((y - pred) ** 2) @ w
        return np.where(ok & np.isfinite(b).all(axis=1) & np.isfinite(sse), sse, np.inf)

    def inner(c: float) -> tuple[float, list[float]]:
        # weighted least squares of the linear coefficients for a given nonlinear one,
        # by the normal equations of the one or two basis functions (lstsq where singular)
        b = basis(np.asarray(c, float))
        if not np.isfinite(b).all():
            return math.inf, []
        wb = w * b
        sbb, sby = float(np.dot(wb, b)), float(np.dot(wb, y))
        if form in ("power", "exponential"):
            if not sbb > 0:
                return math.inf, []
            a = sby / sbb
            pred, coef = a * b, [a, c]
        else:
            sb = float(np.sum(wb))
            det = sw * sbb - sb * sb
            if det > 1e-12 * sw * sbb:
                a0, a1 = (sbb * sy - sb * sby) / det, (sw * sby - sb * sy) / det
            else:  # b constant on the weighted cases: the minimum-norm solution
                a0, a1 = (float(v) for v in wls([one, b], y, w))
            pred, coef = a0 + a1 * b, [a0, a1, c]
        sse = float(np.dot(w, (y - pred) ** 2))
        return (sse if math.isfinite(sse) else math.inf), coef

    span = float(np.ptp(x)) or 1.0
    if form == "power":
        grid = np.linspace(-3.0, 3.0, 25)
    elif form == "exponential":
        grid = np.linspace(-5.0, 5.0, 25) / span
    elif form == "saturating":
        grid = span * np.geomspace(0.02, 5.0, 25)
    else:
        grid = np.unique(np.quantile(x, np.linspace(0.05, 0.95, 37)))
    if near is not None and math.isfinite(near):
        k = int(np.argmin(np.abs(grid - near)))
        grid = np.unique(np.append(grid[max(k - 2, 0):k + 3], near))
    def best_of(cs: np.ndarray) -> tuple[int, tuple[float, list[float]]]:
        # candidates in one pass of the normal equations, the best once more by inner
        # (every one by inner where a singular one needs the minimum-norm solution)
        sse = sse_many(cs)
        if np.isfinite(sse).all():
            j = int(np.argmin(sse))
            return j, inner(float(cs[j]))
        vals = [inner(float(c)) for c in cs]
        j = int(np.argmin([v[0] for v in vals]))
        return j, vals[j]

    k, best = best_of(grid)
    if form == "step" and len(grid) > 1:
        # the partition changes only between data values: try the midpoints between
        # the distinct values of x in the grid cells around the best threshold
        lo, hi = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, len(grid) - 1)])
        ux = np.unique(x[(x >= lo) & (x <= hi)])
        mids = 0.5 * (ux[1:] + ux[:-1])
        if mids.size:
            cand = best_of(mids)[1]
            if cand[0] < best[0]:
                best = cand
    elif len(grid) > 2:
        lo, hi = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, len(grid) - 1)])
        if hi > lo:
            cand = inner(zoom_minimum(sse_many, lo, hi))
            if cand[0] < best[0]:
                best = cand
    if not best[1]:
        return [float(np.sum(w * y) / np.sum(w))] + [0.0] * (len(FORMS[form][1]) - 1)
    return best[1]


#: Points and rounds of :func:`zoom_minimum`: each round narrows the bracket to the two
#: cells around the best of its points, 6 rounds of 9 points to 1.2e-4 of the first bracket.
ZOOM_POINTS, ZOOM_ROUNDS = 9, 6


def zoom_minimum(f: Callable[[np.ndarray], np.ndarray], lo: float, hi: float) -> float:
    """Minimiser of ``f`` in [lo, hi] by nested grids (``f`` evaluates many points at
    once): :data:`ZOOM_ROUNDS` rounds of :data:`ZOOM_POINTS` evenly spaced points, each
    narrowing the bracket to the cells either side of its best point.
    """
    best = 0.5 * (lo + hi)
    for _ in range(ZOOM_ROUNDS):
        xs = np.linspace(lo, hi, ZOOM_POINTS)
        v = f(xs)
        if not np.isfinite(v).any():
            break
        j = int(np.argmin(v))
        best = float(xs[j])
        lo, hi = float(xs[max(j - 1, 0)]), float(xs[min(j + 1, ZOOM_POINTS - 1)])
    return best


#: Most abscissas of a smoothing spline: beyond, consecutive distinct abscissas are pooled
#: into this many groups (weighted means); the smoothing parameter's GCV search costs
#: O(n) Python steps per trial, and 80 groups keep a step's position to ~1 % of the cases.
#: A group never spans a gap wider than 1 / SPLINE_BINS of the range (:func:`pool_groups`).
SPLINE_BINS = 80
#: Points of the log grid of the smoothing parameter's GCV search (:func:`gcv_smoothing`).
SMOOTHING_GRID = 121


def pool_groups(ux: np.ndarray, bins: int = SPLINE_BINS) -> np.ndarray:
    """Group index of each of the increasing distinct abscissas ``ux`` (the feature's unit):
    ``bins`` consecutive groups of equal count, each split further where two neighbours
    are more than 1 / ``bins`` of the range apart.

    Equal counts alone pooled an isolated cluster at the end of the range with the first
    cases beyond a gap (two identified rear-end impacts at impact angle 0 with cases at
    1.2 rad into one abscissa near 0.6 rad): the spline then had no value at the cluster
    and extrapolated into it.
    """
    n = ux.size
    start = np.zeros(n, bool)
    start[np.cumsum([len(a) for a in np.array_split(np.arange(n), bins)])[:-1]] = True
    if n > 1 and np.ptp(ux) > 0:
        start[1:] |= np.diff(ux) > np.ptp(ux) / bins
    return np.cumsum(start)


def smoothing_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> Any:
    """Smoothing spline through weighted means of equal x (increasing abscissas; more
    than :data:`SPLINE_BINS` distinct ones pooled into consecutive groups,
    :func:`pool_groups`).
    """
    from scipy.interpolate import make_smoothing_spline

    keep = w > 0
    order = np.argsort(x[keep], kind="stable")
    xs, ys, ws = x[keep][order], y[keep][order], w[keep][order]
    ux, inv = np.unique(np.round(xs, 9), return_inverse=True)
    sw = np.bincount(inv, ws)
    my = np.bincount(inv, ws * ys) / sw
    if ux.size < 5:
        return None
    if ux.size > SPLINE_BINS:  # consecutive abscissas pooled: weighted means, summed weights
        group = pool_groups(ux)
        gw = np.bincount(group, sw)
        ux = np.bincount(group, sw * ux) / gw
        my = np.bincount(group, sw * my) / gw
        sw = gw
    wn = sw / sw.mean()
    return make_smoothing_spline(ux, my, w=wn, lam=gcv_smoothing(ux, my, wn))


def gcv_smoothing(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> float:
    """Smoothing parameter of the cubic smoothing spline (the objective
    sum w (y - f)^2 + lam int f''^2 of :func:`scipy.interpolate.make_smoothing_spline`)
    that minimises the generalised cross-validation criterion (Wahba's GCV): the mean
    *weighted* squared residual, w (y - f)^2, over (1 - tr(A) / n)^2, evaluated in closed
    form for all lam at once.  scipy's criterion takes the residuals unweighted: a few
    cases of small weight (wide identification intervals) far from the curve then drove
    the smoothing down to nearly interpolate them.

    The spline's values at the n abscissas are f = (W + lam K)^-1 W y with
    K = Q R^-1 Q' the Reinsch penalty matrix (Green & Silverman, *Nonparametric
    Regression and Generalized Linear Models*, sec. 2.1); with the eigenvectors U
    and eigenvalues d of W^-1/2 K W^-1/2 the hat matrix has the eigenvalues
    1 / (1 + lam d), so residuals and trace cost one matrix product per lam
    (scipy's search costs O(n) Python steps per trial).  The search is for the global
    minimum over a log grid of lam d (:data:`SMOOTHING_GRID` points, unit-free: the same
    fit whatever the feature's unit), then a bounded Brent search around the best grid
    point; at most n / 4 degrees of freedom (tr(A)).  scipy's own search, a bounded Brent
    search over 0 < lam < n, stopped in a local minimum that depends on the feature's unit
    (a fold of the contact-plane turn over the impact angle in rad: lam = 1.44, a straight
    line, where the global minimum was 9 times lower).

    Parameters
    ----------
    x : ndarray (n,)
        Increasing abscissas (n >= 5; the feature's unit).
    y : ndarray (n,)
        Values (the channel's unit).
    w : ndarray (n,)
        Positive weights.

    Returns
    -------
    float
        lam (unit of y^2 x^3).
    """
    from scipy.optimize import minimize_scalar

    n = x.size
    h = np.diff(x)
    i = np.arange(n - 2)
    q = np.zeros((n, n - 2))
    q[i, i], q[i + 1, i], q[i + 2, i] = 1.0 / h[:-1], -1.0 / h[:-1] - 1.0 / h[1:], 1.0 / h[1:]
    r = np.diag((h[:-1] + h[1:]) / 3.0) + np.diag(h[1:-1] / 6.0, 1) + np.diag(h[1:-1] / 6.0, -1)
    k = q @ np.linalg.solve(r, q.T)
    root = np.sqrt(w)
    d, u = np.linalg.eigh(k / np.outer(root, root))
    d = np.maximum(d, 0.0)
    z = u.T @ (root * y)

    def criterion(lams: np.ndarray) -> np.ndarray:
        f = 1.0 / (1.0 + np.asarray(lams, float).reshape(-1, 1) * d)
        # the weighted residuals sqrt(w) (y - f(x)) are U ((1 - f) z): their sum of squares
        # needs no product with U
        wrss = np.sum(((1.0 - f) * z) ** 2, axis=1)
        return np.asarray(wrss / n / (1.0 - f.sum(axis=1) / n) ** 2)

    # the global minimum over a log grid of lam d (unit-free: lam scales as x^3, d as
    # x^-3) from interpolation to the straight line, at most n / 4 degrees of freedom
    # (towards tr(A) = n the residuals and 1 - tr(A) / n vanish together: a spurious
    # minimum), then a bounded Brent search in the grid cells around it
    pos = d[d > 1e-12 * d.max()] if d.max() > 0 else np.ones(1)
    lams = np.geomspace(0.01 / pos.max(), 100.0 / pos.min(), SMOOTHING_GRID)
    crit = criterion(lams)
    dof = (1.0 / (1.0 + lams.reshape(-1, 1) * d)).sum(axis=1)
    crit = np.where((dof <= max(n / 4.0, 2.5)) & np.isfinite(crit), crit, np.inf)
    if not np.isfinite(crit).any():
        return float(lams[-1])
    j = int(np.argmin(crit))
    lo, hi = math.log(lams[max(j - 1, 0)]), math.log(lams[min(j + 1, lams.size - 1)])
    best = minimize_scalar(lambda a: float(criterion(np.array([math.exp(a)]))[0]),
                           bounds=(lo, hi), method="bounded")
    lam = float(math.exp(best.x))
    lam_dof = float(np.sum(1.0 / (1.0 + lam * d)))
    return lam if best.fun <= crit[j] and lam_dof <= max(n / 4.0, 2.5) else float(lams[j])


def predict_spline(spl: Any, x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Spline values, held constant outside [lo, hi] (no extrapolation)."""
    return np.asarray(spl(np.clip(x, lo, hi)), float)

def robust_scale(r: np.ndarray) -> float:
    """Normal-consistent median absolute deviation of residuals r (their unit)."""
    r = r[np.isfinite(r)]
    if r.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def robust_weights(u: np.ndarray, kind: str) -> np.ndarray:
    """Huber's (``kind`` "huber") or Tukey's biweight weights of standardised residuals u."""
    a = np.abs(u)
    if kind == "huber":
        return np.minimum(1.0, HUBER_C / np.maximum(a, 1e-300))
    return np.where(a < BIWEIGHT_C, (1.0 - (u / BIWEIGHT_C) ** 2) ** 2, 0.0)


def robust_loss(u: np.ndarray) -> np.ndarray:
    """Tukey's biweight loss of standardised residuals u, scaled to u^2 near 0
    (bounded by ``BIWEIGHT_C ** 2 / 3``).
    """
    a = np.minimum(np.abs(u) / BIWEIGHT_C, 1.0)
    return BIWEIGHT_C ** 2 / 3.0 * (1.0 - (1.0 - a ** 2) ** 3)


def irls(fit: Callable[[np.ndarray], Any], predict: Callable[[Any], np.ndarray],
          y: np.ndarray, w: np.ndarray, start: Any = None,
          stages: tuple[str, ...] = ("huber", "biweight")) -> Any:
    """Iteratively reweighted fit: Huber weights (scale re-estimated by the MAD of
    the standardised residuals), then Tukey's biweight at the last scale; at most
    :data:`ROBUST_ITERATIONS` refits per stage; ``start``: the first fit if known (default: the
    fit with weights w); ``stages``: ("biweight",) from a robust start (the scale is
    then the MAD of the start's residuals).

    Returns the last fit.
    """
    sw = np.sqrt(w)
    rw = np.ones_like(y)
    model = fit(w) if start is None else start
    scale = 0.0
    for kind in stages:
        for _ in range(ROBUST_ITERATIONS):
            r = sw * (y - predict(model))
            if kind == "huber" or scale <= 0:
                scale = robust_scale(r)
            if not scale > 0:
                return model
            new_rw = robust_weights(r / scale, kind)
            if np.max(np.abs(new_rw - rw)) < 1e-2:
                break
            rw = new_rw
            model = fit(w * rw)
    return model


def fit_form(form: str, x: np.ndarray, y: np.ndarray, w: np.ndarray,
             robust: bool = True, start: Sequence[float] | None = None) -> list[float]:
    """Coefficients of a closed form (:data:`FORMS`) fitted to (x, y) with weights w.

    Weighted least squares, or (``robust``) an M-estimate: iteratively
    reweighted least squares with Huber's then Tukey's biweight weights of
    the standardised residuals sqrt(w) (y - f(x)), so that cases whose
    identification went to a wrong minimum do not pull the law.  ``start``: robust
    coefficients of the same form on a superset of the cases (the fit on all cases,
    for a fold of the cross-validation): the biweight stage alone, from them.
    """
    if not robust:
        return fit_form_ls(form, x, y, w)
    last: list[float] = [] if start is None else [float(v) for v in start]

    def fit(wt: np.ndarray) -> list[float]:
        # the nonlinear coefficient is searched near the previous one after the first fit
        near = last[-1] if last and form not in ("constant", "linear") else None
        last[:] = fit_form_ls(form, x, y, wt, near)
        return list(last)

    def predict(c: list[float]) -> np.ndarray:
        return evaluate_law({"form": form, "coefficients": c}, x)

    if start is None:
        coef = irls(fit, predict, y, w)
    else:
        coef = irls(fit, predict, y, w, start=list(last), stages=("biweight",))
    return list(coef)


def running_median(x: np.ndarray, y: np.ndarray,
                   half_width: int = RUNNING_MEDIAN_HALF_WIDTH) -> np.ndarray:
    """Robust local level of y at each case: the median over its 2 k + 1 neighbours ranked
    by x (k = ``half_width``); for the k cases at each end, where no symmetric window
    exists, the repeated-medians line through the 2 k + 1 end cases (Siegel 1982,
    :func:`scipy.stats.siegelslopes`), so that a trend there is not taken for outliers.

    Tukey's running median (*Exploratory Data Analysis*, 1977, ch. 7): it follows steps
    and trends and ignores isolated values; y's unit.
    """
    from numpy.lib.stride_tricks import sliding_window_view
    from scipy.stats import siegelslopes

    n = y.size
    order = np.argsort(x, kind="stable")
    xs, ys = x[order], y[order]
    k = min(half_width, (n - 1) // 2)
    med = np.empty(n)
    if k < 1:
        med[:] = np.median(ys)
    else:
        med[k:n - k] = np.median(sliding_window_view(ys, 2 * k + 1), axis=1)
        for end, ends in ((slice(0, 2 * k + 1), slice(0, k)),
                          (slice(n - 2 * k - 1, n), slice(n - k, n))):
            xe, ye = xs[end], ys[end]
            if np.ptp(xe) > 0:
                slope, icpt = siegelslopes(ye, xe)
                med[ends] = icpt + slope * xs[ends]
            else:
                med[ends] = np.median(ye)
    out = np.empty(n)
    out[order] = med
    return out


def robust_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray
                   ) -> tuple[Any, np.ndarray, float]:
    """Smoothing spline (:func:`smoothing_spline`) fitted robustly: the spline (None if too few
    distinct abscissas), the robust weights (0 = rejected) and the scale of its
    standardised residuals sqrt(w) (y - f(x)).

    The weights are Tukey's biweight of the residuals from the :func:`running_median`
    (standardised by their median absolute deviation): a case is rejected when it
    disagrees with its neighbours along the feature, not with a global curve.  Reweighting
    against the spline itself (as :func:`fit_form` does) rejected a whole cluster at the
    end of a feature's range (rear-end impacts at impact angle 0) once the first spline,
    drawn by the bulk, missed it, and the law was then extrapolated into it.
    """
    sw = np.sqrt(w)
    r = sw * (y - running_median(x, y))
    scale = robust_scale(r)
    rw = robust_weights(r / scale, "biweight") if scale > 0 else np.ones_like(y)
    spl = smoothing_spline(x, y, w * rw)
    if spl is None:
        spl = smoothing_spline(x, y, w)
    if spl is None:
        return None, np.ones_like(y), 0.0
    lo, hi = float(np.min(x)), float(np.max(x))
    return spl, rw, robust_scale(sw * (y - predict_spline(spl, x, lo, hi)))


def fit_spline(x: np.ndarray, y: np.ndarray, w: np.ndarray, robust: bool = True) -> Any:
    """Smoothing spline (:func:`smoothing_spline`), or robustly :func:`robust_spline`'s;
    None if too few distinct abscissas.
    """
    return robust_spline(x, y, w)[0] if robust else smoothing_spline(x, y, w)


__all__ = ["BIWEIGHT_C", "HUBER_C", "ROBUST_ITERATIONS", "RUNNING_MEDIAN_HALF_WIDTH",
           "SMOOTHING_GRID", "SPLINE_BINS", "ZOOM_POINTS", "ZOOM_ROUNDS", "fit_form",
           "fit_form_ls", "fit_spline", "gcv_smoothing", "irls", "pool_groups", "predict_spline",
           "robust_loss", "robust_scale", "robust_spline", "robust_weights", "running_median",
           "smoothing_spline", "wls", "zoom_minimum"]
