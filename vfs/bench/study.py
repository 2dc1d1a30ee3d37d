"""End-to-end benchmarks of the jobs users run: ``vfs study`` and ``vfs diagnose``.

Unlike the kernel benchmarks (:mod:`vfs.bench.kernels`), these run the job
as a user does, on a generated database written to a temporary folder:

* ``study``: ``python -m vfs study --db FOLDER --systems three-stage,ideal
  --engine serial`` in a fresh interpreter (imports, parser, chunking,
  case loading, chunk files, ``runs.parquet`` and the manifest included),
  then the same study resumed after its last half of chunk files was
  deleted (the resume path: manifest check, chunks on disk kept);
* ``diagnose``: :func:`vfs.diagnosis.diagnose.diagnose` on the generated
  cases (in this process; the one call sits in :func:`run_diagnose`).

Figures are case-runs per second (a case run = one case simulated with one
system, the baseline included) of wall time and of CPU time (the CPU time
of the child process, which is what the job costs on a loaded machine).
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

#: Systems of the study benchmark (the README's quick start).
STUDY_SYSTEMS = "three-stage,ideal"


def generated_database(folder: Path, n_cases: int, seed: int = 11) -> Path:
    """Write a generated ``default``-preset database of ``n_cases`` cases to ``folder``."""
    from vfs.database import save_database
    from vfs.scenarios.generator import generate_database

    db, _ = generate_database("default", n_cases=n_cases, seed=seed)
    save_database(db, folder)
    return folder


def _child_cpu() -> float:
    """CPU time [s] (user + system) of the finished child processes so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_cli(argv: list[str]) -> tuple[float, float]:
    """Run ``python -m vfs ARGV`` in a fresh interpreter; (wall [s], CPU [s]).

    The child imports the same ``vfs`` as this process (it runs in the
    package's parent folder, which is also put on ``PYTHONPATH``); paths in
    ``argv`` should be absolute.
    """
    import vfs

    env = dict(os.environ)
    root = str(Path(vfs.__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("MPLBACKEND", "Agg")
    cpu0 = _child_cpu()
    t0 = time.perf_counter()
    # run in the package's parent folder: ``-m`` puts the working folder first on sys.path
    proc = subprocess.run([sys.executable, "-m", "vfs", *argv], env=env, cwd=root,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"vfs {' '.join(argv)} failed ({proc.returncode}): "
                           f"{proc.stderr.strip()[-2000:]}")
    return wall, _child_cpu() - cpu0


def bench_study(quick: bool) -> dict[str, Any]:
    """``vfs study`` end to end, one core (``--engine serial``): case-runs/s.

    3,000 generated cases (600 with ``quick``) with the systems
    :data:`STUDY_SYSTEMS` (3 runs per case), then a resume of the last half
    of the chunks.
    """
    n = 600 if quick else 3_000
    runs_per_case = 1 + len(STUDY_SYSTEMS.split(","))
    tmp = Path(tempfile.mkdtemp(prefix="vfs-bench-study-"))
    try:
        db = generated_database(tmp / "db", n)
        out = tmp / "study"
        argv = ["study", "--db", str(db), "--systems", STUDY_SYSTEMS, "--engine", "serial",
                "--out", str(out), "--overwrite"]
        wall, cpu = run_cli(argv)
        chunks = sorted((out / "chunks").glob("chunk_*.parquet"))
        redo = chunks[len(chunks) // 2:]
        for path in redo:
            path.unlink()
        (out / "runs.parquet").unlink()
        redo_cases = _cases_in(out, len(chunks), len(redo), n)
        resume_wall, resume_cpu = run_cli([a for a in argv if a != "--overwrite"]
                                          + ["--resume"])
        hello_wall, hello_cpu = run_cli(["study", "--help"])
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    case_runs = n * runs_per_case
    return {
        "cases": n, "systems": STUDY_SYSTEMS, "case_runs": case_runs,
        "chunks": len(chunks),
        "wall_s": wall, "cpu_s": cpu,
        "case_runs_per_s_wall": case_runs / wall, "case_runs_per_s_cpu": case_runs / cpu,
        "resumed_cases": redo_cases, "resume_wall_s": resume_wall, "resume_cpu_s": resume_cpu,
        "resume_case_runs_per_s_cpu": redo_cases * runs_per_case / resume_cpu,
        "startup_cpu_s": hello_cpu, "startup_wall_s": hello_wall,
        "load_average_1min": os.getloadavg()[0],
    }


def first_compiled_run() -> None:
    """The first runs of a process: a replay (the compiled per-case loop), a run with a
    controller (the compiled step) and the run-outs of both kinds (pairs, single vehicles),
    on 20 synthetic cases; what a first ``vfs study`` compiles (or loads from numba's cache).
    """
    import numpy as np

    from vfs.physics.precrash import ScheduledBraking, simulate_precrash
    from vfs.physics.runout import RunoutState, run_out, run_out_pair
    from vfs.scenarios.random import synthetic_case_batch

    batch = synthetic_case_batch(20, np.random.default_rng(3))
    args = (batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction)
    simulate_precrash(*args)
    simulate_precrash(*args, controller=ScheduledBraking(np.full((20, 2), 4.0),
                                                         np.full((20, 2), 8.0)))
    state = RunoutState.from_arrays(0.0, 0.0, 0.0, np.linspace(1.0, 10.0, 20), 0.0, 0.5)
    run_out_pair(batch.vehicle1, batch.vehicle2, state, state._replace(y=state.y + 3.0), 0.8)
    run_out(batch.vehicle1, state, 0.8, paths=False)


def bench_warmup(quick: bool) -> dict[str, Any]:
    """Cold and warm start of the compiled core, CPU time of a fresh interpreter that runs
    :func:`first_compiled_run`: with an empty numba cache (``NUMBA_CACHE_DIR`` a new
    folder: the first run after install compiles), again with that cache filled (every
    later run), and on the numpy reference path (``VFS_COMPILED=0``: no numba at all).
    ``compile_cpu_s`` = cold - reference, ``cache_load_cpu_s`` = warm - reference.
    """
    tmp = Path(tempfile.mkdtemp(prefix="vfs-bench-warmup-"))
    code = "from vfs.bench.study import first_compiled_run; first_compiled_run()"
    try:
        cold = run_python(code, {"NUMBA_CACHE_DIR": str(tmp)})
        warm = run_python(code, {"NUMBA_CACHE_DIR": str(tmp)})
        ref = run_python(code, {"NUMBA_CACHE_DIR": str(tmp), "VFS_COMPILED": "0"})
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {
        "cold_wall_s": cold[0], "cold_cpu_s": cold[1], "warm_wall_s": warm[0],
        "warm_cpu_s": warm[1], "reference_cpu_s": ref[1],
        "compile_cpu_s": cold[1] - ref[1], "cache_load_cpu_s": warm[1] - ref[1],
        "load_average_1min": os.getloadavg()[0],
    }


def run_python(code: str, extra_env: dict[str, str]) -> tuple[float, float]:
    """Run ``python -c CODE`` in a fresh interpreter with ``extra_env``; (wall [s], CPU [s])
    (imports the same ``vfs`` as this process, as :func:`run_cli`).
    """
    import vfs

    env = dict(os.environ)
    env.update(extra_env)
    root = str(Path(vfs.__file__).resolve().parent.parent)
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    cpu0 = _child_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=root,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"python -c {code!r} failed ({proc.returncode}): "
                           f"{proc.stderr.strip()[-2000:]}")
    return wall, _child_cpu() - cpu0


def _cases_in(out: Path, n_chunks: int, n_redo: int, n_cases: int) -> int:
    """Cases of the last ``n_redo`` of ``n_chunks`` chunks of a study of ``n_cases``."""
    import json

    size = int(json.loads((out / "study.json").read_text())["chunk_size"])
    return n_cases - size * (n_chunks - n_redo)


def run_diagnose(db: Any, quick: bool) -> Any:
    """The diagnosis the benchmark times (:func:`vfs.diagnosis.diagnose.diagnose`).

    ``quick`` uses the settings of ``vfs diagnose --quick`` and no law search.
    """
    from vfs.diagnosis.diagnose import diagnose

    if quick:
        return diagnose(db, folds=3, grid_points=5, zoom_rounds=2, n_boot=500, laws=None)
    return diagnose(db, laws="all")


def bench_diagnose(quick: bool) -> dict[str, Any]:
    """Full diagnosis (identification, laws, stepwise) of 600 generated cases, one core;
    ``quick``: 120 cases, ``vfs diagnose --quick`` settings, no laws.
    """
    from vfs.database import open_database

    n = 120 if quick else 600
    tmp = Path(tempfile.mkdtemp(prefix="vfs-bench-diagnose-"))
    try:
        db = open_database(str(generated_database(tmp / "db", n)))
        cpu0 = time.process_time()
        t0 = time.perf_counter()
        diag = run_diagnose(db, quick)
        wall = time.perf_counter() - t0
        cpu = time.process_time() - cpu0
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    stats = getattr(diag, "stats", {}) or {}
    return {
        "cases": n, "settings": "quick, no laws" if quick else "full (laws, stepwise)",
        "wall_s": wall, "cpu_s": cpu,
        "variants": stats.get("variants"), "case_runs": stats.get("case_runs"),
        "load_average_1min": os.getloadavg()[0],
    }


__all__ = ["STUDY_SYSTEMS", "bench_diagnose", "bench_study", "bench_warmup",
           "first_compiled_run", "generated_database", "run_cli", "run_diagnose",
           "run_python"]
