"""Where the CPU time of `vfs bench study` goes per case-run, and the throughput that the
compiled kernels alone would allow at the 10 ms pre-crash grid (issue 37's first row).

Runs the benchmark study's three runs (baseline, three-stage, ideal; both vehicles
equipped) in this process on the study benchmark's database (3,000 generated cases,
seed 11, :func:`vfs.bench.study.generated_database`), each once to warm the kernels and
then measured, with one BLAS thread as the command line has.  Every compiled kernel call is
timed (CPU) and counted: the pre-crash replay (row-steps from its end steps), the step of
the controlled runs (rows per call), the AEB measurement kernels, the run-out (vehicle
steps).  "Python" is the run's CPU time outside the kernels.  Output:
benchmarks/results/core_37_floor.json and .txt.  Run from the repository root:
``VFS_THREADS=1 python benchmarks/core_37_floor.py`` (the run-out in one thread, so that
its CPU time is per core).
"""
import json
import os
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import vfs.adas.compiled as aeb_kernels
import vfs.physics.core as core
import vfs.physics.core_runout as core_runout
from vfs.adas import load_system
from vfs.adas.systems import builtin_definition
from vfs.bench.study import generated_database
from vfs.blas import single_threaded_blas
from vfs.database import load_database
from vfs.simulation import CaseBatch, SimulationParams
from vfs.study.tasks import run_batch

N_CASES = 3000
OUT = Path(__file__).resolve().parent / "results"

cpu: dict[str, float] = defaultdict(float)
calls: dict[str, int] = defaultdict(int)
units: dict[str, int] = defaultdict(int)


def timed(module, label_of):
    """Wrap ``module.run_kernel``: CPU time and work units per kernel label."""
    orig = module.run_kernel

    def wrapper(kernel, name, *args):
        c0 = time.process_time()
        out = orig(kernel, name, *args)
        label = label_of(name)
        cpu[label] += time.process_time() - c0
        calls[label] += 1
        if name == "step of the pre-crash core":
            units[label] += int(args[6].shape[0])  # running rows this step
        elif name == "replay of the pre-crash core":
            end_k, first = args[13][:, core._END_K], args[7]
            units[label] += int(np.sum(end_k - first + 1))  # row-steps
        elif name.endswith("measurement"):
            units[label] += int(args[0].shape[1])  # egos measured
        return out

    module.run_kernel = wrapper


timed(core, lambda name: "pre-crash replay" if name.startswith("replay") else "pre-crash step")
timed(aeb_kernels, lambda name: "AEB kernels")
orig_rest = core_runout.run_to_rest


def rest_wrapper(par, state, consts, max_steps, per_sample, lt, record, pairs):
    """The run-out kernel's entry, timed (CPU) and its vehicle-steps counted."""
    c0 = time.process_time()
    out = orig_rest(par, state, consts, max_steps, per_sample, lt, record, pairs)
    cpu["run-out"] += time.process_time() - c0
    calls["run-out"] += 1
    units["run-out"] += int(np.sum(out.steps))  # vehicle-steps
    return out


core_runout.run_to_rest = rest_wrapper


def main() -> None:
    """Run the three runs twice each (warm-up, measured) and write the records."""
    with tempfile.TemporaryDirectory() as tmp, single_threaded_blas():
        db = load_database(generated_database(Path(tmp) / "db", N_CASES))
        batch = CaseBatch.from_database(db)
        equipped = np.ones((batch.size, 2), dtype=bool)
        runs = {"baseline": None,
                **{name: load_system(builtin_definition(name))
                   for name in ("three-stage", "ideal")}}
        report: dict[str, dict] = {}
        for label, system in runs.items():
            for _warm_then_measured in range(2):
                cpu.clear(), calls.clear(), units.clear()
                c0 = time.process_time()
                run_batch(batch, system, equipped, SimulationParams(),
                          np.random.default_rng(1))
                total = time.process_time() - c0
            kernels = {k: {"cpu_s": cpu[k], "calls": calls[k], "units": units[k]}
                       for k in cpu}
            report[label] = {"cpu_s": total, "kernels": kernels,
                             "python_s": total - sum(cpu.values())}
    case_runs = N_CASES * len(runs)
    kernel_s = sum(sum(k["cpu_s"] for k in r["kernels"].values()) for r in report.values())
    total_s = sum(r["cpu_s"] for r in report.values())
    rec = {"cases": N_CASES, "case_runs": case_runs, "runs": report,
           "simulation_cpu_s": total_s, "kernel_cpu_s": kernel_s,
           "case_runs_per_s_simulation": case_runs / total_s,
           "case_runs_per_s_kernels_only": case_runs / kernel_s,
           "load_average": os.getloadavg()[0],
           "vfs_threads": os.environ.get("VFS_THREADS", "")}
    OUT.mkdir(exist_ok=True)
    (OUT / "core_37_floor.json").write_text(json.dumps(rec, indent=1) + "\n")
    lines = [f"# benchmarks/core_37_floor.py: {N_CASES} generated cases (seed 11), both "
             f"vehicles equipped, warm kernels, CPU time, load average {rec['load_average']:.2f}, "
             f"VFS_THREADS={rec['vfs_threads'] or '(unset)'}"]
    per = {"pre-crash replay": "row-step", "pre-crash step": "row-step",
           "AEB kernels": "ego", "run-out": "vehicle-step"}
    for label, r in report.items():
        lines.append(f"{label}: {r['cpu_s']:.2f} s CPU, Python outside the kernels "
                     f"{r['python_s']:.2f} s")
        for k, v in r["kernels"].items():
            each = 1e9 * v["cpu_s"] / v["units"] if v["units"] else float("nan")
            lines.append(f"  {k}: {v['cpu_s']:.3f} s, {v['calls']} calls, {v['units']:,} "
                         f"{per[k]}s, {each:.0f} ns per {per[k]}")
    lines.append(f"simulation of {case_runs} case-runs: {total_s:.2f} s CPU "
                 f"({rec['case_runs_per_s_simulation']:.0f} case-runs/s); kernels alone "
                 f"{kernel_s:.2f} s ({rec['case_runs_per_s_kernels_only']:.0f} case-runs/s)")
    (OUT / "core_37_floor.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
