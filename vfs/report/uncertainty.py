"""Reports of ``vfs uncertainty``, ``vfs sensitivity`` and ``vfs reconstruct``.

Tables (Parquet and CSV), a JSON summary, Markdown and HTML reports and
figures, written atomically (temporary file, then rename) into an output
folder.  matplotlib is imported lazily by the figure functions only
(:func:`vfs.report.figures.new_figure`, no pyplot); the text is rendered by
:mod:`vfs.report.render`; the physics modules never import this one.  Speeds are shown in km/h,
angles in degrees; the tables keep SI units.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from vfs.atomic import write_json, write_table
from vfs.report.figures import new_figure, save_figure
from vfs.report.provenance import with_provenance
from vfs.report.references import cite
from vfs.report.render import (
    Block,
    BulletList,
    Figure,
    Heading,
    Note,
    Paragraph,
    Report,
    Table,
    write_report,
)
from vfs.uncertainty import (
    DISPLAY_UNITS,
    INPUTS_BY_NAME,
    OUTCOMES_BY_NAME,
    UncertaintyResult,
    band_summary,
)
from vfs.units import KMH_PER_MS

#: Colours of the nominal impact types.
TYPE_COLORS = {"full": "#1f4e9c", "sliding": "#e6b800", "none": "#9e9e9e"}
#: Outcomes of the overview figure of the sensitivity report.
OVERVIEW_OUTCOMES: tuple[str, ...] = ("delta_v1", "ees1", "runout_distance1", "sliding")


def _horizontal() -> dict[str, Any]:
    """Keyword of a horizontal box plot (``orientation`` since matplotlib 3.10)."""
    import matplotlib

    major, minor = (int(p) for p in matplotlib.__version__.split(".")[:2])
    return {"orientation": "horizontal"} if (major, minor) >= (3, 10) else {"vert": False}


def _save(fig: Any, path: Path) -> Path:
    return save_figure(fig, path, dpi=110, tight=True)


def _tables(folder: Path, tables: dict[str, pd.DataFrame], parquet: Sequence[str],
            files: dict[str, Path]) -> None:
    for name, df in tables.items():
        files[name] = write_table(folder / f"{name}.csv", df)
        if name in parquet:
            files[f"{name}_parquet"] = write_table(folder / f"{name}.parquet", df)


def _report(folder: Path, blocks: Sequence[object], title: str, files: dict[str, Path]) -> None:
    files.update(write_report(folder, Report(title, tuple(cast("Block", b) for b in blocks))))


def _display(outcome: str) -> tuple[str, float]:
    o = OUTCOMES_BY_NAME[outcome]
    return DISPLAY_UNITS[o.quantity]


def _fmt(v: Any, digits: int = 1) -> str:
    if v is None:
        return "-"
    x = float(v)
    return "-" if math.isnan(x) else f"{x:.{digits}f}"


def _pct(v: Any) -> str:
    x = float(v)
    return "-" if math.isnan(x) else f"{100.0 * x:.0f} %"


# ----------------------------------------------------------------------------
# Monte-Carlo uncertainty
# ----------------------------------------------------------------------------


def plot_relative_half_widths(bands: pd.DataFrame, path: Path) -> Path:
    """Box plots of the relative half-width (the +- % of the Collision Calculation Uncertainty
    paper) per ratio outcome, full and sliding nominal impacts side by side.
    """
    data = bands[bands["kind"] == "ratio"]
    outcomes = list(dict.fromkeys(data["outcome"]))
    fig = new_figure((8.5, 0.42 * len(outcomes) + 1.6))
    ax = fig.subplots()
    for k, group in enumerate(("full", "sliding")):
        vals = [100.0 * data[(data["outcome"] == o) & (data["nominal_type"] == group)]
                ["rel_half_width"].dropna().to_numpy() for o in outcomes]
        pos = np.arange(len(outcomes)) + (k - 0.5) * 0.36
        keep = [i for i, v in enumerate(vals) if v.size]
        if keep:
            bp = ax.boxplot([vals[i] for i in keep], positions=pos[keep], widths=0.32,
                            patch_artist=True, showfliers=False, **_horizontal())
            for patch in bp["boxes"]:
                patch.set_facecolor(TYPE_COLORS[group])
                patch.set_alpha(0.6)
        ax.plot([], [], "s", color=TYPE_COLORS[group], label=f"nominal {group}")
    ax.set_yticks(np.arange(len(outcomes)), [OUTCOMES_BY_NAME[o].label for o in outcomes])
    ax.invert_yaxis()
    ax.set_xlabel("relative half-width (p95 - p5) / (2 median) [%]")
    ax.axvline(13, color="grey", ls=":", lw=1,
               label="13 %: max. spread of back-calculated\nimpact speeds between methods")
    ax.axvline(28, color="grey", ls="--", lw=1, label="28 %: the same, road friction unknown")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_title("Monte-Carlo uncertainty per case (whiskers 1.5 IQR)", fontsize=10)
    return _save(fig, path)


def plot_case_bands(bands: pd.DataFrame, outcome: str, path: Path, max_cases: int = 40) -> Path:
    """5-95 % band, median and recorded value of one outcome for the first cases."""
    unit, factor = _display(outcome)
    data = bands[bands["outcome"] == outcome].head(max_cases)
    y = np.arange(len(data))
    fig = new_figure((7.5, 0.22 * len(data) + 1.5))
    ax = fig.subplots()
    colors = [TYPE_COLORS.get(t, "#777777") for t in data["nominal_type"]]
    ax.hlines(y, data["p5"] * factor, data["p95"] * factor, colors=colors, lw=3, alpha=0.7)
    ax.plot(data["p50"] * factor, y, "|", color="black", ms=8, label="median")
    ax.plot(data["recorded"] * factor, y, "x", color="#d62728", ms=5, label="reconstruction")
    ax.set_yticks(y, [str(c) for c in data["case_id"]], fontsize=7)
    ax.invert_yaxis()
    ax.set_ylabel("case")
    ax.set_xlabel(f"{OUTCOMES_BY_NAME[outcome].label} [{unit}]")
    for t in ("full", "sliding"):
        ax.plot([], [], "-", lw=3, color=TYPE_COLORS[t], label=f"5-95 % band ({t})")
    ax.legend(fontsize=7, loc="best")
    return _save(fig, path)


def plot_sliding_probability(cases: pd.DataFrame, path: Path) -> Path:
    """Histogram of the probability of a sliding impact, by nominal impact type."""
    fig = new_figure((6.5, 3.8))
    ax = fig.subplots()
    bins = np.linspace(0, 100, 21).tolist()
    for t in ("full", "sliding"):
        v = 100.0 * cases.loc[cases["nominal_type"] == t, "p_sliding"].to_numpy(float)
        if v.size:
            ax.hist(v, bins=bins, alpha=0.6, color=TYPE_COLORS[t], label=f"nominal {t}")
    ax.set_xlabel("probability of a sliding impact [%]")
    ax.set_ylabel("cases")
    ax.legend(fontsize=8)
    return _save(fig, path)


def _summary_display(summary: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for outcome, g in summary.groupby("outcome", sort=False):
        o = OUTCOMES_BY_NAME[outcome]
        unit, factor = DISPLAY_UNITS[o.quantity]
        row: dict[str, Any] = {"outcome": o.label}
        for group in ("all", "full", "sliding"):
            h = g[g["group"] == group]
            if h.empty:
                row[f"{group}: +-"] = "-"
                continue
            h = h.iloc[0]
            if o.kind == "ratio":
                row[f"{group}: +-"] = (f"{_pct(h['median_rel_half_width'])} "
                                       f"(p90 {_pct(h['p90_rel_half_width'])})")
            else:
                row[f"{group}: +-"] = f"{_fmt(h['median_half_width'] * factor)} {unit}"
        all_row = g[g["group"] == "all"]
        row["recorded in band"] = _pct(all_row["recorded_in_band"].iloc[0]) \
            if len(all_row) else "-"
        rows.append(row)
    return pd.DataFrame(rows)


#: Headline outcomes of the "In short" summary: label -> outcomes pooled (both vehicles).
SUMMARY_OUTCOMES: dict[str, tuple[str, ...]] = {
    "delta-v": ("delta_v1", "delta_v2"),
    "EES": ("ees1", "ees2"),
    "impact-to-rest distance": ("runout_distance1", "runout_distance2"),
}


def summary_blocks(result: UncertaintyResult, confidence: float = 0.95,
                   n_boot: int = 1000) -> list[Block]:
    """The one-screen summary: band widths with intervals, coverage, impact-type doubt.

    Per headline outcome (:data:`SUMMARY_OUTCOMES`, both vehicles pooled) the median
    relative half-width of the 5-95 % band with a percentile-bootstrap interval over
    the cases, and the share of vehicles whose reconstruction value lies inside the
    band with a Wilson interval; then the cases whose impact type is in doubt.
    """
    from vfs.analysis.intervals import wilson_interval
    from vfs.analysis.stats import bootstrap_ci

    bands, cases = result.bands, result.cases
    n_cases = len(cases)
    if n_cases == 0 or bands.empty:
        return []
    pct = int(round(100 * confidence))
    rng = np.random.default_rng(result.seed if result.seed is not None else 0)
    items = []
    for label, names in SUMMARY_OUTCOMES.items():
        sub = bands[bands["outcome"].isin(names)]
        if sub.empty:
            continue
        wide = sub.pivot_table(index="case_id", columns="outcome", values="rel_half_width",
                               dropna=False)
        values = wide.to_numpy(float)
        if not np.isfinite(values).any():
            continue
        est, lo, hi = bootstrap_ci(lambda x: float(np.nanmedian(x)), values, n_boot=n_boot,
                                   confidence=confidence, rng=rng, vectorized=False)
        p90 = float(np.nanquantile(values, 0.9))
        name = label[0].upper() + label[1:]
        text = (f"{name} within +-{100 * est:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] for "
                f"the median vehicle, 9 in 10 vehicles within +-{100 * p90:.0f} %")
        inband = sub["recorded_in_band"].to_numpy(float)
        inband = inband[np.isfinite(inband)]
        if inband.size:
            k = float(inband.sum())
            w_lo, w_hi = wilson_interval(k, inband.size, confidence)
            text += (f"; the reconstruction lies inside the band for "
                     f"{100 * k / inband.size:.0f} % [{100 * float(w_lo):.0f}, "
                     f"{100 * float(w_hi):.0f}] of {inband.size} vehicles")
        items.append(text + ".")
    p = cases["p_sliding"].to_numpy(float)
    doubt = int(np.sum((p > 0.1) & (p < 0.9)))
    d_lo, d_hi = wilson_interval(doubt, n_cases, confidence)
    items.append(f"Impact type in doubt (a sliding impact with a probability between 10 % and "
                 f"90 %) in {doubt} of {n_cases} cases ({100 * doubt / n_cases:.0f} % "
                 f"[{100 * float(d_lo):.0f}, {100 * float(d_hi):.0f}]); mean probability of a "
                 f"sliding impact {100 * float(np.nanmean(p)):.0f} %.")
    blocks: list[Block] = [
        Heading("In short", 2), BulletList(tuple(items)),
        Paragraph(f"+-: half the 5-95 % band relative to its median, {n_cases} cases x "
                  f"{result.n_samples} samples. Brackets: {pct} % confidence intervals "
                  "(bootstrap over cases for the half-widths, Wilson for shares). For "
                  "orientation only (not the same quantity), "
                  + cite("collision-uncertainty") + " finds that impact speeds "
                  "back-calculated by different methods for a documented crash test deviate "
                  "by at most +-13 %, up to +-28 % with unknown road friction. A band "
                  "that holds the reconstruction for about 90 % of the vehicles fits inputs "
                  "whose spread describes the real uncertainty; far fewer means the bands are "
                  "too narrow, nearly all that they may be wider than it."),
    ]
    if n_cases < 10:
        blocks.insert(1, Note(f"Only {n_cases} case(s): the intervals are wide and the "
                              "figures describe these cases, not a population.", "warning"))
    return blocks


def write_uncertainty_report(result: UncertaintyResult, out: str | os.PathLike[str], *,
                             plots: bool = True, database: Any = None,
                             database_reference: str | None = None) -> dict[str, Path]:
    """Write the tables, JSON summary, report and figures of a Monte-Carlo run.

    Files: ``bands.parquet``/``.csv`` (per case and outcome, SI),
    ``cases.parquet``/``.csv``, ``summary.csv`` (:func:`band_summary`),
    ``inputs.csv``, ``samples.parquet`` (when the result kept them),
    ``uncertainty.json``, ``report.md``, ``report.html`` and
    ``figures/*.png``.  With the ``database`` the cases came from (``database_reference``:
    how the user named it) the report says where its numbers come from
    (:func:`vfs.report.provenance.with_provenance`).

    Returns
    -------
    dict of str to Path
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    summary = band_summary(result.bands)
    _tables(folder, {"bands": result.bands, "cases": result.cases, "summary": summary,
                     "inputs": result.inputs}, ("bands", "cases"), files)
    if result.samples is not None:
        files["samples"] = folder / "samples.parquet"
        write_table(files["samples"], result.samples)
    n_cases = len(result.cases)
    files["json"] = write_json(folder / "uncertainty.json", {
        "n_cases": n_cases, "n_samples": result.n_samples, "seed": result.seed,
        "sampling": result.sampling,
        "model_runs": n_cases * result.n_samples, "seconds": result.seconds,
        "config": result.config.source,
        "runout_dt_s": result.config.runout_dt,
        "inputs": result.inputs.to_dict(orient="records"),
        "summary": summary.to_dict(orient="records"),
        "impact_types": result.cases["nominal_type"].value_counts().to_dict(),
        "mean_p_sliding": float(result.cases["p_sliding"].mean()),
    })
    figs = folder / "figures"
    if plots:
        files["fig_rel_half_width"] = plot_relative_half_widths(
            result.bands, figs / "relative_half_width.png")
        files["fig_bands_delta_v1"] = plot_case_bands(result.bands, "delta_v1",
                                                      figs / "bands_delta_v1.png")
        files["fig_bands_runout_distance1"] = plot_case_bands(
            result.bands, "runout_distance1", figs / "bands_runout_distance1.png")
        files["fig_p_sliding"] = plot_sliding_probability(result.cases,
                                                          figs / "p_sliding.png")
    inputs = result.inputs[["input", "label", "distribution", "varied", "database_sd_cases",
                            "clipped_share"]].copy()
    inputs["clipped_share"] = [_pct(v) for v in inputs["clipped_share"]]
    types = result.cases["nominal_type"].value_counts()
    blocks = [
        Heading("Monte-Carlo uncertainty of the collision outcomes", 1),
        *summary_blocks(result),
        Paragraph(f"{n_cases} cases x {result.n_samples} samples = "
                  f"{n_cases * result.n_samples} model runs (impact from the reconstruction's "
                  f"configuration, run-out at dt = {result.config.runout_dt * 1e3:g} ms) in "
                  f"{result.seconds:.1f} s, seed {result.seed}, sampling {result.sampling}. "
                  "Nominal impact types: "
                  + ", ".join(f"{k} {v}" for k, v in types.items())
                  + f". Configuration: {result.config.source}. Method and definitions: "
                  "docs/uncertainty.md (" + cite("collision-uncertainty") + ": back-calculated "
                  "impact speeds of a documented crash test within +-13 % between methods, "
                  "up to +-28 % with unknown road friction)."),
        Heading("Input distributions", 2),
        Table.from_frame(inputs, empty="(no rows)"),
        Heading("Band widths over the cases", 2),
        Paragraph("Per outcome the median over the cases of the relative half-width "
                  "(p95 - p5) / (2 median) and its 90th percentile (ratio outcomes), or the "
                  "median absolute half-width (coordinates and angles); groups by the nominal "
                  "impact type; last column: share of cases whose reconstruction value lies in "
                  "the 5-95 % band."),
        Table.from_frame(_summary_display(summary), empty="(no rows)"),
    ]
    if plots:
        blocks += [
            Figure("figures/relative_half_width.png",
                   "Relative half-width per case and outcome; dotted and dashed: the "
                   "Collision Calculation Uncertainty paper's largest deviation of "
                   "back-calculated impact speeds between methods, 13 % (a documented crash "
                   "test) and 28 % (unknown road friction), for orientation: not the same "
                   "quantity as these forward bands."),
            Figure("figures/bands_delta_v1.png",
                   "Delta-v 1: 5-95 % band, median and reconstruction of the first "
                   "cases."),
            Figure("figures/bands_runout_distance1.png",
                   "Impact-to-rest distance of vehicle 1."),
            Figure("figures/p_sliding.png",
                   "Probability of a sliding impact per case."),
        ]
    blocks += [
        Heading("Files", 2),
        BulletList((
            "`bands.parquet`/`.csv`: per case and outcome nominal, recorded, mean, sd, p5, "
            "p50, p95, half_width, rel_half_width (SI units)",
            "`cases.parquet`/`.csv`: impact-type probabilities per case",
            "`summary.csv`, `inputs.csv`, `uncertainty.json`",
            "`samples.parquet`: every run (with --save-samples)",
        )),
    ]
    if database is not None:
        blocks = with_provenance(blocks, database, database_reference)
    _report(folder, blocks, "Monte-Carlo uncertainty", files)
    return files


# ----------------------------------------------------------------------------
# Sensitivity
# ----------------------------------------------------------------------------


def _label(name: str) -> str:
    return "dummy" if name not in INPUTS_BY_NAME else INPUTS_BY_NAME[name].label


def _bars(ax: Any, table: pd.DataFrame, title: str) -> None:
    t = table.sort_values("rank")
    y = np.arange(len(t))
    st = t["st"].to_numpy(float)
    s1 = t["s1"].to_numpy(float)
    err = np.vstack([np.clip(st - t["st_low"].to_numpy(float), 0, None),
                     np.clip(t["st_high"].to_numpy(float) - st, 0, None)])
    ax.barh(y, np.nan_to_num(st), color="#9ecae1", label="total ST",
            xerr=np.nan_to_num(err), error_kw={"lw": 0.8, "capsize": 2})
    ax.barh(y, np.nan_to_num(np.clip(s1, 0, None)), height=0.45, color="#08519c",
            label="first order S1")
    ax.set_yticks(y, [_label(n) for n in t["input"]], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0, max(1.0, float(np.nanmax(np.r_[st, 0.0])) * 1.05))
    ax.set_title(title, fontsize=9)
    ax.tick_params(axis="x", labelsize=8)


def plot_sobol_ranking(result: Any, outcomes: Sequence[str], path: Path) -> Path:
    """Ranked horizontal bars of the mean Sobol indices, full and sliding impacts side by
    side, one row per outcome (bars: ST with its case-bootstrap interval; inner bars: S1).
    """
    d = len(result.names)
    fig = new_figure((10, (0.22 * d + 1.0) * len(outcomes)))
    axes = fig.subplots(len(outcomes), 2, squeeze=False)
    for r, outcome in enumerate(outcomes):
        for c, group in enumerate(("full", "sliding")):
            t = result.ranking(outcome, group)
            n = int(t["n_cases"].max()) if len(t) else 0
            _bars(axes[r, c], t, f"{OUTCOMES_BY_NAME[outcome].label}: nominal {group} "
                  f"({n} cases)")
    axes[0, 0].legend(fontsize=7, loc="lower right")
    return _save(fig, path)


def _ranking_display(result: Any, outcome: str, top: int) -> pd.DataFrame:
    rows = []
    for group in ("full", "sliding"):
        t = result.ranking(outcome, group).head(top)
        for _, r in t.iterrows():
            rows.append({"group": group, "rank": int(r["rank"]), "input": _label(r["input"]),
                         "ST": f"{_fmt(r['st'], 2)} [{_fmt(r['st_low'], 2)}, "
                               f"{_fmt(r['st_high'], 2)}]",
                         "S1": f"{_fmt(r['s1'], 2)} [{_fmt(r['s1_low'], 2)}, "
                               f"{_fmt(r['s1_high'], 2)}]",
                         "cases": int(r["n_cases"])})
    return pd.DataFrame(rows)


def _sums_display(result: Any) -> pd.DataFrame:
    g = result.groups
    rows = []
    for (group, outcome), h in g.groupby(["group", "outcome"], sort=False):
        dummy = h[h["input"] == "dummy"]
        rows.append({"group": group, "outcome": OUTCOMES_BY_NAME[outcome].label,
                     "sum S1": _fmt(h["s1"].sum(), 2), "sum ST": _fmt(h["st"].sum(), 2),
                     "dummy ST": _fmt(dummy["st"].iloc[0], 3) if len(dummy) else "-",
                     "cases": int(h["n_cases"].max())})
    return pd.DataFrame(rows)


def write_sensitivity_report(result: Any, out: str | os.PathLike[str], *, plots: bool = True,
                             top: int = 6) -> dict[str, Path]:
    """Write the Sobol tables, JSON summary, report and ranked bar figures.

    Files: ``per_case.parquet`` (every case, outcome and input), ``groups``
    (``.csv`` and ``.parquet``: mean indices per nominal impact type with
    case-bootstrap intervals and ranks), ``inputs.csv``, ``sensitivity.json``,
    ``report.md``, ``report.html``, ``figures/sobol_overview.png`` and
    ``figures/sobol_<outcome>.png``.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    files["per_case"] = folder / "per_case.parquet"
    write_table(files["per_case"], result.per_case)
    _tables(folder, {"groups": result.groups, "inputs": result.inputs}, ("groups",), files)
    outcomes = list(dict.fromkeys(result.groups["outcome"]))
    ranked = {g: {o: result.ranking(o, g)["input"].tolist() for o in outcomes}
              for g in ("all", "full", "sliding")}
    files["json"] = write_json(folder / "sensitivity.json", {
        "n_base": result.n_base, "n_runs": result.n_runs, "seed": result.seed,
        "seconds": result.seconds, "inputs": list(result.names),
        "n_cases": int(result.per_case["case_id"].nunique()),
        "ranking_by_total_index": ranked,
        "groups": result.groups.to_dict(orient="records"),
    })
    figs = folder / "figures"
    blocks = [
        Heading("Global sensitivity: Sobol indices", 1),
        Paragraph(f"{result.per_case['case_id'].nunique()} cases, {result.n_base} base "
                  f"samples, {len(result.names)} inputs (incl. the dummy) = {result.n_runs} model "
                  f"runs in {result.seconds:.1f} s, seed {result.seed}. First-order index S1 = "
                  "share of the outcome's variance due to the input alone (the main effect of "
                  "the functional ANOVA), total index ST = including all its interactions; "
                  "estimators of Saltelli (2010) and Jansen (1999), per case, then averaged over "
                  "the cases whose nominal impact is full or sliding (intervals: bootstrap over "
                  "cases). Answers the Momentum Based Impact Model paper's outlook (ANOVA of the "
                  "most sensitive impact "
                  "parameters). Details: docs/uncertainty.md."),
        Heading("Inputs", 2),
        Table.from_frame(result.inputs[["input", "label", "distribution"]], empty="(no rows)"),
    ]
    if plots:
        over = [o for o in OVERVIEW_OUTCOMES if o in outcomes] or outcomes[:4]
        files["fig_overview"] = plot_sobol_ranking(result, over, figs / "sobol_overview.png")
        blocks.append(Figure("figures/sobol_overview.png",
                             "Ranked Sobol indices, full (left) and sliding (right) "
                             "nominal impacts."))
    for outcome in outcomes:
        blocks += [Heading(f"{OUTCOMES_BY_NAME[outcome].label}", 2),
                   Table.from_frame(_ranking_display(result, outcome, top), empty="(no rows)")]
        if plots:
            files[f"fig_{outcome}"] = plot_sobol_ranking(result, [outcome],
                                                         figs / f"sobol_{outcome}.png")
            blocks.append(Figure(f"figures/sobol_{outcome}.png",
                                 f"Sobol indices of {OUTCOMES_BY_NAME[outcome].label}."))
    blocks += [
        Heading("Checks", 2),
        Paragraph("Sum of the mean first-order indices (<= 1 up to estimation noise), of "
                  "the total indices (>= 1 with interactions) and the total index of the dummy "
                  "input, which enters nothing (must be ~0)."),
        Table.from_frame(_sums_display(result), empty="(no rows)"),
    ]
    _report(folder, blocks, "Sobol sensitivity", files)
    return files


# ----------------------------------------------------------------------------
# Reconstruction
# ----------------------------------------------------------------------------


def plot_reconstruction_speeds(rec: Any, path: Path, truth: Sequence[float] | None = None
                               ) -> Path:
    """Feasible impact speeds (speed 1 against speed 2) coloured by the road friction,
    as the Collision Calculation Uncertainty paper's Figure 11, with the optimum and the
    database's speeds.
    """
    k = DISPLAY_UNITS["speed"][1]
    f = rec.feasible
    fig = new_figure((6.5, 5.2))
    ax = fig.subplots()
    if len(f):
        sc = ax.scatter(f["speed1"] * k, f["speed2"] * k, c=f["road_friction"], s=6,
                        cmap="viridis", alpha=0.6)
        fig.colorbar(sc, ax=ax, label="road friction [-]")
    b = rec.band.set_index("quantity")
    ax.plot(b.loc["speed1", "optimum"] * k, b.loc["speed2", "optimum"] * k, "*", ms=14,
            color="#d62728", label="optimum")
    ax.plot(b.loc["speed1", "nominal"] * k, b.loc["speed2", "nominal"] * k, "s", ms=7,
            mfc="none", color="black", label="database")
    if truth is not None:
        ax.plot(truth[0] * k, truth[1] * k, "P", ms=10, color="#ff7f0e", label="truth")
    for name, axis in (("speed1", ax.axvline), ("speed2", ax.axhline)):
        for q in ("p5", "p95"):
            if np.isfinite(b.loc[name, q]):
                axis(b.loc[name, q] * k, color="grey", ls=":", lw=1)
    ax.set_xlabel("impact speed 1 [km/h]")
    ax.set_ylabel("impact speed 2 [km/h]")
    ax.set_title(f"case {rec.case_id}: feasible set ({len(f)} samples), 5-95 % dotted",
                 fontsize=9)
    ax.legend(fontsize=8, loc="best")
    return _save(fig, path)


def plot_reconstruction_rest(rec: Any, path: Path) -> Path:
    """Rest positions of the feasible set against the observed ones (circles: 2 sigma)."""
    from matplotlib.patches import Circle

    f = rec.feasible
    obs = dict(zip(rec.observations.names, rec.observations.observed, strict=True))
    sig = dict(zip(rec.observations.names, rec.observations.sigma, strict=True))
    fig = new_figure((6.5, 5.2))
    ax = fig.subplots()
    for i, color in ((1, "#1f77b4"), (2, "#d62728")):
        if len(f):
            ax.plot(f[f"rest_x{i}"], f[f"rest_y{i}"], ".", ms=2, alpha=0.3, color=color,
                    label=f"feasible rest {i}")
        if f"rest_x{i}" in obs:
            x, y = obs[f"rest_x{i}"], obs[f"rest_y{i}"]
            ax.plot(x, y, "x", ms=10, color="black")
            r = 2.0 * sig[f"rest_x{i}"]
            ax.add_patch(Circle((x, y), r, fill=False, color=color, ls="--"))
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"case {rec.case_id}: observed rest positions (x, 2 sigma circles)",
                 fontsize=9)
    ax.legend(fontsize=8, loc="best")
    return _save(fig, path)


def _band_display(rec: Any) -> pd.DataFrame:
    rows = []
    for _, r in rec.band.iterrows():
        name = r["quantity"]
        if name in INPUTS_BY_NAME:
            quantity = INPUTS_BY_NAME[name].quantity
            label = INPUTS_BY_NAME[name].label
        else:
            quantity = OUTCOMES_BY_NAME[name].quantity
            label = OUTCOMES_BY_NAME[name].label
        unit, k = {"speed": ("km/h", KMH_PER_MS), "angle": ("deg", 180 / math.pi),
                   "time": ("ms", 1e3)}.get(quantity, ("", 1.0))
        if quantity == "mass":
            unit = "kg"
        elif quantity == "length":
            unit = "m"
        rows.append({"quantity": label, "unit": unit or "-",
                     "database": _fmt(r["nominal"] * k, 2), "optimum": _fmt(r["optimum"] * k, 2),
                     "p5": _fmt(r["p5"] * k, 2), "median": _fmt(r["p50"] * k, 2),
                     "p95": _fmt(r["p95"] * k, 2), "min": _fmt(r["min"] * k, 2),
                     "max": _fmt(r["max"] * k, 2)})
    return pd.DataFrame(rows)


def write_reconstruct_report(rec: Any, out: str | os.PathLike[str], *, plots: bool = True,
                             truth: Sequence[float] | None = None) -> dict[str, Path]:
    """Write the feasible set, the band, the optimum, report and figures of one case.

    Files: ``samples.parquet`` (Monte-Carlo stage), ``feasible.parquet`` (the
    feasible set), ``band.csv``, ``observations.csv``, ``reconstruct.json``
    (optimum with its scaled residuals, statistics), ``report.md``,
    ``report.html``, ``figures/speeds.png``, ``figures/rest_positions.png``.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    files["samples"] = folder / "samples.parquet"
    write_table(files["samples"], rec.samples)
    files["feasible"] = folder / "feasible.parquet"
    write_table(files["feasible"], rec.feasible)
    obs = rec.observations.table()
    _tables(folder, {"band": rec.band, "observations": obs}, (), files)
    o = rec.optimum
    files["json"] = write_json(folder / "reconstruct.json", {
        "case_id": rec.case_id, "stats": rec.stats,
        "optimum": {"inputs": o.inputs, "outcomes": o.outcomes, "residuals": o.residuals,
                    "chi2": o.chi2, "objective": o.objective, "accepted": o.accepted,
                    "success": o.success, "message": o.message},
        "band": rec.band.to_dict(orient="records"),
        "observations": obs.to_dict(orient="records"),
        "settings": {"criterion": rec.settings.criterion, "k_sigma": rec.settings.k_sigma,
                     "chi2_level": rec.settings.chi2_level,
                     "speed1": rec.settings.speed1.describe(),
                     "speed2": rec.settings.speed2.describe()},
    })
    s = rec.stats
    obs_disp = obs.copy()
    scale = np.where(obs_disp["angular"], 180 / math.pi,
                     np.where(obs_disp["observation"].str.startswith("ees"), KMH_PER_MS, 1.0))
    obs_disp["observed"] = [_fmt(v, 2) for v in obs_disp["observed"] * scale]
    obs_disp["sigma"] = [_fmt(v, 2) for v in obs_disp["sigma"] * scale]
    obs_disp["unit"] = np.where(obs_disp["angular"], "deg",
                                np.where(obs["observation"].str.startswith("ees"), "km/h",
                                         "m"))
    obs_disp["optimum residual"] = [f"{o.residuals[n]:+.2f}" for n in obs["observation"]]
    blocks = [
        Heading(f"Reconstruction of case {rec.case_id}", 1),
        Paragraph(f"Unknowns: {', '.join(s['unknowns'])}; impact speed priors: "
                  f"{rec.settings.speed1.describe()} (1), {rec.settings.speed2.describe()} (2). "
                  f"Acceptance: {s['criterion']} (threshold {s['threshold']:.3g}) on the scaled "
                  "residuals (model - observed) / sigma. Method: docs/uncertainty.md (the "
                  "Collision Calculation Uncertainty paper's "
                  "Monte-Carlo acceptance, a local optimiser, chains exploring the feasible "
                  "set)."),
        Heading("Observations", 2),
        Table.from_frame(obs_disp[["observation", "observed", "sigma", "unit", "sd_source",
                                        "optimum residual"]], empty="(no rows)"),
        Heading("Feasible set", 2),
        Paragraph(f"Monte-Carlo stage: {s['n_prior_accepted']} of {s['n_prior']} prior "
                  f"samples accepted ({_pct(s['acceptance_rate'])}). Feasible set: "
                  f"{s['n_feasible']} samples ({s['n_chains']} chains, move rate "
                  f"{_fmt(s['move_rate'], 2)}, median drift "
                  + ", ".join(f"{k} {_fmt(v, 2)}" for k, v in s["drift"].items())
                  + f"); {s['n_model_runs']} model runs in {s['seconds']:.1f} s. Optimum: chi2 "
                  f"{o.chi2:.2f} ({'accepted' if o.accepted else 'not accepted'})."),
        Table.from_frame(_band_display(rec), empty="(no rows)"),
    ]
    if s["n_feasible"] == 0:
        blocks.append(Paragraph("No sample is consistent with the observations within the "
                                "tolerances: widen the tolerances or the speed prior, or check "
                                "the observations."))
    if plots:
        files["fig_speeds"] = plot_reconstruction_speeds(rec, folder / "figures" / "speeds.png",
                                                         truth)
        files["fig_rest"] = plot_reconstruction_rest(rec, folder / "figures" /
                                                     "rest_positions.png")
        blocks += [Figure("figures/speeds.png",
                          "Feasible impact speeds coloured by road friction (the Collision "
                          "Calculation Uncertainty paper, "
                          "Fig. 11)."),
                   Figure("figures/rest_positions.png",
                          "Rest positions of the feasible set.")]
    blocks += [Heading("Files", 2), BulletList((
        "`feasible.parquet`: the feasible set (inputs SI, outcomes, scaled residuals)",
        "`samples.parquet`: every Monte-Carlo sample with its residuals and acceptance",
        "`band.csv` (SI), `observations.csv`, `reconstruct.json` (optimum, statistics)"))]
    _report(folder, blocks, f"Reconstruction of case {rec.case_id}", files)
    return files


__all__ = [
    "SUMMARY_OUTCOMES", "plot_case_bands", "plot_reconstruction_rest", "plot_reconstruction_speeds",
    "plot_relative_half_widths", "plot_sliding_probability", "plot_sobol_ranking",
    "summary_blocks", "write_reconstruct_report", "write_sensitivity_report",
    "write_uncertainty_report",
]
