"""Law discovery: regress identified channels on case features (``vfs learn``).

Input: the per-case identification of :mod:`vfs.analysis.identify` joined
with the case features (closing speed, normal closing speed, overlap,
impact angle, mass ratio, impact speeds, road friction; SI units).  For
each channel, only the identifiable cases are used, weighted by
1 / sigma^2 with sigma the half width of the chi^2 + 1 interval (floored at
a tenth of the spread of the values, so that no case dominates).

For each numeric feature, k-fold cross-validation (seeded) of

* a smoothing spline (:func:`scipy.interpolate.make_smoothing_spline`, its
  smoothness chosen by generalised cross-validation), with a bootstrap band;
* the closed forms of :data:`vfs.effects.learned.FORMS` (constant, linear,
  power, exponential, saturating, step): the nonlinear coefficient by a
  grid and :func:`scipy.optimize.minimize_scalar`, the linear ones by
  weighted least squares.

The best (feature, form) is the one with the lowest CV error; a closed form
is preferred to the spline when its CV error is at most 2 % higher (a
formula the user can read).  The law is *significant* when the bootstrap
CI (over cases, Bonferroni over the features) of its CV RMSE reduction
against the constant lies above zero and the reduction reaches
``min_reduction``; otherwise the channel is reported as "no structure".
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vfs.analysis.calibrate import kfold_indices, reduction_ci
from vfs.effects.learned import CHANNELS, FORMS, LAW_FEATURES, evaluate_law, law_text
from vfs.errors import ParameterError

#: Numeric features regressed on, in report order.
LEARN_FEATURES: tuple[str, ...] = tuple(LAW_FEATURES)
#: A closed form is preferred to the spline up to this relative CV excess.
CLOSED_FORM_TOLERANCE = 0.02
#: Fewest identifiable cases for a law.
MIN_LAW_CASES = 30


def _wls(cols: Sequence[np.ndarray], y: np.ndarray, w: np.ndarray) -> np.ndarray:
    a = np.stack(cols, axis=1) * np.sqrt(w)[:, None]
    coef, *_ = np.linalg.lstsq(a, y * np.sqrt(w), rcond=None)
    return np.asarray(coef, float)


def fit_form(form: str, x: np.ndarray, y: np.ndarray, w: np.ndarray) -> list[float]:
    """Weighted least-squares coefficients of a closed form (:data:`FORMS`)."""
    from scipy.optimize import minimize_scalar

    one = np.ones_like(x)
    if form == "constant":
        return [float(np.sum(w * y) / np.sum(w))]
    if form == "linear":
        return [float(v) for v in _wls([one, x], y, w)]

    def inner(c: float) -> tuple[float, list[float]]:
        if form == "power":
            basis = [np.maximum(x, 1e-9) ** c]
        elif form == "exponential":
            basis = [np.exp(c * x)]
        elif form == "saturating":
            basis = [one, 1.0 - np.exp(-np.maximum(x, 0.0) / c)]
        else:  # step
            basis = [one, (x >= c).astype(float)]
        if not all(np.isfinite(b).all() for b in basis):
            return math.inf, []
        coef = [float(v) for v in _wls(basis, y, w)]
        if form in ("power", "exponential"):
            coef = [coef[0], c]
        else:
            coef = coef + [c]
        pred = evaluate_law({"form": form, "coefficients": coef}, x)
        sse = float(np.sum(w * (y - pred) ** 2))
        return (sse if math.isfinite(sse) else math.inf), coef

    span = float(np.ptp(x)) or 1.0
    if form == "power":
        grid = np.linspace(-3.0, 3.0, 25)
    elif form == "exponential":
        grid = np.linspace(-5.0, 5.0, 25) / span
    elif form == "saturating":
        grid = span * np.geomspace(0.02, 5.0, 25)
    else:
        grid = np.unique(np.quantile(x, np.linspace(0.05, 0.95, 37)))
    vals = [inner(float(c)) for c in grid]
    k = int(np.argmin([v[0] for v in vals]))
    best = vals[k]
    if form != "step" and len(grid) > 2:
        lo, hi = float(grid[max(k - 1, 0)]), float(grid[min(k + 1, len(grid) - 1)])
        if hi > lo:
            r = minimize_scalar(lambda c: inner(c)[0], bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-4 * (hi - lo)})
            cand = inner(float(r.x))
            if cand[0] < best[0]:
                best = cand
    if not best[1]:
        return [float(np.sum(w * y) / np.sum(w))] + [0.0] * (len(FORMS[form][1]) - 1)
    return best[1]


def _spline(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> Any:
    """Smoothing spline through weighted means of equal x (increasing abscissas)."""
    from scipy.interpolate import make_smoothing_spline

    order = np.argsort(x, kind="stable")
    xs, ys, ws = x[order], y[order], w[order]
    ux, inv = np.unique(np.round(xs, 9), return_inverse=True)
    sw = np.bincount(inv, ws)
    my = np.bincount(inv, ws * ys) / sw
    if ux.size < 5:
        return None
    return make_smoothing_spline(ux, my, w=sw / sw.mean())


def predict_spline(spl: Any, x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Spline values, held constant outside [lo, hi] (no extrapolation)."""
    return np.asarray(spl(np.clip(x, lo, hi)), float)


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
        CV RMSE reduction of the law against the constant, with its CI.
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

    def text(self) -> str:
        """One line for reports."""
        if self.law is None or not self.significant:
            return (f"{self.channel}: no structure ({self.note or 'nothing beats the constant'}"
                    f"; {self.n} identifiable cases)")
        return (f"{self.channel} follows f({self.law['feature']}): {law_text(self.law)}; "
                f"CV reduction vs constant {100 * self.reduction:.1f} % "
                f"[{100 * self.low:.1f}, {100 * self.high:.1f}] ({self.n} cases)")


def _cv_predictions(form: str, x: np.ndarray, y: np.ndarray, w: np.ndarray,
                    held: Sequence[np.ndarray]) -> np.ndarray:
    pred = np.full_like(y, np.nan)
    for h in held:
        tr = np.setdiff1d(np.arange(y.size), h)
        if form == "spline":
            spl = _spline(x[tr], y[tr], w[tr])
            if spl is None:
                continue
            pred[h] = predict_spline(spl, x[h], x[tr].min(), x[tr].max())
        else:
            coef = fit_form(form, x[tr], y[tr], w[tr])
            pred[h] = evaluate_law({"form": form, "coefficients": coef}, x[h])
    return pred


def learn_channel(table: pd.DataFrame, channel: str,
                  features: Iterable[str] = LEARN_FEATURES, folds: int = 5, seed: int = 0,
                  forms: Iterable[str] | None = None, confidence: float = 0.95,
                  n_boot: int = 1000, min_reduction: float = 0.05,
                  band_boot: int = 100) -> ChannelLaw:
    """Learn the law of one channel from the identification table (see the module docstring).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`vfs.analysis.identify.identify` rows joined with the case
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
    t = t[t["identifiable"].astype(bool) & np.isfinite(t["value"].to_numpy(float))]
    feats = [f for f in features if f in t.columns]
    y = t["value"].to_numpy(float)
    n = y.size
    empty = pd.DataFrame(columns=["feature", "form", "cv_mse", "reduction", "coefficients"])
    if n < MIN_LAW_CASES:
        return ChannelLaw(channel, n, False, None, math.nan, math.nan, math.nan, empty,
                          note=f"fewer than {MIN_LAW_CASES} identifiable cases")
    sigma = 0.5 * (t["high"].to_numpy(float) - t["low"].to_numpy(float))
    floor = 0.1 * float(np.std(y)) if np.std(y) > 0 else 1e-6
    w = 1.0 / np.maximum(sigma, floor) ** 2
    w = w / w.mean()
    held = kfold_indices(n, folds, seed)
    form_names = list(forms) if forms is not None else list(FORMS)
    if "constant" not in form_names:
        form_names.insert(0, "constant")
    const_pred = _cv_predictions("constant", y, y, w, held)
    e0 = w * (y - const_pred) ** 2
    mse0 = float(np.mean(e0))
    rows: list[dict[str, Any]] = []
    for feat in feats:
        x = t[feat].to_numpy(float)
        ok = np.isfinite(x)
        if ok.sum() < n or np.ptp(x) == 0:
            continue
        for form in [f for f in form_names if f != "constant"] + ["spline"]:
            if form == "power" and x.min() <= 0:
                continue
            pred = _cv_predictions(form, x, y, w, held)
            e = w * (y - pred) ** 2
            if not np.isfinite(e).all():
                continue
            mse = float(np.mean(e))
            rows.append({"feature": feat, "form": form, "cv_mse": mse,
                         "reduction": 1.0 - math.sqrt(mse / mse0) if mse0 > 0 else math.nan,
                         "coefficients": "" if form == "spline" else
                         " ".join(f"{v:.5g}" for v in fit_form(form, x, y, w))})
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
    pred = _cv_predictions(form, x, y, w, held)
    e = w * (y - pred) ** 2
    level = 1.0 - (1.0 - confidence) / max(len(feats), 1)
    rng = np.random.default_rng(seed)
    est, lo, hi = reduction_ci(e[:, None], e0[:, None], rng, confidence=level, n_boot=n_boot)
    significant = bool(np.isfinite(lo) and lo > 0 and est >= min_reduction)
    ch = CHANNELS[channel]
    law: dict[str, Any] = {"name": f"learned_{channel}", "channel": channel, "feature": feat,
                           "channel_unit": ch.unit, "feature_unit": LAW_FEATURES[feat],
                           "mode": ch.mode}
    xg = np.linspace(float(x.min()), float(x.max()), 41)
    spl = _spline(x, y, w)
    band: dict[str, list[float]] = {}
    if spl is not None:
        curve = predict_spline(spl, xg, x.min(), x.max())
        boots = []
        for _ in range(band_boot):
            idx = rng.integers(0, n, n)
            s = _spline(x[idx], y[idx], w[idx])
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
        law.update(form=form, coefficients=fit_form(form, x, y, w))
    law["cv"] = {"reduction_vs_constant": est, "ci_low": lo, "ci_high": hi,
                 "confidence": level, "cases": n, "folds": folds}
    law["feature_range"] = [float(x.min()), float(x.max())]
    law["formula"] = law_text(law)
    return ChannelLaw(channel, n, significant, law, est, lo, hi, cand, band)


def learn(table: pd.DataFrame, channels: Iterable[str] | None = None,
          **options: Any) -> list[ChannelLaw]:
    """:func:`learn_channel` for each channel of the table (default all present)."""
    names = list(channels) if channels is not None else \
        [c for c in CHANNELS if c in set(table["channel"])]
    return [learn_channel(table, c, **options) for c in names]


def laws_document(results: Sequence[ChannelLaw]) -> dict[str, Any]:
    """JSON-ready ``law.json``: the significant laws and the channels without structure."""
    return {
        "format": "vfs-law/1",
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
        expr = {"constant": "np.full_like(x, a)", "linear": "a + b * x",
                "power": "a * np.maximum(x, 1e-9) ** b", "exponential": "a * np.exp(b * x)",
                "saturating": "a + b * (1.0 - np.exp(-np.maximum(x, 0.0) / c))",
                "step": "np.where(x >= c, a + b, a)"}[form]
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


__all__ = ["CLOSED_FORM_TOLERANCE", "LEARN_FEATURES", "MIN_LAW_CASES", "ChannelLaw",
           "fit_form", "laws_document", "learn", "learn_channel", "plugin_source",
           "predict_spline", "read_laws"]
