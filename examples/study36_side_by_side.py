"""The Momentum Based Impact Model paper's comparison on study36, seeds 0-4, under both
impact-parameter settings: the Table 1 rows and the impact-type/POI table of
docs/compare.md (Markdown).

    python examples/study36_side_by_side.py [--seeds 5] [--hidden structure_poi,...]
        [--out benchmarks/results/study36-side-by-side]

With ``--out DIR`` the tables are also written to ``DIR/printed.md`` and the numbers they
print, unrounded, to ``DIR/study36.json`` (the record tests/test_docs_figures.py binds the
page's figures to).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
from pathlib import Path

from vfs.analysis.compare import compare_database
from vfs.analysis.paper_reference import PAPER_TABLE1, table1_label
from vfs.scenarios.generator import generate_database

#: Table 1 of the paper (vfs.analysis.paper_reference, the one copy): n, mean
#: reconstruction, mean VFS, p, by the row label `vfs compare` uses.
PAPER = {table1_label(r.outcome, r.group): (r.n, r.mean_reconstruction, r.mean_vfs, r.p_value)
         for r in PAPER_TABLE1}
SETTINGS = (("default", "defaults"), ("reconstruction", "reconstruction"))


def fmtp(p: float) -> str:
    return "< 0.001" if p < 0.001 else f"{p:.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--hidden", help="hidden effects of the reconstructions (default: preset)")
    ap.add_argument("--out", type=Path, help="write printed.md and study36.json here")
    args = ap.parse_args()
    kw = {"hidden": tuple(args.hidden.split(","))} if args.hidden else {}
    runs = {}
    for seed in range(args.seeds):
        db, _ = generate_database("study36", seed=seed, **kw)
        for setting, _label in SETTINGS:
            runs[seed, setting] = compare_database(db, impact_parameters=setting)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        print_tables(runs, args.seeds)
    print(printed.getvalue(), end="")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "printed.md").write_text(printed.getvalue(), encoding="utf-8")
        record = {"seeds": args.seeds, "hidden": kw.get("hidden"),
                  "runs": [record_of(seed, setting, c) for (seed, setting), c in runs.items()]}
        (args.out / "study36.json").write_text(json.dumps(record, indent=1) + "\n",
                                               encoding="utf-8")


def record_of(seed: int, setting: str, c) -> dict:
    """The numbers of one comparison the tables print, unrounded (km/h, degrees, m)."""
    t = c.contingency.table
    poi = c.poi_distances.set_index("group")["mean"]
    return {
        "seed": seed, "setting": setting,
        "table1": [{"parameter": r.parameter, "n": int(r.n),
                    "mean_vfs": float(r.mean_vfs),
                    "mean_reconstruction": float(r.mean_reconstruction),
                    "difference": float(r.mean_vfs - r.mean_reconstruction),
                    "p_value": float(r.p_value)}
                   for r in c.table1.itertuples(index=False)],
        "contingency": {f"{a}->{b}": int(t.loc[a, b]) if a in t.index and b in t.columns
                        else 0 for a in ("full", "sliding") for b in ("full", "sliding")},
        "chi2_pvalue": float(c.contingency.chi2_pvalue),
        "poi_distance_m": {g: float(poi[g]) for g in poi.index},
    }


def print_tables(runs: dict, seeds: int) -> None:
    """The two Markdown tables of docs/compare.md."""
    print("| Table 1 row | paper: n, rec., VFS, p | setting | per seed: VFS - rec. (p) | "
          "significant (p < 0.05) | VFS higher |")
    print("|---|---|---|---|---|---|")
    for key, (n, r, v, p) in PAPER.items():
        for setting, label in SETTINGS:
            cells, sig, hi = [], 0, 0
            for seed in range(seeds):
                t1 = runs[seed, setting].table1.set_index("parameter").loc[key]
                d = t1["mean_vfs"] - t1["mean_reconstruction"]
                cells.append(f"{d:+.1f} ({fmtp(t1['p_value'])})")
                sig += t1["p_value"] < 0.05
                hi += d > 0
            first = (f"{n}, {r:.2f}, {v:.2f}, {p:.3f} (VFS {'higher' if v > r else 'lower'}, "
                     "n.s.)") if setting == "default" else ""
            print(f"| {key if setting == 'default' else ''} | {first} | {label} | "
                  f"{'; '.join(cells)} | {sig}/{seeds} | {hi}/{seeds} |")
    print()
    print("| seed | setting | full→full | full→sliding | sliding→full | sliding→sliding | "
          "chi² p | POI distance all / both full / both sliding / type changed [m] |")
    print("|---|---|---|---|---|---|---|---|")
    print("| paper | | 13 | 17 (changed) | | 6 | ≤ 0.01 | 0.190 / 0.167 / 0.148 / 0.222 |")
    for (seed, setting), c in runs.items():
        t = c.contingency.table
        poi = c.poi_distances.set_index("group")["mean"]
        cell = " / ".join(f"{poi.get(g, float('nan')):.3f}" for g in
                          ("all", "both full", "both sliding", "type changed"))
        sf = int(t.loc["sliding", "full"]) if "full" in t.columns else 0
        label = dict(SETTINGS)[setting]
        print(f"| {seed} | {label} | {int(t.loc['full', 'full'])} | "
              f"{int(t.loc['full', 'sliding'])} | {sf} | {int(t.loc['sliding', 'sliding'])} | "
              f"{c.contingency.chi2_pvalue:.4f} | {cell} |")


if __name__ == "__main__":
    main()
