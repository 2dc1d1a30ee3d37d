"""Statistics for comparing a simulation with reconstructions of the same accidents.

The data are *paired*: every accident has a reference value (reconstruction)
and a model value (virtual forward simulation, VFS) of the same quantity
(delta-v, EES, change-of-velocity angle, impact type, ...).  This module offers
a small functional API that returns frozen result records:

* :func:`paired_comparison` -- paired t-test, Wilcoxon signed-rank test,
  Bland-Altman bias and limits of agreement, equivalence test (TOST), effect
  size and error measures for one numeric outcome;
* :func:`paired_comparison_table` -- the same for several outcomes and groups
  (e.g. Table 1 of the Momentum Based Impact Model paper: split by impact type), as a DataFrame;
* :func:`contingency_comparison` -- paired categorical data: the chi-squared
  test of the paper (which treats the samples as independent), McNemar,
  Stuart-Maxwell, Bowker and Cohen's kappa;
* :func:`bootstrap_ci` -- vectorised percentile bootstrap over cases;
* :func:`wilson_interval` -- score interval of a share (proportion), sound at 0 and 100 %
  (defined in :mod:`vfs.analysis.intervals`, re-exported here);
* :func:`bca_interval` -- bias-corrected and accelerated (BCa) bootstrap interval for
  skewed statistics (ratios), from bootstrap replicates and jackknife values;
* :func:`holm_bonferroni` and :func:`benjamini_hochberg` -- multiple testing.

Formulas, assumptions and the conventions for degenerate inputs are written
down in ``docs/statistics.md``; the docstrings repeat the conventions.

Conventions shared by all functions
-----------------------------------
* Differences are ``model - reference``.
* Missing values are NaN (numbers) or ``None``/NaN (categories); a pair with a
  missing value on either side is dropped and counted in ``n_dropped``.
* Tests, p-values and confidence intervals need at least
  :data:`MIN_PAIRS_FOR_TESTS` complete pairs; with fewer they are NaN.
* When the standard deviation of the differences is exactly zero, a ratio
  ``x / sd`` is taken in the limit ``sd -> 0``: ``0 / 0 -> 0`` and
  ``x / 0 -> sign(x) * inf``.  This gives p = 1 for all-zero differences and
  p = 0 for constant nonzero differences instead of NaN and a RuntimeWarning.
"""

from __future__ import annotations

import inspect
import math
import warnings
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from vfs.analysis.intervals import bca_interval, wilson_interval
from vfs.errors import DataError, DataProblem, ParameterError


def _sps() -> Any:
    """:mod:`scipy.stats`, imported on first use (it costs about 0.5 s; the command line and
    the study import this module without needing it).
    """
    from scipy import stats

    return stats

#: Minimum number of complete pairs for which test statistics, p-values and
#: confidence intervals are reported (with fewer pairs they are NaN).  With two
#: pairs a t-test has one degree of freedom and the smallest attainable
#: Wilcoxon p-value is 0.5: such "tests" are not informative.
MIN_PAIRS_FOR_TESTS = 3

#: Multiplier of the sd of the differences for the 95 % Bland-Altman limits of
#: agreement (Bland & Altman 1986, 1999).
LOA_Z = 1.96

#: McNemar uses the exact binomial test when the number of discordant pairs is
#: below this value, else the chi-squared test with continuity correction.
MCNEMAR_EXACT_BELOW = 25

#: Label of the group holding all pairs in :func:`paired_comparison_table`.
ALL_GROUP = "all"

#: Upper bound of resampled elements held in memory at once by bootstrap_ci.
_MAX_RESAMPLED_ELEMENTS = 1 << 22

_NAN = math.nan


# ----------------------------------------------------------------------------
# Validation helpers
# ----------------------------------------------------------------------------


def _check_open_unit(value: float, name: str) -> float:
    """Return ``value`` as float if it lies in (0, 1), else raise ParameterError."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name}={value!r} is not a number in (0, 1)") from exc
    if not 0.0 < v < 1.0:
        raise ParameterError(f"{name}={value!r} must lie in the open interval (0, 1)")
    return v


def _as_1d_float(values: npt.ArrayLike, name: str) -> np.ndarray:
    """Convert numeric input to a 1-D float array; NaN allowed, +-inf not."""
    arr: np.ndarray
    try:
        if isinstance(values, pd.Series | pd.Index):
            arr = values.to_numpy(dtype=float, na_value=np.nan)
        else:
            arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(
            DataProblem(name, "", None, None, f"values are not numeric ({exc})")
        ) from exc
    if arr.ndim != 1:
        raise DataError(
            DataProblem(name, "", None, None, f"expected a 1-D sequence, got shape {arr.shape}")
        )
    bad = np.flatnonzero(np.isinf(arr))
    if bad.size:
        raise DataError(
            [
                DataProblem(name, "", int(i), None,
                            f"value {arr[i]} is not finite (use NaN for a missing value)")
                for i in bad
            ]
        )
    return arr


def _ratio(numerator: float, denominator: float) -> float:
    """``numerator / denominator`` for a denominator >= 0, in the limit for 0.

    ``0 / 0 -> 0`` and ``x / 0 -> sign(x) * inf``: the limit of a test
    statistic ``x / sd`` when the sample standard deviation shrinks to zero.
    """
    if denominator > 0.0:
        return numerator / denominator
    if numerator == 0.0:
        return 0.0
    return math.copysign(math.inf, numerator)


def _mean(values: np.ndarray) -> float:
    """Mean, NaN for an empty array (without a RuntimeWarning)."""
    return float(np.mean(values)) if values.size else _NAN


def _sd(values: np.ndarray) -> float:
    """Sample standard deviation (ddof = 1); exactly 0 for constant data, NaN if n < 2."""
    if values.size < 2:
        return _NAN
    if np.all(values == values[0]):
        # np.std of constant data can be 1e-17 instead of 0 (rounding of the mean)
        return 0.0
    return float(np.std(values, ddof=1))


# ----------------------------------------------------------------------------
# Paired numeric data
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class PairedComparison:
    """Comparison of paired numeric values: ``model`` against ``reference``.

    Values in "[input unit]" carry the unit of the inputs (e.g. m/s for
    delta-v).  Fields that cannot be computed for the given data are NaN; see
    :func:`paired_comparison` for the conventions.

    Attributes
    ----------
    name : str
        Label of the outcome (free text).
    n : int
        Number of complete pairs used.
    n_dropped : int
        Number of pairs dropped because a value was NaN.
    alpha : float
        Significance level of the equivalence decision [-].
    confidence : float
        Confidence level of all confidence intervals [-].
    mean_reference : float
        Mean of the reference values [input unit].
    mean_model : float
        Mean of the model values [input unit].
    sd_reference : float
        Sample standard deviation (ddof = 1) of the reference values [input unit].
    sd_model : float
        Sample standard deviation (ddof = 1) of the model values [input unit].
    mean_difference : float
        Mean of the differences ``model - reference`` [input unit].
    sd_difference : float
        Sample standard deviation (ddof = 1) of the differences [input unit].
    ci_low : float
        Lower limit of the t-based confidence interval of the mean difference
        [input unit].
    ci_high : float
        Upper limit of that interval [input unit].
    t_statistic : float
        Paired t statistic ``mean_difference / (sd_difference / sqrt(n))`` [-];
        +-inf for constant nonzero differences, 0 for all-zero differences.
    t_df : int
        Degrees of freedom of the t-test, ``n - 1`` (0 if not computed).
    t_pvalue : float
        Two-sided p-value of the paired t-test [-] (scipy.stats.ttest_rel).
    wilcoxon_statistic : float
        Wilcoxon signed-rank statistic, ``min(R+, R-)`` with zero differences
        ranked and then dropped (zero_method "pratt") [-].
    wilcoxon_pvalue : float
        Two-sided p-value of the Wilcoxon signed-rank test [-].
    bland_altman_bias : float
        Bland-Altman bias, the mean difference [input unit].
    loa_low : float
        Lower 95 % limit of agreement, ``bias - 1.96 sd_difference`` [input unit].
    loa_high : float
        Upper 95 % limit of agreement, ``bias + 1.96 sd_difference`` [input unit].
    loa_low_ci_low : float
        Lower confidence limit of ``loa_low`` [input unit] (Bland & Altman
        1999: se = sqrt(3 sd^2 / n), t quantile with n - 1 df).
    loa_low_ci_high : float
        Upper confidence limit of ``loa_low`` [input unit].
    loa_high_ci_low : float
        Lower confidence limit of ``loa_high`` [input unit].
    loa_high_ci_high : float
        Upper confidence limit of ``loa_high`` [input unit].
    tost_margin : float
        Equivalence margin ``m`` of the TOST [input unit]; NaN if none given.
    tost_pvalue : float
        TOST p-value [-]: the larger of the two one-sided paired t-test
        p-values against ``-m`` and ``+m``; NaN without a margin.
    equivalent : bool
        True if ``tost_pvalue < alpha``: the mean difference lies within
        ``(-m, +m)`` at level alpha.  False without a margin.
    cohen_dz : float
        Effect size of paired data, ``mean_difference / sd_difference`` [-].
    mean_abs_error : float
        Mean absolute difference [input unit].
    rmse : float
        Root mean square difference [input unit].
    mean_rel_error : float
        Mean signed relative difference ``(model - reference) / |reference|``
        over the pairs with ``reference != 0`` [-] (a fraction, not percent).
    mean_abs_rel_error : float
        Mean of ``|model - reference| / |reference|`` over the same pairs [-].
    n_rel : int
        Number of pairs used for the relative errors (``reference != 0``).
    """

    name: str
    n: int
    n_dropped: int
    alpha: float
    confidence: float
    mean_reference: float
    mean_model: float
    sd_reference: float
    sd_model: float
    mean_difference: float
    sd_difference: float
    ci_low: float
    ci_high: float
    t_statistic: float
    t_df: int
    t_pvalue: float
    wilcoxon_statistic: float
    wilcoxon_pvalue: float
    bland_altman_bias: float
    loa_low: float
    loa_high: float
    loa_low_ci_low: float
    loa_low_ci_high: float
    loa_high_ci_low: float
    loa_high_ci_high: float
    tost_margin: float
    tost_pvalue: float
    equivalent: bool
    cohen_dz: float
    mean_abs_error: float
    rmse: float
    mean_rel_error: float
    mean_abs_rel_error: float
    n_rel: int


def _wilcoxon(differences: np.ndarray) -> tuple[float, float]:
    """Two-sided Wilcoxon signed-rank test (zero_method "pratt") of differences.

    All-zero differences give (0.0, 1.0): there is no evidence of a shift, and
    scipy would return NaN with a warning.
    """
    if not np.any(differences):
        return 0.0, 1.0
    with warnings.catch_warnings():
        # small-sample and tie warnings of the normal approximation; scipy's
        # "auto" method already switches to a permutation test for n <= 13
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", UserWarning)
        result = _sps().wilcoxon(differences, zero_method="pratt", alternative="two-sided")
    return float(result.statistic), float(result.pvalue)


def paired_comparison(
    reference: npt.ArrayLike,
    model: npt.ArrayLike,
    *,
    margin: float | None = None,
    alpha: float = 0.05,
    confidence: float = 0.95,
    name: str = "",
) -> PairedComparison:
    """Compare paired numeric values of a model with reference values.

    Parameters
    ----------
    reference : array_like, shape (n,)
        Reference values (reconstruction), NaN for missing.
    model : array_like, shape (n,)
        Model values (VFS) of the same cases in the same order, NaN for missing.
    margin : float or None, optional
        Equivalence margin ``m > 0`` of the TOST, in the unit of the data.  The
        hypothesis of equivalence is ``-m < mean(model - reference) < m``.
        ``None`` (default) skips the TOST (``tost_*`` NaN, ``equivalent`` False).
    alpha : float, optional
        Significance level of the equivalence decision (default 0.05).
    confidence : float, optional
        Level of the confidence intervals (default 0.95).
    name : str, optional
        Label stored in the result.

    Returns
    -------
    PairedComparison
        All statistics; see the class for the fields.

    Raises
    ------
    DataError
        If the inputs are not 1-D numeric sequences of equal length or contain
        +-inf.
    ParameterError
        If ``alpha`` or ``confidence`` is outside (0, 1) or ``margin`` is not a
        positive finite number.

    Notes
    -----
    Differences are ``d = model - reference``; pairs with a NaN are dropped.

    * Paired t-test (scipy.stats.ttest_rel semantics): ``t = mean(d) / (sd(d) /
      sqrt(n))``, ``df = n - 1``, two-sided p; the confidence interval of the
      mean difference is ``mean(d) +- t_{(1+c)/2, n-1} sd(d) / sqrt(n)``.
    * Wilcoxon signed-rank test, zero_method "pratt": zero differences take
      part in the ranking and are then dropped (Pratt 1959), which keeps the
      test consistent when many differences are exactly zero; scipy's "auto"
      method (exact or permutation distribution for small samples, normal
      approximation otherwise).
    * Bland-Altman: bias ``mean(d)``, limits of agreement ``bias +- 1.96 sd(d)``,
      their confidence limits ``loa +- t_{(1+c)/2, n-1} sqrt(3 sd(d)^2 / n)``
      (Bland & Altman 1999, approximate).
    * TOST: ``p = max(P(T_{n-1} > (mean(d) + m) / se), P(T_{n-1} < (mean(d) - m)
      / se))`` with ``se = sd(d) / sqrt(n)``.

    Degenerate inputs (never an exception or a warning):

    * ``n == 0``: all statistics NaN, ``equivalent`` False.
    * ``n < 3`` (:data:`MIN_PAIRS_FOR_TESTS`): descriptive statistics are
      reported where defined (sd needs n >= 2), test statistics, p-values and
      confidence intervals are NaN.
    * All differences exactly zero: t = 0, p = 1.0, CI [0, 0]; Wilcoxon
      statistic 0, p = 1.0; Cohen's dz = 0; TOST p = 0.0 and equivalent
      whenever a margin is given.  The sample then shows no variability at all:
      both one-sided statistics ``(0 +- m) / se`` tend to +-inf as ``se -> 0``,
      so both one-sided p-values tend to 0.
    * Constant nonzero differences (sd = 0): t = sign(mean) * inf, p = 0.0,
      CI [mean, mean], Cohen's dz = +-inf; TOST p = 0.0 if ``|mean| < m``,
      0.5 if ``|mean| == m`` and 1.0 if ``|mean| > m``.
    * Relative errors ignore pairs with ``reference == 0`` (division by zero);
      NaN if no pair is left (``n_rel == 0``).

    Examples
    --------
    >>> res = paired_comparison([10.0, 12.0, 15.0, 20.0], [11.0, 12.5, 14.0, 21.5])
    >>> res.n, round(res.mean_difference, 3), round(res.t_pvalue, 3)
    (4, 0.5, 0.423)
    """
    ref = _as_1d_float(reference, "reference")
    mod = _as_1d_float(model, "model")
    if ref.shape != mod.shape:
        raise DataError(
            DataProblem("model", "", None, None,
                        f"has {mod.size} values but reference has {ref.size}; "
                        "paired data need equal lengths")
        )
    alpha = _check_open_unit(alpha, "alpha")
    confidence = _check_open_unit(confidence, "confidence")
    tost_margin = _NAN
    if margin is not None:
        try:
            tost_margin = float(margin)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"margin={margin!r} is not a number") from exc
        if not (math.isfinite(tost_margin) and tost_margin > 0.0):
            raise ParameterError(f"margin={margin!r} must be a positive finite number")

    keep = ~(np.isnan(ref) | np.isnan(mod))
    ref, mod = ref[keep], mod[keep]
    n = int(ref.size)
    diff = mod - ref

    mean_d = _mean(diff)
    sd_d = _sd(diff)
    nan_tests = n < MIN_PAIRS_FOR_TESTS

    t_stat = t_p = ci_low = ci_high = _NAN
    w_stat = w_p = _NAN
    loa_ci = (_NAN, _NAN, _NAN, _NAN)
    tost_p = _NAN
    t_df = 0
    if not nan_tests:
        t_df = n - 1
        se = sd_d / math.sqrt(n)
        quantile = float(_sps().t.ppf(0.5 * (1.0 + confidence), t_df))
        t_stat = _ratio(mean_d, se)
        t_p = min(1.0, float(2.0 * _sps().t.sf(abs(t_stat), t_df)))
        ci_low, ci_high = mean_d - quantile * se, mean_d + quantile * se
        w_stat, w_p = _wilcoxon(diff)
        se_loa = math.sqrt(3.0 * sd_d**2 / n)  # Bland & Altman (1999), section 5
        lo, hi = mean_d - LOA_Z * sd_d, mean_d + LOA_Z * sd_d
        loa_ci = (lo - quantile * se_loa, lo + quantile * se_loa,
                  hi - quantile * se_loa, hi + quantile * se_loa)
        if margin is not None:
            p_lower = float(_sps().t.sf(_ratio(mean_d + tost_margin, se), t_df))
            p_upper = float(_sps().t.cdf(_ratio(mean_d - tost_margin, se), t_df))
            tost_p = max(p_lower, p_upper)

    nonzero_ref = ref != 0.0
    n_rel = int(np.count_nonzero(nonzero_ref))
    rel = diff[nonzero_ref] / np.abs(ref[nonzero_ref])

    return PairedComparison(
        name=str(name),
        n=n,
        n_dropped=int(keep.size - n),
        alpha=alpha,
        confidence=confidence,
        mean_reference=_mean(ref),
        mean_model=_mean(mod),
        sd_reference=_sd(ref),
        sd_model=_sd(mod),
        mean_difference=mean_d,
        sd_difference=sd_d,
        ci_low=float(ci_low),
        ci_high=float(ci_high),
        t_statistic=float(t_stat),
        t_df=t_df,
        t_pvalue=float(t_p),
        wilcoxon_statistic=w_stat,
        wilcoxon_pvalue=w_p,
        bland_altman_bias=mean_d,
        loa_low=mean_d - LOA_Z * sd_d,
        loa_high=mean_d + LOA_Z * sd_d,
        loa_low_ci_low=float(loa_ci[0]),
        loa_low_ci_high=float(loa_ci[1]),
        loa_high_ci_low=float(loa_ci[2]),
        loa_high_ci_high=float(loa_ci[3]),
        tost_margin=tost_margin,
        tost_pvalue=tost_p,
        equivalent=bool(tost_p < alpha),  # NaN < alpha is False
        cohen_dz=_ratio(mean_d, sd_d) if n >= 2 else _NAN,
        mean_abs_error=_mean(np.abs(diff)),
        rmse=math.sqrt(_mean(diff**2)) if n else _NAN,
        mean_rel_error=_mean(rel),
        mean_abs_rel_error=_mean(np.abs(rel)),
        n_rel=n_rel,
    )


def paired_comparison_table(
    df: pd.DataFrame,
    reference_cols: str | Sequence[str],
    model_cols: str | Sequence[str],
    *,
    group_col: str | None = None,
    margins: Mapping[str, float] | None = None,
    outcomes: Sequence[str] | None = None,
    alpha: float = 0.05,
    confidence: float = 0.95,
) -> pd.DataFrame:
    """Paired comparisons of several outcomes, overall and per group.

    Reproduces tables like Table 1 of the Momentum Based Impact Model paper (paired t-tests of
    delta-v, EES and the change-of-velocity angle split by impact type) and adds
    the other columns of :class:`PairedComparison`.

    Parameters
    ----------
    df : pandas.DataFrame
        One row per case.
    reference_cols : str or sequence of str
        Columns with the reference values, one per outcome.
    model_cols : str or sequence of str
        Columns with the model values, in the same order as ``reference_cols``.
    group_col : str or None, optional
        Column to split by (e.g. the impact type).  Rows with a missing group
        count only in the group ``"all"``.
    margins : mapping of str to float, optional
        Equivalence margin per outcome name (outcomes without an entry get no
        TOST).
    outcomes : sequence of str, optional
        Names of the outcomes; default the reference column names.
    alpha, confidence : float, optional
        Passed to :func:`paired_comparison`.

    Returns
    -------
    pandas.DataFrame
        One row per (outcome, group): for each outcome first the group ``"all"``
        (:data:`ALL_GROUP`), then the groups in sorted order.  Columns
        ``outcome``, ``group`` and the fields of :class:`PairedComparison`
        (``name`` holds the outcome).

    Raises
    ------
    DataError
        If a column is missing or a group is labelled ``"all"``.
    ParameterError
        If the column lists differ in length, ``outcomes`` has the wrong length
        or duplicates, or ``margins`` names an unknown outcome.

    Notes
    -----
    p-values are not adjusted for multiple testing; apply
    :func:`holm_bonferroni` or :func:`benjamini_hochberg` to a p-value column
    when the table is read as a family of tests.
    """
    ref_cols = [reference_cols] if isinstance(reference_cols, str) else list(reference_cols)
    mod_cols = [model_cols] if isinstance(model_cols, str) else list(model_cols)
    if len(ref_cols) != len(mod_cols):
        raise ParameterError(
            f"{len(ref_cols)} reference column(s) but {len(mod_cols)} model column(s)"
        )
    names = ref_cols if outcomes is None else [str(o) for o in outcomes]
    if len(names) != len(ref_cols):
        raise ParameterError(f"{len(names)} outcome name(s) for {len(ref_cols)} column pair(s)")
    if len(set(names)) != len(names):
        raise ParameterError(f"outcome names must be unique, got {names}")
    margins = dict(margins or {})
    unknown = sorted(set(margins) - set(names))
    if unknown:
        raise ParameterError(f"margins for unknown outcome(s) {unknown}; known: {names}")

    needed = ref_cols + mod_cols + ([group_col] if group_col is not None else [])
    missing = [c for c in dict.fromkeys(needed) if c not in df.columns]
    if missing:
        raise DataError(
            [DataProblem("df", c, None, None, "column is missing") for c in missing]
        )

    groups: list[tuple[Hashable, np.ndarray]] = [(ALL_GROUP, np.ones(len(df), dtype=bool))]
    if group_col is not None:
        labels = df[group_col]
        present = labels.dropna().unique().tolist()
        if ALL_GROUP in present:
            raise DataError(
                DataProblem("df", group_col, None, None,
                            f"group label {ALL_GROUP!r} is reserved for all cases")
            )
        try:
            present = sorted(present)
        except TypeError:  # mixed label types: keep the order of appearance
            pass
        groups += [(g, (labels == g).to_numpy()) for g in present]

    rows: list[dict[str, Any]] = []
    for outcome, rc, mc in zip(names, ref_cols, mod_cols, strict=True):
        ref_all = _as_1d_float(df[rc], rc)
        mod_all = _as_1d_float(df[mc], mc)
        for group, mask in groups:
            res = paired_comparison(
                ref_all[mask], mod_all[mask], margin=margins.get(outcome),
                alpha=alpha, confidence=confidence, name=outcome,
            )
            rows.append({"outcome": outcome, "group": group, **asdict(res)})
    columns = ["outcome", "group"] + [f.name for f in fields(PairedComparison)]
    return pd.DataFrame(rows, columns=columns)


# ----------------------------------------------------------------------------
# Paired categorical data
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class ContingencyComparison:
    """Comparison of paired categories (e.g. impact type: reconstruction vs VFS).

    Tests that cannot be computed are NaN; see :func:`contingency_comparison`.

    Attributes
    ----------
    categories : tuple
        The k category labels, in table order.
    n : int
        Number of complete pairs.
    n_dropped : int
        Number of pairs dropped because a label was missing (None/NaN).
    table : pandas.DataFrame
        k x k counts; rows (index name ``"reference"``) are the reference
        categories, columns (``"model"``) the model categories.  Treat it as
        read-only.
    n_agree : int
        Number of pairs with equal categories (the diagonal).
    n_discordant : int
        Number of pairs with different categories, ``n - n_agree``.
    observed_agreement : float
        ``n_agree / n`` [-].
    chi2_statistic : float
        Pearson chi-squared statistic of the 2 x k table "reference counts vs
        model counts" (samples treated as independent, as in the Momentum Based Impact Model paper,
        Figure 4; no continuity correction) [-].
    chi2_pvalue : float
        Its p-value [-].
    chi2_df : int
        Its degrees of freedom, (number of categories observed) - 1.
    mcnemar_statistic : float
        McNemar statistic [-]: ``min(b, c)`` for the exact binomial version,
        ``(|b - c| - 1)^2 / (b + c)`` for the chi-squared version (b, c the
        off-diagonal counts).  NaN for k > 2.
    mcnemar_pvalue : float
        McNemar p-value [-], NaN for k > 2.
    mcnemar_method : str
        ``"exact"`` (binomial, b + c < 25), ``"chi2"`` (continuity corrected)
        or ``""`` (not computed).
    stuart_maxwell_statistic : float
        Stuart-Maxwell statistic of marginal homogeneity [-].
    stuart_maxwell_pvalue : float
        Its p-value (chi-squared with ``stuart_maxwell_df`` df) [-].
    stuart_maxwell_df : int
        Its degrees of freedom, the rank of the covariance matrix of the
        marginal differences (k - 1 in the regular case).
    bowker_statistic : float
        Bowker statistic of symmetry [-].
    bowker_pvalue : float
        Its p-value [-].
    bowker_df : int
        Its degrees of freedom, the number of category pairs with discordant
        counts.
    kappa : float
        Cohen's kappa [-].
    kappa_se : float
        Asymptotic standard error of kappa (Fleiss, Cohen & Everitt 1969) [-].
    kappa_ci_low : float
        Lower Wald confidence limit of kappa [-].
    kappa_ci_high : float
        Upper Wald confidence limit of kappa [-].
    kappa_pvalue : float
        Two-sided p-value of H0: kappa = 0 (standard error under H0) [-].
    confidence : float
        Level of the kappa confidence interval [-].
    """

    categories: tuple[Hashable, ...]
    n: int
    n_dropped: int
    table: pd.DataFrame = field(compare=False, repr=False)
    n_agree: int
    n_discordant: int
    observed_agreement: float
    chi2_statistic: float
    chi2_pvalue: float
    chi2_df: int
    mcnemar_statistic: float
    mcnemar_pvalue: float
    mcnemar_method: str
    stuart_maxwell_statistic: float
    stuart_maxwell_pvalue: float
    stuart_maxwell_df: int
    bowker_statistic: float
    bowker_pvalue: float
    bowker_df: int
    kappa: float
    kappa_se: float
    kappa_ci_low: float
    kappa_ci_high: float
    kappa_pvalue: float
    confidence: float


def _as_labels(values: Iterable[Hashable], name: str) -> np.ndarray:
    """Convert a sequence of category labels to a 1-D object array."""
    if isinstance(values, str | bytes):
        raise DataError(
            DataProblem(name, "", None, None, "expected a sequence of labels, got one string")
        )
    items = list(values)
    arr = np.empty(len(items), dtype=object)
    arr[:] = items
    return arr


def _independent_chi2(counts: np.ndarray) -> tuple[float, float, int]:
    """Pearson chi-squared of 'reference counts vs model counts' (the paper's test)."""
    if counts.sum() == 0:
        return _NAN, _NAN, 0
    observed = np.vstack([counts.sum(axis=1), counts.sum(axis=0)])
    observed = observed[:, observed.sum(axis=0) > 0]  # zero expected counts are undefined
    if observed.shape[1] < 2:
        return 0.0, 1.0, 0  # both samples in one category: identical distributions
    res = _sps().chi2_contingency(observed, correction=False)
    return float(res.statistic), float(res.pvalue), int(res.dof)


def _mcnemar(counts: np.ndarray) -> tuple[float, float, str]:
    """McNemar test of a k x k table with k <= 2 (k = 1: a category never observed)."""
    k = counts.shape[0]
    if counts.sum() == 0 or k > 2:
        return _NAN, _NAN, ""
    b, c = (int(counts[0, 1]), int(counts[1, 0])) if k == 2 else (0, 0)
    if b + c == 0:
        return 0.0, 1.0, "exact"
    exact = b + c < MCNEMAR_EXACT_BELOW
    from statsmodels.stats.contingency_tables import mcnemar

    res = mcnemar(np.array([[0, b], [c, 0]]), exact=exact, correction=True)
    return float(res.statistic), min(1.0, float(res.pvalue)), "exact" if exact else "chi2"


def _stuart_maxwell(counts: np.ndarray) -> tuple[float, float, int]:
    """Stuart-Maxwell test of marginal homogeneity with a generalised inverse.

    ``d = row margins - column margins``; ``V_ii = n_i. + n_.i - 2 n_ii``,
    ``V_ij = -(n_ij + n_ji)``; statistic ``d' V^+ d`` with ``rank(V)`` df.
    For a regular table this equals the textbook form (drop one category,
    invert the (k-1) x (k-1) matrix).  Categories without discordant pairs
    have zero rows in V and d_i = 0; the generalised inverse ignores them.
    """
    if counts.sum() == 0:
        return _NAN, _NAN, 0
    sym = (counts + counts.T).astype(float)
    np.fill_diagonal(sym, 0.0)
    cov = -sym
    np.fill_diagonal(cov, sym.sum(axis=1))
    d = (counts.sum(axis=1) - counts.sum(axis=0)).astype(float)
    df = int(np.linalg.matrix_rank(cov)) if np.any(cov) else 0
    if df == 0:
        return 0.0, 1.0, 0
    statistic = float(d @ np.linalg.pinv(cov, hermitian=True) @ d)
    return statistic, float(_sps().chi2.sf(statistic, df)), df


def _bowker(counts: np.ndarray) -> tuple[float, float, int]:
    """Bowker test of symmetry over the category pairs with discordant counts."""
    if counts.sum() == 0:
        return _NAN, _NAN, 0
    upper = np.triu_indices(counts.shape[0], 1)
    n_ij = counts[upper].astype(float)
    n_ji = counts.T[upper].astype(float)
    total = n_ij + n_ji
    used = total > 0
    df = int(np.count_nonzero(used))
    if df == 0:
        return 0.0, 1.0, 0
    statistic = float(np.sum((n_ij[used] - n_ji[used]) ** 2 / total[used]))
    return statistic, float(_sps().chi2.sf(statistic, df)), df


def _cohens_kappa(counts: np.ndarray, confidence: float) -> tuple[float, ...]:
    """Cohen's kappa, its asymptotic se, Wald CI and the p-value of kappa = 0.

    Variances after Fleiss, Cohen & Everitt (1969), as in
    statsmodels.stats.inter_rater.cohens_kappa.  NaN when n = 0 or when the
    expected agreement is 1 (both raters used one and the same category only).
    """
    n = float(counts.sum())
    if n == 0:
        return (_NAN,) * 5
    p = counts / n
    row, col = p.sum(axis=1), p.sum(axis=0)
    p_obs = float(np.trace(p))
    p_exp = float(row @ col)
    if p_exp >= 1.0 - 1e-12:
        return (_NAN,) * 5
    kappa = (p_obs - p_exp) / (1.0 - p_exp)
    term_a = float(np.sum(np.diag(p) * (1.0 - (row + col) * (1.0 - kappa)) ** 2))
    off = p * (col[:, None] + row[None, :]) ** 2  # p_ij (p_.i + p_j.)^2
    np.fill_diagonal(off, 0.0)
    term_b = (1.0 - kappa) ** 2 * float(off.sum())
    term_c = (kappa - p_exp * (1.0 - kappa)) ** 2
    var = max(0.0, (term_a + term_b - term_c) / ((1.0 - p_exp) ** 2 * n))
    var0 = (p_exp + p_exp**2 - float(np.sum(row * col * (row + col)))) / (
        (1.0 - p_exp) ** 2 * n
    )
    se = math.sqrt(var)
    z = _ratio(kappa, math.sqrt(max(0.0, var0)))
    quantile = float(_sps().norm.ppf(0.5 * (1.0 + confidence)))
    p_value = min(1.0, float(2.0 * _sps().norm.sf(abs(z))))
    return kappa, se, kappa - quantile * se, kappa + quantile * se, p_value


def contingency_comparison(
    reference_categories: Iterable[Hashable],
    model_categories: Iterable[Hashable],
    categories: Sequence[Hashable] | None = None,
    *,
    confidence: float = 0.95,
) -> ContingencyComparison:
    """Compare paired categories of a model with reference categories.

    Parameters
    ----------
    reference_categories : iterable of hashable
        Reference category per case (e.g. impact type ``"full"``/``"sliding"``
        of the reconstruction); ``None`` or NaN for missing.
    model_categories : iterable of hashable
        Model category of the same cases in the same order.
    categories : sequence of hashable, optional
        All possible categories, in table order.  Categories never observed
        get zero rows/columns.  Default: the observed labels, sorted (order of
        first appearance if they cannot be sorted).
    confidence : float, optional
        Level of the kappa confidence interval (default 0.95).

    Returns
    -------
    ContingencyComparison
        Table, agreement, tests and kappa; see the class for the fields.

    Raises
    ------
    DataError
        If the inputs differ in length or contain a label outside
        ``categories``.
    ParameterError
        If ``categories`` has duplicates or ``confidence`` is outside (0, 1).

    Notes
    -----
    * Chi-squared as in the Momentum Based Impact Model paper (Figure 4): the
      reference counts and the model counts per category form a 2 x k table analysed with
      ``scipy.stats.chi2_contingency(correction=False)``.  This treats the two
      samples as independent although they are the same cases; it tests only
      whether the category *frequencies* differ, ignores which case changed
      category and is too conservative for positively correlated pairs.
      Reported to reproduce the paper; use McNemar / Stuart-Maxwell / Bowker
      and kappa for paired data.  Categories observed in neither sample are
      left out (zero expected counts); with fewer than two observed categories
      the statistic is 0 and p = 1.
    * McNemar (k <= 2): exact binomial test when the discordant count
      ``b + c < 25``, else chi-squared with continuity correction
      (statsmodels ``mcnemar``).  With ``b + c = 0`` (all pairs agree)
      statistic 0 and p = 1.0.  k = 1 is a 2 x 2 table with one category
      never observed.  NaN for k > 2.
    * Stuart-Maxwell (marginal homogeneity) and Bowker (symmetry) for any k;
      both equal the uncorrected McNemar statistic for k = 2.  Categories or
      category pairs without discordant counts carry no information and are
      left out of the degrees of freedom (statsmodels ``SquareTable`` counts
      all k (k - 1) / 2 pairs for Bowker and fails on singular tables).  No
      discordant pairs at all: statistic 0, df 0, p = 1.0.
    * Cohen's kappa ``(p_o - p_e) / (1 - p_e)`` with the asymptotic standard
      error of Fleiss, Cohen & Everitt (1969); Wald CI; p-value with the
      standard error under H0.  NaN when ``p_e = 1``.
    * ``n = 0``: counts 0, all proportions, statistics and p-values NaN.
    """
    confidence = _check_open_unit(confidence, "confidence")
    ref = _as_labels(reference_categories, "reference_categories")
    mod = _as_labels(model_categories, "model_categories")
    if ref.size != mod.size:
        raise DataError(
            DataProblem("model_categories", "", None, None,
                        f"has {mod.size} labels but reference_categories has {ref.size}")
        )
    keep = ~(pd.isna(ref) | pd.isna(mod)) if ref.size else np.zeros(0, dtype=bool)
    ref, mod = ref[keep], mod[keep]
    n = int(ref.size)

    if categories is None:
        observed = list(dict.fromkeys([*ref.tolist(), *mod.tolist()]))
        try:
            cats = sorted(observed)
        except TypeError:
            cats = observed
    else:
        cats = list(categories)
        if len(set(cats)) != len(cats):
            raise ParameterError(f"categories must be unique, got {cats}")
        known = set(cats)
        problems = [
            DataProblem(table, "", int(i), None,
                        f"label {label!r} is not one of the categories {cats}")
            for table, labels in (("reference_categories", ref), ("model_categories", mod))
            for i, label in enumerate(labels)
            if label not in known
        ]
        if problems:
            raise DataError(problems)

    position = {c: i for i, c in enumerate(cats)}
    k = len(cats)
    counts = np.zeros((k, k), dtype=np.int64)
    if n:
        rows = np.array([position[c] for c in ref], dtype=np.intp)
        cols = np.array([position[c] for c in mod], dtype=np.intp)
        np.add.at(counts, (rows, cols), 1)
    table = pd.DataFrame(
        counts,
        index=pd.Index(cats, name="reference", dtype=object),
        columns=pd.Index(cats, name="model", dtype=object),
    )
    n_agree = int(np.trace(counts))
    chi2 = _independent_chi2(counts)
    mcn = _mcnemar(counts)
    sm = _stuart_maxwell(counts)
    bw = _bowker(counts)
    kap = _cohens_kappa(counts, confidence)
    return ContingencyComparison(
        categories=tuple(cats),
        n=n,
        n_dropped=int(keep.size - n),
        table=table,
        n_agree=n_agree,
        n_discordant=n - n_agree,
        observed_agreement=n_agree / n if n else _NAN,
        chi2_statistic=chi2[0],
        chi2_pvalue=chi2[1],
        chi2_df=chi2[2],
        mcnemar_statistic=mcn[0],
        mcnemar_pvalue=mcn[1],
        mcnemar_method=mcn[2],
        stuart_maxwell_statistic=sm[0],
        stuart_maxwell_pvalue=sm[1],
        stuart_maxwell_df=sm[2],
        bowker_statistic=bw[0],
        bowker_pvalue=bw[1],
        bowker_df=bw[2],
        kappa=kap[0],
        kappa_se=kap[1],
        kappa_ci_low=kap[2],
        kappa_ci_high=kap[3],
        kappa_pvalue=kap[4],
        confidence=confidence,
    )


# ----------------------------------------------------------------------------
# Bootstrap
# ----------------------------------------------------------------------------


def _accepts_keyword(func: Callable[..., Any], keyword: str) -> bool:
    """True if ``func`` has a parameter named ``keyword`` (not just ``**kwargs``)."""
    try:
        return keyword in inspect.signature(func).parameters
    except (TypeError, ValueError):  # builtins without a signature
        return False


def _as_scalar(value: Any) -> float:
    """Convert a statistic's value to float; ParameterError if it is not a scalar."""
    arr = np.asarray(value, dtype=float)
    if arr.size != 1:
        raise ParameterError(
            f"the statistic must return one number per sample, got shape {arr.shape}"
        )
    return float(arr.reshape(()))


def bootstrap_ci(
    statistic: Callable[..., Any],
    *arrays: npt.ArrayLike,
    n_boot: int = 2000,
    confidence: float = 0.95,
    rng: np.random.Generator,
    weights: npt.ArrayLike | None = None,
    vectorized: bool | None = None,
    method: str = "percentile",
) -> tuple[float, float, float]:
    """Percentile or BCa bootstrap confidence interval of a statistic, resampling cases.

    Parameters
    ----------
    statistic : callable
        ``statistic(*arrays) -> float``.  If it accepts an ``axis`` keyword
        (like ``numpy.mean``) it is called *batched*: all bootstrap samples are
        stacked along a new leading axis and the case axis is ``axis=1``; it
        must then return one value per sample.  The estimate is computed with
        ``axis=0`` on the original arrays.
    *arrays : array_like
        One or more arrays whose first axis is the case axis, all of the same
        length n.  Rows are resampled jointly (the same cases for all arrays),
        which keeps pairs together.
    n_boot : int, optional
        Number of bootstrap samples (default 2000).
    confidence : float, optional
        Level of the interval (default 0.95).
    rng : numpy.random.Generator
        The only source of randomness (keyword, required).
    weights : array_like, shape (n,), optional
        Case weights (e.g. weights of a case sample to national statistics).
        They are *not* used as resampling probabilities: cases are resampled
        uniformly and each case keeps its weight, which is passed to the
        statistic as ``weights=`` (same shape as the resampled case axis), so
        the statistic must be weighted itself, e.g. ``numpy.average``.  This
        bootstraps the weighted estimator as it is computed on the data.
    vectorized : bool or None, optional
        Force (True) or forbid (False) the batched call; default: batched if
        ``statistic`` has a parameter named ``axis``.  A statistic with a parameter
        ``counts`` gets the original arrays and the (samples, n) numbers of draws of each
        case (ones for the estimate): a matrix product for sums over cases, same draws.
    method : {"percentile", "bca"}, optional
        ``percentile`` (default) or ``bca``: bias-corrected and accelerated
        (:func:`vfs.analysis.intervals.bca_interval`), for skewed statistics such
        as means of distances or ratios; its acceleration comes from the n
        leave-one-case-out values of the statistic.

    Returns
    -------
    estimate : float
        The statistic on the original data.
    low, high : float
        Percentiles ``(1 - confidence) / 2`` and ``(1 + confidence) / 2`` of
        the bootstrap distribution; NaN if any bootstrap value is NaN.

    Raises
    ------
    DataError
        If no array is given, the arrays differ in length, are empty or 0-d.
    ParameterError
        If ``rng`` is not a Generator, ``n_boot < 1``, ``confidence`` outside
        (0, 1), the weights are invalid (negative, non-finite, wrong length, zero
        sum), ``weights`` is given but the statistic has no ``weights``
        parameter, or the statistic does not return one value per sample.

    Notes
    -----
    All index samples of a chunk (at most 2^22 resampled elements) are drawn
    at once with ``rng.integers``; a batched statistic then runs without a
    Python loop over the samples.  Results are reproducible for a fixed seed.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> est, low, high = bootstrap_ci(np.mean, [1.0, 2.0, 3.0, 4.0], rng=rng)
    >>> est, low <= est <= high
    (2.5, True)
    """
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if not arrays:
        raise DataError(DataProblem("arrays", "", None, None, "no data array given"))
    if isinstance(n_boot, bool) or int(n_boot) != n_boot or n_boot < 1:
        raise ParameterError(f"n_boot={n_boot!r} must be a positive integer")
    n_boot = int(n_boot)
    confidence = _check_open_unit(confidence, "confidence")
    if method not in ("percentile", "bca"):
        raise ParameterError(f"method={method!r} must be 'percentile' or 'bca'")
    data = [np.asarray(a) for a in arrays]
    problems = [
        DataProblem(f"arrays[{i}]", "", None, None, "is 0-d; the first axis must hold the cases")
        for i, a in enumerate(data) if a.ndim == 0
    ]
    if problems:
        raise DataError(problems)
    n = data[0].shape[0]
    problems = [
        DataProblem(f"arrays[{i}]", "", None, None, f"has {a.shape[0]} cases, arrays[0] has {n}")
        for i, a in enumerate(data) if a.shape[0] != n
    ]
    if problems:
        raise DataError(problems)
    if n == 0:
        raise DataError(DataProblem("arrays", "", None, None, "no cases to resample"))

    case_weights: np.ndarray | None = None
    if weights is not None:
        case_weights = np.asarray(weights, dtype=float)
        if case_weights.shape != (n,):
            raise ParameterError(f"weights must have shape ({n},), got {case_weights.shape}")
        if not np.all(np.isfinite(case_weights)) or np.any(case_weights < 0):
            raise ParameterError("weights must be finite and non-negative")
        if case_weights.sum() <= 0:
            raise ParameterError("weights must not all be zero")
        if not _accepts_keyword(statistic, "weights"):
            raise ParameterError(
                "weights given but the statistic has no 'weights' parameter "
                "(use a weighted statistic such as numpy.average)"
            )
    by_counts = case_weights is None and _accepts_keyword(statistic, "counts")
    batched = _accepts_keyword(statistic, "axis") if vectorized is None else bool(vectorized)

    def call(samples: Sequence[np.ndarray], w: np.ndarray | None, **kw: Any) -> Any:
        if w is not None:
            kw["weights"] = w
        return statistic(*samples, **kw)

    if by_counts:
        estimate = _as_scalar(np.asarray(statistic(*data, counts=np.ones((1, n))))[0])
    else:
        estimate = _as_scalar(call(data, case_weights, **({"axis": 0} if batched else {})))

    boot = np.empty(n_boot)
    chunk = max(1, _MAX_RESAMPLED_ELEMENTS // n)
    for start in range(0, n_boot, chunk):
        size = min(chunk, n_boot - start)
        index = rng.integers(0, n, size=(size, n))
        samples = [] if by_counts else [a[index] for a in data]  # each (size, n, ...)
        w_samples = None if case_weights is None else case_weights[index]
        if by_counts or batched:
            if by_counts:
                counts = np.bincount((np.arange(size)[:, None] * n + index).ravel(),
                                     minlength=size * n).reshape(size, n).astype(float)
                values = np.asarray(statistic(*data, counts=counts), dtype=float)
            else:
                values = np.asarray(call(samples, w_samples, axis=1), dtype=float)
            if values.shape != (size,):
                raise ParameterError(
                    f"the batched statistic must return shape ({size},), got {values.shape}"
                )
        else:
            values = np.array([
                _as_scalar(call([s[b] for s in samples],
                                None if w_samples is None else w_samples[b]))
                for b in range(size)
            ])
        boot[start:start + size] = values

    if method == "bca":
        if np.isnan(boot).any() or n < 3:
            return estimate, math.nan, math.nan
        loo = np.array([np.delete(np.arange(n), i) for i in range(n)])  # (n, n - 1)
        if batched:
            jack = np.asarray(call([a[loo] for a in data],
                                   None if case_weights is None else case_weights[loo],
                                   axis=1), dtype=float)
        else:
            jack = np.array([_as_scalar(call([a[row] for a in data],
                                             None if case_weights is None
                                             else case_weights[row])) for row in loo])
        low, high = bca_interval(boot, estimate, jack, confidence)
        return estimate, low, high
    low, high = np.quantile(boot, [0.5 * (1.0 - confidence), 0.5 * (1.0 + confidence)])
    return estimate, float(low), float(high)


# ----------------------------------------------------------------------------
# Multiple testing
# ----------------------------------------------------------------------------


def _pvalues_array(pvalues: npt.ArrayLike) -> np.ndarray:
    """Validate p-values: numeric, in [0, 1] or NaN."""
    try:
        p = np.asarray(pvalues, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"p-values must be numeric ({exc})") from exc
    bad = ~np.isnan(p) & ((p < 0.0) | (p > 1.0))
    if np.any(bad):
        raise ParameterError(f"p-values must lie in [0, 1], got {p[bad].tolist()}")
    return p


def _adjust(
    pvalues: npt.ArrayLike, adjust_sorted: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """Apply a step-wise adjustment to the non-NaN p-values, keeping shape and order."""
    p = _pvalues_array(pvalues)
    flat = p.ravel()
    out = np.full(flat.shape, _NAN)
    valid = np.flatnonzero(~np.isnan(flat))
    if valid.size:
        order = np.argsort(flat[valid], kind="stable")
        adjusted = np.empty(valid.size)
        adjusted[order] = adjust_sorted(flat[valid][order])
        out[valid] = adjusted
    return out.reshape(p.shape)


def holm_bonferroni(pvalues: npt.ArrayLike) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values (family-wise error rate control).

    Parameters
    ----------
    pvalues : array_like
        Raw p-values in [0, 1]; NaN entries stay NaN and do not count in m.

    Returns
    -------
    numpy.ndarray
        Adjusted p-values, same shape: with the m valid p-values sorted
        ascending, ``p_adj(i) = max_{j <= i} min(1, (m - j + 1) p(j))``.
        Reject where ``p_adj < alpha``.

    Raises
    ------
    ParameterError
        If a p-value is outside [0, 1] or not numeric.
    """

    def step_down(p_sorted: np.ndarray) -> np.ndarray:
        m = p_sorted.size
        return np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p_sorted))

    return _adjust(pvalues, step_down)


def benjamini_hochberg(pvalues: npt.ArrayLike) -> np.ndarray:
    """Benjamini-Hochberg adjusted p-values (false discovery rate control).

    Parameters
    ----------
    pvalues : array_like
        Raw p-values in [0, 1]; NaN entries stay NaN and do not count in m.

    Returns
    -------
    numpy.ndarray
        Adjusted p-values ("q-values"), same shape: with the m valid p-values
        sorted ascending, ``p_adj(i) = min_{j >= i} min(1, m p(j) / j)``.

    Raises
    ------
    ParameterError
        If a p-value is outside [0, 1] or not numeric.
    """

    def step_up(p_sorted: np.ndarray) -> np.ndarray:
        m = p_sorted.size
        scaled = m * p_sorted / np.arange(1, m + 1)
        return np.minimum(1.0, np.minimum.accumulate(scaled[::-1])[::-1])

    return _adjust(pvalues, step_up)


__all__ = [
    "ALL_GROUP",
    "LOA_Z",
    "MCNEMAR_EXACT_BELOW",
    "MIN_PAIRS_FOR_TESTS",
    "ContingencyComparison",
    "PairedComparison",
    "benjamini_hochberg",
    "bca_interval",
    "bootstrap_ci",
    "contingency_comparison",
    "holm_bonferroni",
    "paired_comparison",
    "paired_comparison_table",
    "wilson_interval",
]
