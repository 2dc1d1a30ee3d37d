"""Identification per case, law discovery and learned laws as effects
(vfs.diagnosis.identify, vfs.diagnosis.learn, vfs.effects.learned).

The hidden laws below are written here, in forms that are NOT in the effect
library; the slow tests hide each in a generated database and check that the
learned law is within 20 % of the true law's range (RMS over the data's
feature range), that, used as an effect, it removes at least 70 % of the
cross-validated error the true law removes, and that ``vfs diagnose`` names
the channel and the feature.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tests.conftest import slow_scale
from vfs.diagnosis.calibrate import CalibrationData, VariantSimulator, kfold_indices
from vfs.diagnosis.identify import identification_features, identify
from vfs.diagnosis.learn import (
    cross_validate_law,
    learn_channel,
    plugin_source,
)
from vfs.diagnosis.robust_fit import fit_form, robust_spline, running_median
from vfs.effects import Effect, EffectParameter
from vfs.effects.learned import (
    FORMS,
    evaluate_law,
    law_effect_class,
    normal_closing_speed,
)
from vfs.errors import ParameterError
from vfs.physics.impact import contact_frame
from vfs.scenarios.generator import generate_database

# ------------------------------------------------------------------ the hidden laws


def step_restitution(v_n):
    """Restitution 0.35 below a normal closing speed of 12 m/s, 0.10 above."""
    return np.where(v_n < 12.0, 0.35, 0.10)


def friction_of_mass_ratio(q):
    """Contact friction growing with the mass ratio m1 / m2."""
    return np.clip(0.15 + 0.35 * q, 0.0, 1.2)


def penetration_of_overlap(ov):
    """Penetration time growing as the overlap falls [s]."""
    return 0.015 + 0.07 * (1.0 - np.clip(ov, 0.0, 1.0))


def poi_shift_of_speed(v):
    """POI shift along the contact plane proportional to the closing speed [m]."""
    return 0.012 * v


class HiddenStepRestitution(Effect):
    name = "test_hidden_step_restitution"
    parameters = (EffectParameter("on", 1.0, 0.0, 1.0, "-", "switch", 0.0),)

    def impact_parameters(self, ctx, config):
        return config._replace(restitution=step_restitution(normal_closing_speed(config)))


class HiddenFrictionMass(Effect):
    name = "test_hidden_friction_mass"
    parameters = (EffectParameter("on", 1.0, 0.0, 1.0, "-", "switch", 0.0),)

    def impact_parameters(self, ctx, config):
        ratio = config.m[:, 0] / config.m[:, 1]
        return config._replace(contact_friction=friction_of_mass_ratio(ratio))


class HiddenPenetrationOverlap(Effect):
    name = "test_hidden_penetration_overlap"
    parameters = (EffectParameter("on", 1.0, 0.0, 1.0, "-", "switch", 0.0),)

    def penetration(self, ctx, penetration_time):
        return penetration_of_overlap(ctx.swept_overlap)


class HiddenPoiSpeed(Effect):
    name = "test_hidden_poi_speed"
    parameters = (EffectParameter("on", 1.0, 0.0, 1.0, "-", "switch", 0.0),)

    def impact_configuration(self, ctx, config):
        f = contact_frame(config)
        d = poi_shift_of_speed(ctx.relative_speed)
        return config._replace(poi_x=config.poi_x + d * f.tx, poi_y=config.poi_y + d * f.ty)


# (hidden effect, channel, feature, true law of the feature)
LAWS = {
    "step_restitution": (HiddenStepRestitution, "restitution", "normal_closing_speed",
                         step_restitution),
    "friction_mass": (HiddenFrictionMass, "contact_friction", "mass_ratio",
                      friction_of_mass_ratio),
    "penetration_overlap": (HiddenPenetrationOverlap, "penetration_time", "overlap",
                            penetration_of_overlap),
    "poi_speed": (HiddenPoiSpeed, "poi_along", "closing_speed", poi_shift_of_speed),
}


# ------------------------------------------------------------------ fast checks


@pytest.mark.parametrize("form", sorted(FORMS))
def test_fit_form_recovers_each_closed_form(form):
    rng = np.random.default_rng(1)
    x = rng.uniform(0.5, 10.0, 400)
    coef = {"constant": [0.4], "linear": [0.2, 0.05], "power": [0.8, -0.6],
            "exponential": [0.6, -0.15], "saturating": [0.1, 0.5, 2.0],
            "step": [0.35, -0.25, 4.0]}[form]
    law = {"form": form, "coefficients": coef}
    y = evaluate_law(law, x) + rng.normal(0, 0.005, x.size)
    fitted = fit_form(form, x, y, np.ones_like(x))
    grid = np.linspace(0.5, 10.0, 200)
    err = evaluate_law({"form": form, "coefficients": fitted}, grid) - evaluate_law(law, grid)
    assert np.sqrt(np.mean(err ** 2)) < 0.01


def test_robust_fit_ignores_cases_identified_at_a_wrong_minimum():
    # a linear law identified with small noise, and 8 % of the cases at a wrong minimum
    # far above the law with narrow intervals (large weights): least squares are pulled,
    # the M-estimate is not
    rng = np.random.default_rng(4)
    x = rng.uniform(0.1, 1.0, 300)
    truth = 0.085 - 0.07 * x
    y = truth + rng.normal(0, 0.001, x.size)
    w = np.ones_like(x)
    bad = rng.choice(x.size, 24, replace=False)
    y[bad] = rng.uniform(0.12, 0.2, bad.size)
    w[bad] = 10.0
    grid = np.linspace(0.1, 1.0, 50)

    def err(coef):
        law = {"form": "linear", "coefficients": coef}
        return np.sqrt(np.mean((evaluate_law(law, grid) - (0.085 - 0.07 * grid)) ** 2))

    assert err(fit_form("linear", x, y, w, robust=False)) > 0.01
    assert err(fit_form("linear", x, y, w)) < 0.0005
    # the step's threshold lies between the data values either side of the true one
    ys = np.where(x >= 0.5, 0.1, 0.35) + rng.normal(0, 0.01, x.size)
    c = fit_form("step", x, ys, np.ones_like(x))[2]
    assert x[x < 0.5].max() < c <= x[x >= 0.5].min()


def test_running_median_follows_lines_and_steps_and_ignores_isolated_values():
    # a straight line is its own running median everywhere, the ends included (the
    # repeated-medians line there); a step too, away from its own window; isolated
    # outliers do not move it
    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(0.0, 10.0, 200))
    line = 0.3 - 0.8 * x
    assert np.allclose(running_median(x, line), line, atol=1e-9)
    step = np.where(x < 5.0, 0.0, 1.0)
    assert np.array_equal(running_median(x, step), step)
    noisy = line.copy()
    noisy[::17] += 50.0  # one case in 17: never more than one in a window of 11
    assert np.allclose(running_median(x, noisy)[1::17], line[1::17], atol=1e-9)
    # the order of the cases does not matter
    perm = rng.permutation(x.size)
    assert np.array_equal(running_median(x[perm], noisy[perm]), running_median(x, noisy)[perm])
    # as few cases as one window (2 k + 1 = 11): both ends are the end lines
    assert np.allclose(running_median(x[:11], line[:11]), line[:11], atol=1e-9)


def test_robust_spline_keeps_a_cluster_at_the_end_of_the_range():
    # rear-end impacts: a cluster at feature 0 separated by a gap from the bulk, on the
    # law; one of them identified at a wrong minimum.  The cluster is kept (it agrees with
    # its neighbours), the wrong one rejected, and the spline passes through the cluster
    # instead of continuing the bulk's curve into it
    rng = np.random.default_rng(3)
    bulk = rng.uniform(1.2, 3.1, 200)
    x = np.concatenate([np.zeros(8), bulk])
    truth = 0.4 * np.sin(x)
    y = truth + rng.normal(0.0, 0.003, x.size)
    y[0] = -0.4
    bad = rng.choice(np.arange(8, x.size), 10, replace=False)
    y[bad] += rng.choice([-1.0, 1.0], bad.size) * rng.uniform(0.2, 0.5, bad.size)
    spl, rw, scale = robust_spline(x, y, np.ones_like(x))
    assert rw[0] == 0.0 and np.all(rw[1:8] > 0.5)
    assert np.all(rw[bad] == 0.0)
    assert 0.5 * 0.003 < scale < 2.0 * 0.003
    assert abs(float(spl(0.0))) < 0.02
    grid = np.linspace(1.2, 3.1, 20)
    assert np.max(np.abs(spl(grid) - 0.4 * np.sin(grid))) < 0.02


def test_zoom_finds_values_at_least_as_good_as_the_grid():
    db, _ = generate_database("default", n_cases=30, seed=4,
                              hidden=(HiddenPenetrationOverlap(),))
    data = CalibrationData.from_database(db)
    sim = VariantSimulator(data)
    # chi^2 at the recorded scales (the estimated ones differ between the runs)
    plain = identify(data, ["penetration_time"], grid_points=9, sim=sim, refine=False,
                     noise="recorded")
    zoom = identify(data, ["penetration_time"], grid_points=9, sim=sim, zoom_starts=2,
                    zoom_points=4, noise="recorded")
    assert (zoom["chi2"].to_numpy() <= plain["chi2"].to_numpy() + 1e-9).all()
    assert (zoom["chi2"].to_numpy() < plain["chi2"].to_numpy() - 1.0).mean() > 0.3
    assert ((zoom["low"] <= zoom["value"]) & (zoom["value"] <= zoom["high"])).all()
    with pytest.raises(ParameterError, match="zoom_points"):
        identify(data, ["penetration_time"], grid_points=9, sim=sim, zoom_starts=1,
                 zoom_points=1)


def test_law_class_parameters_and_checks():
    law = {"name": "t_law", "channel": "restitution", "feature": "closing_speed",
           "form": "step", "coefficients": [0.3, -0.2, 12.0]}
    cls = law_effect_class(law)
    assert [p.name for p in cls.parameters] == ["a", "b", "c"]
    assert cls.stages() == ("impact_parameters",)
    assert cls(c=15.0)["c"] == 15.0
    with pytest.raises(ParameterError, match="unknown channel"):
        law_effect_class({**law, "channel": "nonsense"})
    with pytest.raises(ParameterError, match="unknown feature"):
        law_effect_class({**law, "feature": "nonsense"})
    with pytest.raises(ParameterError, match="coefficients"):
        law_effect_class({**law, "coefficients": [0.3]})


def test_identify_recovers_the_recorded_restitution():
    # no hidden effect: the model reproduces the reconstruction (up to its recorded noise)
    # with the recorded restitution, so the identified value is near the recorded one
    db, _ = generate_database("default", n_cases=40, seed=2, hidden=())
    data = CalibrationData.from_database(db)
    t = identify(data, ["restitution", "poi_along"], grid_points=17)
    rest = t[t["channel"] == "restitution"].set_index("case_id")
    rec = db.reconstruction.set_index("case_id")["restitution"]
    ok = rest["identifiable"].to_numpy()
    assert ok.mean() > 0.8
    err = rest["value"].to_numpy()[ok] - rec.loc[rest.index].to_numpy()[ok]
    assert np.sqrt(np.mean(err ** 2)) < 0.04
    assert (rest["low"] <= rest["value"]).all() and (rest["value"] <= rest["high"]).all()
    np.testing.assert_allclose(rest["model_value"], rec.loc[rest.index], atol=1e-12)
    poi = t[(t["channel"] == "poi_along") & t["identifiable"]]
    assert np.median(np.abs(poi["value"])) < 0.05


def test_plugin_source_is_an_effect(tmp_path):
    import importlib.util

    law = {"name": "learned_plugin_test", "channel": "restitution",
           "feature": "normal_closing_speed", "form": "saturating",
           "coefficients": [0.4, -0.3, 10.0], "channel_unit": "-", "feature_unit": "m/s",
           "cv": {"cases": 10, "reduction_vs_constant": 0.5}}
    law["formula"] = "x"
    path = tmp_path / "law_plugin.py"
    path.write_text(plugin_source(law, path.name))
    spec = importlib.util.spec_from_file_location("vfs_plugin_law_plugin_test", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    from vfs.effects import get_effect, unregister_effect

    try:
        cls = get_effect("learned_plugin_test")
        x = np.linspace(0, 40, 9)
        np.testing.assert_allclose(mod.law_value(x), evaluate_law(law, x))
        assert dict(cls().values) == {"a": 0.4, "b": -0.3, "c": 10.0}
    finally:
        unregister_effect("learned_plugin_test")


def test_noise_only_learns_no_law():
    db, _ = generate_database("default", n_cases=120, seed=9, hidden=())
    data = CalibrationData.from_database(db)
    t = identify(data, ["restitution"], grid_points=13)
    t = t.merge(identification_features(data), on="case_id")
    r = learn_channel(t, "restitution", n_boot=300, band_boot=5)
    assert not r.significant, r.text()


# ------------------------------------------------------------------ hidden laws (slow)


def _n_cases() -> int:
    return max(300, int(round(600 * slow_scale())))


def true_law_errors(sim, effect):
    return sim.data.case_errors(sim.residuals([(effect,)])[0])


def learn_hidden(key, n_cases, seed=21):
    hidden_cls, channel, feature, law = LAWS[key]
    db, _ = generate_database("default", n_cases=n_cases, seed=seed, hidden=(hidden_cls(),))
    data = CalibrationData.from_database(db)
    sim = VariantSimulator(data)
    t = identify(data, [channel], grid_points=21, sim=sim)
    t = t.merge(identification_features(data), on="case_id")
    r = learn_channel(t, channel, n_boot=400, band_boot=20)
    return db, data, sim, t, r


@pytest.mark.slow
@pytest.mark.parametrize("key", sorted(LAWS))
def test_hidden_law_is_learned(key):
    hidden_cls, channel, feature, law = LAWS[key]
    db, data, sim, t, r = learn_hidden(key, _n_cases())
    assert r.significant, r.text()
    assert r.law["feature"] == feature, r.text()
    # curve error: RMS over the data's feature range, against the true law's range
    x = t[t["channel"] == channel][feature].to_numpy(float)
    grid = np.linspace(np.nanmin(x), np.nanmax(x), 200)
    truth = law(grid)
    curve_err = np.sqrt(np.mean((evaluate_law(r.law, grid) - truth) ** 2)) / np.ptp(truth)
    # outcome CV: the learned law (refitted per fold) against the true law
    held = kfold_indices(data.n, 5, 0)
    base = sim.data.case_errors(sim.residuals([()])[0])
    _, learned = cross_validate_law(sim, t, r.law, held)
    true = true_law_errors(sim, hidden_cls())

    def rmse(e):
        return math.sqrt(np.nanmean(np.nanmean(e, axis=0)))

    red_true = 1 - rmse(true) / rmse(base)
    red_learned = 1 - rmse(learned) / rmse(base)
    print(f"{key}: {r.law['formula']}; curve error {100 * curve_err:.1f} % of the range; "
          f"CV reduction {100 * red_learned:.1f} % vs true law {100 * red_true:.1f} %")
    assert curve_err <= 0.20
    assert red_learned >= 0.7 * red_true


@pytest.mark.slow
def test_diagnose_names_channel_and_feature():
    from vfs.diagnosis.diagnose import diagnose

    hidden_cls, channel, feature, _ = LAWS["step_restitution"]
    db, _ = generate_database("default", n_cases=_n_cases(), seed=21, hidden=(hidden_cls(),))
    diag = diagnose(db, effects="restitution_speed,tyre_impulse", folds=3, grid_points=5,
                    zoom_rounds=2, n_boot=400, worst=0, laws="all")
    top = diag.laws[0]
    assert top.significant and top.channel == channel
    assert top.learned.law["feature"] == feature
    assert top.outcome.estimate > diag.candidates[0].overall.estimate
    assert diag.verdict[0].startswith(f"Most likely missing physics: a law of {channel} over "
                                      f"{feature}"), diag.verdict


def test_identification_table_has_units_and_flags(tmp_path):
    from vfs.diagnosis.identify import write_identification

    db, _ = generate_database("default", n_cases=30, seed=3, hidden=())
    data = CalibrationData.from_database(db)
    t = identify(data, ["ees_stiffness_ratio"], grid_points=9)
    paths = write_identification(t, identification_features(data), tmp_path)
    back = pd.read_parquet(paths["parquet"])
    assert set(back["unit"]) == {"-"}
    assert {"flat", "multimodal", "at_bound", "identifiable", "normal_closing_speed"} \
        <= set(back.columns)
    assert paths["csv"].is_file() and paths["units"].is_file()


def test_cli_identify_learn_calibrate_compare(tmp_path):
    from vfs.cli import main as cli
    from vfs.effects import registered_effects, unregister_effect
    from vfs.scenarios.generator import write_generated

    db, truth = generate_database("default", n_cases=100, seed=21,
                                  hidden=(HiddenStepRestitution(),))
    folder = write_generated(db, truth, tmp_path / "db")
    assert cli(["identify", "--db", str(folder), "--parameters", "restitution", "--grid", "13",
                "--out", str(tmp_path / "id")]) == 0
    law = tmp_path / "law.json"
    assert cli(["learn", "--identified", str(tmp_path / "id"), "--out", str(law),
                "--export-plugin", str(tmp_path / "law_plugin.py")]) == 0
    import json

    doc = json.loads(law.read_text())
    assert [x["channel"] for x in doc["laws"]] == ["restitution"]
    assert doc["laws"][0]["feature"] == "normal_closing_speed"
    assert "def law_value" in (tmp_path / "law_plugin.py").read_text()
    try:
        assert cli(["calibrate", "--db", str(folder), "--plugin", str(law), "--effects",
                    "learned_restitution", "--quick", "--no-cv",
                    "--out", str(tmp_path / "res" / "model.json")]) == 0
        model = json.loads((tmp_path / "res" / "model.json").read_text())
        assert model["effects"][0]["name"] == "learned_restitution"
    finally:
        if "learned_restitution" in registered_effects():
            unregister_effect("learned_restitution")


def _gcv_by_hat_matrix(x, y, w, lam):
    """Wahba's GCV (weighted residuals) of scipy's smoothing spline at ``lam`` from its hat
    matrix, built column by column by smoothing the unit vectors (the spline is linear in
    y): the reference of the closed form; (criterion, degrees of freedom tr(A))."""
    from scipy.interpolate import make_smoothing_spline

    n = x.size
    a = np.column_stack([make_smoothing_spline(x, e, w=w, lam=lam)(x) for e in np.eye(n)])
    r = y - a @ y
    return float(np.sum(w * r ** 2) / n / (1.0 - np.trace(a) / n) ** 2), float(np.trace(a))


def test_gcv_smoothing_finds_the_global_minimum_within_the_dof_cap():
    """The smoothing parameter is the global minimum of the GCV criterion among the
    splines of at most n / 4 degrees of freedom: no lam of a dense log grid (criterion and
    trace from the hat matrix of scipy's spline, an independent computation) does better,
    over sizes, weightings and noise levels."""
    from vfs.diagnosis.robust_fit import gcv_smoothing

    rng = np.random.default_rng(7)
    for _ in range(4):
        n = int(rng.integers(16, 41))
        x = np.sort(rng.uniform(0.0, 30.0, n))
        y = np.sin(x / 3.0) + rng.uniform(0.01, 0.3) * rng.normal(size=n)
        w = rng.uniform(0.2, 2.0, n)
        w /= w.mean()
        lam = gcv_smoothing(x, y, w)
        ours, dof = _gcv_by_hat_matrix(x, y, w, lam)
        assert dof <= n / 4 + 1e-6
        for trial in np.geomspace(1e-4, 1e5, 40):
            crit, trial_dof = _gcv_by_hat_matrix(x, y, w, trial)
            if trial_dof <= n / 4:
                assert ours <= crit * (1 + 1e-6)


def test_gcv_smoothing_does_not_depend_on_the_unit_of_the_feature():
    """The same data with the feature in rad and in degrees give the same spline (lam
    scales with the cube of the feature's unit; a search over a range fixed in the
    feature's unit found another local minimum in each unit)."""
    from vfs.diagnosis.robust_fit import smoothing_spline

    rng = np.random.default_rng(11)
    x = np.sort(np.concatenate([[0.0, 0.0], rng.uniform(0.4, math.pi, 150)]))
    y = 0.22 * np.sin(2 * x) + 0.03 * rng.normal(size=x.size)
    w = rng.uniform(0.5, 1.5, x.size)
    rad = smoothing_spline(x, y, w)
    deg = smoothing_spline(np.degrees(x), y, w)
    xg = np.linspace(0.0, math.pi, 50)
    assert np.max(np.abs(rad(xg) - deg(np.degrees(xg)))) < 1e-6


def test_spline_pooling_keeps_an_isolated_end_cluster():
    """Pooling the abscissas of a large sample into SPLINE_BINS groups must not merge an
    isolated cluster at the end of the range with the cases beyond the gap: two cases at
    x = 0 with value 0 and 200 cases on 1.3 <= x <= 3.1 on the line 0.3 - 0.1 x (whose
    continuation to x = 0 is 0.3).  The spline must pass near 0 at x = 0 (within the
    line's value at the gap's far end, 0.17, of it), not continue the line to 0.3."""
    from vfs.diagnosis.robust_fit import pool_groups, smoothing_spline

    rng = np.random.default_rng(5)
    x = np.concatenate([[0.0, 0.0], np.sort(rng.uniform(1.3, 3.1, 200))])
    y = np.where(x > 1.0, 0.3 - 0.1 * x, 0.0) + 0.002 * rng.normal(size=x.size)
    spl = smoothing_spline(x, y, np.ones_like(x))
    assert abs(float(spl(0.0))) < 0.05
    g = pool_groups(np.unique(x))
    assert g[0] != g[1]  # the cluster at 0 is a group of its own


def test_law_rows_keep_cases_identified_at_a_physical_bound():
    """A brake factor of 1 (locked wheels) is a limit of the physics: a case whose interval
    reaches it, and only it, and whose outcomes the bound explains (chi^2 within the 99 %
    quantile of chi^2 with its 8 columns, 20.1) is identified there and enters the law; not
    a case pressed against the bound with chi^2 = 800 (it makes up for something else), nor
    at a bound of the scan only (the contact-plane turn's +-0.5 rad), nor a case whose
    interval spans the whole range."""
    from vfs.diagnosis.learn import law_rows

    def rows(channel, value, low, high, ident, chi2):
        return pd.DataFrame({"case_id": np.arange(len(value)), "channel": channel,
                             "value": value, "low": low, "high": high,
                             "identifiable": ident, "flat": False, "multimodal": False,
                             "at_bound": ~np.asarray(ident), "chi2": chi2, "n_columns": 8})

    brake = rows("runout_brake1", [0.5, 1.0, 1.0, 0.5, 1.0], [0.45, 0.9, 0.0, 0.0, 0.95],
                 [0.55, 1.0, 1.0, 0.55, 1.0], [True, False, False, False, False],
                 [6.0, 7.0, 7.0, 7.0, 800.0])
    t, y, w = law_rows(brake, "runout_brake1")
    assert list(t["case_id"]) == [0, 1, 3]  # 2 spans [0, 1]; 3 reaches the bound 0; 4 misfits
    cp = rows("cp_angle", [0.1, 0.5], [0.05, 0.4], [0.15, 0.5], [True, False], [6.0, 7.0])
    t, y, w = law_rows(cp, "cp_angle")
    assert list(t["case_id"]) == [0]


def test_gcv_smoothing_follows_the_noise():
    """More noise, more smoothing: lam grows with the noise of a line's values (a straight
    line is in the spline's null space, so a noiseless line gets the smallest lam)."""
    from vfs.diagnosis.robust_fit import gcv_smoothing

    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 10.0, 60)
    e = rng.normal(size=60)
    lams = [gcv_smoothing(x, 1.0 + 0.5 * x + s * e + 0.3 * np.sin(x), np.ones(60))
            for s in (0.01, 0.3)]
    assert lams[0] < lams[1]
