"""Claims of the diagnosis: the significance rules and the evaluator of its one selection.

:func:`helps` is the one significance rule of :func:`vfs.diagnosis.diagnose.diagnose`
(its table, JSON and text): the simultaneous bootstrap CI of a CV RMSE reduction
(:class:`Reduction`) lies above 0 and the estimate reaches ``min_reduction``.
:func:`stepwise_helps` is the rule of a further claim (on top of the claims, and with them
refitted together).  :func:`first_laws` identifies every channel per case, learns its law
and cross-validates it as an effect in outcome space; :class:`ModelEvaluator` gives
:func:`vfs.diagnosis.selection.select` the cross-validated reductions of library effects and
learned laws alone, on top of claims (laws re-learned from their channels re-identified
with the claims applied) and in joint models (docs/diagnosis.md, "One selection").
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vfs.diagnosis.calibrate import (
    CVResult,
    FitSpace,
    VariantSimulator,
    reduction_ci,
)


@dataclass
class Reduction:
    """CV RMSE reduction 1 - RMSE_model / RMSE_default with a bootstrap CI."""

    estimate: float
    low: float
    high: float

    def as_dict(self) -> dict[str, float]:
        """JSON-ready."""
        return {"estimate": self.estimate, "low": self.low, "high": self.high}



def helps(r: Reduction | None, min_reduction: float) -> bool:
    """The significance rule: the CI lies above 0 and the estimate reaches ``min_reduction``."""
    return bool(r is not None and np.isfinite(r.low) and r.low > 0
                and r.estimate >= min_reduction)


def stepwise_helps(given: Reduction | None, refit: Reduction | None, min_reduction: float,
                   also: Iterable[Reduction | None] = ()) -> bool:
    """The stepwise rule of a further effect or law (ranks 2...): :func:`helps` for its
    reduction on top of what is claimed before it, fitted on all cases (``given``), and
    for its reduction when that is refitted together with it, against it alone
    (``refit``); and for each reduction of ``also`` (an effect: its reduction alone; a
    law: the claimed laws' reduction with it present).
    """
    return all(helps(r, min_reduction) for r in (given, refit, *also))



@dataclass
class LawFinding:
    """A law learned from the per-case identification and its effect on the outcomes.

    Attributes
    ----------
    channel : str
    learned : vfs.diagnosis.learn.ChannelLaw
        The law over the identified values (formula, CV against the null).
    outcome : Reduction
        Cross-validated overall RMSE reduction of the outcomes against the
        default model when the law is used as an effect (refitted per fold).
    errors : ndarray (n, n_groups)
        Its held-out per-case errors.
    significant : bool
        The law is claimed: the first claimed law by :func:`helps` of
        ``outcome``, a further one by :func:`stepwise_helps` of ``given_claimed``,
        ``refit`` and ``kept`` (and the sample is large enough).
    given_claimed : Reduction or None
        Stepwise (round >= 1): reduction when the law, learned from the
        identification with the laws of ``on_top_of`` applied, is added to
        them (fitted on all cases), against them.
    refit : Reduction or None
        Stepwise: reduction of the claimed laws refitted together with it
        (their channels re-identified with it applied; all refitted per fold)
        against the claimed laws alone.
    kept : Reduction or None
        Stepwise: reduction of the same refitted model against the law alone
        (the claimed laws still help with it present).
    on_top_of : tuple of str
        Channels of the laws claimed before it was tested (empty: round 0).
    round : int
        Stepwise round that learned it (0: identification with the other
        channels at the model's values).
    table : pandas.DataFrame or None
        The identification it was learned from.
    note : str
        Why it is not claimed, when that is not a failed reduction.
    """

    channel: str
    learned: Any
    outcome: Reduction
    errors: np.ndarray
    significant: bool = False
    given_claimed: Reduction | None = None
    refit: Reduction | None = None
    kept: Reduction | None = None
    on_top_of: tuple[str, ...] = ()
    round: int = 0
    table: pd.DataFrame | None = field(default=None, repr=False)
    note: str = ""
    reason: str = ""
    share: Reduction | None = None

    @property
    def status(self) -> str:
        """"claimed", the selection's reason, "not confirmed on top of <claims>" or "not
        significant".
        """
        if self.significant:
            return "claimed"
        if self.reason:
            return self.reason
        if self.on_top_of:
            return f"not confirmed on top of {', '.join(self.on_top_of)}"
        return "not significant"

    def text(self) -> str:
        """One line for reports."""
        law = self.learned.law
        out = f"the identified {self.channel} "
        if self.round:
            out += f"(re-identified with the law(s) of {', '.join(self.on_top_of)} applied) "
        out += (f"follows f({law['feature']}): {law['formula']}; outcome CV RMSE reduction "
                f"{format_reduction(self.outcome)}")
        if self.given_claimed is not None:
            out += f", on top of {', '.join(self.on_top_of)} {format_reduction(self.given_claimed)}"
        if self.refit is not None and self.kept is not None:
            out += (f", with {', '.join(self.on_top_of)} refitted together "
                    f"{format_reduction(self.refit)} (they keep "
                    f"{format_reduction(self.kept)} with it)")
        if not self.significant and self.on_top_of:
            out += f" ({self.status}{'; ' + self.note if self.note else ''})"
        return out


def format_reduction(r: Reduction) -> str:
    """``"12.3 % [4.5, 20.1]"``: a reduction and its CI in per cent."""
    return f"{100 * r.estimate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"


def closed_alternative(r: Any) -> dict[str, Any] | None:
    """The best closed form over the law's feature when the law is a table."""
    from vfs.effects.learned import law_text

    law = r.law
    if law is None or law["form"] != "table":
        return None
    c = r.candidates
    c = c[(c["feature"] == law["feature"]) & (c["form"] != "spline")]
    if c.empty:
        return None
    form = str(c["form"].iloc[0])
    alt = {k: v for k, v in law.items() if k not in ("table",)}
    alt["form"] = form
    alt["coefficients"] = [float(v) for v in str(c["coefficients"].iloc[0]).split()]
    alt["formula"] = law_text(alt)
    return alt


def with_effects(sim: VariantSimulator, effects: Iterable[Any]) -> VariantSimulator:
    """A simulator of the same cases whose base model has ``effects`` added."""
    return VariantSimulator(sim.data, dataclasses.replace(
        sim.params, effects=tuple(sim.params.effects) + tuple(effects)))


def absorb_counters(sim: VariantSimulator, other: VariantSimulator) -> None:
    """Add the simulation counters of ``other`` to those of ``sim``."""
    sim.n_variants += other.n_variants
    sim.n_case_runs += other.n_case_runs
    sim.n_calls += other.n_calls
    sim.seconds += other.seconds


def law_effects(laws: Iterable[Mapping[str, Any]]) -> tuple[Any, ...]:
    """One effect object per law (:func:`vfs.effects.learned.law_effect_class`)."""
    from vfs.effects.learned import law_effect_class

    return tuple(law_effect_class(law)() for law in laws)


#: Level of the paired bootstrap CI by which the outcomes overrule the identified values'
#: choice of a table over its best closed form (:func:`outcome_law`), and its samples.
FORMULA_OVERRULE_LEVEL, FORMULA_OVERRULE_BOOT = 0.95, 500


def outcome_law(sim: VariantSimulator, table: pd.DataFrame, r: Any,
                held: Sequence[np.ndarray], say: Callable[[str], None]) -> np.ndarray:
    """Held-out errors of the law of ``r``: a table, or its best formula where that does
    better on the outcomes with the paired bootstrap CI (over cases, seeded) of its RMSE
    reduction against the table above 0 (then ``r.law`` becomes the formula).

    The table won on the identified values (:func:`vfs.diagnosis.learn.learn_channel`, by
    cross-validation, a closed form preferred within 2 %); a point comparison of the
    held-out outcome errors, whose case errors are heavy-tailed, overruled it by chance: in
    ``tyre_friction_speed+cp_sin_angle`` a step of the contact-plane turn replaced its
    sin(2 angle) table (38.0 % against 37.1 % of the default model's error; the step
    against the table 1.4 % [-36, 25] %).
    """
    from vfs.diagnosis.learn import cross_validate_law

    _, err = cross_validate_law(sim, table, r.law, held)
    alt = closed_alternative(r)
    if alt is not None:  # a table won on the identified values: try the best formula
        _, err2 = cross_validate_law(sim, table, alt, held)
        est, low, _ = reduction_ci(err2, err, np.random.default_rng(0),
                                   confidence=FORMULA_OVERRULE_LEVEL,
                                   n_boot=FORMULA_OVERRULE_BOOT)
        if np.isfinite(low) and low > 0:
            r.law, err = alt, err2
            say(f"  the formula does better on the outcomes ({100 * est:.1f} % "
                f"[{100 * low:.1f}, ...] against the table): {alt['formula']}")
    return err


def refit_all(table: pd.DataFrame, law: Mapping[str, Any]) -> dict[str, Any]:
    """The law's form and feature refitted to all identifiable cases of ``table``."""
    from vfs.diagnosis.learn import law_rows, refit_law

    t, y, w = law_rows(table, law["channel"])
    out = refit_law(law, t[law["feature"]].to_numpy(float), y, w)
    from vfs.effects.learned import law_text

    out["formula"] = law_text(out)
    return out


def law_key(channel: str) -> str:
    """The selection's name of the learned law of ``channel`` (``"<channel> law"``)."""
    return f"{channel} law"


def _named(law: Mapping[str, Any]) -> dict[str, Any]:
    """A table law named by its values (the simulator's cache knows a model by names)."""
    out = dict(law)
    if out.get("form") == "table":
        import hashlib

        digest = hashlib.sha1(np.asarray(out["table"]["y"], float).tobytes()).hexdigest()
        out["name"] = f"{str(out['name']).split('_t')[0]}_t{digest[:10]}"
    return out


class ModelEvaluator:
    """The :class:`vfs.diagnosis.selection.Evaluator` of the diagnosis: cross-validated outcome
    errors of library effects and learned laws, alone, on top of claims and jointly.

    Library effects are fitted per fold (:func:`vfs.diagnosis.calibrate.cross_validate_many`;
    alone and on top: "the effect, or no effect"); learned laws are refitted per fold to the
    training cases' identified values (:func:`vfs.diagnosis.learn.fold_law_effects`).  On top of
    claims, the claims (fitted on all cases) form the base model of a simulator, effects are
    fitted on it and the laws' channels are **re-identified** with it and their laws learned
    again (a law missing on one channel leaks into the identification of the others).  A joint
    model refits everything per fold: the laws from their identification tables, the effects'
    parameters by one search per fold with the fold's laws applied.  Joint models and
    simulators on top of a claim set are cached (the same model is never simulated twice).

    Parameters
    ----------
    sim : VariantSimulator
    held : sequence of int arrays
        Held-out rows of each fold.
    base : CVResult
        The default model.
    effects : mapping of str to effect class
        The library candidates.
    alone : mapping of str to ndarray
        Held-out per-case errors of each candidate alone (library effects from the ranking,
        laws from the first identification).
    alone_reductions : mapping of str to Reduction, optional
        Their reductions against the default model as reported (else bootstrapped here).
    alone_cv : mapping of str to CVResult, optional
        The library candidates' cross-validations alone (a joint model of one effect).
    group_ci : callable, optional
        (errors, reference errors, output group index) -> Reduction of that group, for
        :meth:`worse` (None: no output is ever reported worse).
    min_worsening : float
        Smallest worsening that counts (a reduction at or below ``-min_worsening``).
    laws : mapping of str to LawFinding
        The law candidates (key :func:`law_key`) of the first identification.
    ident, learned : callables
        Identify channels with a simulator (table joined with the features); learn laws.
    ci : callable
        (errors, reference errors) -> Reduction.
    parameters : str
        ``"primary"`` or ``"all"`` (:meth:`FitSpace.alternatives`).
    fit_options : mapping
        ``grid_points``, ``zoom_rounds`` of the searches.
    say : callable
    """

    def __init__(self, sim: VariantSimulator, held: Sequence[np.ndarray], base: CVResult,
                 effects: Mapping[str, Any], alone: Mapping[str, np.ndarray],
                 laws: Mapping[str, LawFinding],
                 ident: Callable[[VariantSimulator, Sequence[str]], pd.DataFrame],
                 learned: Callable[[pd.DataFrame], list[Any]],
                 ci: Callable[[np.ndarray, np.ndarray], Reduction], parameters: str,
                 fit_options: Mapping[str, Any], say: Callable[[str], None],
                 alone_reductions: Mapping[str, Reduction] | None = None,
                 alone_cv: Mapping[str, CVResult] | None = None,
                 group_ci: Callable[[np.ndarray, np.ndarray, int], Reduction] | None = None,
                 min_worsening: float = 0.0) -> None:
        self.sim, self.held, self.base = sim, list(held), base
        self.group_ci, self.min_worsening = group_ci, min_worsening
        self.alone_reductions = dict(alone_reductions or {})
        self.alone_cv = dict(alone_cv or {})
        self.effects = dict(effects)
        self.alone = dict(alone)
        self.laws = dict(laws)
        self.ident, self.learned, self.ci = ident, learned, ci
        self.parameters, self.fit_options, self.say = parameters, dict(fit_options), say
        self._version = dict.fromkeys(self.laws, 0)
        self._versions_made = 0  # a new law version gets a number never used before
        self._joint: dict[tuple[Any, ...], tuple[np.ndarray, tuple[Any, ...]]] = {}
        self._sims: dict[tuple[Any, ...], VariantSimulator] = {}
        self._residuals: dict[tuple[Any, ...], np.ndarray] = {}
        self.on_top_errors: dict[tuple[str, tuple[str, ...]], np.ndarray] = {}
        self.stepwise_seconds = 0.0

    # -- models ---------------------------------------------------------------------------

    def _key(self, model: Sequence[str]) -> tuple[Any, ...]:
        return tuple(sorted((m, self._version.get(m, 0)) for m in model))

    def joint(self, model: Sequence[str]) -> tuple[np.ndarray, tuple[Any, ...]]:
        """Held-out per-case errors of the joint model (all refitted per fold) and its
        effects fitted on all cases.
        """
        if not model:
            return self.base.errors, ()
        key = self._key(model)
        if key in self._joint:
            return self._joint[key]
        if len(model) == 1 and model[0] in self.alone_cv:  # one effect: its CV alone
            cv = self.alone_cv[model[0]]
            self._joint[key] = (cv.errors, tuple(cv.fitted_model()))
            self._residuals[key] = cv.residuals
            return self._joint[key]
        from vfs.diagnosis.calibrate import fit_steps, run_fits
        from vfs.diagnosis.learn import fold_law_effects

        sim, data = self.sim, self.sim.data
        laws = [(self.laws[m].table, self.laws[m].learned.law) for m in model
                if m in self.laws]
        classes = [self.effects[m] for m in model if m not in self.laws]
        folds = fold_law_effects(data, laws, self.held)
        every = law_effects(_named(refit_all(t, law)) for t, law in laws)
        if not classes:
            models: list[tuple[Any, ...]] = list(folds)
            fitted: tuple[Any, ...] = every
        else:
            alts = FitSpace.alternatives(classes, self.parameters)
            rows = [np.setdiff1d(np.arange(data.n), h) for h in self.held] + [np.arange(data.n)]
            spaces = []
            for lk in [*folds, every]:
                spaces.append([FitSpace(tuple(lk) + a.effects,
                                        tuple((i + len(lk), j) for i, j in a.free))
                               for a in alts])
            gens = [fit_steps(data, sp, [r], **self.fit_options)
                    for group, r in zip(spaces, rows, strict=True) for sp in group]
            fits = run_fits(sim, gens)
            models = []
            for k, group in enumerate(spaces):
                part = fits[k * len(alts):(k + 1) * len(alts)]
                a = int(np.argmin([f.train_mse[0] if np.isfinite(f.train_mse[0]) else np.inf
                                   for f in part]))
                models.append(group[a].model(part[a].x[0]))
            fitted = models.pop()
        res = sim.residuals(models)
        residuals = np.full_like(data.observed, np.nan)
        for h, r in zip(self.held, res, strict=True):
            residuals[h] = r[h]
        out = (data.case_errors(residuals), tuple(fitted))
        self._joint[key] = out
        self._residuals[key] = residuals
        return out

    def joint_residuals(self, model: Sequence[str]) -> np.ndarray:
        """Held-out residuals of the joint model (:meth:`joint`)."""
        if not model:
            return self.base.residuals
        self.joint(model)
        return self._residuals[self._key(model)]

    def _on(self, claimed: tuple[str, ...]) -> VariantSimulator:
        key = self._key(claimed)
        if key not in self._sims:
            self._sims[key] = with_effects(self.sim, self.joint(claimed)[1])
        return self._sims[key]

    # -- the Evaluator protocol -----------------------------------------------------------

    def rmse(self, model: tuple[str, ...]) -> float:
        """Cross-validated overall RMSE (standardised) of the joint model."""
        from vfs.diagnosis.calibrate import overall_mse

        return math.sqrt(overall_mse(self.joint(model)[0]))

    def joint_gain(self, name: str, model: tuple[str, ...]) -> Reduction:
        """The joint model against it without ``name``."""
        return self.ci(self.joint(model)[0],
                       self.joint(tuple(m for m in model if m != name))[0])

    def on_top(self, names: Sequence[str], claimed: tuple[str, ...]) -> dict[str, Reduction]:
        """Each candidate on top of the claims (fitted on all cases), against them."""
        if not claimed:
            return {n: self.alone_reductions[n] if n in self.alone_reductions
                    else self.ci(self.alone[n], self.base.errors) for n in names}
        from vfs.diagnosis.calibrate import cross_validate_many

        t0 = time.perf_counter()
        sim_c = self._on(claimed)
        n_before = (sim_c.n_variants, sim_c.n_case_runs, sim_c.n_calls, sim_c.seconds)
        ref = sim_c.data.case_errors(sim_c.residuals([()])[0])
        out: dict[str, Reduction] = {}
        eff = [n for n in names if n not in self.laws]
        if eff:
            self.say(f"  fitting {len(eff)} library effect(s) on top of {', '.join(claimed)} ...")
        cvs = cross_validate_many(
            sim_c, [FitSpace.alternatives([self.effects[n]], self.parameters) for n in eff],
            self.held, [f"{'+'.join(claimed)}+{n}" for n in eff], fit_all=False,
            allow_off=True, **self.fit_options) if eff else []
        for n, cv in zip(eff, cvs, strict=True):
            self.on_top_errors[(n, claimed)] = cv.errors
            out[n] = self.ci(cv.errors, ref)
        laws = [n for n in names if n in self.laws]
        if laws:
            out.update(self._learn_on(sim_c, ref, laws, claimed))
        # the simulator on top of the claims is kept (cache); count its new work once
        self.sim.n_variants += sim_c.n_variants - n_before[0]
        self.sim.n_case_runs += sim_c.n_case_runs - n_before[1]
        self.sim.n_calls += sim_c.n_calls - n_before[2]
        self.sim.seconds += sim_c.seconds - n_before[3]
        self.stepwise_seconds += time.perf_counter() - t0
        return out

    def _learn_on(self, sim_c: VariantSimulator, ref: np.ndarray, laws: Sequence[str],
                  claimed: tuple[str, ...]) -> dict[str, Reduction]:
        """The laws' channels re-identified with the base model of ``sim_c`` (the claims
        ``claimed`` applied), their laws learned anew and cross-validated against ``ref``
        (its per-case errors); a law with structure replaces its former version.
        """
        out: dict[str, Reduction] = {}
        on = ", ".join(claimed)
        self.say(f"  re-identifying {len(laws)} channel(s) with {on} applied ...")
        table = self.ident(sim_c, [self.laws[n].channel for n in laws])
        found = {r.channel: r for r in self.learned(table)}
        for n in laws:
            f = self.laws[n]
            r = found.get(f.channel)
            if r is None or not r.significant or r.law is None:
                f.note = f"no structure in its identification with {on} applied"
                out[n] = Reduction(math.nan, math.nan, math.nan)
                continue
            err = outcome_law(sim_c, table, r, self.held, self.say)
            self.laws[n] = LawFinding(f.channel, r, f.outcome, f.errors,
                                      given_claimed=self.ci(err, ref), on_top_of=claimed,
                                      round=len(claimed), table=table)
            self._versions_made += 1
            self._version[n] = self._versions_made
            self.on_top_errors[(n, claimed)] = err
            out[n] = self.laws[n].given_claimed  # type: ignore[assignment]
            self.say(f"  on top of {on}: {r.text()}")
        return out

    def worse(self, model: tuple[str, ...]) -> dict[str, Reduction]:
        """The output groups the joint model ``model`` makes worse than the default model: its
        held-out errors against the default model's, per group, with the CI of ``group_ci``
        entirely below 0 and the estimate at most ``-min_worsening`` (the mirror of
        :func:`helps`; a single candidate: its errors alone).
        """
        if self.group_ci is None or not model:
            return {}
        err = self.alone[model[0]] if len(model) == 1 and model[0] in self.alone \
            else self.joint(model)[0]
        out = {}
        for k, g in enumerate(self.sim.data.group_names):
            r = self.group_ci(err, self.base.errors, k)
            if np.isfinite(r.high) and r.high < 0 and r.estimate <= -self.min_worsening:
                out[g] = r
        return out

    def exchange(self, first: str, rival: str, min_reduction: float) -> Reduction | None:
        """The first claim ``first`` (a law) learned again on top of ``rival`` (a law that
        did as well alone and that it absorbed): the model ``rival`` + ``first`` replaces
        ``first`` alone where ``first`` helps on top of ``rival`` (:func:`helps`: both steps
        of that path pass the claim rule) and the joint model's CV RMSE is lower than that of
        ``first`` alone (the rule of :meth:`relearn`); else ``first`` is restored.  A law
        learned from an identification missing another law absorbs that law (an unmodelled
        contact-plane turn makes the tyre impulse follow the impact angle), and which of the
        two comes first was decided by chance.

        Returns the joint model's reduction against ``first`` alone, or None.
        """
        if first not in self.laws or rival not in self.laws:
            return None
        old, version, note = self.laws[first], self._version.get(first, 0), self.laws[first].note
        alone, before = self.joint((first,))[0], self.rmse((first,))
        self.say(f"  {first} against {rival}: {first} learned again on top of {rival} ...")
        gain = self.on_top([first], (rival,))[first]
        self.say(f"  {first} on top of {rival}: {format_reduction(gain)}")
        if helps(gain, min_reduction):
            r = self.ci(self.joint((rival, first))[0], alone)
            after = self.rmse((rival, first))
            self.say(f"  {rival} + {first} against {first} alone: {format_reduction(r)}; "
                     f"CV RMSE {before:.3f} -> {after:.3f}")
            if after < before:
                return r
        self.laws[first], self._version[first] = old, version
        old.note = note
        return None

    def relearn(self, model: tuple[str, ...]) -> list[str]:
        """Backfitting of the claimed laws: each law of ``model`` but the last (the one just
        claimed, learned on top of the others) is learned again from its channel
        re-identified with the other claims applied, and kept where the
        joint model's cross-validated RMSE falls; else its former version is restored.  The
        other claims are applied as fitted together with the law (the joint model on all
        cases), as in backfitting (Hastie & Tibshirani, *Generalized Additive Models*, 1990,
        ch. 4): each part refitted to what the others, at their joint fit, leave.

        A law claimed early was identified without the later claims, and a missing law leaks
        into the identification of the others (an unmodelled tyre impulse into the
        contact-plane turn and back): the later claims can explain part of what it absorbed.

        Returns the names of the laws kept in their new version.
        """
        kept: list[str] = []
        for n in model[:-1]:
            if n not in self.laws:
                continue
            before, old, version = self.rmse(model), self.laws[n], self._version.get(n, 0)
            note = old.note
            others = tuple(m for m in model if m != n)
            # the other claims as fitted in the joint model with this law (its effect left
            # out): the joint fit's effects are the laws' (model order), then the library's
            laws = [m for m in model if m in self.laws]
            fitted = list(self.joint(model)[1])
            del fitted[laws.index(n)]
            sim_c = with_effects(self.sim, fitted)
            ref = sim_c.data.case_errors(sim_c.residuals([()])[0])
            self.say(f"  re-learning {n} with {', '.join(others)} applied (as fitted with it) ...")
            self._learn_on(sim_c, ref, [n], others)
            absorb_counters(self.sim, sim_c)
            if self.laws[n] is old:  # no structure once re-identified: keep it as it was
                old.note = note
                continue
            after = self.rmse(model)
            if after < before:
                kept.append(n)
                self.say(f"  {n} re-learned: CV RMSE {before:.3f} -> {after:.3f}")
            else:
                self.say(f"  {n} kept as it was: re-learned, CV RMSE {before:.3f} -> {after:.3f}")
                self.laws[n], self._version[n] = old, version
        return kept


def first_laws(sim: VariantSimulator, base: CVResult, held: Sequence[np.ndarray],
               channels: str | Iterable[str], grid: int, seed: int, n_boot: int,
               say: Callable[[str], None]
               ) -> tuple[pd.DataFrame, list[tuple[Any, np.ndarray]], Callable[..., Any],
                          Callable[..., Any]]:
    """Identify every channel per case with the default model, learn its law and
    cross-validate each law with structure as an effect (the laws' step 0).

    Returns the identification table, (ChannelLaw, held-out errors) of each law with
    structure, and the identify and learn functions the selection uses again.
    """
    from vfs.diagnosis.identify import identification_features, identify, parse_channels
    from vfs.diagnosis.learn import learn

    data = sim.data
    feats = identification_features(data)

    def ident(s: VariantSimulator, names: Sequence[str]) -> pd.DataFrame:
        t = identify(data, names, grid_points=grid, sim=s, progress=say)
        return t.merge(feats, on="case_id", how="left")

    def learned(table: pd.DataFrame) -> list[Any]:
        return learn(table, None, seed=seed, n_boot=min(n_boot, 1000), band_boot=50)

    t0 = time.perf_counter()
    names = parse_channels(channels)
    say(f"identifying {len(names)} channels per case ({grid} values each, {data.n} cases) ...")
    table = ident(sim, names)
    say(f"identified {table['channel'].nunique()} channels per case in "
        f"{time.perf_counter() - t0:.1f} s; learning their laws ...")
    out = []
    for r in learned(table):
        say(r.text())
        if r.significant and r.law is not None:
            out.append((r, outcome_law(sim, table, r, held, say)))
    return table, out, ident, learned


__all__ = ["FORMULA_OVERRULE_BOOT", "FORMULA_OVERRULE_LEVEL", "LawFinding", "ModelEvaluator",
           "Reduction", "absorb_counters",
           "closed_alternative", "first_laws", "format_reduction", "helps", "law_effects",
           "law_key", "outcome_law", "refit_all", "stepwise_helps", "with_effects"]
