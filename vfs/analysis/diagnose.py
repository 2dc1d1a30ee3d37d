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
   :func:`vfs.analysis.calibrate.cross_validate`); the reduction of the CV RMSE of the
   standardised residuals, overall, over the effect's own outputs and per
   output, gets a bootstrap CI over cases; the candidates are ranked by the
   overall reduction.  A candidate *helps significantly* if the lower bound
   of its CI (simultaneous over the candidates, Bonferroni) is above zero
   and the reduction reaches ``min_reduction`` (:func:`helps`, the one rule
   of the table and the text); a further effect (stepwise) also needs the
   CI of its reduction on top of the first effect, and of its reduction
   when the first effect is refitted together with it, above zero.  Below
   ``min_cases`` cases (or with held-out folds of fewer than
   :data:`MIN_FOLD_CASES` cases) nothing is claimed: the result is reported as
   unreliable.  With ``parameters="primary"`` the parameters that are not
   fitted sit at their neutral values (that part of the effect off) or at
   their nominal strengths, whichever fits each fold's training cases better
   (:meth:`vfs.analysis.calibrate.FitSpace.alternatives`).  Residual structure left
   after the best effect (significant associations of its held-out
   residuals) is reported with the strata it points to.
3. **Beyond the library** (``laws``).  Each channel is identified per case
   (:mod:`vfs.analysis.identify`) and its law learned
   (:mod:`vfs.analysis.learn`); every law with structure is
   cross-validated as an effect in outcome space.  The best is claimed if
   it helps; then, forward stepwise (at most ``law_rounds`` rounds), the
   other channels with structure are re-identified with the claimed laws
   applied (a law missing on one channel leaks into the identification of
   the others), their laws learned anew, and the best of them on top of the
   claimed laws is claimed if :func:`stepwise_helps` (the same rule as for
   the effects: on top of the claimed laws, and with them refitted on their
   channels re-identified with it applied; and the claimed laws still help
   with it).  The others are reported as not confirmed on top of the
   claimed laws.

:func:`vfs.report.diagnose.write_diagnosis_report` writes the ranked table (CSV), a
JSON summary, and Markdown and HTML reports with figures.  Reports show km/h and degrees
(display units of :mod:`vfs.outcomes`); all computations are SI.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from vfs.analysis.calibrate import (
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
from vfs.analysis.claims import (
    LAW_ROUNDS,
    LawFinding,
    Reduction,
    absorb_counters,
    helps,
    learn_laws,
    stepwise_helps,
    with_effects,
)
from vfs.analysis.claims import (
    format_reduction as fr,
)
from vfs.analysis.features import case_features
from vfs.effects import get_effect, registered_effects
from vfs.errors import ParameterError
from vfs.outcomes import OUTPUT_GROUPS, QUANTITIES, Quantity
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
#: Fewest cases for which the diagnosis claims anything (below: unreliable, nothing
#: significant).
MIN_CASES = 30
#: Fewest held-out cases per fold for which the diagnosis claims anything.
MIN_FOLD_CASES = 5


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

    Columns: feature, stratum, output, column, n, bias (mean residual) and
    rmse in the output's report unit, rmse_std (RMSE of the standardised
    residuals of the output).
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
                          correction: str = "bh", alpha: float = 0.05,
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

    if correction not in ("bh", "holm"):
        raise ParameterError(f"correction={correction!r}; use 'bh' or 'holm'")
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
    out["p_adj"] = benjamini_hochberg(p) if correction == "bh" else holm_bonferroni(p)
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
        Stepwise (ranks 2...): overall reduction when added to the model with
        the rank-1 effect, against that model; None for rank 1 or when no
        effect helps.
    refit : Reduction or None
        Stepwise, for candidates that help on top of rank 1: overall
        reduction of the model with both effects fitted together (rank 1
        refitted) against rank 1 alone (both cross-validated).
    significant : bool
        :func:`helps` for the overall reduction; ranks 2... (if rank 1
        helps) also for ``given_best`` and ``refit``; always False when the
        sample is too small (:attr:`Diagnosis.reliable`).
    rank : int
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

    def fitted(self) -> list[dict[str, Any]]:
        """Parameters fitted on all cases (empty if the default model fits better)."""
        return self.cv.fitted_parameters()


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

    @property
    def ranking(self) -> list[str]:
        """Candidate names, best first."""
        return [c.name for c in self.candidates]

    @property
    def best(self) -> CandidateResult | None:
        """The best candidate if it helps significantly, else None."""
        return self.candidates[0] if self.candidates and self.candidates[0].significant \
            else None

    def ranked_table(self) -> pd.DataFrame:
        """One row per candidate, best first: reductions with CIs, fitted parameters."""
        rows = []
        for c in self.candidates:
            row: dict[str, Any] = {
                "rank": c.rank, "effect": c.name, "significant": c.significant,
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


def diagnose(db: Any, outputs: str | Iterable[str] | None = None,
             effects: str | Iterable[str] | None = "all", folds: int = 5, seed: int = 0,
             parameters: str = "primary", grid_points: int = 9, zoom_rounds: int = 3,
             confidence: float = 0.95, n_boot: int = 2000, correction: str = "bh",
             alpha: float = 0.05, min_reduction: float = 0.01, worst: int = 6,
             params: SimulationParams | None = None, database: str = "",
             stepwise: bool = True, min_cases: int = MIN_CASES,
             laws: str | Iterable[str] | None = None, law_grid: int = 13,
             law_rounds: int = LAW_ROUNDS,
             progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Diagnose the default model against the reconstructions of ``db``.

    Parameters
    ----------
    db : Database
        Analysed blind: only its tables (never a ground-truth file).
    outputs : str or list, optional
        Compared outputs (names of :data:`vfs.outcomes.OUTPUT_GROUPS`;
        default all available).
    effects : "all" or names
        Candidate effects (default every registered effect).
    folds, seed : int
        k-fold cross-validation by case; seed of the fold assignment and the
        bootstrap.
    parameters : {"primary", "all"}
        Fit only each effect's primary parameter (the others at their neutral
        values or their nominal strengths, per fold whichever fits the
        training cases better) or all its
        parameters (coordinate search, slower).
    grid_points, zoom_rounds : int
        Coarse grid and refinement rounds of :func:`vfs.analysis.calibrate.fit_folds`.
    confidence : float
        Simultaneous level of the CIs of the overall reductions (Bonferroni
        over the candidates); per-output CIs are pointwise at this level.
    n_boot : int
        Bootstrap samples.
    correction : {"bh", "holm"}
        Multiplicity control of the residual-feature associations.
    alpha : float
        Level of the association tests.
    min_reduction : float
        Smallest overall reduction that counts as "helps" (besides the CI).
    worst : int
        Number of worst cases listed (and sketched by
        :func:`vfs.report.diagnose.write_diagnosis_report`).
    params : SimulationParams, optional
        Base model (default: the default model).
    database : str
        Name or path for the reports.
    stepwise : bool
        If the best candidate helps, cross-validate every other candidate
        added to the model with the best one (fitted on all cases) and rank
        them by that conditional reduction: a weaker effect masked by a
        dominant one is found second.  It is claimed only if it also helps
        when the first effect is refitted together with it.
    laws : str or list, optional
        Channels to identify per case and learn laws for
        (:mod:`vfs.analysis.identify`, :mod:`vfs.analysis.learn`; "all" for
        every channel; default None: skipped).  Each law whose identified
        values show structure is cross-validated as an effect (refitted on
        the training folds) and compared with the library ranking.  The
        best law is claimed if it helps (:func:`helps`); then, forward
        stepwise, the other channels with structure are re-identified with
        the claimed laws applied and their laws learned anew; the law that
        lowers the error most on top of the claimed ones is claimed if it
        passes :func:`stepwise_helps` (on top of the claimed laws; with them
        refitted on their channels re-identified with it applied, against
        them alone; and they still help with it present); the others are
        "not confirmed on top of" the claimed laws.
    law_grid : int
        Grid values per channel of the identification.
    law_rounds : int
        Most stepwise rounds after the first claimed law (each one more
        identification of the candidate channels).
    min_cases : int
        Fewest cases (and :data:`MIN_FOLD_CASES` held-out cases per fold)
        for which anything is claimed; below, the verdict says the result is
        unreliable and no candidate is significant.
    progress : callable, optional
        Called with one line per finished step.
    """
    t0 = time.perf_counter()
    say = progress or (lambda _msg: None)
    data = CalibrationData.from_database(db, outputs)
    names = resolve_candidates(effects)
    sim = VariantSimulator(data, params)
    held = kfold_indices(data.n, folds, seed)
    reliable = data.n >= min_cases and min(len(h) for h in held) >= MIN_FOLD_CASES
    rng = np.random.default_rng(seed)
    features = case_features(data)
    base = cross_validate(sim, FitSpace((), ()), held, "default", fit_all=False)
    say(f"default model: CV RMSE {base.overall_rmse():.3f} (standardised) over "
        f"{data.n} cases, {len(data.groups)} outputs")
    strata = stratified_residuals(data, base.residuals, features)
    assoc = residual_associations(residual_variables(data, base.residuals), features,
                                  correction, alpha)
    level = 1.0 - (1.0 - confidence) / max(len(names), 1)
    cands: list[CandidateResult] = []
    fit_opts: dict[str, Any] = {"grid_points": grid_points, "zoom_rounds": zoom_rounds}
    classes = [get_effect(name) for name in names]
    t1, v1 = time.perf_counter(), sim.n_variants
    spaces = [FitSpace.alternatives([cls], parameters) for cls in classes]
    cvs = cross_validate_many(sim, spaces, held, names, allow_off=True,
                              **fit_opts) if classes else []
    fit_seconds = time.perf_counter() - t1
    say(f"fitted {len(classes)} candidates: {sim.n_variants - v1} model variants in "
        f"{fit_seconds:.1f} s")
    for name, cls, cv in zip(names, classes, cvs, strict=True):
        affected = tuple(o for o in cls.outputs if o in data.group_names) or data.group_names
        w = np.array([1.0 if g in affected else 0.0 for g in data.group_names])
        est, lo, hi = reduction_ci(cv.errors, base.errors, rng, confidence=level,
                                   n_boot=n_boot)
        a_est, a_lo, a_hi = reduction_ci(cv.errors, base.errors, rng, confidence=confidence,
                                         n_boot=n_boot, weights=w)
        per = {}
        for k, g in enumerate(data.group_names):
            per[g] = Reduction(*reduction_ci(cv.errors, base.errors, rng, group=k,
                                             confidence=confidence, n_boot=n_boot))
        c = CandidateResult(name, cv, Reduction(est, lo, hi), Reduction(a_est, a_lo, a_hi),
                            per, affected,
                            significant=reliable and helps(Reduction(est, lo, hi),
                                                           min_reduction),
                            variants=cv.variants)
        cands.append(c)
        say(f"candidate {name}: CV RMSE reduction {100 * est:.1f} % "
            f"[{100 * lo:.1f}, {100 * hi:.1f}] ({c.variants} variants)")
    cands.sort(key=lambda c: (-np.nan_to_num(c.overall.estimate, nan=-np.inf), c.name))
    best = cands[0] if cands and cands[0].significant else None
    best_model = best.cv.fitted_model() if best is not None else ()
    if stepwise and best is not None and best_model and len(cands) > 1:
        rest = cands[1:]
        sim2 = with_effects(sim, best_model)
        base2 = cross_validate(sim2, FitSpace((), ()), held, best.name, fit_all=False)
        cvs2 = cross_validate_many(
            sim2, [FitSpace.alternatives([get_effect(c.name)], parameters) for c in rest], held,
            [f"{best.name}+{c.name}" for c in rest], allow_off=True, **fit_opts)
        for c, cv2 in zip(rest, cvs2, strict=True):
            c.given_best = Reduction(*reduction_ci(cv2.errors, base2.errors, rng,
                                                   confidence=level, n_boot=n_boot))
        # survive a refit of the first effect: both fitted together, against the first alone
        keep = [c for c in rest
                if helps(c.overall, min_reduction) and helps(c.given_best, min_reduction)]
        best_cls = get_effect(best.name)
        cvs3 = cross_validate_many(
            sim, [FitSpace.alternatives([best_cls, get_effect(c.name)], parameters) for c in keep],
            held, [f"{best.name}+{c.name} (refit)" for c in keep], allow_off=True,
            **fit_opts) if keep else []
        for c, cv3 in zip(keep, cvs3, strict=True):
            c.refit = Reduction(*reduction_ci(cv3.errors, best.cv.errors, rng,
                                              confidence=level, n_boot=n_boot))
        for c in rest:
            c.significant = reliable and stepwise_helps(c.given_best, c.refit, min_reduction,
                                                        also=(c.overall,))
        rest.sort(key=lambda c: (-np.nan_to_num(c.given_best.estimate, nan=-np.inf)
                                 if c.given_best else np.inf, c.name))
        cands = [cands[0], *rest]
        say(f"stepwise: {len(rest)} candidates added to {best.name} "
            f"({sim2.n_variants} variants, {sim2.seconds:.1f} s)")
        absorb_counters(sim, sim2)
    for i, c in enumerate(cands, 1):
        c.rank = i
    findings: list[LawFinding] = []
    ident = None
    law_stats: dict[str, Any] = {}
    if laws is not None:
        findings, ident, law_stats = learn_laws(sim, base, held, laws, law_grid, seed, level,
                                                 n_boot, min_reduction, reliable, rng, say,
                                                 law_rounds)
    after = best.cv if best is not None else base
    remaining = residual_associations(residual_variables(data, after.residuals), features,
                                      correction, alpha)
    worst_df = worst_cases(data, base.residuals, features, worst)
    settings = {"outputs": list(data.group_names), "folds": folds, "seed": seed,
                "parameters": parameters, "grid_points": grid_points,
                "zoom_rounds": zoom_rounds, "confidence": confidence,
                "simultaneous_confidence": level, "n_boot": n_boot,
                "correction": correction, "alpha": alpha, "min_reduction": min_reduction,
                "candidates": names, "min_cases": min_cases, "reliable": reliable,
                "law_rounds": law_rounds,
                "fixed_parameters": ("neutral or nominal, per fold the better on the "
                                     "training cases" if parameters == "primary" else
                                     "none (all fitted)"),
                "scales": dict(zip(data.group_names, data.scales.tolist(), strict=True)),
                "scale_source": dict(zip(data.group_names, data.scale_source, strict=True))}
    diag = Diagnosis(data, features, base, cands, strata, assoc, remaining,
                     after.label, worst_df, [], settings, database=database,
                     reliable=reliable, laws=findings, identification=ident)
    diag.verdict = _verdict(diag)
    diag.stats = {**sim.stats(), "total_seconds": round(time.perf_counter() - t0, 2),
                  "n_cases": data.n, **law_stats}
    return diag


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


def _verdict(diag: Diagnosis) -> list[str]:
    out: list[str] = []
    sig = [c for c in diag.candidates if c.significant]
    if not diag.candidates:
        return ["No candidate effect was tested."]
    if not diag.reliable:
        n, k = diag.data.n, diag.settings["folds"]
        out.append(
            f"UNRELIABLE: {n} cases in {k} folds (fewer than "
            f"{diag.settings['min_cases']} cases or fewer than {MIN_FOLD_CASES} held-out cases "
            "per fold): the cross-validated reductions and their CIs below are not "
            "trustworthy and no candidate is claimed to help significantly.")
    if not sig:
        top = diag.candidates[0]
        out.append(
            "No candidate effect helps significantly: every simultaneous "
            f"{100 * diag.settings['confidence']:.0f} % CI of the cross-validated RMSE "
            "reduction includes 0 or the reduction is below "
            f"{100 * diag.settings['min_reduction']:.0f} % (best: {top.name}, "
            f"{100 * top.overall.estimate:.1f} % [{100 * top.overall.low:.1f}, "
            f"{100 * top.overall.high:.1f}])."
        )
    else:
        b = sig[0]
        out.append(
            f"Most likely missing effect: {b.name} (rank 1). Added to the model it lowers "
            f"the cross-validated RMSE by {100 * b.overall.estimate:.1f} % "
            f"[{100 * b.overall.low:.1f}, {100 * b.overall.high:.1f}] over all outputs and by "
            f"{100 * b.affected.estimate:.1f} % [{100 * b.affected.low:.1f}, "
            f"{100 * b.affected.high:.1f}] over its own outputs "
            f"({', '.join(b.affected_outputs)}); fitted on all cases: "
            f"{_format_params(b.fitted())}."
        )
        if len(sig) > 1:
            out.append(f"Added to the model with {b.name}, these effects lower the "
                       "cross-validated RMSE further (significantly; calibrate them together "
                       f"with vfs calibrate --effects {b.name},...): "
                       + ", ".join(f"{c.name} ({100 * c.given_best.estimate:.1f} % "
                                   f"[{100 * c.given_best.low:.1f}, "
                                   f"{100 * c.given_best.high:.1f}]; refitted together "
                                   f"{100 * c.refit.estimate:.1f} % [{100 * c.refit.low:.1f}, "
                                   f"{100 * c.refit.high:.1f}])"
                                   for c in sig[1:] if c.given_best and c.refit) + ".")
    law_sig = [f for f in diag.laws if f.significant]
    if law_sig:
        top = diag.candidates[0]
        lib = (f"{100 * top.overall.estimate:.1f} % [{100 * top.overall.low:.1f}, "
               f"{100 * top.overall.high:.1f}] for the best library effect ({top.name})")
        f = law_sig[0]
        out.append(f"Beyond the library: {f.text()}, against {lib}. Add it with "
                   "vfs learn --out law.json and --plugin law.json (or --export-plugin "
                   "law.py to edit it).")
        if len(law_sig) > 1:
            out.append("Claimed stepwise on top of it (each channel re-identified with the "
                       "laws claimed before applied; the law helps on top of them and with them "
                       "refitted together, and they still help with it; add them together): "
                       + "; ".join(x.text() for x in law_sig[1:]) + ".")
        rest = [x for x in diag.laws if not x.significant]
        if rest:
            out.append(
                "Not claimed (structure in the identified values that the claimed laws "
                "explain or that does not lower the outcome error on top of them): "
                + "; ".join(f"{x.channel} ~ {x.learned.law['feature']} (alone "
                            f"{fr(x.outcome)}"
                            + (f", on top {fr(x.given_claimed)}" if x.given_claimed else "")
                            + (f", refitted together {fr(x.refit)}" if x.refit else "")
                            + f"; {x.status}{'; ' + x.note if x.note else ''})"
                            for x in rest[:6]) + ".")
    elif diag.identification is not None:
        out.append("The per-case identification shows no channel law that lowers the "
                   "cross-validated error significantly.")
    rem = diag.remaining[diag.remaining["significant"]] if len(diag.remaining) else \
        diag.remaining
    after = diag.remaining_model
    res = (diag.candidates[0].cv.residuals if diag.best is not None
           else diag.default.residuals)
    if len(rem):
        items = []
        for _, r in rem.head(5).iterrows():
            hint = _strata_hint(diag, r["residual"], r["feature"], res)
            stat = "rho" if r["test"] == "spearman" else "eps^2"
            items.append(f"{r['residual']} ~ {r['feature']} ({stat} = {r['statistic']:+.2f}, "
                         f"p_adj = {r['p_adj']:.2g}{'; ' + hint if hint else ''})")
        who = "the default model" if after == "default" else f"adding {after}"
        out.append(f"Residual structure remains after {who} that no tested candidate "
                   f"explains alone: {len(rem)} significant residual-feature association(s), "
                   "strongest: " + "; ".join(items) + ".")
    else:
        who = "the default model" if after == "default" else after
        out.append(f"No significant residual-feature association remains with {who} "
                   f"({diag.settings['correction'].upper()} at alpha = "
                   f"{diag.settings['alpha']:g}).")
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
        "significant": [c.name for c in diag.candidates if c.significant],
        "candidates": [
            {
                "rank": c.rank, "name": c.name, "significant": c.significant,
                "fitted": c.fitted(),
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
        "claimed_laws": [f.channel for f in diag.laws if f.significant],
        "laws": [{"channel": f.channel, "significant": f.significant, "status": f.status,
                  "round": f.round, "on_top_of": list(f.on_top_of), "note": f.note,
                  "law": f.learned.law, "text": f.text(),
                  "outcome_reduction": f.outcome.as_dict(),
                  "reduction_given_claimed": f.given_claimed.as_dict()
                  if f.given_claimed else None,
                  "reduction_refit": f.refit.as_dict() if f.refit else None,
                  "reduction_claimed_kept": f.kept.as_dict() if f.kept else None,
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
    "CATEGORICAL_FEATURES", "NUMERIC_FEATURES", "STRATA_FEATURES", "CandidateResult",
    "MIN_CASES", "MIN_FOLD_CASES", "Diagnosis", "case_features", "diagnose", "output_names",
    "residual_associations", "residual_variables", "resolve_candidates",
    "rmse_reduction", "stratified_residuals", "summary_dict", "worst_cases",
]
