"""Sobol indices (vfs.uncertainty.sensitivity, vfs sensitivity), checked against SALib
and theory."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
from SALib.analyze import sobol as salib_analyze
from SALib.sample import sobol as salib_sample

from tests.conftest import slow_scale
from vfs.cli import main as vfs_main
from vfs.errors import ParameterError
from vfs.scenarios.generator import generate_database, write_generated
from vfs.uncertainty import (
    INPUT_NAMES,
    CaseSet,
    Distribution,
    InputSpec,
    default_config,
    evaluate,
    resolve_inputs,
    values_from_unit,
)
from vfs.uncertainty.sensitivity import (
    DUMMY,
    SaltelliDesign,
    ishigami,
    ishigami_indices,
    saltelli_design,
    sensitivity_analysis,
    sobol_analyze,
    sobol_indices,
)


def _salib_to_blocks(y: np.ndarray, n: int, d: int) -> np.ndarray:
    """SALib's row order (per base row: A, AB_1..AB_d, B) -> ours ([A; B; AB_1; ...])."""
    r = y.reshape((n, d + 2) + y.shape[1:])
    return np.concatenate([r[:, 0], r[:, -1]] + [r[:, 1 + i] for i in range(d)])


# ------------------------------------------------------------------ estimators


def test_estimators_equal_salib_on_the_same_sample():
    d, n = 4, 512
    problem = {"num_vars": d, "names": ["x1", "x2", "x3", "dummy"], "bounds": [[0, 1]] * d}
    x = salib_sample.sample(problem, n, calc_second_order=False, seed=3)
    y = ishigami(x[:, :3])
    ref = salib_analyze.analyze(problem, y, calc_second_order=False, seed=4)
    ours = sobol_indices(_salib_to_blocks(y, n, d), d, n_boot=300,
                         rng=np.random.default_rng(0))
    np.testing.assert_allclose(ours.s1, ref["S1"], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ours.st, ref["ST"], rtol=1e-10, atol=1e-12)
    # bootstrap half-widths of the same size as SALib's (normal approximation)
    half = (ours.s1_high - ours.s1_low)[:3] / 2
    assert np.all(half / ref["S1_conf"][:3] > 0.6) and np.all(half / ref["S1_conf"][:3] < 1.6)
    assert np.all(ours.s1_low <= ours.s1 + 1e-12) and np.all(ours.s1 <= ours.s1_high + 1e-12)


def test_ishigami_indices_with_own_design():
    d = 4
    est = sobol_analyze(lambda x: ishigami(x[:, :3]), d, 8192, np.random.default_rng(5),
                        n_boot=200)
    s1, st = ishigami_indices()
    np.testing.assert_allclose(est.s1[:3], s1, atol=0.02)
    np.testing.assert_allclose(est.st[:3], st, atol=0.02)
    # the dummy enters nothing: AB_4 = A row for row, both estimators exactly 0
    assert est.s1[3] == 0.0 and est.st[3] == 0.0
    assert est.s1.sum() <= 1.02
    assert np.all(est.st >= est.s1 - 0.02)
    # the exact values lie in the 95 % bootstrap intervals
    assert np.all((est.st_low[:3] - 0.01 <= st) & (st <= est.st_high[:3] + 0.01))


def test_trailing_dimensions_are_independent_analyses():
    d, n = 3, 256
    design = saltelli_design(n, d, np.random.default_rng(1))
    x = design.matrix()
    y = np.stack([ishigami(x), x[:, 0] + 0.0 * x[:, 1], x[:, 1] ** 2 + x[:, 2]], axis=1)
    both = sobol_indices(y, d)
    for k in range(3):
        alone = sobol_indices(y[:, k], d)
        np.testing.assert_allclose(both.s1[:, k], alone.s1, rtol=1e-12)
        np.testing.assert_allclose(both.st[:, k], alone.st, rtol=1e-12)
    # a linear function of x1 alone: S1 = ST = 1 for x1 (up to the estimator), 0 else
    np.testing.assert_allclose(both.st[:, 1], [1.0, 0.0, 0.0], atol=0.05)
    assert both.s1[1, 1] == 0.0 and both.s1[2, 1] == 0.0


def test_constant_output_has_no_indices():
    idx = sobol_indices(np.full((5 * 16, 2), 3.0), 3)
    assert np.isnan(idx.s1).all() and np.isnan(idx.st).all()


def test_design_layout_and_errors():
    design = saltelli_design(16, 3, np.random.default_rng(0))
    m = design.matrix()
    assert m.shape == (16 * 5, 3)
    np.testing.assert_array_equal(m[:16], design.a)
    np.testing.assert_array_equal(m[16:32], design.b)
    for i in range(3):
        ab = m[32 + 16 * i:48 + 16 * i]
        np.testing.assert_array_equal(ab[:, i], design.b[:, i])
        np.testing.assert_array_equal(np.delete(ab, i, 1), np.delete(design.a, i, 1))
    assert isinstance(design, SaltelliDesign) and design.n == 16 and design.d == 3
    with pytest.raises(ParameterError, match="power of two"):
        saltelli_design(100, 3, np.random.default_rng(0))
    with pytest.raises(ParameterError, match="method"):
        saltelli_design(16, 3, np.random.default_rng(0), method="lhs")
    with pytest.raises(ParameterError, match="Saltelli design"):
        sobol_indices(np.zeros(17), 3)
    with pytest.raises(ParameterError, match="finite"):
        sobol_indices(np.full(5 * 4, np.nan), 3)
    with pytest.raises(ParameterError, match="rng"):
        sobol_indices(np.arange(5 * 4.0), 3, n_boot=10)


# ------------------------------------------------------------------ the collision model


@pytest.fixture(scope="module")
def clean_cases():
    db, _ = generate_database("clean", n_cases=16, seed=8)
    return CaseSet.from_database(db)


def test_model_output_matches_salib(clean_cases):
    """Our estimators on the collision model's output equal SALib's on the same runs."""
    cases = clean_cases.take(slice(0, 1))
    cfg = default_config()
    res = resolve_inputs(cases, cfg)
    varied = [k for k, v in enumerate(res.varied) if v]
    d, n = len(varied), 64
    problem = {"num_vars": d, "names": [INPUT_NAMES[k] for k in varied],
               "bounds": [[0, 1]] * d}
    u = salib_sample.sample(problem, n, calc_second_order=False, seed=2)
    runs = evaluate(cases, values_from_unit(res, u, np.zeros(len(u), dtype=int), varied), cfg)
    for name in ("delta_v1", "runout_distance2"):
        y = runs.outcomes[name]
        ref = salib_analyze.analyze(problem, y, calc_second_order=False, seed=1)
        ours = sobol_indices(_salib_to_blocks(y, n, d), d)
        np.testing.assert_allclose(ours.s1, ref["S1"], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ours.st, ref["ST"], rtol=1e-9, atol=1e-12)


def test_inputs_that_do_not_enter_an_outcome_get_zero(clean_cases):
    res = sensitivity_analysis(clean_cases, n_base=32, seed=3, n_boot=50,
                               outcomes=("delta_v1", "ees2", "runout_distance1", "sliding"))
    pc = res.per_case
    # the dummy enters nothing; road friction and post-crash brakes do not enter the impact
    for name in (DUMMY, "road_friction", "wheel_brake1", "wheel_brake2"):
        impact = pc[(pc["input"] == name) & pc["outcome"].isin(["delta_v1", "ees2"])]
        assert (impact[["s1", "st"]].fillna(0.0).to_numpy() == 0.0).all(), name
    dummy = pc[pc["input"] == DUMMY]
    assert (dummy[["s1", "st"]].fillna(0.0).to_numpy() == 0.0).all()
    # but the run-out parameters do drive the rest distance
    g = res.ranking("runout_distance1", "all").set_index("input")
    assert g.loc["road_friction", "st"] > 0.02 and g.loc["wheel_brake1", "st"] > 0.02
    # vehicle 2's brakes do not move vehicle 1 (secondary collisions are not solved)
    rest1 = pc[(pc["outcome"] == "runout_distance1") & (pc["input"] == "wheel_brake2")]
    assert (rest1[["s1", "st"]].fillna(0.0).to_numpy() == 0.0).all()
    # indices sum sensibly: S1 <= 1 and ST >= S1 on the group means
    for (_, _), h in res.groups.groupby(["group", "outcome"]):
        if h["n_cases"].max() == 0:
            continue
        assert h["s1"].sum() <= 1.1
        assert h["st"].sum() >= 0.9
        assert (h["st"] >= h["s1"] - 0.1).all()


def test_restitution_alone_explains_full_impact_delta_v(clean_cases):
    """In a full impact S = (1 + eps) S_C: with only restitution and road friction
    uncertain, delta-v depends on eps alone and linearly (S1 = ST = 1), road friction 0."""
    fixed = {name: InputSpec(Distribution("fixed", "offset")) for name in INPUT_NAMES}
    fixed["restitution"] = default_config().inputs["restitution"]
    fixed["road_friction"] = default_config().inputs["road_friction"]
    cfg = dataclasses.replace(default_config(), inputs=fixed)
    res = sensitivity_analysis(clean_cases, cfg, n_base=64, seed=1, n_boot=0,
                               outcomes=("delta_v1", "rest_x1"), dummy=False)
    full = res.per_case[(res.per_case["group"] == "full")
                        & (res.per_case["outcome"] == "delta_v1")].set_index(["case_id",
                                                                              "input"])
    assert len(full)
    eps = full.xs("restitution", level="input")
    np.testing.assert_allclose(eps["s1"], 1.0, atol=0.02)
    np.testing.assert_allclose(eps["st"], 1.0, atol=0.02)
    road = full.xs("road_friction", level="input")
    assert (road[["s1", "st"]].to_numpy() == 0.0).all()
    assert set(res.names) == {"road_friction", "restitution"}


def test_groups_split_the_cases_by_nominal_type(clean_cases):
    res = sensitivity_analysis(clean_cases, n_base=16, seed=0, n_boot=20,
                               outcomes=("delta_v2",))
    g = res.groups[res.groups["input"] == "restitution"].set_index("group")
    types = res.per_case.drop_duplicates("case_id")["group"].value_counts()
    assert g.loc["all", "n_cases"] == len(clean_cases.case_id)
    assert g.loc["full", "n_cases"] == types.get("full", 0)
    assert g.loc["sliding", "n_cases"] == types.get("sliding", 0)
    pc = res.per_case[(res.per_case["input"] == "restitution")]
    np.testing.assert_allclose(g.loc["full", "st"], pc[pc["group"] == "full"]["st"].mean())
    assert res.n_runs == 16 * (len(res.names) + 2) * len(clean_cases.case_id)
    with pytest.raises(ParameterError, match="unknown outcomes"):
        sensitivity_analysis(clean_cases, n_base=16, outcomes=("delta_v3",))


def test_old_outcome_name_is_read_with_a_deprecation_warning(clean_cases):
    kw = {"n_base": 16, "seed": 0, "n_boot": 10, "dummy": False}
    with pytest.warns(DeprecationWarning, match="runout_distance1"):
        old = sensitivity_analysis(clean_cases, outcomes=("rest_distance1",), **kw)
    new = sensitivity_analysis(clean_cases, outcomes=("runout_distance1",), **kw)
    pd.testing.assert_frame_equal(old.groups, new.groups)


@pytest.mark.slow
def test_ranking_on_a_larger_sample_is_stable_between_seeds():
    """Different seeds give the same leading input per outcome and group."""
    n_cases = max(16, int(round(60 * slow_scale())))
    db, _ = generate_database("default", n_cases=n_cases, seed=12)
    cases = CaseSet.from_database(db)
    a = sensitivity_analysis(cases, n_base=64, seed=1, n_boot=0,
                             outcomes=("delta_v1", "runout_distance1"))
    b = sensitivity_analysis(cases, n_base=64, seed=2, n_boot=0,
                             outcomes=("delta_v1", "runout_distance1"))
    for outcome in ("delta_v1", "runout_distance1"):
        ra, rb = a.ranking(outcome, "all"), b.ranking(outcome, "all")
        assert set(ra["input"].head(3)) & set(rb["input"].head(3))
        np.testing.assert_allclose(ra.set_index("input")["st"],
                                   rb.set_index("input")["st"].loc[ra["input"]], atol=0.12)


def test_cli_writes_indices_report_and_figures(tmp_path, capsys):
    db, truth = generate_database("default", n_cases=8, seed=6)
    folder = tmp_path / "db"
    write_generated(db, truth, folder)
    out = tmp_path / "sens"
    code = vfs_main(["sensitivity", "--db", str(folder), "--base-samples", "16",
                     "--bootstrap", "20", "--outcomes", "delta_v1,sliding", "--out", str(out)])
    assert code == 0
    assert "model runs" in capsys.readouterr().out
    groups = pd.read_parquet(out / "groups.parquet")
    assert set(groups["outcome"]) == {"delta_v1", "sliding"}
    assert DUMMY in set(groups["input"])
    summary = json.loads((out / "sensitivity.json").read_text(encoding="utf-8"))
    assert summary["n_base"] == 16 and "ranking_by_total_index" in summary
    for f in ("report.md", "report.html", "per_case.parquet", "figures/sobol_overview.png",
              "figures/sobol_delta_v1.png"):
        assert (out / f).is_file(), f
    code = vfs_main(["sensitivity", "--db", str(folder), "--base-samples", "20", "--out",
                     str(tmp_path / "x")])
    assert code == 2 and "power of two" in capsys.readouterr().err
