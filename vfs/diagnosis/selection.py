"""One model selection over library effects and learned laws (forward stepwise, backward checks).

:func:`select` is the selection of :func:`vfs.diagnosis.diagnose.diagnose`; it knows the
candidates only by name and asks an :class:`Evaluator` for cross-validated reductions, so the
same logic runs on simulated outcomes (:class:`vfs.diagnosis.claims.ModelEvaluator`) and on
synthetic reductions (the tests).  Each step:

1. every candidate not claimed (and never dropped) is cross-validated **on top of the claims**
   (the claims fitted on all cases, the candidate fitted per fold; a learned law is learned
   again from its channel re-identified with the claims applied);
2. the one with the largest reduction is claimed if :func:`vfs.diagnosis.claims.stepwise_helps`
   holds: its reduction on top lies above 0 with its CI and reaches ``min_reduction``, and the
   model with the claims **refitted together with it** lowers the error against the claims
   alone; if it fails the refit, the next best is tried;
3. **backfitting** (:meth:`Evaluator.relearn`): each learned law claimed before it is learned
   again from its channel re-identified with the other claims applied, kept where the joint
   model's CV RMSE falls (a law claimed early was identified without the later claims, and a
   missing law leaks into the identification of the others);
   A candidate is claimed only if the model with it **makes no output worse than the default
   model does** (:meth:`Evaluator.worse`: an output group whose reduction against the default
   model has its CI entirely below 0); otherwise the next best is tried, and the candidate's
   reason names the outputs it worsens ("mimics a run-out mechanism" where it improves the
   run-out's outputs and worsens those fixed at separation: delta-v, post-impact speeds);
4. **backward check**: every earlier claim is re-tested given the others (the joint model
   against the joint model without it) and dropped if it no longer helps ("dropped after X
   joined"); a dropped candidate does not come back.

The selection stops when no candidate is claimed or after ``max_steps`` claims.  Every
candidate not claimed gets one reason: "dropped after X joined", "not confirmed on top of
X" (helps on top, fails the refit), "mimics X" (helps alone, no longer on top of the claims:
X is the claim after whose joining its reduction vanished), "mimics a run-out mechanism
(worsens ...)" / "worsens ..." (the last time it was the best candidate, its model made an
output worse than the default model) or "not significant".  The claims
are ordered by their share in the final joint model (reduction of the joint model against
it without the claim), the leading explanation first.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from vfs.diagnosis.claims import Reduction, helps
from vfs.diagnosis.diagnose_spec import DiagnoseSpec


class Evaluator(Protocol):
    """Cross-validated reductions of models named by their candidates."""

    def on_top(self, names: Sequence[str], claimed: tuple[str, ...]) -> dict[str, Reduction]:
        """Reduction of each candidate added to the claims (fitted on all cases), against
        the claims; ``claimed`` empty: against the default model.
        """

    def joint_gain(self, name: str, model: tuple[str, ...]) -> Reduction:
        """Reduction of the joint model ``model`` (all refitted per fold) against the joint
        model without ``name``.
        """

    def rmse(self, model: tuple[str, ...]) -> float:
        """Cross-validated overall RMSE (standardised) of the joint model."""

    def relearn(self, model: tuple[str, ...]) -> list[str]:
        """Backfitting: the claims of ``model`` before its last learned again given the
        others where that lowers :meth:`rmse`; the names of those re-learned.
        """

    def exchange(self, first: str, rival: str, min_reduction: float) -> Reduction | None:
        """The model ``rival`` then ``first`` learned again on top of it, where ``first``
        helps there and that model's :meth:`rmse` is below that of ``first`` alone; its
        reduction against ``first`` alone, or None (nothing changed).
        """

    def worse(self, model: tuple[str, ...]) -> dict[str, Reduction]:
        """The output groups the joint model ``model`` makes worse than the default model
        (their reduction against it, its CI entirely below 0); empty: none.
        """


#: Output groups fixed at separation: a mechanism acting only in the run-out leaves them as
#: the default model has them (:data:`vfs.effects.learned.CHANNEL_OUTPUTS`).
RUNOUT_GROUPS = ("rest_position", "rest_yaw", "runout_distance")


def worse_reason(worse: Mapping[str, Reduction]) -> str:
    """The reason of a candidate whose model worsens the outputs ``worse``: "mimics a run-out
    mechanism (worsens delta_v, post_speed against the default model)" where none of them is
    an output of the run-out (it moved outputs fixed at separation to mimic a run-out
    mechanism), else "worsens ... against the default model".
    """
    names = ", ".join(f"{g} ({_fmt(r)})" for g, r in worse.items())
    if not any(g in RUNOUT_GROUPS for g in worse):
        return f"mimics a run-out mechanism (worsens {names} against the default model)"
    return f"worsens {names} against the default model"


#: Sign of each step's action in the ledger's labels (verdict and report figure).
STEP_SIGNS = {"add": "+", "relearn": "~", "drop": "-"}


def step_label(action: str, name: str, sep: str = "") -> str:
    """The ledger's label of a step: "default" at the start, else the action's sign and the
    candidate ("+tyre_impulse", "~cp_angle law", "-proxy"), ``sep`` between them.
    """
    return "default" if action == "start" else f"{STEP_SIGNS.get(action, '-')}{sep}{name}"


@dataclass(frozen=True)
class Step:
    """One step of the selection's ledger.

    Attributes
    ----------
    action : str
        "start" (the default model), "add", "relearn" (a claimed law learned again given the
        later claims) or "drop".
    name : str
        The candidate added or dropped ("" at the start).
    rmse : float
        Cross-validated overall RMSE (standardised) of the joint model after the step.
    reduction : Reduction or None
        The added candidate's reduction on top of the claims before it; the dropped
        claim's share in the model it left.
    model : tuple of str
        The claims after the step.
    """

    action: str
    name: str
    rmse: float
    reduction: Reduction | None
    model: tuple[str, ...]


@dataclass
class Selection:
    """What :func:`select` found.

    Attributes
    ----------
    claims : list of str
        The final claims, the largest share in the joint model first.
    share : dict of Reduction
        Per claim: the joint model against it without the claim (one claim: its reduction
        alone).
    alone : dict of Reduction
        Per candidate: its reduction against the default model.
    on_top : dict of Reduction
        Per candidate: its reduction on top of the claims at the step it joined (claims), or
        at the last step it was tried (the others).
    on_top_of : dict of tuple
        The claims ``on_top`` was measured on.
    refit : dict of Reduction
        Per candidate that helped on top: the claims refitted together with it against the
        claims alone.
    reasons : dict of str
        Per candidate not claimed: why.
    steps : list of Step
        The ledger: the default model, then each addition and drop.
    removed : dict of float
        Per claim: how much the joint model's CV RMSE rises without it (the order of
        ``claims``).
    worse : dict of dict of Reduction
        Per candidate not claimed because its model made outputs worse than the default
        model (:meth:`Evaluator.worse`): those outputs' reductions.
    """

    claims: list[str] = field(default_factory=list)
    share: dict[str, Reduction] = field(default_factory=dict)
    alone: dict[str, Reduction] = field(default_factory=dict)
    on_top: dict[str, Reduction] = field(default_factory=dict)
    on_top_of: dict[str, tuple[str, ...]] = field(default_factory=dict)
    refit: dict[str, Reduction] = field(default_factory=dict)
    reasons: dict[str, str] = field(default_factory=dict)
    steps: list[Step] = field(default_factory=list)
    removed: dict[str, float] = field(default_factory=dict)
    worse: dict[str, dict[str, Reduction]] = field(default_factory=dict)

    @property
    def rejected(self) -> list[str]:
        """The candidates not claimed, those that helped alone first, then by reduction."""
        return sorted(self.reasons, key=lambda n: (not helps(self.alone.get(n), 0.0),
                                                   -_est(self.alone.get(n))))


def _est(r: Reduction | None) -> float:
    return -math.inf if r is None or not math.isfinite(r.estimate) else r.estimate


def select(names: Sequence[str], ev: Evaluator, min_reduction: float,
           max_steps: int = DiagnoseSpec.max_steps,
           reliable: bool = True, worth_trying: Callable[[Reduction], bool] | None = None,
           say: Callable[[str], None] | None = None,
           always_try: Collection[str] = ()) -> Selection:
    """Forward stepwise selection with backward checks (module docstring).

    Parameters
    ----------
    names : sequence of str
        The candidates.
    ev : Evaluator
    min_reduction : float
        Smallest reduction that counts (:func:`vfs.diagnosis.claims.helps`).
    max_steps : int
        Most claims added.
    reliable : bool
        False: nothing is claimed (too few cases), the reductions alone are still reported.
    worth_trying : callable, optional
        Which candidates are tried on top of claims, from their reduction alone (default:
        all; the diagnosis skips the laws whose CI alone lies entirely below
        ``min_reduction``).
    say : callable, optional
        Progress lines.
    always_try : collection of str
        Candidates tried on top of claims whatever their reduction alone (the diagnosis:
        the library effects; an effect masked by a missing one of opposite sign, such as a
        contact-phase tyre impulse that shortens run-outs a released brake lengthens, helps
        only once that is claimed).
    """
    out = Selection()
    tell = say or (lambda _m: None)
    claimed: list[str] = []
    dropped: dict[str, str] = {}
    absorbed: dict[str, str] = {}
    out.steps.append(Step("start", "", ev.rmse(()), None, ()))
    alone = ev.on_top(list(names), ())
    out.alone = dict(alone)
    try_ = worth_trying or (lambda _r: True)
    capped = False
    worsens: dict[str, dict[str, Reduction]] = {}
    check_worse = getattr(ev, "worse", None)
    for step in range(max_steps + 1):
        if step == max_steps:
            capped = True
            break
        pool = [n for n in names if n not in claimed and n not in dropped]
        if step:
            pool = [n for n in pool if n in always_try or try_(alone[n])]
        if not pool:
            break
        gains = alone if not claimed else ev.on_top(pool, tuple(claimed))
        for n in pool:
            out.on_top[n] = gains[n]
            out.on_top_of[n] = tuple(claimed)
            if claimed and n not in absorbed and helps(alone[n], min_reduction) \
                    and not helps(gains[n], min_reduction):
                absorbed[n] = claimed[-1]
        added = None
        for n in sorted(pool, key=lambda m: (-_est(gains[m]), m)):
            if not (reliable and helps(gains[n], min_reduction)):
                break
            if claimed:
                r = ev.joint_gain(n, (*claimed, n))
                out.refit[n] = r
                if not helps(r, min_reduction):
                    tell(f"step {step + 1}: {n} helps on top of {', '.join(claimed)} but not "
                         "with them refitted together")
                    continue
            bad = check_worse((*claimed, n)) if check_worse is not None else {}
            if bad:
                worsens[n] = dict(bad)
                tell(f"step {step + 1}: {n} not claimed: {worse_reason(bad)}")
                continue
            worsens.pop(n, None)
            added = n
            break
        if added is None:
            break
        claimed.append(added)
        out.steps.append(Step("add", added, ev.rmse(tuple(claimed)), gains[added],
                              tuple(claimed)))
        tell(f"step {step + 1}: claimed {added} ({_fmt(gains[added])} on top of "
             f"{', '.join(out.on_top_of[added]) or 'the default model'})")
        if len(claimed) == 1:
            # the first claim against the candidates as good alone (each estimate within
            # the other's CI): which of two mimics comes first was decided by chance, and a
            # law learned without the other absorbs it
            first = gains[added]
            for n in sorted(pool, key=lambda m: (-_est(gains[m]), m)):
                r0 = gains[n]
                if n == added or r0 is None or not helps(r0, min_reduction) \
                        or not (r0.high >= first.estimate and r0.estimate >= first.low):
                    continue
                swap = ev.exchange(added, n, min_reduction)
                if swap is not None:
                    claimed.insert(0, n)
                    out.steps.append(Step("add", n, ev.rmse(tuple(claimed)), swap,
                                          tuple(claimed)))
                    tell(f"step {step + 1}: claimed {n} before {added} ({_fmt(swap)} against "
                         f"{added} alone, {added} learned again on top of {n})")
                    break
        for n in ev.relearn(tuple(claimed)) if len(claimed) > 1 else []:
            out.steps.append(Step("relearn", n, ev.rmse(tuple(claimed)), None, tuple(claimed)))
            tell(f"step {step + 1}: re-learned {n} given {added}")
        again = True
        while again and len(claimed) > 1:
            again = False
            for s in claimed[:-1]:
                r = ev.joint_gain(s, tuple(claimed))
                if not helps(r, min_reduction):
                    claimed.remove(s)
                    dropped[s] = added
                    out.steps.append(Step("drop", s, ev.rmse(tuple(claimed)), r,
                                          tuple(claimed)))
                    tell(f"step {step + 1}: dropped {s} after {added} joined "
                         f"({_fmt(r)} in the joint model)")
                    again = True
                    break
    share = {s: (out.alone[s] if len(claimed) == 1 else ev.joint_gain(s, tuple(claimed)))
             for s in claimed}
    final = ev.rmse(tuple(claimed))
    removed = {s: ev.rmse(tuple(m for m in claimed if m != s)) - final for s in claimed}
    out.claims = sorted(claimed, key=lambda s: (-removed[s], s))
    out.share = {s: share[s] for s in out.claims}
    out.removed = {s: removed[s] for s in out.claims}
    out.worse = {n: w for n, w in worsens.items() if n not in claimed}
    lead = out.claims[0] if out.claims else ""
    for n in names:
        if n in claimed:
            continue
        if n in dropped:
            out.reasons[n] = f"dropped after {dropped[n]} joined"
        elif n in worsens and reliable:
            out.reasons[n] = worse_reason(worsens[n])
        elif capped and reliable and helps(out.on_top.get(n), min_reduction) \
                and n not in out.refit:
            out.reasons[n] = f"not tried: at most {max_steps} claims"
        elif n in out.refit and helps(out.on_top.get(n), min_reduction) and reliable:
            out.reasons[n] = f"not confirmed on top of {', '.join(out.on_top_of[n])}"
        elif reliable and claimed and helps(alone[n], min_reduction):
            by = absorbed.get(n, lead)
            out.reasons[n] = f"mimics {by if by in claimed else lead}"
        elif not reliable:
            out.reasons[n] = "too few cases for any claim"
        else:
            out.reasons[n] = "not significant"
    return out


def _fmt(r: Reduction | None) -> str:
    if r is None:
        return "-"
    return f"{100 * r.estimate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"


class TableEvaluator:
    """An :class:`Evaluator` over given reductions (tests, what-if studies).

    Parameters
    ----------
    explains : mapping of str to mapping of str to float
        Per candidate, the share of each error component it explains (0..1).
    components : mapping of str to float
        The squared error of each component in the default model; a model explains of a
        component the largest share any of its candidates does.
    half_width : float
        Half width of every CI (in reduction units).
    worsens : mapping of str to mapping of str to float, optional
        Per candidate, the output groups it makes worse than the default model and by how
        much (a negative reduction); a model worsens a group when any of its candidates does.
    """

    def __init__(self, explains: Mapping[str, Mapping[str, float]],
                 components: Mapping[str, float], half_width: float = 0.02,
                 worsens: Mapping[str, Mapping[str, float]] | None = None) -> None:
        self.explains = explains
        self.components = components
        self.half_width = half_width
        self.worsens = dict(worsens or {})
        self.calls = 0

    def _mse(self, model: Sequence[str]) -> float:
        total = 0.0
        for c, e in self.components.items():
            share = max([self.explains[m].get(c, 0.0) for m in model], default=0.0)
            total += e * (1.0 - share)
        return total

    def _red(self, model: Sequence[str], ref: Sequence[str]) -> Reduction:
        est = 1.0 - math.sqrt(self._mse(model) / self._mse(ref))
        return Reduction(est, est - self.half_width, est + self.half_width)

    def on_top(self, names: Sequence[str], claimed: tuple[str, ...]) -> dict[str, Reduction]:
        """See :class:`Evaluator`."""
        self.calls += 1
        return {n: self._red((*claimed, n), claimed) for n in names}

    def joint_gain(self, name: str, model: tuple[str, ...]) -> Reduction:
        """See :class:`Evaluator`."""
        return self._red(model, tuple(m for m in model if m != name))

    def rmse(self, model: tuple[str, ...]) -> float:
        """See :class:`Evaluator`."""
        return math.sqrt(self._mse(model))

    def relearn(self, model: tuple[str, ...]) -> list[str]:
        """See :class:`Evaluator` (given reductions: nothing to re-learn)."""
        return []

    def exchange(self, first: str, rival: str, min_reduction: float) -> Reduction | None:
        """See :class:`Evaluator` (given reductions: nothing to learn again)."""
        return None

    def worse(self, model: tuple[str, ...]) -> dict[str, Reduction]:
        """See :class:`Evaluator` (the given ``worsens`` of the model's candidates)."""
        out: dict[str, Reduction] = {}
        for m in model:
            for g, v in self.worsens.get(m, {}).items():
                if g not in out or v < out[g].estimate:
                    out[g] = Reduction(v, v - self.half_width, v + self.half_width)
        return {g: r for g, r in out.items() if r.high < 0}


__all__ = ["RUNOUT_GROUPS", "STEP_SIGNS", "Evaluator", "Selection", "Step", "TableEvaluator",
           "select", "step_label", "worse_reason"]
