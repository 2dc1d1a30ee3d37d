"""Plain Monte Carlo and randomised quasi-Monte Carlo draws of the uncertain inputs."""

from __future__ import annotations

import numpy as np
import pytest

from vfs.errors import ParameterError
from vfs.uncertainty.sampling import SAMPLING_METHODS, unit_samples


@pytest.mark.parametrize("method", SAMPLING_METHODS)
def test_unit_samples_shape_range_and_seed(method: str) -> None:
    u = unit_samples(64, 3, 5, np.random.default_rng(1), method)
    assert u.shape == (64 * 3, 5)
    assert np.all((u > 0) & (u < 1))
    again = unit_samples(64, 3, 5, np.random.default_rng(1), method)
    other = unit_samples(64, 3, 5, np.random.default_rng(2), method)
    assert np.array_equal(u, again) and not np.array_equal(u, other)
    # cases get independent randomisations (sample-major rows s N + j)
    per_case = u.reshape(64, 3, 5)
    assert not np.allclose(per_case[:, 0], per_case[:, 1])


@pytest.mark.parametrize("method", ["sobol", "lhs"])
def test_qmc_stratifies_every_input_of_every_case(method: str) -> None:
    """LHS by construction, scrambled Sobol' for S = 2^m: each of the S equal strata of
    every one-dimensional projection holds exactly one point."""
    s = 128
    u = unit_samples(s, 4, 6, np.random.default_rng(3), method).reshape(s, 4, 6)
    strata = np.floor(u * s).astype(int)
    for j in range(4):
        for k in range(6):
            assert np.array_equal(np.sort(strata[:, j, k]), np.arange(s)), (j, k)


def test_random_is_not_stratified() -> None:
    """The stratification test above can fail: plain Monte Carlo leaves strata empty."""
    s = 128
    u = unit_samples(s, 1, 6, np.random.default_rng(3), "random")
    strata = np.floor(u * s).astype(int)
    assert any(len(np.unique(strata[:, k])) < s for k in range(6))


def test_qmc_integrates_a_smooth_function_more_accurately() -> None:
    """Mean of f(u) = prod_k (1 + (u_k - 1/2)) = 1 exactly; RMS error over 20 seeds."""
    def rms(method: str) -> float:
        errs = [np.prod(1 + (unit_samples(256, 1, 4, np.random.default_rng(r), method) - 0.5),
                        axis=1).mean() - 1.0 for r in range(20)]
        return float(np.sqrt(np.mean(np.square(errs))))
    random = rms("random")
    assert rms("sobol") < random / 5
    assert rms("lhs") < random / 2


def test_unknown_method_and_bad_size_raise() -> None:
    with pytest.raises(ParameterError, match="sobol"):
        unit_samples(8, 1, 2, np.random.default_rng(0), "halton")
    with pytest.raises(ParameterError):
        unit_samples(0, 1, 2, np.random.default_rng(0), "random")


def test_run_uncertainty_records_the_method() -> None:
    from vfs.database import open_database
    from vfs.uncertainty import CaseSet, default_config, run_uncertainty
    cases = CaseSet.from_database(open_database("default")).take(slice(0, 2))
    res = run_uncertainty(cases, default_config(), n_samples=32, seed=0, sampling="lhs")
    assert res.sampling == "lhs"
    assert res.bands["p5"].notna().any()
