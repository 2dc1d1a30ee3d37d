"""Self-describing runs: unit and description on every column a study writes (AEB events
included), in the Parquet field metadata and in ``vfs.read_runs(...).attrs``; ``vfs db schema
runs`` lists the same columns in file order.
"""

from __future__ import annotations

import pyarrow.parquet as pq
import pytest

import vfs
from vfs.adas import EVENT_KEYS
from vfs.cli import main
from vfs.cli.db import runs_columns
from vfs.errors import DataError
from vfs.study import run_study


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("units") / "s"
    run_study("default", ["three-stage"], out, engine="serial",
              where="case_id IN (10, 20, 50)", progress=False)
    return out


def test_every_written_column_has_unit_and_description(study):
    schema = pq.read_schema(study / "runs.parquet")
    missing = [f.name for f in schema
               if not f.metadata or b"unit" not in f.metadata or not f.metadata.get(
                   b"description")]
    assert missing == []
    events = {f"{k}{i}" for k in EVENT_KEYS for i in (1, 2)}
    assert events <= set(schema.names)


def test_read_runs_carries_units_in_attrs(study):
    df = vfs.read_runs(study)
    assert df.attrs["units"]["impact_speed1"] == "m/s"
    assert df.attrs["units"]["driver_deceleration1"] == "m/s^2"
    assert set(df.attrs["units"]) == set(df.columns) == set(df.attrs["descriptions"])
    assert vfs.read_runs(study / "runs.parquet").attrs == df.attrs
    with pytest.raises(DataError, match="not a study folder"):
        vfs.read_runs(study.parent)


def test_schema_runs_lists_the_written_columns_in_order(study, capsys):
    assert runs_columns() == pq.read_schema(study / "runs.parquet").names
    assert main(["db", "schema", "runs"]) == 0
    out = capsys.readouterr().out
    assert "impact_speed1" in out and "m/s" in out and "warning_time2" in out


def test_database_tables_carry_units_in_attrs():
    db = vfs.open_database("default", "case_id IN (10)")
    assert db.participants.attrs["units"]["mass"] == "kg"
    assert db.trajectories.attrs["units"]["speed"] == "m/s"
    assert db.reconstruction.attrs["units"]["pdof1"] == "rad"  # SI in memory
