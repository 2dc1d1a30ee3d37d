"""Publishable study reports: provenance, synthetic data said so, the database never as a
local path, systems described from their parameters, paired system differences, contents and
colours (vfs.report.provenance, vfs.adas.describe, vfs.analysis.system_differences).
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from vfs.adas import get_system
from vfs.adas.describe import describe_system
from vfs.analysis.effectiveness import effectiveness
from vfs.analysis.system_differences import system_differences
from vfs.report.effectiveness import write_effectiveness_report
from vfs.report.figures import COLORS, RUN_COLORS
from vfs.report.provenance import database_argument, database_label, is_synthetic
from vfs.report.render import heading_anchor
from vfs.study import load_study, run_study

WHERE = "case_id IN (1, 2, 3, 5, 8, 13, 21, 34, 55, 89)"


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "s"
    run_study("default", ["three-stage", "ideal"], out, engine="serial", where=WHERE,
              progress=False)
    return load_study(out)


def test_database_is_shown_relative_never_as_a_local_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    inside = tmp_path / "data" / "db"
    inside.mkdir(parents=True)
    assert database_label({"db_reference": str(inside)}) == "data/db"
    assert database_label({"db_reference": "/somewhere/else/project/db"}) == "project/db"
    assert database_label({"db_reference": "default"}) == "default (bundled)"
    assert database_argument({"db_reference": "default"}) == "default"
    assert database_label({"db_reference": "s3://bucket/db"}) == "s3://bucket/db"


def test_system_description_follows_the_parameters_run():
    s = get_system("three-stage")
    changed = dataclasses.replace(s, aeb=dataclasses.replace(s.aeb, full_ttc=1.0))
    assert "full braking (demand 10 m/s^2) at TTC 0.6 s" in describe_system(s)
    assert "full braking (demand 10 m/s^2) at TTC 1 s" in describe_system(changed)
    assert changed.description == s.description  # the free text alone would not show it
    assert describe_system(get_system("none")).startswith("no AEB")


def test_paired_differences_are_the_difference_of_the_shares(study):
    eff = effectiveness(study.table, n_boot=200, seed=1)
    diff = system_differences(eff)
    m = eff.metrics
    share = {s: float(m[(m.group == "all") & (m.metric == "avoided_share")
                        & (m.system == s)]["estimate"].iloc[0]) for s in ("three-stage", "ideal")}
    row = diff[diff.outcome == "avoided_share"].iloc[0]
    assert (row.system_a, row.system_b) == ("three-stage", "ideal")
    # identity: the mean of the paired differences is the difference of the means
    assert row.difference == pytest.approx(100 * (share["ideal"] - share["three-stage"]))
    assert row.value_b - row.value_a == pytest.approx(row.difference)
    assert row.low <= row.difference <= row.high
    swapped = system_differences(eff, pairs=[("ideal", "three-stage")], seed=1)
    assert swapped.iloc[0].difference == pytest.approx(-row.difference)


def test_report_has_provenance_synthetic_note_contents_and_no_local_path(study, tmp_path):
    write_effectiveness_report(study.path, n_boot=50, out=tmp_path / "r", list_cases=1)
    md = (tmp_path / "r" / "report.md").read_text(encoding="utf-8")
    html = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    manifest = json.loads((Path(study.path) / "study.json").read_text())
    assert is_synthetic(manifest)
    assert "Synthetic data" in md and "## Provenance" in md
    assert manifest["data_hash"][:16] in md
    assert manifest["versions"]["vfs"] in md
    assert "Systems compared with each other" in md
    assert "at TTC 0.6 s" in md  # the parameters, generated
    # the headline figure comes before the first section
    assert md.index("![") < md.index("## The study")
    # every contents link points at a heading id of the HTML page
    links = re.findall(r'href="#([^"]+)"', html)
    ids = set(re.findall(r'<h\d id="([^"]+)"', html))
    assert links and set(links) <= ids
    for page in [tmp_path / "r" / "report.md", *(tmp_path / "r" / "cases").glob("*.html")]:
        text = page.read_text(encoding="utf-8")
        assert str(Path.cwd().resolve()) not in text and "scenarios/databases" not in text


def test_heading_anchor_is_github_like():
    assert heading_anchor("Crashes avoided") == "crashes-avoided"
    assert heading_anchor("Per accident type (avoided share)") == \
        "per-accident-type-avoided-share"


def test_run_colours_never_reuse_the_vehicle_colours():
    assert not set(RUN_COLORS) & set(COLORS)
    assert len(set(RUN_COLORS)) == len(RUN_COLORS)
    assert np.all([c.startswith("#") for c in RUN_COLORS])


def test_comparison_report_has_provenance_and_the_synthetic_note(tmp_path):
    from vfs.analysis.compare import compare_database
    from vfs.database import open_database
    from vfs.report.compare import write_comparison_report

    db = open_database("default", "case_id IN (10, 20, 50, 60, 150, 480)")
    write_comparison_report(compare_database(db), tmp_path / "c", database=db, top=2,
                            sketches=0, case_pages=False, database_reference="default")
    md = (tmp_path / "c" / "report.md").read_text(encoding="utf-8")
    assert "## Provenance" in md and "Synthetic data" in md and "default (bundled)" in md
    assert "scenarios/databases" not in md
