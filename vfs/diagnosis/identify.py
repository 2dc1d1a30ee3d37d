"""Per-case identification of model channels (``vfs identify``).

For every case and every channel of :data:`vfs.effects.learned.CHANNELS`
(restitution, contact friction, POI shifts along / across the contact
plane, contact-plane turn, penetration time, EES stiffness ratio, yaw-inertia
factor, contact-phase tyre impulse, run-out brake factor per vehicle), the
value that best reproduces the case's reconstruction:

1. a grid of ``grid_points`` candidate values over the channel's range
   (geometric for ratios) is simulated on **all** cases, one stacked
   simulation for the grids of all channels (:class:`vfs.diagnosis.variants.VariantSimulator`;
   the refinement steps below likewise run all channels together, one simulation per
   step: a stacked run-out lasts as long as its slowest vehicle);
2. the objective of a case is chi^2 = sum over the compared residual
   columns of (residual / scale)^2, the scale of each output being the RMS
   of its recorded ``_sd`` columns (:class:`vfs.diagnosis.calibrate.CalibrationData`);
3. optionally (``zoom_starts``), a zoom per case into the lowest local
   minima of its grid profile: values spread over the grid cells around
   each, then around the best of them (two stacked simulations, each case
   at its own values), for channels whose outcomes react on a scale finer
   than the grid (penetration time: chi^2 wells ~1 ms wide against a 10 ms
   grid in the most sensitive cases);
4. per case, a parabola through the best value tried and its neighbours
   gives the refined value, simulated once more for all cases together
   (each case at its own value) and kept where it is better; then
   :data:`POLISH_ROUNDS` rounds halve the bracket around the best value;
5. the uncertainty interval is the profile interval chi^2 <= min + 1
   read from all the values tried (between two of them, sqrt(chi^2 - min)
   interpolated linearly: exact for a parabolic profile), by default with
   each output's scale times its estimated noise factor
   (:func:`noise_factors`) and the channel's scale times the factor k of
   the cases' consistency (:func:`consistency_factor`), i.e. chi^2 <= min +
   k^2 (no simulation added); flags (at k = 1): ``flat`` (the objective
   varies by less than 1 over the whole range), ``multimodal`` (another
   local minimum within min + 1 separated by a rise above it),
   ``at_bound`` (the interval reaches a bound of the range).  A value is
   *identifiable* if none applies.

The values are absolute for "set" channels and offsets from the model's
value for "shift" channels (:class:`vfs.effects.learned.Channel`).
Units: SI (the channel's unit column).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.atomic import write_text
from vfs.blas import one_blas_thread
from vfs.diagnosis.calibrate import CalibrationData, VariantSimulator
from vfs.diagnosis.choices import DEFAULT_CHANNELS, parse_channels
from vfs.diagnosis.features import case_features
from vfs.effects.context import ContactContext, ImpactContext
from vfs.effects.learned import CHANNELS, LAW_FEATURES, ChannelLaw, law_effect_class
from vfs.errors import ParameterError
from vfs.physics.impact import ImpactConfig

#: Rounds of bracket halving after the first parabolic step (:func:`identify`): the
#: chi^2 well of a case can be narrower than the grid spacing and far from a parabola
#: over it (run-out brake factors: chi^2 rising by hundreds within 0.05), where one
#: parabola through grid values misses the minimum by many interval widths.
POLISH_ROUNDS = 3

#: A refinement (:func:`_refine_profile`): yields per-case values, is sent their residuals,
#: returns the values tried and their residuals.
RefineSteps = Generator[list[np.ndarray], np.ndarray, tuple[np.ndarray, np.ndarray]]

def channel_grid(channel: str, points: int) -> np.ndarray:
    """Candidate values of a channel (its unit): linear or geometric over its range."""
    ch = CHANNELS[channel]
    if points < 3:
        raise ParameterError(f"grid points = {points} must be >= 3")
    if ch.log_grid:
        return np.geomspace(ch.lo, ch.hi, points)
    return np.linspace(ch.lo, ch.hi, points)


def _constant_class(channel: str) -> type[ChannelLaw]:
    ch = CHANNELS[channel]
    v0 = 0.0 if ch.mode == "shift" else 0.5 * (ch.lo + ch.hi)
    cls = law_effect_class({"name": f"identify_{channel}", "channel": channel,
                            "feature": "closing_speed", "form": "constant",
                            "coefficients": [v0]})
    return cls  # type: ignore[return-value]


def _per_case_class(channel: str, n: int) -> type[ChannelLaw]:
    """A law effect whose value is given per case (row of the batch modulo n)."""
    base = _constant_class(channel)

    class PerCase(base):  # type: ignore[valid-type, misc]
        values_per_case: np.ndarray = np.zeros(n)

        def value(self, ctx: ContactContext | ImpactContext, config: ImpactConfig | None,
                  base_value: np.ndarray) -> np.ndarray:
            v = self.values_per_case[np.asarray(ctx.rows) % n]
            ch = CHANNELS[self.law["channel"]]
            return base_value + v if ch.mode == "shift" else np.asarray(v, float)

    PerCase.__name__ = f"PerCase_{channel}"
    return PerCase


def _probe_class(channel: str, n: int) -> type[ChannelLaw]:
    """A law effect that leaves the channel unchanged and records the model's value."""
    base = _constant_class(channel)

    class Probe(base):  # type: ignore[valid-type, misc]
        seen: np.ndarray = np.full(n, np.nan)

        def value(self, ctx: ContactContext | ImpactContext, config: ImpactConfig | None,
                  base_value: np.ndarray) -> np.ndarray:
            self.seen[np.asarray(ctx.rows) % n] = base_value
            return base_value

    Probe.__name__ = f"Probe_{channel}"
    return Probe


def model_values(sim: VariantSimulator, channel: str) -> np.ndarray:
    """The model's own value of a channel per case (0 for shift channels; NaN where the
    case does not collide).
    """
    n = sim.data.n
    if CHANNELS[channel].mode == "shift":
        return np.zeros(n)
    probe = _probe_class(channel, n)
    setattr(probe, "seen", np.full(n, np.nan))  # noqa: B010
    sim.simulate([(probe(),)])
    return np.asarray(getattr(probe, "seen"), float)  # noqa: B009


def chi2(data: CalibrationData, residuals: np.ndarray,
         factors: np.ndarray | None = None) -> np.ndarray:
    """Per-case chi^2 = sum of squared standardised residuals (..., n); NaN columns skipped.

    ``residuals`` (..., n, n_columns) [SI]; ``factors`` (n_groups,) multiply the
    scale of each output (:func:`noise_factors`; default 1).
    """
    scale = data.scales if factors is None else data.scales * factors
    z = residuals / scale[data.column_group]
    return np.nansum(z ** 2, axis=-1)


#: Median of the chi^2 distribution with one degree of freedom (a squared standard
#: normal): median(z^2) / this is a robust estimate of the variance of z.
_CHI2_1_MEDIAN = 0.454936423119572


def noise_factors(data: CalibrationData, residuals: np.ndarray) -> np.ndarray:
    """Robust noise scale of each output relative to its recorded scale (n_groups,) [-].

    ``residuals`` (n, n_columns) [SI] at the identified values.  Per group,
    sqrt(median(z^2) / 0.4549) over its cases and columns (z: residual over the
    recorded scale; 0.4549 the median of chi^2 with one degree of freedom), which
    is 1 for normal residuals at the recorded scale and is not moved by a few
    cases far off.  The recorded scale describes the measurement noise of the
    outputs only; the reconstruction's other inputs (positions, speeds, vehicle
    data at impact) are noisy too and their errors reach the outputs through
    the simulation, most of all the rest positions.  Groups without values: 1.
    """
    z2 = (residuals / data.scales[data.column_group]) ** 2
    out = np.ones(len(data.groups))
    for k in range(len(data.groups)):
        block = z2[:, data.column_group == k]
        block = block[np.isfinite(block)]
        if block.size >= 3:
            out[k] = max(math.sqrt(float(np.median(block)) / _CHI2_1_MEDIAN), 1.0)
    return out


#: Probability of a standard normal within one standard deviation.
_ONE_SIGMA = 0.6826894921370859

#: Fewest identifiable cases for :func:`consistency_factor` (below: 1).
MIN_CONSISTENCY_CASES = 12


def _successive_spreads(values: np.ndarray, low: np.ndarray, high: np.ndarray,
                        feature: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standardised successive differences of the values sorted by one feature, the
    even-numbered and the odd-numbered ones (finite only); see :func:`consistency_factor`.
    """
    o = np.argsort(feature, kind="stable")
    v, lo, hi = values[o], low[o], high[o]
    d = v[1:] - v[:-1]
    # half widths facing each other: the upper one of the lower value
    h_a = np.where(d > 0, hi[:-1] - v[:-1], v[:-1] - lo[:-1])
    h_b = np.where(d > 0, v[1:] - lo[1:], hi[1:] - v[1:])
    se = np.hypot(h_a, h_b)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(se > 0, d / se, np.nan)
    even, odd = z[0::2], z[1::2]
    return even[np.isfinite(even)], odd[np.isfinite(odd)]


def consistency_factor(values: np.ndarray, low: np.ndarray, high: np.ndarray,
                       features: np.ndarray) -> float:
    """Factor (>= 1) [-] by which the profile intervals of one channel are too narrow,
    from the agreement of cases with similar features: the estimated noise scale of
    the channel's chi^2 beyond the outputs' (:func:`identify` takes the interval at
    chi^2 <= min + factor^2).

    For the cases sorted by one feature, the successive differences of the
    values over the root sum of squares of their half widths (each on the side
    facing the other value) are standard normal if the intervals are right
    and the channel's true value varies slowly with the feature (von Neumann's
    successive differences).  Their spread, the 68.27 % quantile of |z| about
    its median (1 for a standard normal; what the coverage of a one-sigma
    interval asks for also where the errors have heavier tails than normal
    ones), is the factor.

    The features are chosen on one half of the differences and the spread is
    measured on the other (a choice made on one half is not biased low by the
    choice), both ways round (cross-fitting), and averaged: the features
    chosen on the even-numbered differences are those whose spread there is
    within a relative ``2 / sqrt(m)`` of the smallest (``m`` differences per
    half; the standard error of the spread of m standard normal differences
    is about ``0.96 / sqrt(m)``, so this keeps the features the data cannot
    tell from the best one, about 1.5 standard errors of a difference of two
    spreads), and the factor of that half is the mean of their spreads on the
    odd-numbered differences; likewise the other way round.  A feature the
    true value follows is chosen alone when the variation is large against
    the intervals; where it is not, the other features' orderings add their
    pairs of cases, which cuts the variance of the factor to less than half
    of that of one feature's odd half alone (docs/diagnosis.md, "Interval
    coverage").
    Never below 1.

    Parameters
    ----------
    values, low, high : ndarray (n,)
        Identified values and interval edges of the identifiable cases (the
        channel's unit; geometric channels in the logarithm).
    features : ndarray (n, k)
        Case features (any unit; only their order is used).
    """
    n = values.shape[0]
    if n < MIN_CONSISTENCY_CASES:
        return 1.0

    def spread(z: np.ndarray) -> float:
        return float(np.quantile(np.abs(z - np.median(z)), _ONE_SIGMA))

    rows: list[tuple[float, float]] = []
    m = n
    for j in range(features.shape[1]):
        f = features[:, j]
        if not np.isfinite(f).all() or np.ptp(f) == 0:
            continue
        even, odd = _successive_spreads(values, low, high, f)
        if min(even.size, odd.size) < MIN_CONSISTENCY_CASES // 2:
            continue
        rows.append((spread(even), spread(odd)))
        m = min(m, even.size, odd.size)
    if not rows:
        return 1.0
    s = np.asarray(rows)  # (features, 2): spread on the even / odd differences
    tol = 1.0 + 2.0 / math.sqrt(m)
    halves = [float(s[s[:, a] <= tol * s[:, a].min(), 1 - a].mean()) for a in (0, 1)]
    return max(0.5 * (halves[0] + halves[1]), 1.0)


def _local_minima(prof: np.ndarray) -> np.ndarray:
    """Local minima along the first axis of a (m, n) profile (ends included)."""
    loc = np.zeros(prof.shape, bool)
    if prof.shape[0] < 2:
        return np.ones(prof.shape, bool)
    loc[1:-1] = (prof[1:-1] <= prof[:-2]) & (prof[1:-1] <= prof[2:])
    loc[0] = prof[0] <= prof[1]
    loc[-1] = prof[-1] <= prof[-2]
    return loc


def profile_interval(xs: np.ndarray, prof: np.ndarray, best: np.ndarray,
                     fmin: np.ndarray, rise: float = 1.0
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Profile interval chi^2 <= min + rise per case and its flags (vectorised over cases).

    Each edge lies between the last value tried inside and the first one
    outside, walking outwards from the best value, where the linear
    interpolation of sqrt(chi^2 - min) between the two reaches sqrt(rise):
    exact for a parabolic profile (whose local curvature interval it is),
    and within the bracket of the two values for any other.  A rugged
    profile (a value above the level, values below it further out) ends at
    its first crossing; the values beyond are ``multimodal`` where one of
    them is a local minimum.

    Parameters
    ----------
    xs : ndarray (m, n)
        Values tried per case, increasing along the first axis (the channel's
        unit).
    prof : ndarray (m, n)
        chi^2 there [-].
    best : ndarray (n,)
        Best values (the channel's unit).
    fmin : ndarray (n,)
        chi^2 there [-].
    rise : float
        Rise of chi^2 at the edges [-]: 1 for one sigma at the scales of
        ``prof``, k^2 for one sigma at k times those scales.

    Returns
    -------
    low, high : ndarray (n,)
        Interval edges (the channel's unit), low <= best <= high.
    flat, multimodal, at_bound : ndarray of bool (n,)
        chi^2 varies by less than ``rise`` over all values tried; another
        local minimum within min + rise separated from the best by a rise
        above it; the interval reaches the first or last value tried.
    """
    m, n = prof.shape
    cols = np.arange(n)
    level = fmin + rise
    below = prof <= level[None, :]
    ib = np.argmin(prof, axis=0)
    low = np.empty(n)
    high = np.empty(n)
    at_bound = np.zeros(n, bool)
    idx = np.arange(m)[:, None]
    for side in (-1, 1):
        # first point from the best one outwards that rises above the level
        outward = (idx - ib[None, :]) * side > 0
        above = outward & ~below
        if side > 0:
            first = np.where(above.any(axis=0), np.argmax(above, axis=0), -1)
        else:
            first = np.where(above.any(axis=0), m - 1 - np.argmax(above[::-1], axis=0), -1)
        hit = first < 0
        j = np.clip(first, 0, m - 1)
        k = np.clip(j - side, 0, m - 1)  # the point inside
        y0, y1 = prof[k, cols], prof[j, cols]
        x0, x1 = xs[k, cols], xs[j, cols]
        # interpolate sqrt(chi^2 - min), linear in the distance for a parabolic profile
        # (chi^2 itself would put the edge far too close to a minimum between two values
        # tried far apart)
        s0 = np.sqrt(np.maximum(y0 - fmin, 0.0))
        s1 = np.sqrt(np.maximum(y1 - fmin, 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.clip((math.sqrt(rise) - s0) / (s1 - s0), 0.0, 1.0)
        edge = np.where(hit, xs[-1] if side > 0 else xs[0], x0 + t * (x1 - x0))
        if side > 0:
            high = np.maximum(edge, best)
        else:
            low = np.minimum(edge, best)
        at_bound |= hit
    span = np.nanmax(prof, axis=0) - np.nanmin(prof, axis=0)
    flat = span < rise
    # another local minimum within the level, separated from the best by a rise above it
    multimodal = np.zeros(n, bool)
    cand = _local_minima(prof) & below
    for i in np.flatnonzero(cand.sum(axis=0) > 1):
        for o in np.flatnonzero(cand[:, i]):
            a, b = sorted((int(o), int(ib[i])))
            if b - a > 1 and (prof[a:b + 1, i] > level[i]).any():
                multimodal[i] = True
                break
    return low, high, flat, multimodal, at_bound


def _per_case_models(data: CalibrationData, channel: str,
                     values: Sequence[np.ndarray]) -> list[tuple[Any, ...]]:
    """Models of k variants that set the channel to per-case values (k arrays (n,))."""
    models = []
    for v in values:
        per = _per_case_class(channel, data.n)
        setattr(per, "values_per_case", np.asarray(v, float))  # noqa: B010
        models.append((per(),))
    return models


def _sorted_profile(xs: np.ndarray, res: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-case profile sorted by value (columns are cases); ``res`` (m, n, n_columns)."""
    order = np.argsort(xs, axis=0, kind="stable")
    return (np.take_along_axis(xs, order, axis=0),
            np.take_along_axis(res, order[:, :, None], axis=0))


def _refine_profile(data: CalibrationData, channel: str, grid: np.ndarray, res: np.ndarray,
                    starts: int, points: int) -> RefineSteps:
    """The grid profile refined per case, as a generator of the simulations it needs.

    With ``starts`` > 0 (the zoom: the outcomes can react to a channel on a
    scale finer than the grid, the chi^2 well of a case a few percent of the
    grid spacing wide):

    1. around each of the ``starts`` lowest local minima of a case's grid
       profile, ``points`` values spread over the grid cells either side (a
       case with fewer minima gets more values around its best one);
    2. ``points`` values spread over the cells either side of the best value
       so far (spacing ``2 / (points + 1)`` of the previous one).

    Then (always) the vertex of the parabola through the best value and its
    neighbours.  Each step is one stacked simulation of all cases (a value
    per case and variant; geometric channels are refined in the logarithm):
    the generator yields the values of each step, a list of (n,) arrays in
    the channel's unit, and is sent their residuals (k, n, n_columns)
    (:func:`_refine_all` runs the steps of all channels together, one
    simulation per step).

    Returns (as the generator's value)
    ----------------------------------
    (xs, res)
        Values tried per case (m, n), increasing along the first axis, and
        their residuals (m, n, n_columns) (the grid's included).
    """
    ch = CHANNELS[channel]
    prof = chi2(data, res)
    n = prof.shape[1]
    u = np.log(grid) if ch.log_grid else np.asarray(grid, float)
    ulo, uhi = float(u[0]), float(u[-1])

    def spread(centre: np.ndarray, half: np.ndarray, offset: float = 0.0) -> list[np.ndarray]:
        lo = np.maximum(centre - half, ulo)
        hi = np.minimum(centre + half, uhi)
        return [lo + (hi - lo) * ((k + 1 + offset) / (points + 1)) for k in range(points)]

    to_value = np.exp if ch.log_grid else np.asarray
    us = np.broadcast_to(u[:, None], prof.shape)
    fs = prof
    rs = res
    # 1. the best local minima of the grid profile
    score = np.where(_local_minima(prof), prof, np.inf)
    rank = np.argsort(score, axis=0, kind="stable")[:max(starts, 1)]  # (starts, n)
    found = np.isfinite(np.take_along_axis(score, rank, axis=0))
    h = np.full(n, float(u[1] - u[0]))
    cand: list[np.ndarray] = []
    for r in range(rank.shape[0] if starts > 0 else 0):
        # a case without an r-th minimum gets values between those around its best one
        own = spread(u[rank[r]], h)
        extra = spread(u[rank[0]], h, r / rank.shape[0])
        cand += [np.where(found[r], a, b) for a, b in zip(own, extra, strict=True)]
    for step in range(2 if starts > 0 else 0):
        if step == 1:  # 2. zoom around the best value so far
            ib = np.argmin(fs, axis=0)
            h = 2.0 * h / (points + 1)
            cand = spread(us[ib, np.arange(n)], h)
        c = np.stack(cand)
        new = yield [to_value(v) for v in c]
        us, rs = _sorted_profile(np.concatenate([us, c]), np.concatenate([rs, new]))
        fs = chi2(data, rs)
    # 3. parabola through the best value and its neighbours, then ``POLISH_ROUNDS``
    # rounds that halve the bracket around the best value (values half-way to its
    # neighbours) together with the new parabola's vertex
    cols = np.arange(n)
    for rnd in range(POLISH_ROUNDS + 1):
        m = us.shape[0]
        i0 = np.clip(np.argmin(fs, axis=0), 1, m - 2)
        xa, xb, xc = us[i0 - 1, cols], us[i0, cols], us[i0 + 1, cols]
        ya, yb, yc = fs[i0 - 1, cols], fs[i0, cols], fs[i0 + 1, cols]
        num = (xb - xa) ** 2 * (yb - yc) - (xb - xc) ** 2 * (yb - ya)
        den = (xb - xa) * (yb - yc) - (xb - xc) * (yb - ya)
        with np.errstate(invalid="ignore", divide="ignore"):
            vx = xb - 0.5 * num / den
        ok = np.isfinite(vx) & (den != 0) & (vx > xa) & (vx < xc)
        vals = [np.where(ok, vx, xb)]
        if rnd > 0:
            ib = np.argmin(fs, axis=0)
            best = us[ib, cols]
            left = us[np.maximum(ib - 1, 0), cols]
            right = us[np.minimum(ib + 1, m - 1), cols]
            vals += [0.5 * (best + left), 0.5 * (best + right)]
        c = np.stack(vals)
        new = yield [to_value(v) for v in c]
        us, rs = _sorted_profile(np.concatenate([us, c]), np.concatenate([rs, new]))
        fs = chi2(data, rs)
    return to_value(us), rs


def _refine_all(data: CalibrationData, sim: VariantSimulator,
                steps: dict[str, RefineSteps]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Run the refinements of several channels in lockstep: the values of every channel's
    next step in one stacked simulation (the run-out of a stacked call lasts as long as
    its slowest vehicle, so one call per step instead of one per channel and step saves
    the run-out's long tails; each case's result is the same either way).
    """
    done: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    asked: dict[str, list[np.ndarray]] = {}

    def advance(name: str, gen: RefineSteps, sent: np.ndarray | None) -> None:
        try:
            asked[name] = next(gen) if sent is None else gen.send(sent)
        except StopIteration as stop:
            done[name] = stop.value

    for name, gen in steps.items():
        advance(name, gen, None)
    while asked:
        order = list(asked)
        models = [m for name in order for m in _per_case_models(data, name, asked[name])]
        res = sim.uncached_residuals(models)
        at = 0
        current = dict(asked)
        asked.clear()
        for name in order:
            k = len(current[name])
            advance(name, steps[name], np.stack(res[at:at + k]))
            at += k
    return done


@one_blas_thread
def identify(data: CalibrationData, channels: str | Iterable[str] | None = None,
             grid_points: int = 21, sim: VariantSimulator | None = None,
             refine: bool = True, zoom_starts: int = 0,
             zoom_points: int = 8, noise: str = "estimated",
             progress: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Identify each channel per case (see the module docstring).

    Parameters
    ----------
    data : CalibrationData
        Cases and their reconstruction outcomes.
    channels : str or list, optional
        Channel names (default all).
    grid_points : int
        Candidate values per channel (>= 3).
    sim : VariantSimulator, optional
        Shared simulator (its base model is the model whose channel is moved).
    refine : bool
        Parabolic refinement (one more simulation per channel).
    zoom_starts : int
        Before it, zoom into this many of the lowest local minima of each
        case's grid profile (0 = no zoom; two more stacked simulations of
        ``zoom_starts * zoom_points`` and ``zoom_points`` variants), for
        channels whose outcomes react on a scale finer than the grid.
    zoom_points : int
        Values per zoomed minimum and per zoom step (>= 2).
    noise : {"estimated", "recorded"}
        Scale of each output in the chi^2 of the value and its interval:
        "recorded" = the RMS of its ``_sd`` columns; "estimated" (default) =
        that times the output's robust noise factor (:func:`noise_factors`) of
        the channel's residuals at the values found with the recorded scales,
        and the interval is chi^2 <= min + k^2 with the channel's consistency
        factor k (:func:`consistency_factor`), so that it covers the true
        value about 68 % of the time (docs/diagnosis.md, "Interval coverage").
    progress : callable, optional
        Called with a line after each channel (its count, name and seconds).

    Returns
    -------
    pandas.DataFrame
        One row per case and channel: case_id, channel, unit, mode, value,
        model_value (the model's own value; 0 for shift channels), low, high
        (interval chi^2 <= min + 1, or min + k^2 with "estimated";
        asymmetric where the profile is), chi2 (at the value), chi2_model
        (the model's own value), chi2_span, n_columns, flat, multimodal,
        at_bound, identifiable, noise_factor (the RMS of the channel's
        output noise factors, 1 for "recorded"), interval_factor (k, 1 for
        "recorded"); chi2, chi2_model and
        chi2_span are at the scales used.
    """
    names = parse_channels(channels)
    if noise not in ("estimated", "recorded"):
        raise ParameterError(f"noise = {noise!r}; use 'estimated' or 'recorded'")
    if zoom_starts < 0 or zoom_points < 2:
        raise ParameterError(f"zoom_starts = {zoom_starts} must be >= 0 and "
                             f"zoom_points = {zoom_points} >= 2")
    sim = sim or VariantSimulator(data)
    n = data.n
    ncol = np.isfinite(data.observed).sum(axis=1)
    base_res = sim.residuals([()])[0]
    if noise == "estimated":
        ft = identification_features(data)
        feats = ft[list(LAW_FEATURES)].to_numpy(float)
    frames = []
    t0 = time.perf_counter()
    # every channel's grid in one stacked simulation, then its refinement steps in lockstep
    grids = {name: channel_grid(name, grid_points) for name in names}
    models = [(_constant_class(name)(a=float(v)),) for name in names for v in grids[name]]
    flat_res = sim.residuals(models)
    profiles: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    at = 0
    for name in names:
        g = grids[name]
        res = np.stack(flat_res[at:at + len(g)])  # (g, n, c)
        at += len(g)
        profiles[name] = (np.broadcast_to(g[:, None], res.shape[:2]), res)
    if refine or zoom_starts > 0:
        profiles.update(_refine_all(data, sim, {
            name: _refine_profile(data, name, grids[name], profiles[name][1], zoom_starts,
                                  zoom_points) for name in names}))
    for i, name in enumerate(names):
        ch = CHANNELS[name]
        xs, res = profiles[name]
        factors = np.ones(len(data.groups))
        if noise == "estimated":
            ib = np.argmin(chi2(data, res), axis=0)
            factors = noise_factors(data, res[ib, np.arange(n)])
        prof = chi2(data, res, factors)  # (m, n)
        base_chi2 = chi2(data, base_res, factors)
        ib = np.argmin(prof, axis=0)
        best = xs[ib, np.arange(n)].astype(float)
        fmin = prof[ib, np.arange(n)]
        low, high, flat, multi, at_b = profile_interval(xs, prof, best, fmin)
        k = 1.0
        ok = ~(flat | multi | at_b)
        if noise == "estimated" and ok.any():
            tr = np.log if ch.log_grid else np.asarray
            k = consistency_factor(tr(best[ok]), tr(low[ok]), tr(high[ok]), feats[ok])
            if k > 1.0:  # the profile interval at the channel's noise scale k
                low, high = profile_interval(xs, prof, best, fmin, k * k)[:2]
        frames.append(pd.DataFrame({
            "case_id": data.case_ids, "channel": name, "unit": ch.unit, "mode": ch.mode,
            "value": best, "model_value": model_values(sim, name), "low": low, "high": high,
            "chi2": fmin,
            "chi2_model": base_chi2, "chi2_span": np.ptp(prof, axis=0),
            "n_columns": ncol, "flat": flat, "multimodal": multi, "at_bound": at_b,
            "identifiable": ~(flat | multi | at_b),
            "noise_factor": float(np.sqrt(np.mean(factors ** 2))),
            "interval_factor": k,
        }))
        if progress is not None:
            progress(f"  identified {name} ({i + 1}/{len(names)}; "
                     f"{time.perf_counter() - t0:.0f} s so far)")
    return pd.concat(frames, ignore_index=True)


def identification_features(data: CalibrationData) -> pd.DataFrame:
    """Numeric case features of the laws (:data:`vfs.effects.learned.LAW_FEATURES`, SI)
    from the reconstruction: those of :func:`vfs.diagnosis.features.case_features` and
    the normal closing speed of the POIs at the recorded contact plane (velocities at
    impact with the yaw rates).
    """
    f = case_features(data)
    rec = data.reconstruction

    def col(name: str) -> np.ndarray:
        return pd.to_numeric(rec[name], errors="coerce").to_numpy(float)

    cp = col("cp_angle")
    px, py = col("poi_x"), col("poi_y")
    x1, y1, x2, y2 = col("x1"), col("y1"), col("x2"), col("y2")
    w1 = np.nan_to_num(col("yaw_rate1")) if "yaw_rate1" in rec.columns else 0.0
    w2 = np.nan_to_num(col("yaw_rate2")) if "yaw_rate2" in rec.columns else 0.0
    ux = (col("vx1") - w1 * (py - y1)) - (col("vx2") - w2 * (py - y2))
    uy = (col("vy1") + w1 * (px - x1)) - (col("vy2") + w2 * (px - x2))
    f["normal_closing_speed"] = np.abs(-np.sin(cp) * ux + np.cos(cp) * uy)
    return f[["case_id", *LAW_FEATURES, "impact_type", "accident_type"]]


def write_identification(table: pd.DataFrame, features: pd.DataFrame, out: str | Path,
                         meta: dict[str, Any] | None = None) -> dict[str, Path]:
    """Write ``identified.parquet``, ``identified.csv`` (values joined with the case
    features, SI units) and ``units.json`` into ``out``.
    """
    import json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t = table.merge(features, on="case_id", how="left")
    pq = out / "identified.parquet"
    t.to_parquet(pq, index=False)
    csv = out / "identified.csv"
    write_text(csv, t.to_csv(index=False))
    units = {"value, low, high": "unit column (channel's SI unit)",
             "chi2": "-", "closing_speed": "m/s", "normal_closing_speed": "m/s",
             "overlap": "-", "mass_ratio": "-", "impact_angle": "rad",
             "impact_speed1": "m/s", "impact_speed2": "m/s", "road_friction": "-",
             **(meta or {})}
    meta_path = out / "units.json"
    write_text(meta_path, json.dumps(units, indent=2, default=str))
    return {"parquet": pq, "csv": csv, "units": meta_path}


def timed_identify(data: CalibrationData, channels: Sequence[str] | str | None = None,
                   grid_points: int = 21) -> tuple[pd.DataFrame, float]:
    """:func:`identify` and its wall time [s]."""
    t0 = time.perf_counter()
    t = identify(data, channels, grid_points)
    return t, time.perf_counter() - t0


__all__ = ["DEFAULT_CHANNELS", "channel_grid", "chi2", "consistency_factor",
           "identification_features", "identify",
           "noise_factors", "profile_interval",
           "parse_channels",
           "timed_identify", "write_identification"]
