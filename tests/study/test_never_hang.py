"""Never hang, never a traceback: the generated corruption and fault suite (issue 41).

Each bad input of :mod:`tests.study.faultsuite` must end with one clear line of the
expected class (CLEAR error or WARN warning naming the problem; OK for the plausible
control), within a time limit where a hang was possible; signals at random moments
must stop the study without a traceback, leave no process of its group behind and
leave a folder that ``--resume`` completes.  The CI size is small (VFS_SLOW_SCALE
0.2: three signals); ``benchmarks/fault_suite.py`` runs the whole suite with 50
random kills and writes its table to benchmarks/results/fault_suite.md.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.conftest import slow_scale
from tests.study.faultsuite import (
    DATABASE_EDITS,
    FAULTS,
    IMPACT_EDITS,
    BadInput,
    CliRun,
    edited_database,
    fault_run,
    impact_row,
    judge,
    run_cli,
    small_database,
)
from vfs.cli import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return small_database(tmp_path_factory.mktemp("never_hang") / "small")


def _in_process(capsys: pytest.CaptureFixture[str], argv: list[str]) -> CliRun:
    code = main(argv)
    out = capsys.readouterr()
    return CliRun(tuple(argv), code, out.out, out.err, 0.0, ())


@pytest.mark.parametrize("name", list(DATABASE_EDITS))
def test_each_bad_database_gives_its_line_in_the_study(small, tmp_path, capsys, name):
    edit, expect, words = DATABASE_EDITS[name]
    db = edited_database(small, tmp_path / "db", edit)
    where = [] if name == "text case ids" else ["--where", "case_id <= 6"]  # 6: a near miss
    argv = ["study", "--db", str(db), "--systems", "three-stage", "--engine", "serial",
            *where, "--out", str(tmp_path / "study")]
    bad = BadInput(name, tuple(argv), expect, words)
    assert judge(bad, _in_process(capsys, argv)) == expect


@pytest.mark.parametrize("name", list(IMPACT_EDITS))
def test_each_implausible_impact_table_gives_its_line(tmp_path, capsys, name):
    change, expect, words = IMPACT_EDITS[name]
    file = tmp_path / "in.csv"
    pd.DataFrame([impact_row(**change)]).to_csv(file, index=False)
    argv = ["impact", "--input", str(file), "--output", str(tmp_path / "out.parquet")]
    assert judge(BadInput(name, tuple(argv), expect, words), _in_process(capsys, argv)) == expect


def test_a_record_in_milliseconds_ends_fast_with_workers_and_the_fixed_rerun_runs(
        small, tmp_path, capsys):
    """The issue's hang: validation ran in a thread while the workers simulated the
    1,000 times longer records.  Now it ends within the limit, writes nothing, and the
    rerun with the fixed data at the same --out is not refused."""
    edit, _, words = DATABASE_EDITS["trajectory time in milliseconds"]
    db = edited_database(small, tmp_path / "db", edit)
    out = tmp_path / "study"
    argv = ["study", "--db", str(db), "--systems", "three-stage", "--engine", "process",
            "--workers", "2", "--where", "case_id <= 4", "--out", str(out)]
    run = run_cli(argv, cwd=ROOT, limit_s=120)
    assert judge(BadInput("ms", tuple(argv), "CLEAR", words), run) == "CLEAR", run.stderr
    assert not run.orphans and not out.exists()
    shutil.rmtree(db)
    shutil.copytree(small, db)  # the fix
    argv[argv.index("process")] = "serial"
    fixed = _in_process(capsys, argv)
    assert fixed.code == 0 and not fixed.traceback, fixed.stderr


def test_the_simulation_refuses_a_record_too_long_for_its_samples(small, tmp_path):
    """The worker's own guard: steps per case capped by the record's samples."""
    from vfs.database import load_database
    from vfs.errors import SimulationError
    from vfs.simulation import CaseBatch, simulate_cases

    edit = DATABASE_EDITS["trajectory time in milliseconds"][0]
    db = load_database(edited_database(small, tmp_path / "db", edit), where="case_id <= 2",
                       validate=False)
    with pytest.raises(SimulationError, match="time column in milliseconds"):
        simulate_cases(CaseBatch.from_database(db))
    good = load_database(small, where="case_id <= 2")
    assert simulate_cases(CaseBatch.from_database(good)).precrash.collided.shape == (2,)


def test_a_study_that_failed_before_its_first_chunk_does_not_block_the_rerun(small, tmp_path,
                                                                            capsys):
    out = tmp_path / "study"
    argv = ["study", "--db", str(small), "--systems", "three-stage", "--engine", "serial",
            "--where", "case_id <= 1", "--out", str(out)]
    assert _in_process(capsys, argv).code == 0
    manifest = json.loads((out / "study.json").read_text())
    for chunk in (out / "chunks").glob("*.parquet"):
        chunk.unlink()
    (out / "runs.parquet").unlink()
    manifest.update(status="failed", error="DataError: ...")
    (out / "study.json").write_text(json.dumps(manifest))
    again = _in_process(capsys, argv)  # neither --resume nor --overwrite
    assert again.code == 0, again.stderr
    manifest["status"] = "complete"  # a finished study is still protected
    (out / "study.json").write_text(json.dumps(manifest))
    refused = _in_process(capsys, argv)
    assert refused.code == 2 and "already holds a study" in refused.stderr


def _signal_plan() -> list[tuple[str, float]]:
    rng = np.random.default_rng(41)
    n = max(3, int(round(15 * slow_scale())))
    names = ["SIGINT (Ctrl-C, group)", "SIGTERM (kill PID)", "SIGKILL (kill -9 PID)",
             "SIGTERM (group)"]
    return [(names[k % len(names)], float(rng.uniform(0.5, 6.0))) for k in range(n)]


@pytest.mark.parametrize(("fault", "at_s"), _signal_plan())
def test_a_signal_at_a_random_moment_stops_the_study_cleanly(tmp_path, fault, at_s):
    assert fault in FAULTS
    res = fault_run(fault, at_s, tmp_path / "study", cwd=ROOT, cases=40,
                    resume=fault.startswith("SIGINT"), limit_s=240)
    assert res.outcome == "CLEAN", (res.outcome, res.run.code, res.run.stderr[-3000:],
                                    res.run.orphans, res.resumed)
    expected = {"SIGINT": (130, 0), "SIGTERM": (143, 0), "SIGKILL": (-9, 0)}[fault.split()[0]]
    assert res.run.code in expected  # stopped, or finished before the signal
    if res.status == "interrupted":
        assert "--resume" in res.run.stderr


def test_impact_tables_stream_in_batches_with_the_whole_tables_result(tmp_path, capsys):
    from vfs.database.impact_table import solve_impact_file, solve_impact_table

    rng = np.random.default_rng(3)
    rows = [impact_row(case_id=i, vx1=float(rng.uniform(5, 20)), vy2=float(rng.uniform(3, 15)))
            for i in range(50)]
    df = pd.DataFrame(rows)
    whole = solve_impact_table(df)
    for suffix in (".csv", ".parquet"):
        src = tmp_path / f"in{suffix}"
        df.to_csv(src, index=False) if suffix == ".csv" else df.to_parquet(src, index=False)
        out = tmp_path / f"out{suffix}"
        counts = solve_impact_file(src, out, batch_rows=7)
        got = pd.read_csv(out) if suffix == ".csv" else pd.read_parquet(out)
        assert sum(counts.values()) == 50
        pd.testing.assert_frame_equal(got[whole.columns.drop("error")],
                                      whole.drop(columns="error"), check_dtype=False)
    df.loc[23, "m2"] = -1.0  # a bad row in the fourth batch: named with its file row
    df.to_csv(tmp_path / "bad.csv", index=False)
    code = main(["impact", "--input", str(tmp_path / "bad.csv"), "--output",
                 str(tmp_path / "bad-out.csv")])
    err = capsys.readouterr().err
    assert code == 2 and "row 23" in err and not (tmp_path / "bad-out.csv").exists()
