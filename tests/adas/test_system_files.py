"""System files that copy and say everything at once (issue 40 item 5, issue 41):
the name from the file, cross-field rules, every problem of a file in one error, an empty
file refused, absurd values refused by the declared bounds; the README's tables derived
from the declarations."""

from __future__ import annotations

from pathlib import Path

import pytest

from vfs.adas import AEBParams, load_system
from vfs.adas.definition import readme_tables
from vfs.errors import DefinitionError, DefinitionErrors, SettingsError
from vfs.study.systems import resolve_systems

ROOT = Path(__file__).resolve().parents[2]
THREE = (ROOT / "adas" / "three-stage.toml").read_text(encoding="utf-8")


def _write(folder: Path, text: str, name: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def test_a_copied_builtin_with_a_changed_threshold_runs_beside_the_original(
        tmp_path: Path) -> None:
    _write(tmp_path, THREE.replace("ttc_s = 0.6", "ttc_s = 0.8"), "adas/my-aeb.toml")
    systems = resolve_systems("three-stage,my-aeb", lambda s: __import__(
        "vfs.adas", fromlist=["find_system"]).find_system(s, cwd=tmp_path))
    assert [s.name for s in systems] == ["three-stage", "my-aeb"]
    assert systems[1].aeb.full_ttc == 0.8 and systems[0].aeb.full_ttc == 0.6
    # the copy differs from the original only in that threshold
    assert systems[1].aeb == AEBParams(**{**systems[0].aeb.__dict__, "full_ttc": 0.8})


def test_the_name_is_the_file_name_even_where_the_file_says_otherwise(tmp_path: Path) -> None:
    path = _write(tmp_path, 'name = "three-stage"\n' + THREE, "copy.toml")
    assert load_system(path).name == "copy"


@pytest.mark.parametrize(("stages", "rule"), [
    ("[aeb.partial]\nttc_s = 0.4\n[aeb.full]\nttc_s = 0.6\n", "stage order"),
    ("[aeb.warning]\nttc_s = 1.0\n[aeb.full]\nttc_s = 1.5\n", "stage order"),
    ("[aeb]\nttc_horizon_s = 2.0\n[aeb.full]\nttc_s = 2.5\n", "<= ttc_horizon"),
    ("[aeb.partial]\nttc_s = 1.6\ndeceleration_mps2 = 12.0\n[aeb.full]\nttc_s = 0.6\n",
     "partial_deceleration <= full_deceleration"),
])
def test_cross_field_rules_name_the_file_the_table_and_the_rule(
        tmp_path: Path, stages: str, rule: str) -> None:
    path = _write(tmp_path, stages, "bad.toml")
    with pytest.raises(DefinitionError, match=r"bad\.toml: aeb: .*" + rule):
        load_system(path)


def test_every_problem_of_a_file_is_reported_at_once(tmp_path: Path) -> None:
    text = (THREE.replace("latency_s = 0.1", "latency_s = 3.0")
            .replace("brake_lag_s = 0.2", "brake_lagg_s = 0.2")
            .replace("jerk_mps3 = 40.0", "jerk_mps3 = -1.0")
            .replace("prediction = \"ctrv\"", "prediction = \"magic\""))
    with pytest.raises(DefinitionErrors) as info:
        load_system(_write(tmp_path, text, "many.toml"))
    fields = [e.field for e in info.value.errors]
    assert fields == ["aeb.prediction", "aeb.sensor.latency_s", "driver.brake_lagg_s",
                      "brake.jerk_mps3", "brake.release_jerk_mps3"]
    assert all(f"many.toml: {f}" in str(info.value) for f in fields)


@pytest.mark.parametrize("text", ["", "# nothing\n", 'description = "x"\n', "[driver]\n"])
def test_a_file_that_defines_no_aeb_and_does_not_say_so_is_refused(
        tmp_path: Path, text: str) -> None:
    with pytest.raises(DefinitionError, match=r"empty\.toml: aeb: no \[aeb\] table"):
        load_system(_write(tmp_path, text, "empty.toml"))
    assert load_system(_write(tmp_path, text + "aeb = false\n" if "[" not in text
                              else "aeb = false\n" + text, "off.toml")).aeb is None


@pytest.mark.parametrize(("old", "new"), [
    ("ttc_s = 0.6", "ttc_s = 1e300"), ("deceleration_mps2 = 10.0", "deceleration_mps2 = 1e300"),
    ("release_factor = 1.5", "release_factor = 1e300"), ("jerk_mps3 = 40.0", "jerk_mps3 = 1e300"),
    ("mount_x_m = 0.0", "mount_x_m = 1e300"), ("max_speed_kmh = 250.0", "max_speed_kmh = 1e300"),
    ("reaction_shape = 7.0", "reaction_shape = 1e300"),
])
def test_absurd_values_are_refused_by_the_declared_bounds(
        tmp_path: Path, old: str, new: str) -> None:
    assert old in THREE
    with pytest.raises(DefinitionError, match="is out of range"):
        load_system(_write(tmp_path, THREE.replace(old, new, 1), "huge.toml"))


def test_the_parameter_classes_report_every_bad_setting_with_its_range() -> None:
    with pytest.raises(SettingsError) as info:
        AEBParams(ttc_horizon=-1.0, release="later", full_ttc=1e300)
    assert [p.name for p in info.value.problems] == ["ttc_horizon", "full_ttc", "release"]
    assert "AEBParams.ttc_horizon: -1.0 is out of range (allowed: (0, 30] s)" in str(info.value)


def test_the_readme_tables_are_the_ones_derived_from_the_declarations() -> None:
    readme = (ROOT / "adas" / "README.md").read_text(encoding="utf-8")
    assert readme_tables() in readme
