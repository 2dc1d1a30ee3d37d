"""Threads of the linear-algebra library (BLAS) under vfs's own jobs.

vfs's numerical work is many small problems (2x2 normal equations, 80x80
eigenproblems of the spline smoothing, vectorised elementwise kernels), for
which a multi-threaded BLAS only adds thread hand-offs: on a loaded 2-core
machine an 80 x 80 ``numpy.linalg.eigh`` took 18 ms with OpenBLAS's
threads against 0.8 ms with one.  The command line and the study's worker
processes therefore run with one BLAS thread (:func:`single_threaded_blas`),
unless the user chose a thread count with ``OPENBLAS_NUM_THREADS``,
``OMP_NUM_THREADS`` or ``MKL_NUM_THREADS`` (kept as given).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

#: Environment variables by which a user chooses the BLAS thread count (respected).
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run the block with one BLAS thread (threadpoolctl), unless a variable of
    :data:`THREAD_VARIABLES` is set: then the user's choice holds.
    """
    if any(os.environ.get(v) for v in THREAD_VARIABLES):
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


__all__ = ["THREAD_VARIABLES", "single_threaded_blas"]
