"""The compiled run-out in numba's threads (``VFS_THREADS``, :mod:`vfs.threads`): every output
bit for bit as in one thread, for the vehicle loop and the pair loop, on generated cases of
every accident type; launches from several Python threads at once neither crash nor change
a result; a bad ``VFS_THREADS`` is refused.

Each vehicle (each pair) writes only its own rows, and its arithmetic does not depend on
which thread runs it: the outputs must be equal, not close.  Every comparison checks too
that the threaded kernel really ran with 2 threads (the spy on
:func:`vfs.physics.numba_support.kernel_threads`), so a silent fall-back to one thread
cannot pass for agreement.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import pytest

from tests.generated import cases_of_every_type, with_random_wheel_inputs
from tests.physics.test_core_runout import _draw
from vfs.errors import SettingsError
from vfs.physics import core_runout, numba_support
from vfs.physics.numba_support import AVAILABLE, ENV_SWITCH
from vfs.physics.runout import RunoutParams, RunoutState, run_out, run_out_pair
from vfs.simulation import CaseBatch, simulate_cases
from vfs.threads import MOST_THREADS, THREADS_VARIABLE

pytestmark = [pytest.mark.skipif(not AVAILABLE, reason="numba not installed"),
              pytest.mark.skipif(MOST_THREADS < 2, reason="numba's pool has one thread")]


@pytest.fixture
def used(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The thread counts the run-out's launches got (compiled path)."""
    monkeypatch.setenv(ENV_SWITCH, "1")
    seen: list[int] = []
    real = numba_support.kernel_threads

    @contextlib.contextmanager
    def spy(iterations: int) -> Iterator[int]:
        with real(iterations) as threads:
            seen.append(threads)
            yield threads

    monkeypatch.setattr(core_runout, "kernel_threads", spy)
    return seen


def _one_and_two(monkeypatch: pytest.MonkeyPatch, used: list[int],
                 run: Callable[[], Any]) -> tuple[Any, Any]:
    monkeypatch.setenv(THREADS_VARIABLE, "1")
    one = run()
    assert used and set(used) == {1}
    used.clear()
    monkeypatch.setenv(THREADS_VARIABLE, "2")
    two = run()
    assert 2 in used, used
    return one, two


def _identical(a: Any, b: Any, where: str = "") -> None:
    if isinstance(a, tuple):
        for name, x, y in zip(getattr(a, "_fields", range(len(a))), a, b, strict=True):
            _identical(x, y, f"{where}.{name}")
    elif isinstance(a, np.ndarray) or np.isscalar(a):
        assert np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True), where
    elif a is not None:
        _identical(tuple(vars(a).values()), tuple(vars(b).values()), where)


@pytest.mark.parametrize("load_transfer", [False, True])
def test_vehicle_loop_is_bit_identical_in_two_threads(monkeypatch: pytest.MonkeyPatch,
                                                      used: list[int],
                                                      load_transfer: bool) -> None:
    cars, state, mu, brake, wheels = _draw(3, 300)
    params = RunoutParams(load_transfer=load_transfer)
    one, two = _one_and_two(monkeypatch, used,
                            lambda: run_out(cars, state, mu, params, brake, **wheels))
    assert one.at_rest.all()
    _identical(one, two)


def test_long_paths_rerun_bit_identical_in_two_threads(monkeypatch: pytest.MonkeyPatch,
                                                       used: list[int]) -> None:
    """More path columns than the first pass holds (the long run-outs run again) and a time
    limit that stops some vehicles while they move; pairs too."""
    cars, state, mu, brake, _ = _draw(5, 60)
    brake[:30] = 0.0
    params = RunoutParams(dt=0.01, path_interval=0.01, max_time=2.0)
    one, two = _one_and_two(monkeypatch, used, lambda: run_out(cars, state, mu, params, brake))
    assert (~one.at_rest).any() and one.path.shape[1] > 64
    _identical(one, two)
    used.clear()
    s1, s2 = (RunoutState(*(a[sl] for a in state)) for sl in (slice(0, 30), slice(30, None)))
    v1, v2 = cars.take(np.arange(30)), cars.take(np.arange(30, 60))
    one, two = _one_and_two(monkeypatch, used, lambda: run_out_pair(
        v1, v2, s1, s2, mu[:30], params, brake[:30], brake[30:]))
    _identical(one, two)


@pytest.fixture(scope="module")
def batch() -> CaseBatch:
    """Generated cases of every accident type with random post-impact wheel inputs."""
    return with_random_wheel_inputs(cases_of_every_type(5, seed=41, near_miss_share=0.1),
                                    13)


def test_every_accident_type_is_bit_identical_in_two_threads(
        batch: CaseBatch, monkeypatch: pytest.MonkeyPatch, used: list[int]) -> None:
    """The product path: simulate_cases, whose pair run-out checks secondary collisions."""
    one, two = _one_and_two(monkeypatch, used, lambda: simulate_cases(batch))
    assert np.isfinite(one.runout.rest_x).any()
    _identical(one, two)


def test_launches_from_several_python_threads(monkeypatch: pytest.MonkeyPatch,
                                              used: list[int]) -> None:
    """Four Python threads run the run-out at once with VFS_THREADS=2 (dask's threaded
    scheduler does): one threaded launch at a time, the others in one thread each; no crash
    of numba's workqueue layer, no hang, every result as in one thread."""
    draws = [_draw(seed, 120) for seed in (21, 22, 23, 24)]

    def run(d: tuple) -> Any:
        cars, state, mu, brake, wheels = d
        return run_out(cars, state, mu, None, brake, **wheels)

    monkeypatch.setenv(THREADS_VARIABLE, "1")
    ref = [run(d) for d in draws]
    monkeypatch.setenv(THREADS_VARIABLE, "2")
    with ThreadPoolExecutor(4) as pool:
        for _ in range(3):
            got = list(pool.map(run, draws))
            for a, b in zip(ref, got, strict=True):
                _identical(a, b)
    assert 2 in used


def test_a_bad_setting_is_refused_at_the_launch(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ENV_SWITCH, "1")
    monkeypatch.setenv(THREADS_VARIABLE, "0")
    cars, state, mu, brake, _ = _draw(3, 4)
    with pytest.raises(SettingsError, match=THREADS_VARIABLE):
        run_out(cars, state, mu, None, brake)


_WORKQUEUE_RUN = """
import os
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from tests.physics.test_core_runout import _draw
from vfs.physics.runout import run_out

draws = [_draw(seed, 120) for seed in (21, 22, 23, 24)]
run = lambda d: run_out(d[0], d[1], d[2], None, d[3], **d[4])
os.environ["VFS_THREADS"] = "1"
ref = [run(d) for d in draws]
os.environ["VFS_THREADS"] = "2"
with ThreadPoolExecutor(4) as pool:
    for _ in range(3):
        for a, b in zip(ref, pool.map(run, draws), strict=True):
            assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))
print(numba.threading_layer())
"""


def test_launches_from_several_python_threads_on_numbas_workqueue_layer() -> None:
    """The same on numba's own "workqueue" layer (the default where no OpenMP or TBB runtime
    is found; this machine may pick OpenMP): it aborts the whole process when two threads
    enter it at once, so this runs in a child process."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue", VFS_COMPILED="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(root),
                                                        os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-c", _WORKQUEUE_RUN], cwd=root, env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.split()[-1] == "workqueue"
