"""Report of an AEB effectiveness analysis: Markdown, HTML, tables and figures.

:func:`write_effectiveness_report` analyses a finished study with
:func:`vfs.analysis.effectiveness.effectiveness` and writes ``report.md``,
``report.html`` (:mod:`vfs.report.render`), ``metrics.csv``,
``crosstabs.csv`` and PNG figures (:func:`write_figures`) into
``STUDY/report/``, every file atomically.  Speeds are shown in km/h.  A study on the
Euro NCAP matrix (``--db euro-ncap-c2c``) also gets the protocol's view
(:mod:`vfs.report.euro_ncap`: section, ``euro_ncap_tests.csv``, ``euro_ncap_scores.csv``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.accident_types import accident_type_label
from vfs.analysis.effectiveness import ALL, BASELINE, Effectiveness, effectiveness
from vfs.analysis.system_differences import system_differences
from vfs.atomic import write_text
from vfs.errors import DataError, DataProblem
from vfs.progress import note
from vfs.report.case_pages import case_link, write_effectiveness_case_pages
from vfs.report.euro_ncap import euro_ncap_blocks, study_tables, write_euro_ncap_tables
from vfs.report.figures import RUN_COLORS, new_figure, save_figure
from vfs.report.provenance import (
    database_label,
    provenance_blocks,
    synthetic_note,
    table_of_contents,
)
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
from vfs.units import KMH_PER_MS


def _fmt(value: float, unit: str, digits: int = 1) -> str:
    if not np.isfinite(value):
        return "-"
    if unit == "-":
        return f"{100 * value:.{digits}f} %"
    if unit == "m/s":
        return f"{value * KMH_PER_MS:.{digits}f}"
    if unit == "drivers":
        return f"{value:.2f}"
    if abs(value - round(value)) < 1e-6 * max(1.0, abs(value)):
        return f"{value:.0f}"
    return f"{value:.{digits}f}"


def _fmt_ci(row: pd.Series) -> str:
    unit = row["unit"]
    if not np.isfinite(row["low"]):
        return _fmt(row["estimate"], unit)
    return (f"{_fmt(row['estimate'], unit)} [{_fmt(row['low'], unit)}, "
            f"{_fmt(row['high'], unit)}]")


def _metric_table(eff: Effectiveness, metrics: Sequence[str], group: object = ALL,
                  labels: Sequence[str] | None = None) -> pd.DataFrame:
    m = eff.metrics[eff.metrics["group"] == group].set_index(["metric", "system"])
    systems = [p.system for p in eff.pairs]
    data = {}
    for name, label in zip(metrics, labels or metrics, strict=True):
        data[label] = [_fmt_ci(m.loc[(name, s)]) if (name, s) in m.index else "-"
                       for s in systems]
    return pd.DataFrame(data, index=pd.Index(systems, name="system")).reset_index()


def baseline_crashes(eff: Effectiveness) -> float:
    """Weighted number of baseline crashes over all compared cases."""
    m = eff.metrics[(eff.metrics["group"] == ALL) & (eff.metrics["metric"] == "crashes_baseline")]
    return float(m["estimate"].max()) if len(m) else 0.0


def _figure_block(figures: dict[str, str], key: str, caption: str) -> list[Block]:
    """The figure ``key`` as a one-block list, or no block when it was not drawn."""
    return [Figure(figures[key], caption)] if figures.get(key) else []


def summary_blocks(eff: Effectiveness) -> list[Block]:
    """The one-screen summary: per system one sentence with the headline figures."""
    m = eff.metrics[eff.metrics["group"] == ALL].set_index(["metric", "system"])
    level = next(iter(eff.curves), None)
    crashes = baseline_crashes(eff)
    if crashes <= 0:
        return []
    pct = int(round(100 * eff.confidence))

    def cell(metric: str, system: str) -> str:
        return _fmt_ci(m.loc[(metric, system)]) if (metric, system) in m.index else "-"

    items = []
    for pair in eff.pairs:
        s = pair.system
        new = m.loc[("crashes_new", s), "estimate"] if ("crashes_new", s) in m.index else 0
        text = (f"`{s}` avoids {cell('avoided_share', s)} of the {crashes:g} baseline crashes"
                + (f", lowers the expected {level} injuries by "
                   f"{cell(f'risk_{level}_reduction', s)}" if level else "")
                + f" and the mean delta-v by {cell('dv_reduction_all', s)} km/h per baseline "
                f"crash; it causes {'no' if new == 0 else f'{new:g}'} new "
                f"crash{'' if new == 1 else 'es'}.")
        items.append(text)
    return [Heading("In short", 2), BulletList(tuple(items)),
            Paragraph(f"Brackets: {pct} % confidence intervals. Details and definitions "
                      "below.")]


def _report_blocks(eff: Effectiveness, manifest: dict[str, Any], figures: dict[str, str],
                   cases: list[Block] | None = None, pages: dict[Any, str] | None = None
                   ) -> list[Block]:
    pct = int(round(100 * eff.confidence))
    n_valid = eff.pairs[0].size
    n_bad = int(eff.excluded["case_id"].nunique())
    systems = manifest.get("systems") or [{"name": p.system, "description": ""}
                                          for p in eff.pairs]
    head: list[Block] = [
        Heading(f"AEB effectiveness: {manifest.get('name') or manifest.get('path', 'study')}",
                1),
        *synthetic_note(manifest),
        *summary_blocks(eff),
        # the headline figure, above the fold
        *_figure_block(figures, "avoided_by_type", "Avoided share of the baseline crashes per "
                       "accident type and system (the tables below give the intervals)"),
    ]
    blocks: list[Block] = [
        Heading("The study", 2),
        Paragraph(f"Database `{database_label(manifest)}` ({manifest.get('n_cases', '?')} cases"
                  + (f", selection `{manifest['where']}`" if manifest.get("where") else "")
                  + f"); equipped vehicles: {manifest.get('equip', '?')}; study seed "
                  f"{manifest.get('seed', '?')}. {n_valid} cases compared (total weight "
                  f"{eff.pairs[0].weight.sum():g}); {n_bad} case(s) excluded because a run "
                  "failed."),
        Paragraph("The systems, as they ran (generated from their parameters):"),
        BulletList(tuple(f"`{s['name']}`: {s.get('parameters') or s.get('description', '')}"
                         for s in systems)),
        Paragraph(f"Every system is compared case by case with the baseline (the recorded "
                  f"behaviour), weighted by the cases' `weight` (frequency weights). Brackets: "
                  f"{pct} % confidence intervals: Wilson score intervals for shares, BCa "
                  f"bootstrap over cases for means and relative reductions, percentile "
                  f"bootstrap for totals ({eff.n_boot} resamples, seed {eff.seed}; why: "
                  f"docs/statistics.md). Speeds in km/h. Definitions and formulas: "
                  f"docs/study.md."),
        *([] if baseline_crashes(eff) > 0 else [Note(
            f"No crash in the baseline: none of the {n_valid} compared cases collides without "
            "a system, so there is nothing to avoid. Shares, mean speeds and risk reductions "
            "are undefined (shown as '-') and no figures are drawn; the tables below still "
            "count crashes that happen only with a system.", "warning")]),
        Heading("Crashes avoided", 2),
        Table.from_frame(_metric_table(
            eff, ["crashes_baseline", "crashes_treatment", "crashes_avoided", "crashes_new",
                  "avoided_share", "crash_reduction"],
            labels=["baseline crashes", "crashes with system", "avoided", "new crashes",
                    "avoided share", "net crash reduction"])),
        Paragraph("Avoided share = weighted baseline crashes without a crash in the treatment "
                  "run / weighted baseline crashes. Net crash reduction also subtracts crashes "
                  "that happen only with the system."),
        *_difference_blocks(eff),
        Heading("Per accident type (avoided share)", 3),
        Table.from_frame(_per_type_table(eff, "avoided_share")),
        Heading("Per accident type and system", 3),
        Paragraph("Reductions per baseline crash (a run without a crash counts 0); risk: "
                  "relative reduction of the expected injured drivers."),
    ]
    group_metrics = ["avoided_share", "speed_reduction_all", "dv_reduction_all",
                     *[f"risk_{level}_reduction" for level in eff.curves]]
    group_labels = ["avoided share", "impact-speed reduction [km/h]", "delta-v reduction [km/h]",
                    *[f"{level} reduction" for level in eff.curves]]
    for pair in eff.pairs:
        blocks += [Paragraph(f"`{pair.system}`:"),
                   Table.from_frame(_group_table(eff, pair.system, group_metrics,
                                                 group_labels))]
    blocks += [
        Heading("Impact speed", 2),
        Paragraph("Case impact speed = the larger impact speed of the two vehicles. 'Per "
                  "baseline crash': mean over the baseline crashes, a run without a crash counts "
                  "0 km/h (avoided crashes count 0; crashes new with the system add their "
                  "speed). 'Not avoided': only cases that crash in both runs."),
        Table.from_frame(_metric_table(
            eff, ["speed_baseline", "speed_treatment_all", "speed_reduction_all",
                  "speed_reduction_all_rel", "speed_treatment_nav", "speed_reduction_nav",
                  "speed_reduction_nav_rel"],
            labels=["baseline [km/h]", "with system, per baseline crash [km/h]",
                    "reduction per baseline crash [km/h]", "relative",
                    "with system, not avoided [km/h]", "reduction, not avoided [km/h]",
                    "relative, not avoided"])),
        *_figure_block(figures, "impact_speed_cdf",
                       "Cumulative distribution of the impact speed over the baseline crashes "
                       f"(avoided = 0 km/h), {pct} % bootstrap bands"),
        Heading("Delta-v", 2),
        Paragraph("Case delta-v = the larger delta-v of the two vehicles; same two averages."),
        Table.from_frame(_metric_table(
            eff, ["dv_baseline", "dv_treatment_all", "dv_reduction_all", "dv_reduction_all_rel",
                  "dv_reduction_nav", "dv_reduction_nav_rel"],
            labels=["baseline [km/h]", "with system, per baseline crash [km/h]",
                    "reduction per baseline crash [km/h]", "relative",
                    "reduction, not avoided [km/h]", "relative, not avoided"])),
        *_figure_block(figures, "delta_v_scatter",
                       "Delta-v per case, baseline vs. with the system (0 = avoided)"),
        Heading("Impact type", 2),
        Paragraph("Weighted cases by impact type, baseline (rows) x with the system "
                  "(columns); `none` = no crash, `separating` = contact without an impact "
                  "impulse."),
    ]
    for system, table in eff.crosstabs.items():
        blocks.append(Heading(system, 3))
        shown = table.copy()
        shown.index = [f"baseline {i}" for i in shown.index]
        blocks.append(Table.from_frame(shown.map(lambda v: f"{v:g}").reset_index(
            names="baseline \\ " + system)))
    curve_lines = [f"{level}: `{c.name}`: {c.description}. Source: {c.source}."
                   for level, c in eff.curves.items()]
    risk_metrics, risk_labels = [], []
    for level in eff.curves:
        risk_metrics += [f"risk_{level}_baseline", f"risk_{level}_treatment",
                         f"risk_{level}_avoided", f"risk_{level}_reduction"]
        risk_labels += [f"{level} baseline", f"{level} with system", f"{level} avoided",
                        f"{level} reduction"]
    blocks += [
        Heading("Injury risk", 2),
        Paragraph("Every vehicle holds one occupant (the driver); the driver's risk is the "
                  "curve's probability at the vehicle's delta-v (0 without a crash); a case's "
                  "expected number of injured drivers is the sum over its two vehicles. "
                  "Figures are weighted sums over the cases (expected injured drivers)."),
        BulletList(tuple(curve_lines)),
        Table.from_frame(_metric_table(eff, risk_metrics, labels=risk_labels)),
        *_figure_block(figures, "injury_risk",
                       f"Expected injured drivers per system with {pct} % bootstrap intervals"),
        *(cases or []),
        Heading("Excluded cases", 2),
    ]
    if eff.excluded.empty:
        blocks.append(Paragraph("No run failed."))
    else:
        blocks.append(Paragraph(f"{n_bad} case(s) with a failed run are excluded from every "
                                "comparison:"))
        shown = eff.excluded.head(50).copy()
        shown["case_id"] = [case_link(c, pages) for c in shown["case_id"]]
        blocks.append(Table.from_frame(shown))
        if len(eff.excluded) > 50:
            blocks.append(Paragraph(f"... and {len(eff.excluded) - 50} more failed runs."))
    blocks += provenance_blocks(manifest)
    return [*head, *table_of_contents(blocks), *blocks]


def _difference_blocks(eff: Effectiveness) -> list[Block]:
    """The systems against each other: paired differences with intervals (two or more)."""
    if len(eff.pairs) < 2 or baseline_crashes(eff) <= 0:
        return []
    diff = system_differences(eff)
    pct = int(round(100 * eff.confidence))
    rows = []
    for r in diff.itertuples(index=False):
        fmt = "{:.1f}"
        rows.append((f"`{r.system_b}` - `{r.system_a}`", str(r.label),
                     f"{fmt.format(r.value_a)} / {fmt.format(r.value_b)} {r.unit}",
                     f"{r.difference:+.1f} [{r.low:+.1f}, {r.high:+.1f}] {r.unit}",
                     str(r.n_cases)))
    return [
        Heading("Systems compared with each other", 3),
        Paragraph(f"Both systems ran on the same cases, so they are compared case by case on "
                  f"the baseline crashes: the difference B - A of each outcome with its {pct} % "
                  f"BCa bootstrap interval over the cases, pairs kept together "
                  f"({eff.n_boot} resamples; `vfs.analysis.system_differences`). An interval "
                  "that excludes 0 is a difference the study resolves."),
        Table(("B - A", "outcome", "A / B", "difference B - A", "baseline crashes"),
              tuple(rows)),
    ]


def _group_table(eff: Effectiveness, system: str, metrics: Sequence[str],
                 labels: Sequence[str]) -> pd.DataFrame:
    """Rows: all cases and each accident type; columns: metrics of one system."""
    m = eff.metrics[eff.metrics["system"] == system]
    groups = list(pd.unique(m["group"]))
    by = m.set_index(["group", "metric"])
    rows = []
    for group in groups:
        cells = [accident_type_label(group), str(int(by.loc[(group, metrics[0]), "n_cases"]))]
        cells += [_fmt_ci(by.loc[(group, name)]) for name in metrics]
        rows.append(cells)
    return pd.DataFrame(rows, columns=["accident type", "cases", *labels])


def _per_type_table(eff: Effectiveness, metric: str) -> pd.DataFrame:
    m = eff.metrics[(eff.metrics["metric"] == metric) & (eff.metrics["group"] != ALL)]
    if m.empty:
        return pd.DataFrame()
    cells = m.assign(cell=m.apply(_fmt_ci, axis=1))
    table = cells.pivot(index="group", columns="system", values="cell")
    table = table[[p.system for p in eff.pairs if p.system in table.columns]]
    n = m.drop_duplicates("group").set_index("group")["n_cases"]
    table.insert(0, "cases", n.reindex(table.index).astype(int).astype(str))
    table.index = [accident_type_label(g) for g in table.index]
    return table.reset_index(names="accident type")


# ----------------------------------------------------------------------------
# Cases to look into
# ----------------------------------------------------------------------------

#: Default number of cases listed per kind and system (``--list-cases``).
LIST_CASES = 5


def notable_cases(eff: Effectiveness, per_kind: int = LIST_CASES) -> pd.DataFrame:
    """Cases worth a look, per system: new crashes, crashes not avoided, crashes avoided.

    Per system and kind at most ``per_kind`` cases: crashes the system causes (largest
    impact speed with it first), baseline crashes it does not avoid (largest remaining
    impact speed first) and baseline crashes it avoids (fastest baseline impact first).

    Returns
    -------
    pandas.DataFrame
        Columns ``system``, ``kind``, ``case_id``, ``accident_type``, ``speed_base``,
        ``speed_treat`` [m/s], ``dv_base``, ``dv_treat`` [m/s] (the larger of both
        vehicles; 0 without a crash), ``crash_base``, ``crash_treat``.
    """
    frames = []
    for pair in eff.pairs:
        kinds = (("new crash", pair.crash_treat & ~pair.crash_base, pair.speed_treat),
                 ("not avoided", pair.crash_base & pair.crash_treat, pair.speed_treat),
                 ("avoided", pair.crash_base & ~pair.crash_treat, pair.speed_base))
        for kind, mask, key in kinds:
            idx = np.flatnonzero(mask)
            idx = idx[np.argsort(-key[idx], kind="stable")][:max(0, int(per_kind))]
            frames.append(pd.DataFrame({
                "system": pair.system, "kind": kind, "case_id": pair.case_id[idx],
                "accident_type": pair.accident_type[idx],
                "speed_base": pair.speed_base[idx], "speed_treat": pair.speed_treat[idx],
                "dv_base": pair.delta_v_base[idx].max(axis=1, initial=0.0),
                "dv_treat": pair.delta_v_treat[idx].max(axis=1, initial=0.0),
                "crash_base": pair.crash_base[idx], "crash_treat": pair.crash_treat[idx]}))
    if not frames:
        return pd.DataFrame(columns=["system", "kind", "case_id", "accident_type",
                                     "speed_base", "speed_treat", "dv_base", "dv_treat",
                                     "crash_base", "crash_treat"])
    return pd.concat(frames, ignore_index=True)


def _crash_cell(speed: float, crash: bool) -> str:
    """A speed [m/s] as km/h, or "no crash"."""
    return f"{speed * KMH_PER_MS:.1f}" if crash else "no crash"


def notable_blocks(eff: Effectiveness, notable: pd.DataFrame, pages: dict[Any, str],
                   problem: str = "") -> list[Block]:
    """The section listing :func:`notable_cases` per system, case ids linked to their pages."""
    per_kind = int(notable.groupby(["system", "kind"]).size().max()) if len(notable) else 0
    blocks: list[Block] = [
        Heading("Cases to look into", 2),
        Paragraph(f"Per system up to {per_kind} cases of each kind: crashes the system causes, "
                  "baseline crashes it does not avoid (largest impact speed with the system "
                  "first) and crashes it avoids (fastest baseline impact first). "
                  + ("Each case id links to its page: top views, speed and brake traces of "
                     "the baseline and every system, the AEB events and the impact table."
                     if pages else "")),
    ]
    if problem:
        blocks.append(Note(f"No case pages: {problem}", "warning"))
    for pair in eff.pairs:
        sub = notable[notable["system"] == pair.system]
        blocks.append(Paragraph(f"`{pair.system}`:"))
        blocks.append(Table(
            ("case", "accident type", "listed as", "impact speed [km/h]: baseline \u2192 "
             "with system", "delta-v [km/h]: baseline \u2192 with system"),
            tuple((case_link(r.case_id, pages), accident_type_label(r.accident_type), r.kind,
                   f"{_crash_cell(r.speed_base, r.crash_base)} \u2192 "
                   f"{_crash_cell(r.speed_treat, r.crash_treat)}",
                   f"{_crash_cell(r.dv_base, r.crash_base)} \u2192 "
                   f"{_crash_cell(r.dv_treat, r.crash_treat)}")
                  for r in sub.itertuples(index=False)),
            align=("left", "left", "left", "right", "right"),
            empty="No case changes its outcome with this system."))
    return blocks


# ----------------------------------------------------------------------------
# Figures
# ----------------------------------------------------------------------------


def _figure(width: float, height: float, ncols: int = 1) -> tuple[Any, Any]:
    fig = new_figure((width, height), layout="constrained")
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    return fig, axes


_COLORS = RUN_COLORS


def write_figures(eff: Effectiveness, folder: Path) -> dict[str, str]:
    """Write the PNG figures; return {key: file name}."""
    files: dict[str, str] = {}
    systems = [p.system for p in eff.pairs]
    pct = int(round(100 * eff.confidence))

    # impact-speed CDF with bands
    fig, (ax,) = _figure(7.0, 4.5)
    for i, name in enumerate([BASELINE, *systems]):
        d = eff.cdf[eff.cdf["system"] == name]
        x = d["speed"].to_numpy() * KMH_PER_MS
        color = _COLORS[i % len(_COLORS)]
        ax.step(x, d["share"], where="post", color=color, label=name)
        ax.fill_between(x, d["low"], d["high"], step="post", color=color, alpha=0.2, lw=0)
    ax.set_xlabel("impact speed (faster vehicle) [km/h]; avoided = 0")
    ax.set_ylabel("cumulative share of baseline crashes")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    files["impact_speed_cdf"] = "impact_speed_cdf.png"
    save_figure(fig, folder / files["impact_speed_cdf"], dpi=110)

    # delta-v scatter per system
    fig, axes = _figure(4.2 * len(systems), 4.2, ncols=len(systems))
    for ax, pair, color in zip(axes, eff.pairs, _COLORS[1:] * 5, strict=False):
        crash = pair.crash_base | pair.crash_treat
        xb = pair.delta_v_base.max(axis=1)[crash] * KMH_PER_MS
        yt = pair.delta_v_treat.max(axis=1)[crash] * KMH_PER_MS
        size = 12.0 * pair.weight[crash] / max(float(pair.weight[crash].mean()), 1e-12) \
            if crash.any() else 12.0
        ax.scatter(xb, yt, s=size, color=color, alpha=0.5, lw=0)
        top = max(float(np.max(xb, initial=0)), float(np.max(yt, initial=0)), 1.0) * 1.05
        ax.plot([0, top], [0, top], "k--", lw=0.8)
        ax.set_xlim(0, top)
        ax.set_ylim(0, top)
        ax.set_aspect("equal")
        row = eff.metrics[(eff.metrics["system"] == pair.system) & (eff.metrics["group"] == ALL)
                          & (eff.metrics["metric"] == "dv_reduction_all")].iloc[0]
        ax.set_title(f"{pair.system}\nmean reduction {_fmt_ci(row)} km/h", fontsize=9)
        ax.set_xlabel("baseline delta-v (max of both) [km/h]")
        ax.set_ylabel("delta-v with system [km/h]; 0 = avoided")
        ax.grid(alpha=0.3)
    files["delta_v_scatter"] = "delta_v_scatter.png"
    save_figure(fig, folder / files["delta_v_scatter"], dpi=110)

    # injury risk bars
    levels = list(eff.curves)
    fig, axes = _figure(3.6 * len(levels) + 1.0, 4.0, ncols=len(levels))
    m = eff.metrics[eff.metrics["group"] == ALL].set_index(["metric", "system"])
    for ax, level in zip(axes, levels, strict=True):
        labels, est, lo, hi = [BASELINE], [], [], []
        base = m.loc[(f"risk_{level}_baseline", systems[0])]
        est.append(base["estimate"])
        lo.append(base["low"])
        hi.append(base["high"])
        for s in systems:
            r = m.loc[(f"risk_{level}_treatment", s)]
            labels.append(s)
            est.append(r["estimate"])
            lo.append(r["low"])
            hi.append(r["high"])
        est_a = np.asarray(est)
        err = np.vstack([est_a - np.asarray(lo), np.asarray(hi) - est_a])
        ax.bar(labels, est_a, yerr=np.nan_to_num(err), capsize=4,
               color=[_COLORS[i % len(_COLORS)] for i in range(len(labels))], alpha=0.8)
        ax.set_title(f"{level} ({eff.curves[level].name})", fontsize=9)
        ax.set_ylabel(f"expected {level} injured drivers")
        ax.tick_params(axis="x", rotation=30)
        ax.grid(alpha=0.3, axis="y")
    fig.suptitle(f"Injury risk, {pct} % bootstrap intervals", fontsize=10)
    files["injury_risk"] = "injury_risk.png"
    save_figure(fig, folder / files["injury_risk"], dpi=110)

    # avoided share per accident type
    sub = eff.metrics[eff.metrics["metric"] == "avoided_share"]
    groups = list(pd.unique(sub["group"]))
    fig, (ax,) = _figure(min(12.0, max(6.0, 0.45 * len(groups) * max(len(systems), 1) + 2)),
                         4.0)
    width = 0.8 / max(len(systems), 1)
    for i, s in enumerate(systems):
        d = sub[sub["system"] == s].set_index("group").reindex(groups)
        x = np.arange(len(groups)) + (i - (len(systems) - 1) / 2) * width
        est_v = d["estimate"].to_numpy(float) * 100
        err = np.vstack([est_v - d["low"].to_numpy(float) * 100,
                         d["high"].to_numpy(float) * 100 - est_v])
        ax.bar(x, est_v, width, yerr=np.nan_to_num(np.clip(err, 0, None)), capsize=3,
               color=_COLORS[(i + 1) % len(_COLORS)], label=s, alpha=0.85)
    ax.set_xticks(np.arange(len(groups)), [accident_type_label(g) for g in groups],
                  rotation=20, ha="right")
    ax.set_xlabel("accident type")
    ax.set_ylabel(f"baseline crashes avoided [%] ({pct} % CI)")
    ax.set_ylim(0, 105)
    ax.grid(alpha=0.3, axis="y")
    ax.legend()
    files["avoided_by_type"] = "avoided_by_type.png"
    save_figure(fig, folder / files["avoided_by_type"], dpi=110)
    return files


def write_effectiveness_report(study: str | os.PathLike[str], *,
                               risk_curves: Iterable[str] | None = None, n_boot: int = 2000,
                               seed: int = 0, confidence: float = 0.95,
                               out: str | os.PathLike[str] | None = None,
                               case_pages: bool = True, list_cases: int = LIST_CASES,
                               say: Callable[[str], None] | None = None) -> Path:
    """Analyse a finished study and write its report.

    Parameters
    ----------
    study : path
        Study folder (``study.json`` and ``runs.parquet``).
    risk_curves : iterable of str, optional
        Curves replacing the defaults of their injury level.
    n_boot, seed, confidence
        Bootstrap settings.
    out : path, optional
        Report folder; default ``STUDY/report``.
    case_pages : bool
        Write a page per case listed in the report's tables (``cases/<id>.html``,
        :mod:`vfs.report.case_pages`; re-simulates those cases only) and link the
        case ids to them.
    list_cases : int
        Cases listed per system and kind in "Cases to look into" (0: none).
    say : callable, optional
        Progress lines.

    Returns
    -------
    Path
        ``report.md`` (next to ``report.html``, ``metrics.csv``,
        ``crosstabs.csv``, the PNG figures and the case pages).

    Raises
    ------
    DataError
        Not a study folder, or the study is not complete.
    """
    from vfs.study import RUNS_FILE, load_study

    result = load_study(study)
    if result.table is None:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{study}: the study is not complete (status "
                                    f"{result.manifest.get('status')!r}); finish it with "
                                    f"vfs study ... --resume (no {RUNS_FILE} yet)"))
    note("effectiveness of %d system(s) over %d cases, intervals from %d bootstrap "
         "resamples", len(result.manifest.get("system_names", [])),
         result.table["case_id"].nunique(), n_boot)
    eff = effectiveness(result.table, risk_curves=risk_curves, n_boot=n_boot,
                        confidence=confidence, seed=seed)
    folder = Path(out) if out is not None else result.path / "report"
    folder.mkdir(parents=True, exist_ok=True)
    note("drawing the figures")
    figures = write_figures(eff, folder) if baseline_crashes(eff) > 0 else {}
    manifest = {**result.manifest, "name": result.path.name}
    notable = notable_cases(eff, list_cases)
    pages: dict[Any, str] = {}
    problem = ""
    if case_pages:
        linked = [*notable["case_id"].tolist(), *eff.excluded["case_id"].head(50).tolist()]
        pages, problem = write_effectiveness_case_pages(folder, result, linked, say=say)
    cases = notable_blocks(eff, notable, pages, problem) if list_cases > 0 else []
    blocks = _report_blocks(eff, manifest, figures, cases, pages)
    ncap = study_tables(result)  # a study on the Euro NCAP matrix: the protocol's view
    if ncap is not None:
        blocks += euro_ncap_blocks(*ncap)
        write_euro_ncap_tables(folder, *ncap)
    note("writing the report")
    write_report(folder, Report(f"AEB effectiveness: {result.path.name}", tuple(blocks)))
    write_text(folder / "metrics.csv", eff.metrics.to_csv(index=False))
    cross = [(s, b, t, float(table.loc[b, t])) for s, table in eff.crosstabs.items()
             for b in table.index for t in table.columns]
    write_text(folder / "crosstabs.csv", pd.DataFrame(
        cross, columns=["system", "baseline_type", "treatment_type", "weight"]).to_csv(index=False))
    return folder / "report.md"


__all__ = ["LIST_CASES", "notable_blocks", "notable_cases", "write_effectiveness_report",
           "write_figures"]
