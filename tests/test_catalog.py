"""The scenario catalogue as data: scenarios/accident-types, scenarios/presets, databases."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from vfs.accident_types import ACCIDENT_TYPES
from vfs.catalog import catalog_path
from vfs.database import BUNDLED_DATABASES, bundled_database_path, load_database
from vfs.database.schema import TABLES
from vfs.errors import DefinitionError
from vfs.scenarios.catalogue import SCENARIO_TYPES, ScenarioSpec, load_scenario_types
from vfs.scenarios.generator import PRESETS, load_presets, preset_from_dict
from vfs.units import KMH_PER_MS

ROOT = Path(__file__).resolve().parents[1]


def test_accident_types_are_the_files_with_units_converted_exactly() -> None:
    files = sorted((ROOT / "scenarios" / "accident-types").glob("*.toml"))
    assert {int(f.stem) for f in files} == set(SCENARIO_TYPES)
    assert load_scenario_types(ROOT / "scenarios" / "accident-types") == SCENARIO_TYPES
    for code, spec in SCENARIO_TYPES.items():
        assert spec.name == ACCIDENT_TYPES[code]  # the name exists once: vfs.accident_types
    rear = SCENARIO_TYPES[601]
    assert rear.speed2 == (5.0 / KMH_PER_MS, 60.0 / KMH_PER_MS)  # speed2_kmh = [5.0, 60.0]
    assert rear.evasive_angle == (math.radians(2.0), math.radians(7.0))
    assert rear.brake_prob == (0.6, 0.4)  # per participant, not a range
    # a field left out keeps the dataclass default
    default = ScenarioSpec("x", "head_on", "x")
    assert rear.turn_radius == default.turn_radius


def test_presets_are_the_files_and_weights_are_normalised() -> None:
    assert set(PRESETS) == {p.stem for p in (ROOT / "scenarios" / "presets").glob("*.toml")}
    assert list(PRESETS)[0] == "default"
    assert load_presets(catalog_path("scenarios", "presets")) == PRESETS
    study = PRESETS["study36"]
    assert study.type_shares == {241: 13 / 36, 242: 9 / 36, 264: 6 / 36, 243: 5 / 36,
                                 211: 3 / 36}
    # [specs.241] overrides four fields of the catalogue's 241 and keeps the others
    over = study.specs[241]
    assert over.speed1 == (45 / KMH_PER_MS, 90 / KMH_PER_MS)
    assert dataclasses.replace(over, speed1=SCENARIO_TYPES[241].speed1,
                               speed2=SCENARIO_TYPES[241].speed2,
                               overlap=SCENARIO_TYPES[241].overlap,
                               brake_prob=SCENARIO_TYPES[241].brake_prob) == SCENARIO_TYPES[241]
    assert PRESETS["clean"].noise.is_zero and not PRESETS["default"].noise.is_zero


@pytest.mark.parametrize(("data", "field"), [
    ({"description": "d", "cases": 1, "type_shares": {"241": 1.0}}, "name"),
    ({"name": "p", "description": "d", "cases": 0, "type_shares": {"241": 1.0}}, "cases"),
    ({"name": "p", "description": "d", "cases": 5}, "type_shares"),
    ({"name": "p", "description": "d", "cases": 5, "type_shares": {"99": 1.0}},
     "type_shares.99"),
    ({"name": "p", "description": "d", "cases": 5, "type_shares": {"241": 1.0},
      "specs": {"999": {}}}, "specs.999"),
    ({"name": "p", "description": "d", "cases": 5, "type_shares": {"241": 1.0},
      "wet_share": 1.5}, "wet_share"),
    ({"name": "p", "description": "d", "cases": 5, "type_shares": {"241": 1.0},
      "noise": {"pdof_rad": 0.1}}, "noise.pdof_rad"),
    ({"name": "p", "description": "d", "cases": 5, "type_shares": {"241": 1.0},
      "sample_interval_s": 1.0}, "sample_interval_s"),
])
def test_malformed_preset_names_the_field(data: dict, field: str) -> None:
    with pytest.raises(DefinitionError) as info:
        preset_from_dict(data, "my.toml")
    assert info.value.field == field and "my.toml" in str(info.value)


def test_malformed_accident_type_names_the_file(tmp_path: Path) -> None:
    (tmp_path / "241.toml").write_text('code = 241\nkind = "head_on"\ndescription = "d"\n'
                                       "speed1_kmh = [90.0, 60.0]\n")
    with pytest.raises(DefinitionError, match=r"241\.toml: speed1_kmh: .*low <= high"):
        load_scenario_types(tmp_path)
    (tmp_path / "241.toml").write_text('code = 241\nkind = "flying"\ndescription = "d"\n')
    with pytest.raises(DefinitionError, match="kind.*head_on"):
        load_scenario_types(tmp_path)


def test_bundled_databases_live_in_scenarios_and_open_by_name() -> None:
    for name in BUNDLED_DATABASES:
        folder = bundled_database_path(name)
        assert folder == ROOT / "scenarios" / "databases" / name
        assert load_database(folder).n_cases >= 1
    assert not (ROOT / "vfs" / "data" / "default").exists()


@pytest.mark.parametrize("name", sorted(BUNDLED_DATABASES))
def test_every_bundled_table_field_carries_unit_and_description(name: str) -> None:
    folder = bundled_database_path(name)
    tables = [t for t in TABLES if (folder / f"{t}.parquet").is_file()]
    assert {"cases", "participants", "trajectories", "reconstruction"} <= set(tables)
    for table in tables:
        schema = pq.read_schema(folder / f"{table}.parquet")
        for field in schema:
            meta = field.metadata or {}
            assert meta.get(b"unit") is not None, (name, table, field.name)
            assert meta.get(b"description"), (name, table, field.name)


def test_definition_errors_in_the_catalogue_are_reported_at_import(tmp_path: Path) -> None:
    (tmp_path / "x.toml").write_text("name = 'x'\ncases = 3\n")
    with pytest.raises(DefinitionError, match=r"x\.toml: description: missing"):
        load_presets(tmp_path)


def test_presets_by_name_or_file_project_folder_first(tmp_path: Path) -> None:
    from vfs.scenarios.generator import get_preset

    assert get_preset("clean", cwd=tmp_path) is PRESETS["clean"]
    own = tmp_path / "scenarios" / "presets"
    own.mkdir(parents=True)
    text = (ROOT / "scenarios" / "presets" / "clean.toml").read_text(encoding="utf-8")
    (own / "clean.toml").write_text(text.replace("cases = 200", "cases = 7"), encoding="utf-8")
    assert get_preset("clean", cwd=tmp_path).cases == 7
    assert get_preset("scenarios/presets/clean.toml", cwd=tmp_path).cases == 7
    assert get_preset("default", cwd=tmp_path) is PRESETS["default"]
    with pytest.raises(DefinitionError, match="no such file"):
        get_preset("nowhere.toml", cwd=tmp_path)
