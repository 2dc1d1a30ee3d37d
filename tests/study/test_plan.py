"""The task plan of a study (:mod:`vfs.study.plan`) and results independent of it.

Invariants: every chunk to do is run exactly once per runner (baseline and each
system), a task runs consecutive chunks of the study's order and at most
``task_cases`` cases (at least one chunk), tasks are submitted longest first;
list scheduling against its closed forms.  The plan may change only the CPU
time, never the runs: a study run in another order, on another number of
planned workers, equals the serial one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vfs.physics.precrash import PrecrashParams
from vfs.physics.runout import RunoutParams
from vfs.simulation import SimulationParams
from vfs.study import (
    EXECUTORS,
    ExecutorOptions,
    register_executor,
    run_study,
    run_task,
)
from vfs.study.plan import (
    AEB_COST,
    BASELINE_COST,
    LAST_MOMENT_COST,
    TaskCost,
    plan_tasks,
    runner_cost,
    schedule,
)
from vfs.study.tasks import RunTask

COSTS = (BASELINE_COST, AEB_COST, LAST_MOMENT_COST)
FAST = SimulationParams(precrash=PrecrashParams(dt=0.02, extra_time=1.0, contact_tolerance=0.001),
                        runout=RunoutParams(dt=0.025))


def _check_plan(todo: Sequence[int], sizes: Sequence[int], runners: int, workers: int,
                chunk_size: int, task_cases: int) -> None:
    costs = COSTS[:runners]
    plan = plan_tasks(todo, sizes, costs, workers, chunk_size, task_cases)
    at = dict(zip(todo, sizes, strict=True))
    position = {k: i for i, k in enumerate(todo)}
    for j in range(runners):
        mine = sorted((t for t in plan if t.system_index == j), key=lambda t: position[t.chunks[0]])
        assert [k for t in mine for k in t.chunks] == list(todo)  # each chunk once, in order
    for t in plan:
        idx = [position[k] for k in t.chunks]
        assert idx == list(range(idx[0], idx[0] + len(idx)))  # consecutive in the study
        assert t.cases == sum(at[k] for k in t.chunks)
        assert len(t.chunks) == 1 or t.cases <= max(task_cases, chunk_size)
        assert t.cost == pytest.approx(costs[t.system_index].of(t.cases))
    if len(plan) <= 4 * workers and workers > 1:
        assert all(a.cost >= b.cost for a, b in zip(plan, plan[1:], strict=False))


@pytest.mark.parametrize(("todo", "size", "task_cases", "runners", "workers"), [
    (list(range(15)), 200, 2000, 3, 1), (list(range(15)), 200, 2000, 3, 14),
    ([1, 4, 5, 9], 100, 250, 2, 1), ([0], 200, 50, 3, 8), (list(range(40)), 50, 10_000, 3, 4),
    (list(range(50)), 200, 5000, 3, 16), (list(range(500)), 200, 5000, 3, 16),
])
def test_plan_covers_every_chunk_once_per_runner(todo: list[int], size: int, task_cases: int,
                                                 runners: int, workers: int) -> None:
    sizes = [size] * len(todo)
    sizes[-1] = max(1, size // 3)  # the last chunk of a study is short
    _check_plan(todo, sizes, runners, workers, size, task_cases)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 60), size=st.integers(1, 300), task_cases=st.integers(1, 3000),
       runners=st.integers(1, 3), workers=st.integers(1, 20), skip=st.integers(1, 3))
def test_plan_invariants_hold_for_any_study(n: int, size: int, task_cases: int, runners: int,
                                            workers: int, skip: int) -> None:
    todo = list(range(0, n * skip, skip))  # chunks left to do after a resume
    _check_plan(todo, [size] * n, runners, workers, size, task_cases)


def test_one_worker_runs_groups_of_task_cases_group_by_group() -> None:
    plan = plan_tasks(list(range(7)), [100] * 7, COSTS, 1, 100, 300)
    assert [(t.system_index, t.chunks) for t in plan] == [
        (j, g) for g in ((0, 1, 2), (3, 4, 5), (6,)) for j in range(3)]


def test_parallel_plan_gives_costly_runners_smaller_tasks() -> None:
    plan = plan_tasks(list(range(50)), [200] * 50, COSTS, 16, 200, 5000)
    largest = {j: max(t.cases for t in plan if t.system_index == j) for j in range(3)}
    assert largest[2] < largest[1] <= largest[0]
    # at least as many tasks as workers, so that none stays idle
    assert len(plan) >= 16


def test_schedule_against_closed_forms() -> None:
    # m equal tasks on W workers: ceil(m / W) rounds
    assert schedule([2.0] * 10, 4) == 6.0
    assert schedule([5.0, 1.0, 1.0, 1.0, 1.0, 1.0], 2) == 5.0
    # one worker: the sum; more workers than tasks: the largest
    assert schedule([3.0, 1.5, 2.0], 1) == 6.5
    assert schedule([3.0, 1.5, 2.0], 8) == 3.0


def test_runner_cost_of_systems() -> None:
    from vfs.adas import get_system

    assert runner_cost(None) == BASELINE_COST
    assert runner_cost(get_system("ideal")) == LAST_MOMENT_COST
    assert runner_cost(get_system("three-stage")) == AEB_COST
    with pytest.raises(Exception, match="TaskCost"):
        TaskCost(0.0, 1.0)


def _reversed(tasks: Sequence[RunTask], on_result, options: ExecutorOptions) -> None:  # noqa: ANN001
    """An executor that runs the tasks last first, in this process."""
    for task in reversed(list(tasks)):
        on_result(task, run_task(task))


def test_results_do_not_depend_on_plan_nor_order(tmp_path) -> None:  # noqa: ANN001
    if "reversed-test" not in EXECUTORS:
        register_executor("reversed-test", _reversed)
    common = dict(where="case_id <= 60", chunk_size=10, params=FAST, progress=False,
                  systems="three-stage,ideal")
    serial = run_study("default", out=tmp_path / "serial", engine="serial", **common)
    planned = run_study("default", out=tmp_path / "planned", engine="reversed-test", workers=5,
                        **common)
    assert isinstance(serial.table, pd.DataFrame) and isinstance(planned.table, pd.DataFrame)
    assert serial.table.equals(planned.table)
    # the data hash, computed while the workers ran, is the serial study's
    assert planned.manifest["data_hash"] == serial.manifest["data_hash"] != ""
    assert np.unique(planned.table["case_id"]).size * 3 == len(planned.table)


def test_validation_refuses_invalid_data_before_any_task(tmp_path) -> None:  # noqa: ANN001
    """With workers too the client validates before any task starts (issue 41: a record in
    milliseconds validated while the workers simulated it ran for ever); nothing is written."""
    from vfs.database import Database, open_database, save_database
    from vfs.errors import DataError

    if "reversed-test" not in EXECUTORS:
        register_executor("reversed-test", _reversed)
    db = open_database("default", where="case_id <= 30")
    bad = db.participants.copy()
    bad.loc[bad["case_id"] == 25, "mass"] = -1.0
    folder = save_database(Database(db.cases, bad, db.trajectories, db.reconstruction,
                                    meta=db.meta), tmp_path / "bad", validate=False)
    out = tmp_path / "study"
    with pytest.raises(DataError, match=r"case_id 25.*mass|mass.*case_id 25"):
        run_study(folder, "three-stage", out, engine="reversed-test", workers=2, chunk_size=10,
                  params=FAST, progress=False)
    assert not out.exists()  # refused before the folder: the fixed rerun is not blocked


def test_workers_get_single_threaded_pools_unless_the_user_set_them(monkeypatch) -> None:  # noqa: ANN001
    import os

    from vfs.blas import WORKER_THREAD_VARIABLES, single_threaded_workers

    for name in WORKER_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    with single_threaded_workers():
        inside = {name: os.environ.get(name) for name in WORKER_THREAD_VARIABLES}
    assert inside["OMP_NUM_THREADS"] == "3"  # the user's setting stays
    assert all(v == "1" for k, v in inside.items() if k != "OMP_NUM_THREADS")
    # this process's environment is as before
    assert os.environ.get("OMP_NUM_THREADS") == "3"
    assert all(name not in os.environ for name in WORKER_THREAD_VARIABLES
               if name != "OMP_NUM_THREADS")


def test_chunks_assembled_at_once_equal_chunks_assembled_alone() -> None:
    from vfs.study import assemble_chunk
    from vfs.study.tasks import assemble_chunks

    common = dict(system=None, db="default", db_format="parquet", batch=None, equip="both",
                  seed=1, params=FAST, impact_parameters="reconstruction")
    tasks = [RunTask(chunk=k, case_ids=np.arange(1 + 6 * k, 7 + 6 * k), system_index=0,
                     **common) for k in range(3)]
    runs = [run_task(t) for t in tasks]
    chunks = [[r, r.assign(system="again")] for r in runs]
    together = assemble_chunks(chunks)
    assert len(together) == 3
    for parts, table in zip(chunks, together, strict=True):
        assert assemble_chunk(parts).equals(table)
