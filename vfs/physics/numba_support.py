"""The one switch and the one check of the compiled (numba) kernels.

The kernels -- the pre-crash core (:mod:`vfs.physics.core`), the run-out to rest
(:mod:`vfs.physics.core_runout`), the overlap clip (:mod:`vfs.physics.compiled`) and the
gym's gap (:mod:`vfs.gym.compiled`) -- each repeat a numpy reference.  numba is a required
dependency of vfs; ``VFS_COMPILED=0`` selects the numpy references everywhere (read at every
call, so a test can switch it).  :func:`run_kernel` says once per kernel and process when
numba compiled it instead of loading it from its cache (the first run after an install).
:func:`kernel_threads` gives a threaded kernel its numba threads (``VFS_THREADS``,
:mod:`vfs.threads`) and keeps two threaded launches from running at once.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import threading
import time
from collections.abc import Iterator
from typing import Any

from vfs.errors import ParameterError
from vfs.threads import compute_threads

#: Environment variable that switches the compiled kernels off ("0").
ENV_SWITCH = "VFS_COMPILED"

#: numba is installed (it is imported only when a kernel first runs: importing it costs a
#: few tenths of a second that a command without a kernel need not pay).
AVAILABLE = importlib.util.find_spec("numba") is not None


def require_numba() -> None:
    """Raise :class:`vfs.errors.ParameterError` where numba is missing: the one check of
    every compiled kernel.
    """
    if not AVAILABLE:
        raise ParameterError("the compiled kernels need numba (a dependency of vfs): "
                             "pip install numba")


def enabled() -> bool:
    """True where numba is installed and ``VFS_COMPILED`` is not "0" (read at every call)."""
    return AVAILABLE and os.environ.get(ENV_SWITCH, "1") != "0"


_REPORTED_COMPILE: set[str] = set()


def run_kernel(kernel: Any, name: str, *args: Any) -> Any:
    """Call ``kernel(*args)``; after its first call in this process, say (logging WARNING on
    the ``vfs.physics.core`` logger, once per ``name``) when numba compiled it instead of
    loading it from its cache: the first run after an install or an upgrade.
    """
    if name in _REPORTED_COMPILE:
        return kernel(*args)
    t0 = time.perf_counter()
    out = kernel(*args)
    _REPORTED_COMPILE.add(name)
    stats = getattr(kernel, "stats", None)
    if stats is not None and sum(stats.cache_misses.values()):
        logging.getLogger("vfs.physics.core").warning(
            "vfs: compiled the %s in %.0f s (once: numba cached it "
            "in %s; later runs load it)", name, time.perf_counter() - t0, stats.cache_path)
    return out


#: numba's threading layer, once known (after the first threaded launch of the process).
_REPORTED_LAYER: list[str] = []
#: Held while a threaded kernel (``parallel=True``) runs in this process.
_THREADED_LAUNCH = threading.Lock()


@contextlib.contextmanager
def kernel_threads(iterations: int) -> Iterator[int]:
    """The numba threads for a threaded kernel of ``iterations`` parallel iterations
    launched in this block: :func:`vfs.threads.compute_threads` (at most ``iterations``),
    or 1, where the caller runs its one-thread kernel instead.

    1 also where another thread of this process is running a threaded kernel at that
    moment (dask's threaded scheduler, a thread pool): numba's own "workqueue" threading
    layer, the one it falls back to where no OpenMP or TBB runtime is found (a pip install
    is sure of no other), aborts the process when two threads launch parallel kernels at
    once; ``numba.threading_layer()`` is known only after the first launch, so the rule
    holds for every layer.  So one threaded launch runs at a time, whatever the
    layer, and the others run in one thread each at the same time (the one-thread
    kernels release the GIL).  Inside the block ``numba.set_num_threads`` holds the
    count (numba keeps it per calling thread); it is restored on exit.

    Raises
    ------
    SettingsError
        Where ``VFS_THREADS`` is not an integer in the allowed range.
    """
    threads = min(compute_threads(), iterations)
    if threads <= 1 or not _THREADED_LAUNCH.acquire(blocking=False):
        yield 1
        return
    try:
        import numba

        before = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            yield threads
        finally:
            numba.set_num_threads(before)
        if not _REPORTED_LAYER:
            with contextlib.suppress(ValueError):  # the block launched no threaded kernel
                _REPORTED_LAYER.append(numba.threading_layer())
                logging.getLogger("vfs.physics.core").debug(
                    "vfs: compiled kernels in %d threads on numba's %s threading layer",
                    threads, _REPORTED_LAYER[0])
    finally:
        _THREADED_LAUNCH.release()
