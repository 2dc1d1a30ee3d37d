"""Sampling of the uncertain inputs: per-case distributions, inverse-CDF draws, seeded.

:func:`resolve_inputs` turns the configuration into one distribution per input
and case (the configured one, a road-surface override or a normal with the
database's standard deviation, conditioned on the input's physical bounds);
:func:`values_from_unit` maps probabilities to input values through the
vectorised inverse CDF (:func:`distribution_ppf`); :func:`sample_inputs` draws
them from a seeded :class:`numpy.random.Generator` (:func:`make_rng`), by plain
Monte Carlo or by randomised quasi-Monte Carlo (:func:`unit_samples`: scrambled
Sobol' or Latin hypercube from :mod:`scipy.stats.qmc`, one independent
randomisation per case, seeded from the generator).
Values are SI (or factors).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy.special import ndtr, ndtri

from vfs.database.post_impact import post_impact_inputs
from vfs.errors import ParameterError
from vfs.uncertainty.cases import CaseSet
from vfs.uncertainty.config import (
    FACTOR,
    FAMILIES,
    FIXED,
    INPUT_NAMES,
    INPUTS,
    LOGNORMAL,
    MODES,
    NORMAL,
    OFFSET,
    SURFACES,
    TRUNCNORMAL,
    UNIFORM,
    UncertaintyConfig,
)


def make_rng(seed: int | np.random.Generator | None) -> tuple[np.random.Generator, int | None]:
    """The generator of all random numbers of a run, and the seed to report.

    Parameters
    ----------
    seed : int or numpy.random.Generator
        An int seeds :func:`numpy.random.default_rng` (reproducible runs); a
        generator is used as it is (reported seed None).

    Raises
    ------
    ParameterError
        For None: runs must be reproducible.
    """
    if isinstance(seed, np.random.Generator):
        return seed, None
    if seed is None:
        raise ParameterError("a seed (int) or numpy.random.Generator is required "
                             "(runs must be reproducible)")
    return np.random.default_rng(int(seed)), int(seed)


def distribution_ppf(family: np.ndarray, a: np.ndarray, b: np.ndarray, lo: np.ndarray,
                     hi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Inverse CDF of per-row distributions, vectorised.

    Parameters
    ----------
    family : ndarray of int (M,)
        Family codes (:data:`FIXED` ... :data:`LOGNORMAL`).
    a, b, lo, hi : ndarray (M,)
        Parameters from :meth:`Distribution.params`: uniform (low, high),
        normal (mean, sd), truncated normal (mean, sd, low, high), lognormal
        (log median, sigma), fixed (value).
    u : ndarray (M,)
        Probabilities in (0, 1).

    Returns
    -------
    ndarray (M,)
        The draws (same unit as the parameters).
    """
    u = np.clip(np.asarray(u, float), 1e-12, 1.0 - 1e-12)
    out = np.array(a, dtype=float, copy=True)  # fixed: the value
    m = family == UNIFORM
    out[m] = a[m] + u[m] * (b[m] - a[m])
    m = family == NORMAL
    out[m] = a[m] + b[m] * ndtri(u[m])
    m = family == LOGNORMAL
    out[m] = np.exp(a[m] + b[m] * ndtri(u[m]))
    m = np.flatnonzero(family == TRUNCNORMAL)
    if m.size:
        za = (lo[m] - a[m]) / b[m]
        zb = (hi[m] - a[m]) / b[m]
        # work in the lower tail (reflect when the interval lies above the mean) for accuracy
        flip = za > 0.0
        za, zb = np.where(flip, -zb, za), np.where(flip, -za, zb)
        uu = np.where(flip, 1.0 - u[m], u[m])
        pa, pb = ndtr(za), ndtr(zb)
        z = ndtri(np.clip(pa + uu * (pb - pa), 1e-300, 1.0 - 1e-16))
        z = np.clip(z, za, zb)
        out[m] = a[m] + b[m] * np.where(flip, -z, z)
    return out


class ResolvedInputs(NamedTuple):
    """The distribution of every input for every case, as arrays (d inputs, N cases).

    Attributes
    ----------
    family, mode : ndarray of int (d, N)
    a, b, lo, hi : ndarray (d, N)
        Parameters of :func:`distribution_ppf` (SI, or factors).
    nominal : ndarray (d, N)
        Nominal values [SI].
    bounds : ndarray (d, 2)
        Physical limits (:attr:`InputInfo.bounds`).
    from_database : ndarray of bool (d, N)
        True where the database's standard deviation was used.
    """

    family: np.ndarray
    mode: np.ndarray
    a: np.ndarray
    b: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    nominal: np.ndarray
    bounds: np.ndarray
    from_database: np.ndarray

    @property
    def varied(self) -> np.ndarray:
        """(d,) True for inputs that vary in at least one case."""
        return np.any(self.family != FIXED, axis=1)

    @property
    def varied_names(self) -> tuple[str, ...]:
        """Names of the varied inputs."""
        return tuple(n for n, v in zip(INPUT_NAMES, self.varied, strict=True) if v)


def nominal_inputs(cases: CaseSet, config: UncertaintyConfig) -> np.ndarray:
    """Nominal input values (d, N) [SI]: the database's values, no shifts."""
    c = cases.config
    n = cases.size
    post = post_impact_inputs(cases.reconstruction, cases.case_id)
    steer = np.zeros((n, 2)) if post is None else post.steer()  # [rad], the data's or 0
    rows = {
        "road_friction": cases.road_friction,
        "restitution": c.restitution,
        "contact_friction": c.contact_friction,
        "poi_shift_t": np.zeros(n), "poi_shift_n": np.zeros(n), "cp_angle": np.zeros(n),
        "penetration_time": cases.penetration,
        "speed1": np.hypot(c.vx[:, 0], c.vy[:, 0]), "speed2": np.hypot(c.vx[:, 1], c.vy[:, 1]),
        "mass1": c.m[:, 0], "mass2": c.m[:, 1],
        "wheel_brake1": np.full(n, config.wheel_brake),
        "wheel_brake2": np.full(n, config.wheel_brake),
        "corner_brake1": np.zeros(n), "corner_brake2": np.zeros(n),
        "steer1": steer[:, 0], "steer2": steer[:, 1],
    }
    return np.stack([np.asarray(rows[name], float) for name in INPUT_NAMES])


def resolve_inputs(cases: CaseSet, config: UncertaintyConfig) -> ResolvedInputs:
    """Per-case distributions of every input: the configured one, the road-surface
    override, or normal with the database's sd (``database_sd``).
    """
    d, n = len(INPUT_NAMES), cases.size
    family = np.zeros((d, n), dtype=int)
    mode = np.zeros((d, n), dtype=int)
    a, b = np.zeros((d, n)), np.zeros((d, n))
    lo, hi = np.full((d, n), -np.inf), np.full((d, n), np.inf)
    nominal = nominal_inputs(cases, config)
    bounds = np.array([info.bounds for info in INPUTS], float)
    from_db = np.zeros((d, n), dtype=bool)
    for k, name in enumerate(INPUT_NAMES):
        spec = config.inputs[name]
        dists = [spec.distribution] + [spec.surface.get(s, spec.distribution)
                                       for s in SURFACES]
        which = np.zeros(n, dtype=int)  # 0: default, 1 + j: surface j
        for j, s in enumerate(SURFACES):
            if s in spec.surface:
                which[cases.road_surface == s] = 1 + j
        for j, dist in enumerate(dists):
            m = which == j
            if not m.any():
                continue
            family[k, m] = FAMILIES.index(dist.family)
            mode[k, m] = MODES.index(dist.mode)
            pa, pb, plo, phi = dist.params()
            a[k, m], b[k, m], lo[k, m], hi[k, m] = pa, pb, plo, phi
        if spec.database_sd:
            sd = cases.sd.get(name, np.full(n, np.nan))
            m = np.isfinite(sd) & (sd > 0)
            family[k, m], mode[k, m] = NORMAL, OFFSET
            a[k, m], b[k, m] = 0.0, sd[m]
            from_db[k, m] = True
        _truncate_to_bounds(family[k], mode[k], a[k], b[k], lo[k], hi[k], nominal[k],
                            bounds[k])
    return ResolvedInputs(family, mode, a, b, lo, hi, nominal, bounds, from_db)


def _truncate_to_bounds(family: np.ndarray, mode: np.ndarray, a: np.ndarray, b: np.ndarray,
                        lo: np.ndarray, hi: np.ndarray, nominal: np.ndarray,
                        bounds: np.ndarray) -> None:
    """Condition each case's distribution on the input's physical bounds (in place).

    The bounds of the value become bounds of the draw (offset: minus the nominal
    value; factor: divided by it); uniform supports are intersected with them,
    normal distributions become truncated normals.  So no probability piles up
    at a bound (as clipping would do); :func:`values_from_unit` clips only
    rounding and lognormal tails.
    """
    blo = np.full(nominal.shape, bounds[0])
    bhi = np.full(nominal.shape, bounds[1])
    off = mode == OFFSET
    blo[off], bhi[off] = blo[off] - nominal[off], bhi[off] - nominal[off]
    fac = (mode == FACTOR) & (nominal > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        blo[fac], bhi[fac] = blo[fac] / nominal[fac], bhi[fac] / nominal[fac]
    free = (mode == FACTOR) & ~(nominal > 0)  # zero nominal: the factor cannot matter
    blo[free], bhi[free] = -np.inf, np.inf
    u = family == UNIFORM
    a[u], b[u] = np.maximum(a[u], blo[u]), np.minimum(b[u], bhi[u])
    empty = u & ~(a < b)  # support entirely outside the bounds: the nearest bound
    family[empty] = FIXED
    a[empty] = np.clip(np.where(a[empty] >= bhi[empty], bhi[empty], blo[empty]),
                       blo[empty], bhi[empty])
    nrm = (family == NORMAL) & (np.isfinite(blo) | np.isfinite(bhi))
    family[nrm] = TRUNCNORMAL
    lo[nrm], hi[nrm] = blo[nrm], bhi[nrm]
    t = family == TRUNCNORMAL
    lo[t], hi[t] = np.maximum(lo[t], blo[t]), np.minimum(hi[t], bhi[t])
    bad = t & ~(lo < hi)
    family[bad] = FIXED
    a[bad] = np.clip(a[bad], blo[bad], bhi[bad])


class SampledInputs(NamedTuple):
    """Input values of M model runs.

    Attributes
    ----------
    rows : ndarray of int (M,)
        Case position of each run.
    values : ndarray (M, d)
        Input values [SI], columns :data:`INPUT_NAMES`.
    clipped : ndarray of int (d,)
        Number of values clipped to the physical bounds per input.
    """

    rows: np.ndarray
    values: np.ndarray
    clipped: np.ndarray


def values_from_unit(resolved: ResolvedInputs, u: np.ndarray, rows: np.ndarray,
                     columns: Sequence[int] | None = None) -> SampledInputs:
    """Input values for probabilities ``u`` (inverse-CDF transform).

    Parameters
    ----------
    resolved : ResolvedInputs
    u : ndarray (M, k)
        Probabilities in (0, 1) of the inputs ``columns``.
    rows : ndarray of int (M,)
        Case position of each run.
    columns : sequence of int, optional
        Input indices (into :data:`INPUT_NAMES`) of the columns of ``u``
        (default: all inputs).  The other inputs take their fixed value
        (their median where they are not fixed).

    Returns
    -------
    SampledInputs
    """
    rows = np.asarray(rows, dtype=int)
    d = len(INPUT_NAMES)
    cols = list(range(d)) if columns is None else list(columns)
    u = np.asarray(u, float).reshape(rows.shape[0], len(cols))
    full = np.full((rows.shape[0], d), 0.5)
    full[:, cols] = u
    values = np.empty((rows.shape[0], d))
    clipped = np.zeros(d, dtype=int)
    for k in range(d):
        fam = resolved.family[k, rows]
        draw = distribution_ppf(fam, resolved.a[k, rows], resolved.b[k, rows],
                                resolved.lo[k, rows], resolved.hi[k, rows], full[:, k])
        mode = resolved.mode[k, rows]
        nom = resolved.nominal[k, rows]
        x = np.where(mode == OFFSET, nom + draw, np.where(mode == FACTOR, nom * draw, draw))
        lo, hi = resolved.bounds[k]
        bad = (x < lo) | (x > hi)
        clipped[k] = int(np.count_nonzero(bad))
        values[:, k] = np.clip(x, lo, hi)
    return SampledInputs(rows, values, clipped)


#: Sampling methods of :func:`unit_samples` (``vfs uncertainty --sampling``).
SAMPLING_METHODS: tuple[str, ...] = ("random", "sobol", "lhs")

#: Default sampling method: scrambled Sobol' needed the fewest samples for a given accuracy
#: of the 5-95 % band in ``vfs bench uncertainty_sampling`` (docs/uncertainty.md).
DEFAULT_SAMPLING = "sobol"


def unit_samples(n_samples: int, n_cases: int, dim: int, rng: np.random.Generator,
                 method: str = DEFAULT_SAMPLING) -> np.ndarray:
    """Probabilities in (0, 1) for S samples of N cases in d dimensions.

    Parameters
    ----------
    n_samples, n_cases, dim : int
        S, N and d.
    rng : numpy.random.Generator
        The only source of randomness (also seeds the QMC randomisation).
    method : {"random", "sobol", "lhs"}
        ``random``: independent uniforms (plain Monte Carlo).  ``sobol``: for every case
        its own scrambled Sobol' sequence (Owen scrambling, :class:`scipy.stats.qmc.Sobol`);
        its balance holds for S a power of two (other S take the first S points, still
        valid but less even).  ``lhs``: for every case its own Latin hypercube
        (:class:`scipy.stats.qmc.LatinHypercube`): each input's S strata hit once.
        Randomised QMC keeps every point uniform on (0, 1)^d, so the estimates stay
        unbiased; cases are independent of each other.

    Returns
    -------
    ndarray (S N, d)
        Sample-major: row s N + j is sample s of case j.

    Raises
    ------
    ParameterError
        Unknown method or S < 1.
    """
    if method not in SAMPLING_METHODS:
        raise ParameterError(f"sampling method {method!r} is not one of "
                             f"{', '.join(SAMPLING_METHODS)}")
    if n_samples < 1:
        raise ParameterError(f"samples = {n_samples} must be >= 1")
    s, n, d = int(n_samples), int(n_cases), int(dim)
    if method == "random":
        return rng.random((s * n, d))
    from scipy.stats import qmc  # imported on first use (about 0.5 s)

    u = np.empty((s, n, d))
    for j in range(n):
        if method == "sobol":
            engine = qmc.Sobol(d, scramble=True, rng=rng)
            with warnings.catch_warnings():  # S not a power of two: documented above
                warnings.simplefilter("ignore", UserWarning)
                u[:, j, :] = engine.random(s)
        else:
            u[:, j, :] = qmc.LatinHypercube(d, rng=rng).random(s)
    return u.reshape(s * n, d)


def sample_inputs(resolved: ResolvedInputs, n_samples: int, rng: np.random.Generator,
                  method: str = "random") -> SampledInputs:
    """S samples of every case: M = S x N runs, sample-major (row s N + j is sample s of
    case j), by plain Monte Carlo or randomised QMC (:func:`unit_samples`).
    """
    if n_samples < 1:
        raise ParameterError(f"samples = {n_samples} must be >= 1")
    d, n = resolved.family.shape
    rows = np.tile(np.arange(n), n_samples)
    u = unit_samples(int(n_samples), n, d, rng, method)
    return values_from_unit(resolved, u, rows)


__all__ = [
    "DEFAULT_SAMPLING", "SAMPLING_METHODS",
    "ResolvedInputs", "SampledInputs", "distribution_ppf", "make_rng", "nominal_inputs",
    "resolve_inputs", "sample_inputs", "unit_samples", "values_from_unit",
]
