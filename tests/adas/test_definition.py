"""AEB systems as TOML files (adas/*.toml): loader, errors, lookup order, catalogue accessor."""

from __future__ import annotations

import dataclasses
import math
import os
import pickle
import subprocess
import sys
from pathlib import Path

import pytest

from vfs.adas import AEBParams, AEBSystem, DriverParams, SensorParams, find_system, load_system
from vfs.adas.definition import SCHEMA
from vfs.adas.systems import SYSTEMS, builtin_definition
from vfs.catalog import catalog_path, catalog_root, checkout_root
from vfs.errors import DefinitionError, ParameterError
from vfs.physics.precrash import BrakeActuatorParams
from vfs.units import KMH_PER_MS

ROOT = Path(__file__).resolve().parents[2]

# The presets as docs/aeb.md states them (sources: docs/references.md), written as the
# dataclasses they were before they became files; a step actuator is 1e5 m/s^3.
_STEP = BrakeActuatorParams(model="jerk", jerk=1.0e5, release_jerk=1.0e5)
_IDEAL_AEB = AEBParams(
    sensor=SensorParams(range=math.inf, field_of_view=2.0 * math.pi, cycle_time=0.0,
                        latency=0.0),
    prediction="cv", ttc_horizon=6.0, warning_ttc=None, partial_ttc=None, full_ttc=None,
    full_deceleration=100.0, last_moment=True, release="standstill", min_speed=0.2)
EXPECTED = {
    "none": AEBSystem("none", "no AEB: the record is replayed", None, None,
                      BrakeActuatorParams()),
    "openpass-like": AEBSystem(
        "openpass-like",
        "openPASS-like single stage: 6 m/s^2 step at TTC 2.0 s (outlines +4.0/+1.5 m), "
        "release at 1.5 x TTC, 150 m / 0.35 rad sensor, no latency",
        AEBParams(sensor=SensorParams(range=150.0, field_of_view=0.35, cycle_time=0.01,
                                      latency=0.0),
                  prediction="ctrv", ttc_horizon=4.0, warning_ttc=None, partial_ttc=None,
                  full_ttc=2.0, full_deceleration=6.0, release="ttc", release_factor=1.5,
                  box_margin_longitudinal=4.0, box_margin_lateral=1.5, min_speed=0.0),
        None, _STEP),
    "three-stage": AEBSystem(
        "three-stage",
        "warning 2.6 s, partial (4 m/s^2) 1.6 s, full 0.6 s; 150 m / 0.35 rad sensor, 20 Hz, "
        "0.1 s latency; jerk 40 m/s^3; Gamma(7,7) driver reacts to the warning",
        AEBParams(sensor=SensorParams(range=150.0, field_of_view=0.35, cycle_time=0.05,
                                      latency=0.1),
                  prediction="ctrv", ttc_horizon=4.0, warning_ttc=2.6, partial_ttc=1.6,
                  partial_deceleration=4.0, full_ttc=0.6, full_deceleration=10.0,
                  release="standstill"),
        DriverParams(), BrakeActuatorParams(model="jerk", jerk=40.0, release_jerk=40.0)),
    "ideal": AEBSystem(
        "ideal",
        "ideal: 360 deg perfect sensor, no latency, instant full braking at the friction limit "
        "at the last moment that avoids the CV-predicted contact",
        _IDEAL_AEB, None, dataclasses.replace(_STEP, max_deceleration=20.0)),
}


def _fields(obj: object, prefix: str = "") -> dict[str, object]:
    """Every leaf field of nested dataclasses, by dotted name."""
    out: dict[str, object] = {}
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out.update(_fields(value, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = value
    return out


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_builtin_files_give_todays_presets_field_by_field(name: str) -> None:
    got = load_system(builtin_definition(name))
    want = EXPECTED[name]
    got_fields, want_fields = _fields(got), _fields(want)
    assert got_fields.keys() == want_fields.keys()
    for key, value in want_fields.items():
        # exact equality (no tolerance): deg -> rad and km/h -> m/s at the edge are exact here
        assert got_fields[key] == value, key
    assert got == want and SYSTEMS.get(name) == want


def test_ideal_ctra_differs_from_ideal_in_the_prediction_only() -> None:
    ideal, ctra = load_system(builtin_definition("ideal")), SYSTEMS.get("ideal-ctra")
    assert ctra.aeb is not None and ctra.aeb.prediction == "ctra"
    assert dataclasses.replace(ctra, name="ideal", description=ideal.description,
                               aeb=dataclasses.replace(ctra.aeb, prediction="cv")) == ideal


def test_every_builtin_file_names_every_field_of_the_schema() -> None:
    # the built-in files are complete: a reader sees every field with its unit and comment
    text = builtin_definition("three-stage").read_text(encoding="utf-8")
    for table, fields in SCHEMA.items():
        for f in fields:
            if table == "" and f.name == "name":
                assert "\nname = " not in text  # the name is the file's
                continue
            if table == "driver" and f.name == "reaction_time":
                assert "# reaction_time_s" in text  # documented, off (drawn from Gamma)
                continue
            assert any(f"\n{k} = " in text for k in f.keys()), (table, f.name)
            line = next(ln for ln in text.splitlines() if ln.split(" = ")[0] in f.keys())
            assert "#" in line, line  # a comment per field


def _write(tmp_path: Path, text: str, name: str = "sys.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


THREE = (ROOT / "adas" / "three-stage.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize(("old", "new", "field", "allowed"), [
    ("latency_s = 0.1", "latency_s = 2.5", "aeb.sensor.latency_s", "[0, 2] s"),
    ("range_m = 150.0", "range_m = -1.0", "aeb.sensor.range_m", "(0, inf] m"),
    ("field_of_view_deg = 20.05352282957881", "field_of_view_deg = 361.0",
     "aeb.sensor.field_of_view_deg", "(0, 360] deg"),
    ("field_of_view_deg = 20.05352282957881", "field_of_view_rad = 7.0",
     "aeb.sensor.field_of_view_rad", "(0, 6.283185307] rad"),
    ("min_speed_kmh = 5.0", "min_speed_kmh = -5.0", "aeb.min_speed_kmh", "[0, 360) km/h"),
    ('prediction = "ctrv"', 'prediction = "kalman"', "aeb.prediction", "'cv', 'ctrv'"),
    ("ttc_s = 2.6", 'ttc_s = "soon"', "aeb.warning.ttc_s", "(0, 30] s"),
    ("brake_share = 0.7", "brake_share = 1.5", "driver.brake_share", "[0, 1]"),
    ("jerk_mps3 = 40.0", "jerk_mps3 = 0.0", "brake.jerk_mps3", "(0, 1000000] m/s^3"),
    ("last_moment = false", "last_moment = 0", "aeb.full.last_moment", "true or false"),
    ("latency_s = 0.1", "latency_ms = 100", "aeb.sensor.latency_ms", "latency_s"),
    ("latency_s = 0.1", "latency_s = 0.1\nlatency = 0.1", "aeb.sensor.latency",
     "latency_s"),
])
def test_malformed_or_out_of_range_field_names_file_field_and_range(
        tmp_path: Path, old: str, new: str, field: str, allowed: str) -> None:
    assert old in THREE
    path = _write(tmp_path, THREE.replace(old, new, 1))
    with pytest.raises(DefinitionError) as info:
        load_system(path)
    err = info.value
    assert err.path == str(path) and err.field == field
    assert allowed in err.allowed
    message = str(err)
    assert str(path) in message and field in message and allowed in message
    assert "\n" not in message  # one line


def test_a_field_in_two_units_invalid_toml_and_a_missing_file(tmp_path: Path) -> None:
    two = _write(tmp_path, THREE.replace("min_speed_kmh = 5.0",
                                         "min_speed_kmh = 5.0\nmin_speed_mps = 1.0"))
    with pytest.raises(DefinitionError, match="given twice"):
        load_system(two)
    broken = _write(tmp_path, "name = 'x'\n[aeb\n", "broken.toml")
    with pytest.raises(DefinitionError, match=r"broken\.toml: not valid TOML.*line 2"):
        load_system(broken)
    with pytest.raises(DefinitionError, match="no such file"):
        load_system(tmp_path / "missing.toml")
    table = _write(tmp_path, THREE.replace("[aeb.warning]", "[aeb.warningx]"), "t.toml")
    with pytest.raises(DefinitionError, match="aeb.warningx: unknown field"):
        load_system(table)


def test_cross_field_rules_of_the_dataclasses_name_the_file_and_table(tmp_path: Path) -> None:
    path = _write(tmp_path, THREE.replace("deceleration_min_mps2 = 3.0",
                                          "deceleration_min_mps2 = 8.0"))
    with pytest.raises(DefinitionError, match=r"sys\.toml: driver: .*deceleration_min <= "
                                                "deceleration_mean") as info:
        load_system(path)
    assert isinstance(info.value, ParameterError)  # handled like every parameter error
    again = pickle.loads(pickle.dumps(info.value))  # crosses process boundaries intact
    assert str(again) == str(info.value) and again.field == "driver"


def test_omitted_fields_take_the_dataclass_defaults_and_absent_stages_are_off(
        tmp_path: Path) -> None:
    path = _write(tmp_path, "[aeb.full]\nttc_s = 1.0\n", "minimal.toml")
    system = load_system(path)
    assert system.name == "minimal" and system.driver is None
    assert system.aeb == AEBParams(warning_ttc=None, partial_ttc=None, full_ttc=1.0)
    assert system.brake == BrakeActuatorParams()
    none = load_system(_write(tmp_path, 'aeb = false\n', "off.toml"))
    assert none.aeb is None and none.controller is not None
    speeds = load_system(_write(tmp_path, "[aeb]\nmin_speed_kmh = 36.0\nmax_speed_mps = 20.0\n"
                                "[aeb.full]\nttc_s = 1.0\n", "speeds.toml")).aeb
    assert speeds is not None
    assert speeds.min_speed == 36.0 / KMH_PER_MS and speeds.max_speed == 20.0
    with pytest.raises(DefinitionError, match="at least one stage"):
        load_system(_write(tmp_path, "[aeb]\nprediction = 'cv'\n", "nostage.toml"))


def test_names_are_looked_up_in_the_project_adas_folder_first(tmp_path: Path) -> None:
    builtin = find_system("three-stage", cwd=tmp_path)
    assert builtin is SYSTEMS.get("three-stage")  # no project folder: the built-in
    (tmp_path / "adas").mkdir()
    _write(tmp_path / "adas", THREE.replace("latency_s = 0.1", "latency_s = 0.4"),
           "three-stage.toml")
    _write(tmp_path / "adas", THREE.replace('name = "three-stage"', 'name = "mine"'),
           "mine.toml")
    own = find_system("three-stage", cwd=tmp_path)
    assert own.name == "three-stage" and own.aeb is not None
    assert own.aeb.sensor.latency == 0.4  # the project's file wins over the built-in
    assert find_system("ideal", cwd=tmp_path) is SYSTEMS.get("ideal")  # then the built-ins
    assert find_system("mine", cwd=tmp_path).name == "mine"
    by_path = find_system("adas/mine.toml", cwd=tmp_path)
    assert by_path == find_system(str(tmp_path / "adas" / "mine.toml"))
    with pytest.raises(ParameterError, match="unknown AEB system 'nobody'.*three-stage"):
        find_system("nobody", cwd=tmp_path)
    with pytest.raises(DefinitionError, match="no such file"):
        find_system("adas/nobody.toml", cwd=tmp_path)


def test_study_resolves_names_and_files_through_the_same_lookup(tmp_path: Path,
                                                                monkeypatch) -> None:
    from vfs.study import resolve_systems

    (tmp_path / "adas").mkdir()
    _write(tmp_path / "adas", THREE.replace('name = "three-stage"', 'name = "mine"'),
           "mine.toml")
    monkeypatch.chdir(tmp_path)
    systems = resolve_systems("mine,ideal,adas/mine.toml".split(",")[:2], None)
    assert [s.name for s in systems] == ["mine", "ideal"]
    with pytest.raises(ParameterError, match="given twice"):
        resolve_systems(["mine", "adas/mine.toml"], None)


def test_catalogue_accessor_reads_the_repository_folders_from_any_cwd(tmp_path: Path) -> None:
    assert checkout_root() == ROOT
    assert catalog_root("adas") == ROOT / "adas"
    assert catalog_path("scenarios", "databases", "default") == \
        ROOT / "scenarios" / "databases" / "default"
    with pytest.raises(ParameterError, match="unknown catalogue"):
        catalog_root("results")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    code = ("from vfs.catalog import catalog_root; from vfs.adas import get_system; "
            "print(catalog_root('adas')); print(catalog_root('scenarios')); "
            "print(get_system('three-stage').aeb.warning_ttc)")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                         capture_output=True, text=True, check=True)
    assert out.stdout.split() == [str(ROOT / "adas"), str(ROOT / "scenarios"), "2.6"]


def test_example_controller_registers_a_system_a_study_can_run(tmp_path: Path) -> None:
    from vfs.cli.common import load_plugins
    from vfs.database import open_database
    from vfs.study import run_study

    load_plugins([str(ROOT / "adas" / "example_controller.py")])
    system = SYSTEMS.get("gap-time")
    assert pickle.loads(pickle.dumps(system)) == system  # workers import it by path
    db = open_database("default", "case_id <= 10")
    result = run_study(db, ["gap-time", "three-stage"], tmp_path / "s", engine="serial")
    runs = result.table
    assert runs is not None
    assert set(runs["system"]) >= {"baseline", "gap-time", "three-stage"}
    base = runs[runs["system"] == "baseline"].set_index("case_id")["collided"]
    gap = runs[runs["system"] == "gap-time"].set_index("case_id")["collided"]
    # full braking 1.2 s before the centres meet avoids some of the recorded crashes
    assert gap.sum() < base.sum()


def test_readme_explains_every_field_with_its_unit_and_range() -> None:
    readme = (ROOT / "adas" / "README.md").read_text(encoding="utf-8")
    for table, fields in SCHEMA.items():
        for f in fields:
            row = next((ln for ln in readme.splitlines() if ln.startswith(f"| `{f.keys()[0]}`")),
                       None)
            assert row is not None, (table, f.name)
            for unit in f.units():
                if f.quantity not in ("text", "bool"):
                    assert f.allowed(unit) in row, (table, f.name, unit.label)
