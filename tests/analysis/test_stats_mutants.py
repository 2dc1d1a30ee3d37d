"""Statistics tests written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): the bootstrap beyond one block of resampled
elements, the smallest sample the BCa interval takes, and the closed ends of the p-value
range.  References: scipy where it has the method, closed forms otherwise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vfs.analysis import stats
from vfs.analysis.stats import benjamini_hochberg, bootstrap_ci, holm_bonferroni
from vfs.errors import ParameterError


def test_bootstrap_of_more_cases_than_one_block_holds() -> None:
    """More cases than the resampled-element budget of one block: one resample per block,
    the percentile interval of the mean still about mean +- 1.96 sd / sqrt(n)."""
    n = (1 << 22) + 3
    assert n > stats._MAX_RESAMPLED_ELEMENTS  # noqa: SLF001 (the budget this is about)
    x = np.random.default_rng(3).normal(5.0, 2.0, n)
    est, low, high = bootstrap_ci(np.mean, x, n_boot=3, rng=np.random.default_rng(1))
    assert est == pytest.approx(float(x.mean()))
    se = 2.0 / math.sqrt(n)
    assert low < high and abs(low - est) < 5 * se and abs(high - est) < 5 * se


def test_bca_takes_three_cases_and_not_two() -> None:
    est, low, high = bootstrap_ci(np.mean, np.array([1.0, 2.0, 4.0]), method="bca",
                                  rng=np.random.default_rng(1))
    assert est == pytest.approx(7.0 / 3.0)
    assert 1.0 <= low <= est <= high <= 4.0 and np.isfinite([low, high]).all()
    est, low, high = bootstrap_ci(np.mean, np.array([1.0, 2.0]), method="bca",
                                  rng=np.random.default_rng(1))
    assert est == 1.5 and math.isnan(low) and math.isnan(high)


@pytest.mark.parametrize("adjust", [holm_bonferroni, benjamini_hochberg])
def test_p_value_range_is_closed(adjust) -> None:
    np.testing.assert_allclose(adjust([0.0, 1.0]), [0.0, 1.0])
    for bad in (-1e-12, 1.0 + 1e-12, 1.5):
        with pytest.raises(ParameterError, match=r"\[0, 1\]"):
            adjust([0.2, bad])
    # Holm: (m - j + 1) p(j), running maximum, capped at 1; BH: m p(j) / j, running minimum
    p = [0.01, 0.04, 0.03, 0.5]
    if adjust is holm_bonferroni:
        np.testing.assert_allclose(adjust(p), [0.04, 0.09, 0.09, 0.5])
    else:
        np.testing.assert_allclose(adjust(p), [0.04, 0.04 * 4 / 3, 0.04 * 4 / 3, 0.5])


def test_square_table_tests_without_discordant_pairs_are_zero() -> None:
    """All pairs agree: no marginal difference and no asymmetry, statistic 0, df 0, p 1
    (statsmodels cannot invert the zero covariance; the limit is exact here)."""
    ref = ["full"] * 5 + ["sliding"] * 3 + ["none"] * 2
    res = stats.contingency_comparison(ref, list(ref))
    assert (res.stuart_maxwell_statistic, res.stuart_maxwell_df) == (0.0, 0)
    assert (res.bowker_statistic, res.bowker_df) == (0.0, 0)
    assert res.stuart_maxwell_pvalue == 1.0 and res.bowker_pvalue == 1.0
    assert res.kappa == pytest.approx(1.0) and res.n_discordant == 0


def test_weights_with_one_negative_entry_are_refused() -> None:
    x = np.arange(5.0)
    for w in ([1.0, 1.0, -0.5, 1.0, 1.0], [-1.0] * 5):
        with pytest.raises(ParameterError, match="non-negative"):
            bootstrap_ci(np.average, x, weights=w, rng=np.random.default_rng(0))


def test_a_statistic_taking_axis_is_called_once_per_block() -> None:
    """vectorized=None: a statistic with an ``axis`` keyword gets all resamples of a block
    at once (the estimate, then one call per block); vectorized=False calls it per
    resample; both give the same interval (the same draws)."""
    calls: list[tuple[int, ...]] = []

    def mean(a, axis=None):
        calls.append(np.shape(a))
        return np.mean(a, axis=axis)

    x = np.random.default_rng(2).normal(size=40)
    batched = bootstrap_ci(mean, x, n_boot=200, rng=np.random.default_rng(5))
    assert len(calls) == 2 and calls[1] == (200, 40)
    calls.clear()
    looped = bootstrap_ci(mean, x, n_boot=200, rng=np.random.default_rng(5), vectorized=False)
    assert len(calls) == 201
    np.testing.assert_allclose(looped, batched, rtol=1e-12)
