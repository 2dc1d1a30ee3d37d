"""Tests of ``vfs compare``: VFS against the reconstructions (Momentum Based Impact Model paper)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from vfs.analysis.compare import (
    DEFAULT_MARGINS,
    GROUP_ALL,
    GROUP_CHANGED,
    GROUP_FULL,
    GROUP_SLIDING,
    GROUPS,
    STATUS_AVOIDED,
    STATUS_ERROR,
    STATUS_MISSING,
    STATUS_OK,
    compare_database,
    parse_margins,
    read_run_table,
)
from vfs.analysis.model_config import load_model_config
from vfs.cli import main
from vfs.errors import DataError, ParameterError
from vfs.report.compare import write_comparison_report
from vfs.scenarios.generator import NO_NOISE, generate_database
from vfs.units import KMH_PER_MS

# ----------------------------------------------------------------------------
# Fixtures
# ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def study36():
    """the Momentum Based Impact Model paper's sample (structure-aware POI and realistic noise
    hidden in the data).

    Seed 0 (measured: 13 both full, 16 full -> sliding, 7 both sliding): the
    chi-squared test is significant and none of the full-impact t-tests is
    (p = 0.093, 0.406, 0.176), as in the paper.
    """
    db, _ = generate_database("study36", seed=0)
    # the reconstructed impact parameters given to the simulation (not the paper's protocol:
    # test_default_impact_parameters_follow_the_papers_protocol)
    return db, compare_database(db, impact_parameters="reconstruction")


@pytest.fixture(scope="module")
def clean():
    """No hidden effect and no noise: the reconstruction is the model."""
    db, _ = generate_database("clean", seed=1)
    return compare_database(db, impact_parameters="reconstruction")


def _run_table_from_reconstruction(rec: pd.DataFrame) -> pd.DataFrame:
    """A baseline run table (results_table columns, angles in rad) equal to ``rec`` (SI)."""
    run = rec.copy()
    run["collided"] = True
    run["system"] = "baseline"
    run["error"] = None
    return run


@pytest.fixture(scope="module")
def small_db():
    """Four reconstructed cases with hand-set impact types and delta-v (SI)."""
    db, _ = generate_database("clean", n_cases=8, seed=3)
    ids = db.reconstruction["case_id"].to_numpy()[:4]
    db = db.subset(ids)
    rec = db.reconstruction.copy()
    rec["impact_type"] = ["full", "full", "full", "sliding"]
    rec["delta_v1"] = [10.0, 14.0, 20.0, 8.0]
    rec["delta_v2"] = [12.0, 16.0, 22.0, 9.0]
    return replace(db, reconstruction=rec)


# ----------------------------------------------------------------------------
# The Momentum Based Impact Model paper reproduced on the synthetic study36 sample
# ----------------------------------------------------------------------------


def test_study36_reproduces_seed001(study36):
    _, c = study36
    table = c.contingency.table
    # more sliding impacts in the VFS than in the reconstruction (Figure 4)
    assert table["sliding"].sum() > table.loc["sliding"].sum()
    assert table.loc["full", "sliding"] > 0 and table.loc["sliding", "full"] == 0
    assert (table.loc["full", "full"], table.loc["full", "sliding"],
            table.loc["sliding", "sliding"]) == (13, 16, 7)
    assert c.contingency.chi2_pvalue < 0.05  # the paper's test
    assert c.contingency_impacts.mcnemar_pvalue < 0.05  # the paired test agrees
    assert 0.0 < c.contingency.kappa < 0.6
    # full impacts: no significant difference in delta-v, EES, change of velocity angle
    t1 = c.table1.set_index(["outcome", "group"])
    for outcome in ("delta_v", "ees", "velocity_angle_change"):
        row = t1.loc[(outcome, GROUP_FULL)]
        assert row["n"] == 2 * 13
        assert row["p_value"] > 0.05, outcome
    # Table 1 layout: six rows, full first, in km/h and degrees
    assert list(c.table1["parameter"])[0] == "Delta-v, full impacts [km/h]"
    assert list(c.table1["group"]) == [GROUP_FULL] * 3 + [GROUP_SLIDING] * 3
    paired = c.paired.set_index(["outcome", "group"])
    dv = paired.loc[("delta_v", GROUP_FULL)]
    assert t1.loc[("delta_v", GROUP_FULL), "mean_vfs"] == pytest.approx(
        dv["mean_model"] * KMH_PER_MS)
    assert 40.0 < t1.loc[("delta_v", GROUP_FULL), "mean_reconstruction"] < 60.0
    # POI distances: n = 2 x cases per group
    poi = c.poi_distances.set_index("group")
    assert poi.loc[GROUP_ALL, "n"] == 72
    assert poi.loc[GROUP_FULL, "n"] == 26 and poi.loc[GROUP_SLIDING, "n"] == 14
    assert poi.loc[GROUP_CHANGED, "n"] == 32
    assert 0.0 < poi.loc[GROUP_ALL, "mean"] < 0.3


def test_paired_table_structure(study36):
    _, c = study36
    assert set(c.outcomes) >= {"delta_v", "ees", "velocity_angle_change", "post_speed",
                               "rest_x", "rest_y", "pdof", "energy_loss"}
    assert len(c.paired) == len(c.outcomes) * len(GROUPS)
    assert list(c.paired["group"].iloc[:4]) == list(GROUPS)
    # Holm never lowers a p-value and keeps it in [0, 1]
    p, ph = c.paired["t_pvalue"].to_numpy(float), c.paired["t_pvalue_holm"].to_numpy(float)
    ok = np.isfinite(p)
    assert np.all(ph[ok] >= p[ok] - 1e-15) and np.all(ph[ok] <= 1.0)
    # vehicle-level rows stack both vehicles, energy loss is per case
    rows = c.paired.set_index(["outcome", "group"])
    assert rows.loc[("delta_v", GROUP_ALL), "n"] == 72
    assert rows.loc[("energy_loss", GROUP_ALL), "n"] == 36
    assert rows.loc[("delta_v", GROUP_ALL), "n_cases"] == 36
    # angles are compared as the smallest signed difference
    assert np.all(np.abs(c.pairs["difference_pdof"]) <= math.pi)
    # ranked worst first
    score = c.case_errors["score"].to_numpy(float)
    assert np.all(np.diff(score) <= 0.0)
    assert list(c.case_errors["rank"]) == list(range(1, 37))


def test_model_config_with_the_hidden_effect_removes_the_discrepancy(study36, tmp_path):
    db, _ = study36
    cfg = tmp_path / "model.json"
    cfg.write_text(json.dumps({"name": "structure-aware",
                               "effects": [{"name": "structure_poi", "parameters": {}}]}))
    params = load_model_config(cfg)
    assert [e.name for e in params.effects] == ["structure_poi"]
    c = compare_database(db, params=params, impact_parameters="reconstruction")
    assert c.contingency.n_discordant == 0
    assert c.contingency.kappa == pytest.approx(1.0)
    assert c.poi_distances.set_index("group").loc[GROUP_ALL, "max"] < 1e-9


def test_load_model_config_errors(tmp_path):
    with pytest.raises(DataError):
        load_model_config(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(DataError):
        load_model_config(bad)
    unknown = tmp_path / "unknown.json"
    unknown.write_text(json.dumps({"effects": [], "penetration": 0.03}))
    with pytest.raises(ParameterError, match="unknown key"):
        load_model_config(unknown)
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps({"effects": [{"name": "no_such_effect"}]}))
    with pytest.raises(ParameterError):
        load_model_config(wrong)
    empty = tmp_path / "empty.json"
    empty.write_text("{}")
    assert load_model_config(empty).effects == ()


# ----------------------------------------------------------------------------
# No hidden effect, no noise: everything agrees exactly
# ----------------------------------------------------------------------------


def _assert_identical(c) -> None:
    assert c.status_counts[STATUS_OK] == len(c.cases)
    diffs = c.pairs.filter(like="difference_").to_numpy(float)
    assert np.all(diffs[np.isfinite(diffs)] == 0.0)
    assert np.all(c.pairs["poi_distance"] == 0.0)
    assert np.all(c.pairs["rest_distance"] == 0.0)
    table = c.contingency.table.to_numpy()
    assert np.all(table == np.diag(np.diag(table)))
    assert c.contingency.kappa == 1.0
    assert c.contingency.chi2_pvalue == 1.0
    assert c.contingency.mcnemar_pvalue == 1.0
    assert c.contingency.bowker_pvalue == 1.0
    assert c.contingency.stuart_maxwell_pvalue == 1.0
    tested = c.paired[c.paired["n"] >= 3]
    assert len(tested) > 0
    for col in ("t_pvalue", "wilcoxon_pvalue", "case_t_pvalue", "t_pvalue_holm"):
        assert np.all(tested[col] == 1.0), col
    assert np.all(tested["mean_difference"] == 0.0)
    assert np.all(tested["loa_low"] == 0.0) and np.all(tested["loa_high"] == 0.0)
    assert np.all(tested["tost_pvalue"] == 0.0) and tested["equivalent"].all()
    assert np.all(c.case_errors["score"] == 0.0)


def test_clean_database_agrees_exactly(clean):
    _assert_identical(clean)
    assert set(clean.contingency.categories) == {"full", "sliding"}
    assert clean.table1["p_value"].eq(1.0).all()


def test_default_preset_without_hidden_effects_agrees_exactly():
    db, _ = generate_database("default", n_cases=60, seed=2, hidden=(), noise=NO_NOISE)
    _assert_identical(compare_database(db, impact_parameters="reconstruction"))


# ----------------------------------------------------------------------------
# Hand-computed example through a run table
# ----------------------------------------------------------------------------


def _hand_run(small_db) -> pd.DataFrame:
    run = _run_table_from_reconstruction(small_db.reconstruction)
    run["impact_type"] = ["full", "full", "sliding", "sliding"]
    run["delta_v1"] = run["delta_v1"] + np.array([1.0, 3.0, 0.0, 2.0])
    run["delta_v2"] = run["delta_v2"] + np.array([2.0, -1.0, 0.0, 4.0])
    run["poi_x"] = run["poi_x"] + np.array([0.1, 0.2, 0.3, 0.4])  # same poses
    return run


def test_hand_computed_example(small_db):
    run = _hand_run(small_db).iloc[[2, 0, 3, 1]]  # rows are matched by case_id
    c = compare_database(small_db, run=run)
    assert list(c.cases["group"]) == [GROUP_FULL, GROUP_FULL, GROUP_CHANGED, GROUP_SLIDING]
    t = c.contingency.table
    assert (t.loc["full", "full"], t.loc["full", "sliding"], t.loc["sliding", "sliding"],
            t.loc["sliding", "full"]) == (2, 1, 1, 0)
    # POI distances: the VFS POI moved by 0.1 .. 0.4 m at the same poses, both vehicles
    poi = c.poi_distances.set_index("group")
    assert poi.loc[GROUP_ALL, "n"] == 8 and poi.loc[GROUP_ALL, "mean"] == pytest.approx(0.25)
    assert poi.loc[GROUP_ALL, "median"] == pytest.approx(0.25)
    assert poi.loc[GROUP_ALL, "sd"] == pytest.approx(np.std([.1, .1, .2, .2, .3, .3, .4, .4],
                                                            ddof=1))
    assert poi.loc[GROUP_FULL, "n"] == 4 and poi.loc[GROUP_FULL, "mean"] == pytest.approx(0.15)
    assert poi.loc[GROUP_SLIDING, "n"] == 2
    assert poi.loc[GROUP_SLIDING, "mean"] == pytest.approx(0.4)
    assert poi.loc[GROUP_CHANGED, "mean"] == pytest.approx(0.3)
    assert math.isnan(poi.loc[GROUP_FULL, "mean_ci_low"])  # two cases: no CI
    assert np.isfinite(poi.loc[GROUP_ALL, "mean_ci_low"])
    # Table 1, delta-v of full impacts: vehicles (10, 12), (14, 16) m/s, VFS +1, +2, +3, -1
    t1 = c.table1.set_index(["outcome", "group"])
    row = t1.loc[("delta_v", GROUP_FULL)]
    d = np.array([1.0, 2.0, 3.0, -1.0])
    t_stat = d.mean() / (d.std(ddof=1) / 2.0)
    assert row["n"] == 4
    assert row["mean_reconstruction"] == pytest.approx(13.0 * 3.6)
    assert row["mean_vfs"] == pytest.approx(14.25 * 3.6)
    assert row["mean_difference"] == pytest.approx(1.25 * 3.6)
    assert row["p_value"] == pytest.approx(2.0 * sps.t.sf(t_stat, 3))
    # two sliding vehicles: means reported, no test (n < 3)
    row = t1.loc[("delta_v", GROUP_SLIDING)]
    assert row["n"] == 2 and row["mean_vfs"] == pytest.approx((10.0 + 13.0) / 2 * 3.6)
    assert math.isnan(row["p_value"])
    # EES untouched: all differences zero -> p = 1 by convention
    assert t1.loc[("ees", GROUP_FULL), "p_value"] == 1.0
    # the worst case is case 4 (delta-v +4 m/s = 14.4 km/h, 2.88 x the 5 km/h margin)
    worst = c.case_errors.iloc[0]
    assert worst["case_id"] == small_db.reconstruction["case_id"].iloc[3]
    assert worst["worst"] == "delta_v2"
    assert worst["score"] == pytest.approx(4.0 / DEFAULT_MARGINS["delta_v"])
    assert worst["rel_error_delta_v2"] == pytest.approx(4.0 / 9.0)


def test_poi_distance_uses_the_vehicle_frames(small_db):
    """Rotating and moving the whole VFS scene leaves every POI in the vehicle frames."""
    run = _run_table_from_reconstruction(small_db.reconstruction)
    angle, shift = 0.7, np.array([12.0, -3.0])
    c_, s_ = math.cos(angle), math.sin(angle)
    for xc, yc in (("poi_x", "poi_y"), ("x1", "y1"), ("x2", "y2")):
        x, y = run[xc].to_numpy(float), run[yc].to_numpy(float)
        run[xc], run[yc] = c_ * x - s_ * y + shift[0], s_ * x + c_ * y + shift[1]
    for yaw in ("yaw1", "yaw2"):
        run[yaw] = run[yaw] + angle
    c = compare_database(small_db, run=run)
    assert np.allclose(c.pairs["poi_distance"], 0.0, atol=1e-9)
    # while a POI moved 0.5 m along vehicle 1's axis is 0.5 m away in both frames
    run2 = _run_table_from_reconstruction(small_db.reconstruction)
    yaw1 = run2["yaw1"].to_numpy(float)
    run2["poi_x"] += 0.5 * np.cos(yaw1)
    run2["poi_y"] += 0.5 * np.sin(yaw1)
    c2 = compare_database(small_db, run=run2)
    assert np.allclose(c2.pairs["poi_distance"], 0.5)
    p1 = c2.pairs[c2.pairs["vehicle"] == 1]
    assert np.allclose(p1["vfs_poi_x"] - p1["reference_poi_x"], 0.5)
    assert np.allclose(p1["vfs_poi_y"] - p1["reference_poi_y"], 0.0, atol=1e-12)


# ----------------------------------------------------------------------------
# Degenerate inputs
# ----------------------------------------------------------------------------


def test_avoided_error_and_missing_cases_are_reported_and_excluded(small_db):
    run = _run_table_from_reconstruction(small_db.reconstruction)
    run.loc[0, "error"] = "solver failed"
    run.loc[1, ["collided", "impact_type"]] = [False, "none"]
    run = run.drop(index=2)
    other = run.iloc[[0]].assign(system="aeb", error=None)  # not a baseline row
    c = compare_database(small_db, run=pd.concat([run, other]))
    assert list(c.cases["status"]) == [STATUS_ERROR, STATUS_AVOIDED, STATUS_MISSING, STATUS_OK]
    assert c.excluded["status"].tolist() == [STATUS_ERROR, STATUS_AVOIDED, STATUS_MISSING]
    assert c.excluded["error"].iloc[0] == "solver failed"
    assert len(c.pairs) == 2 and len(c.case_errors) == 1
    # "none" enters the contingency; McNemar needs 2 x 2: all cases -> NaN,
    # the cases with an impact in both -> defined
    assert c.contingency.categories == ("full", "sliding", "none")
    assert c.contingency.n == 2 and c.contingency.table.loc["full", "none"] == 1
    assert math.isnan(c.contingency.mcnemar_pvalue)
    assert np.isfinite(c.contingency.bowker_pvalue)
    assert c.contingency_impacts.n == 1 and c.contingency_impacts.mcnemar_pvalue == 1.0
    # one compared case: descriptive statistics only
    rows = c.paired.set_index(["outcome", "group"])
    assert rows.loc[("delta_v", GROUP_ALL), "n"] == 2
    assert math.isnan(rows.loc[("delta_v", GROUP_ALL), "t_pvalue"])
    assert rows.loc[("delta_v", GROUP_FULL), "n"] == 0


def test_all_cases_avoided_gives_a_defined_empty_comparison(small_db, tmp_path):
    run = _run_table_from_reconstruction(small_db.reconstruction)
    run["collided"] = False
    run["impact_type"] = "none"
    c = compare_database(small_db, run=run)
    assert c.status_counts[STATUS_AVOIDED] == 4 and c.pairs.empty
    assert c.contingency.table["none"].sum() == 4
    assert c.contingency.chi2_pvalue < 0.05  # the types differ completely
    assert c.contingency_impacts.n == 0 and math.isnan(c.contingency_impacts.kappa)
    assert c.paired["n"].eq(0).all() and c.paired["t_pvalue"].isna().all()
    assert c.table1["n"].eq(0).all()
    assert c.poi_distances["n"].eq(0).all() and c.poi_distances["mean"].isna().all()
    files = write_comparison_report(c, tmp_path / "empty", sketches=2)
    assert files["report_html"].is_file()
    json.loads(files["json"].read_text())


def test_a_category_never_observed(small_db):
    """Only full impacts on both sides: the sliding row and column stay zero."""
    rec = small_db.reconstruction.assign(impact_type="full")
    db = replace(small_db, reconstruction=rec)
    run = _run_table_from_reconstruction(rec)
    c = compare_database(db, run=run)
    assert c.contingency.table.loc["sliding"].sum() == 0
    assert c.contingency.table["sliding"].sum() == 0
    assert c.contingency.chi2_pvalue == 1.0 and c.contingency.mcnemar_pvalue == 1.0
    assert math.isnan(c.contingency.kappa)  # p_e = 1: kappa undefined
    t1 = c.table1.set_index(["outcome", "group"])
    assert t1.loc[("delta_v", GROUP_SLIDING), "n"] == 0
    assert math.isnan(t1.loc[("delta_v", GROUP_SLIDING), "p_value"])


def test_run_table_validation(small_db, tmp_path):
    run = _run_table_from_reconstruction(small_db.reconstruction)
    with pytest.raises(DataError, match="poi_x"):
        compare_database(small_db, run=run.drop(columns=["poi_x"]))
    with pytest.raises(DataError, match="more than once"):
        compare_database(small_db, run=pd.concat([run, run.iloc[[0]]]))
    with pytest.raises(DataError, match="baseline"):
        read_run_table(run.assign(system="aeb"))
    with pytest.raises(DataError, match="impact type"):
        compare_database(small_db, run=run.assign(impact_type="crash"))
    with pytest.raises(DataError, match="not found"):
        read_run_table(tmp_path)
    (tmp_path / "study").mkdir()
    run.to_parquet(tmp_path / "study" / "runs.parquet")
    assert len(read_run_table(tmp_path / "study")) == 4


def test_margins():
    m = parse_margins("delta_v=3, ees=2m/s, velocity_angle_change=0.1rad, rest_x=0.5")
    assert m["delta_v"] == pytest.approx(3.0 / 3.6)
    assert m["ees"] == pytest.approx(2.0)
    assert m["velocity_angle_change"] == pytest.approx(0.1)
    assert m["rest_x"] == pytest.approx(0.5)
    assert parse_margins("pdof=5deg")["pdof"] == pytest.approx(math.radians(5.0))
    assert parse_margins("") == {}
    for bad in ("delta_v=3deg", "speed=3", "delta_v=-1", "delta_v", "delta_v=abc"):
        with pytest.raises(ParameterError):
            parse_margins(bad)


def test_margins_reach_the_tost(small_db):
    run = _hand_run(small_db)
    wide = compare_database(small_db, run=run, margins={"delta_v": 10.0})
    none = compare_database(small_db, run=run, margins={"delta_v": None})
    rows = wide.paired.set_index(["outcome", "group"])
    assert rows.loc[("delta_v", GROUP_FULL), "tost_margin"] == 10.0
    assert rows.loc[("delta_v", GROUP_FULL), "equivalent"]
    assert not none.paired.set_index(["outcome", "group"]).loc[("delta_v", GROUP_FULL),
                                                               "equivalent"]
    with pytest.raises(ParameterError):
        compare_database(small_db, run=run, margins={"delta_v": 0.0})
    with pytest.raises(ParameterError):
        compare_database(small_db, run=run, margins={"unknown": 1.0})


# ----------------------------------------------------------------------------
# Report and command line
# ----------------------------------------------------------------------------


def test_report_files(study36, tmp_path):
    _, c = study36
    files = write_comparison_report(c, tmp_path / "cmp", database=study36[0], top=5,
                                    sketches=2, case_pages=False)
    for key in ("json", "report_md", "report_html", "table1", "paired", "pairs_parquet",
                "case_errors", "contingency", "poi_distances", "rest_distances", "cases",
                "fig_impact_types", "fig_poi", "fig_boxplots", "fig_bland_altman",
                "fig_scatter", "fig_worst_1", "fig_worst_2"):
        assert files[key].is_file() and files[key].stat().st_size > 0, key
    data = json.loads(files["json"].read_text())
    assert data["contingency"]["table"] == [[13, 16], [0, 7]]
    assert len(data["table1"]) == 6
    md = files["report_md"].read_text()
    assert "Delta-v, full impacts [km/h]" in md and "figures/fig4_impact_types.png" in md
    assert "McNemar" in md and "kappa" in md
    html = files["report_html"].read_text()
    assert html.count("<img") >= 7
    t1 = pd.read_csv(files["table1"])
    assert list(t1.columns[:5]) == ["parameter", "outcome", "group", "n", "mean_reconstruction"]


def test_cli_writes_all_files(tmp_path, capsys):
    cfg = tmp_path / "model.json"
    cfg.write_text(json.dumps({"effects": []}))
    out = tmp_path / "compare"
    code = main(["compare", "--db", "default", "--where", "case_id <= 60", "--model", str(cfg),
                 "--margins", "delta_v=3,rest_x=0.5m", "--sketches", "1", "--no-case-pages",
                 "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "chi-squared" in printed and "report ->" in printed
    for name in ("comparison.json", "report.md", "report.html", "table1.csv", "paired.csv",
                 "paired.parquet", "pairs.parquet", "case_errors.csv", "contingency.csv",
                 "poi_distances.csv", "rest_distances.csv", "cases.csv",
                 "figures/fig4_impact_types.png", "figures/fig5_poi_positions.png",
                 "figures/fig6_boxplots.png", "figures/bland_altman.png",
                 "figures/scatter.png"):
        assert (out / name).is_file(), name
    assert len(list((out / "figures").glob("worst_*.png"))) == 1
    data = json.loads((out / "comparison.json").read_text())
    assert data["margins"]["delta_v"] == pytest.approx(3.0 / 3.6)
    assert len(data["cases"]) <= 60


def test_cli_user_errors(capsys, tmp_path):
    assert main(["compare", "--db", "default", "--margins", "delta_v=3deg",
                 "--out", str(tmp_path)]) == 2
    assert "does not fit" in capsys.readouterr().err
    assert main(["compare", "--db", "default", "--run", str(tmp_path / "nothing"),
                 "--out", str(tmp_path)]) == 2


# ----------------------------------------------------------------------------
# --impact-parameters
# ----------------------------------------------------------------------------


def test_impact_parameters_change_only_what_the_simulation_uses():
    from vfs.physics.impact import ImpactParams

    db, _ = generate_database("default", n_cases=60, seed=2, hidden=(), noise=NO_NOISE)
    rec = compare_database(db, impact_parameters="reconstruction")
    dflt = compare_database(db, impact_parameters="default")
    assert (rec.impact_parameters, dflt.impact_parameters) == ("reconstruction", "default")
    # without hidden effects and noise the reconstruction is the model with its own values
    _assert_identical(rec)
    # the pre-impact phase does not depend on them: same impact poses, closing speeds, POIs
    a, b = rec.pairs.set_index(["case_id", "vehicle"]), dflt.pairs.set_index(
        ["case_id", "vehicle"])
    for col in ("vfs_closing_speed", "vfs_poi_x", "vfs_poi_y"):
        if col in a:
            np.testing.assert_array_equal(a[col], b.loc[a.index, col])
    # the impact does: delta-v differs exactly where a case's values differ from the defaults
    d = ImpactParams()
    r = db.reconstruction.set_index("case_id")
    own = ~(np.isclose(r["restitution"], d.restitution)
            & np.isclose(r["contact_friction"], d.contact_friction))
    moved = ~np.isclose(a["vfs_delta_v"], b.loc[a.index, "vfs_delta_v"], rtol=0, atol=1e-9)
    moved_cases = set(a.index[moved].get_level_values(0))
    assert moved_cases and moved_cases <= set(r.index[own])
    # a database whose reconstructed values are the defaults: both settings agree exactly
    same = replace(db, reconstruction=db.reconstruction.assign(
        restitution=d.restitution, contact_friction=d.contact_friction))
    x = compare_database(same, impact_parameters="reconstruction")
    y = compare_database(same, impact_parameters="default")
    pd.testing.assert_frame_equal(x.pairs, y.pairs)
    with pytest.raises(ParameterError, match="impact_parameters"):
        compare_database(db, impact_parameters="expert")


def test_report_states_the_impact_parameters_first(tmp_path):
    from vfs.scenarios.generator import write_generated

    db, truth = generate_database("clean", n_cases=10, seed=4)
    folder = write_generated(db, truth, tmp_path / "db")
    out = tmp_path / "c"
    assert main(["compare", "--db", str(folder), "--out", str(out), "--sketches", "0",
                 "--no-case-pages"]) == 0
    # the title, then (after the synthetic-data warning, a block quote) the impact parameters
    lines = [ln for ln in (out / "report.md").read_text().splitlines()
             if ln.strip() and not ln.startswith(">")]
    assert lines[1].startswith("Impact parameters: the model's generic defaults")
    assert "restitution 0.1, contact friction 0.6" in lines[1]
