"""Law discovery: regress identified channels on case features (``vfs learn``).

Input: the per-case identification of :mod:`vfs.diagnosis.identify` joined
with the case features (closing speed, normal closing speed, overlap,
impact angle, mass ratio, impact speeds, road friction; SI units).  For
each channel, only the identifiable cases are used (and those identified at a
bound of the channel that is a limit of the physics, e.g. locked wheels,
:func:`law_rows`), weighted by 1 / sigma^2 with sigma the half width of the
identification interval (chi^2 <= min + k^2, :func:`vfs.diagnosis.identify.identify`;
floored at a tenth of the spread of the values, so that
no case dominates).

Some cases are identified at a wrong minimum of their objective: where
the outcomes react to the channel on a scale finer than the identification
grid, or are chaotic in it, a case can prefer a value far from the law
(penetration time: a few percent of the cases tens of milliseconds off,
often with a narrow interval, i.e. a large weight).  Least squares let
these few cases pull the law (a 2-3 ms bias at small overlaps, enough to
lose a third of the outcome-error reduction), so every fit is an
M-estimate (:mod:`vfs.diagnosis.robust_fit`): iteratively reweighted least squares with
Huber's, then Tukey's biweight weights of the standardised residuals sqrt(w) (y - f(x))
(scale: their normal-consistent MAD), which gives the misidentified cases no weight.

For each numeric feature, k-fold cross-validation (seeded) of

* a smoothing spline (:func:`scipy.interpolate.make_smoothing_spline`, its
  smoothness chosen by generalised cross-validation), with a bootstrap band;
  its robust weights are Tukey's biweight of the residuals from a running median
  along the feature, once per feature (the folds and the band reuse them);
* the closed forms of :data:`vfs.effects.learned.FORMS` (constant, linear,
  power, exponential, saturating, step): the nonlinear coefficient by a
  grid and nested grids around its best point (the step's threshold:
  the midpoints between the data values around the best grid point), the
  linear ones by weighted least squares; each fold's robust fit starts from
  the robust fit on all cases.

The CV error is the same robust loss: Tukey's biweight of the held-out
standardised residuals (u^2 near 0, bounded for a misidentified case) at
one scale per channel, the smallest robust residual scale of the features'
splines (the identification noise), so that all candidates and the null
are scored alike.  The best (feature, form) is the one with the lowest CV
error; a closed form is preferred to the spline when its CV error is at
most 2 % higher (a formula the user can read).  The law is *significant*
when the bootstrap CI (over cases, Bonferroni over the features) of its
CV reduction (1 - sqrt of the ratio of mean losses) against the null model
(the better of a constant and the model's own value of the channel, e.g.
the EES stiffness ratio m1 / m2 of the default model) lies above zero and
the reduction reaches ``min_reduction``; otherwise the channel is reported
as "no structure".

"Significant" here is structure in the identified values only, and each
channel was identified with all other channels at the model's values: a
law missing on one channel leaks into the identification of others, which
then show structure too.  There is no outcome cross-validation here;
``vfs diagnose --laws`` decides which laws are claimed (outcome CV, the
further laws stepwise on channels re-identified with the claimed laws
applied; :func:`vfs.diagnosis.diagnose.diagnose`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vfs.diagnosis.calibrate import kfold_indices, reduction_ci
from vfs.diagnosis.diagnose_spec import DiagnoseSpec
from vfs.diagnosis.robust_fit import (
    fit_form,
    fit_spline,
    predict_spline,
    robust_loss,
    robust_scale,
    robust_spline,
    smoothing_spline,
)
from vfs.effects.learned import (
    CHANNELS,
    FORM_EXPRESSIONS,
    FORMS,
    LAW_FEATURES,
    evaluate_law,
    law_text,
)
from vfs.errors import ParameterError

#: Numeric features regressed on, in report order.
LEARN_FEATURES: tuple[str, ...] = tuple(LAW_FEATURES)
#: A closed form is preferred to the spline up to this relative CV excess.
CLOSED_FORM_TOLERANCE = 0.02
#: Fewest identifiable cases for a law.
MIN_LAW_CASES = 30
#: Level of the goodness-of-fit test of a case identified at a physical bound of its channel
#: (:func:`law_rows`): its chi^2 there at most this quantile of chi^2(n_columns).
BOUND_FIT_LEVEL = 0.99
@dataclass
class ChannelLaw:
    """What :func:`learn_channel` found for one channel.

    Attributes
    ----------
    channel : str
    n : int
        Identifiable cases used.
    significant : bool
    law : dict or None
        The law (JSON-ready, :func:`vfs.effects.learned.law_effect_class`).
    reduction, low, high : float
        CV RMSE reduction of the law against the null (the better of a
        constant and the model's own value, ``null``), with its CI.
    candidates : pandas.DataFrame
        feature, form, cv_mse, reduction (against the constant), coefficients.
    band : dict
        Spline curve and bootstrap band over the chosen feature (x, y, low, high).
    """

    channel: str
    n: int
    significant: bool
    law: dict[str, Any] | None
    reduction: float
    low: float
    high: float
    candidates: pd.DataFrame
    band: dict[str, list[float]] = field(default_factory=dict)
    note: str = ""
    null: str = "constant"

    def text(self) -> str:
        """One line for reports."""
        if self.law is None or not self.significant:
            return (f"{self.channel}: no structure ({self.note or 'nothing beats the constant'}"
                    f"; {self.n} identifiable cases)")
        return (f"{self.channel} follows f({self.law['feature']}): {law_text(self.law)}; "
                f"CV reduction vs {'the model' if self.null == 'model' else 'a constant'} "
                f"{100 * self.reduction:.1f} % "
                f"[{100 * self.low:.1f}, {100 * self.high:.1f}] ({self.n} cases; structure in "
                "the identified values)")


def _cv_predictions(form: str, x: np.ndarray, y: np.ndarray, w: np.ndarray,
                    held: Sequence[np.ndarray], robust: bool = True,
                    start: Sequence[float] | None = None) -> np.ndarray:
    """Held-out predictions of a form fitted on the other folds (``start``: the robust fit
    on all cases, from which each fold's robust fit starts, :func:`fit_form`).
    """
    pred = np.full_like(y, np.nan)
    for h in held:
        tr = np.setdiff1d(np.arange(y.size), h)
        if form == "spline":
            spl = fit_spline(x[tr], y[tr], w[tr], robust)
            if spl is None:
                continue
            pred[h] = predict_spline(spl, x[h], x[tr].min(), x[tr].max())
        else:
            coef = fit_form(form, x[tr], y[tr], w[tr], robust, start=start)
            pred[h] = evaluate_law({"form": form, "coefficients": coef}, x[h])
    return pred


def _noise_scale(scales: Iterable[float], y: np.ndarray, w: np.ndarray) -> float:
    """Robust scale of the identification noise (the channel's unit at weight 1):
    the smallest of ``scales`` (those of the robust splines over the features) and
    of the residuals from the median; the scale of the robust CV loss.
    """
    sw = np.sqrt(w)
    cand = [v for v in (robust_scale(sw * (y - np.median(y))), *scales) if v > 0]
    s = min(cand) if cand else 0.0
    return s if s > 0 else float(np.std(sw * y)) or 1.0


def law_rows(table: pd.DataFrame, channel: str) -> tuple[pd.DataFrame, np.ndarray,
                                                          np.ndarray]:
    """Rows of a channel a law is learned from, their values and weights 1 / sigma^2
    (mean 1): the identifiable cases, and those whose interval reaches only a bound of the
    channel that is a limit of the physics (:attr:`vfs.effects.learned.Channel.physical`:
    a brake factor of 1, locked wheels, is identified there, not beyond; the run-out of
    the fastest vehicles of ``brake1_speed_hinge`` is only identified so).

    Such a case must fit its outcomes at the bound (chi^2 at most its
    :data:`BOUND_FIT_LEVEL` quantile for its number of outcome columns): in
    ``tp_hinge+brake2_bell_angle`` head-on cases pressed vehicle 2's brake factor against 0
    or 1 (chi^2 ~100 per column) to make up for the missing penetration-time law.

    sigma is the half width of the identification interval (chi^2 <= min + k^2), taken on
    its one side at a physical bound and floored at a tenth of the standard deviation of
    the values.
    """
    t = table[table["channel"] == channel]
    ok = t["identifiable"].to_numpy(bool)
    if "at_bound" in t.columns and channel in CHANNELS:
        ch = CHANNELS[channel]
        tol = 1e-9 * (ch.hi - ch.lo)
        low, high = t["low"].to_numpy(float), t["high"].to_numpy(float)
        reach_lo, reach_hi = low <= ch.lo + tol, high >= ch.hi - tol
        censored = (t["at_bound"].to_numpy(bool) & ~t["flat"].to_numpy(bool)
                    & ~t["multimodal"].to_numpy(bool) & (reach_lo != reach_hi)
                    & (ch.physical[0] | ~reach_lo) & (ch.physical[1] | ~reach_hi))
        if "chi2" in t.columns and "n_columns" in t.columns:
            from scipy.stats import chi2

            # the bound must explain the case's outcomes (chi^2 within its 99 % quantile):
            # a case pressed against a bound while compensating another missing law is not
            # evidence of the bound
            censored &= t["chi2"].to_numpy(float) <= chi2.ppf(
                BOUND_FIT_LEVEL, np.maximum(t["n_columns"].to_numpy(float), 1.0))
        ok = ok | censored
    t = t[ok & np.isfinite(t["value"].to_numpy(float))]
    y = t["value"].to_numpy(float)
    if y.size == 0:
        return t, y, y
    sigma = 0.5 * (t["high"].to_numpy(float) - t["low"].to_numpy(float))
    floor = 0.1 * float(np.std(y)) if np.std(y) > 0 else 1e-6
    w = 1.0 / np.maximum(sigma, floor) ** 2
    return t, y, w / w.mean()


def refit_law(law: Mapping[str, Any], x: np.ndarray, y: np.ndarray, w: np.ndarray,
              name: str | None = None) -> dict[str, Any]:
    """The law's form refitted to (x, y, w) (closed form: WLS; table: spline)."""
    out = dict(law)
    if name is not None:
        out["name"] = name
    if law["form"] == "table":
        spl = fit_spline(x, y, w)
        xg = np.asarray(law["table"]["x"], float)
        if spl is not None:
            out["table"] = {"x": xg.tolist(),
                            "y": predict_spline(spl, xg, x.min(), x.max()).tolist()}
    else:
        out["coefficients"] = fit_form(law["form"], x, y, w)
    return out


def cross_validate_law(sim: Any, table: pd.DataFrame, law: Mapping[str, Any],
                       held: Sequence[np.ndarray], polish: bool = False,
                       grid_points: int = 7,
                       zoom_rounds: int = DiagnoseSpec.zoom_rounds
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Cross-validated outcome errors of a law used as an effect.

    For each fold, the law's form is refitted to the identified values of
    the training cases only (identification is per case, so the held-out
    cases' outcomes do not enter), simulated on all cases (one stacked
    call for all folds) and scored on the held-out cases.

    Parameters
    ----------
    sim : VariantSimulator
    table : pandas.DataFrame
        Identification joined with features, rows of the simulator's cases.
    law : mapping
    held : sequence of int arrays
        Held-out rows (positions in ``sim.data``).
    polish : bool
        Then refit the law's first coefficient (closed forms) on the training
        cases' *outcomes* (:func:`vfs.diagnosis.calibrate.fit_folds`, bounds
        +-30 % of its value or a tenth of the channel's range), for outcomes
        more sensitive to the channel than its identification is precise
        (off by default: with the robust fits of the identified values the
        laws of tests/diagnosis/test_learn.py reach the true law's reduction without it).
    grid_points, zoom_rounds : int
        Search of the polish.

    Returns
    -------
    (residuals, errors)
        Held-out residuals (n, n_columns) and per-case errors (n, n_groups).
    """
    from vfs.effects.learned import law_effect_class

    data = sim.data
    models = []
    for k, h in enumerate(held):
        lk = _fold_law(data, table, law, h, k)
        if polish and lk["form"] != "table":
            from vfs.diagnosis.calibrate import FitSpace, fit_folds

            a0 = float(lk["coefficients"][0])
            ch = CHANNELS[lk["channel"]]
            half = max(0.3 * abs(a0), 0.1 * (ch.hi - ch.lo))
            cls = law_effect_class(lk, bounds={"a": (a0 - half, a0 + half)})
            space = FitSpace((cls(),), ((0, 0),))
            train = np.setdiff1d(np.arange(data.n), h)
            fit = fit_folds(sim, space, [train], grid_points=grid_points,
                            zoom_rounds=zoom_rounds)
            models.append(space.model(fit.x[0]))
        else:
            models.append((law_effect_class(lk)(),))
    return _held_out(sim, models, held)


def _fold_law(data: Any, table: pd.DataFrame, law: Mapping[str, Any], h: np.ndarray,
              k: int) -> dict[str, Any]:
    """The law refitted to the identified values of the cases outside fold ``h``."""
    t, y, w = law_rows(table, law["channel"])
    pos = pd.Index(data.case_ids).get_indexer(t["case_id"])
    x = t[law["feature"]].to_numpy(float)
    tr = ~np.isin(pos, h)
    out = refit_law(law, x[tr], y[tr], w[tr], name=f"{law['name']}_cv{k}")
    if out["form"] == "table":  # the simulator's cache knows a table law by name only
        import hashlib

        digest = hashlib.sha1(np.asarray(out["table"]["y"], float).tobytes()).hexdigest()
        out["name"] = f"{out['name']}_{digest[:10]}"
    return out


def _held_out(sim: Any, models: Sequence[Any], held: Sequence[np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Held-out residuals and per-case errors of one model per fold (one stacked call)."""
    data = sim.data
    res = sim.residuals(models)
    residuals = np.full_like(data.observed, np.nan)
    for h, r in zip(held, res, strict=True):
        residuals[h] = r[h]
    return residuals, data.case_errors(residuals)


def cross_validate_laws(sim: Any, laws: Sequence[tuple[pd.DataFrame, Mapping[str, Any]]],
                        held: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Cross-validated outcome errors of several laws used together as effects.

    As :func:`cross_validate_law`, each law refitted per fold to the
    training cases' identified values of its own identification table (the
    laws of a stepwise model come from identifications conditional on each
    other, :func:`vfs.diagnosis.diagnose.diagnose`); all laws of a fold are
    applied together.

    Parameters
    ----------
    sim : VariantSimulator
    laws : sequence of (table, law)
        Identification table (joined with the features) and law mapping.
    held : sequence of int arrays
        Held-out rows (positions in ``sim.data``).

    Returns
    -------
    (residuals, errors)
        Held-out residuals (n, n_columns) and per-case errors (n, n_groups).
    """
    return _held_out(sim, fold_law_effects(sim.data, laws, held), held)


def fold_law_effects(data: Any, laws: Sequence[tuple[pd.DataFrame, Mapping[str, Any]]],
                     held: Sequence[np.ndarray]) -> list[tuple[Any, ...]]:
    """Per fold, one effect per law, refitted to the identified values of the cases outside
    the fold (:func:`cross_validate_laws`); table laws get a name that tells their values
    apart (the simulator's cache knows a model by names and parameters).
    """
    from vfs.effects.learned import law_effect_class

    return [tuple(law_effect_class(_fold_law(data, t, law, h, k))() for t, law in laws)
            for k, h in enumerate(held)]


def learn_channel(table: pd.DataFrame, channel: str,
                  features: Iterable[str] = LEARN_FEATURES, folds: int = DiagnoseSpec.folds,
                  seed: int = DiagnoseSpec.seed, forms: Iterable[str] | None = None,
                  confidence: float = DiagnoseSpec.confidence,
                  n_boot: int = 1000, min_reduction: float = 0.05,
                  band_boot: int = 100) -> ChannelLaw:
    """Learn the law of one channel from the identification table (see the module docstring).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`vfs.diagnosis.identify.identify` rows joined with the case
        features (``identified.parquet``).
    channel : str
    features : iterable of str
        Numeric feature columns to try.
    folds, seed : int
        K-fold CV by case (seeded).
    forms : iterable of str, optional
        Closed forms (default all of :data:`FORMS`).
    confidence : float
        Simultaneous level of the reduction CI (Bonferroni over the features).
    n_boot : int
        Bootstrap samples of the reduction CI.
    min_reduction : float
        Smallest CV RMSE reduction against the constant that counts.
    band_boot : int
        Bootstrap refits of the spline for its band.
    """
    if channel not in CHANNELS:
        raise ParameterError(f"unknown channel {channel!r}; known: {sorted(CHANNELS)}")
    t = table[(table["channel"] == channel)]
    if t.empty:
        raise ParameterError(f"identification table: no rows of channel {channel!r} "
                             f"(channels: {sorted(set(table['channel']))})")
    t, y, w = law_rows(table, channel)
    feats = [f for f in features if f in t.columns]
    n = y.size
    empty = pd.DataFrame(columns=["feature", "form", "cv_mse", "reduction", "coefficients"])
    if n < MIN_LAW_CASES:
        return ChannelLaw(channel, n, False, None, math.nan, math.nan, math.nan, empty,
                          note=f"fewer than {MIN_LAW_CASES} identifiable cases")
    held = kfold_indices(n, folds, seed)
    form_names = list(forms) if forms is not None else list(FORMS)
    if "constant" not in form_names:
        form_names.insert(0, "constant")
    # per feature: robust smoothing spline over all cases, whose weights flag the cases
    # identified at a wrong minimum (the spline's folds reuse them) and whose residual
    # scale gives that of the robust CV loss
    splines: dict[str, tuple[Any, np.ndarray, float]] = {}
    for feat in feats:
        x = t[feat].to_numpy(float)
        if np.isfinite(x).all() and np.ptp(x) > 0:
            splines[feat] = robust_spline(x, y, w)
    scale = _noise_scale([v[2] for v in splines.values() if v[0] is not None], y, w)

    def loss(pred: np.ndarray) -> np.ndarray:
        """Per-case robust loss of predictions (the channel's unit squared)."""
        return scale ** 2 * robust_loss(np.sqrt(w) * (y - pred) / scale)

    const_pred = _cv_predictions("constant", y, y, w, held)
    e0 = loss(const_pred)
    null = "constant"
    if "model_value" in t.columns:  # the model's own value of the channel (no law)
        mv = t["model_value"].to_numpy(float)
        em = loss(mv)
        if np.isfinite(em).all() and em.mean() < e0.mean():
            e0, null = em, "model"
    mse0 = float(np.mean(e0))
    rows: list[dict[str, Any]] = []
    # per (feature, form): the robust fit on all cases and the held-out predictions
    fits: dict[tuple[str, str], tuple[list[float], np.ndarray]] = {}
    for feat in splines:
        x = t[feat].to_numpy(float)
        rw = splines[feat][1]
        for form in [f for f in form_names if f != "constant"] + ["spline"]:
            if form == "power" and x.min() <= 0:
                continue
            coef: list[float] = []
            if form == "spline":
                pred = _cv_predictions(form, x, y, w * rw, held, robust=False)
            else:
                coef = fit_form(form, x, y, w)
                pred = _cv_predictions(form, x, y, w, held, start=coef)
            fits[feat, form] = (coef, pred)
            e = loss(pred)
            if not np.isfinite(e).all():
                continue
            mse = float(np.mean(e))
            rows.append({"feature": feat, "form": form, "cv_mse": mse,
                         "reduction": 1.0 - math.sqrt(mse / mse0) if mse0 > 0 else math.nan,
                         "coefficients": " ".join(f"{v:.5g}" for v in coef)})
    cand = pd.DataFrame(rows) if rows else empty
    if cand.empty:
        return ChannelLaw(channel, n, False, None, math.nan, math.nan, math.nan, cand,
                          note="no usable feature")
    cand = cand.sort_values("cv_mse", kind="stable").reset_index(drop=True)
    top = cand.iloc[0]
    feat = str(top["feature"])
    in_feat = cand[cand["feature"] == feat]
    closed = in_feat[in_feat["form"] != "spline"]
    form = str(top["form"])
    if form == "spline" and len(closed) and \
            float(closed["cv_mse"].iloc[0]) <= (1 + CLOSED_FORM_TOLERANCE) * float(top["cv_mse"]):
        form = str(closed["form"].iloc[0])
    x = t[feat].to_numpy(float)
    spl, rw, _ = splines[feat]
    coef, pred = fits[feat, form]
    e = loss(pred)
    level = 1.0 - (1.0 - confidence) / max(len(feats), 1)
    rng = np.random.default_rng(seed)
    est, lo, hi = reduction_ci(e[:, None], e0[:, None], rng, confidence=level, n_boot=n_boot)
    significant = bool(np.isfinite(lo) and lo > 0 and est >= min_reduction)
    ch = CHANNELS[channel]
    law: dict[str, Any] = {"name": f"learned_{channel}", "channel": channel, "feature": feat,
                           "channel_unit": ch.unit, "feature_unit": LAW_FEATURES[feat],
                           "mode": ch.mode}
    xg = np.linspace(float(x.min()), float(x.max()), 41)
    band: dict[str, list[float]] = {}
    if spl is not None:
        curve = predict_spline(spl, xg, x.min(), x.max())
        boots = []
        for _ in range(band_boot):  # resampled cases, their robust weights held
            idx = rng.integers(0, n, n)
            s = smoothing_spline(x[idx], y[idx], (w * rw)[idx])
            if s is not None:
                boots.append(predict_spline(s, xg, x[idx].min(), x[idx].max()))
        b = np.array(boots) if boots else np.array([curve])
        band = {"x": xg.tolist(), "y": curve.tolist(),
                "low": np.quantile(b, 0.025, axis=0).tolist(),
                "high": np.quantile(b, 0.975, axis=0).tolist()}
    if form == "spline":
        law.update(form="table", table={"x": xg.tolist(), "y": band["y"]} if band else
                   {"x": [0.0, 1.0], "y": [float(np.mean(y))] * 2})
    else:
        law.update(form=form, coefficients=coef)
    law["cv"] = {"reduction_vs_constant": est, "null": null, "ci_low": lo, "ci_high": hi,
                 "confidence": level, "cases": n, "folds": folds}
    law["feature_range"] = [float(x.min()), float(x.max())]
    law["formula"] = law_text(law)
    return ChannelLaw(channel, n, significant, law, est, lo, hi, cand, band, null=null)


def learn(table: pd.DataFrame, channels: Iterable[str] | None = None,
          **options: Any) -> list[ChannelLaw]:
    """:func:`learn_channel` for each channel of the table (default all present)."""
    names = list(channels) if channels is not None else \
        [c for c in CHANNELS if c in set(table["channel"])]
    return [learn_channel(table, c, **options) for c in names]


#: What "significant" means in ``vfs learn`` (its output and ``law.json``).
LEARN_SCOPE = ("significant = structure in the identified values, each channel identified "
               "with the other channels at the model's values (a law missing on one channel "
               "leaks into the others); not cross-validated on the outcomes: vfs diagnose "
               "--laws decides which laws are claimed")


def laws_document(results: Sequence[ChannelLaw]) -> dict[str, Any]:
    """JSON-ready ``law.json``: the significant laws and the channels without structure."""
    return {
        "format": "vfs-law/1",
        "note": LEARN_SCOPE,
        "laws": [r.law for r in results if r.significant and r.law is not None],
        "results": [{"channel": r.channel, "significant": r.significant, "cases": r.n,
                     "text": r.text(), "reduction": r.reduction, "ci_low": r.low,
                     "ci_high": r.high, "law": r.law, "band": r.band,
                     "candidates": r.candidates.head(12).to_dict(orient="records")}
                    for r in results],
    }


def read_laws(doc: Mapping[str, Any] | str) -> list[dict[str, Any]]:
    """The laws of a ``law.json`` document (a path or the parsed mapping).

    Accepts ``{"laws": [...]}`` or a single law mapping.
    """
    import json
    from pathlib import Path

    if isinstance(doc, str):
        p = Path(doc)
        if not p.is_file():
            raise ParameterError(f"law file {doc}: no such file")
        doc = json.loads(p.read_text())
    if not isinstance(doc, Mapping):
        raise ParameterError("law document: expected a JSON object")
    if "laws" in doc:
        return [dict(x) for x in doc["laws"]]
    return [dict(doc)]


PLUGIN_TEMPLATE = '''"""Learned law exported by ``vfs learn --export-plugin`` (edit freely).

{formula}

Use it with ``--plugin {file}`` in ``vfs calibrate``, ``vfs diagnose`` and
``vfs compare``: it registers the effect ``{name}``.  Learned on {cases} cases:
cross-validated RMSE reduction against a constant {reduction:.1f} %.
"""

import numpy as np

from vfs.effects import register_effect
from vfs.effects.learned import ChannelLaw, law_effect_class

#: The law: channel {channel!r} [{channel_unit}] as a function of feature {feature!r}
#: [{feature_unit}]; form {form!r}.
LAW = {law_repr}


def law_value(x{signature}):
    """The law at feature values x [{feature_unit}] -> {channel} [{channel_unit}]."""
    x = np.asarray(x, float)
{body}


_Base = law_effect_class(LAW)


@register_effect
class Learned(_Base):
    """{channel} = f({feature}) (learned; see LAW)."""

    name = LAW["name"]

    def value(self, ctx, config, base):
        """Apply :func:`law_value` (clipped to the channel's range)."""
        from vfs.effects.learned import CHANNELS, feature_values

        ch = CHANNELS[LAW["channel"]]
        x = feature_values(ctx, config, LAW["feature"])
        if LAW["form"] == "table":
            return ChannelLaw.value(self, ctx, config, base)
        coefficients = [self[p.name] for p in type(self).parameters]
        v = np.clip(law_value(x, *coefficients), ch.lo, ch.hi)
        v = base + v if ch.mode == "shift" else v
        return np.where(np.isfinite(v), v, base)
'''


def plugin_source(law: Mapping[str, Any], file: str = "law.py") -> str:
    """Readable Python source of a plugin that registers ``law`` as an effect."""
    import pprint

    form = law["form"]
    signature = ""
    if form == "table":
        body = ('    t = LAW["table"]\n'
                '    return np.interp(x, np.asarray(t["x"]), np.asarray(t["y"]))')
    else:
        names = FORMS[form][1]
        signature = "".join(f", {n}={float(v)!r}" for n, v in
                            zip(names, law["coefficients"], strict=True))
        expr = FORM_EXPRESSIONS[form][1]
        body = f"    return {expr}"
    clean = {k: v for k, v in law.items() if k not in ("cv",)}
    cv = law.get("cv", {})
    return PLUGIN_TEMPLATE.format(
        formula=law_text(law), file=file, name=law["name"], cases=cv.get("cases", "?"),
        reduction=100 * float(cv.get("reduction_vs_constant", math.nan)),
        channel=law["channel"], feature=law["feature"],
        channel_unit=CHANNELS[law["channel"]].unit, feature_unit=LAW_FEATURES[law["feature"]],
        form=form, signature=signature,
        law_repr=pprint.pformat(clean, width=88, sort_dicts=False), body=body)


__all__ = ["BOUND_FIT_LEVEL", "CLOSED_FORM_TOLERANCE", "LEARN_FEATURES", "LEARN_SCOPE",
           "MIN_LAW_CASES",
           "ChannelLaw", "cross_validate_law", "cross_validate_laws", "fold_law_effects",
           "law_rows", "laws_document", "learn", "learn_channel", "plugin_source", "read_laws",
           "refit_law"]
