"""Claims of the diagnosis: the significance rules and the stepwise claims of learned laws.

:func:`helps` is the one significance rule of :func:`vfs.analysis.diagnose.diagnose`
(its table, JSON and text): the simultaneous bootstrap CI of a CV RMSE reduction
(:class:`Reduction`) lies above 0 and the estimate reaches ``min_reduction``.
:func:`stepwise_helps` is the rule of a further effect or law (ranks 2...).
:func:`learn_laws` identifies every channel per case, learns its law, cross-validates
it as an effect in outcome space and claims laws forward stepwise, each further one
learned from the identification with the claimed laws applied (docs/diagnosis.md,
"Beyond the library").
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

from vfs.analysis.calibrate import (
    CVResult,
    FitSpace,
    VariantSimulator,
    cross_validate,
    reduction_ci,
)

#: Most stepwise rounds of the law claims of :func:`learn_laws` (after the first law).
LAW_ROUNDS = 3


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
    learned : vfs.analysis.learn.ChannelLaw
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

    @property
    def status(self) -> str:
        """"claimed", "not confirmed on top of <claimed channels>" or "not significant"."""
        if self.significant:
            return "claimed"
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


def outcome_law(sim: VariantSimulator, table: pd.DataFrame, r: Any,
                held: Sequence[np.ndarray], say: Callable[[str], None]) -> np.ndarray:
    """Held-out errors of the law of ``r`` (a table, or its best formula if that does
    better on the outcomes: then ``r.law`` becomes the formula).
    """
    from vfs.analysis.learn import cross_validate_law

    _, err = cross_validate_law(sim, table, r.law, held)
    alt = closed_alternative(r)
    if alt is not None:  # a table won on the identified values: try the best formula
        _, err2 = cross_validate_law(sim, table, alt, held)
        if np.nanmean(err2) < np.nanmean(err):
            r.law, err = alt, err2
            say(f"  the formula does better on the outcomes: {alt['formula']}")
    return err


def refit_all(table: pd.DataFrame, law: Mapping[str, Any]) -> dict[str, Any]:
    """The law's form and feature refitted to all identifiable cases of ``table``."""
    from vfs.analysis.learn import law_rows, refit_law

    t, y, w = law_rows(table, law["channel"])
    out = refit_law(law, t[law["feature"]].to_numpy(float), y, w)
    from vfs.effects.learned import law_text

    out["formula"] = law_text(out)
    return out


def learn_laws(sim: VariantSimulator, base: CVResult, held: Sequence[np.ndarray],
                channels: str | Iterable[str], grid: int, seed: int,
                level: float, n_boot: int, min_reduction: float, reliable: bool,
                rng: np.random.Generator, say: Callable[[str], None], rounds: int
                ) -> tuple[list[LawFinding], pd.DataFrame, dict[str, float]]:
    """Identify, learn, cross-validate and claim the laws stepwise.

    See :func:`vfs.analysis.diagnose.diagnose` (``laws``, ``law_rounds``).

    Returns the findings (claimed first, in the order claimed), the first
    identification table and timings [s].
    """
    from vfs.analysis.identify import identification_features, identify, parse_channels
    from vfs.analysis.learn import cross_validate_law, cross_validate_laws, learn

    t0 = time.perf_counter()
    data = sim.data
    feats = identification_features(data)

    def ident(s: VariantSimulator, names: Sequence[str]) -> pd.DataFrame:
        t = identify(data, names, grid_points=grid, sim=s)
        return t.merge(feats, on="case_id", how="left")

    def learned(table: pd.DataFrame) -> list[Any]:
        return learn(table, None, folds=5, seed=seed, n_boot=min(n_boot, 1000),
                     band_boot=50)

    def ci(err: np.ndarray, ref: np.ndarray) -> Reduction:
        return Reduction(*reduction_ci(err, ref, rng, confidence=level, n_boot=n_boot))

    order = parse_channels(channels)
    table = ident(sim, order)
    say(f"identified {table['channel'].nunique()} channels per case in "
        f"{time.perf_counter() - t0:.1f} s")
    out = []
    for r in learned(table):
        say(r.text())
        if not r.significant or r.law is None:
            continue
        err = outcome_law(sim, table, r, held, say)
        red = ci(err, base.errors)
        out.append(LawFinding(r.channel, r, red, err,
                              significant=reliable and helps(red, min_reduction), table=table))
    out.sort(key=lambda f: -np.nan_to_num(f.outcome.estimate, nan=-np.inf))
    stats = {"law_seconds": round(time.perf_counter() - t0, 2), "law_stepwise_seconds": 0.0}
    first = next((f for f in out if f.significant), None)
    for f in out:
        f.significant = f is first
    if first is None:
        return out, table, stats
    # forward stepwise: the other channels with structure, re-identified with the claimed
    # laws applied (a missing law on one channel leaks into the identification of others)
    t1 = time.perf_counter()
    claimed = [first]
    model: list[tuple[pd.DataFrame, dict[str, Any]]] = [(table, dict(first.learned.law))]
    model_err = first.errors
    latest = {f.channel: f for f in out if f is not first}
    pending = [c for c in order if c in latest]
    for rnd in range(1, rounds + 1):
        if not pending:
            break
        on_top = tuple(f.channel for f in claimed)
        sim_c = with_effects(sim, law_effects(law for _, law in model))
        base_c = cross_validate(sim_c, FitSpace((), ()), held, "+".join(on_top),
                                fit_all=False)
        table_c = ident(sim_c, pending)
        cands: list[LawFinding] = []
        for r in learned(table_c):
            say(f"round {rnd}, with the law(s) of {', '.join(on_top)} applied: {r.text()}")
            prev = latest[r.channel]
            if not r.significant or r.law is None:
                if not prev.round:
                    prev.on_top_of = on_top
                prev.note = ("no structure in its identification with the law(s) of "
                             f"{', '.join(on_top)} applied")
                continue
            err_g = outcome_law(sim_c, table_c, r, held, say)
            _, err_a = cross_validate_law(sim, table_c, r.law, held)
            f = LawFinding(r.channel, r, ci(err_a, base.errors), err_a,
                           given_claimed=ci(err_g, base_c.errors), on_top_of=on_top,
                           round=rnd, table=table_c)
            latest[r.channel] = f
            cands.append(f)
        absorb_counters(sim, sim_c)
        cands.sort(key=lambda f: -np.nan_to_num(
            f.given_claimed.estimate if f.given_claimed else math.nan, nan=-np.inf))
        new = None
        for f in cands:
            if not helps(f.given_claimed, min_reduction):
                continue
            # the claimed laws refitted with it present: their channels re-identified with
            # it (and the other claimed laws) applied, all laws refitted per fold together
            law_f = f.learned.law
            refit_model = []
            for k, (_, law) in enumerate(model):
                others = [m for j, (_, m) in enumerate(model) if j != k] + [law_f]
                sim_r = with_effects(sim, law_effects(others))
                refit_model.append((ident(sim_r, [law["channel"]]), law))
                absorb_counters(sim, sim_r)
            _, err_r = cross_validate_laws(sim, [*refit_model, (table_c, law_f)], held)
            f.refit = ci(err_r, model_err)
            f.kept = ci(err_r, f.errors)
            f.significant = stepwise_helps(f.given_claimed, f.refit, min_reduction,
                                           also=(f.kept,))
            say(f"round {rnd}: {f.text()}{' (claimed)' if f.significant else ''}")
            if f.significant:
                new = f
                model = [(t, refit_all(t, law)) for t, law in refit_model] + [(table_c, law_f)]
                model_err = err_r
                break
        if new is None:
            break
        claimed.append(new)
        pending = [c for c in pending if c != new.channel and latest[c].round == rnd]
        if rnd == rounds:
            for c in pending:
                latest[c].note = f"stepwise rounds capped at {rounds}"
    stats["law_stepwise_seconds"] = round(time.perf_counter() - t1, 2)
    stats["law_seconds"] = round(time.perf_counter() - t0, 2)
    say(f"stepwise law claims: {', '.join(f.channel for f in claimed)} "
        f"({stats['law_stepwise_seconds']:.1f} s)")
    rest = sorted((f for f in latest.values() if not f.significant),
                  key=lambda f: -np.nan_to_num(f.outcome.estimate, nan=-np.inf))
    return claimed + rest, table, stats


__all__ = ["LAW_ROUNDS", "LawFinding", "Reduction", "absorb_counters", "closed_alternative",
           "format_reduction", "helps", "law_effects", "learn_laws", "outcome_law", "refit_all",
           "stepwise_helps", "with_effects"]
