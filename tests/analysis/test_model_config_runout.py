"""Run-out settings in a model configuration file (``vfs compare --model``): the key
``runout`` sets fields of RunoutParams by name, checked by their declarations; the
contacts it switches on act after the separation only."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vfs.analysis.model_config import load_model_config, read_model_config
from vfs.errors import ParameterError


def write(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "model.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_runout_settings_reach_the_simulation_parameters(tmp_path: Path) -> None:
    path = write(tmp_path, {"runout": {"contact": True, "contact_restitution": 0.2},
                            "effects": []})
    params = load_model_config(path)
    assert params.runout.contact is True
    assert params.runout.contact_restitution == 0.2
    assert params.effects == ()
    assert read_model_config(path) == ()
    assert load_model_config(write(tmp_path, {})).runout.contact is False


@pytest.mark.parametrize(("runout", "words"), [
    ({"contacts": True}, ["'runout'", "contacts", "contact_restitution"]),
    ({"contact_restitution": 1.5}, ["'runout'", "contact_restitution", "[0, 1]"]),
    ({"contact": "yes"}, ["'runout'", "contact", "boolean"]),
    ([True], ["'runout' must be an object"]),
])
def test_bad_runout_settings_are_refused_by_name(tmp_path: Path, runout: object,
                                                 words: list[str]) -> None:
    path = write(tmp_path, {"runout": runout})
    with pytest.raises(ParameterError) as err:
        load_model_config(path)
    message = str(err.value)
    assert str(path) in message
    for word in words:
        assert word in message


def test_contacts_from_a_model_file_change_the_runout_not_the_impact(tmp_path: Path) -> None:
    """The contacts act after the separation: delta-v and the impact are those of the
    default model, and on the bundled cases some rest positions move."""
    from vfs.database import open_database
    from vfs.simulation import CaseBatch, results_table, simulate_cases

    batch = CaseBatch.from_database(open_database("default", where="case_id <= 40"))
    default = results_table(batch, simulate_cases(batch))
    params = load_model_config(write(tmp_path, {"runout": {"contact": True}}))
    contact = results_table(batch, simulate_cases(batch, params=params))
    for col in ("delta_v1", "delta_v2", "ees1", "impact_type", "pdof1"):
        np.testing.assert_array_equal(contact[col], default[col], err_msg=col)
    moved = np.hypot(contact["rest_x1"] - default["rest_x1"],
                     contact["rest_y1"] - default["rest_y1"])
    assert np.nanmax(moved) > 0.01
