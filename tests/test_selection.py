"""The one model selection of the diagnosis (vfs.diagnosis.selection) on synthetic reductions.

A :class:`TableEvaluator` model: error components with known squared errors; each candidate
explains a share of some components, a model the largest share any of its candidates has.
The reductions follow from that exactly, so each expected claim is derived, not tuned.
"""

from __future__ import annotations

from vfs.diagnosis.claims import Reduction
from vfs.diagnosis.selection import TableEvaluator, select


def test_proxy_claimed_first_is_dropped_after_the_true_ones_join():
    # the proxy explains 70 % of both components (alone 1 - sqrt(0.3) = 45 %), each true
    # law one component fully (1 - sqrt(0.5) = 29 %): the proxy leads step 1; with both true
    # laws in, the proxy explains nothing more and the backward check drops it
    ev = TableEvaluator({"proxy": {"A": 0.7, "B": 0.7}, "law_a": {"A": 1.0},
                         "law_b": {"B": 1.0}}, {"A": 1.0, "B": 1.0, "noise": 0.5},
                        half_width=0.01)
    sel = select(["proxy", "law_a", "law_b"], ev, 0.01)
    assert sel.steps[1].name == "proxy"
    assert sorted(sel.claims) == ["law_a", "law_b"]
    assert sel.reasons == {"proxy": "dropped after law_b joined"}
    assert [s.action for s in sel.steps] == ["start", "add", "add", "add", "drop"]
    # the ledger's error falls with every addition; the drop leaves it unchanged
    rmse = [s.rmse for s in sel.steps]
    assert rmse[1] < rmse[0] and rmse[2] < rmse[1]
    assert rmse[-1] == rmse[-2] == ev.rmse(("law_a", "law_b"))


def test_a_mimic_is_labelled_with_the_claim_that_absorbs_it():
    # the library effect explains 60 % of the law's component: helps alone, nothing on top
    ev = TableEvaluator({"effect": {"A": 0.6}, "law": {"A": 1.0}}, {"A": 1.0, "noise": 1.0})
    sel = select(["effect", "law"], ev, 0.01)
    assert sel.claims == ["law"]
    assert sel.reasons == {"effect": "mimics law"}
    assert sel.alone["effect"].low > 0 and sel.on_top["effect"].estimate == 0.0


def test_noise_claims_nothing():
    ev = TableEvaluator({"a": {}, "b": {"A": 0.005}}, {"A": 1.0})
    sel = select(["a", "b"], ev, 0.01)
    assert sel.claims == [] and set(sel.reasons.values()) == {"not significant"}
    assert [s.action for s in sel.steps] == ["start"]


def test_too_few_cases_claims_nothing_but_reports_the_reductions():
    ev = TableEvaluator({"a": {"A": 1.0}}, {"A": 1.0, "B": 1.0})
    sel = select(["a"], ev, 0.01, reliable=False)
    assert sel.claims == [] and sel.alone["a"].estimate > 0.2
    assert sel.reasons["a"] == "too few cases for any claim"


def test_claims_are_ordered_by_their_share_in_the_joint_model():
    # the verdict order is by the share in the final model: 'big' explains the larger part
    ev = TableEvaluator({"big": {"A": 1.0}, "small": {"B": 1.0}},
                        {"A": 3.0, "B": 1.0, "noise": 1.0})
    sel = select(["small", "big"], ev, 0.01)
    assert sel.claims == ["big", "small"]
    assert sel.removed["big"] > sel.removed["small"] > 0
    assert sel.share["big"].estimate > sel.share["small"].estimate > 0


def test_failed_refit_is_not_confirmed_and_the_next_best_is_tried():
    class Refit(TableEvaluator):
        def joint_gain(self, name, model):
            if name == "fake" and len(model) > 1:
                return Reduction(0.0, -0.05, 0.05)
            return super().joint_gain(name, model)

    ev = Refit({"a": {"A": 1.0}, "fake": {"B": 1.0}, "b": {"C": 1.0}},
               {"A": 4.0, "B": 2.0, "C": 1.0, "noise": 1.0})
    sel = select(["a", "fake", "b"], ev, 0.01)
    assert sorted(sel.claims) == ["a", "b"]
    assert sel.reasons["fake"] == "not confirmed on top of a, b"


def test_step_cap():
    ev = TableEvaluator({n: {n: 1.0} for n in "abc"}, {"a": 3.0, "b": 2.0, "c": 1.0,
                                                        "noise": 1.0})
    sel = select(list("abc"), ev, 0.01, max_steps=2)
    assert sel.claims == ["a", "b"] and sel.reasons["c"] == "not tried: at most 2 claims"


def test_a_law_claimed_early_is_relearned_given_the_later_claims():
    # law 'cp' was learned with the tyre component unmodelled: it explains half of its own
    # component C only (the identification absorbed the leak); learned again with 'tyre'
    # applied it explains C fully.  The backfitting step re-learns it after 'tyre' joins,
    # where the joint model's error falls (the evaluator's rule): the ledger records it,
    # and the final model's error is that of both components explained
    class Leak(TableEvaluator):
        def relearn(self, model):
            if "tyre" in model and "cp" in model[:-1] and self.explains["cp"]["C"] < 1.0:
                before = self.rmse(model)
                old = dict(self.explains["cp"])
                self.explains["cp"]["C"] = 1.0
                if self.rmse(model) < before:
                    return ["cp"]
                self.explains["cp"] = old
            return []

    ev = Leak({"cp": {"C": 0.5}, "tyre": {"T": 1.0}}, {"C": 4.0, "T": 2.0, "noise": 0.5},
              half_width=0.01)
    sel = select(["cp", "tyre"], ev, 0.01)
    assert [(s.action, s.name) for s in sel.steps] == [
        ("start", ""), ("add", "cp"), ("add", "tyre"), ("relearn", "cp")]
    assert sel.steps[-1].rmse == ev.rmse(("cp", "tyre")) < sel.steps[-2].rmse
    assert sel.steps[-1].rmse == (0.5) ** 0.5  # only the noise component is left
    assert sorted(sel.claims) == ["cp", "tyre"]


class _Relearning(TableEvaluator):
    """A :class:`TableEvaluator` whose ``leak`` law, learned without ``true``, explains
    its component and most of ``true``'s (0.85), and learned again on top of ``true``
    explains its own fully (what the diagnosis's re-identification does)."""

    def __init__(self, **kw):
        super().__init__({"leak": {"L": 1.0, "T": 0.85}, "true": {"T": 1.0},
                          "leak_again": {"L": 1.0}}, {"L": 0.3, "T": 1.0, "noise": 0.3}, **kw)
        self.asked: list[tuple[str, str]] = []

    def exchange(self, first, rival, min_reduction):
        self.asked.append((first, rival))
        r = self._red((rival, "leak_again"), (first,))
        return r if r.estimate > 0 else None


def test_a_first_claim_that_absorbed_an_equally_good_rival_is_exchanged():
    # alone: leak 1 - sqrt(0.45 / 1.6) = 47.0 %, true 1 - sqrt(0.6 / 1.6) = 38.8 %; with CIs
    # of +-10 % the true law is as good (its CI reaches 47.0 %): the exchange is tried, and
    # true + leak learned again (0.3 of noise left) beats leak alone (0.45) by 18 %
    ev = _Relearning(half_width=0.10)
    sel = select(["leak", "true"], ev, 0.01)
    assert ev.asked == [("leak", "true")]
    assert [s.action for s in sel.steps][:3] == ["start", "add", "add"]
    assert sel.steps[2].name == "true" and sel.steps[2].model == ("true", "leak")
    # with CIs of +-2 % the true law is worse alone: no exchange (it joins on top, second)
    ev = _Relearning(half_width=0.02)
    sel = select(["leak", "true"], ev, 0.01)
    assert ev.asked == [] and sel.steps[2].model == ("leak", "true")


def test_a_claim_that_worsens_an_output_is_a_mimic_not_a_claim():
    # the contact-phase tyre impulse explains more of the run-out error than the brake law
    # of both cars (90 % against 80 % of the component), but makes delta-v worse than the
    # default model: it is not claimed, the law is, and the impulse is named a mimic
    explains = {"tyre_impulse": {"rest": 0.9}, "runout_brake law": {"rest": 0.8}}
    comps = {"rest": 1.0, "noise": 0.3}
    control = select(list(explains), TableEvaluator(explains, comps), 0.01)
    assert control.claims == ["tyre_impulse"]  # without the rule the impulse wins
    ev = TableEvaluator(explains, comps, worsens={"tyre_impulse": {"delta_v": -0.2}})
    sel = select(list(explains), ev, 0.01)
    assert sel.claims == ["runout_brake law"]
    assert sel.reasons["tyre_impulse"].startswith(
        "mimics a run-out mechanism (worsens delta_v (-20.0 %")
    assert set(sel.worse) == {"tyre_impulse"}
    # worsening a run-out output is no mimic of a run-out mechanism, still no claim
    ev2 = TableEvaluator(explains, comps, worsens={"tyre_impulse": {"rest_yaw": -0.2}})
    sel2 = select(list(explains), ev2, 0.01)
    assert sel2.claims == ["runout_brake law"]
    assert sel2.reasons["tyre_impulse"].startswith("worsens rest_yaw")


def test_a_library_effect_masked_alone_is_tried_on_top():
    # the tutorial's second example: the tyre impulse alone explains nothing (it shortens
    # run-outs that the released brake makes too long), on top of the brake release it
    # explains its own component; the selection tries it there only as ``always_try``
    explains = {"brake_release": {"rest1": 1.0}, "tyre_impulse": {"dv": 1.0}}

    class Masked(TableEvaluator):
        def on_top(self, names, claimed):
            out = super().on_top(names, claimed)
            if not claimed and "tyre_impulse" in out:
                out["tyre_impulse"] = Reduction(0.0, 0.0, 0.0)
            return out

    comps = {"rest1": 3.0, "dv": 1.0, "noise": 0.5}
    skipped = select(list(explains), Masked(explains, comps), 0.01,
                     worth_trying=lambda r: r.high >= 0.01)
    assert skipped.claims == ["brake_release"]
    tried = select(list(explains), Masked(explains, comps), 0.01,
                   worth_trying=lambda r: r.high >= 0.01, always_try={"tyre_impulse"})
    assert tried.claims == ["brake_release", "tyre_impulse"]
