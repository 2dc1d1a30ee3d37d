"""Global sensitivity of the collision outcomes: Sobol indices (``vfs sensitivity``).

The Momentum Based Impact Model paper ends its outlook with "an ANOVA could be
used to find the most sensitive pre-collision impact parameters ... POI, angle of the CP,
penetration depth, masses of the vehicles and others".  Sobol indices are
that analysis of variance for a non-linear model: the variance of an outcome
Y = f(X_1, ..., X_d) with independent inputs splits into the shares of the
main effects and of all interactions (Sobol' 1993), and

* the first-order index S_i = Var(E[Y | X_i]) / Var(Y) is the share of the
  main effect of X_i (the ANOVA's main effect),
* the total index ST_i = E[Var(Y | X_~i)] / Var(Y) adds every interaction of
  X_i; ST_i >= S_i, sum S_i <= 1, and ST_i = 0 exactly when Y does not depend
  on X_i.

Estimation (Saltelli et al. 2010, "Variance based sensitivity analysis of
model output", the scheme SALib implements): two independent n x d sample
matrices A and B (a scrambled Sobol' sequence of dimension 2d, split in two)
and the d matrices AB_i (A with column i from B), n (d + 2) model runs; with
the outputs centred on their overall mean,

    V    = Var([f(A), f(B)])
    S_i  = mean( f(B) (f(AB_i) - f(A)) ) / V                 (Saltelli 2010)
    ST_i = mean( (f(A) - f(AB_i))^2 ) / (2 V)                (Jansen 1999)

Every term is a mean over the n base rows, so the bootstrap (resampling base
rows, as SALib does) is one matrix product of resampling weights with the
per-row terms.  :func:`sobol_indices` works on outputs with any trailing
shape (cases x outcomes) at once.  :func:`sensitivity_analysis` applies it to
the impact and run-out model of :mod:`vfs.uncertainty.model`, per case, and
averages the per-case indices separately over the cases whose nominal
impact is full and those whose nominal impact is sliding.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from scipy.stats import qmc

from vfs.errors import ParameterError
from vfs.physics.impact import impact_type_names
from vfs.uncertainty.bands import input_table, unwrap_circular
from vfs.uncertainty.cases import CaseSet
from vfs.uncertainty.config import INPUT_NAMES, INPUTS_BY_NAME, UncertaintyConfig, default_config
from vfs.uncertainty.model import evaluate, nominal_runs
from vfs.uncertainty.outcomes import OUTCOME_NAMES, OUTCOMES_BY_NAME, RENAMED_OUTCOMES
from vfs.uncertainty.sampling import resolve_inputs, values_from_unit

#: Name of the dummy input that enters no outcome (its indices must be ~0).
DUMMY = "dummy"
#: Groups of the aggregated indices: the nominal impact type of the case.
GROUPS: tuple[str, ...] = ("all", "full", "sliding")
#: Default outcomes of the analysis.
DEFAULT_OUTCOMES: tuple[str, ...] = (
    "delta_v1", "delta_v2", "ees1", "ees2", "velocity_angle_change1", "velocity_angle_change2",
    "post_speed1", "post_speed2", "runout_distance1", "runout_distance2", "sliding",
)


# ----------------------------------------------------------------------------
# Saltelli design and estimators
# ----------------------------------------------------------------------------


class SaltelliDesign(NamedTuple):
    """The two base matrices of a Saltelli design (points in [0, 1)^d).

    Attributes
    ----------
    a, b : ndarray (n, d)
    """

    a: np.ndarray
    b: np.ndarray

    @property
    def n(self) -> int:
        """Base samples n."""
        return int(self.a.shape[0])

    @property
    def d(self) -> int:
        """Inputs d."""
        return int(self.a.shape[1])

    def matrix(self) -> np.ndarray:
        """All n (d + 2) points in block order [A; B; AB_1; ...; AB_d] (rows)."""
        blocks = [self.a, self.b]
        for i in range(self.d):
            ab = self.a.copy()
            ab[:, i] = self.b[:, i]
            blocks.append(ab)
        return np.concatenate(blocks, axis=0)


def saltelli_design(n: int, d: int, rng: np.random.Generator,
                    method: str = "sobol") -> SaltelliDesign:
    """Base matrices A, B for n (d + 2) model runs.

    Parameters
    ----------
    n : int
        Base samples; a power of two for ``method="sobol"`` (the balance of
        the Sobol' sequence), >= 4.
    d : int
        Number of inputs, >= 1.
    rng : numpy.random.Generator
        Scrambling seed (Owen scrambling) or the random numbers.
    method : {"sobol", "random"}
        ``sobol``: a scrambled Sobol' sequence of dimension 2d, columns 1..d
        are A and d+1..2d are B (as SALib); ``random``: independent uniforms.
    """
    if d < 1:
        raise ParameterError(f"d = {d}: need at least one input")
    if n < 4:
        raise ParameterError(f"base samples n = {n} must be >= 4")
    if method == "sobol":
        m = int(round(math.log2(n)))
        if 2**m != n:
            raise ParameterError(f"base samples n = {n} must be a power of two (e.g. "
                                 f"{2 ** max(2, m)}) for the Sobol' sequence")
        pts = qmc.Sobol(2 * d, scramble=True, seed=rng).random_base2(m)
    elif method == "random":
        pts = rng.random((n, 2 * d))
    else:
        raise ParameterError(f"method = {method!r}; use 'sobol' or 'random'")
    return SaltelliDesign(pts[:, :d], pts[:, d:])


class SobolIndices(NamedTuple):
    """First-order and total Sobol indices with bootstrap intervals.

    Arrays have shape (d, *rest) (``rest`` = the trailing shape of the
    outputs); the intervals are NaN without bootstrap; everything is NaN where
    the output has no variance.

    Attributes
    ----------
    s1, st : ndarray
        Point estimates (Saltelli 2010, Jansen 1999).
    s1_low, s1_high, st_low, st_high : ndarray
        Percentile bootstrap interval (resampled base rows).
    variance : ndarray (*rest)
        Output variance V (unit of the output squared).
    n : int
        Base samples.
    """

    s1: np.ndarray
    st: np.ndarray
    s1_low: np.ndarray
    s1_high: np.ndarray
    st_low: np.ndarray
    st_high: np.ndarray
    variance: np.ndarray
    n: int


def _row_terms(y: np.ndarray, n: int, d: int) -> np.ndarray:
    """Per-base-row terms whose means give every estimator: (n, 4 + 2d, *rest).

    Order: f(A), f(A)^2, f(B), f(B)^2, then f(B)(f(AB_i) - f(A)) for i = 1..d,
    then (f(A) - f(AB_i))^2 / 2.
    """
    y = y - y.mean(axis=0)  # centring on the overall mean (as SALib): smaller estimator variance
    ya, yb = y[:n], y[n:2 * n]
    yab = y[2 * n:].reshape((d, n) + y.shape[1:])
    first = yb[None] * (yab - ya[None])
    total = 0.5 * (ya[None] - yab) ** 2
    head = np.stack([ya, ya * ya, yb, yb * yb], axis=1)
    return np.concatenate([head, np.moveaxis(first, 0, 1), np.moveaxis(total, 0, 1)], axis=1)


def _indices_from_means(means: np.ndarray, d: int, floor: np.ndarray | float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(S1, ST, V) from the means of the :func:`_row_terms` (term axis first: (T, ...)).

    Where V <= ``floor`` (no variance beyond rounding) the indices are NaN.
    """
    ma, ma2, mb, mb2 = means[0], means[1], means[2], means[3]
    var = 0.5 * (ma2 + mb2) - (0.5 * (ma + mb)) ** 2
    ok = var > floor
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(ok, 1.0 / np.where(ok, var, 1.0), np.nan)
    s1 = means[4:4 + d] * scale
    st = means[4 + d:4 + 2 * d] * scale
    return s1, st, var


def sobol_indices(y: np.ndarray, d: int, n_boot: int = 0, confidence: float = 0.95,
                  rng: np.random.Generator | None = None,
                  max_block: int = 20_000_000) -> SobolIndices:
    """Sobol indices from the outputs of a Saltelli design.

    Parameters
    ----------
    y : ndarray (n (d + 2), *rest)
        Model outputs in the row order of :meth:`SaltelliDesign.matrix`;
        any trailing shape (e.g. cases x outcomes) is analysed at once.
    d : int
        Number of inputs.
    n_boot : int
        Bootstrap resamples of the base rows (0: no intervals).
    confidence : float
        Level of the percentile intervals.
    rng : numpy.random.Generator
        Required for the bootstrap.
    max_block : int
        Largest number of floats of one bootstrap block (memory bound).

    Returns
    -------
    SobolIndices
    """
    y = np.asarray(y, float)
    rows = y.shape[0]
    if rows % (d + 2) or rows == 0:
        raise ParameterError(f"{rows} output rows do not form a Saltelli design of d = {d} "
                             f"(need n (d + 2) rows)")
    n = rows // (d + 2)
    if not np.isfinite(y).all():
        raise ParameterError("model outputs contain NaN or inf; Sobol indices need finite "
                             "outputs")
    # variance below rounding noise of the outputs' magnitude counts as none
    floor = 1e-24 * np.mean(y * y, axis=0) + 1e-300
    terms = _row_terms(y, n, d)  # (n, T, *rest)
    s1, st, var = _indices_from_means(terms.mean(axis=0), d, floor)
    nan = np.full_like(s1, np.nan)
    lo1 = hi1 = lot = hit = nan
    if n_boot:
        if rng is None:
            raise ParameterError("the bootstrap needs rng (numpy.random.Generator)")
        if not 0.0 < confidence < 1.0:
            raise ParameterError(f"confidence = {confidence} outside (0, 1)")
        flat = terms.reshape(n, -1)
        counts = np.zeros((n_boot, n))
        idx = rng.integers(0, n, size=(n_boot, n))
        np.add.at(counts, (np.repeat(np.arange(n_boot), n), idx.ravel()), 1.0)
        counts /= n
        boot1 = np.empty((n_boot,) + s1.shape)
        boott = np.empty_like(boot1)
        step = max(1, max_block // max(1, flat.shape[1]))
        for lo in range(0, n_boot, step):
            means = (counts[lo:lo + step] @ flat).reshape((-1,) + terms.shape[1:])
            b1, bt, _ = _indices_from_means(np.moveaxis(means, 1, 0), d, floor)
            boot1[lo:lo + step] = np.moveaxis(b1, 1, 0)
            boott[lo:lo + step] = np.moveaxis(bt, 1, 0)
        alpha = 0.5 * (1.0 - confidence)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN: zero-variance outputs
            lo1, hi1 = np.nanquantile(boot1, [alpha, 1.0 - alpha], axis=0)
            lot, hit = np.nanquantile(boott, [alpha, 1.0 - alpha], axis=0)
    return SobolIndices(s1, st, lo1, hi1, lot, hit, var, n)


def sobol_analyze(func: Callable[[np.ndarray], np.ndarray], d: int, n: int,
                  rng: np.random.Generator, n_boot: int = 0,
                  confidence: float = 0.95) -> SobolIndices:
    """Sobol indices of a vectorised function of d inputs uniform on [0, 1).

    ``func(x)`` takes (M, d) points and returns (M, ...) outputs.
    """
    design = saltelli_design(n, d, rng)
    y = np.asarray(func(design.matrix()), float)
    return sobol_indices(y, d, n_boot=n_boot, confidence=confidence, rng=rng)


def ishigami(x: np.ndarray, a: float = 7.0, b: float = 0.1) -> np.ndarray:
    """Ishigami function of x in [0, 1)^3 mapped to [-pi, pi)^3 (a test function with
    known indices; x3 has S1 = 0 but ST > 0 through its interaction with x1).
    """
    z = -np.pi + 2.0 * np.pi * np.asarray(x, float)
    return np.sin(z[:, 0]) + a * np.sin(z[:, 1]) ** 2 + b * z[:, 2] ** 4 * np.sin(z[:, 0])


def ishigami_indices(a: float = 7.0, b: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Analytic first-order and total indices of :func:`ishigami` (Sobol' and Levitan 1999)."""
    v1 = 0.5 * (1.0 + b * np.pi**4 / 5.0) ** 2
    v2 = a**2 / 8.0
    v13 = b**2 * np.pi**8 * (1.0 / 18.0 - 1.0 / 50.0)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


# ----------------------------------------------------------------------------
# The collision model
# ----------------------------------------------------------------------------


class SensitivityResult(NamedTuple):
    """Result of :func:`sensitivity_analysis`.

    Attributes
    ----------
    per_case : pandas.DataFrame
        One row per case, outcome and input: ``case_id``, ``group`` (nominal
        impact type), ``outcome``, ``input``, ``s1``, ``s1_low``, ``s1_high``,
        ``st``, ``st_low``, ``st_high``, ``variance`` [SI unit squared].
    groups : pandas.DataFrame
        Per group (``all``, ``full``, ``sliding``), outcome and input: mean
        of the per-case indices over the cases with output variance
        (``n_cases``), its case-bootstrap interval, and ``rank`` by the mean
        total index (1 = most influential).
    inputs : pandas.DataFrame
        The analysed inputs and their distributions (plus the dummy).
    names : tuple of str
        Analysed inputs in design column order (the dummy last).
    n_base : int
    n_runs : int
        Model runs n (d + 2) x cases.
    seed : int or None
    seconds : float
    """

    per_case: pd.DataFrame
    groups: pd.DataFrame
    inputs: pd.DataFrame
    names: tuple[str, ...]
    n_base: int
    n_runs: int
    seed: int | None
    seconds: float

    def ranking(self, outcome: str, group: str = "all") -> pd.DataFrame:
        """The inputs of one outcome and group ranked by the total index."""
        g = self.groups
        out = g[(g["outcome"] == outcome) & (g["group"] == group)]
        return out.sort_values("rank").reset_index(drop=True)


def _check_outcomes(outcomes: Sequence[str] | None) -> tuple[str, ...]:
    names = DEFAULT_OUTCOMES if outcomes is None else tuple(outcomes)
    old = [o for o in names if o in RENAMED_OUTCOMES]
    if old:
        warnings.warn(f"outcomes {old} are now called "
                      f"{[RENAMED_OUTCOMES[o] for o in old]}", DeprecationWarning, stacklevel=3)
        names = tuple(RENAMED_OUTCOMES.get(o, o) for o in names)
    unknown = [o for o in names if o not in OUTCOMES_BY_NAME]
    if unknown or not names:
        raise ParameterError(f"unknown outcomes {unknown}; known: {', '.join(OUTCOME_NAMES)}")
    return names


def _group_means(values: np.ndarray, members: np.ndarray, n_boot: int, confidence: float,
                 rng: np.random.Generator, max_block: int = 20_000_000
                 ) -> tuple[np.ndarray, ...]:
    """Mean over the member cases (axis 1 of (d, N, K)) with a case-bootstrap interval.

    Returns mean, low, high (d, K) and the number of cases with finite indices.
    """
    sub = values[:, members]
    nan = np.full(sub.shape[:1] + sub.shape[2:], np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # groups without variance: NaN
        mean = np.nanmean(sub, axis=1) if members.size else nan
        count = np.isfinite(sub).sum(axis=1)
        if not n_boot or members.size == 0:
            return mean, nan, nan.copy(), count
        idx = rng.integers(0, members.size, size=(n_boot, members.size))
        boot = np.empty((n_boot,) + nan.shape)
        step = max(1, max_block // max(1, sub.size))
        for lo in range(0, n_boot, step):
            block = sub[:, idx[lo:lo + step]]  # (d, b, m, K)
            boot[lo:lo + step] = np.moveaxis(np.nanmean(block, axis=2), 1, 0)
        alpha = 0.5 * (1.0 - confidence)
        lo_q, hi_q = np.nanquantile(boot, [alpha, 1.0 - alpha], axis=0)
    return mean, lo_q, hi_q, count


def sensitivity_analysis(cases: CaseSet, config: UncertaintyConfig | None = None,
                         n_base: int = 256, seed: int | np.random.Generator | None = 0,
                         outcomes: Sequence[str] | None = None, n_boot: int = 200,
                         confidence: float = 0.95, dummy: bool = True) -> SensitivityResult:
    """Sobol indices of the outcomes on the uncertain inputs, per case and per group.

    The inputs are the varied inputs of ``config`` (:mod:`vfs.uncertainty.model`;
    each keeps its distribution, so the indices answer "which of the stated
    uncertainties matters most"), plus a dummy input that enters nothing.
    Every case gets the same Saltelli design (its points mapped through the
    case's own distributions); all n (d + 2) x N runs are one vectorised
    batch.

    Groups: the cases are split by their *nominal* impact type (the model at
    the nominal inputs), not by each sample's type: the Saltelli estimators
    need every design row of a case, and conditioning on a sampled output
    would drop rows and bias the indices; the influence of an input on the
    switch between full and sliding shows in the outcome ``sliding``
    (variance p (1 - p)).

    Parameters
    ----------
    cases : CaseSet
    config : UncertaintyConfig, optional
    n_base : int
        Base samples n per case (a power of two).
    seed : int or numpy.random.Generator
    outcomes : sequence of str, optional
        Default :data:`DEFAULT_OUTCOMES`.
    n_boot : int
        Bootstrap resamples (base rows per case; cases per group).
    confidence : float
    dummy : bool
        Add the dummy input :data:`DUMMY`.

    Returns
    -------
    SensitivityResult
    """
    t0 = time.perf_counter()
    config = config or default_config()
    if isinstance(seed, np.random.Generator):
        rng, seed_int = seed, None
    elif seed is None:
        raise ParameterError("a seed (int) or numpy.random.Generator is required")
    else:
        rng, seed_int = np.random.default_rng(int(seed)), int(seed)
    names_out = _check_outcomes(outcomes)
    resolved = resolve_inputs(cases, config)
    varied = [k for k, v in enumerate(resolved.varied) if v]
    if not varied:
        raise ParameterError("no input varies: every input of the configuration is fixed")
    names = tuple(INPUT_NAMES[k] for k in varied) + ((DUMMY,) if dummy else ())
    d = len(names)
    design = saltelli_design(int(n_base), d, rng)
    x = design.matrix()  # (R, d)
    r, n = x.shape[0], cases.size
    rows = np.tile(np.arange(n), r)  # design-major: row i N + j is design row i of case j
    u = np.repeat(x[:, :len(varied)], n, axis=0)
    sampled = values_from_unit(resolved, u, rows, varied)
    runs = evaluate(cases, sampled, config, show="running the model for the Sobol samples")
    nom = nominal_runs(cases, config)
    y = np.empty((r, n, len(names_out)))
    for k, name in enumerate(names_out):
        v = runs.outcomes[name].reshape(r, n)
        if OUTCOMES_BY_NAME[name].kind == "circular":
            ref = np.where(np.isfinite(nom.outcomes[name]), nom.outcomes[name], 0.0)
            v = unwrap_circular(v, ref[None, :])
        # NaN (e.g. change of velocity angle of a standing vehicle) -> 0: no variance
        y[:, :, k] = np.where(np.isfinite(v), v, 0.0)
    idx = sobol_indices(y, d, n_boot=n_boot, confidence=confidence, rng=rng)
    group = impact_type_names(nom.impact_type)
    per_case = _per_case_table(idx, cases.case_id, group, names, names_out)
    tables = []
    for g in GROUPS:
        members = np.arange(n) if g == "all" else np.flatnonzero(group == g)
        parts = {}
        for key in ("s1", "st"):
            mean, lo, hi, count = _group_means(getattr(idx, key), members, n_boot, confidence,
                                               rng)
            parts[key], parts[f"{key}_low"], parts[f"{key}_high"] = mean, lo, hi
            parts["n_cases"] = count
        for k, outcome in enumerate(names_out):
            t = pd.DataFrame({"group": g, "outcome": outcome, "input": list(names),
                              "n_cases": parts["n_cases"][:, k],
                              **{key: parts[key][:, k] for key in
                                 ("s1", "s1_low", "s1_high", "st", "st_low", "st_high")}})
            order = np.argsort(-np.nan_to_num(t["st"].to_numpy(), nan=-np.inf), kind="stable")
            rank = np.empty(d, dtype=int)
            rank[order] = np.arange(1, d + 1)
            t["rank"] = rank
            tables.append(t)
    groups = pd.concat(tables, ignore_index=True)
    inputs = input_table(resolved, config)
    inputs = inputs[inputs["input"].isin(names)].reset_index(drop=True)
    if dummy:
        inputs = pd.concat([inputs, pd.DataFrame([{
            "input": DUMMY, "label": "dummy (enters nothing)", "unit": "-",
            "distribution": "uniform [0, 1]", "varied": True, "database_sd_cases": 0,
            "clipped_share": 0.0, "description": "check input: its indices must be ~0"}])],
            ignore_index=True)
    return SensitivityResult(per_case, groups, inputs, names, int(n_base), r * n, seed_int,
                             time.perf_counter() - t0)


def _per_case_table(idx: SobolIndices, case_id: np.ndarray, group: np.ndarray,
                    names: Sequence[str], outcomes: Sequence[str]) -> pd.DataFrame:
    """Long table ordered by case, outcome, input (arrays (d, N, K) -> rows)."""
    d, n, k = idx.s1.shape
    c, o, i = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(k), np.arange(d),
                                               indexing="ij"))
    data: dict[str, Any] = {
        "case_id": case_id[c], "group": group[c],
        "outcome": np.asarray(outcomes, dtype=object)[o],
        "input": np.asarray(names, dtype=object)[i],
    }
    for key in ("s1", "s1_low", "s1_high", "st", "st_low", "st_high"):
        data[key] = getattr(idx, key)[i, c, o]
    data["variance"] = idx.variance[c, o]
    return pd.DataFrame(data)


def input_labels() -> dict[str, str]:
    """Report labels of the inputs (and the dummy)."""
    labels = {name: INPUTS_BY_NAME[name].label for name in INPUT_NAMES}
    labels[DUMMY] = "dummy"
    return labels


__all__ = [
    "DEFAULT_OUTCOMES", "DUMMY", "GROUPS", "SaltelliDesign", "SensitivityResult",
    "SobolIndices", "input_labels", "ishigami", "ishigami_indices", "saltelli_design",
    "sensitivity_analysis", "sobol_analyze", "sobol_indices",
]
