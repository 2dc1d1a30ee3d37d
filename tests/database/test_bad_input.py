"""Corrupted inputs: each gives a clear error or warning, never a traceback or a silent result.

One small database (12 cases of the bundled one) is written once per session; every
test copies it, damages one thing, and runs the command line in-process
(``vfs.cli.main``), asserting the exit code, the class of the message (error naming
table, column and case, or warning) and that no traceback is printed.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from vfs.cli import main
from vfs.database import open_database, save_database

TABLES = ("cases", "participants", "trajectories", "reconstruction")


@pytest.fixture(scope="session")
def small_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("bad_input") / "small"
    save_database(open_database("default", where="case_id <= 12"), folder)
    return folder


def _copy(small_db: Path, tmp_path: Path, edit: Callable[[dict[str, pd.DataFrame]], None] | None
          = None) -> Path:
    """A copy of the small database with ``edit`` applied to its tables (file units)."""
    out = tmp_path / "db"
    shutil.copytree(small_db, out)
    if edit is not None:
        frames = {name: pq.read_table(out / f"{name}.parquet").to_pandas() for name in TABLES}
        edit(frames)
        for name, df in frames.items():
            pq.write_table(pa.Table.from_pandas(df, preserve_index=False), out / f"{name}.parquet")
    return out


def _cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    text = out.out + out.err
    assert "Traceback" not in text, text
    return code, text


def _study(capsys: pytest.CaptureFixture[str], db: Path, tmp_path: Path, *extra: str
           ) -> tuple[int, str]:
    return _cli(capsys, "study", "--db", str(db), "--systems", "three-stage",
                "--out", str(tmp_path / "study"), "--engine", "serial", *extra)


# ----------------------------------------------------------------------------
# File-level damage
# ----------------------------------------------------------------------------


def _truncate(file: Path) -> None:
    file.write_bytes(file.read_bytes()[: file.stat().st_size // 2])


def _zero(file: Path) -> None:
    file.write_bytes(b"")


def _random(file: Path) -> None:
    file.write_bytes(np.random.default_rng(0).bytes(4096))


def _csv_text(file: Path) -> None:
    file.write_text("case_id,participant\n1,1\n", encoding="utf-8")


@pytest.mark.parametrize("damage", [_truncate, _zero, _random, _csv_text])
@pytest.mark.parametrize("table", ["cases", "trajectories"])
def test_a_damaged_parquet_file_is_named(small_db, tmp_path, capsys, damage, table):
    db = _copy(small_db, tmp_path)
    damage(db / f"{table}.parquet")
    want = f"file {db / f'{table}.parquet'} is not a readable Parquet file"
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 1 and want in text
    code, text = _study(capsys, db, tmp_path)
    assert code == 2 and want in text
    assert "orphaned" not in text and "has no trajectory" not in text  # no consequences


# ----------------------------------------------------------------------------
# Case ids and orphaned rows
# ----------------------------------------------------------------------------


def _text_ids(frames: dict[str, pd.DataFrame]) -> None:
    for df in frames.values():
        df["case_id"] = [f"Fall-ü-{i}-事故" for i in df["case_id"]]


def _nan_id(frames: dict[str, pd.DataFrame]) -> None:
    cases = frames["cases"]
    cases["case_id"] = cases["case_id"].astype(float)
    cases.loc[2, "case_id"] = np.nan


@pytest.mark.parametrize(("edit", "message"), [
    (_text_ids, "'Fall-ü-1-事故' is not a number: case ids are integers"),
    (_nan_id, "column 'case_id', row 2: missing value (NaN)"),
])
def test_case_ids_that_are_not_integers_are_an_error(small_db, tmp_path, capsys, edit,
                                                     message):
    db = _copy(small_db, tmp_path, edit)
    for argv in (("db", "validate", str(db)),):
        code, text = _cli(capsys, *argv)
        assert code == 1 and message in text
    code, text = _study(capsys, db, tmp_path)
    assert code == 2 and "table 'cases'" in text and message in text


@pytest.mark.parametrize("table", ["participants", "reconstruction"])
def test_rows_of_a_case_not_in_cases_are_an_error_in_every_command(small_db, tmp_path, capsys,
                                                                   table):
    def orphan(frames: dict[str, pd.DataFrame]) -> None:
        extra = frames[table].iloc[:1].copy()
        extra["case_id"] = 999
        frames[table] = pd.concat([frames[table], extra])

    db = _copy(small_db, tmp_path, orphan)
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 1 and f"table '{table}', column 'case_id'" in text and "999" in text
    code, text = _study(capsys, db, tmp_path)
    assert code == 2 and f"table '{table}', column 'case_id', case_id 999: orphaned" in text
    code, text = _cli(capsys, "run-case", "--db", str(db), "--case", "1")
    assert code == 2 and "orphaned" in text


# ----------------------------------------------------------------------------
# Values impossible together (warnings; errors under --strict)
# ----------------------------------------------------------------------------


def _participant(frames: dict[str, pd.DataFrame], case: int, number: int, **values: object
                 ) -> None:
    df = frames["participants"]
    row = (df["case_id"] == case) & (df["participant"] == number)
    for key, value in values.items():
        df.loc[row, key] = value


def _heavy_car(frames):
    _participant(frames, 3, 1, mass=50_000.0, yaw_inertia=np.nan)


def _long_car(frames):
    _participant(frames, 3, 1, length=20.0, wheelbase=2.5, front_overhang=0.9,
                 cg_to_front_axle=1.2)


def _tiny_inertia(frames):
    _participant(frames, 3, 1, yaw_inertia=1.0)


def _pounds(frames):
    df = frames["participants"]
    half = df["case_id"] % 2 == 0
    df.loc[half, "mass"] = df.loc[half, "mass"] * 2.2046
    df["yaw_inertia"] = np.nan


def _moving_fixed(frames):
    _participant(frames, 4, 2, fixed_object=True)


def _on_path(frames):
    tr = frames["trajectories"]
    one = tr[(tr["case_id"] == 5) & (tr["participant"] == 1)]
    two = tr.index[(tr["case_id"] == 5) & (tr["participant"] == 2)]
    n = min(len(one), len(two))
    for col in ("x", "y", "yaw", "speed", "accel"):
        tr.loc[two[:n], col] = one[col].to_numpy()[:n]
    tr.loc[two[:n], "t"] = one["t"].to_numpy()[:n]
    frames["trajectories"] = tr.drop(index=two[n:])


def _pdof_radians(frames):
    rec = frames["reconstruction"]
    rec["pdof1"] = np.radians(rec["pdof1"])


def _poi_far(frames):
    rec = frames["reconstruction"]
    rec.loc[rec["case_id"] == 7, "poi_x"] += 500.0


def _accel_mismatch(frames):
    tr = frames["trajectories"]
    tr.loc[(tr["case_id"] == 7) & (tr["participant"] == 1), "accel"] = 8.0


@pytest.mark.parametrize(("edit", "table", "column", "case", "words"), [
    (_heavy_car, "participants", "mass", 3, "kg/m^2"),
    (_long_car, "participants", "wheelbase", 3, "of the length"),
    (_tiny_inertia, "participants", "yaw_inertia", 3, "x m L1 L2"),
    (_pounds, "participants", "mass", 2, "pounds"),
    (_moving_fixed, "participants", "fixed_object", 4, "fixed object but moves"),
    (_on_path, "trajectories", "x", 5, "overlap at the first sample"),
    (_pdof_radians, "reconstruction", "pdof1", None, "read as radians"),
    (_poi_far, "reconstruction", "poi_x", 7, "outside both outlines"),
    (_accel_mismatch, "trajectories", "accel", 7, "differs from d speed / dt"),
])
def test_values_impossible_together_warn_in_validate_and_study(small_db, tmp_path, capsys, edit,
                                                              table, column, case, words):
    db = _copy(small_db, tmp_path, edit)
    where = f"table '{table}', column '{column}'" + (f", case_id {case}" if case else "")
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 0 and "plausibility warning" in text and where in text and words in text
    code, text = _cli(capsys, "db", "validate", "--strict", str(db))
    assert code == 1 and where in text and words in text
    if edit in (_heavy_car, _on_path):  # the study prints the same warnings, and refuses
        code, text = _study(capsys, db, tmp_path, "--strict")  # under --strict
        assert code == 2 and where in text and "under --strict" in text


def test_the_study_shows_validates_warnings_before_running(small_db, tmp_path, capsys):
    def speed_zero(frames):  # speed 0 while the positions move
        tr = frames["trajectories"]
        tr.loc[(tr["case_id"] == 8) & (tr["participant"] == 1), ["speed", "accel"]] = 0.0

    db = _copy(small_db, tmp_path, speed_zero)
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 0
    warned = [line for line in text.splitlines() if "case_id 8" in line]
    assert warned
    code, text = _study(capsys, db, tmp_path)
    assert code == 0
    for line in warned:  # the same lines, as "warning:" before the summary
        assert f"warning: {line.strip()[2:]}" in text


def test_fifty_g_recorded_acceleration_is_an_error(small_db, tmp_path, capsys):
    def fifty_g(frames):
        frames["trajectories"]["accel"] = 50 * 9.81

    db = _copy(small_db, tmp_path, fifty_g)
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 1 and "column 'accel'" in text and "50 g" in text
    code, text = _study(capsys, db, tmp_path)
    assert code == 2 and "column 'accel'" in text


def test_both_participants_fixed_is_an_error(small_db, tmp_path, capsys):
    db = _copy(small_db, tmp_path,
               lambda f: (_participant(f, 2, 1, fixed_object=True),
                          _participant(f, 2, 2, fixed_object=True)))
    code, text = _cli(capsys, "db", "validate", str(db))
    assert code == 1 and "column 'fixed_object', case_id 2: both participants" in text
    code, text = _study(capsys, db, tmp_path)
    assert code == 2 and "both participants" in text


def test_the_untouched_small_database_has_no_warning(small_db, tmp_path, capsys):
    code, text = _cli(capsys, "db", "validate", "--strict", str(small_db))
    assert code == 0 and "warning" not in text


# ----------------------------------------------------------------------------
# vfs impact
# ----------------------------------------------------------------------------


def _impact_row(**change: float) -> dict[str, float]:
    """A plausible car-to-car side impact [SI], 1,500 and 1,750 kg."""
    row = dict(case_id=1, m1=1500.0, izz1=2500.0, x1=0.0, y1=0.0, yaw1=0.0, vx1=14.0, vy1=0.0,
               yaw_rate1=0.0, m2=1750.0, izz2=3000.0, x2=3.2, y2=-2.0, yaw2=math.pi / 2,
               vx2=0.0, vy2=10.0, yaw_rate2=0.0, poi_x=2.2, poi_y=-0.6, cp_angle=0.0,
               restitution=0.1, contact_friction=0.3)
    row.update(change)
    return row


def _impact(capsys, tmp_path, rows, *extra: str, text: str | None = None) -> tuple[int, str]:
    file = tmp_path / "in.csv"
    if text is None:
        pd.DataFrame(rows).to_csv(file, index=False)
    else:
        file.write_text(text, encoding="utf-8")
    return _cli(capsys, "impact", "--input", str(file), "--output", str(tmp_path / "out.csv"),
                *extra)


def test_a_plausible_impact_table_gives_no_warning(tmp_path, capsys):
    code, text = _impact(capsys, tmp_path, [_impact_row()], "--strict")
    assert code == 0 and "warning" not in text


def test_a_duplicated_column_is_an_error(tmp_path, capsys):
    row = _impact_row()
    header = ",".join([*row, "m1"])
    line = ",".join(str(v) for v in [*row.values(), 1600.0])
    code, text = _impact(capsys, tmp_path, None, text=f"{header}\n{line}\n")
    assert code == 2 and "column 'm1'" in text and "twice" in text


@pytest.mark.parametrize(("change", "column", "words"), [
    ({"yaw1": 90.0, "yaw2": 180.0, "vx1": 0.0, "vy1": 14.0, "vx2": -10.0, "vy2": 0.0},
     "yaw1", "degrees"),
    ({"x2": 0.0, "y2": 0.0}, "x2", "centres of gravity"),
    ({"poi_x": 500.0, "poi_y": 0.0}, "poi_x", "from the nearer"),
    ({"m1": 1.5, "m2": 1.75, "izz1": 2.5, "izz2": 3.0}, "m1", "tonnes"),
    ({"izz2": 9.9e6}, "izz2", "radius of gyration"),
    ({"vx1": 100.0, "vy2": 80.0}, "vx1", "km/h"),
    ({"vx1": 55.0, "x2": 4.6, "y2": 0.0, "yaw2": math.pi, "vx2": -50.0, "vy2": 0.0,  # head-on
      "poi_x": 2.3, "poi_y": 0.0, "cp_angle": math.pi / 2}, "delta_v1", "km/h"),
])
def test_impact_values_that_cannot_be_true_warn(tmp_path, capsys, change, column, words):
    code, text = _impact(capsys, tmp_path, [_impact_row(**change)])
    assert code == 0 and f"column '{column}'" in text and words in text
    assert "warning:" in text
    code, text = _impact(capsys, tmp_path, [_impact_row(**change)], "--strict")
    assert code == 2 and f"column '{column}'" in text


# ----------------------------------------------------------------------------
# Faults of vfs study: exit codes, manifest status, files named
# ----------------------------------------------------------------------------


def _manifest(out: Path) -> dict:
    import json

    return json.loads((out / "study.json").read_text())


def test_a_case_that_fails_inside_the_simulation_makes_the_exit_code_non_zero(
        tmp_path, capsys, monkeypatch):
    import dataclasses

    import vfs.study
    from tests.study.test_run import FakeSystem

    real = vfs.study.run_study
    broken = FakeSystem("late", 1.0, fail_case=3)
    monkeypatch.setattr(vfs.study, "run_study",
                        lambda spec: real(dataclasses.replace(spec, systems=(broken,))))
    argv = ["study", "--db", "default", "--where", "case_id <= 6", "--systems", "late",
            "--engine", "serial"]
    code, text = _cli(capsys, *argv, "--out", str(tmp_path / "a"))
    assert code == 4 and "1 run(s) failed" in text and "--allow-failed" in text
    assert _manifest(tmp_path / "a")["status"] == "complete"  # the rows hold the error
    code, text = _cli(capsys, *argv, "--out", str(tmp_path / "b"), "--allow-failed")
    assert code == 0 and "1 failed" in text


def test_sigterm_stops_the_study_as_interrupted_and_releases_the_lock(tmp_path, capsys,
                                                                      monkeypatch):
    import os
    import signal

    import vfs.study.run as study_run

    real = study_run.write_table

    def terminate_on_first_chunk(path, *args, **kwargs):
        result = real(path, *args, **kwargs)
        if "chunk_" in str(path):
            os.kill(os.getpid(), signal.SIGTERM)  # as `kill PID` from outside
        return result

    monkeypatch.setattr(study_run, "write_table", terminate_on_first_chunk)
    out = tmp_path / "s"
    code, text = _cli(capsys, "study", "--db", "default", "--where", "case_id <= 6",
                      "--systems", "three-stage", "--engine", "serial", "--chunk-size", "3",
                      "--out", str(out))
    assert code == 143 and "terminated (SIGTERM)" in text and "--resume" in text
    assert _manifest(out)["status"] == "interrupted"
    assert not study_run.lock_path(out).exists()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # handler restored


def test_a_full_disk_names_the_file_and_the_manifest_says_failed(tmp_path, capsys,
                                                                 monkeypatch):
    import pyarrow.parquet

    import vfs.study.faults as faults

    def arrow_full(table, where, *args, **kwargs):  # pyarrow's message: no file name in it
        raise OSError("Error writing bytes to file. Detail: [errno 28] No space left on device")

    def no_new_file(path, data, **kwargs):  # the disk cannot take a new manifest either
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(pyarrow.parquet, "write_table", arrow_full)
    monkeypatch.setattr(faults, "write_json", no_new_file)
    out = tmp_path / "s"
    code, text = _cli(capsys, "study", "--db", "default", "--where", "case_id <= 6",
                      "--systems", "three-stage", "--engine", "serial", "--out", str(out))
    assert code == 1
    assert "error: No space left on device (" in text and ".parquet)" in text
    named = text.split("(", 1)[1].rsplit(")", 1)[0]
    assert Path(named).parent.exists() and Path(named).suffix == ".parquet"
    manifest = _manifest(out)  # rewritten in place: still JSON
    assert manifest["status"] == "failed" and "No space left" in manifest["error"]
