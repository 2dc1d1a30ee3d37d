"""Tests of vfs.analysis.stats: hand-computed examples, reference implementations,
degenerate cases."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats as sps
from statsmodels.stats.contingency_tables import SquareTable, mcnemar
from statsmodels.stats.inter_rater import cohens_kappa
from statsmodels.stats.multitest import multipletests
from statsmodels.stats.weightstats import ttost_paired

from vfs.analysis.stats import (
    ALL_GROUP,
    ContingencyComparison,
    PairedComparison,
    benjamini_hochberg,
    bootstrap_ci,
    contingency_comparison,
    holm_bonferroni,
    paired_comparison,
    paired_comparison_table,
)
from vfs.errors import DataError, ParameterError

# Every degenerate case must be handled without a RuntimeWarning (or any other).
pytestmark = pytest.mark.filterwarnings("error")

REF = [10.0, 12.0, 15.0, 20.0]
MOD = [11.0, 12.5, 14.0, 21.5]  # differences d = [1.0, 0.5, -1.0, 1.5]

INFERENTIAL_FIELDS = (
    "ci_low", "ci_high", "t_statistic", "t_pvalue", "wilcoxon_statistic", "wilcoxon_pvalue",
    "loa_low_ci_low", "loa_low_ci_high", "loa_high_ci_low", "loa_high_ci_high", "tost_pvalue",
)


# ----------------------------------------------------------------------------
# paired_comparison: hand-computed example
# ----------------------------------------------------------------------------


def test_paired_hand_computed_descriptives_and_t_test() -> None:
    res = paired_comparison(REF, MOD, name="dv")
    n = 4
    mean_d = (1.0 + 0.5 - 1.0 + 1.5) / 4  # = 0.5
    # squared deviations from 0.5: 0.25, 0, 2.25, 1 -> sum 3.5, ddof = 1
    sd_d = math.sqrt(3.5 / 3)
    se = sd_d / math.sqrt(n)
    t = mean_d / se  # paired t statistic
    p = 2 * sps.t.sf(abs(t), n - 1)
    q = sps.t.ppf(0.975, n - 1)
    assert res.name == "dv" and res.n == 4 and res.n_dropped == 0
    assert res.mean_reference == pytest.approx((10 + 12 + 15 + 20) / 4)
    assert res.mean_model == pytest.approx((11 + 12.5 + 14 + 21.5) / 4)
    assert res.mean_difference == pytest.approx(mean_d)
    assert res.sd_difference == pytest.approx(sd_d)
    assert res.t_statistic == pytest.approx(t)
    assert res.t_df == 3
    assert res.t_pvalue == pytest.approx(p)
    assert (res.ci_low, res.ci_high) == pytest.approx((mean_d - q * se, mean_d + q * se))
    assert res.cohen_dz == pytest.approx(mean_d / sd_d)


def test_paired_hand_computed_bland_altman_and_errors() -> None:
    res = paired_comparison(REF, MOD)
    mean_d, sd_d, n = 0.5, math.sqrt(3.5 / 3), 4
    loa_low, loa_high = mean_d - 1.96 * sd_d, mean_d + 1.96 * sd_d
    se_loa = math.sqrt(3 * sd_d**2 / n)  # Bland & Altman 1999
    q = sps.t.ppf(0.975, n - 1)
    assert res.bland_altman_bias == pytest.approx(mean_d)
    assert (res.loa_low, res.loa_high) == pytest.approx((loa_low, loa_high))
    assert (res.loa_low_ci_low, res.loa_low_ci_high) == pytest.approx(
        (loa_low - q * se_loa, loa_low + q * se_loa))
    assert (res.loa_high_ci_low, res.loa_high_ci_high) == pytest.approx(
        (loa_high - q * se_loa, loa_high + q * se_loa))
    assert res.mean_abs_error == pytest.approx((1 + 0.5 + 1 + 1.5) / 4)
    assert res.rmse == pytest.approx(math.sqrt((1 + 0.25 + 1 + 2.25) / 4))
    rel = [1 / 10, 0.5 / 12, -1 / 15, 1.5 / 20]
    assert res.mean_rel_error == pytest.approx(sum(rel) / 4)
    assert res.mean_abs_rel_error == pytest.approx(sum(abs(r) for r in rel) / 4)
    assert res.n_rel == 4


def test_paired_hand_computed_wilcoxon() -> None:
    res = paired_comparison(REF, MOD)
    # |d| = 1, 0.5, 1, 1.5 -> ranks 2.5, 1, 2.5, 4; R+ = 2.5 + 1 + 4 = 7.5, R- = 2.5
    assert res.wilcoxon_statistic == pytest.approx(2.5)
    # exact sign-flip distribution (16 equally likely sign patterns): R- <= 2.5 for the
    # negative-rank sets {}, {1}, {2.5}, {2.5'} -> P(R+ >= 7.5) = 4/16, two-sided 2 * 4/16
    ranks = [2.5, 1.0, 2.5, 4.0]
    count = sum(
        1 for signs in itertools.product([0, 1], repeat=4)
        if sum(r for r, s in zip(ranks, signs, strict=True) if s) >= 7.5
    )
    assert count == 4
    assert res.wilcoxon_pvalue == pytest.approx(2 * 4 / 16)


def test_paired_hand_computed_tost() -> None:
    margin = 2.0
    res = paired_comparison(REF, MOD, margin=margin)
    mean_d, se = 0.5, math.sqrt(3.5 / 3) / 2
    p_lower = sps.t.sf((mean_d + margin) / se, 3)  # H0: mean <= -margin
    p_upper = sps.t.cdf((mean_d - margin) / se, 3)  # H0: mean >= +margin
    assert res.tost_margin == margin
    assert res.tost_pvalue == pytest.approx(max(p_lower, p_upper))
    assert res.equivalent == (max(p_lower, p_upper) < 0.05)
    p_ref = ttost_paired(np.array(MOD), np.array(REF), -margin, margin)[0]
    assert res.tost_pvalue == pytest.approx(p_ref)


def test_paired_tost_decision_depends_on_margin() -> None:
    rng = np.random.default_rng(3)
    ref = rng.normal(50, 10, 40)
    mod = ref + rng.normal(0.2, 1.0, 40)
    assert paired_comparison(ref, mod, margin=2.0).equivalent
    assert not paired_comparison(ref, mod, margin=0.05).equivalent
    assert not paired_comparison(ref, mod, margin=2.0, alpha=1e-30).equivalent


# ----------------------------------------------------------------------------
# paired_comparison: agreement with scipy and properties
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 5, 12, 14, 40, 120])
@pytest.mark.parametrize("rounded", [False, True])
def test_paired_agrees_with_scipy(n: int, rounded: bool) -> None:
    rng = np.random.default_rng(n + 1000 * rounded)
    ref = rng.normal(40, 12, n)
    mod = ref + rng.normal(0.5, 3.0, n)
    if rounded:  # ties and zero differences: the Wilcoxon paths with corrections
        ref, mod = np.round(ref), np.round(ref + np.round(mod - ref))
    res = paired_comparison(ref, mod, confidence=0.9)
    tt = sps.ttest_rel(mod, ref)
    assert res.t_statistic == pytest.approx(tt.statistic, rel=1e-10)
    assert res.t_pvalue == pytest.approx(tt.pvalue, rel=1e-10)
    ci = tt.confidence_interval(0.9)
    assert (res.ci_low, res.ci_high) == pytest.approx((ci.low, ci.high), rel=1e-10)
    d = mod - ref
    if np.any(d):
        wx = sps.wilcoxon(mod, ref, zero_method="pratt")
        assert res.wilcoxon_statistic == pytest.approx(wx.statistic)
        assert res.wilcoxon_pvalue == pytest.approx(wx.pvalue)


_values = st.integers(min_value=-400, max_value=400).map(lambda v: v / 4)


@st.composite
def _pairs(draw: st.DrawFn) -> tuple[list[float], list[float]]:
    n = draw(st.integers(min_value=3, max_value=25))
    ref = draw(st.lists(_values, min_size=n, max_size=n))
    mod = draw(st.lists(_values, min_size=n, max_size=n))
    return ref, mod


@settings(max_examples=60, deadline=None)
@given(_pairs(), st.floats(min_value=0.25, max_value=50))
def test_swapping_reference_and_model_flips_sign_keeps_p(
    pairs: tuple[list[float], list[float]], margin: float
) -> None:
    ref, mod = pairs
    a = paired_comparison(ref, mod, margin=margin)
    b = paired_comparison(mod, ref, margin=margin)
    assert b.mean_difference == -a.mean_difference
    assert b.sd_difference == a.sd_difference
    assert b.t_statistic == -a.t_statistic
    assert b.t_pvalue == pytest.approx(a.t_pvalue, rel=1e-12, abs=1e-300)
    assert b.wilcoxon_pvalue == pytest.approx(a.wilcoxon_pvalue, rel=1e-9)
    assert b.tost_pvalue == pytest.approx(a.tost_pvalue, rel=1e-12, abs=1e-300)
    assert b.equivalent == a.equivalent
    assert (b.loa_low, b.loa_high) == pytest.approx((-a.loa_high, -a.loa_low))
    assert (b.ci_low, b.ci_high) == pytest.approx((-a.ci_high, -a.ci_low))
    assert b.mean_abs_error == a.mean_abs_error and b.rmse == a.rmse


@settings(max_examples=60, deadline=None)
@given(_pairs())
def test_paired_results_are_well_formed(pairs: tuple[list[float], list[float]]) -> None:
    res = paired_comparison(*pairs, margin=1.0)
    for p in (res.t_pvalue, res.wilcoxon_pvalue, res.tost_pvalue):
        assert 0.0 <= p <= 1.0
    assert res.ci_low <= res.mean_difference <= res.ci_high
    assert res.loa_low <= res.bland_altman_bias <= res.loa_high
    assert res.loa_low_ci_low <= res.loa_low <= res.loa_low_ci_high
    assert res.rmse >= res.mean_abs_error - 1e-12


def test_nan_pairs_are_dropped_and_counted() -> None:
    ref = [10.0, np.nan, 12.0, 15.0, 20.0, 3.0]
    mod = [11.0, 5.0, 12.5, 14.0, 21.5, np.nan]
    res = paired_comparison(ref, mod)
    assert res.n == 4 and res.n_dropped == 2
    assert res.t_pvalue == pytest.approx(paired_comparison(REF, MOD).t_pvalue)


def test_relative_error_ignores_zero_reference() -> None:
    res = paired_comparison([0.0, 2.0, 4.0], [1.0, 3.0, 3.0])
    assert res.n_rel == 2
    assert res.mean_rel_error == pytest.approx((1 / 2 + (-1) / 4) / 2)
    assert res.mean_abs_rel_error == pytest.approx((1 / 2 + 1 / 4) / 2)
    all_zero = paired_comparison([0.0, 0.0, 0.0], [1.0, 2.0, 3.0])
    assert all_zero.n_rel == 0 and math.isnan(all_zero.mean_rel_error)


def test_result_is_frozen() -> None:
    res = paired_comparison(REF, MOD)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.n = 3  # type: ignore[misc]


# ----------------------------------------------------------------------------
# paired_comparison: degenerate inputs
# ----------------------------------------------------------------------------


def test_n_zero_gives_nan() -> None:
    for res in (paired_comparison([], [], margin=1.0),
                paired_comparison([np.nan, 1.0], [2.0, np.nan], margin=1.0)):
        assert res.n == 0
        for f in dataclasses.fields(PairedComparison):
            value = getattr(res, f.name)
            if isinstance(value, float) and f.name not in ("alpha", "confidence", "tost_margin"):
                assert math.isnan(value), f.name
        assert res.equivalent is False and res.t_df == 0 and res.n_rel == 0
    assert paired_comparison([np.nan, 1.0], [2.0, np.nan]).n_dropped == 2


def test_n_one_gives_descriptives_only() -> None:
    res = paired_comparison([10.0], [12.0], margin=5.0)
    assert res.n == 1 and res.mean_difference == 2.0 and res.mean_abs_error == 2.0
    assert math.isnan(res.sd_difference) and math.isnan(res.loa_low)
    assert math.isnan(res.cohen_dz)
    for name in INFERENTIAL_FIELDS:
        assert math.isnan(getattr(res, name)), name
    assert res.equivalent is False


def test_n_two_gives_no_tests() -> None:
    res = paired_comparison([10.0, 11.0], [12.0, 12.5], margin=5.0)
    assert res.n == 2
    assert res.sd_difference == pytest.approx(math.sqrt(0.125))  # d = 2, 1.5
    assert res.loa_high == pytest.approx(1.75 + 1.96 * math.sqrt(0.125))
    for name in INFERENTIAL_FIELDS:
        assert math.isnan(getattr(res, name)), name
    assert res.equivalent is False


def test_all_differences_zero() -> None:
    x = [3.0, 5.0, 7.0, 9.0]
    res = paired_comparison(x, x, margin=0.5)
    assert res.sd_difference == 0.0 and res.mean_difference == 0.0
    assert res.t_statistic == 0.0 and res.t_pvalue == 1.0
    assert (res.ci_low, res.ci_high) == (0.0, 0.0)
    assert res.wilcoxon_statistic == 0.0 and res.wilcoxon_pvalue == 1.0
    assert res.tost_pvalue == 0.0 and res.equivalent is True
    assert res.cohen_dz == 0.0
    assert (res.loa_low, res.loa_high, res.loa_low_ci_low, res.loa_high_ci_high) == (0, 0, 0, 0)
    assert res.mean_abs_error == 0.0 and res.rmse == 0.0


@pytest.mark.parametrize("shift", [0.25, 2.0, -0.75])
def test_constant_nonzero_differences(shift: float) -> None:
    ref = np.array([3.0, 5.0, 7.0, 9.0, 11.0])
    res = paired_comparison(ref, ref + shift)  # shifts exact in binary floating point
    assert res.sd_difference == 0.0
    assert res.t_statistic == math.copysign(math.inf, shift)
    assert res.t_pvalue == 0.0
    assert res.ci_low == res.ci_high == pytest.approx(shift)
    assert res.cohen_dz == math.copysign(math.inf, shift)


def test_constant_differences_exactly_representable() -> None:
    ref = np.array([1.0, 2.0, 4.0, 8.0])
    res = paired_comparison(ref, ref - 0.5)
    assert res.sd_difference == 0.0
    assert res.t_statistic == -math.inf and res.t_pvalue == 0.0
    assert (res.ci_low, res.ci_high) == (-0.5, -0.5)
    # all differences negative: R+ = 0, exact two-sided p = 2 / 2^4
    assert res.wilcoxon_statistic == 0.0
    assert res.wilcoxon_pvalue == pytest.approx(2 / 16)


@pytest.mark.parametrize(("margin", "p"), [(1.0, 0.0), (0.5, 0.5), (0.25, 1.0)])
def test_tost_with_constant_differences(margin: float, p: float) -> None:
    ref = np.array([1.0, 2.0, 4.0, 8.0])
    res = paired_comparison(ref, ref + 0.5, margin=margin)
    assert res.tost_pvalue == p
    assert res.equivalent is (p < 0.05)


def test_margin_none_gives_nan_tost() -> None:
    res = paired_comparison(REF, MOD)
    assert math.isnan(res.tost_margin) and math.isnan(res.tost_pvalue)
    assert res.equivalent is False


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"reference": [1.0, 2.0, 3.0], "model": [1.0, 2.0]}, DataError),
        ({"reference": [1.0, np.inf, 3.0], "model": [1.0, 2.0, 3.0]}, DataError),
        ({"reference": [[1.0, 2.0]], "model": [[1.0, 2.0]]}, DataError),
        ({"reference": ["a", "b"], "model": [1.0, 2.0]}, DataError),
        ({"reference": REF, "model": MOD, "margin": 0.0}, ParameterError),
        ({"reference": REF, "model": MOD, "margin": -1.0}, ParameterError),
        ({"reference": REF, "model": MOD, "margin": math.inf}, ParameterError),
        ({"reference": REF, "model": MOD, "alpha": 0.0}, ParameterError),
        ({"reference": REF, "model": MOD, "confidence": 1.0}, ParameterError),
    ],
)
def test_paired_invalid_input(kwargs: dict, error: type[Exception]) -> None:
    with pytest.raises(error):
        paired_comparison(**kwargs)


def test_pandas_nullable_input() -> None:
    ref = pd.Series([10.0, 12.0, None, 15.0, 20.0], dtype="Float64")
    mod = pd.Series([11.0, 12.5, 3.0, 14.0, 21.5], dtype="Float64")
    res = paired_comparison(ref, mod)
    assert res.n == 4 and res.n_dropped == 1


# ----------------------------------------------------------------------------
# paired_comparison_table
# ----------------------------------------------------------------------------


def _table_frame() -> pd.DataFrame:
    rng = np.random.default_rng(7)
    n = 36
    dv_rec = rng.uniform(5, 25, n)
    ees_rec = rng.uniform(5, 40, n)
    return pd.DataFrame({
        "impact_type": np.where(np.arange(n) < 30, "full", "sliding"),
        "dv_rec": dv_rec,
        "dv_vfs": dv_rec + rng.normal(0, 1, n),
        "ees_rec": ees_rec,
        "ees_vfs": ees_rec + rng.normal(0.5, 2, n),
    })


def test_table_rows_match_individual_comparisons() -> None:
    df = _table_frame()
    df.loc[3, "impact_type"] = None  # counts in "all" only
    tab = paired_comparison_table(
        df, ["dv_rec", "ees_rec"], ["dv_vfs", "ees_vfs"], group_col="impact_type",
        outcomes=["delta_v", "ees"], margins={"delta_v": 1.0},
    )
    assert list(tab["outcome"]) == ["delta_v"] * 3 + ["ees"] * 3
    assert list(tab["group"]) == [ALL_GROUP, "full", "sliding"] * 2
    assert set(f.name for f in dataclasses.fields(PairedComparison)) <= set(tab.columns)
    row = tab[(tab.outcome == "delta_v") & (tab.group == "full")].iloc[0]
    sub = df[df.impact_type == "full"]
    direct = paired_comparison(sub.dv_rec, sub.dv_vfs, margin=1.0)
    assert row["n"] == direct.n == 29
    assert row["t_pvalue"] == pytest.approx(direct.t_pvalue)
    assert row["tost_pvalue"] == pytest.approx(direct.tost_pvalue)
    assert tab.loc[0, "n"] == 36
    assert tab[tab.outcome == "ees"]["tost_pvalue"].isna().all()


def test_table_without_groups_and_single_columns() -> None:
    df = _table_frame()
    tab = paired_comparison_table(df, "dv_rec", "dv_vfs")
    assert len(tab) == 1 and tab.loc[0, "group"] == ALL_GROUP
    assert tab.loc[0, "outcome"] == "dv_rec"


def test_table_errors() -> None:
    df = _table_frame()
    with pytest.raises(DataError, match="missing"):
        paired_comparison_table(df, ["dv_rec"], ["nope"])
    with pytest.raises(ParameterError):
        paired_comparison_table(df, ["dv_rec", "ees_rec"], ["dv_vfs"])
    with pytest.raises(ParameterError, match="unknown outcome"):
        paired_comparison_table(df, ["dv_rec"], ["dv_vfs"], margins={"dv": 1.0})
    df.loc[0, "impact_type"] = ALL_GROUP
    with pytest.raises(DataError, match="reserved"):
        paired_comparison_table(df, ["dv_rec"], ["dv_vfs"], group_col="impact_type")


# ----------------------------------------------------------------------------
# contingency_comparison
# ----------------------------------------------------------------------------


def _labels_from_table(table: np.ndarray, cats: list[str]) -> tuple[list[str], list[str]]:
    ref: list[str] = []
    mod: list[str] = []
    for i, j in itertools.product(range(len(cats)), repeat=2):
        ref += [cats[i]] * int(table[i, j])
        mod += [cats[j]] * int(table[i, j])
    return ref, mod


def test_contingency_hand_computed_2x2() -> None:
    # rows reference, columns model: 25 full/full, 3 full->sliding, 1 sliding->full, 7 sliding
    counts = np.array([[25, 3], [1, 7]])
    ref, mod = _labels_from_table(counts, ["full", "sliding"])
    res = contingency_comparison(ref, mod)
    assert res.categories == ("full", "sliding")
    assert res.table.loc["full", "sliding"] == 3 and res.table.loc["sliding", "full"] == 1
    assert res.table.index.name == "reference" and res.table.columns.name == "model"
    assert (res.n, res.n_agree, res.n_discordant) == (36, 32, 4)
    assert res.observed_agreement == pytest.approx(32 / 36)
    # paper's chi-squared: 2x2 table reference counts (28, 8) vs model counts (26, 10)
    # chi2 = N (ad - bc)^2 / (r1 r2 c1 c2) with N = 72
    chi2 = 72 * (28 * 10 - 8 * 26) ** 2 / (36 * 36 * 54 * 18)
    assert res.chi2_statistic == pytest.approx(chi2)
    assert res.chi2_pvalue == pytest.approx(sps.chi2.sf(chi2, 1))
    assert res.chi2_df == 1
    # McNemar exact (b + c = 4 < 25): p = 2 * P(Bin(4, 0.5) <= 1) = 2 * (1 + 4) / 16
    assert res.mcnemar_method == "exact"
    assert res.mcnemar_statistic == 1.0
    assert res.mcnemar_pvalue == pytest.approx(2 * 5 / 16)
    # Stuart-Maxwell = Bowker = uncorrected McNemar = (b - c)^2 / (b + c) = 4 / 4
    assert res.stuart_maxwell_statistic == pytest.approx(1.0)
    assert res.bowker_statistic == pytest.approx(1.0)
    assert res.stuart_maxwell_df == res.bowker_df == 1
    assert res.bowker_pvalue == pytest.approx(sps.chi2.sf(1.0, 1))
    # kappa: p_o = 32/36, p_e = (28 * 26 + 8 * 10) / 36^2 -> (1152 - 808) / (1296 - 808)
    assert res.kappa == pytest.approx(344 / 488)


def test_contingency_chi2_matches_scipy_on_2xk() -> None:
    counts = np.array([[10, 2, 1], [3, 8, 2], [0, 4, 6]])
    ref, mod = _labels_from_table(counts, ["a", "b", "c"])
    res = contingency_comparison(ref, mod)
    expected = sps.chi2_contingency(
        np.vstack([counts.sum(axis=1), counts.sum(axis=0)]), correction=False)
    assert res.chi2_statistic == pytest.approx(expected.statistic)
    assert res.chi2_pvalue == pytest.approx(expected.pvalue)
    assert res.chi2_df == 2


@pytest.mark.parametrize("seed", range(8))
def test_mcnemar_matches_statsmodels(seed: int) -> None:
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 30, size=(2, 2))
    ref, mod = _labels_from_table(counts, ["x", "y"])
    res = contingency_comparison(ref, mod, categories=["x", "y"])
    discordant = counts[0, 1] + counts[1, 0]
    if discordant == 0:
        assert res.mcnemar_pvalue == 1.0
        return
    exact = discordant < 25
    expected = mcnemar(counts, exact=exact, correction=True)
    assert res.mcnemar_method == ("exact" if exact else "chi2")
    assert res.mcnemar_statistic == pytest.approx(expected.statistic)
    assert res.mcnemar_pvalue == pytest.approx(min(1.0, expected.pvalue))


def test_mcnemar_uses_chi2_from_25_discordant_pairs() -> None:
    counts = np.array([[5, 20], [5, 5]])
    res = contingency_comparison(*_labels_from_table(counts, ["x", "y"]))
    assert res.mcnemar_method == "chi2"
    assert res.mcnemar_statistic == pytest.approx((abs(20 - 5) - 1) ** 2 / 25)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("k", [2, 3, 4])
def test_square_table_tests_and_kappa_match_statsmodels(seed: int, k: int) -> None:
    rng = np.random.default_rng(100 * k + seed)
    counts = rng.integers(1, 25, size=(k, k)) + np.diag(rng.integers(5, 40, size=k))
    cats = [f"c{i}" for i in range(k)]
    res = contingency_comparison(*_labels_from_table(counts, cats))
    square = SquareTable(counts, shift_zeros=False)
    hom = square.homogeneity(method="stuart_maxwell")
    sym = square.symmetry(method="bowker")
    assert res.stuart_maxwell_statistic == pytest.approx(hom.statistic, rel=1e-9)
    assert res.stuart_maxwell_pvalue == pytest.approx(hom.pvalue, rel=1e-7, abs=1e-12)
    assert res.stuart_maxwell_df == hom.df == k - 1
    assert res.bowker_statistic == pytest.approx(sym.statistic, rel=1e-9)
    assert res.bowker_pvalue == pytest.approx(sym.pvalue, rel=1e-9)
    assert res.bowker_df == sym.df
    kap = cohens_kappa(counts)  # 95 % Wald interval
    assert res.kappa == pytest.approx(kap.kappa)
    assert res.kappa_se == pytest.approx(kap.std_kappa)
    assert (res.kappa_ci_low, res.kappa_ci_high) == pytest.approx((kap.kappa_low, kap.kappa_upp))
    assert res.kappa_pvalue == pytest.approx(kap.pvalue_two_sided)
    if k > 2:
        assert math.isnan(res.mcnemar_pvalue) and res.mcnemar_method == ""


def test_unobserved_category() -> None:
    counts = np.array([[10, 2], [4, 6]])
    ref, mod = _labels_from_table(counts, ["full", "sliding"])
    base = contingency_comparison(ref, mod)
    res = contingency_comparison(ref, mod, categories=["full", "sliding", "none"])
    assert res.table.shape == (3, 3)
    assert res.table.loc["none"].sum() == 0 and res.table["none"].sum() == 0
    assert res.chi2_statistic == pytest.approx(base.chi2_statistic) and res.chi2_df == 1
    assert res.stuart_maxwell_statistic == pytest.approx(base.stuart_maxwell_statistic)
    assert res.stuart_maxwell_df == 1
    assert res.bowker_statistic == pytest.approx(base.bowker_statistic) and res.bowker_df == 1
    assert res.kappa == pytest.approx(base.kappa)
    assert res.kappa_se == pytest.approx(base.kappa_se)
    assert math.isnan(res.mcnemar_pvalue)  # k = 3 given: McNemar is for 2 x 2 only


def test_stuart_maxwell_singular_table_uses_informative_categories() -> None:
    # category "c" only ever agrees: statsmodels cannot invert, we drop it (df = 1)
    counts = np.array([[10, 5, 0], [2, 8, 0], [0, 0, 4]])
    res = contingency_comparison(*_labels_from_table(counts, ["a", "b", "c"]))
    reduced = SquareTable(counts[:2, :2], shift_zeros=False).homogeneity()
    assert res.stuart_maxwell_df == 1
    assert res.stuart_maxwell_statistic == pytest.approx(reduced.statistic)
    assert res.stuart_maxwell_pvalue == pytest.approx(reduced.pvalue)
    # Bowker: only the pair (a, b) has discordant counts -> df 1, (5 - 2)^2 / 7
    assert res.bowker_df == 1
    assert res.bowker_statistic == pytest.approx(9 / 7)


def test_all_pairs_agree() -> None:
    ref = ["full"] * 5 + ["sliding"] * 3
    res = contingency_comparison(ref, list(ref))
    assert res.n_discordant == 0 and res.observed_agreement == 1.0
    assert res.mcnemar_statistic == 0.0 and res.mcnemar_pvalue == 1.0
    assert res.stuart_maxwell_pvalue == 1.0 and res.bowker_pvalue == 1.0
    assert res.stuart_maxwell_df == 0 and res.bowker_df == 0
    assert res.chi2_statistic == pytest.approx(0.0) and res.chi2_pvalue == pytest.approx(1.0)
    assert res.kappa == pytest.approx(1.0) and res.kappa_se == pytest.approx(0.0)


def test_single_category_used() -> None:
    res = contingency_comparison(["full"] * 4, ["full"] * 4)
    assert res.categories == ("full",)
    assert res.mcnemar_pvalue == 1.0 and res.chi2_pvalue == 1.0 and res.chi2_df == 0
    assert math.isnan(res.kappa) and math.isnan(res.kappa_se)  # expected agreement 1


def test_contingency_n_zero() -> None:
    res = contingency_comparison([], [], categories=["full", "sliding"])
    assert res.n == 0 and res.table.shape == (2, 2) and res.table.to_numpy().sum() == 0
    for name in ("observed_agreement", "chi2_pvalue", "mcnemar_pvalue", "stuart_maxwell_pvalue",
                 "bowker_pvalue", "kappa", "kappa_se", "kappa_pvalue"):
        assert math.isnan(getattr(res, name)), name
    empty = contingency_comparison([None, "a"], ["b", np.nan])
    assert empty.n == 0 and empty.n_dropped == 2 and empty.categories == ()


def test_contingency_missing_labels_dropped() -> None:
    res = contingency_comparison(["a", None, "b", "a"], ["a", "b", np.nan, "b"])
    assert res.n == 2 and res.n_dropped == 2
    assert res.table.loc["a", "a"] == 1 and res.table.loc["a", "b"] == 1


def test_contingency_errors() -> None:
    with pytest.raises(DataError):
        contingency_comparison(["a", "b"], ["a"])
    with pytest.raises(DataError, match="not one of the categories"):
        contingency_comparison(["a", "b"], ["a", "z"], categories=["a", "b"])
    with pytest.raises(ParameterError):
        contingency_comparison(["a"], ["a"], categories=["a", "a"])
    with pytest.raises(DataError):
        contingency_comparison("ab", "ab")


def test_contingency_result_equality_ignores_table() -> None:
    res = contingency_comparison(["a", "b", "a"], ["a", "a", "a"])
    assert isinstance(res, ContingencyComparison)
    assert res == contingency_comparison(["a", "b", "a"], ["a", "a", "a"])


# ----------------------------------------------------------------------------
# bootstrap_ci
# ----------------------------------------------------------------------------


def test_bootstrap_reproducible_for_fixed_seed() -> None:
    x = np.random.default_rng(0).normal(size=50)
    a = bootstrap_ci(np.mean, x, rng=np.random.default_rng(42))
    b = bootstrap_ci(np.mean, x, rng=np.random.default_rng(42))
    c = bootstrap_ci(np.mean, x, rng=np.random.default_rng(43))
    assert a == b
    assert a[0] == c[0] and a[1:] != c[1:]
    assert a[0] == pytest.approx(np.mean(x))


def test_bootstrap_batched_equals_loop_and_manual() -> None:
    x = np.random.default_rng(1).exponential(size=30)
    batched = bootstrap_ci(np.mean, x, n_boot=500, rng=np.random.default_rng(5))
    looped = bootstrap_ci(lambda v: float(np.mean(v)), x, n_boot=500,
                          rng=np.random.default_rng(5))
    assert batched == pytest.approx(looped)
    # the same draw by hand: all indices at once, percentiles 2.5 and 97.5
    idx = np.random.default_rng(5).integers(0, 30, size=(500, 30))
    boot = x[idx].mean(axis=1)
    assert batched[1:] == pytest.approx(tuple(np.quantile(boot, [0.025, 0.975])))


def test_bootstrap_counts_statistic_uses_the_same_draws() -> None:
    # a statistic of the resampling counts (ratio of means by a matrix product) gives the
    # interval of the same statistic on the copied samples, drawn alike
    rng = np.random.default_rng(4)
    a, b = rng.exponential(size=(60, 3)), rng.exponential(size=60)

    def ratio(x: np.ndarray, y: np.ndarray, axis: int = 0) -> np.ndarray:
        return np.mean(x[..., 1], axis=axis) / np.mean(y, axis=axis)

    def ratio_counts(x: np.ndarray, y: np.ndarray, counts: np.ndarray) -> np.ndarray:
        return (counts @ x[:, 1]) / (counts @ y)

    copied = bootstrap_ci(ratio, a, b, n_boot=700, rng=np.random.default_rng(9))
    counted = bootstrap_ci(ratio_counts, a, b, n_boot=700, rng=np.random.default_rng(9))
    assert counted == pytest.approx(copied, rel=1e-12)
    assert counted[1] < counted[0] < counted[2]


def test_bootstrap_resamples_pairs_jointly() -> None:
    rng = np.random.default_rng(2)
    ref = rng.normal(20, 5, 40)
    mod = ref + 1.0  # every paired difference is exactly 1 -> any joint resample gives 1
    def mean_diff(r: np.ndarray, m: np.ndarray, axis: int = 0) -> np.ndarray:
        return np.mean(m - r, axis=axis)
    est, low, high = bootstrap_ci(mean_diff, ref, mod, rng=np.random.default_rng(3))
    assert (est, low, high) == pytest.approx((1.0, 1.0, 1.0))


def test_bootstrap_weights() -> None:
    x = np.array([1.0, 2.0, 3.0, 10.0])
    w = np.array([1.0, 1.0, 1.0, 0.5])
    est, low, high = bootstrap_ci(np.average, x, weights=w, n_boot=300,
                                  rng=np.random.default_rng(0))
    assert est == pytest.approx((1 + 2 + 3 + 0.5 * 10) / 3.5)  # weighted mean
    # weights travel with their cases: same draw by hand
    idx = np.random.default_rng(0).integers(0, 4, size=(300, 4))
    boot = np.average(x[idx], axis=1, weights=w[idx])
    assert (low, high) == pytest.approx(tuple(np.quantile(boot, [0.025, 0.975])))
    uniform = bootstrap_ci(np.average, x, weights=np.ones(4), rng=np.random.default_rng(9))
    plain = bootstrap_ci(np.mean, x, rng=np.random.default_rng(9))
    assert uniform == pytest.approx(plain)


def test_bootstrap_2d_cases() -> None:
    data = np.column_stack([np.arange(20.0), np.arange(20.0) * 2])
    def ratio_of_means(a: np.ndarray, axis: int = 0) -> np.ndarray:
        means = np.mean(a, axis=axis)
        return means[..., 1] / means[..., 0]
    est, low, high = bootstrap_ci(ratio_of_means, data, rng=np.random.default_rng(0))
    assert (est, low, high) == pytest.approx((2.0, 2.0, 2.0))


def test_bootstrap_coverage_near_nominal() -> None:
    rng = np.random.default_rng(2024)
    true_mean, n, reps = 5.0, 30, 200
    covered = 0
    for _ in range(reps):
        x = rng.normal(true_mean, 2.0, n)
        _, low, high = bootstrap_ci(np.mean, x, n_boot=1000, rng=rng)
        covered += low <= true_mean <= high
    assert 0.86 <= covered / reps <= 0.99


def test_bootstrap_errors() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ParameterError, match="Generator"):
        bootstrap_ci(np.mean, [1.0, 2.0], rng=np.random.RandomState(0))  # type: ignore[arg-type]
    with pytest.raises(DataError):
        bootstrap_ci(np.mean, [1.0, 2.0], [1.0], rng=rng)
    with pytest.raises(DataError):
        bootstrap_ci(np.mean, [], rng=rng)
    with pytest.raises(DataError):
        bootstrap_ci(np.mean, rng=rng)
    with pytest.raises(ParameterError):
        bootstrap_ci(np.mean, [1.0, 2.0], n_boot=0, rng=rng)
    with pytest.raises(ParameterError, match="weights"):
        bootstrap_ci(np.mean, [1.0, 2.0], weights=[1.0, 1.0], rng=rng)
    with pytest.raises(ParameterError):
        bootstrap_ci(np.average, [1.0, 2.0], weights=[1.0, -1.0], rng=rng)
    with pytest.raises(ParameterError, match="one number"):
        bootstrap_ci(lambda v: v, [1.0, 2.0], rng=rng)


# ----------------------------------------------------------------------------
# Multiple testing
# ----------------------------------------------------------------------------


def test_holm_and_bh_hand_computed() -> None:
    p = [0.01, 0.04, 0.03, 0.005]
    # Holm: sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 = 0.02, 0.03, 0.06, 0.04,
    # running maximum 0.02, 0.03, 0.06, 0.06, back in input order:
    assert holm_bonferroni(p) == pytest.approx([0.03, 0.06, 0.06, 0.02])
    # BH: sorted times m / rank = 0.02, 0.02, 0.04, 0.04, running minimum from the top:
    assert benjamini_hochberg(p) == pytest.approx([0.02, 0.04, 0.04, 0.02])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=1, max_size=30))
def test_multiple_testing_matches_statsmodels(pvalues: list[float]) -> None:
    holm = multipletests(pvalues, method="holm")[1]
    bh = multipletests(pvalues, method="fdr_bh")[1]
    assert holm_bonferroni(pvalues) == pytest.approx(holm, abs=1e-12)
    assert benjamini_hochberg(pvalues) == pytest.approx(bh, abs=1e-12)


def test_multiple_testing_nan_shape_and_errors() -> None:
    p = np.array([[0.01, np.nan], [0.04, 0.03]])
    holm = holm_bonferroni(p)
    assert holm.shape == (2, 2) and math.isnan(holm[0, 1])
    assert holm[~np.isnan(p)] == pytest.approx(holm_bonferroni([0.01, 0.04, 0.03]))
    assert benjamini_hochberg([]).shape == (0,)
    with pytest.raises(ParameterError):
        holm_bonferroni([0.5, 1.5])
    with pytest.raises(ParameterError):
        benjamini_hochberg([-0.1])


# ----------------------------------------------------------------------------
# Wilson and BCa intervals
# ----------------------------------------------------------------------------


def test_wilson_against_hand_computed_value() -> None:
    from vfs.analysis.stats import wilson_interval
    # 3 of 10 at 95 %: z = 1.959964, z^2 = 3.841459; centre (0.3 + z^2/20) / (1 + z^2/10)
    # = 0.355507, half-width z sqrt(0.021 + z^2/400) / (1 + z^2/10) = 0.247716
    low, high = wilson_interval(3, 10)
    assert float(low) == pytest.approx(0.355507 - 0.247716, abs=2e-6)
    assert float(high) == pytest.approx(0.355507 + 0.247716, abs=2e-6)


@pytest.mark.parametrize(("k", "n", "conf"), [(0, 7, 0.95), (7, 7, 0.95), (13, 40, 0.9),
                                              (1, 1000, 0.99), (250, 500, 0.95)])
def test_wilson_matches_statsmodels(k: int, n: int, conf: float) -> None:
    from statsmodels.stats.proportion import proportion_confint

    from vfs.analysis.stats import wilson_interval
    low, high = wilson_interval(k, n, conf)
    ref = proportion_confint(k, n, alpha=1 - conf, method="wilson")
    assert (float(low), float(high)) == pytest.approx(ref, abs=1e-12)


def test_wilson_at_the_edges_is_not_a_point() -> None:
    from vfs.analysis.stats import wilson_interval
    low, high = wilson_interval(np.array([0, 20]), np.array([20, 20]))
    assert low[0] == 0.0 and high[0] > 0.0
    assert high[1] == 1.0 and low[1] < 1.0
    z2 = 1.959964 ** 2
    assert high[0] == pytest.approx(z2 / (20 + z2), rel=1e-6)   # closed form at k = 0
    nan_low, _ = wilson_interval(0, 0)
    assert np.isnan(nan_low)
    with pytest.raises(ParameterError):
        wilson_interval(5, 3)


def test_bca_matches_scipy_for_a_skewed_mean() -> None:
    from scipy.stats import bootstrap

    from vfs.analysis.stats import bca_interval
    rng = np.random.default_rng(3)
    x = rng.exponential(size=25) ** 2            # strongly right-skewed
    b = 40000
    boot = x[rng.integers(0, x.size, size=(b, x.size))].mean(axis=1)
    jack = (x.sum() - x) / (x.size - 1)
    low, high = bca_interval(boot, float(x.mean()), jack)
    ref = bootstrap((x,), np.mean, method="BCa", n_resamples=b,
                    rng=np.random.default_rng(4)).confidence_interval
    width = ref.high - ref.low
    assert low == pytest.approx(ref.low, abs=0.04 * width)
    assert high == pytest.approx(ref.high, abs=0.04 * width)
    # the percentile interval of the same replicates sits lower: BCa corrects the skew
    p_low, p_high = np.quantile(boot, [0.025, 0.975])
    assert high > p_high


def test_bca_falls_back_to_percentiles_when_undefined() -> None:
    from vfs.analysis.stats import bca_interval
    boot = np.array([1.0, 2.0, 3.0, 4.0])
    assert bca_interval(boot, 10.0, [1.0, 1.0]) == (1.0, 4.0)
    assert np.isnan(bca_interval([np.nan], 1.0, [1.0, 2.0])[0])


def test_bootstrap_ci_bca_matches_scipy() -> None:
    from scipy.stats import bootstrap
    rng = np.random.default_rng(5)
    x = rng.lognormal(sigma=1.0, size=30)
    est, low, high = bootstrap_ci(np.mean, x, n_boot=20000, rng=np.random.default_rng(6),
                                  method="bca")
    ref = bootstrap((x,), np.mean, method="BCa", n_resamples=20000,
                    rng=np.random.default_rng(7)).confidence_interval
    width = ref.high - ref.low
    assert est == pytest.approx(x.mean())
    assert low == pytest.approx(ref.low, abs=0.05 * width)
    assert high == pytest.approx(ref.high, abs=0.05 * width)
    # the same with a statistic called per sample (no axis parameter)
    _, low2, high2 = bootstrap_ci(lambda v: float(np.mean(v)), x, n_boot=4000,
                                  rng=np.random.default_rng(6), method="bca")
    assert low2 == pytest.approx(ref.low, abs=0.1 * width)
    with pytest.raises(ParameterError):
        bootstrap_ci(np.mean, x, rng=np.random.default_rng(0), method="basic")
