r"""Estimated wall time of ``vfs study`` on W workers: the task plans list-scheduled.

An **estimate**, for a machine with fewer cores than the workers asked about:
the CPU time of a task of each runner (baseline, ``three-stage``, ``ideal``) is
measured here at two sizes on a generated database and fitted as a fixed part
plus a part per case; the client's serial parts (interpreter and imports,
validation and hash of the selection, writing ``runs.parquet``) are measured
per case too.  Then the tasks of a study of ``--cases`` cases are planned as
main d77c8ce planned them (groups of consecutive chunks shrunk so that every
worker gets two tasks, every group run by every runner, group by group) and as
:func:`vfs.study.plan.plan_tasks` plans them, and list-scheduled in submission
order onto W workers (each task to the worker free first, as a process pool
does).  Estimated wall = client's serial part before the tasks + makespan +
the chunk files completed by the last tasks + the end (combine, ``runs.parquet``);
speed-up against the serial plan on one worker.  What it leaves out: memory bandwidth and clock
(turbo) of W busy cores, hyper-threads, the startup of the workers, and the
spread of the real task costs around the fit (the plan allows 25 %).

::

    python benchmarks/schedule_estimate.py --cases 10000 --workers 2,4,8,14,16 \
        --out docs/figures
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

import pandas as pd

from vfs.bench.study import generated_database
from vfs.simulation import SimulationParams
from vfs.study.inputs import streamed_data_hash, study_input, validate_selection
from vfs.study.plan import plan_tasks, runner_cost, schedule, task_groups
from vfs.study.systems import resolve_systems
from vfs.study.tasks import RunTask, run_task

SYSTEMS = ["three-stage", "ideal"]
CHUNK = 200
TASK_CASES = 5000
#: CPU time of ``vfs study --help`` (interpreter, imports, parser) [s], docs/performance.md.
STARTUP_S = 0.95


def measure(db: Path, small: int, large: int) -> dict[str, Any]:
    """Fitted task costs [s] per runner and the client's costs per case [s]."""
    sel = study_input(str(db), None, validate=False)
    ids = sel.case_ids
    runners = [None, *resolve_systems(SYSTEMS, None)]
    fits = []
    for j, system in enumerate(runners):
        xs, ys = [], []
        for n in (small, large):
            parts = tuple((k, CHUNK) for k in range(n // CHUNK))
            task = RunTask(chunk=0, case_ids=ids[:n], system_index=j, system=system,
                           db=sel.reference, db_format=sel.fmt, batch=None, equip="both", seed=0,
                           params=SimulationParams(), impact_parameters="reconstruction",
                           group=parts if len(parts) > 1 else ())
            t0 = time.process_time()
            run_task(task)
            xs.append(n)
            ys.append(time.process_time() - t0)
        per_case = (ys[1] - ys[0]) / (xs[1] - xs[0])
        fits.append({"per_task_s": ys[0] - per_case * xs[0], "per_case_s": per_case,
                     "measured": list(zip(xs, ys, strict=True))})
    tail = _writing_costs(db)
    t0 = time.process_time()
    validate_selection(sel)
    validation = (time.process_time() - t0) / ids.size
    t0 = time.process_time()
    streamed_data_hash(sel.folder, ids)
    hashing = (time.process_time() - t0) / ids.size
    return {"tasks": fits, "validation_s_per_case": validation, "hash_s_per_case": hashing,
            **tail}


def _writing_costs(db: Path) -> dict[str, float]:
    """Client CPU [s] per chunk file (assembled and written) and per case for the end.

    The end: chunk files combined, ``runs.parquet`` written and read back; both
    from a serial study of ``db`` (the functions :mod:`vfs.study.run` calls, timed).
    """
    import vfs.study.run as run_module

    spent = {"chunk": 0.0, "chunks": 0, "end": 0.0}
    originals = (run_module.assemble_chunks, run_module.write_table,
                 run_module.combine_chunks)
    assemble, write, combine = originals

    def timed(fn: Any, key: str) -> Any:
        def call(*args: Any) -> Any:
            t0 = time.process_time()
            out = fn(*args)
            chunk_file = key == "chunk" or (key == "write" and "chunk_" in str(args[0]))
            spent["chunk" if chunk_file else "end"] += time.process_time() - t0
            spent["chunks"] += int(key == "write" and chunk_file)
            return out
        return call

    run_module.assemble_chunks = timed(assemble, "chunk")
    run_module.write_table = timed(write, "write")
    run_module.combine_chunks = timed(combine, "end")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            spent["end"] = 0.0
            result = run_module.run_study(str(db), ",".join(SYSTEMS), Path(tmp) / "s",
                                          engine="serial", progress=False)
            t0 = time.process_time()
            pd.read_parquet(Path(tmp) / "s" / "runs.parquet")  # the study reads it back
            spent["end"] += time.process_time() - t0
            n = len(result.table) // (len(SYSTEMS) + 1)
    finally:
        run_module.assemble_chunks, run_module.write_table, run_module.combine_chunks = originals
    # "end" also holds cases.parquet, written before the tasks (small)
    return {"chunk_file_s": spent["chunk"] / max(1, spent["chunks"]),
            "end_s_per_case": spent["end"] / max(1, n)}


def _old_groups(todo: list[int], runners: int, workers: int) -> list[list[int]]:
    """Main d77c8ce's ``task_groups``: at least 2 workers / runners groups."""
    per_task = max(1, TASK_CASES // CHUNK)
    wanted = -(-2 * workers // runners) if workers > 1 else 1
    per_task = max(1, min(per_task, len(todo) // max(1, wanted)))
    return [todo[i:i + per_task] for i in range(0, len(todo), per_task)]


def estimate(costs: dict[str, Any], cases: int, workers: list[int]) -> list[dict[str, Any]]:
    """Estimated wall [s] of the old and the new plan on each worker count."""
    fits = costs["tasks"]
    n_chunks = -(-cases // CHUNK)
    sizes = [CHUNK] * n_chunks
    sizes[-1] = cases - CHUNK * (n_chunks - 1)
    todo = list(range(n_chunks))

    def cost(j: int, n: int) -> float:
        return fits[j]["per_task_s"] + fits[j]["per_case_s"] * n

    client_old = STARTUP_S + cases * (costs["validation_s_per_case"] + costs["hash_s_per_case"])
    client_new = STARTUP_S  # validation and hash overlapped with the tasks
    end = cases * costs["end_s_per_case"]
    serial_tasks = [cost(j, sum(sizes[k] for k in g))
                    for g in task_groups(todo, CHUNK, TASK_CASES) for j in range(3)]
    serial = client_old + sum(serial_tasks) + end + n_chunks * costs["chunk_file_s"]
    runners = [None, *resolve_systems(SYSTEMS, None)]
    model = [runner_cost(r) for r in runners]
    rows = []
    for w in workers:
        old = [cost(j, sum(sizes[k] for k in g)) for g in _old_groups(todo, 3, w)
               for j in range(3)]
        plan = plan_tasks(todo, sizes, model, w, CHUNK, TASK_CASES)
        new = [cost(t.system_index, t.cases) for t in plan]
        # after the last task: the chunk files it completes (main: its group's; the plan:
        # all of them, every runner ends near the makespan), then the end
        last_group = _old_groups(todo, 3, w)[-1]
        wall_old = client_old + schedule(old, w) + len(last_group) * costs["chunk_file_s"] + end
        wall_new = client_new + schedule(new, w) + n_chunks * costs["chunk_file_s"] + end
        rows.append({"workers": w, "old_tasks": len(old), "old_cpu_s": sum(old),
                     "old_wall_s": wall_old, "old_speedup": serial / wall_old,
                     "new_tasks": len(new), "new_cpu_s": sum(new), "new_wall_s": wall_new,
                     "new_speedup": serial / wall_new})
    return [{"workers": 1, "serial_wall_s": serial, "serial_tasks": len(serial_tasks)}, *rows]


def main() -> None:
    """Measure, estimate, print the table (and write it with --out)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=10_000)
    ap.add_argument("--workers", default="2,4,8,14,16")
    ap.add_argument("--measure-cases", type=int, default=1000,
                    help="cases of the generated database the costs are measured on")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        db = generated_database(Path(tmp) / "db", args.measure_cases)
        costs = measure(db, CHUNK, args.measure_cases)
    rows = estimate(costs, args.cases, [int(w) for w in args.workers.split(",")])
    print(json.dumps(costs, indent=1))
    print(f"serial: {rows[0]['serial_wall_s']:.1f} s ({rows[0]['serial_tasks']} tasks)")
    print("workers  main: tasks  CPU s  wall s  speed-up | plan: tasks  CPU s  wall s  speed-up")
    for r in rows[1:]:
        print(f"{r['workers']:7d}  {r['old_tasks']:11d} {r['old_cpu_s']:6.1f} "
              f"{r['old_wall_s']:7.1f} {r['old_speedup']:8.2f}x | {r['new_tasks']:11d} "
              f"{r['new_cpu_s']:6.1f} {r['new_wall_s']:7.1f} {r['new_speedup']:8.2f}x")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "schedule_estimate.json").write_text(json.dumps(
            {"cases": args.cases, "costs": costs, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
