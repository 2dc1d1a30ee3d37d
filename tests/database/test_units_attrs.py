"""Units and descriptions in ``frame.attrs``: every loader gives them (SI), every frame pandas
derives keeps them, and they are shared read-only dicts (:class:`ColumnTexts`) that pandas does
not deep-copy into each derived frame (issue 37: a quarter of a million ``copy.deepcopy``
calls per 3,000 cases)."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pandas as pd
import pytest

from vfs.database import load_database, open_database, save_database
from vfs.database.io import iter_table, load_cases
from vfs.database.metadata import ColumnTexts, with_units


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    db = open_database("default", where="case_id <= 12")
    return save_database(db, tmp_path_factory.mktemp("attrs") / "db")


def test_loaded_tables_and_derived_frames_share_read_only_units(folder):
    db = load_database(folder)
    traj = db.trajectories
    units = traj.attrs["units"]
    assert isinstance(units, ColumnTexts) and units["speed"] == "m/s"
    assert db.reconstruction.attrs["units"]["pdof1"] == "rad"  # SI in memory
    derived = [traj["speed"], traj[["t", "speed"]], traj.iloc[:5], traj.copy(),
               traj[traj["participant"] == 1], traj.astype({"t": float})]
    for frame in derived:  # shared, not copied: no deep copy per column access
        assert frame.attrs["units"] is units
        assert frame.attrs["descriptions"] is traj.attrs["descriptions"]
    with pytest.raises(TypeError, match="read-only"):
        units["speed"] = "km/h"
    with pytest.raises(TypeError, match="read-only"):
        units.update(speed="km/h")
    assert units["speed"] == "m/s"
    derived[0].attrs["units"] = {**units, "speed": "km/h"}  # a new dict changes one frame
    assert traj.attrs["units"]["speed"] == "m/s"


def test_column_texts_are_a_dict_that_copies_pickles_and_writes_as_one(tmp_path):
    texts = ColumnTexts({"speed": "m/s", "t": "s"})
    assert texts == {"speed": "m/s", "t": "s"} and isinstance(texts, dict)
    assert copy.deepcopy(texts) is texts and copy.copy(texts) is texts
    again = pickle.loads(pickle.dumps(texts))
    assert again == texts and isinstance(again, ColumnTexts)
    frame = with_units(pd.DataFrame({"speed": [1.0, 2.0], "t": [0.0, 0.1]}), "trajectories")
    frame.to_parquet(tmp_path / "f.parquet")  # pandas stores attrs as JSON
    assert pd.read_parquet(tmp_path / "f.parquet").attrs["units"] == frame.attrs["units"]


def test_every_reader_gives_the_same_si_units(folder):
    db = load_database(folder)
    ids = db.case_ids[:3]
    assert load_cases(folder).attrs == db.cases.attrs
    for name in ("cases", "participants", "trajectories", "reconstruction"):
        part = next(iter_table(folder, name, ids))
        assert part.attrs == getattr(db, name).attrs, name
        assert isinstance(part.attrs["units"], ColumnTexts)


def test_raw_frames_read_from_files_carry_no_stale_attrs(tmp_path):
    # the files store the attrs they were written with; the loaders replace them by the
    # schema's (SI) ones, so a table written with other attrs loads with the right units
    folder = save_database(open_database("default", where="case_id <= 12"), tmp_path / "db")
    frame = pd.read_parquet(folder / "trajectories.parquet")
    assert frame.attrs  # pandas keeps what the file stores
    frame.attrs = {"units": {"speed": "furlong/fortnight"}}
    frame.to_parquet(folder / "trajectories.parquet", index=False)
    db = load_database(folder)
    assert db.trajectories.attrs["units"]["speed"] == "m/s"
    assert next(iter_table(folder, "trajectories")).attrs["units"]["speed"] == "m/s"
    np.testing.assert_array_equal(db.trajectories["speed"].to_numpy(), frame["speed"].to_numpy())
