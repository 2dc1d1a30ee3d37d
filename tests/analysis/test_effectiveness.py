"""Effectiveness report: hand-computed figures, weights, CIs, exclusions, CLI."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.special import expit

from vfs.analysis.effectiveness import (
    ALL,
    bootstrap_sums,
    effectiveness,
    paired_runs,
    risk_curves_for,
)
from vfs.analysis.risk import MS_PER_MPH, get_risk_curve
from vfs.cli import main
from vfs.errors import DataError, ParameterError
from vfs.report.effectiveness import write_effectiveness_report
from vfs.study import normalise_runs

NAN = np.nan


def row(case_id: int, system: str, crash: bool, kind: str = "none", s1: float = NAN,
        s2: float = NAN, dv1: float = NAN, dv2: float = NAN, accident_type: int = 241,
        weight: float = 1.0, error: str = "") -> dict:
    return {"case_id": case_id, "system": system, "accident_type": accident_type,
            "weight": weight, "error": error, "collided": crash, "avoided": not crash,
            "impact_type": kind, "impact_speed1": s1, "impact_speed2": s2,
            "closing_speed": NAN if not crash else abs(s1 - s2), "delta_v1": dv1,
            "delta_v2": dv2}


def hand_table() -> pd.DataFrame:
    """4 cases: 3 baseline crashes, 2 of them avoided by 'aeb', one slowed down."""
    rows = [
        row(1, "baseline", True, "full", 20, 10, 10, 8),
        row(1, "aeb", False),
        row(2, "baseline", True, "sliding", 15, 5, 6, 4),
        row(2, "aeb", False),
        row(3, "baseline", True, "full", 20, 0, 12, 9, accident_type=601),
        row(3, "aeb", True, "full", 10, 0, 5, 4, accident_type=601),
        row(4, "baseline", False, accident_type=601),
        row(4, "aeb", False, accident_type=601),
    ]
    return pd.DataFrame(rows)


def estimates(eff, group: object = ALL) -> pd.Series:  # noqa: ANN001
    m = eff.metrics[(eff.metrics["system"] == "aeb") & (eff.metrics["group"] == group)]
    return m.set_index("metric")["estimate"]


def test_hand_computed_figures() -> None:
    eff = effectiveness(hand_table(), n_boot=200, seed=1)
    e = estimates(eff)
    assert e["crashes_baseline"] == 3 and e["crashes_treatment"] == 1
    assert e["crashes_avoided"] == 2 and e["crashes_new"] == 0
    assert e["avoided_share"] == pytest.approx(2 / 3)
    assert e["crash_reduction"] == pytest.approx(2 / 3)
    # impact speed (the faster vehicle): 20, 15, 20 -> treatment 0, 0, 10 [m/s]
    assert e["speed_baseline"] == pytest.approx(55 / 3)
    assert e["speed_treatment_all"] == pytest.approx(10 / 3)
    assert e["speed_reduction_all"] == pytest.approx(15.0)
    assert e["speed_reduction_all_rel"] == pytest.approx(45 / 55)
    assert e["speed_baseline_nav"] == pytest.approx(20.0)
    assert e["speed_treatment_nav"] == pytest.approx(10.0)
    assert e["speed_reduction_nav"] == pytest.approx(10.0)
    assert e["speed_reduction_nav_rel"] == pytest.approx(0.5)
    # delta-v (the larger of both): 10, 6, 12 -> 0, 0, 5
    assert e["dv_baseline"] == pytest.approx(28 / 3)
    assert e["dv_reduction_all"] == pytest.approx(23 / 3)
    assert e["dv_reduction_all_rel"] == pytest.approx(23 / 28)
    assert e["dv_reduction_nav"] == pytest.approx(7.0)
    # risk: NHTSA 2022 all-direction logistic curves in mph, summed over both drivers
    for level, (a, b) in {"MAIS3+": (-6.9540, 0.1637), "fatal": (-8.9819, 0.1603)}.items():
        p = lambda dv: expit(a + b * np.asarray(dv) / MS_PER_MPH)  # noqa: B023, E731
        base = p([10, 8, 6, 4, 12, 9]).sum()
        treat = p([5, 4]).sum()
        assert e[f"risk_{level}_baseline"] == pytest.approx(base, rel=1e-12)
        assert e[f"risk_{level}_treatment"] == pytest.approx(treat, rel=1e-12)
        assert e[f"risk_{level}_avoided"] == pytest.approx(base - treat, rel=1e-12)
        assert e[f"risk_{level}_reduction"] == pytest.approx(1 - treat / base, rel=1e-12)
    # per accident type
    assert estimates(eff, 241)["avoided_share"] == 1.0
    assert estimates(eff, 601)["avoided_share"] == 0.0
    assert estimates(eff, 601)["speed_reduction_nav"] == pytest.approx(10.0)
    # impact types: full -> none, sliding -> none, full -> full, none -> none
    ct = eff.crosstabs["aeb"]
    assert ct.loc["full", "none"] == 1 and ct.loc["sliding", "none"] == 1
    assert ct.loc["full", "full"] == 1 and ct.loc["none", "none"] == 1
    assert ct.to_numpy().sum() == 4
    # impact-speed distribution: avoided crashes count as 0 km/h
    cdf = eff.cdf[eff.cdf["system"] == "aeb"]
    assert cdf["share"].iloc[0] == pytest.approx(2 / 3)
    assert cdf["share"].iloc[-1] == pytest.approx(1.0)


def test_confidence_intervals_contain_the_estimates() -> None:
    for runs in (hand_table(), random_runs(120, np.random.default_rng(3))):
        eff = effectiveness(runs, n_boot=400, seed=2)
        m = eff.metrics[np.isfinite(eff.metrics["low"])]
        assert len(m) > 0.8 * len(eff.metrics)
        tol = 1e-9 * np.maximum(1.0, m["estimate"].abs())
        assert (m["low"] <= m["estimate"] + tol).all()
        assert (m["estimate"] <= m["high"] + tol).all()
        band = eff.cdf.dropna()
        assert ((band["low"] <= band["share"] + 1e-12)
                & (band["share"] <= band["high"] + 1e-12)).all()
    # reproducible from the seed, different with another seed
    a = effectiveness(hand_table(), n_boot=100, seed=5).metrics
    b = effectiveness(hand_table(), n_boot=100, seed=5).metrics
    c = effectiveness(random_runs(50, np.random.default_rng(1)), n_boot=100, seed=6).metrics
    d = effectiveness(random_runs(50, np.random.default_rng(1)), n_boot=100, seed=7).metrics
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(c["low"].fillna(0), d["low"].fillna(0))


def random_runs(n: int, rng: np.random.Generator) -> pd.DataFrame:
    rows = []
    for i in range(1, n + 1):
        kind = str(rng.choice(["full", "sliding"]))
        s1, s2 = rng.uniform(5, 30, 2)
        dv1, dv2 = rng.uniform(2, 20, 2)
        at = int(rng.choice([211, 241, 321]))
        crash = rng.random() < 0.9
        rows.append(row(i, "baseline", crash, kind, s1, s2, dv1, dv2, accident_type=at))
        for name, keep in (("a", 0.5), ("b", 0.8)):
            if crash and rng.random() < keep:
                f = rng.uniform(0.3, 1.0)
                rows.append(row(i, name, True, kind, s1 * f, s2 * f, dv1 * f, dv2 * f,
                                accident_type=at))
            else:
                rows.append(row(i, name, False, accident_type=at))
    return pd.DataFrame(rows)


def test_weights_are_frequency_weights() -> None:
    weighted = hand_table()
    weighted.loc[weighted["case_id"] == 1, "weight"] = 2.0
    duplicated = pd.concat([hand_table(), hand_table().query("case_id == 1").assign(case_id=5)],
                           ignore_index=True)
    a = effectiveness(weighted, n_boot=20).metrics
    b = effectiveness(duplicated, n_boot=20).metrics
    pd.testing.assert_series_equal(a["estimate"], b["estimate"], rtol=1e-12)
    assert a.loc[a["metric"] == "crashes_baseline", "weight"].iloc[0] == 5.0
    assert estimates(effectiveness(weighted, n_boot=20))["avoided_share"] == pytest.approx(3 / 4)
    ct = effectiveness(weighted, n_boot=20).crosstabs["aeb"]
    assert ct.loc["full", "none"] == 2.0
    # missing weights count 1
    nan_w = hand_table().assign(weight=np.nan)
    pd.testing.assert_series_equal(effectiveness(nan_w, n_boot=20).metrics["estimate"],
                                   effectiveness(hand_table(), n_boot=20).metrics["estimate"])


def test_failed_cases_are_excluded_and_counted() -> None:
    runs = pd.concat([hand_table(), pd.DataFrame([
        row(9, "baseline", True, "full", 30, 30, 20, 20),
        row(9, "aeb", False, error="SimulationError: boom")])], ignore_index=True)
    pairs, excluded = paired_runs(runs)
    assert pairs[0].size == 4 and 9 not in pairs[0].case_id
    assert excluded.to_dict("records") == [{"case_id": 9, "system": "aeb",
                                            "error": "SimulationError: boom"}]
    pd.testing.assert_series_equal(effectiveness(runs, n_boot=20).metrics["estimate"],
                                   effectiveness(hand_table(), n_boot=20).metrics["estimate"])


def test_bootstrap_sums_resample_cases() -> None:
    values = np.arange(12.0).reshape(6, 2)
    got = bootstrap_sums(values, 50, np.random.default_rng(4))
    idx = np.random.default_rng(4).integers(0, 6, size=(50, 6))
    np.testing.assert_allclose(got, values[idx].sum(axis=1))


def test_risk_curve_selection_and_argument_checks() -> None:
    curves = risk_curves_for(["joksch1993_fatal"])
    assert curves["fatal"].name == "joksch1993_fatal"
    assert curves["MAIS3+"].name == "nhtsa2022_all_mais3"
    assert "MAIS2+" in risk_curves_for(["nhtsa2022_all_mais2"])
    with pytest.raises(ParameterError, match="two risk curves"):
        risk_curves_for(["joksch1993_fatal", "nhtsa2022_all_fatal"])
    with pytest.raises(ParameterError, match="unknown risk curve"):
        risk_curves_for(["nope"])
    eff = effectiveness(hand_table(), risk_curves=["joksch1993_fatal"], n_boot=10)
    joksch = get_risk_curve("joksch1993_fatal")
    expected = joksch.probability(np.array([10, 8, 6, 4, 12, 9.0])).sum()
    assert estimates(eff)["risk_fatal_baseline"] == pytest.approx(expected)
    with pytest.raises(ParameterError):
        effectiveness(hand_table(), n_boot=0)
    with pytest.raises(ParameterError):
        effectiveness(hand_table(), confidence=1.0)
    with pytest.raises(DataError, match="missing"):
        effectiveness(hand_table().drop(columns="delta_v2"))
    with pytest.raises(DataError, match="baseline"):
        effectiveness(hand_table().query("system == 'aeb'"))
    with pytest.raises(DataError, match="twice"):
        effectiveness(pd.concat([hand_table(), hand_table().iloc[:1]]))


def write_study(folder, runs: pd.DataFrame, status: str = "complete") -> None:  # noqa: ANN001
    """A study folder as vfs.study.core writes it (manifest + runs.parquet)."""
    folder.mkdir(parents=True)
    manifest = {"format": "vfs-study", "format_version": 1, "status": status,
                "db": "hand-built", "n_cases": int(runs["case_id"].nunique()), "seed": 0,
                "equip": "both", "system_names": ["aeb"],
                "systems": [{"name": "aeb", "description": "test system"}]}
    (folder / "study.json").write_text(json.dumps(manifest))
    normalise_runs(runs).to_parquet(folder / "runs.parquet", index=False)


def test_cli_writes_the_report(tmp_path, capsys) -> None:
    runs = pd.concat([random_runs(40, np.random.default_rng(8)), pd.DataFrame([
        row(99, "baseline", True, "full", 30, 30, 20, 20),
        row(99, "a", False, error="SimulationError: boom"),
        row(99, "b", False)])], ignore_index=True)
    study = tmp_path / "results" / "demo"
    write_study(study, runs)
    code = main(["report", "effectiveness", str(study), "--bootstrap", "200",
                 "--risk-curve", "joksch1993_fatal"])
    assert code == 0, capsys.readouterr().err
    folder = study / "report"
    for name in ("report.md", "report.html", "metrics.csv", "crosstabs.csv",
                 "impact_speed_cdf.png", "delta_v_scatter.png", "injury_risk.png",
                 "avoided_by_type.png"):
        assert (folder / name).stat().st_size > 100, name
    md = (folder / "report.md").read_text()
    for text in ("joksch1993_fatal", "Joksch", "nhtsa2022_all_mais3", "DOT HS 813 219",
                 "1 case(s) excluded", "SimulationError: boom", "avoided share",
                 "(impact_speed_cdf.png)", "not avoided"):
        assert text.lower() in md.lower(), text
    html = (folder / "report.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "<table>" in html
    assert 'src="injury_risk.png"' in html
    metrics = pd.read_csv(folder / "metrics.csv")
    assert set(metrics["system"]) == {"a", "b"}
    assert {"all", "211", "241", "321"} <= set(metrics["group"].astype(str))
    # accident types appear with their catalogue names in the report tables
    for label in ("211 left turn, oncoming", "241 head-on, straight road",
                  "321 crossing at a junction"):
        assert label in md, label
    # incomplete studies and non-studies are refused (exit code 2)
    write_study(tmp_path / "half", runs, status="incomplete")
    assert main(["report", "effectiveness", str(tmp_path / "half")]) == 2
    assert "not complete" in capsys.readouterr().err
    assert main(["report", "effectiveness", str(tmp_path)]) == 2
    with pytest.raises(DataError, match="not a study"):
        write_effectiveness_report(tmp_path)


def test_shares_at_the_edges_get_wilson_intervals() -> None:
    """Avoided share 2/2 (type 241) and 0/1 (type 601): intervals of positive width that
    contain the estimate, equal to Wilson's with n = number of baseline crashes."""
    from statsmodels.stats.proportion import proportion_confint
    eff = effectiveness(hand_table(), n_boot=300)
    m = eff.metrics[(eff.metrics["system"] == "aeb") & (eff.metrics["metric"] == "avoided_share")]
    by = m.set_index("group")
    assert by.loc[241, "estimate"] == 1.0 and by.loc[241, "high"] == 1.0
    assert by.loc[241, "low"] == pytest.approx(proportion_confint(2, 2, method="wilson")[0])
    assert by.loc[601, "estimate"] == 0.0 and by.loc[601, "low"] == 0.0
    assert by.loc[601, "high"] == pytest.approx(proportion_confint(0, 1, method="wilson")[1])
    assert by.loc[ALL, "low"] == pytest.approx(proportion_confint(2, 3, method="wilson")[0])
    cdf = eff.cdf[eff.cdf["system"] == "aeb"]
    assert (cdf["high"] > cdf["low"]).all()


def test_study_without_crashes_says_so(tmp_path, capsys) -> None:
    runs = pd.DataFrame([row(i, s, False) for i in (1, 2, 3) for s in ("baseline", "a")])
    study = tmp_path / "quiet"
    write_study(study, runs)
    assert main(["report", "effectiveness", str(study), "--bootstrap", "50"]) == 0, \
        capsys.readouterr().err
    md = (study / "report" / "report.md").read_text()
    assert "No crash in the baseline" in md
    assert not list((study / "report").glob("*.png"))
