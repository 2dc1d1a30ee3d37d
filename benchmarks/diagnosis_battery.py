"""The diagnosis battery: hidden laws of our own making, found or not by ``vfs diagnose``.

For every entry (a single hidden law of benchmarks/battery_laws.py, a pair of
them, or a null database with nothing hidden) a database is generated with
the law(s) hidden (``generate_database(..., hidden=[effect])``, default noise,
its own seed), and

1. ``vfs.diagnosis.diagnose.diagnose`` runs blind on it (every library effect,
   every channel identified and learned), timed;
2. the truth's own cross-validated reduction: the hidden effect(s) refitted
   per fold (their strength) on the same folds
   (:func:`vfs.diagnosis.calibrate.cross_validate`);
3. the claimed answer's reduction the same way: the claimed library effects
   and laws, refitted per fold together;
4. the judgement, by code: the first sentence of the verdict is *right* when
   the claim it names first sets the hidden channel (a law of that channel
   whose feature is the hidden law's leading feature or a near-equivalent, or
   a library effect acting on that channel, :data:`EFFECT_CHANNELS`); a pair
   is *named* when both hidden laws are matched by claims; a claim that
   matches no hidden law is an *absent* claim.

Each result is one JSON line in ``OUT/battery.jsonl`` (entries already there
are skipped: the run resumes); ``OUT/battery.md`` is the table of all lines with
the counts against the targets (docs/diagnosis.md, "The battery").

Usage::

    PYTHONPATH=. python benchmarks/diagnosis_battery.py --out battery_out
        [--cases 400] [--quick] [--jobs 2] [--only eps_bell,null1]
        [--held-out | --held-out-2 | --runout | --held-out-3 | --steer | --held-out-4]

``--quick``: diagnose with 3 folds, a 5-point grid, 2 zoom rounds and 500
bootstrap samples (the settings of benchmarks/diagnose_builtin_effects.py).
"""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from battery_laws import (  # noqa: E402
    HELD_OUT,
    HELD_OUT_2,
    HELD_OUT_2_PAIRS,
    HELD_OUT_3,
    HELD_OUT_3_PAIRS,
    HELD_OUT_4,
    HELD_OUT_4_PAIRS,
    HELD_OUT_PAIRS,
    PAIRS,
    RUNOUT,
    RUNOUT_PAIRS,
    SINGLES,
    STEER,
    STEER_PAIRS,
    HiddenLaw,
    hidden_effect,
    law_by_name,
)

#: Channels each library effect acts on (a claim of the effect names these channels).
EFFECT_CHANNELS: Mapping[str, tuple[str, ...]] = {
    "restitution_speed": ("restitution",),
    "tyre_impulse": ("tyre_impulse",),
    "body_friction": (),
    "penetration_depth": ("penetration_time",),
    "structure_poi": ("poi_along", "poi_across", "cp_angle"),
    "wheel_lock": ("runout_brake1", "runout_brake2", "corner_brake"),
    "ees_stiffness": ("ees_stiffness_ratio",),
    "yaw_inertia": ("yaw_inertia_factor",),
}

#: Null databases: their seeds.
NULL_SEEDS = (901, 902, 903)


def entries(part: str = "main") -> list[dict[str, Any]]:
    """The battery: singles, pairs and nulls (``part`` "main"), a held-out part
    ("held_out", "held_out_2"), the run-out part ("runout", issue 36) or its held-out part
    ("held_out_3"), each entry with its seed.
    """
    out: list[dict[str, Any]] = []
    if part in ("runout", "held_out_3", "steer", "held_out_4"):
        singles, pairs, base = {"runout": (RUNOUT, RUNOUT_PAIRS, 600),
                                "held_out_3": (HELD_OUT_3, HELD_OUT_3_PAIRS, 650),
                                "steer": (STEER, STEER_PAIRS, 1000),
                                "held_out_4": (HELD_OUT_4, HELD_OUT_4_PAIRS, 1050)}[part]
        for i, law in enumerate(singles):
            out.append({"id": law.name, "kind": "single", "laws": [law.name], "seed": base + i})
        for i, (a, b) in enumerate(pairs):
            out.append({"id": f"{a}+{b}", "kind": "pair", "laws": [a, b], "seed": base + 25 + i})
        if part == "held_out_3":
            out.append({"id": "null5", "kind": "null", "laws": [], "seed": 905})
        if part == "held_out_4":
            out.append({"id": "null6", "kind": "null", "laws": [], "seed": 906})
        return out
    if part == "held_out_2":
        for i, law in enumerate(HELD_OUT_2):
            out.append({"id": law.name, "kind": "single", "laws": [law.name], "seed": 800 + i})
        for i, (a, b) in enumerate(HELD_OUT_2_PAIRS):
            out.append({"id": f"{a}+{b}", "kind": "pair", "laws": [a, b], "seed": 850 + i})
        out.append({"id": "null4", "kind": "null", "laws": [], "seed": 904})
        return out
    if part == "held_out":
        for i, law in enumerate(HELD_OUT):
            out.append({"id": law.name, "kind": "single", "laws": [law.name], "seed": 700 + i})
        for i, (a, b) in enumerate(HELD_OUT_PAIRS):
            out.append({"id": f"{a}+{b}", "kind": "pair", "laws": [a, b], "seed": 750 + i})
        return out
    for i, law in enumerate(SINGLES):
        out.append({"id": law.name, "kind": "single", "laws": [law.name], "seed": 100 + 7 * i})
    for i, (a, b) in enumerate(PAIRS):
        out.append({"id": f"{a}+{b}", "kind": "pair", "laws": [a, b], "seed": 500 + 11 * i})
    for i, seed in enumerate(NULL_SEEDS):
        out.append({"id": f"null{i + 1}", "kind": "null", "laws": [], "seed": seed})
    return out


def diagnose_options(quick: bool) -> dict[str, Any]:
    """Keyword arguments of the blind diagnosis (those its signature accepts)."""
    from vfs.diagnosis.diagnose import diagnose

    opts: dict[str, Any] = {"laws": "all", "worst": 0}
    if quick:
        opts.update(folds=3, grid_points=5, zoom_rounds=2, n_boot=500)
    accepted = set(inspect.signature(diagnose).parameters)
    try:  # the settings of the spec (diagnose(db, spec=None, **settings))
        import dataclasses

        from vfs.diagnosis.diagnose_spec import DiagnoseSpec

        accepted |= {f.name for f in dataclasses.fields(DiagnoseSpec)}
    except ImportError:
        pass
    return {k: v for k, v in opts.items() if k in accepted}


def first_sentence(verdict: Sequence[str] | str) -> str:
    """First sentence of the verdict."""
    text = verdict if isinstance(verdict, str) else " ".join(verdict)
    text = text.strip()
    for stop in (". ", ".\n"):
        if stop in text:
            return text[:text.index(stop) + 1]
    return text


def claims_of(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The final claims of a diagnosis summary (``summary_dict``): library effects of
    ``significant`` with their fitted parameters, laws of ``claimed_laws`` with the law.
    """
    out: list[dict[str, Any]] = []
    cands = {c["name"]: c for c in summary.get("candidates", [])}
    for name in summary.get("significant", []):
        c = cands.get(name, {})
        out.append({"kind": "effect", "name": name, "channels": list(EFFECT_CHANNELS.get(
            name, ())), "fitted": c.get("fitted", [])})
    laws = [f for f in summary.get("laws", []) if f.get("status") == "claimed"
            or f.get("significant")]
    for entry in summary.get("claimed_laws", []):
        key = entry if isinstance(entry, str) else entry.get("name", entry.get("channel"))
        f = next((f for f in laws if key in (f["channel"], f["law"].get("name"))), None)
        if f is None:
            continue
        laws.remove(f)
        out.append({"kind": "law", "name": f["law"].get("name", f["channel"]),
                    "channel": f["channel"], "feature": f["law"].get("feature"),
                    "text": f.get("text", ""), "law": f["law"]})
    return out


def matches(claim: Mapping[str, Any], law: HiddenLaw) -> bool:
    """Whether a claim names the hidden law's physics (module docstring)."""
    if claim["kind"] == "law":
        return claim["channel"] == law.channel and claim["feature"] in law.accepted_features()
    return law.channel in claim["channels"]


def leading_claim(claims: Sequence[Mapping[str, Any]], sentence: str) -> int | None:
    """Index of the claim the first sentence names first (None: it names none)."""
    best: tuple[int, int] | None = None
    for i, c in enumerate(claims):
        keys = [c["name"]] + ([c["channel"]] if c["kind"] == "law" else [])
        pos = [sentence.find(k) for k in keys if k and sentence.find(k) >= 0]
        if pos and (best is None or min(pos) < best[0]):
            best = (min(pos), i)
    return None if best is None else best[1]


def _cv_reduction(sim: Any, effects: Sequence[Any], folds: Sequence[np.ndarray],
                  base: np.ndarray) -> float:
    from vfs.diagnosis.calibrate import FitSpace, cross_validate, rmse_reduction

    if not effects:
        return 0.0
    cv = cross_validate(sim, FitSpace.of(list(effects), "primary"), folds)
    return float(rmse_reduction(cv.errors, base))


def claimed_effects(claims: Iterable[Mapping[str, Any]]) -> list[Any]:
    """Effect instances of the claims (library effects at their fitted parameters)."""
    from vfs.effects.base import get_effect
    from vfs.effects.learned import law_effect_class

    out = []
    for c in claims:
        if c["kind"] == "effect":
            fitted = next((f for f in c["fitted"] if f.get("name") == c["name"]), None)
            cls = get_effect(c["name"])
            out.append(cls(**fitted["parameters"]) if fitted else cls())
        else:
            out.append(law_effect_class(c["law"])())
    return out


def run_entry(entry: Mapping[str, Any], cases: int, quick: bool) -> dict[str, Any]:
    """Generate, diagnose and judge one battery entry; a JSON-ready record."""
    from vfs.diagnosis.calibrate import CalibrationData, VariantSimulator, kfold_indices
    from vfs.diagnosis.diagnose import diagnose, summary_dict
    from vfs.errors import ParameterError
    from vfs.scenarios.generator import generate_database

    laws = [law_by_name(n) for n in entry["laws"]]
    hidden = [hidden_effect(law) for law in laws]
    seed = int(entry["seed"])
    for attempt in range(4):
        # the generator draws 2 % more scenes than cases; a law that makes more of them
        # unusable (over-deep penetration) needs another seed or a few cases fewer
        try:
            db, _ = generate_database("default", n_cases=cases, seed=seed, hidden=hidden)
            break
        except ParameterError:
            if attempt == 3:
                raise
            seed, cases = seed + 1000, int(cases * 0.92)
    opts = diagnose_options(quick)
    t0, c0 = time.perf_counter(), time.process_time()
    diag = diagnose(db, **opts)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    summary = summary_dict(diag)
    claims = claims_of(summary)
    sentence = first_sentence(summary["verdict"])
    # the truth's and the claimed answer's CV reductions, same folds and machinery
    data = CalibrationData.from_database(db)
    sim = VariantSimulator(data)
    folds = kfold_indices(data.n, int(opts.get("folds", 5)), int(opts.get("seed", 0)))
    base = data.case_errors(sim.residuals([()])[0])
    t1 = time.perf_counter()
    truth_red = _cv_reduction(sim, hidden, folds, base)
    claimed_red = _cv_reduction(sim, claimed_effects(claims), folds, base)
    record = {
        "id": entry["id"], "kind": entry["kind"], "hidden": entry["laws"],
        "hidden_text": [law.text for law in laws], "seed": seed, "cases": data.n,
        "settings": {k: v for k, v in opts.items()},
        "first_sentence": sentence,
        "claims": [{k: v for k, v in c.items() if k in ("kind", "name", "channel", "feature",
                                                          "text")} for c in claims],
        "laws_tried": [{"channel": f["channel"], "feature": f["law"].get("feature"),
                        "status": f.get("status"),
                        "outcome": (f.get("outcome_reduction") or {}).get("estimate")}
                       for f in summary.get("laws", [])],
        "ledger": [{"action": st["action"], "candidate": st["candidate"],
                    "cv_rmse": st["cv_rmse"]} for st in summary.get("steps", [])],
        "truth_reduction": truth_red, "claimed_reduction": claimed_red,
        "share_of_truth": claimed_red / truth_red if truth_red > 0 else None,
        "diagnose_wall_s": round(wall, 1), "diagnose_cpu_s": round(cpu, 1),
        "reference_s": round(time.perf_counter() - t1, 1),
    }
    return judge(record)


def judge(record: dict[str, Any]) -> dict[str, Any]:
    """The record with the judgement (module docstring): ``leading`` (the claim the
    first sentence names first; None if it names none), ``first_right`` (a null: no
    claim), ``all_named``, ``absent_claimed``.
    """
    laws = [law_by_name(n) for n in record["hidden"]]
    claims = [{**c, "channels": list(EFFECT_CHANNELS.get(c["name"], ()))}
              if c["kind"] == "effect" else c for c in record["claims"]]
    lead = leading_claim(claims, record["first_sentence"])
    matched = [[matches(c, law) for law in laws] for c in claims]
    out = dict(record)
    out["leading"] = claims[lead]["name"] if lead is not None else None
    out["first_right"] = (bool(laws) and lead is not None and any(matched[lead])
                          if laws else not claims)
    out["all_named"] = all(any(m[j] for m in matched) for j in range(len(laws)))
    out["absent_claimed"] = [c["name"] for c, m in zip(claims, matched, strict=True)
                             if not any(m)]
    return out


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


def table(records: Sequence[Mapping[str, Any]]) -> str:
    """Markdown table of the records and the counts against the targets."""
    lines = ["| entry | hidden | truth CV red. | first sentence names | right | claimed | "
             "absent claimed | claimed red. (share of truth) | diagnose wall (CPU) [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        claimed = ", ".join(c["name"] + (f" ({c['channel']} ~ {c['feature']})"
                                         if c["kind"] == "law" else "") for c in r["claims"])
        lines.append(
            f"| {r['id']} | {'; '.join(r['hidden_text']) or 'nothing'} | "
            f"{_pct(r['truth_reduction']) if r['hidden'] else '-'} | {r['leading'] or 'nothing'} | "
            f"{'yes' if r['first_right'] else '**no**'} | {claimed or '-'} | "
            f"{', '.join(r['absent_claimed']) or '-'} | {_pct(r['claimed_reduction'])} "
            f"({_pct(r['share_of_truth'])}) | {r['diagnose_wall_s']:.0f} "
            f"({r['diagnose_cpu_s']:.0f}) |")
    singles = [r for r in records if r["kind"] == "single"]
    pairs = [r for r in records if r["kind"] == "pair"]
    nulls = [r for r in records if r["kind"] == "null"]
    shares = [r["share_of_truth"] for r in records if r["share_of_truth"] is not None]
    lines += [
        "",
        f"- first sentence right: {sum(r['first_right'] for r in singles)} of {len(singles)} "
        "singles (target >= 13 of 14)",
        f"- hidden law claimed anywhere (not necessarily first): "
        f"{sum(r['all_named'] for r in singles)} of {len(singles)} singles",
        f"- both named: {sum(r['all_named'] for r in pairs)} of {len(pairs)} pairs "
        "(target >= 3 of 4)",
        f"- nulls claiming nothing: {sum(not r['claims'] for r in nulls)} of {len(nulls)}",
        f"- entries with an absent effect or law claimed: "
        f"{sum(bool(r['absent_claimed']) for r in records)} of {len(records)} (target 0)",
        f"- claimed answer >= 80 % of the truth's reduction: "
        f"{sum(s >= 0.8 for s in shares)} of {len(shares)}",
        f"- diagnose wall time: median {np.median([r['diagnose_wall_s'] for r in records]):.0f} s"
        if records else "",
    ]
    return "\n".join(lines) + "\n"


def _run(args: tuple[Mapping[str, Any], int, bool]) -> dict[str, Any]:
    from vfs.blas import single_threaded_blas

    with single_threaded_blas():  # one BLAS thread per job, as the command line runs
        return run_entry(*args)


def main(argv: Sequence[str] | None = None) -> None:
    """Run the battery (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="battery_out", help="output folder")
    ap.add_argument("--cases", type=int, default=400, help="cases per database")
    ap.add_argument("--scale", type=float, default=1.0, help="factor on --cases")
    ap.add_argument("--quick", action="store_true", help="quicker diagnose settings")
    ap.add_argument("--jobs", type=int, default=1, help="databases in parallel")
    ap.add_argument("--only", default="", help="comma-separated entry ids")
    ap.add_argument("--held-out", action="store_true", help="run the held-out part only")
    ap.add_argument("--held-out-2", action="store_true",
                    help="run the second held-out part only")
    ap.add_argument("--runout", action="store_true",
                    help="run the run-out part only (issue 36)")
    ap.add_argument("--held-out-3", action="store_true",
                    help="run the run-out part's held-out laws only")
    ap.add_argument("--steer", action="store_true",
                    help="run the run-out steer part only (issue 36)")
    ap.add_argument("--held-out-4", action="store_true",
                    help="run the steer part's held-out law and its null only")
    ap.add_argument("--table-only", action="store_true", help="rewrite battery.md only")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    part = ("held_out_4" if a.held_out_4 else "steer" if a.steer else
            "held_out_3" if a.held_out_3 else "runout" if a.runout else "held_out_2"
            if a.held_out_2 else "held_out" if a.held_out else "main")
    stem = "battery" if part == "main" else f"battery_{part}"
    jsonl = out / f"{stem}.jsonl"
    done = {}
    if jsonl.exists():
        for line in jsonl.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[r["id"]] = r
    todo = [e for e in entries(part) if e["id"] not in done
            and (not a.only or e["id"] in a.only.split(","))]
    if a.only:  # in the order given
        rank = {name: i for i, name in enumerate(a.only.split(","))}
        todo.sort(key=lambda e: rank[e["id"]])
    cases = max(20, round(a.cases * a.scale))
    if not a.table_only and todo:
        work = [(e, cases, a.quick) for e in todo]
        if a.jobs > 1:
            with ProcessPoolExecutor(a.jobs) as pool:
                futures = {pool.submit(_run, w): w[0]["id"] for w in work}
                for fut in as_completed(futures):
                    try:
                        _append(jsonl, fut.result(), done)
                    except Exception as exc:  # one database failing does not stop the rest
                        print(f"{futures[fut]}: failed: {exc}", flush=True)
        else:
            for w in work:
                _append(jsonl, _run(w), done)
    order = [e["id"] for e in entries(part)]
    records = [judge(done[i]) for i in order if i in done]
    md = out / f"{stem}.md"
    md.write_text(table(records))
    print(md.read_text())


def _append(path: Path, record: dict[str, Any], done: dict[str, Any]) -> None:
    with path.open("a") as f:
        f.write(json.dumps(record, default=float) + "\n")
    done[record["id"]] = record
    print(f"{record['id']}: {record['first_sentence']} ({record['diagnose_wall_s']} s)",
          flush=True)


if __name__ == "__main__":
    main()
