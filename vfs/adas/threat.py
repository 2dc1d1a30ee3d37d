"""Threat assessment kernels: time to collision of two predicted outlines.

Pure functions over arrays of n vehicle pairs (no per-pair loop).  A vehicle
is an outline rectangle (:class:`Motion`: CG pose, direction of motion, speed,
longitudinal acceleration, yaw rate and the rectangle's half extents and
centre offset).  Prediction models (docs/aeb.md, section 3):

* "cv" -- constant velocity: straight, constant speed;
* "ctrv" -- constant turn rate and velocity: the arc of the current curvature
  yaw rate / speed at constant speed;
* "ca" -- constant acceleration: straight, the current acceleration until
  standstill;
* "ctra" -- the arc of the current curvature with the current acceleration
  until standstill (the path is kept, as vfs keeps a braked vehicle's path).

The kernels:

* :func:`vfs.physics.geometry.first_contact` (used here) -- first contact of two
  rectangles that translate linearly over an interval, by the swept
  separating-axis theorem (exact);
* :func:`ttc_cv` -- TTC under constant velocity (one swept interval, exact);
* :func:`ttc_sampled` -- TTC under the other models (a sweep of short
  intervals, orientation frozen at each interval's middle);
* :func:`time_to_collision` -- any model; the exact CV test wherever the
  model's prediction differs from CV by less than the tolerance;
* :func:`braked_contact` -- whether a contact is still predicted when the
  ego brakes with a given deceleration after a given delay (the last-moment
  rule of the "ideal" system).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vfs.adas.params import Prediction
from vfs.physics.geometry import first_contact
from vfs.physics.vehicle import corner_radius

#: Smallest sampling step of the sampled sweep [s] (bounds the cost of sharp turns).
MIN_STEP = 0.01

#: Upper bounds of the numbers of intervals by which pairs are grouped for the sweep.
_INTERVAL_GROUPS = np.array([4.5, 16.5, 64.5])

#: Models that follow the arc of the current curvature / that keep the acceleration.
TURNING_MODELS: tuple[str, ...] = (Prediction.CTRV, Prediction.CTRA)
ACCELERATING_MODELS: tuple[str, ...] = (Prediction.CA, Prediction.CTRA)


class Motion(NamedTuple):
    """State and outline of n vehicles for the prediction (arrays (n,)).

    ``yaw`` orients the outline, ``heading`` is the direction of motion (they
    differ by the side-slip angle, which the prediction keeps constant).
    """

    x: np.ndarray  # CG [m]
    y: np.ndarray  # CG [m]
    yaw: np.ndarray  # outline heading [rad]
    heading: np.ndarray  # direction of motion [rad]
    speed: np.ndarray  # [m/s], >= 0
    accel: np.ndarray  # longitudinal acceleration [m/s^2] (negative: braking)
    yaw_rate: np.ndarray  # [rad/s]
    half_length: np.ndarray  # half the (enlarged) outline length [m]
    half_width: np.ndarray  # half the (enlarged) outline width [m]
    centre_offset: np.ndarray  # geometric centre ahead of the CG [m]

    def take(self, index: np.ndarray) -> Motion:
        """Rows ``index`` (integer or boolean)."""
        return Motion(*(a[index] for a in self))

    @property
    def circumradius(self) -> np.ndarray:
        """Largest distance [m] from the CG to a corner of the outline."""
        return corner_radius(self.half_length + self.centre_offset,
                             self.half_length - self.centre_offset, 2.0 * self.half_width)


def ttc_cv(a: Motion, b: Motion, horizon: float | np.ndarray) -> np.ndarray:
    """Time to collision [s] of outlines moving at constant velocity (exact).

    Both rectangles keep their orientation and move with v (cos heading,
    sin heading); the relative motion over the horizon is one swept interval
    (docs/aeb.md, eq. 3.2).  Returns 0 for overlapping outlines and ``inf``
    where they do not touch within ``horizon`` [s] (scalar or per pair).
    """
    ca, sa, cb, sb = np.cos(a.yaw), np.sin(a.yaw), np.cos(b.yaw), np.sin(b.yaw)
    dx = b.x + b.centre_offset * cb - a.x - a.centre_offset * ca
    dy = b.y + b.centre_offset * sb - a.y - a.centre_offset * sa
    rvx = b.speed * np.cos(b.heading) - a.speed * np.cos(a.heading)
    rvy = b.speed * np.sin(b.heading) - a.speed * np.sin(a.heading)
    s = first_contact(dx, dy, rvx * horizon, rvy * horizon,
                      a.yaw, a.half_length, a.half_width, b.yaw, b.half_length, b.half_width)
    return s * horizon


def model_terms(m: Motion, model: str) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration [m/s^2] and path curvature [1/m] a prediction ``model`` keeps (n,).

    Curvature = yaw rate / speed for the turning models (0 at standstill),
    acceleration = the current one for the accelerating models; 0 otherwise.
    """
    zeros = np.zeros(m.x.shape[0])
    accel = m.accel if model in ACCELERATING_MODELS else zeros
    if model in TURNING_MODELS:
        safe = np.where(m.speed > 0.0, m.speed, 1.0)
        return accel, np.where(m.speed > 0.0, m.yaw_rate / safe, 0.0)
    return accel, zeros


def predicted_arclength(speed: np.ndarray, accel: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Distance [m] (n, K) covered after times ``t`` [s], (K,) or (n, K), at constant
    acceleration ``accel`` [m/s^2] from ``speed`` [m/s], standing still once stopped.

    u = v tau + a tau^2 / 2, tau = min(t, v / (-a)) for a < 0, tau = t otherwise
    (docs/aeb.md, eq. 3.3).
    """
    v, a = speed[:, None], accel[:, None]
    with np.errstate(divide="ignore"):
        stop = np.where(a < 0.0, v / np.where(a < 0.0, -a, 1.0), np.inf)
    tau = np.minimum(t, stop)
    return v * tau + 0.5 * a * tau * tau


def path_cg(m: Motion, u: np.ndarray, curvature: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CG positions [m] (n, K) after the arc lengths ``u`` [m] (n, K) on arcs of ``curvature``.

    The CG moves along the chord of its arc: length u sin(k u / 2) / (k u / 2),
    direction heading + k u / 2 (docs/aeb.md, eq. 3.3); exact, and regular at
    k = 0.  With u = v t this is the constant-turn-rate motion (w = k v).
    """
    ch, sh = np.cos(m.heading)[:, None], np.sin(m.heading)[:, None]
    if not curvature.any():  # all straight
        return m.x[:, None] + u * ch, m.y[:, None] + u * sh
    half_turn = 0.5 * curvature[:, None] * u
    sin_h, cos_h = np.sin(half_turn), np.cos(half_turn)
    small = np.abs(half_turn) < 1e-6
    ratio = np.where(small, 1.0 - half_turn**2 / 6.0,
                     sin_h / np.where(small, 1.0, half_turn))  # sin(x) / x
    chord = u * ratio
    # direction heading + k u / 2 by the angle-sum formulas
    return (m.x[:, None] + chord * (ch * cos_h - sh * sin_h),
            m.y[:, None] + chord * (sh * cos_h + ch * sin_h))


def _path_samples(m: Motion, u: np.ndarray,
                  curvature: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CG samples (n, K + 1) [m] and the outline orientation of each interval's middle
    (n, K) [rad] along arc lengths ``u`` (n, K + 1).
    """
    x, y = path_cg(m, u, curvature)
    if not curvature.any():
        return x, y, np.broadcast_to(m.yaw[:, None], (u.shape[0], u.shape[1] - 1))
    yaw = m.yaw[:, None] + curvature[:, None] * 0.5 * (u[:, :-1] + u[:, 1:])
    return x, y, yaw


def sampled_contact(a: Motion, b: Motion, t: np.ndarray, xa: np.ndarray, ya: np.ndarray,
                    yaw_a: np.ndarray, xb: np.ndarray, yb: np.ndarray, yaw_b: np.ndarray,
                    speed_bound: np.ndarray, counted: np.ndarray | None = None) -> np.ndarray:
    """First contact time [s] of outlines swept along sampled CG paths.

    Between the sample times ``t`` ((K + 1,) or (n, K + 1)) [s] each CG moves
    on the chord between its samples ``xa, ya`` / ``xb, yb`` (n, K + 1) [m]
    and each outline keeps the orientation ``yaw_a`` / ``yaw_b`` (n, K)
    [rad] of that interval; :func:`vfs.physics.geometry.first_contact` finds the first contact
    in each interval.  Broad phase: within an interval of length h the CG
    distance shrinks by at most ``speed_bound`` (n,) [m/s] (the sum of both
    top speeds) times h, so an interval can only hold a contact if the CG
    distance at its start is at most that plus the sum of the outlines'
    circumradii (docs/aeb.md, eq. 3.4); only those intervals are swept.
    ``counted`` (n, K) bool limits the intervals searched.  Returns ``inf``
    where there is no contact.
    """
    n = xa.shape[0]
    out = np.full(n, np.inf)
    if n == 0:
        return out
    t2 = np.broadcast_to(t, xa.shape)
    sep_x = xb[:, :-1] - xa[:, :-1]
    sep_y = yb[:, :-1] - ya[:, :-1]
    reach = (a.circumradius + b.circumradius)[:, None] + speed_bound[:, None] * np.diff(t2,
                                                                                      axis=1)
    cand = sep_x * sep_x + sep_y * sep_y <= reach * reach
    if counted is not None:
        cand &= counted
    i, k = np.nonzero(cand)
    if i.size == 0:
        return out
    ya_k, yb_k = yaw_a[i, k], yaw_b[i, k]
    off_a, off_b = a.centre_offset[i], b.centre_offset[i]
    dx = sep_x[i, k] + off_b * np.cos(yb_k) - off_a * np.cos(ya_k)
    dy = sep_y[i, k] + off_b * np.sin(yb_k) - off_a * np.sin(ya_k)
    ddx = (xb[i, k + 1] - xb[i, k]) - (xa[i, k + 1] - xa[i, k])
    ddy = (yb[i, k + 1] - yb[i, k]) - (ya[i, k + 1] - ya[i, k])
    s = first_contact(dx, dy, ddx, ddy, ya_k, a.half_length[i], a.half_width[i],
                      yb_k, b.half_length[i], b.half_width[i])
    hit = np.isfinite(s)
    i, k = i[hit], k[hit]
    np.minimum.at(out, i, t2[i, k] + s[hit] * (t2[i, k + 1] - t2[i, k]))
    return out


def earliest_contact(a: Motion, b: Motion, model: str = "cv") -> np.ndarray:
    """Lower bound [s] of the contact time under ``model``.

    The CG distance less both circumradii, g, cannot close faster than
    (v_a + v_b) t + (a_a+ + a_b+) t^2 / 2 (a+: positive accelerations the
    model keeps); the bound is the root of that (0 where the circles
    overlap, inf where nothing moves).
    """
    gap = np.hypot(b.x - a.x, b.y - a.y) - a.circumradius - b.circumradius
    closing = a.speed + b.speed
    gain = np.maximum(model_terms(a, model)[0], 0.0) + np.maximum(model_terms(b, model)[0], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        root = 2.0 * gap / (closing + np.sqrt(closing * closing + 2.0 * gain * gap))
        return np.where(gap <= 0.0, 0.0, np.where((closing > 0.0) | (gain > 0.0), root,
                                                  np.inf))


def _grid(start: np.ndarray, end: np.ndarray,
          step: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-pair sample times start + k step (n, K + 1) [s] and the intervals before ``end``."""
    step = np.broadcast_to(np.asarray(step, float), start.shape)
    span = float(np.max((end - start) / step)) if start.size else 0.0
    k = max(int(np.ceil(span - 1e-9)), 1)
    t = np.minimum(start[:, None] + np.arange(k + 1) * step[:, None], end[:, None])
    return t, t[:, :-1] < end[:, None]


def _error_terms(m: Motion, model: str,
                 horizon: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """|acceleration| [m/s^2], top speed [m/s] and |turn rate| at it [rad/s] over the horizon."""
    accel, curvature = model_terms(m, model)
    top = m.speed + np.maximum(accel, 0.0) * horizon
    return np.abs(accel), top, np.abs(curvature) * top


def deviation(a: Motion, b: Motion, model: str, horizon: float | np.ndarray) -> np.ndarray:
    """Bound [m] of the difference between the ``model`` and the CV predictions.

    Over the horizon H [s], per vehicle: lateral drift w v H^2 / 2 plus the
    swing of the outline w H R (w: turn rate, R: circumradius) plus the
    along-track shift |a| H^2 / 2; summed over both (docs/aeb.md, eq. 3.5).
    """
    h = np.asarray(horizon, float)
    total = 0.0
    for m in (a, b):
        acc, top, turn = _error_terms(m, model, h)
        total = total + turn * h * (0.5 * top * h + m.circumradius) + 0.5 * acc * h * h
    return np.asarray(total)


def sample_step(a: Motion, b: Motion, model: str, horizon: np.ndarray, tolerance: float,
                max_step: float) -> np.ndarray:
    """Sampling step [s] per pair that keeps the error of the sampled sweep below ``tolerance``.

    Within an interval of length h the frozen orientation moves a corner by
    at most w h R / 2 and the chord deviates from the path by at most
    (w v + |a|) h^2 / 8; the step solves
    sum(w v + |a|) h^2 / 8 + sum(w R) h / 2 = tolerance over both vehicles
    (docs/aeb.md, eq. 3.5), clipped to [:data:`MIN_STEP`, ``max_step``].
    """
    quad = 0.0
    lin = 0.0
    for m in (a, b):
        acc, top, turn = _error_terms(m, model, horizon)
        quad = quad + (turn * top + acc) / 8.0
        lin = lin + turn * m.circumradius / 2.0
    step = 2.0 * tolerance / (lin + np.sqrt(lin * lin + 4.0 * quad * tolerance))
    return np.clip(step, MIN_STEP, max_step)


def ttc_sampled(a: Motion, b: Motion, horizon: float | np.ndarray, model: str,
                tolerance: float = 0.05, max_step: float = 0.5) -> np.ndarray:
    """Time to collision [s] of outlines predicted by ``model`` (any of the four).

    The time from the earliest possible contact (:func:`earliest_contact`)
    to the horizon [s] (scalar or per pair) is cut into intervals of the
    step of :func:`sample_step`; in each interval both CGs move on the chord
    between their predicted positions (:func:`predicted_arclength`,
    :func:`path_cg`) at the interval ends and the outlines keep the
    orientation of the interval's middle (:func:`sampled_contact`;
    docs/aeb.md, eq. 3.4), so corners are off by at most ``tolerance`` [m].
    Pairs are processed in groups of similar numbers of intervals.
    """
    n = a.x.shape[0]
    end = np.broadcast_to(np.asarray(horizon, float), (n,))
    first = earliest_contact(a, b, model)
    out = np.full(n, np.inf)
    live = np.flatnonzero(first <= end)
    if live.size == 0:
        return out
    step = sample_step(a.take(live), b.take(live), model, end[live], tolerance, max_step)
    count = np.ceil((end[live] - first[live]) / step)
    group = np.digitize(count, _INTERVAL_GROUPS)
    for g in np.unique(group):
        sel = live[group == g]
        aa, bb = a.take(sel), b.take(sel)
        t, counted = _grid(first[sel], end[sel], step[group == g])
        samples = []
        bound = np.zeros(sel.size)
        for m in (aa, bb):
            accel, curvature = model_terms(m, model)
            samples.append(_path_samples(m, predicted_arclength(m.speed, accel, t), curvature))
            bound = bound + m.speed + np.maximum(accel, 0.0) * end[sel]
        out[sel] = sampled_contact(aa, bb, t, *samples[0], *samples[1], bound, counted)
    return out


def time_to_collision(a: Motion, b: Motion, horizon: float | np.ndarray, model: str = "cv",
                      tolerance: float = 0.05, max_step: float = 0.5) -> np.ndarray:
    """TTC [s] of outline pairs under the prediction ``model``.

    Pairs whose prediction differs from CV by less than ``tolerance`` [m]
    (:func:`deviation`) use the exact CV sweep (:func:`ttc_cv`), the others
    :func:`ttc_sampled`.  ``inf`` = no contact within ``horizon`` [s]
    (scalar or per pair).
    """
    if model == "cv":
        return ttc_cv(a, b, horizon)
    n = a.x.shape[0]
    horizon = np.broadcast_to(np.asarray(horizon, float), (n,))
    sampled = deviation(a, b, model, horizon) > tolerance
    out = np.empty(n)
    if (~sampled).any():
        out[~sampled] = ttc_cv(a.take(~sampled), b.take(~sampled), horizon[~sampled])
    if sampled.any():
        out[sampled] = ttc_sampled(a.take(sampled), b.take(sampled), horizon[sampled], model,
                                   tolerance, max_step)
    return out


def braked_arclength(speed: np.ndarray, delay: np.ndarray | float, deceleration: np.ndarray,
                     t: np.ndarray) -> np.ndarray:
    """Distance [m] (n, K) travelled after times ``t`` [s], (K,) or (n, K), when braking
    starts after ``delay`` [s].

    u = v t up to the delay, then v t - a (t - delay)^2 / 2 until standstill
    at delay + v / a, then constant (docs/aeb.md, eq. 3.6).
    """
    v = speed[:, None]
    a = deceleration[:, None]
    d = np.broadcast_to(np.asarray(delay, float), speed.shape)[:, None]
    braking = np.clip(t - d, 0.0, v / a)
    return v * np.minimum(t, d) + v * braking - 0.5 * a * braking**2


def braked_contact(a: Motion, b: Motion, delay: np.ndarray | float, deceleration: np.ndarray,
                   horizon: float | np.ndarray, model: str = "cv", step: float = 0.1,
                   tail: float = 0.3) -> np.ndarray:
    """Whether outline A still touches B when A brakes at ``deceleration`` after ``delay``.

    A keeps its path (straight along its direction of motion, or the arc of
    its current curvature for the turning models) and covers the arc length
    of :func:`braked_arclength`; B moves as ``model`` predicts.  The time from
    the earliest possible contact (:func:`earliest_contact`) to the later of
    ``horizon`` and A's standstill plus ``tail`` [s] is cut into intervals of
    ``step`` [s] and swept as in :func:`sampled_contact`; a contact with the
    stopped A (B running into it) counts.  For a stationary B and a straight
    path the answer is exact (the sweep covers exactly the stretch A
    travels); otherwise positions within an interval are off by at most
    a step^2 / 8 (1 cm at 8 m/s^2 and 0.1 s).

    Parameters
    ----------
    a, b : Motion
        Ego (braking) and object, n pairs.
    delay : float or ndarray (n,)
        Time [s] until the equivalent step of deceleration acts.
    deceleration : ndarray (n,)
        Deceleration [m/s^2], > 0.
    horizon : float or ndarray (n,)
        Contacts up to this time [s] count (at least until A's standstill + tail).
    model : {"cv", "ctrv", "ca", "ctra"}
    step, tail : float
        Sampling step and time after standstill [s].

    Returns
    -------
    ndarray of bool (n,)
    """
    n = a.x.shape[0]
    out = np.zeros(n, dtype=bool)
    delay_arr = np.broadcast_to(np.asarray(delay, float), (n,))
    end = np.maximum(delay_arr + a.speed / deceleration + tail, horizon)
    # the braking ego never gains speed: bound its contact time with speed only
    first = earliest_contact(a._replace(accel=np.zeros(n)), b, model)
    live = first <= end
    if not live.any():
        return out
    a, b, end, first = a.take(live), b.take(live), end[live], first[live]
    delay_arr, deceleration = delay_arr[live], deceleration[live]
    t, counted = _grid(first, end, step)
    curvature_a = model_terms(a, model)[1]
    accel_b, curvature_b = model_terms(b, model)
    samples_a = _path_samples(a, braked_arclength(a.speed, delay_arr, deceleration, t),
                              curvature_a)
    samples_b = _path_samples(b, predicted_arclength(b.speed, accel_b, t), curvature_b)
    bound = a.speed + b.speed + np.maximum(accel_b, 0.0) * end
    out[live] = np.isfinite(sampled_contact(a, b, t, *samples_a, *samples_b, bound, counted))
    return out
