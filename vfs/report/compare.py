"""Report of ``vfs compare``: tables (CSV/Parquet/JSON), Markdown, HTML and figures.

The figures follow the Momentum Based Impact Model paper so that a reader of the paper
recognises them: Figure 4 (impact types with the flows from full to sliding),
Figure 5 (POIs in vehicle coordinates: reconstruction circles, VFS
triangles), Figure 6 (boxplots per impact type) and Table 1 (paired t-tests
in km/h and degrees); Bland-Altman plots, model-vs-reconstruction scatter
plots and top views of the worst cases are added.  matplotlib is imported
lazily by the figure functions only (:func:`vfs.report.figures.new_figure`,
no pyplot); the text is rendered by :mod:`vfs.report.render`; every file is
written atomically.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from vfs.analysis.compare import (
    GROUP_ALL,
    GROUP_CHANGED,
    GROUP_FULL,
    GROUP_SLIDING,
    GROUPS,
    IMPACT_CATEGORIES,
    NO_IMPACT_CATEGORY,
    OUTCOMES_BY_NAME,
    TABLE1_OUTCOMES,
    Comparison,
)
from vfs.analysis.staged_tests import staged_summary
from vfs.atomic import write_atomic, write_table, write_text
from vfs.report.case_pages import case_link, write_comparison_case_pages
from vfs.report.figures import new_figure, save_figure
from vfs.report.provenance import with_provenance
from vfs.report.references import cite
from vfs.report.render import (
    Block,
    BulletList,
    Figure,
    Heading,
    Paragraph,
    Report,
    Table,
    write_report,
)
from vfs.report.staged_tests import staged_blocks
from vfs.units import KMH_PER_MS

if TYPE_CHECKING:  # pragma: no cover
    from vfs.database import Database

#: Colours of the Momentum Based Impact Model paper's Figure 5: reconstruction full / sliding
# (circles),
#: VFS full / sliding (triangles).
REC_COLORS = {"full": "#1f4e9c", "sliding": "#2ca02c"}
VFS_COLORS = {"full": "#d62728", "sliding": "#e6b800"}
#: Colours of the impact-type categories in Figure 4.
TYPE_COLORS = {"full": "#1f4e9c", "sliding": "#e6b800", NO_IMPACT_CATEGORY: "#9e9e9e"}
#: Colours of the groups in the scatter and Bland-Altman plots.
GROUP_COLORS = {GROUP_FULL: "#1f4e9c", GROUP_SLIDING: "#e6b800", GROUP_CHANGED: "#d62728"}
#: Outcomes shown in the Bland-Altman and scatter figures (those present).
FIGURE_OUTCOMES: tuple[str, ...] = (
    "delta_v", "ees", "velocity_angle_change", "post_speed", "runout_displacement", "pdof",
)


# ----------------------------------------------------------------------------
# Formatting
# ----------------------------------------------------------------------------


def _num(value: Any, digits: int = 2) -> str:
    """A number for a report table; '-' for NaN/None."""
    if value is None:
        return "-"
    v = float(value)
    if math.isnan(v):
        return "-"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.{digits}f}"


def _p_eq(value: Any) -> str:
    """'p = 0.123' or 'p < 0.001' for titles."""
    text = _p(value)
    return f"p {text}" if text.startswith("<") else f"p = {text}"


def _p(value: Any) -> str:
    """A p-value: three decimals, '< 0.001' below."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    v = float(value)
    if math.isnan(v):
        return "-"
    return "< 0.001" if v < 0.001 else f"{v:.3f}"



# ----------------------------------------------------------------------------
# Figures
# ----------------------------------------------------------------------------


def plot_impact_types(comparison: Comparison, path: str | os.PathLike[str]) -> None:
    """The Momentum Based Impact Model paper's Figure 4: impact types in reconstruction and VFS
    with the flows.

    Two stacked columns (reconstruction left, VFS right) with the counts per
    impact type; bands connect the categories of the same cases; labelled
    boxes on the bands count the changes (e.g. full -> sliding).
    """
    from matplotlib.patches import Rectangle

    c = comparison.contingency
    cats = list(c.categories)
    counts = c.table.to_numpy()
    left = counts.sum(axis=1)
    right = counts.sum(axis=0)
    fig = new_figure((7.5, 5.5))
    ax = fig.subplots()
    width, x0, x1 = 0.18, 0.0, 1.0
    gap = max(0.02 * max(c.n, 1), 0.3)

    def stack(totals: np.ndarray) -> np.ndarray:
        starts = np.zeros(len(totals))
        pos = 0.0
        for k, t in enumerate(totals):
            starts[k] = pos
            pos += t + (gap if t else 0.0)
        return starts

    ls, rs = stack(left), stack(right)
    for k, cat in enumerate(cats):
        color = TYPE_COLORS.get(cat, "#777777")
        for x, start, total in ((x0, ls[k], left[k]), (x1, rs[k], right[k])):
            if total:
                ax.add_patch(Rectangle((x - width / 2, start), width, total, color=color,
                                       ec="black", lw=0.8))
                ax.text(x, start + total / 2, f"{cat}\n{int(total)}", ha="center",
                        va="center", fontsize=10, color="white" if cat != "sliding" else "black",
                        weight="bold")
    # bands: within the source category the flows are stacked by target
    lpos, rpos = ls.copy(), rs.copy()
    t = np.linspace(0.0, 1.0, 60)
    smooth = 3 * t**2 - 2 * t**3
    xs = (x0 + width / 2) + (x1 - x0 - width) * t
    for i, src in enumerate(cats):
        for j, dst in enumerate(cats):
            n = counts[i, j]
            if not n:
                continue
            y_lo = lpos[i] + (rpos[j] - lpos[i]) * smooth
            ax.fill_between(xs, y_lo, y_lo + n, color=TYPE_COLORS.get(src, "#777777"),
                            alpha=0.35 if i == j else 0.55, lw=0)
            mid = len(t) // 2
            if i != j:
                # a change: its label on the band near the side it leaves (downward flows
                # near the left, upward ones near the right), so that crossing bands'
                # labels never meet, on a white box above the bands
                k = len(t) // 5 if i < j else len(t) - 1 - len(t) // 5
                ax.text(xs[k], y_lo[k] + n / 2, f"{src} \u2192 {dst}: {int(n)}", fontsize=9,
                        va="center", ha="center", weight="bold", zorder=5,
                        bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.4",
                              "alpha": 0.9})
            else:
                ax.text(xs[mid], y_lo[mid] + n / 2, f"{int(n)}", fontsize=9, va="center",
                        ha="center")
            lpos[i] += n
            rpos[j] += n
    top = max(ls[-1] + left[-1] if len(cats) else 1.0, rs[-1] + right[-1] if len(cats) else 1.0)
    ax.set_xlim(-0.35, 1.35)
    ax.set_ylim(top + gap, -gap)  # first category on top
    ax.set_xticks([x0, x1], ["reconstruction", "VFS"])
    ax.set_yticks([])
    for side in ("left", "right", "top"):
        ax.spines[side].set_visible(False)
    ax.set_title(f"Impact types of {c.n} cases: chi-squared {_p_eq(c.chi2_pvalue)} (paper), "
                 f"McNemar {_p_eq(comparison.contingency_impacts.mcnemar_pvalue)}, "
                 f"kappa = {_num(c.kappa)}", fontsize=9)
    _save(fig, path)


def _poi_plot_coordinates(pairs: pd.DataFrame, prefix: str) -> tuple[np.ndarray, np.ndarray]:
    """POI relative to the front bumper centre [m] (x forward), lateral scaled to the
    median width so that every vehicle fits one outline.
    """
    x = pairs[f"{prefix}_poi_x"].to_numpy(float)
    y = pairs[f"{prefix}_poi_y"].to_numpy(float)
    front = pairs["cg_to_front"].to_numpy(float)
    width = pairs["width"].to_numpy(float)
    ref_width = np.nanmedian(width) if np.isfinite(width).any() else np.nan
    xf = np.where(np.isfinite(front), x - front, x)
    yf = np.where(np.isfinite(width) & np.isfinite(ref_width), y * ref_width / width, y)
    return xf, yf


def plot_poi_positions(comparison: Comparison, path: str | os.PathLike[str]) -> None:
    """The Momentum Based Impact Model paper's Figure 5: POIs in vehicle coordinates.

    Reconstruction POIs as circles (full blue, sliding green), VFS POIs as
    triangles (full red, sliding yellow), thin lines joining the two POIs of a
    vehicle; each vehicle in its own frame at its impact pose, x from the front
    bumper (forward positive), y to the left scaled to the median width, on the
    outline of a median vehicle.  Left: the whole vehicle; right: the front.
    """
    from matplotlib.patches import Rectangle

    pairs = comparison.pairs
    fig = new_figure((11, 4.8))
    axes = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1]})
    length = float(np.nanmedian(pairs["length"])) if pairs["length"].notna().any() else 4.5
    width = float(np.nanmedian(pairs["width"])) if pairs["width"].notna().any() else 1.8
    rx, ry = _poi_plot_coordinates(pairs, "reference")
    mx, my = _poi_plot_coordinates(pairs, "vfs")
    rtype = pairs["reference_type"].to_numpy(object)
    mtype = pairs["vfs_type"].to_numpy(object)
    for ax in axes:
        ax.add_patch(Rectangle((-length, -width / 2), length, width, fill=False, ec="black",
                               lw=1.2))
        ax.plot([0, 0], [-width / 2, width / 2], "k-", lw=3)  # front
        ax.plot(np.c_[rx, mx].T, np.c_[ry, my].T, "-", color="#999999", lw=0.6)
        for cat in IMPACT_CATEGORIES:
            sel = rtype == cat
            ax.scatter(rx[sel], ry[sel], marker="o", s=36, facecolor="none",
                       edgecolor=REC_COLORS[cat], lw=1.4,
                       label=f"reconstruction, {cat} ({int(sel.sum())})")
            sel = mtype == cat
            ax.scatter(mx[sel], my[sel], marker="^", s=30, color=VFS_COLORS[cat],
                       label=f"VFS, {cat} ({int(sel.sum())})")
        ax.set_aspect("equal")
        ax.grid(True, lw=0.3)
        ax.set_xlabel("x from the front bumper [m] (forward +)")
    axes[0].set_ylabel("y [m] (left +), scaled to the median width")
    axes[0].set_xlim(-length - 0.2, 0.6)
    axes[0].set_ylim(-width / 2 - 0.5, width / 2 + 0.5)
    axes[1].set_xlim(-1.2, 0.3)
    axes[1].set_ylim(-width / 2 - 0.15, width / 2 + 0.15)
    axes[1].set_title("front (zoom)", fontsize=9)
    poi = comparison.poi_distances.set_index("group")
    fig.suptitle(f"POIs of {len(pairs)} vehicles in vehicle coordinates; mean distance VFS - "
                 "reconstruction: " + ", ".join(
                     f"{g} {_num(poi.loc[g, 'mean'], 3)} m" for g in GROUPS), fontsize=9)
    axes[0].legend(fontsize=7, loc="lower left", ncol=2)
    _save(fig, path)


def plot_boxplots(comparison: Comparison, path: str | os.PathLike[str]) -> None:
    """The Momentum Based Impact Model paper's Figure 6: boxplots of delta-v, EES and the change
    of velocity angle for (a) both full and (b) both sliding, reconstruction vs VFS, equal
    axes; whiskers at the minimum and maximum.
    """
    pairs = comparison.pairs
    names = [o for o in TABLE1_OUTCOMES if f"reference_{o}" in pairs.columns]
    fig = new_figure((11, 4.8))
    axes = fig.subplots(1, 2, sharey=True)
    for ax, group, letter in ((axes[0], GROUP_FULL, "a"), (axes[1], GROUP_SLIDING, "b")):
        sel = (pairs["group"] == group).to_numpy()
        data, positions, colors, ticks, labels = [], [], [], [], []
        for k, name in enumerate(names):
            o = OUTCOMES_BY_NAME[name]
            for s, (prefix, color) in enumerate((("reference", "#1f4e9c"), ("vfs", "#d62728"))):
                v = pairs.loc[sel, f"{prefix}_{name}"].to_numpy(float) * o.display_factor
                data.append(v[np.isfinite(v)])
                positions.append(3 * k + s)
                colors.append(color)
            ticks.append(3 * k + 0.5)
            labels.append(f"{o.label}\n[{o.display_unit}]")
        box = ax.boxplot(data, positions=positions, whis=(0, 100), widths=0.7,
                         patch_artist=True)
        for patch, color in zip(box["boxes"], colors, strict=True):
            patch.set_facecolor(color)
            patch.set_alpha(0.45)
        ax.set_xticks(ticks, labels, fontsize=8)
        ax.set_title(f"({letter}) {group}: n = {int(sel.sum())} vehicles", fontsize=10)
        ax.grid(True, axis="y", lw=0.3)
    axes[0].plot([], [], "s", color="#1f4e9c", alpha=0.45, label="reconstruction")
    axes[0].plot([], [], "s", color="#d62728", alpha=0.45, label="VFS")
    axes[0].legend(fontsize=8)
    _save(fig, path)


def _figure_outcomes(comparison: Comparison) -> list[str]:
    return [o for o in FIGURE_OUTCOMES if f"reference_{o}" in comparison.pairs.columns]


def plot_bland_altman(comparison: Comparison, path: str | os.PathLike[str]) -> None:
    """Bland-Altman plots: difference VFS - reconstruction against the mean of both,
    per vehicle, coloured by group; bias and 95 % limits of agreement of all
    compared vehicles, the TOST margin shaded.
    """
    names = _figure_outcomes(comparison)
    pairs = comparison.pairs
    paired = comparison.paired.set_index(["outcome", "group"])
    ncol = 3
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = new_figure((13, 3.8 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax, name in zip(axes.ravel(), names, strict=False):
        o = OUTCOMES_BY_NAME[name]
        f = o.display_factor
        r = pairs[f"reference_{name}"].to_numpy(float) * f
        m = pairs[f"vfs_{name}"].to_numpy(float) * f
        groups = pairs["group"].to_numpy(object)
        for g, color in GROUP_COLORS.items():
            sel = groups == g
            ax.scatter((r[sel] + m[sel]) / 2, m[sel] - r[sel], s=14, color=color, alpha=0.8,
                       label=g)
        row = paired.loc[(name, GROUP_ALL)]
        for value, style in ((row["bland_altman_bias"], "-"), (row["loa_low"], "--"),
                             (row["loa_high"], "--")):
            if np.isfinite(value):
                ax.axhline(value * f, color="black", ls=style, lw=1.0)
        margin = comparison.margins.get(name)
        if margin:
            ax.axhspan(-margin * f, margin * f, color="#2ca02c", alpha=0.12, lw=0)
        ax.axhline(0.0, color="#777777", lw=0.6)
        ax.set_title(f"{o.label}: bias {_num(row['bland_altman_bias'] * f)}, LoA "
                     f"[{_num(row['loa_low'] * f)}, {_num(row['loa_high'] * f)}] "
                     f"{o.display_unit}", fontsize=8)
        ax.set_xlabel(f"mean of VFS and reconstruction [{o.display_unit}]", fontsize=8)
        ax.set_ylabel(f"VFS - reconstruction [{o.display_unit}]", fontsize=8)
        ax.grid(True, lw=0.3)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    if names:
        axes.ravel()[0].legend(fontsize=7)
    _save(fig, path)


def plot_scatter(comparison: Comparison, path: str | os.PathLike[str]) -> None:
    """VFS against reconstruction per vehicle with the identity line, coloured by group."""
    names = _figure_outcomes(comparison)
    pairs = comparison.pairs
    ncol = 3
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = new_figure((13, 4.0 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax, name in zip(axes.ravel(), names, strict=False):
        o = OUTCOMES_BY_NAME[name]
        f = o.display_factor
        r = pairs[f"reference_{name}"].to_numpy(float) * f
        m = pairs[f"vfs_{name}"].to_numpy(float) * f
        groups = pairs["group"].to_numpy(object)
        for g, color in GROUP_COLORS.items():
            sel = groups == g
            ax.scatter(r[sel], m[sel], s=14, color=color, alpha=0.8, label=g)
        finite = np.concatenate([r[np.isfinite(r)], m[np.isfinite(m)]])
        if finite.size:
            lo, hi = float(finite.min()), float(finite.max())
            pad = 0.05 * (hi - lo or 1.0)
            ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k-", lw=0.8)
            ax.set_xlim(lo - pad, hi + pad)
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_aspect("equal")
        ax.set_title(o.label, fontsize=9)
        ax.set_xlabel(f"reconstruction [{o.display_unit}]", fontsize=8)
        ax.set_ylabel(f"VFS [{o.display_unit}]", fontsize=8)
        ax.grid(True, lw=0.3)
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    if names:
        axes.ravel()[0].legend(fontsize=7)
    _save(fig, path)


def plot_worst_cases(comparison: Comparison, folder: Path, count: int,
                     database: Database | None = None) -> list[tuple[Path, str]]:
    """Top views of the ``count`` worst cases of ``database``, re-simulated with the
    comparison's model.

    The VFS is drawn by :func:`vfs.report.figures.plot_case_topview`, zoomed on the
    impact with the whole path as an inset; the reconstruction's POI (open circle),
    contact plane (grey line) and rest positions (grey dashed outlines) are added
    (:func:`vfs.report.figures.reconstruction_scene`).  Returns (file, caption) pairs;
    none without a database.
    """
    db = database
    worst = comparison.case_errors.head(count)
    if db is None or worst.empty:
        return []
    from vfs.report.figures import plot_case_topview, reconstruction_scene
    from vfs.simulation import CaseBatch, SimulationParams, simulate_cases

    ids = worst["case_id"].to_numpy()
    batch = CaseBatch.from_database(db, ids,
                                    impact_parameters=comparison.impact_parameters or "default")
    res = simulate_cases(batch, params=comparison.params or SimulationParams())
    rec = db.reconstruction.drop_duplicates("case_id").set_index("case_id").loc[ids]
    out = []
    for k, row in enumerate(worst.itertuples(index=False)):
        title = (f"case {row.case_id} (rank {row.rank}): reconstruction {row.reference_type}, "
                 f"VFS {row.vfs_type}; worst {row.worst} ({_num(row.score, 1)} x margin)")
        fig = plot_case_topview(batch, res, k, None, title=title,
                                overlay=reconstruction_scene(batch, k, rec.iloc[k], overlay=True))
        file = folder / f"worst_{row.rank:02d}_case_{row.case_id}.png"
        save_figure(fig, file, dpi=110)
        out.append((file, title))
    return out


def _save(fig: Any, path: str | os.PathLike[str]) -> None:
    save_figure(fig, path, dpi=110, tight=True)


# ----------------------------------------------------------------------------
# Report tables
# ----------------------------------------------------------------------------


def _contingency_display(comparison: Comparison) -> pd.DataFrame:
    c = comparison.contingency
    t = c.table.copy()
    t["total"] = t.sum(axis=1)
    total = t.sum(axis=0)
    t.loc["total"] = total
    t.index = [f"reconstruction {i}" if i != "total" else "total" for i in t.index]
    t = t.reset_index().rename(columns={"index": "reconstruction \\ VFS"})
    return t.astype(str)


def _tests_display(comparison: Comparison) -> pd.DataFrame:
    c, ci = comparison.contingency, comparison.contingency_impacts
    rows = [
        ("chi-squared, 2 x k method x type (paper; treats the samples as independent)",
         _num(c.chi2_statistic), str(c.chi2_df), _p(c.chi2_pvalue)),
        (f"McNemar ({ci.mcnemar_method}), cases with an impact in both (2 x 2)",
         _num(ci.mcnemar_statistic), "1", _p(ci.mcnemar_pvalue)),
        ("McNemar, all cases" + ("" if len(c.categories) == 2 else " (n/a for k > 2)"),
         _num(c.mcnemar_statistic), "1", _p(c.mcnemar_pvalue)),
        ("Stuart-Maxwell (marginal homogeneity)", _num(c.stuart_maxwell_statistic),
         str(c.stuart_maxwell_df), _p(c.stuart_maxwell_pvalue)),
        ("Bowker (symmetry)", _num(c.bowker_statistic), str(c.bowker_df), _p(c.bowker_pvalue)),
        (f"Cohen's kappa = {_num(c.kappa, 3)} [{_num(c.kappa_ci_low, 3)}, "
         f"{_num(c.kappa_ci_high, 3)}]", "-", "-", _p(c.kappa_pvalue)),
    ]
    return pd.DataFrame(rows, columns=["test", "statistic", "df", "p"])


def _distance_display(df: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({
        "group": df["group"], "n (vehicles)": df["n"], "cases": df["n_cases"],
        "mean [m]": df["mean"].map(lambda v: _num(v, 3)),
        "95 % CI of the mean [m]": [f"[{_num(a, 3)}, {_num(b, 3)}]"
                                    for a, b in zip(df["mean_ci_low"], df["mean_ci_high"],
                                                    strict=True)],
        "median [m]": df["median"].map(lambda v: _num(v, 3)),
        "sd [m]": df["sd"].map(lambda v: _num(v, 3)),
        "max [m]": df["max"].map(lambda v: _num(v, 3)),
    })


def _table1_display(t1: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({
        "": t1["parameter"], "Number of samples n": t1["n"],
        "Mean value reconstruction": t1["mean_reconstruction"].map(_num),
        "Mean value VFS": t1["mean_vfs"].map(_num), "p-value": t1["p_value"].map(_p),
    })


def _table1_extra_display(t1: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({
        "": t1["parameter"],
        "mean difference [95 % CI]": [f"{_num(d)} [{_num(a)}, {_num(b)}]" for d, a, b in
                                      zip(t1["mean_difference"], t1["ci_low"], t1["ci_high"],
                                          strict=True)],
        "p (Holm)": t1["p_holm"].map(_p), "Wilcoxon p": t1["wilcoxon_p"].map(_p),
        "case-level t p": t1["case_level_p"].map(_p),
        "TOST margin": t1["tost_margin"].map(_num), "TOST p": t1["tost_p"].map(_p),
        "equivalent": t1["equivalent"].map(lambda v: "yes" if v else "no"),
    })


def _paired_display(paired: pd.DataFrame) -> pd.DataFrame:
    f = paired["display_factor"].to_numpy(float)

    def col(name: str) -> np.ndarray:
        return paired[name].to_numpy(float) * f

    md, lo, hi = col("mean_difference"), col("ci_low"), col("ci_high")
    return pd.DataFrame({
        "outcome": [f"{a} [{u}]" for a, u in zip(paired["label"], paired["display_unit"],
                                                 strict=True)],
        "group": paired["group"], "n": paired["n"], "cases": paired["n_cases"],
        "mean rec.": [_num(v) for v in col("mean_reference")],
        "mean VFS": [_num(v) for v in col("mean_model")],
        "mean diff. [95 % CI]": [f"{_num(a)} [{_num(b)}, {_num(c)}]"
                                 for a, b, c in zip(md, lo, hi, strict=True)],
        "t p": paired["t_pvalue"].map(_p), "t p (Holm)": paired["t_pvalue_holm"].map(_p),
        "Wilcoxon p": paired["wilcoxon_pvalue"].map(_p),
        "case-level t p": paired["case_t_pvalue"].map(_p),
        "LoA": [f"[{_num(a)}, {_num(b)}]" for a, b in zip(col("loa_low"), col("loa_high"),
                                                           strict=True)],
        "TOST margin": [_num(v) for v in col("tost_margin")],
        "TOST p": paired["tost_pvalue"].map(_p),
        "equivalent": paired["equivalent"].map(lambda v: "yes" if v else "no"),
        "MAE": [_num(v) for v in col("mean_abs_error")],
    })


def _worst_display(comparison: Comparison, top: int,
                   pages: dict[Any, str] | None = None) -> pd.DataFrame:
    e = comparison.case_errors.head(top)
    out = pd.DataFrame({
        "rank": e["rank"], "case": [case_link(cid, pages) for cid in e["case_id"]],
        "reconstruction": e["reference_type"],
        "VFS": e["vfs_type"], "score": e["score"].map(lambda v: _num(v, 1)),
        "worst": e["worst"].fillna("-"),
    })
    for name, label in (("delta_v", "delta-v"), ("ees", "EES")):
        if f"reference_{name}1" in e.columns:
            for i in (1, 2):
                out[f"{label}{i} rec./VFS [km/h]"] = [
                    f"{_num(a * KMH_PER_MS, 1)} / {_num(b * KMH_PER_MS, 1)}"
                    for a, b in zip(e[f"reference_{name}{i}"], e[f"vfs_{name}{i}"], strict=True)]
    for i in (1, 2):
        out[f"POI dist.{i} [m]"] = e[f"poi_distance{i}"].map(lambda v: _num(v, 3))
        out[f"rest dist.{i} [m]"] = e[f"rest_distance{i}"].map(lambda v: _num(v, 2))
    return out


def _margins_text(comparison: Comparison) -> str:
    parts = []
    for name in comparison.outcomes:
        o = OUTCOMES_BY_NAME[name]
        m = comparison.margins.get(name)
        parts.append(f"{name} {_num(m * o.display_factor, 1) if m else 'none'} {o.display_unit}")
    return ", ".join(parts)


# ----------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------


def write_comparison_report(comparison: Comparison, out: str | os.PathLike[str], *,
                            database: Database | None = None, top: int = 10,
                            database_reference: str | None = None,
                            sketches: int = 4, case_pages: bool = True) -> dict[str, Path]:
    """Write every table, figure and the Markdown / HTML report into a folder.

    Parameters
    ----------
    comparison : Comparison
        Result of :func:`vfs.analysis.compare.compare_database`.
    out : path
        Output folder (created; existing files of the same names are replaced).
    database : Database, optional
        The compared database, for the top views of the worst cases and the provenance
        section (its data hash; a warning when it is synthetic).
    database_reference : str, optional
        How the user named the database (``--db``), shown in the provenance section.
    top : int
        Number of worst cases listed in the report.
    sketches : int
        Number of worst cases re-simulated and drawn as top views (0: none;
        needs ``database``).
    case_pages : bool
        Write a page per case in the report's tables (``cases/<id>.html``: the
        simulation beside the reconstruction, :mod:`vfs.report.case_pages`) and link
        the case ids to them (needs ``database``; re-simulates those cases only).

    Returns
    -------
    dict of str to Path
        The files written, by short name: ``json``, ``report_md``,
        ``report_html``, the tables (``cases``, ``pairs``, ``contingency``,
        ``poi_distances``, ``rest_distances``, ``paired``, ``table1``,
        ``case_errors``) and the figures (``fig_*``).
    """
    folder = Path(out)
    figs = folder / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}

    files["json"] = write_text(folder / "comparison.json", json.dumps(
        comparison.to_dict(), indent=1, allow_nan=False) + "\n")
    tables = {
        "cases": comparison.cases, "pairs": comparison.pairs,
        "poi_distances": comparison.poi_distances, "rest_distances": comparison.rest_distances,
        "paired": comparison.paired, "table1": comparison.table1,
        "case_errors": comparison.case_errors,
    }
    for name, df in tables.items():
        files[name] = write_table(folder / f"{name}.csv", df)
    for name in ("pairs", "paired", "case_errors"):
        files[f"{name}_parquet"] = write_table(folder / f"{name}.parquet", tables[name])
    files["contingency"] = write_atomic(folder / "contingency.csv",
                                        comparison.contingency.table.to_csv)
    if comparison.staged is not None and len(comparison.staged):
        files["staged_tests"] = write_table(folder / "staged_tests.csv", comparison.staged)
        files["staged_summary"] = write_table(folder / "staged_summary.csv",
                                              staged_summary(comparison.staged))
    if comparison.measured is None or not len(comparison.measured):
        from vfs.analysis.paper_reference import side_by_side_table1, side_by_side_types

        files["paper_table1"] = write_table(folder / "paper_table1.csv",
                                            side_by_side_table1(comparison))
        files["paper_types"] = write_table(folder / "paper_types.csv",
                                           side_by_side_types(comparison))

    figure_jobs = {
        "fig_impact_types": ("fig4_impact_types.png", plot_impact_types),
        "fig_poi": ("fig5_poi_positions.png", plot_poi_positions),
        "fig_boxplots": ("fig6_boxplots.png", plot_boxplots),
        "fig_bland_altman": ("bland_altman.png", plot_bland_altman),
        "fig_scatter": ("scatter.png", plot_scatter),
    }
    for key, (file, func) in figure_jobs.items():
        files[key] = figs / file
        func(comparison, files[key])
    worst = plot_worst_cases(comparison, figs, max(0, int(sketches)), database)
    for k, (sketch, _) in enumerate(worst):
        files[f"fig_worst_{k + 1}"] = sketch

    pages: dict[Any, str] = {}
    if case_pages and database is not None:
        linked = [*comparison.case_errors["case_id"].head(top).tolist(),
                  *comparison.excluded["case_id"].tolist()]
        if comparison.measured is not None and len(comparison.measured):
            linked = [*comparison.measured["case_id"].tolist(), *linked]
        pages = write_comparison_case_pages(folder, comparison, database, linked)
    blocks = _report_blocks(comparison, top, worst, folder, pages)
    if database is not None:  # where the numbers come from; synthetic data said so
        blocks = with_provenance(blocks, database, database_reference)
    files.update(write_report(folder, Report("VFS vs reconstruction", tuple(blocks))))
    return files


def _table(df: pd.DataFrame) -> Table:
    return Table.from_frame(df, empty="(no rows)")


def _display(outcome: str) -> tuple[str, float]:
    """Display unit and factor from SI of a measurable outcome column."""
    if outcome == "energy_loss":
        return "kJ", 1e-3
    if outcome.startswith(("pdof", "velocity_angle_change", "rest_yaw")):
        return "deg", float(np.degrees(1.0))
    if outcome.startswith("yaw_rate"):
        return "deg/s", float(np.degrees(1.0))
    if outcome.startswith(("rest_x", "rest_y")):
        return "m", 1.0
    return "km/h", KMH_PER_MS


def measured_blocks(c: Comparison, pages: dict[Any, str] | None = None) -> list[Block]:
    """Crash tests: model against every measured value, with its stated uncertainty."""
    m = c.measured
    if m is None or len(m) == 0:
        return []
    rows = []
    for r in m.itertuples(index=False):
        unit, f = _display(str(r.outcome))
        sd = "" if not np.isfinite(r.sd) else f"{r.sd * f:.2f}"
        z = "" if not np.isfinite(r.z) else f"{r.z:+.1f}"
        rel = (f"{100 * r.difference / r.measured:+.1f} %" if r.measured else "")
        rows.append((case_link(r.case_id, pages), f"{r.outcome} [{unit}]", f"{r.measured * f:.2f}",
                     sd,
                     f"{r.model * f:.2f}", f"{r.difference * f:+.2f}", rel, z))
    return [
        Heading("Measured outcomes (crash tests)", 2),
        Paragraph("Cases whose reference is a measurement (outcome_source = measurement): "
                  "every measured value against the model, with the stated measurement "
                  "uncertainty (sd) and the difference in units of it (z). Outcomes the test "
                  "did not measure are left out; the statistics below then have few or no "
                  "pairs. docs/validation.md discusses them."),
        Table(("case", "outcome", "measured", "sd", "model", "model - measured", "relative",
               "z"), tuple(rows)),
    ]


def summary_blocks(c: Comparison) -> list[Block]:
    """The one-screen summary: impact types, delta-v per impact type, POI distance."""
    cont = c.contingency
    if cont.n == 0:
        return []
    items = [f"The impact type (full/sliding) agrees in {cont.n_agree} of {cont.n} cases "
             f"(kappa {_num(cont.kappa, 2)}; chi-squared {_p_eq(cont.chi2_pvalue)})."]
    p = c.paired.set_index(["outcome", "group"])
    for group, label in (("both full", "full impacts"), ("both sliding", "sliding impacts")):
        if ("delta_v", group) not in p.index:
            continue
        r = p.loc[("delta_v", group)]
        if not np.isfinite(r["mean_difference"]):
            continue
        f = float(r["display_factor"])
        items.append(
            f"Delta-v of {label}: VFS - reconstruction {r['mean_difference'] * f:+.1f} km/h "
            f"[{r['ci_low'] * f:+.1f}, {r['ci_high'] * f:+.1f}] over {int(r['n'])} vehicles "
            f"(t-test {_p_eq(r['t_pvalue'])}).")
    poi = c.poi_distances.set_index("group")
    if "all" in poi.index and np.isfinite(poi.loc["all", "mean"]):
        row = poi.loc["all"]
        items.append(f"The geometric POI lies {row['mean']:.2f} m "
                     f"[{row['mean_ci_low']:.2f}, {row['mean_ci_high']:.2f}] from the "
                     f"reconstruction's on average ({int(row['n'])} vehicles).")
    return [Heading("In short", 2), BulletList(tuple(items))]


def impact_parameter_sentence(c: Comparison) -> str:
    """The report's first line: which restitution and contact friction the simulation used."""
    from vfs.physics.impact import ImpactParams

    d = (c.params.impact if c.params is not None else ImpactParams())
    defaults = f"restitution {d.restitution:g}, contact friction {d.contact_friction:g}"
    if c.impact_parameters == "default":
        return (f"Impact parameters: the model's generic defaults for every case ({defaults}), "
                "as in a prospective assessment, where no expert values exist (the protocol "
                "of the Momentum Based Impact Model paper; `--impact-parameters "
                "reconstruction` gives the simulation each case's reconstructed values "
                "instead).")
    if c.impact_parameters == "reconstruction":
        return ("Impact parameters: each case's reconstructed restitution and contact friction "
                f"(the defaults, {defaults}, where the reconstruction has none). This is NOT "
                "the paper's prospective protocol (`--impact-parameters defaults`): the "
                "simulation is given values only a reconstruction can know.")
    return ("Impact parameters: those of the study run compared (`vfs study "
            "--impact-parameters`).")


def paper_blocks(c: Comparison) -> list[Block]:
    """The Momentum Based Impact Model paper's Table 1, impact types and POI distances
    beside ours, with its protocol (left out for crash tests: nothing to set beside).
    """
    from vfs.analysis.paper_reference import (
        PROTOCOL,
        chi2_sentence,
        population_notes,
        side_by_side_table1,
        side_by_side_types,
    )

    if c.measured is not None and len(c.measured):
        return []
    t1 = side_by_side_table1(c)
    rows = [(r.parameter, f"{r.paper_n}", f"{r.paper_reconstruction:.2f}",
             f"{r.paper_vfs:.2f}", f"{r.paper_difference:+.2f}", f"{r.paper_p:.3f}",
             f"{r.n}", _num(r.reconstruction), _num(r.vfs),
             "" if not np.isfinite(r.difference) else f"{r.difference:+.2f}", _p(r.p_value),
             "yes" if r.same_direction else "no")
            for r in t1.itertuples(index=False)]
    types = side_by_side_types(c)
    trows = [(r.group, f"{r.paper_cases}", f"{r.cases}", f"{r.paper_poi_distance:.3f}",
              _num(r.poi_distance, 3), f"{r.paper_poi_n}", f"{r.poi_n}")
             for r in types.itertuples(index=False)]
    notes = population_notes(t1)
    return [
        Heading("The Momentum Based Impact Model paper side by side", 2),
        Paragraph(PROTOCOL + " " + impact_parameter_sentence(c)),
        Table(("Table 1 row", "paper n", "paper rec.", "paper VFS", "paper VFS - rec.",
               "paper p", "n", "rec.", "VFS", "VFS - rec.", "p", "same direction"),
              tuple(rows)),
        Table(("group", "paper cases", "cases", "paper POI distance [m]",
               "POI distance [m]", "paper n (vehicles)", "n (vehicles)"), tuple(trows)),
        Paragraph(chi2_sentence(c)),
        *([BulletList(tuple(notes))] if notes else []),
        Paragraph("Files: `paper_table1.csv`, `paper_types.csv`."),
    ]


def _report_blocks(comparison: Comparison, top: int, worst: list[tuple[Path, str]],
                   folder: Path, pages: dict[Any, str] | None = None) -> list[Block]:
    c = comparison
    cont = c.contingency
    counts = c.status_counts
    excluded = c.excluded
    effects = ", ".join(repr(e) for e in c.params.effects) if c.params is not None else ""
    b: list[Block] = [
        Heading("Virtual forward simulation vs reconstruction", 1),
        Paragraph(impact_parameter_sentence(c)),
        *summary_blocks(c),
        Paragraph(f"VFS source: {c.source}; model: default"
                  + (f" with effects {effects}" if effects else "") + ". "
                  f"{len(c.cases)} cases with a reconstruction: "
                  + ", ".join(f"{k} {v}" for k, v in counts.items() if v)
                  + ". Cases avoided by the VFS or with an error are excluded from the paired "
                  "tests (section 8). Differences are VFS - reconstruction; speeds in km/h, "
                  "angles in degrees. The analysis follows "
                  f"{cite('momentum-impact-model')} (Figures 4-6, Table 1); formulas "
                  "and conventions: docs/compare.md."),
        *measured_blocks(c, pages),
        *staged_blocks(c, pages),
        Heading("1 Impact type (the Momentum Based Impact Model paper, Figure 4)", 2),
        Paragraph(f"Rows: reconstruction, columns: VFS ('none': the VFS found no impact). "
                  f"{cont.n_agree} of {cont.n} cases agree (observed agreement "
                  f"{_num(cont.observed_agreement, 3)})."),
        _table(_contingency_display(c)),
        _table(_tests_display(c)),
        Paragraph("The chi-squared test reproduces the paper: it compares the type "
                  "frequencies of the two methods as if they were independent samples. The "
                  "samples are the same accidents, so McNemar (2 x 2), Stuart-Maxwell and "
                  "Bowker are the appropriate paired tests; kappa measures agreement beyond "
                  "chance."),
        Figure("figures/fig4_impact_types.png",
               "Figure 4: impact types in reconstruction and VFS; bands and arrows show how "
               "the cases move between the types."),
        Heading("2 Point of impact in vehicle coordinates (the Momentum Based Impact Model "
                "paper, Figure 5)", 2),
        Paragraph("Distance between the reconstruction POI (in the vehicle's frame at the "
                  "reconstruction's impact pose) and the VFS POI (in the same vehicle's frame "
                  "at the VFS impact pose), per vehicle (n = 2 x cases). The CI of the mean "
                  "resamples cases with both vehicles (bootstrap)."),
        _table(_distance_display(c.poi_distances)),
        Figure("figures/fig5_poi_positions.png",
               "Figure 5: POIs in vehicle coordinates; circles reconstruction (blue full, "
               "green sliding), triangles VFS (red full, yellow sliding)."),
        Heading("3 Table 1: paired t-tests, same impact type in both", 2),
        Paragraph("The Momentum Based Impact Model paper's layout: per vehicle (n = 2 x cases) "
                  "among the cases with the "
                  "same impact type in reconstruction and VFS; p from the paired t-test."),
        _table(_table1_display(c.table1)),
        Paragraph("Beyond the paper: mean difference VFS - reconstruction with its 95 % "
                  "confidence interval, Holm-adjusted p (family: every test of section 5), "
                  "Wilcoxon signed-rank p (Pratt), the t-test on the per-case mean of the two "
                  "vehicles (the two vehicles of a case are not independent) and the TOST "
                  "equivalence test with its margin. A p-value above 0.05 is no evidence of "
                  "agreement: only the TOST (equivalent = yes) is."),
        _table(_table1_extra_display(c.table1)),
        *paper_blocks(c),
        Heading("4 Boxplots per impact type (the Momentum Based Impact Model paper, Figure 6)", 2),
        Figure("figures/fig6_boxplots.png",
               "Figure 6: (a) both full, (b) both sliding; reconstruction blue, VFS red; "
               "whiskers at minimum and maximum, equal axes."),
        Heading("5 All outcomes", 2),
        Paragraph("Per vehicle (n = 2 x cases; energy loss per case), overall ('all') and by "
                  "impact-type group. Margins of the TOST: " + _margins_text(c) + "."),
        _table(_paired_display(c.paired)),
        Figure("figures/bland_altman.png",
               "Bland-Altman plots: difference against mean, bias (solid) and 95 % limits of "
               "agreement (dashed) over all compared vehicles, TOST margin shaded."),
        Figure("figures/scatter.png", "VFS against reconstruction with the identity line."),
        Heading("6 Rest positions", 2),
        Paragraph("Distance between the rest positions of reconstruction and VFS per vehicle "
                  "[m]; the x/y differences and the run-out displacement are in section 5."),
        _table(_distance_display(c.rest_distances)),
        Heading("7 Worst cases", 2),
        Paragraph(f"The {min(top, len(c.case_errors))} cases with the largest error, ranked by "
                  "score = the largest |VFS - reconstruction| / margin over delta-v, EES, "
                  "change of velocity angle, post-impact speed and rest x/y of both vehicles "
                  "(full list: case_errors.csv)."
                  + (" Each case id links to its page: the simulation beside the "
                     "reconstruction (top views, impact table, speed over time)." if pages
                     else "")),
        _table(_worst_display(c, top, pages)),
    ]
    for file, caption in worst:
        b.append(Figure(file.relative_to(folder).as_posix(),
                        caption + " (VFS in colour, zoomed on the impact, inset: the whole "
                        "path; reconstruction POI, contact plane and rest positions in grey)"))
    b += [
        Heading("8 Cases not compared", 2),
        _table(pd.DataFrame({
            "case": [case_link(cid, pages) for cid in excluded["case_id"]],
            "status": excluded["status"],
            "reconstruction": excluded["reference_type"],
            "message": excluded["error"].fillna("")})),
        Heading("Files", 2),
        BulletList((
            "`comparison.json`: every number (SI units)",
            "`table1.csv` (km/h, deg), `paired.csv`/`.parquet` (SI; `display_factor` converts)",
            "`contingency.csv`, `poi_distances.csv`, `rest_distances.csv`",
            "`pairs.csv`/`.parquet`: the compared values per vehicle (SI)",
            "`case_errors.csv`/`.parquet`: errors per case, worst first (SI)",
            "`cases.csv`: status of every case",
        )),
    ]
    return b


__all__ = [
    "plot_bland_altman",
    "plot_boxplots",
    "plot_impact_types",
    "plot_poi_positions",
    "plot_scatter",
    "plot_worst_cases",
    "write_comparison_report",
]
