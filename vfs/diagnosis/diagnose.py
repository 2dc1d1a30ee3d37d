"""Model diagnosis: where the model fails and which effect is missing.

:func:`diagnose` compares the default model with the reconstructions of a
database (never with a ground-truth file):

1. **Where it fails.**  Residuals ``model - reconstruction`` of every output
   (:data:`vfs.outcomes.OUTPUT_GROUPS`), stratified by impact type, accident
   type, overlap (:func:`vfs.physics.geometry.swept_overlap` at the reconstruction's
   impact configuration), closing speed, mass ratio and impact angle
   (:func:`stratified_residuals`); associations of each signed residual with
   each case feature (Spearman's rank correlation for numeric features,
   Kruskal-Wallis for categorical ones, Benjamini-Hochberg or Holm over all
   tests, :func:`residual_associations`); the worst cases.
2. **Which effect is missing.**  Every candidate effect (registered effects
   by default) has its parameters fitted on the training folds and is scored
   on the held-out fold (k-fold cross-validation by case, seeded;
   :func:`vfs.diagnosis.calibrate.cross_validate`); the reduction of the CV RMSE of the
   standardised residuals, overall, over the effect's own outputs and per
   output, gets a bootstrap CI over cases (simultaneous over all candidates, Bonferroni).
   With ``parameters="primary"`` the parameters that are not fitted sit at their neutral
   values or at their nominal strengths, whichever fits each fold's training cases better
   (:meth:`vfs.diagnosis.calibrate.FitSpace.alternatives`).
3. **Beyond the library** (``laws``).  Each channel is identified per case
   (:mod:`vfs.diagnosis.identify`) and its law learned (:mod:`vfs.diagnosis.learn`); every
   law with structure is cross-validated as an effect in outcome space.
4. **One selection** over the library effects and the learned laws
   (:func:`vfs.diagnosis.selection.select` with :class:`vfs.diagnosis.claims.ModelEvaluator`):
   forward stepwise on top of the claims (laws learned again from their channels
   re-identified with the claims applied), each claim under :func:`helps` on top and
   refitted together, with backward checks after each addition; the rejected candidates
   carry their reason ("mimics X", ...).  Below ``min_cases`` cases (or with held-out folds
   of fewer than :data:`MIN_FOLD_CASES` cases) nothing is claimed.  Residual structure
   left after the claims is reported with the strata it points to.

:func:`vfs.report.diagnose.write_diagnosis_report` writes the ranked table (CSV), a
JSON summary, and Markdown and HTML reports with figures.  Reports show km/h and degrees
(display units of :mod:`vfs.outcomes`); all computations are SI.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from vfs.blas import one_blas_thread
from vfs.diagnosis.calibrate import (
    CalibrationData,
    CVResult,
    FitSpace,
    VariantSimulator,
    cross_validate,
    cross_validate_many,
    group_mse,
    kfold_indices,
    reduction_ci,
    rmse_reduction,
)
from vfs.diagnosis.claims import (
    LawFinding,
    ModelEvaluator,
    Reduction,
    first_laws,
    law_key,
)
from vfs.diagnosis.claims import (
    format_reduction as fr,
)
from vfs.diagnosis.diagnose_spec import (
    MIN_CASES,
    MIN_FOLD_CASES,
    Correction,
    DiagnoseSpec,
    Parameters,
)
from vfs.diagnosis.features import case_features
from vfs.diagnosis.selection import Selection, select, step_label
from vfs.effects import get_effect, registered_effects
from vfs.outcomes import OUTPUT_GROUPS, QUANTITIES, Quantity
from vfs.settings import member
from vfs.simulation import SimulationParams

#: Numeric case features (name -> quantity kind: SI unit, report unit and factor).
NUMERIC_FEATURES: Mapping[str, Quantity] = MappingProxyType({
    "closing_speed": QUANTITIES["speed"],
    "overlap": QUANTITIES["fraction"],
    "mass_ratio": QUANTITIES["dimensionless"],
    "impact_angle": QUANTITIES["angle"],
    "impact_speed1": QUANTITIES["speed"],
    "impact_speed2": QUANTITIES["speed"],
    "road_friction": QUANTITIES["dimensionless"],
    "restitution": QUANTITIES["dimensionless"],
    "contact_friction": QUANTITIES["dimensionless"],
})


#: Categorical case features.
CATEGORICAL_FEATURES: tuple[str, ...] = ("impact_type", "accident_type", "road_surface")

#: Bins of the stratified residual table (feature -> (edges in report units, labels)).
STRATA_BINS: dict[str, tuple[tuple[float, ...], tuple[str, ...]]] = {
    "overlap": ((0, 25, 50, 75, 100.0001), ("0-25 %", "25-50 %", "50-75 %", "75-100 %")),
    "closing_speed": ((0, 30, 50, 70, 90, math.inf),
                      ("< 30 km/h", "30-50 km/h", "50-70 km/h", "70-90 km/h", ">= 90 km/h")),
    "mass_ratio": ((0, 0.8, 1.25, math.inf), ("m1/m2 < 0.8", "0.8-1.25", "m1/m2 >= 1.25")),
    "impact_angle": ((0, 30, 60, 120, 150, 180.0001),
                     ("0-30 deg", "30-60 deg", "60-120 deg", "120-150 deg", "150-180 deg")),
}
#: Stratifying features, in report order.
STRATA_FEATURES: tuple[str, ...] = ("impact_type", "accident_type", "overlap", "closing_speed",
                                    "mass_ratio", "impact_angle")


# ----------------------------------------------------------------------------
# Where the model fails
# ----------------------------------------------------------------------------


def _strata_labels(features: pd.DataFrame, feature: str) -> pd.Series:
    if feature in CATEGORICAL_FEATURES:
        return features[feature].astype(str)
    edges, labels = STRATA_BINS[feature]
    factor = NUMERIC_FEATURES[feature].display_factor
    values = features[feature].to_numpy(float) * factor
    cut = pd.Series(pd.cut(values, bins=list(edges), labels=list(labels), right=False))
    return pd.Series(cut.astype(object).fillna("unknown").to_numpy(), index=features.index)


def stratified_residuals(data: CalibrationData, residuals: np.ndarray,
                         features: pd.DataFrame,
                         strata: Sequence[str] = STRATA_FEATURES) -> pd.DataFrame:
    """Residual statistics per stratum of each stratifying feature (long table).

    Columns: feature, stratum, output, column, n, bias (mean residual) and rmse in the
    output's report unit, rmse_std (RMSE of the standardised residuals of the output).
    """
    rows: list[dict[str, Any]] = []
    errors = data.case_errors(residuals)
    for feature in strata:
        labels = _strata_labels(features, feature)
        for stratum in sorted(labels.unique(), key=str):
            sel = (labels == stratum).to_numpy()
            for k, g in enumerate(data.groups):
                rmse_std = math.sqrt(group_mse(errors, np.flatnonzero(sel))[k]) \
                    if np.isfinite(errors[sel, k]).any() else float("nan")
                for j in np.flatnonzero(data.column_group == k):
                    r = residuals[sel, j] * g.quantity.display_factor
                    r = r[np.isfinite(r)]
                    rows.append({
                        "feature": feature, "stratum": stratum, "output": g.name,
                        "column": data.columns[j], "n": int(r.size),
                        "bias": float(r.mean()) if r.size else float("nan"),
                        "rmse": float(np.sqrt(np.mean(r ** 2))) if r.size else float("nan"),
                        "unit": g.quantity.display_unit, "rmse_std": rmse_std,
                    })
    return pd.DataFrame(rows)


def residual_variables(data: CalibrationData, residuals: np.ndarray) -> pd.DataFrame:
    """Signed residual columns used for the feature associations.

    Every residual column except the rest-position coordinates (their sign
    depends on the orientation of the scene; the run-out distance carries
    their signed information).
    """
    keep = [j for j, c in enumerate(data.columns)
            if data.groups[data.column_group[j]].name != "rest_position"]
    return pd.DataFrame({data.columns[j]: residuals[:, j] for j in keep})


def residual_associations(variables: pd.DataFrame, features: pd.DataFrame,
                          correction: str = Correction.BH, alpha: float = DiagnoseSpec.alpha,
                          min_cases: int = 10) -> pd.DataFrame:
    """Association of each residual with each case feature, with multiplicity control.

    Numeric features: Spearman's rank correlation (statistic = rho);
    categorical features: Kruskal-Wallis H test over the categories with at
    least 5 cases (statistic = epsilon^2 = H / (n - 1)).  The p-values of all
    tests are adjusted together (``correction`` "bh": Benjamini-Hochberg,
    false discovery rate; "holm": Holm-Bonferroni, family-wise error).

    Returns
    -------
    pandas.DataFrame
        residual, feature, test, n, statistic, p, p_adj, significant
        (p_adj < alpha), sorted by p.
    """
    from scipy import stats as sps

    from vfs.analysis.stats import benjamini_hochberg, holm_bonferroni

    correction = member(Correction, correction, owner="residual_associations",
                        name="correction")
    rows: list[dict[str, Any]] = []
    for rname in variables.columns:
        r = variables[rname].to_numpy(float)
        for feat in list(NUMERIC_FEATURES) + list(CATEGORICAL_FEATURES):
            if feat not in features.columns:
                continue
            if feat in NUMERIC_FEATURES:
                f = features[feat].to_numpy(float)
                ok = np.isfinite(r) & np.isfinite(f)
                if ok.sum() < min_cases or np.ptp(f[ok]) == 0 or np.ptp(r[ok]) == 0:
                    continue
                rho, p = sps.spearmanr(r[ok], f[ok])
                rows.append({"residual": rname, "feature": feat, "test": "spearman",
                             "n": int(ok.sum()), "statistic": float(rho), "p": float(p)})
            else:
                cat = features[feat].astype(str).to_numpy()
                ok = np.isfinite(r)
                groups = [r[ok & (cat == c)] for c in np.unique(cat[ok])]
                groups = [g for g in groups if g.size >= 5]
                if len(groups) < 2 or np.ptp(np.concatenate(groups)) == 0:
                    continue
                h, p = sps.kruskal(*groups)
                n = int(sum(g.size for g in groups))
                rows.append({"residual": rname, "feature": feat, "test": "kruskal",
                             "n": n, "statistic": float(h / max(n - 1, 1)), "p": float(p)})
    out = pd.DataFrame(rows, columns=["residual", "feature", "test", "n", "statistic", "p"])
    if out.empty:
        out["p_adj"] = []
        out["significant"] = []
        return out
    p = out["p"].to_numpy(float)
    p = np.where(np.isfinite(p), p, np.nan)
    out["p_adj"] = benjamini_hochberg(p) if correction is Correction.BH else holm_bonferroni(p)
    out["significant"] = out["p_adj"] < alpha
    return out.sort_values(["p", "residual"], kind="stable").reset_index(drop=True)


def worst_cases(data: CalibrationData, residuals: np.ndarray, features: pd.DataFrame,
                count: int = 6) -> pd.DataFrame:
    """The cases with the largest mean standardised squared residual over the outputs."""
    e = data.case_errors(residuals)
    with np.errstate(invalid="ignore"):
        score = np.nanmean(e, axis=1)
    order = np.argsort(-np.nan_to_num(score, nan=-1.0), kind="stable")[:count]
    rows = []
    for i in order:
        k = int(np.nanargmax(np.nan_to_num(e[i], nan=-1.0)))
        rows.append({"index": int(i), "case_id": data.case_ids[i],
                     "accident_type": features["accident_type"].iloc[i],
                     "impact_type": features["impact_type"].iloc[i],
                     "rms_std_error": float(math.sqrt(score[i])),
                     "worst_output": data.groups[k].name,
                     "worst_output_rms_std": float(math.sqrt(e[i, k]))})
    return pd.DataFrame(rows)


# ----------------------------------------------------------------------------
# Which effect is missing
# ----------------------------------------------------------------------------


@dataclass
class CandidateResult:
    """Cross-validated result of one candidate effect.

    Attributes
    ----------
    name : str
    cv : CVResult
    overall : Reduction
        Over all compared outputs.
    affected : Reduction
        Over the outputs the effect declares (:attr:`Effect.outputs`) that
        are compared (all outputs if it declares none).
    per_output : dict of Reduction
    given_best : Reduction or None
        Reduction on top of the claims of ``on_top_of`` (fitted on all cases), against
        them: for a claim, at the step it joined; else at the last step it was tried; None
        when it was only tried alone.
    refit : Reduction or None
        For a candidate that helped on top: the claims refitted together with it against
        the claims alone.
    significant : bool
        Claimed by the selection (:func:`vfs.diagnosis.selection.select`); always False
        when the sample is too small (:attr:`Diagnosis.reliable`).
    status : str
        "claimed" or the reason it is not ("mimics X", "not significant", ...).
    share : Reduction or None
        A claim's share in the final joint model (it against the model without it).
    rank : int
        Verdict order: the claims first (leading explanation first), then the rejected.
    variants : int
        Model variants its search asked for (shared simulation calls; the
        time is reported for all candidates together).
    """

    name: str
    cv: CVResult
    overall: Reduction
    affected: Reduction
    per_output: dict[str, Reduction]
    affected_outputs: tuple[str, ...]
    significant: bool = False
    rank: int = 0
    variants: int = 0
    given_best: Reduction | None = None
    refit: Reduction | None = None
    status: str = ""
    on_top_of: tuple[str, ...] = ()
    share: Reduction | None = None
    fitted_joint: list[dict[str, Any]] | None = None

    def fitted(self) -> list[dict[str, Any]]:
        """Parameters fitted on all cases: in the selected joint model when claimed, else
        alone (empty if the default model fits better).
        """
        return self.fitted_joint if self.fitted_joint else self.cv.fitted_parameters()


@dataclass
class Diagnosis:
    """Everything :func:`diagnose` found.

    Written as a report by :func:`vfs.report.diagnose.write_diagnosis_report`.
    """

    data: CalibrationData
    features: pd.DataFrame
    default: CVResult
    candidates: list[CandidateResult]
    strata: pd.DataFrame
    associations: pd.DataFrame
    remaining: pd.DataFrame
    remaining_model: str
    worst: pd.DataFrame
    verdict: list[str]
    settings: dict[str, Any]
    stats: dict[str, Any] = field(default_factory=dict)
    database: str = ""
    reliable: bool = True
    laws: list[LawFinding] = field(default_factory=list)
    identification: pd.DataFrame | None = None
    selection: Selection | None = None
    spec: DiagnoseSpec | None = None
    selected_residuals: np.ndarray | None = field(default=None, repr=False)

    @property
    def claims(self) -> list[str]:
        """The final claims (library effect names, ``"<channel> law"``), verdict order."""
        return list(self.selection.claims) if self.selection else \
            [c.name for c in self.candidates if c.significant]

    def selection_table(self) -> pd.DataFrame:
        """One row per candidate of the selection, library effects and learned laws, in
        verdict order: status, reduction alone, on top of the claims, refitted with them,
        share in the final model (each with its simultaneous CI), formula or parameters.
        The console and the reports show this table (one source).
        """
        laws = {law_key(f.channel): f for f in self.laws}
        effects = {c.name: c for c in self.candidates}
        sel = self.selection
        names = [*sel.claims, *sel.rejected] if sel else list(effects)
        rows = []
        for n in names:
            c, f = effects.get(n), laws.get(n)
            if c is None and f is None:
                continue
            alone = c.overall if c is not None else f.outcome  # type: ignore[union-attr]
            top = c.given_best if c is not None else f.given_claimed  # type: ignore[union-attr]
            on = (c.on_top_of if c is not None else f.on_top_of)  # type: ignore[union-attr]
            refit = sel.refit.get(n) if sel else None
            share = sel.share.get(n) if sel else None
            rows.append({
                "candidate": n, "kind": "effect" if c is not None else "law",
                "status": ("claimed" if n in self.claims else
                           (sel.reasons.get(n, "") if sel else "")),
                "alone": alone.estimate, "alone_low": alone.low, "alone_high": alone.high,
                "on_top_of": "+".join(on),
                "on_top": top.estimate if top else np.nan,
                "on_top_low": top.low if top else np.nan,
                "on_top_high": top.high if top else np.nan,
                "refit": refit.estimate if refit else np.nan,
                "refit_low": refit.low if refit else np.nan,
                "refit_high": refit.high if refit else np.nan,
                "share": share.estimate if share else np.nan,
                "share_low": share.low if share else np.nan,
                "share_high": share.high if share else np.nan,
                "model": (_format_params(c.fitted()) if c is not None
                          else f.learned.law["formula"]),  # type: ignore[union-attr]
            })
        return pd.DataFrame(rows)

    def selection_residuals(self) -> np.ndarray:
        """Held-out residuals of the selected joint model (the default model's if nothing
        is claimed).
        """
        return self.selected_residuals if self.selected_residuals is not None \
            else self.default.residuals

    def ledger_steps(self) -> pd.DataFrame:
        """The selection's steps: action, candidate, CV RMSE of the joint model after it."""
        steps = self.selection.steps if self.selection else []
        return pd.DataFrame([{"step": i, "action": s.action, "candidate": s.name,
                              "model": "+".join(s.model) or "default", "cv_rmse": s.rmse,
                              "reduction": s.reduction.estimate if s.reduction else np.nan,
                              "low": s.reduction.low if s.reduction else np.nan,
                              "high": s.reduction.high if s.reduction else np.nan}
                             for i, s in enumerate(steps)])

    @property
    def ranking(self) -> list[str]:
        """Candidate names, best first."""
        return [c.name for c in self.candidates]

    @property
    def best(self) -> CandidateResult | None:
        """The leading claimed library effect, else None."""
        return self.candidates[0] if self.candidates and self.candidates[0].significant \
            else None

    def ranked_table(self) -> pd.DataFrame:
        """One row per candidate, best first: reductions with CIs, fitted parameters."""
        rows = []
        for c in self.candidates:
            row: dict[str, Any] = {
                "rank": c.rank, "effect": c.name, "significant": c.significant,
                "status": c.status,
                "reduction": c.overall.estimate, "ci_low": c.overall.low,
                "ci_high": c.overall.high, "reduction_affected": c.affected.estimate,
                "affected_ci_low": c.affected.low, "affected_ci_high": c.affected.high,
                "cv_rmse": c.cv.overall_rmse(),
                "reduction_given_best": c.given_best.estimate if c.given_best else np.nan,
                "given_best_ci_low": c.given_best.low if c.given_best else np.nan,
                "given_best_ci_high": c.given_best.high if c.given_best else np.nan,
                "reduction_refit": c.refit.estimate if c.refit else np.nan,
                "refit_ci_low": c.refit.low if c.refit else np.nan,
                "refit_ci_high": c.refit.high if c.refit else np.nan,
                "fitted": _format_params(c.fitted()),
                "variants": c.variants,
            }
            for g, r in c.per_output.items():
                row[f"reduction_{g}"] = r.estimate
            rows.append(row)
        return pd.DataFrame(rows)


def _format_params(effects: list[dict[str, Any]]) -> str:
    if not effects:
        return "off (default model)"
    return "; ".join(f"{e['name']}: " + ", ".join(f"{k}={v:.4g}"
                                                   for k, v in e["parameters"].items())
                     for e in effects)


def resolve_candidates(effects: str | Iterable[str] | None) -> list[str]:
    """Candidate effect names: "all"/None = every registered effect."""
    if effects is None or (isinstance(effects, str) and effects.strip() in ("", "all")):
        return sorted(registered_effects())
    names = [s.strip() for s in (effects.split(",") if isinstance(effects, str) else effects)]
    names = [s for s in names if s]
    for s in names:
        get_effect(s)
    return list(dict.fromkeys(names))


@one_blas_thread
def diagnose(db: Any, spec: DiagnoseSpec | None = None, *,
             params: SimulationParams | None = None,
             progress: Callable[[str], None] | None = None, **settings: Any) -> Diagnosis:
    """Diagnose the default model against the reconstructions of ``db``.

    Parameters
    ----------
    db : Database
        Analysed blind: only its tables (never a ground-truth file).
    spec : DiagnoseSpec, optional
        What to do (:class:`vfs.diagnosis.diagnose_spec.DiagnoseSpec`); or its fields as
        keyword arguments (``settings``; with a spec they replace its fields).
    params : SimulationParams, optional
        Base model (default: the default model).
    progress : callable, optional
        Called with one line per finished step.

    Notes
    -----
    Steps: where the model fails (:func:`_where_it_fails`), every library candidate alone
    (:func:`_library_alone`), every channel identified and its law learned
    (:func:`vfs.diagnosis.claims.first_laws`), then **one selection** over both
    (:func:`vfs.diagnosis.selection.select`: forward stepwise on top of the claims, with
    refits and backward checks), and the verdict from the final claims.
    """
    if spec is None:
        spec = DiagnoseSpec.from_kwargs(**settings)
    elif settings:
        spec = dataclasses.replace(spec, **settings)
    t0 = time.perf_counter()
    say = progress or (lambda _msg: None)
    data = CalibrationData.from_database(db, spec.outputs)
    spec.check_cases(data.n)
    names = resolve_candidates(spec.effects)
    sim = VariantSimulator(data, params)
    held = kfold_indices(data.n, spec.folds, spec.seed)
    reliable = spec.reliable(data.n) and min(len(h) for h in held) >= MIN_FOLD_CASES
    rng = np.random.default_rng(spec.seed)
    features = case_features(data)
    base = cross_validate(sim, FitSpace((), ()), held, "default", fit_all=False)
    say(f"default model: CV RMSE {base.overall_rmse():.3f} (standardised) over "
        f"{data.n} cases, {len(data.groups)} outputs")
    strata, assoc, worst_df = _where_it_fails(data, base, features, spec)
    cvs = _library_alone(sim, held, names, spec, say)
    table: pd.DataFrame | None = None
    law_alone: list[tuple[Any, np.ndarray]] = []
    ident: Callable[..., Any] | None = None
    learned: Callable[..., Any] | None = None
    t_law = time.perf_counter()
    if spec.laws:
        table, law_alone, ident, learned = first_laws(sim, base, held, spec.laws,
                                                      spec.law_grid, spec.seed, spec.n_boot,
                                                      say)
    law_seconds = time.perf_counter() - t_law
    level = 1.0 - (1.0 - spec.confidence) / max(len(names) + len(law_alone), 1)
    cands = _candidate_results(data, base, names, cvs, rng, level, spec)
    for c in cands:
        say(f"candidate {c.name}: CV RMSE reduction {fr(c.overall)} ({c.variants} variants)")

    def ci(err: np.ndarray, ref: np.ndarray) -> Reduction:
        return Reduction(*reduction_ci(err, ref, rng, confidence=level, n_boot=spec.n_boot))

    findings = {law_key(r.channel): LawFinding(r.channel, r, ci(err, base.errors), err,
                                               table=table)
                for r, err in law_alone}
    ev = ModelEvaluator(
        sim, held, base, {n: get_effect(n) for n in names},
        {**{c.name: c.cv.errors for c in cands}, **{k: f.errors for k, f in findings.items()}},
        findings, ident or (lambda _s, _n: pd.DataFrame()),
        learned or (lambda _t: []), ci, str(spec.parameters),
        {"grid_points": spec.grid_points, "zoom_rounds": spec.zoom_rounds}, say,
        alone_reductions={**{c.name: c.overall for c in cands},
                          **{k: f.outcome for k, f in findings.items()}},
        alone_cv={c.name: c.cv for c in cands}, group_ci=_group_ci(spec, len(data.groups)),
        min_worsening=spec.min_reduction)
    t_sel = time.perf_counter()
    sel = select([*names, *findings], ev, spec.min_reduction,
                 max_steps=spec.max_steps if spec.stepwise else 1, reliable=reliable,
                 worth_trying=lambda r: bool(np.isfinite(r.high)
                                             and r.high >= spec.min_reduction), say=say,
                 always_try=names)
    say(f"selection: {', '.join(sel.claims) or 'nothing claimed'} "
        f"({time.perf_counter() - t_sel:.1f} s)")
    cands, laws = _apply_selection(sel, cands, ev)
    final = tuple(sel.claims)
    after_res = ev.joint_residuals(final) if final else base.residuals
    remaining = residual_associations(residual_variables(data, after_res), features,
                                      str(spec.correction), spec.alpha)
    settings_out = {
        "outputs": list(data.group_names), "folds": spec.folds, "seed": spec.seed,
        "parameters": str(spec.parameters), "grid_points": spec.grid_points,
        "zoom_rounds": spec.zoom_rounds, "confidence": spec.confidence,
        "simultaneous_confidence": level, "n_boot": spec.n_boot,
        "correction": str(spec.correction), "alpha": spec.alpha,
        "min_reduction": spec.min_reduction, "candidates": names,
        "laws": list(spec.laws), "min_cases": spec.min_cases, "reliable": reliable,
        "max_steps": spec.max_steps, "law_rounds": spec.max_steps - 1,
        "fixed_parameters": ("neutral or nominal, per fold the better on the training cases"
                             if spec.parameters == Parameters.PRIMARY else "none (all fitted)"),
        "scales": dict(zip(data.group_names, data.scales.tolist(), strict=True)),
        "scale_source": dict(zip(data.group_names, data.scale_source, strict=True))}
    diag = Diagnosis(data, features, base, cands, strata, assoc, remaining,
                     "+".join(final) or "default", worst_df, [], settings_out,
                     database=spec.database, reliable=reliable, laws=laws,
                     identification=table, selection=sel, spec=spec,
                     selected_residuals=after_res)
    diag.verdict = _verdict(diag)
    diag.stats = {**sim.stats(), "total_seconds": round(time.perf_counter() - t0, 2),
                  "n_cases": data.n, "law_seconds": round(law_seconds, 2),
                  "selection_seconds": round(time.perf_counter() - t_sel, 2)}
    return diag


def _group_ci(spec: DiagnoseSpec, n_groups: int) -> Callable[[np.ndarray, np.ndarray, int],
                                                               Reduction]:
    """The per-output reduction CI of the rule "no output worse than the default model"
    (:meth:`vfs.diagnosis.claims.ModelEvaluator.worse`): Bonferroni over the output groups,
    its own seeded generator (the other CIs draw as before).
    """
    rng = np.random.default_rng([spec.seed, 7])
    level = 1.0 - (1.0 - spec.confidence) / max(n_groups, 1)

    def group_ci(err: np.ndarray, ref: np.ndarray, k: int) -> Reduction:
        return Reduction(*reduction_ci(err, ref, rng, group=k, confidence=level,
                                       n_boot=spec.n_boot))

    return group_ci


def _where_it_fails(data: CalibrationData, base: CVResult, features: pd.DataFrame,
                    spec: DiagnoseSpec) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Residuals by stratum, residual-feature associations and worst cases of the default model."""
    strata = stratified_residuals(data, base.residuals, features)
    assoc = residual_associations(residual_variables(data, base.residuals), features,
                                  str(spec.correction), spec.alpha)
    return strata, assoc, worst_cases(data, base.residuals, features, spec.worst)


def _library_alone(sim: VariantSimulator, held: Sequence[np.ndarray], names: Sequence[str],
                   spec: DiagnoseSpec, say: Callable[[str], None]) -> list[CVResult]:
    """Every library candidate alone, fitted per fold (one shared search)."""
    t1, v1 = time.perf_counter(), sim.n_variants
    spaces = [FitSpace.alternatives([get_effect(n)], str(spec.parameters)) for n in names]
    cvs = cross_validate_many(sim, spaces, held, list(names), allow_off=True,
                              grid_points=spec.grid_points,
                              zoom_rounds=spec.zoom_rounds) if names else []
    say(f"fitted {len(names)} candidates: {sim.n_variants - v1} model variants in "
        f"{time.perf_counter() - t1:.1f} s")
    return cvs


def _candidate_results(data: CalibrationData, base: CVResult, names: Sequence[str],
                       cvs: Sequence[CVResult], rng: np.random.Generator, level: float,
                       spec: DiagnoseSpec) -> list[CandidateResult]:
    """The reductions alone of each library candidate with their CIs."""
    out = []
    for name, cv in zip(names, cvs, strict=True):
        cls = get_effect(name)
        affected = tuple(o for o in cls.outputs if o in data.group_names) or data.group_names
        w = np.array([1.0 if g in affected else 0.0 for g in data.group_names])
        overall = Reduction(*reduction_ci(cv.errors, base.errors, rng, confidence=level,
                                          n_boot=spec.n_boot))
        own = Reduction(*reduction_ci(cv.errors, base.errors, rng, confidence=spec.confidence,
                                      n_boot=spec.n_boot, weights=w))
        per = {g: Reduction(*reduction_ci(cv.errors, base.errors, rng, group=k,
                                          confidence=spec.confidence, n_boot=spec.n_boot))
               for k, g in enumerate(data.group_names)}
        out.append(CandidateResult(name, cv, overall, own, per, affected, variants=cv.variants))
    return out


def _apply_selection(sel: Selection, cands: list[CandidateResult], ev: ModelEvaluator
                     ) -> tuple[list[CandidateResult], list[LawFinding]]:
    """Claims, reasons and conditional reductions onto the library candidates and laws;
    both in verdict order (claims first, the leading explanation first).
    """
    order = {n: i for i, n in enumerate([*sel.claims, *sel.rejected])}
    for c in cands:
        c.significant = c.name in sel.claims
        c.status = "claimed" if c.significant else sel.reasons.get(c.name, "")
        if sel.on_top_of.get(c.name):
            c.given_best = sel.on_top.get(c.name)
            c.on_top_of = sel.on_top_of[c.name]
        c.refit = sel.refit.get(c.name)
        c.share = sel.share.get(c.name)
        if c.significant:
            c.fitted_joint = [e.to_dict() for e in ev.joint(tuple(sel.claims))[1]
                              if e.name == c.name]
    cands.sort(key=lambda c: (order.get(c.name, len(order)), c.name))
    for i, c in enumerate(cands, 1):
        c.rank = i
    laws = []
    for key, f in ev.laws.items():
        f.significant = key in sel.claims
        f.reason = "claimed" if f.significant else sel.reasons.get(key, "")
        f.refit = sel.refit.get(key)
        f.share = sel.share.get(key)
        if sel.on_top_of.get(key) and f.given_claimed is None:
            f.given_claimed = sel.on_top.get(key)
            f.on_top_of = sel.on_top_of[key]
        laws.append(f)
    laws.sort(key=lambda f: (order.get(law_key(f.channel), len(order)), f.channel))
    return cands, laws


def _strata_hint(diag: Diagnosis, residual: str, feature: str, residuals: np.ndarray
                 ) -> str:
    """The stratum of ``feature`` with the largest mean |bias| of ``residual``."""
    data = diag.data
    if residual not in data.columns:
        return ""
    j = data.columns.index(residual)
    g = data.groups[data.column_group[j]]
    if feature in STRATA_BINS or feature in CATEGORICAL_FEATURES:
        labels = _strata_labels(diag.features, feature)
    else:
        values = diag.features[feature].to_numpy(float)
        q = np.nanquantile(values, [0, 1 / 3, 2 / 3, 1])
        unit = NUMERIC_FEATURES[feature].display_unit
        factor = NUMERIC_FEATURES[feature].display_factor
        names = ["low", "middle", "high"]
        idx = np.clip(np.searchsorted(q[1:-1], values, side="right"), 0, 2)
        labels = pd.Series([f"{names[i]} third ({q[i] * factor:.3g}-{q[i + 1] * factor:.3g}"
                            f" {unit})" for i in idx])
    best, best_bias, best_n = "", 0.0, 0
    for s in labels.unique():
        sel = (labels == s).to_numpy() & np.isfinite(residuals[:, j])
        if sel.sum() < 5:
            continue
        b = float(residuals[sel, j].mean() * g.quantity.display_factor)
        if abs(b) > abs(best_bias):
            best, best_bias, best_n = str(s), b, int(sel.sum())
    if not best:
        return ""
    unit = g.quantity.display_unit
    return f"largest bias in {feature} {best}: {best_bias:+.3g} {unit} (n = {best_n})"


def claim_label(diag: Diagnosis, name: str, formula: bool = True) -> str:
    """How a claim or candidate is named in the verdict and the reports: a library effect
    by its name, a learned law as "the law of <channel>: <formula>".
    """
    for f in diag.laws:
        if law_key(f.channel) == name:
            law = f.learned.law
            return (f"a law of {f.channel} over {law['feature']}: {law['formula']}" if formula
                    else f"the {f.channel} law (f({law['feature']}))")
    return name


def _verdict(diag: Diagnosis) -> list[str]:
    out: list[str] = []
    table = diag.selection_table()
    if not len(table):
        return ["No candidate effect was tested."]
    s = diag.settings
    level = f"{100 * s['confidence']:.0f} %"
    has_laws = bool((table["kind"] == "law").any())
    what = "candidate effect or learned law" if has_laws else "candidate effect"
    top = table.sort_values("alone", ascending=False, kind="stable").iloc[0]
    top_text = (f"{claim_label(diag, top['candidate'], False)}, {100 * top['alone']:.1f} % "
                f"[{100 * top['alone_low']:.1f}, {100 * top['alone_high']:.1f}]")
    claims = diag.claims
    if not diag.reliable:
        n, k = diag.data.n, s["folds"]
        out.append(
            f"UNRELIABLE: {n} cases in {k} folds (fewer than {s['min_cases']} cases or fewer "
            f"than {MIN_FOLD_CASES} held-out cases per fold): nothing is claimed; the "
            "cross-validated reductions and intervals below are shown, not concluded from.")
        out.append(f"Nothing is claimed with so few cases (the largest reduction alone: "
                   f"{top_text}, an interval that is not trustworthy at this size).")
    elif not claims:
        out.append(
            f"No {what} helps significantly: every simultaneous {level} CI of the "
            "cross-validated RMSE reduction includes 0 or the reduction is below "
            f"{100 * s['min_reduction']:.0f} % (best: {top_text}).")
    else:
        lead = claims[0]
        sel = diag.selection
        row = table.set_index("candidate").loc[lead]
        alone = (f"{100 * row['alone']:.1f} % [{100 * row['alone_low']:.1f}, "
                 f"{100 * row['alone_high']:.1f}]")
        others = [c for c in claims if c != lead]
        if row["kind"] == "law":
            first = (f"Most likely missing physics: {claim_label(diag, lead)} (learned from "
                     f"the per-case identification). Added to the model it lowers the "
                     f"cross-validated RMSE of all outputs by {alone}")
        else:
            c = next(x for x in diag.candidates if x.name == lead)
            first = (f"Most likely missing effect: {lead} (library effect). Added to the "
                     f"model it lowers the cross-validated RMSE of all outputs by {alone} "
                     f"and of its own outputs ({', '.join(c.affected_outputs)}) by "
                     f"{fr(c.affected)}; fitted: {_format_params(c.fitted())}")
        if others and sel is not None:
            first += (f"; in the selected model it carries {fr(sel.share[lead])} of the error "
                      f"left without it")
        out.append(first + ".")
        if others:
            items = []
            for name in others:
                r = table.set_index("candidate").loc[name]
                items.append(
                    f"{claim_label(diag, name)} ({100 * r['on_top']:.1f} % "
                    f"[{100 * r['on_top_low']:.1f}, {100 * r['on_top_high']:.1f}] on top of "
                    f"{r['on_top_of'] or 'the default model'}; in the selected model "
                    f"{100 * r['share']:.1f} % [{100 * r['share_low']:.1f}, "
                    f"{100 * r['share_high']:.1f}])")
            out.append("Also claimed (each on top of the claims before it, with them refitted "
                       "together, and kept when every claim was re-tested given the others): "
                       + "; ".join(items) + f". Add them together: {'+'.join(claims)}.")
        steps = diag.ledger_steps()
        out.append("Cross-validated RMSE (standardised) step by step: " + " -> ".join(
            step_label(a, n) + (" re-learned" if a == "relearn" else "") + f" {v:.3g}"
            for a, n, v in zip(steps["action"], steps["candidate"], steps["cv_rmse"],
                               strict=True)) + ".")
    rej = table[(table["status"] != "claimed") & (table["status"] != "not significant")
                & (table["status"] != "too few cases for any claim")]
    if len(rej):
        out.append("Tried and rejected: " + "; ".join(
            f"{claim_label(diag, r['candidate'], False)} ({r['status']}; alone "
            f"{100 * r['alone']:.1f} % [{100 * r['alone_low']:.1f}, "
            f"{100 * r['alone_high']:.1f}]"
            + (f", on top of {r['on_top_of']} {100 * r['on_top']:.1f} % "
               f"[{100 * r['on_top_low']:.1f}, {100 * r['on_top_high']:.1f}]"
               if r["on_top_of"] and np.isfinite(r["on_top"]) else "") + ")"
            for _, r in rej.head(8).iterrows()) + ".")
    rem = diag.remaining[diag.remaining["significant"]] if len(diag.remaining) else \
        diag.remaining
    after = diag.remaining_model
    if len(rem):
        res = diag.selection_residuals()
        items = []
        for _, r in rem.head(5).iterrows():
            hint = _strata_hint(diag, r["residual"], r["feature"], res)
            stat = "rho" if r["test"] == "spearman" else "eps^2"
            items.append(f"{r['residual']} ~ {r['feature']} ({stat} = {r['statistic']:+.2f}, "
                         f"p_adj = {r['p_adj']:.2g}{'; ' + hint if hint else ''})")
        who = "the default model" if after == "default" else f"adding {after}"
        out.append(f"Residual structure remains after {who} that no claim explains: "
                   f"{len(rem)} significant residual-feature association(s), "
                   "strongest: " + "; ".join(items) + ".")
    else:
        who = "the default model" if after == "default" else after
        out.append(f"No significant residual-feature association remains with {who} "
                   f"({s['correction'].upper()} at alpha = {s['alpha']:g}).")
    return out


# ----------------------------------------------------------------------------
# Reports
# ----------------------------------------------------------------------------


def summary_dict(diag: Diagnosis) -> dict[str, Any]:
    """JSON-ready summary: ranking, fitted parameters, reductions with CIs per output."""
    d = diag.data
    return {
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "created_by": "vfs diagnose",
        "database": diag.database,
        "n_cases": d.n,
        "reliable": diag.reliable,
        "settings": diag.settings,
        "default": {"cv_rmse": dict(zip(d.group_names, diag.default.rmse().tolist(),
                                        strict=True)),
                    "cv_rmse_overall": diag.default.overall_rmse()},
        "ranking": diag.ranking,
        "claims": [{"name": n, "kind": "law" if n.endswith(" law") and n not in diag.ranking
                    else "effect", "text": claim_label(diag, n),
                    "share": diag.selection.share[n].as_dict() if diag.selection else None}
                   for n in diag.claims],
        "significant": [n for n in diag.claims if n in diag.ranking],
        "rejected": [{"name": r["candidate"], "kind": r["kind"], "reason": r["status"],
                      "alone": {"estimate": r["alone"], "low": r["alone_low"],
                                "high": r["alone_high"]}}
                     for _, r in diag.selection_table().iterrows()
                     if r["status"] != "claimed"],
        "steps": diag.ledger_steps().to_dict(orient="records"),
        "candidates": [
            {
                "rank": c.rank, "name": c.name, "significant": c.significant,
                "status": c.status, "fitted": c.fitted(),
                "fold_parameters": c.cv.fold_x.tolist(),
                "parameters_fitted": c.cv.space.names(),
                "reduction": c.overall.as_dict(),
                "reduction_affected": {**c.affected.as_dict(),
                                       "outputs": list(c.affected_outputs)},
                "reduction_given_best": c.given_best.as_dict() if c.given_best else None,
                "reduction_refit": c.refit.as_dict() if c.refit else None,
                "reduction_per_output": {g: r.as_dict() for g, r in c.per_output.items()},
                "cv_rmse": dict(zip(d.group_names, c.cv.rmse().tolist(), strict=True)),
                "cv_rmse_overall": c.cv.overall_rmse(),
                "variants": c.variants,
            }
            for c in diag.candidates
        ],
        "verdict": diag.verdict,
        "remaining_structure": {
            "model": diag.remaining_model,
            "significant": diag.remaining[diag.remaining["significant"]].head(50)
            .to_dict(orient="records") if len(diag.remaining) else [],
        },
        "worst_cases": diag.worst.to_dict(orient="records"),
        "claimed_laws": [f.channel for n in diag.claims for f in diag.laws
                         if law_key(f.channel) == n],
        "laws": [{"channel": f.channel, "significant": f.significant, "status": f.status,
                  "round": f.round, "on_top_of": list(f.on_top_of), "note": f.note,
                  "law": f.learned.law, "text": f.text(),
                  "outcome_reduction": f.outcome.as_dict(),
                  "reduction_given_claimed": f.given_claimed.as_dict()
                  if f.given_claimed else None,
                  "reduction_refit": f.refit.as_dict() if f.refit else None,
                  "share": f.share.as_dict() if f.share else None,
                  "identified_reduction": {"estimate": f.learned.reduction,
                                           "low": f.learned.low, "high": f.learned.high,
                                           "null": f.learned.null}}
                 for f in diag.laws],
        "stats": diag.stats,
    }


def output_names() -> list[str]:
    """Names of the outputs that can be compared."""
    return list(OUTPUT_GROUPS)


__all__ = [
    "CATEGORICAL_FEATURES", "MIN_CASES", "MIN_FOLD_CASES", "NUMERIC_FEATURES",
    "STRATA_FEATURES", "CandidateResult", "Correction", "DiagnoseSpec", "Diagnosis",
    "Parameters", "case_features", "claim_label", "diagnose", "output_names",
    "residual_associations", "residual_variables", "resolve_candidates", "rmse_reduction",
    "stratified_residuals", "summary_dict", "worst_cases",
]
