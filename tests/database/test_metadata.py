"""Units and descriptions travel with the files: Parquet field metadata and `vfs db schema`."""

from __future__ import annotations

import json

import pyarrow.parquet as pq

from vfs.cli import main
from vfs.database import open_database, save_database
from vfs.database.metadata import field_metadata, frictionless_schema
from vfs.database.schema import TABLES


def _meta(path, column):
    field = pq.read_schema(path).field(column)
    return {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}


def test_database_files_carry_units_descriptions_and_ranges(tmp_path):
    db = open_database("default", where="case_id <= 5")
    folder = save_database(db, tmp_path / "db")
    for name, spec in TABLES.items():
        schema = pq.read_schema(folder / f"{name}.parquet")
        for col in spec.columns:
            if col.name not in schema.names:
                continue
            m = _meta(folder / f"{name}.parquet", col.name)
            assert m["unit"] == col.stored_unit and m["description"] == col.description
            assert m["allowed"] == col.allowed_text()
    # as stored: pdof in the file is in degrees, and the metadata says so
    assert _meta(folder / "reconstruction.parquet", "pdof1")["unit"] == "deg"
    assert _meta(folder / "reconstruction.parquet", "delta_v1")["unit"] == "m/s"
    # the metadata does not change what is read back
    import pandas as pd

    again = open_database(folder)
    pd.testing.assert_frame_equal(again.reconstruction.reset_index(drop=True),
                                  db.reconstruction.reset_index(drop=True))


def test_study_runs_carry_si_units(tmp_path):
    from vfs.study import run_study

    res = run_study("default", ["three-stage"], tmp_path / "s", engine="serial",
                    where="case_id <= 10", progress=False)
    runs = res.path / "runs.parquet"
    assert _meta(runs, "delta_v1")["unit"] == "m/s"
    assert _meta(runs, "pdof1")["unit"] == "rad"  # SI in the runs table
    assert _meta(runs, "impact_speed2")["description"] == "speed of participant 2 at impact"
    known = field_metadata(pq.read_schema(runs).names)
    assert {"system", "collided", "delta_v1", "ees2", "rest_x1"} <= set(known)


def test_schema_command_json_and_frictionless(tmp_path, capsys):
    assert main(["db", "schema"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [t["name"] for t in doc["tables"]] == list(TABLES)
    out = tmp_path / "datapackage.json"
    assert main(["db", "schema", "--format", "frictionless", "--out", str(out)]) == 0
    pkg = json.loads(out.read_text())
    assert pkg == frictionless_schema()
    for res in pkg["resources"]:
        names = [f["name"] for f in res["schema"]["fields"]]
        assert names == [c.name for c in TABLES[res["name"]].columns]
        for f in res["schema"]["fields"]:
            assert f["type"] in ("number", "integer", "boolean", "string", "any")
            lo = f.get("constraints", {}).get("minimum")
            hi = f.get("constraints", {}).get("maximum")
            assert lo is None or hi is None or lo <= hi
