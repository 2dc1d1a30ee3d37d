"""Staged-test errors of ``vfs compare``: delta-v, heading change and range error.

A hand-built test with known numbers checks each formula; a database whose reconstruction
rows are marked as measurements gets the section, its files and the published errors of
other codes side by side.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from vfs.analysis.compare import compare_database
from vfs.analysis.staged_tests import staged_summary, staged_test_errors
from vfs.database import open_database
from vfs.report.compare import write_comparison_report


def test_each_error_follows_its_definition():
    rec = pd.DataFrame({
        "case_id": [7], "outcome_source": ["measurement"],
        "x1": [0.0], "y1": [0.0], "yaw1": [0.1], "rest_x1": [3.0], "rest_y1": [4.0],
        "rest_yaw1": [0.1 + math.radians(90.0)], "delta_v1": [10.0],
        "x2": [1.0], "y2": [1.0], "yaw2": [0.0], "rest_x2": [np.nan], "rest_y2": [np.nan],
        "rest_yaw2": [np.nan], "delta_v2": [np.nan],
        "paper_simon_range_error1": [0.08], "paper_simon_range_error2": [np.nan],
    })
    vfs = pd.DataFrame({
        "case_id": [7], "x1": [0.2], "y1": [0.0], "yaw1": [0.2],
        "rest_x1": [3.0 + 0.6], "rest_y1": [4.0 + 0.8],  # 1 m off a 5 m run-out
        "rest_yaw1": [0.2 + math.radians(90.0) + 2 * math.pi + math.radians(10.0)],
        "delta_v1": [11.5], "x2": [1.0], "y2": [1.0], "yaw2": [0.0], "rest_x2": [2.0],
        "rest_y2": [2.0], "rest_yaw2": [0.0], "delta_v2": [3.0],
    })
    st = staged_test_errors(rec, vfs)
    one = st[st["vehicle"] == 1].iloc[0]
    assert one["runout_range"] == pytest.approx(5.0)
    assert one["rest_distance"] == pytest.approx(1.0)
    assert one["range_error"] == pytest.approx(0.2)
    assert one["delta_v_error"] == pytest.approx(0.15)
    # turned 100 deg (plus a full turn) against 90 deg measured: 10 deg
    assert one["heading_change_error"] == pytest.approx(math.radians(10.0))
    assert one["simon_range_error"] == pytest.approx(0.08)
    two = st[st["vehicle"] == 2].iloc[0]
    assert np.isnan(two["range_error"]) and np.isnan(two["delta_v_error"])
    summary = staged_summary(st).set_index(["code", "metric"])
    assert summary.loc[("vfs", "range_error"), "n"] == 1
    assert summary.loc[("simon", "range_error"), "mean"] == pytest.approx(0.08)


def test_rows_that_are_not_measurements_give_no_staged_table():
    rec = pd.DataFrame({"case_id": [1], "outcome_source": ["reconstruction"]})
    assert staged_test_errors(rec, pd.DataFrame({"case_id": [1]})).empty


def test_compare_writes_the_staged_section_for_measurement_rows(tmp_path):
    db = open_database("default", where="case_id <= 3")
    rec = db.reconstruction.copy()
    rec["outcome_source"] = "measurement"
    rec["paper_edsmac4_range_error1"] = 0.1
    rec["paper_edsmac4_range_error2"] = 0.12
    db = dataclasses.replace(db, reconstruction=rec).normalised()
    c = compare_database(db)
    assert c.staged is not None and len(c.staged) == 2 * len(rec)
    assert np.isfinite(c.staged["range_error"]).all()
    files = write_comparison_report(c, tmp_path, sketches=0, case_pages=False)
    table = pd.read_csv(files["staged_tests"])
    assert "edsmac4_range_error" in table.columns
    report = (tmp_path / "report.md").read_text()
    assert "Staged tests" in report and "edsmac4 range error" in report
    assert "staged_summary" in c.to_dict()
