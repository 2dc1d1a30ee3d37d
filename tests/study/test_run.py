"""AEB studies: executors give identical runs, resume, error capture, folder rules, CLI."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pytest

from vfs.cli import main
from vfs.database import bundled_database_path, load_database
from vfs.errors import DataError, ParameterError
from vfs.physics.precrash import (
    BrakeActuatorParams,
    PrecrashObservation,
    PrecrashParams,
    ScheduledBraking,
)
from vfs.physics.runout import RunoutParams
from vfs.simulation import SimulationParams
from vfs.study import BASELINE, RunTask, load_study, resolve_system, run_task
from vfs.study import run_study as _run_study

WHERE = "case_id <= 40"  # 40 cases of the bundled database
CHUNK = 20  # -> 2 chunks
#: Coarse time steps: the study machinery is under test here, not the physics.
FAST = SimulationParams(precrash=PrecrashParams(dt=0.02, extra_time=1.0, contact_tolerance=0.001),
                        runout=RunoutParams(dt=0.025))


def run_study(*args, **kwargs):  # noqa: ANN002, ANN003, ANN201
    """:func:`vfs.study.run_study` with fast parameters and no progress bar by default."""
    kwargs.setdefault("params", FAST)
    kwargs.setdefault("progress", False)
    return _run_study(*args, **kwargs)


class FakeController(ScheduledBraking):
    """Scheduled braking with controller events (NaN where never)."""

    def __init__(self, start: np.ndarray, case_id: np.ndarray, fail_case: int | None) -> None:
        super().__init__(start, 9.0)
        self.case_id = case_id
        self.fail_case = fail_case

    def demand(self, obs: PrecrashObservation) -> np.ndarray:
        if self.fail_case is not None and obs.t > 1.0 and np.any(
                self.case_id[obs.rows] == self.fail_case):
            raise FloatingPointError(f"sensor model diverged in case {self.fail_case}")
        return super().demand(obs)

    def events(self) -> dict[str, np.ndarray]:
        n = self.start_time.shape[0]
        return {"warning_time": np.full((n, 2), np.nan), "full_time": self.start_time.copy()}


@dataclass(frozen=True)
class FakeSystem:
    """Brakes at 9 m/s^2 ``lead`` seconds before the end of each record (equipped vehicles)."""

    name: str
    lead: float = 1.5
    description: str = "fake AEB for tests"
    brake: BrakeActuatorParams = field(default_factory=BrakeActuatorParams)
    fail_case: int | None = None  # raises in demand() while this case is in the batch

    def controller(self, batch, equipped):  # noqa: ANN001, ANN201
        n = batch.size
        d = batch.paths.duration
        start = np.where(equipped, np.c_[d[:n], d[n:]] - self.lead, np.nan)
        return FakeController(start, np.asarray(batch.case_id), self.fail_case)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        return base


EARLY = FakeSystem("early", 1.6)
LATE = FakeSystem("late", 1.0)
REGISTRY = {"early": EARLY, "late": LATE}


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    """A clean serial study of 40 cases (2 chunks) with two fake systems."""
    out = tmp_path_factory.mktemp("study") / "clean"
    result = run_study("default", ["early", "late"], out, registry=REGISTRY, where=WHERE,
                       chunk_size=CHUNK, engine="serial")
    assert result.complete
    return result.table


def test_runs_table_layout(clean: pd.DataFrame) -> None:
    assert len(clean) == 40 * 3
    assert not clean.duplicated(["case_id", "system"]).any()
    assert list(clean["system"].iloc[:3]) == [BASELINE, "early", "late"]
    assert list(pd.unique(clean["case_id"])) == list(range(1, 41))
    assert (clean["error"] == "").all()
    for col in ("accident_type", "weight", "collided", "avoided", "impact_type", "impact_speed1",
                "closing_speed", "delta_v1", "delta_v2", "ees1", "pdof2", "poi_x", "rest_x1",
                "rest_y2", "brake_start1", "warning_time1", "full_time2"):
        assert col in clean.columns, col
    base = clean[clean["system"] == BASELINE]
    early = clean[clean["system"] == "early"]
    assert base["full_time1"].isna().all() and early["full_time1"].notna().all()
    assert not base["equipped1"].any() and early["equipped1"].all() and early["equipped2"].all()
    # braking earlier avoids more crashes than braking later, and never adds speed
    crashes = clean.groupby("system")["collided"].sum()
    assert crashes["early"] < crashes["late"] <= crashes[BASELINE]


def test_executors_give_identical_runs(clean: pd.DataFrame, tmp_path) -> None:
    expected = clean[clean["system"] != "late"].reset_index(drop=True)
    proc = run_study("default", [EARLY], tmp_path / "proc", where=WHERE, chunk_size=CHUNK,
                     engine="process", workers=2)
    pd.testing.assert_frame_equal(proc.table, expected)
    dask = run_study("default", [EARLY], tmp_path / "dask", where=WHERE, chunk_size=CHUNK,
                     engine="dask", workers=2, dask_processes=False)
    pd.testing.assert_frame_equal(dask.table, expected)
    pd.testing.assert_frame_equal(load_study(tmp_path / "dask").table, expected)


def test_resume_after_interrupt_equals_clean_run(clean: pd.DataFrame, tmp_path) -> None:
    out = tmp_path / "resumed"

    def stop(chunk: int, done: int) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_study("default", ["early"], out, registry=REGISTRY, where=WHERE,
                  chunk_size=CHUNK, engine="serial", on_chunk=stop)
    manifest = json.loads((out / "study.json").read_text())
    assert manifest["status"] == "interrupted"
    assert sorted(p.name for p in (out / "chunks").iterdir()) == ["chunk_000000.parquet"]
    assert not (out / "runs.parquet").exists()
    first = (out / "chunks" / "chunk_000000.parquet").stat().st_mtime_ns
    # not redone without --resume
    with pytest.raises(ParameterError, match="--resume"):
        run_study("default", ["early"], out, registry=REGISTRY, where=WHERE,
                  chunk_size=CHUNK, engine="serial")
    done = []
    result = run_study("default", ["early"], out, registry=REGISTRY, where=WHERE,
                       chunk_size=CHUNK, engine="serial", resume=True,
                       on_chunk=lambda k, n: done.append(k))
    assert done == [1]  # only the missing chunk ran
    assert (out / "chunks" / "chunk_000000.parquet").stat().st_mtime_ns == first
    assert result.complete and result.manifest["status"] == "complete"
    expected = clean[clean["system"] != "late"].reset_index(drop=True)
    pd.testing.assert_frame_equal(result.table, expected)
    pd.testing.assert_frame_equal(load_study(out).table, expected)


def test_resume_refuses_other_inputs(tmp_path) -> None:
    out = tmp_path / "s"
    part = run_study("default", ["early"], out, registry=REGISTRY, where=WHERE,
                     chunk_size=CHUNK, engine="serial", max_chunks=0)
    assert not part.complete and part.table is None
    assert "--resume" in part.summary()
    changes = [({"seed": 1}, "seed"), ({"chunk_size": 10}, "chunk_size"),
               ({"systems": ["early", "late"]}, "system_names"),
               ({"systems": [FakeSystem("early", 1.2)]}, "system_definitions"),
               ({"where": "case_id <= 30"}, "case_ids_hash"), ({"equip": "1"}, "equip"),
               ({"params": SimulationParams()}, "params")]
    for change, key in changes:
        kwargs = {"systems": ["early"], "where": WHERE, "chunk_size": CHUNK, **change}
        systems = kwargs.pop("systems")
        with pytest.raises(ParameterError, match=rf"cannot resume[\s\S]*\n  {key}: "):
            run_study("default", systems, out, registry=REGISTRY, engine="serial",
                      resume=True, max_chunks=0, **kwargs)
    # same inputs: accepted
    run_study("default", ["early"], out, registry=REGISTRY, where=WHERE, chunk_size=CHUNK,
              engine="serial", resume=True, max_chunks=0)


def test_output_folder_rules(tmp_path) -> None:
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    for flags in ({}, {"overwrite": True}, {"resume": True}):
        with pytest.raises(ParameterError, match="not a study"):
            run_study("default", ["early"], other, registry=REGISTRY, where=WHERE,
                      engine="serial", max_chunks=0, **flags)
    assert (other / "notes.txt").read_text() == "mine"
    out = tmp_path / "study"
    run_study("default", ["early"], out, registry=REGISTRY, where=WHERE, chunk_size=CHUNK,
              engine="serial", max_chunks=0)
    with pytest.raises(ParameterError, match="already holds a study"):
        run_study("default", ["late"], out, registry=REGISTRY, where=WHERE, engine="serial",
                  progress=False, max_chunks=0)
    run_study("default", ["late"], out, registry=REGISTRY, where=WHERE, engine="serial",
              progress=False, max_chunks=0, overwrite=True)
    assert json.loads((out / "study.json").read_text())["system_names"] == ["late"]


def test_failing_case_is_isolated_and_recorded(clean: pd.DataFrame, tmp_path) -> None:
    bad = 7
    broken = FakeSystem("late", 1.0, fail_case=bad)
    result = run_study("default", [broken], tmp_path / "err", where="case_id <= 10",
                       chunk_size=CHUNK, engine="serial")
    table = result.table
    assert len(table) == 20 and not table.duplicated(["case_id", "system"]).any()
    failed = table[table["error"] != ""]
    assert list(zip(failed["case_id"], failed["system"], strict=True)) == [(bad, "late")]
    assert "FloatingPointError: sensor model diverged in case 7" in failed["error"].iloc[0]
    row = failed.iloc[0]
    assert pd.isna(row["collided"]) and np.isnan(row["delta_v1"]) and pd.isna(row["impact_type"])
    assert pd.isna(row["cp_rule"]) and np.isnan(row["full_time1"])
    assert row["accident_type"] == clean.loc[clean["case_id"] == bad, "accident_type"].iloc[0]
    # every other run is the same as in the clean study (this fake draws no random numbers;
    # each case ends at its own horizon, and a stopped car's speed reduction is its recorded
    # speed there, whatever the batch)
    ok = (table["error"] == "").to_numpy()
    expected = clean[clean["case_id"].le(10) & clean["system"].isin([BASELINE, "late"])]
    pd.testing.assert_frame_equal(table[ok].reset_index(drop=True),
                                  expected[ok].reset_index(drop=True))
    assert result.manifest["summary"]["systems"]["late"]["errors"] == 1
    assert "1 failed" in result.summary()


def test_chunk_bisection_isolates_several_cases() -> None:
    db = load_database(bundled_database_path(), where="case_id <= 8")
    ids = db.case_ids

    class Picky(FakeSystem):
        def controller(self, batch, equipped):  # noqa: ANN001, ANN201
            if np.isin(batch.case_id, [2, 7]).any():
                raise ValueError("cannot handle cases 2 and 7")
            return super().controller(batch, equipped)

    task = RunTask(chunk=0, case_ids=ids, system_index=1, system=Picky("picky"),
                   db="default", db_format="parquet", batch=None,
                   equip="1", seed=0, params=FAST, impact_parameters="reconstruction")
    table = run_task(task)
    assert len(table) == 8 and list(table["case_id"]) == list(ids)
    errors = table[table["error"] != ""]
    assert sorted(errors["case_id"]) == [2, 7]
    assert "ValueError: cannot handle cases 2 and 7" in errors["error"].iloc[0]
    assert (table["system"] == "picky").all()
    assert (table["equipped1"] & ~table["equipped2"]).all()
    assert table.loc[table["error"] == "", "collided"].notna().all()


def test_in_memory_database_matches_folder(clean: pd.DataFrame, tmp_path) -> None:
    db = load_database(bundled_database_path(), where="case_id <= 12")
    result = run_study(db, [EARLY], tmp_path / "mem", chunk_size=CHUNK, engine="serial",
                       progress=False)
    assert result.manifest["db"] == "<in-memory database>"
    expected = clean[clean["case_id"].le(12) & clean["system"].isin([BASELINE, "early"])]
    got = result.table.drop(columns=[c for c in result.table.columns
                                     if c not in expected.columns])
    pd.testing.assert_frame_equal(got.reset_index(drop=True), expected.reset_index(drop=True))


def test_system_lookup_and_arguments(tmp_path) -> None:
    assert resolve_system("early", REGISTRY) is EARLY
    assert resolve_system("late", REGISTRY.__getitem__) is LATE
    with pytest.raises(ParameterError, match="unknown system 'nope'"):
        resolve_system("nope", REGISTRY)
    with pytest.raises(ParameterError, match="reserved"):
        run_study("default", [FakeSystem(BASELINE)], tmp_path / "x", engine="serial")
    with pytest.raises(ParameterError, match="twice"):
        run_study("default", [EARLY, EARLY], tmp_path / "x", engine="serial")
    with pytest.raises(ParameterError, match="engine"):
        run_study("default", [EARLY], tmp_path / "x", engine="threads")
    with pytest.raises(ParameterError, match="equip"):
        run_study("default", [EARLY], tmp_path / "x", equip="3")
    with pytest.raises(DataError, match="no case selected"):
        run_study("default", [EARLY], tmp_path / "x", where="case_id < 0", engine="serial")
    with pytest.raises(DataError, match="invalid case selection"):
        run_study("default", [EARLY], tmp_path / "x", where="no_such_column = 1")
    assert not (tmp_path / "x").exists()


def test_cli_study_writes_the_study(tmp_path, monkeypatch, capsys) -> None:
    import vfs.adas

    monkeypatch.setattr(vfs.adas, "find_system", REGISTRY.__getitem__, raising=False)
    out = tmp_path / "cli"
    code = main(["study", "--db", "default", "--systems", "early", "--out", str(out),
                 "--where", "case_id <= 6", "--engine", "serial", "--chunk-size", "5",
                 "--equip", "2", "--seed", "3"])
    assert code == 0
    text = capsys.readouterr().out
    assert "6 cases" in text and "baseline crashes avoided" in text and "cases/s" in text
    manifest = json.loads((out / "study.json").read_text())
    assert manifest["status"] == "complete" and manifest["n_chunks"] == 2
    assert manifest["equip"] == "2" and manifest["seed"] == 3
    for key in ("db", "case_ids_hash", "data_hash", "versions", "created", "system_names"):
        assert manifest[key]
    runs = pd.read_parquet(out / "runs.parquet")
    assert len(runs) == 12 and (~runs["equipped1"]).all()
    assert len(pd.read_parquet(out / "cases.parquet")) == 6
    # the report reads what the study wrote
    assert main(["report", "effectiveness", str(out), "--bootstrap", "50",
                 "--no-case-pages"]) == 0
    assert "early" in (out / "report" / "report.md").read_text()
    # a second run without --resume is refused with exit code 2
    assert main(["study", "--db", "default", "--systems", "early", "--out", str(out),
                 "--where", "case_id <= 6", "--engine", "serial"]) == 2
    assert "--resume" in capsys.readouterr().err


def _real_systems_available() -> bool:
    try:
        from vfs.adas import SYSTEM_NAMES, get_system  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(not _real_systems_available(), reason="vfs.adas.get_system not available yet")
def test_real_adas_systems(tmp_path) -> None:
    from vfs.adas import SYSTEM_NAMES

    names = [n for n in ("three-stage", "ideal") if n in SYSTEM_NAMES]
    result = run_study("default", names, tmp_path / "real", where="case_id <= 6",
                       engine="serial")
    table = result.table
    assert (table["error"] == "").all(), table.loc[table["error"] != "", "error"].tolist()
    assert len(table) == 6 * (len(names) + 1)
    for key in ("warning_time", "partial_time", "full_time", "ttc_at_trigger",
                "driver_reaction_time", "driver_brake_time"):
        assert f"{key}1" in table.columns and f"{key}2" in table.columns
    systems = table["system"].to_numpy()
    assert table.loc[systems == BASELINE, "full_time1"].isna().all()
    assert table.loc[systems != BASELINE, "equipped1"].all()
