"""StudySpec (settings checked once, passed whole) and tasks of several chunks.

A task that runs several chunks as one batch (``task_cases``) must give each
chunk the runs of that chunk run alone: the same random draws
(:class:`vfs.physics.precrash.SegmentedRandom`), hence the same decisions,
contacts and outcomes.  Everything but floats is compared exactly; floats to
1e-9 (relative and absolute, SI units): a case's last bits can depend on the
other cases of its batch (a few vectorised kernels take batch-wide branches),
as they already did on main with another ``chunk_size``; the largest such
difference seen is 8e-14 m in a closest-approach distance.  On the bundled
database with the default parameters the study is bit-identical to main's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from vfs.adas import get_system
from vfs.adas.params import SensorParams
from vfs.cli import build_parser
from vfs.database import bundled_database_path, load_database
from vfs.errors import ParameterError
from vfs.physics.precrash import PrecrashParams
from vfs.physics.runout import RunoutParams
from vfs.simulation import SimulationParams
from vfs.study import (
    Equip,
    ImpactParameterSource,
    RunTask,
    StudySpec,
    run_study,
    run_task,
)

FAST = SimulationParams(precrash=PrecrashParams(dt=0.02, extra_time=1.0, contact_tolerance=0.001),
                        runout=RunoutParams(dt=0.025))

#: Tolerance of float columns between batch compositions (see the module docstring).
TOL = 1e-9


def _assert_same_runs(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    floats = [c for c in a.columns if a[c].dtype.kind == "f"]
    pd.testing.assert_frame_equal(a.drop(columns=floats), b.drop(columns=floats),
                                  check_exact=True)
    np.testing.assert_allclose(a[floats].to_numpy(float), b[floats].to_numpy(float),
                               rtol=TOL, atol=TOL, equal_nan=True)


def _noisy_three_stage() -> object:
    """three-stage with a sensor that misses 30 % of its detections (random per cycle)."""
    system = get_system("three-stage")
    sensor = dataclasses.replace(system.aeb.sensor, detection_probability=0.7)
    assert isinstance(sensor, SensorParams)
    return dataclasses.replace(system, name="noisy",
                               aeb=dataclasses.replace(system.aeb, sensor=sensor))


@pytest.mark.parametrize("system_name", ["three-stage", "noisy", "ideal"])
def test_task_of_chunks_equals_chunks_run_alone(system_name: str) -> None:
    system = _noisy_three_stage() if system_name == "noisy" else get_system(system_name)
    ids = np.asarray(load_database(bundled_database_path("default")).case_ids)[:45]
    chunks = [ids[:20], ids[20:40], ids[40:]]

    def task(k: int, case_ids: np.ndarray, group: tuple[tuple[int, int], ...] = ()) -> RunTask:
        return RunTask(chunk=k, case_ids=case_ids, system_index=1, system=system, db="default",
                       db_format="parquet", batch=None, equip="both", seed=5, params=FAST,
                       impact_parameters="reconstruction", group=group)

    alone = pd.concat([run_task(task(k, c)) for k, c in enumerate(chunks)], ignore_index=True)
    together = run_task(task(0, ids, tuple((k, c.size) for k, c in enumerate(chunks))))
    _assert_same_runs(together, alone)


def test_grouped_study_equals_chunk_by_chunk(tmp_path) -> None:  # noqa: ANN001
    common = dict(where="case_id <= 50", chunk_size=10, engine="serial", params=FAST,
                  progress=False)
    one = run_study("default", "three-stage", tmp_path / "one", task_cases=10, **common)
    many = run_study("default", ["three-stage"], tmp_path / "many", task_cases=1000, **common)
    _assert_same_runs(one.table, many.table)
    # resume finer than a task: one chunk file deleted is redone alone, same rows
    (tmp_path / "many" / "chunks" / "chunk_000002.parquet").unlink()
    again = run_study("default", ["three-stage"], tmp_path / "many", task_cases=1000,
                      resume=True, **common)
    _assert_same_runs(one.table, again.table)


@pytest.mark.parametrize(("field", "value"), [
    ("chunk_size", 0), ("chunk_size", 2.5), ("task_cases", -1), ("workers", 0),
    ("in_flight", 0), ("max_chunks", -1), ("equip", "3"), ("impact_parameters", "expert"),
    ("engine", "no-such-engine"), ("seed", "x"),
])
def test_spec_refuses_bad_settings(field: str, value: object) -> None:
    with pytest.raises(ParameterError, match=field if field != "engine" else "engine"):
        StudySpec("default", ("ideal",), "out", **{field: value})


def test_spec_normalises_and_is_frozen() -> None:
    spec = StudySpec("default", "three-stage, ideal", "out", equip=1, chunk_size=50.0)
    assert spec.systems == ("three-stage", "ideal")
    assert spec.equip is Equip.ONE and spec.chunk_size == 50 and isinstance(spec.chunk_size, int)
    assert spec.impact_parameters is ImpactParameterSource.RECONSTRUCTION
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.seed = 3  # type: ignore[misc]
    with pytest.raises(ParameterError, match="dashboard"):
        StudySpec("default", ("ideal",), "out", engine="serial", dashboard=":8787")


def test_run_study_takes_a_spec_or_its_fields(tmp_path) -> None:  # noqa: ANN001
    with pytest.raises(ParameterError, match="unknown study settings: chunksize"):
        run_study("default", ["ideal"], tmp_path / "x", chunksize=10)
    spec = StudySpec("default", ("ideal",), tmp_path / "y", engine="serial",
                     where="case_id <= 3", params=FAST, progress=False)
    with pytest.raises(ParameterError, match="no further arguments"):
        run_study(spec, engine="serial")
    result = run_study(spec)
    assert result.complete and len(result.table) == 2 * result.table["case_id"].nunique() > 0


def test_cli_choices_are_the_enums() -> None:
    parser = build_parser()
    study = parser._subparsers._group_actions[0].choices["study"]  # type: ignore[union-attr]
    choices = {a.dest: a.choices for a in study._actions if a.choices}
    assert list(choices["equip"]) == [m.value for m in Equip]
    assert list(choices["impact_parameters"]) == [m.value for m in ImpactParameterSource]
