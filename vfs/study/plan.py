"""The task plan of a study: which chunks each system's tasks run, in what order.

A task (:class:`vfs.study.tasks.RunTask`) runs whole chunks of one system as one
vectorised batch.  Its CPU time is a fixed part (the ~1,000 pre-crash steps of
10 ms and the run-out steps, each paying the Python overhead of some 50-100
numpy calls whatever the batch size, and loading the cases) plus a part per
case; both depend on the system (:class:`TaskCost`).  Fewer, larger tasks cost
less in all; on W workers the tasks must also keep every worker busy to the
end.  :func:`plan_tasks`:

* one worker: tasks of up to ``task_cases`` cases, consecutive chunks, group by
  group (every chunk file is written as soon as its group is done);
* W workers: for each candidate size, every system's chunks are split into
  groups of equal estimated cost (an ``ideal`` task gets fewer cases than a
  baseline task), the tasks are list-scheduled longest first onto W workers
  (:func:`schedule`), and the plan with the smallest estimated makespan plus
  :data:`COST_UNCERTAINTY` of its largest task (the estimate's error shows in
  the last task to end) is kept.  Tasks are submitted in that order (longest
  processing time first); a study of many tasks per worker is ordered in
  blocks of chunks, longest first within a block, so the runs of a chunk
  finish near each other and the main process holds few incomplete chunks.

Each chunk keeps its own random stream, so the runs do not depend on the plan
(:mod:`vfs.study.run`); the plan only changes the CPU time and how well the
workers are used.
"""

from __future__ import annotations

import bisect
import heapq
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from vfs.errors import ParameterError


@dataclass(frozen=True)
class TaskCost:
    """Estimated CPU time of a task, in units of one baseline case run.

    Attributes
    ----------
    per_case : float
        CPU time per case [baseline case runs].
    per_task : float
        Fixed CPU time of a task whatever its size [baseline case runs].
    """

    per_case: float
    per_task: float

    def __post_init__(self) -> None:
        if not (self.per_case > 0 and self.per_task >= 0
                and math.isfinite(self.per_case) and math.isfinite(self.per_task)):
            raise ParameterError(f"TaskCost needs per_case > 0 and per_task >= 0, got "
                                 f"{self.per_case}, {self.per_task}")

    def of(self, cases: float) -> float:
        """Estimated CPU time of a task of ``cases`` cases [baseline case runs]."""
        return self.per_task + self.per_case * cases


# Measured on the 3,000-case generated database (one core, tasks of 200-2,000 cases):
# per case 0.87 ms (baseline), 1.56 ms (three-stage), 4.5 ms (ideal); per task 0.85 s,
# 1.3 s, 1.7 s.  Only the ratios matter.
#: Cost of the baseline runs (no system): the unit.
BASELINE_COST = TaskCost(1.0, 1000.0)
#: Cost of an AEB system (sensor cycle, TTC, stages).
AEB_COST = TaskCost(1.8, 1500.0)
#: Cost of an AEB with the last-moment rule (a braked-contact prediction every step).
LAST_MOMENT_COST = TaskCost(5.1, 2000.0)

#: Relative error of a task's estimated cost that the plan allows for: it adds this
#: share of the largest task to the estimated makespan.
COST_UNCERTAINTY = 0.25


def runner_cost(system: Any | None) -> TaskCost:
    """Estimated cost of a task of ``system`` (None: the baseline).

    A system may declare its own with an attribute ``task_cost``
    (:class:`TaskCost`); otherwise an AEB with ``last_moment`` gets
    :data:`LAST_MOMENT_COST` and any other system :data:`AEB_COST`.
    """
    if system is None:
        return BASELINE_COST
    declared = getattr(system, "task_cost", None)
    if isinstance(declared, TaskCost):
        return declared
    aeb = getattr(system, "aeb", None)
    if aeb is not None and bool(getattr(aeb, "last_moment", False)):
        return LAST_MOMENT_COST
    return AEB_COST


@dataclass(frozen=True)
class PlannedTask:
    """One task of the plan.

    Attributes
    ----------
    system_index : int
        0 for the baseline, 1.. for the systems.
    chunks : tuple of int
        Consecutive chunks to do, in order.
    cases : int
        Cases of those chunks.
    cost : float
        Estimated CPU time [baseline case runs].
    """

    system_index: int
    chunks: tuple[int, ...]
    cases: int
    cost: float


def schedule(costs: Sequence[float], workers: int) -> float:
    """Makespan of list scheduling ``costs`` in the given order onto ``workers``.

    Each task goes to the worker that becomes free first (what a process pool
    or a dask cluster does with tasks submitted in this order).
    """
    free = [0.0] * max(1, int(workers))
    for cost in costs:
        heapq.heappush(free, heapq.heappop(free) + float(cost))
    return max(free)


def _split(todo: Sequence[int], sizes: Sequence[int], groups: int) -> list[tuple[int, ...]]:
    """``todo`` in ``groups`` runs of consecutive entries of nearly equal cases."""
    groups = max(1, min(groups, len(todo)))
    ends = list(itertools.accumulate(sizes))  # cases up to and including each entry
    total = ends[-1]
    out: list[tuple[int, ...]] = []
    start = 0
    for g in range(1, groups + 1):
        goal = total * g / groups
        stop = bisect.bisect_left(ends, goal) + 1  # first entry reaching the goal, included
        if stop > start + 1 and goal - ends[stop - 2] < ends[stop - 1] - goal:
            stop -= 1  # the goal is nearer the end of the entry before
        stop = max(start + 1, min(stop, len(todo) - (groups - g)))
        out.append(tuple(todo[start:stop]))
        start = stop
    return out


def task_groups(todo: Sequence[int], chunk_size: int, task_cases: int) -> list[list[int]]:
    """Consecutive entries of ``todo`` in groups of at most ``task_cases`` cases
    (at least one chunk each): the tasks of one system on one worker.
    """
    per_task = max(1, task_cases // chunk_size)
    return [list(todo[i:i + per_task]) for i in range(0, len(todo), per_task)]


def _tasks(todo: Sequence[int], sizes: Sequence[int], j: int, groups: int,
           cost: TaskCost, cap: int) -> list[PlannedTask]:
    """Runner ``j``'s tasks: ``todo`` in ``groups`` (or more, to keep each within ``cap``
    cases unless a single chunk) runs of nearly equal cases.
    """
    at = dict(zip(todo, sizes, strict=True))
    while True:
        split = _split(todo, sizes, groups)
        cases = [sum(at[k] for k in group) for group in split]
        if groups >= len(todo) or all(n <= cap or len(g) == 1
                                      for g, n in zip(split, cases, strict=True)):
            break
        groups += 1
    return [PlannedTask(j, group, n, cost.of(n)) for group, n in zip(split, cases, strict=True)]


def plan_tasks(todo: Sequence[int], sizes: Sequence[int], costs: Sequence[TaskCost],
               workers: int, chunk_size: int, task_cases: int) -> list[PlannedTask]:
    """The tasks of the chunks ``todo`` for every runner, in submission order.

    Parameters
    ----------
    todo : sequence of int
        Chunks to do, in study order.
    sizes : sequence of int
        Cases of each chunk of ``todo``.
    costs : sequence of TaskCost
        One per runner (baseline first; :func:`runner_cost`).
    workers : int
        Parallel workers.
    chunk_size : int
        Cases per chunk of the study.
    task_cases : int
        Most cases of a task (at least one chunk).

    Returns
    -------
    list of PlannedTask
        Every chunk of ``todo`` exactly once per runner.
    """
    if len(sizes) != len(todo):
        raise ParameterError("plan_tasks: one size per chunk")
    if not todo:
        return []
    runners = range(len(costs))
    if workers <= 1:  # group by group, so that chunk files appear as the study goes
        at = dict(zip(todo, sizes, strict=True))
        plan = []
        for group in task_groups(todo, chunk_size, task_cases):
            n = sum(at[k] for k in group)
            plan += [PlannedTask(j, tuple(group), n, costs[j].of(n)) for j in runners]
        return plan
    n_chunks = len(todo)
    total = sum(sizes)
    # fewest groups a runner may have: tasks of at most task_cases cases
    fewest = min(n_chunks, max(1, -(-total // max(task_cases, max(sizes)))))
    best: tuple[float, int, list[PlannedTask]] | None = None
    # candidates: the costliest runner split into g groups, the others matched to its cost
    lead = max(runners, key=lambda j: costs[j].of(total))
    # at most about 200 candidates (a study of many thousand chunks)
    for g in range(fewest, n_chunks + 1, max(1, (n_chunks - fewest) // 200)):
        target = costs[lead].of(total / g)
        plan = []
        for j in runners:
            c = costs[j]
            share = c.per_case * total / max(target - c.per_task, c.per_case * total / n_chunks)
            plan += _tasks(todo, sizes, j, min(n_chunks, max(fewest, math.ceil(share - 1e-9))),
                           c, task_cases)
        plan.sort(key=lambda t: (-t.cost, t.system_index, t.chunks[0]))
        estimate = (schedule([t.cost for t in plan], workers)
                    + COST_UNCERTAINTY * max(t.cost for t in plan))
        if best is None or estimate < best[0] - 1e-9 * estimate:
            best = (estimate, g, plan)
        if len(plan) > 4 * workers * len(costs) and g > fewest:
            break  # ever more, smaller tasks only add their fixed costs
    if best is None:  # pragma: no cover - the range above is never empty
        raise ParameterError("plan_tasks: no plan")
    return _in_blocks(best[2], workers)


def _in_blocks(plan: list[PlannedTask], workers: int) -> list[PlannedTask]:
    """Longest first; with many tasks per worker, by blocks of chunks, longest first in each.

    A block holds about four tasks per worker; its runs of a chunk then finish
    near each other, so the main process keeps few incomplete chunks in memory.
    """
    per_block = 4 * workers
    if len(plan) <= per_block:
        return plan
    by_start = sorted(plan, key=lambda t: (t.chunks[0], t.system_index))
    blocks: dict[int, int] = {}
    for i, t in enumerate(by_start):
        blocks[id(t)] = i // per_block
    return sorted(plan, key=lambda t: (blocks[id(t)], -t.cost, t.system_index, t.chunks[0]))


__all__ = ["AEB_COST", "BASELINE_COST", "COST_UNCERTAINTY", "LAST_MOMENT_COST", "PlannedTask",
           "TaskCost", "plan_tasks", "runner_cost", "schedule", "task_groups"]
