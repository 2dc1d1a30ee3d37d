"""One BLAS thread under vfs's jobs, from the command line and from Python (vfs.blas)."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info

from vfs.blas import THREAD_VARIABLES, one_blas_thread


def _blas_threads() -> list[int]:
    return [int(p["num_threads"]) for p in threadpool_info() if p["user_api"] == "blas"]


@pytest.fixture
def no_user_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def test_decorated_function_runs_with_one_blas_thread(no_user_choice: None) -> None:
    import numpy as np
    from threadpoolctl import threadpool_limits

    np.linalg.eigh(np.eye(3))  # BLAS loaded
    with threadpool_limits(limits=2, user_api="blas"):  # as on a machine of 2+ cores
        assert all(n == 2 for n in _blas_threads())
        seen = one_blas_thread(_blas_threads)()
    assert seen and all(n == 1 for n in seen)


def test_the_limit_ends_with_the_call(no_user_choice: None) -> None:
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        one_blas_thread(_blas_threads)()
        assert _blas_threads() == before


def test_a_users_thread_count_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    from threadpoolctl import threadpool_limits

    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    with threadpool_limits(limits=2, user_api="blas"):
        assert one_blas_thread(_blas_threads)() == _blas_threads()


def test_the_job_entry_points_are_wrapped() -> None:
    from vfs.diagnosis.diagnose import diagnose
    from vfs.diagnosis.identify import identify
    from vfs.uncertainty.bands import run_uncertainty
    from vfs.uncertainty.reconstruct import reconstruct

    for func in (diagnose, identify, run_uncertainty, reconstruct):
        assert getattr(func, "__wrapped__", None) is not None, func.__qualname__
