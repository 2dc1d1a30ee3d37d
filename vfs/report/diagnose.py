"""Report of ``vfs diagnose``: tables, JSON summary, Markdown / HTML and figures.

:func:`write_diagnosis_report` writes what :func:`vfs.diagnosis.diagnose.diagnose`
found into a folder: the ranked candidates and the residual tables (CSV), the
JSON summary (:func:`vfs.diagnosis.diagnose.summary_dict`), ``report.md`` and
``report.html`` (:mod:`vfs.report.render`) and the figures (ranking, reduction
per output, residuals by impact type, top views of the worst cases), every
file atomically.  matplotlib is imported lazily (:mod:`vfs.report.figures`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.accident_types import accident_type_label
from vfs.atomic import write_json, write_table
from vfs.diagnosis.claims import LawFinding
from vfs.diagnosis.diagnose import Diagnosis, claim_label, summary_dict
from vfs.diagnosis.diagnose_spec import DiagnoseSpec
from vfs.diagnosis.selection import step_label
from vfs.report.figures import (
    new_figure,
    plot_case_topview,
    reconstruction_scene,
    save_figure,
)
from vfs.report.provenance import with_provenance
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
from vfs.simulation import SimulationParams

#: Format of the floating-point cells of the report tables.
FLOAT_FORMAT = "{:.3g}"
#: The confidence level of a summary written before it recorded its own (the declared
#: default of :attr:`DiagnoseSpec.confidence`).
CONFIDENCE = DiagnoseSpec().confidence


def _pct(x: float) -> str:
    return "" if not math.isfinite(x) else f"{100 * x:.1f}"


def write_diagnosis_report(diag: Diagnosis, out: str | Path, json_path: str | Path | None = None,
                 plots: bool = True, params: SimulationParams | None = None,
                 database: Any = None, database_reference: str | None = None
                 ) -> dict[str, Path]:
    """Write the diagnosis into the folder ``out``.

    Files: ``ranking.csv`` (ranked candidates), ``residuals_by_stratum.csv``,
    ``associations.csv`` (default model), ``associations_after_best.csv``,
    ``worst_cases.csv``, ``summary.json`` (and ``json_path`` if given),
    ``report.md``, ``report.html`` and ``figures/*.png`` (with ``plots``).  With the
    diagnosed ``database`` (``database_reference``: how the user named it) the report
    says where its numbers come from (:func:`vfs.report.provenance.with_provenance`).
    Returns the paths by name.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path] = {
        "ranking": write_table(folder / "ranking.csv", diag.ranked_table()),
        "strata": write_table(folder / "residuals_by_stratum.csv", diag.strata),
        "associations": write_table(folder / "associations.csv", diag.associations),
        "remaining": write_table(folder / "associations_after_best.csv", diag.remaining),
        "worst": write_table(folder / "worst_cases.csv", diag.worst),
    }
    summary = summary_dict(diag)
    paths["summary"] = write_json(folder / "summary.json", summary)
    if json_path is not None:
        paths["json"] = write_json(json_path, summary)
    figures: dict[str, str] = {}
    if plots:
        figures = diagnosis_figures(diag, folder / "figures", params=params)
    blocks = report_blocks(diag, figures)
    if database is not None:
        blocks = with_provenance(blocks, database, database_reference)
    written = write_report(folder, Report("Model diagnosis", tuple(blocks)))
    paths["markdown"] = written["report_md"]
    paths["html"] = written["report_html"]
    return paths


def diagnosis_figures(diag: Diagnosis, folder: str | Path,
                      params: SimulationParams | None = None) -> dict[str, str]:
    """Write the report figures (PNG) into ``folder``; paths relative to its parent.

    ranking (overall reduction with CIs), heatmap (reduction per output),
    strata (standardised residuals of the default model by impact type),
    case_* (top views of the worst cases with the recorded rest positions).
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    rel = out.name
    figs: dict[str, str] = {}
    d = diag.data
    cands = diag.candidates
    table = diag.selection_table()
    if len(table):
        fig = new_figure((7.5, 0.45 * len(table) + 1.5))
        ax = fig.subplots()
        y = np.arange(len(table))[::-1]
        est = 100 * table["alone"].to_numpy(float)
        lo = 100 * table["alone_low"].to_numpy(float)
        hi = 100 * table["alone_high"].to_numpy(float)
        colors = ["#2ca02c" if st == "claimed" else "#999999" for st in table["status"]]
        ax.barh(y, est, color=colors)
        ax.errorbar(est, y, xerr=[np.maximum(est - lo, 0), np.maximum(hi - est, 0)], fmt="none",
                    ecolor="k", capsize=3, lw=1)
        ax.set_yticks(y, [f"{n} ({st})" if st != "claimed" else n
                          for n, st in zip(table["candidate"], table["status"], strict=True)],
                      fontsize=7)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xlabel("cross-validated RMSE reduction alone [%] (green: claimed)")
        ax.set_title("Library effects and learned laws", fontsize=10)
        save_figure(fig, out / "ranking.png", dpi=110, tight=True)
        figs["ranking"] = f"{rel}/ranking.png"
    steps = diag.ledger_steps()
    if len(steps):
        figs["steps"] = f"{rel}/{_plot_steps(steps, out / 'selection_steps.png').name}"
    for k, f in enumerate(diag.laws[:3]):
        figs[f"law_{k}"] = f"{rel}/{_plot_law(diag, f, out / f'law_{f.channel}.png').name}"
    if cands:

        mat = np.array([[100 * c.per_output[g].estimate for g in d.group_names] for c in cands])
        fig = new_figure((1.0 + 0.8 * len(d.group_names), 0.45 * len(cands) + 2.0))
        ax = fig.subplots()
        lim = max(10.0, float(np.nanmax(np.abs(np.clip(mat, -100, 100)))) if mat.size else 10.0)
        im = ax.imshow(np.clip(mat, -lim, lim), cmap="RdYlGn", vmin=-lim, vmax=lim,
                       aspect="auto")
        ax.set_xticks(range(len(d.group_names)), d.group_names, rotation=45, ha="right",
                      fontsize=8)
        ax.set_yticks(range(len(cands)), [c.name for c in cands], fontsize=8)
        for i in range(mat.shape[0]):
            for j in range(mat.shape[1]):
                if math.isfinite(mat[i, j]):
                    ax.text(j, i, f"{mat[i, j]:.0f}", ha="center", va="center", fontsize=7)
        fig.colorbar(im, ax=ax, label="CV RMSE reduction [%]")
        ax.set_title("Reduction per output", fontsize=10)
        save_figure(fig, out / "heatmap.png", dpi=110, tight=True)
        figs["heatmap"] = f"{rel}/heatmap.png"

    kinds = diag.features["impact_type"].astype(str).to_numpy()
    z = diag.default.residuals / d.scales[d.column_group]
    fig = new_figure((1.0 + 0.9 * len(d.groups), 4))
    ax = fig.subplots()
    levels = sorted(set(kinds))
    width = 0.8 / max(len(levels), 1)
    for li, lev in enumerate(levels):
        data_ = []
        for k in range(len(d.groups)):
            v = z[kinds == lev][:, d.column_group == k].ravel()
            data_.append(v[np.isfinite(v)])
        pos = np.arange(len(d.groups)) + (li - (len(levels) - 1) / 2) * width
        bp = ax.boxplot([v if v.size else [np.nan] for v in data_], positions=pos,
                        widths=width * 0.9, showfliers=False, patch_artist=True)
        for patch in bp["boxes"]:
            patch.set_facecolor(("#1f77b4", "#ff7f0e", "#2ca02c")[li % 3])
            patch.set_alpha(0.6)
        ax.plot([], [], "s", color=("#1f77b4", "#ff7f0e", "#2ca02c")[li % 3], label=lev)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(d.groups)), d.group_names, rotation=45, ha="right", fontsize=8)
    ax.set_ylabel("standardised residual (model - reconstruction)")
    ax.set_title("Default model residuals by impact type (reconstruction)", fontsize=10)
    ax.legend(fontsize=8)
    save_figure(fig, out / "strata.png", dpi=110, tight=True)
    figs["strata"] = f"{rel}/strata.png"

    if len(diag.worst):
        from vfs.simulation import simulate_cases

        idx = diag.worst["index"].to_numpy(int)
        batch = d.batch.take(idx)
        res = simulate_cases(batch, params=params or SimulationParams())
        rec = d.reconstruction
        for k, i in enumerate(idx):
            row = diag.worst.iloc[k]
            fig = plot_case_topview(
                batch, res, k,
                title=(f"case {d.case_ids[i]} ({accident_type_label(row['accident_type'])}, "
                       f"{row['impact_type']} in the reconstruction): worst output "
                       f"{row['worst_output']}"),
                overlay=reconstruction_scene(batch, k, rec.iloc[i], overlay=True))
            name = f"case_{k + 1}_{d.case_ids[i]}.png"
            save_figure(fig, out / name, dpi=100)
            figs[f"case_{k + 1:02d}"] = f"{rel}/{name}"
    return figs


def _plot_steps(steps: pd.DataFrame, path: Path) -> Path:
    """The cross-validated RMSE of the joint model after each step of the selection."""
    fig = new_figure((max(4.0, 1.3 * len(steps) + 2), 3.6))
    ax = fig.subplots()
    x = np.arange(len(steps))
    v = steps["cv_rmse"].to_numpy(float)
    colors = [{"start": "#777777", "add": "#2ca02c", "relearn": "#1f77b4"}.get(a, "#d62728")
              for a in steps["action"]]
    ax.bar(x, v, color=colors)
    for i, val in enumerate(v):
        ax.text(i, val, f"{val:.3g}", ha="center", va="bottom", fontsize=8)
    labels = [step_label(a, n, " ")
              for a, n in zip(steps["action"], steps["candidate"], strict=True)]
    ax.set_xticks(x, labels, rotation=20, ha="right", fontsize=8)
    ax.set_ylabel("CV RMSE (standardised)")
    ax.set_title("The error step by step within the selection (green: claimed, blue: "
                 "re-learned given the later claims, red: dropped)",
                 fontsize=9)
    save_figure(fig, path, dpi=110, tight=True)
    return path


def _plot_law(diag: Diagnosis, finding: LawFinding, path: Path) -> Path:
    """Identified values of a channel over the law's feature, the law and the spline band."""
    from vfs.diagnosis.learn import law_rows
    from vfs.effects.learned import evaluate_law

    law = finding.learned.law
    table = finding.table if finding.table is not None else diag.identification
    t, y, _ = law_rows(table, finding.channel) \
        if table is not None else (pd.DataFrame(), np.array([]), None)
    fig = new_figure((6, 4))
    ax = fig.subplots()
    if len(t):
        ax.errorbar(t[law["feature"]], y, yerr=[y - t["low"], t["high"] - y], fmt="o", ms=2.5,
                    color="#999999", elinewidth=0.5, label="identified (chi^2 + 1 interval)")
    band = finding.learned.band
    if band:
        ax.fill_between(band["x"], band["low"], band["high"], color="#1f77b4", alpha=0.2,
                        label="smoothing spline, 95 % bootstrap band")
        ax.plot(band["x"], band["y"], color="#1f77b4", lw=1)
        xg = np.asarray(band["x"], float)
        ax.plot(xg, evaluate_law(law, xg), color="#d62728", lw=2, label=law["formula"][:60])
    ax.set_xlabel(f"{law['feature']} [{law['feature_unit']}]")
    ax.set_ylabel(f"{law['channel']} [{law['channel_unit']}]")
    ax.legend(fontsize=7)
    ax.set_title(f"Learned law of {law['channel']} ({finding.status})"
                 + (f"\nidentified with the law(s) of {', '.join(finding.on_top_of)} applied"
                    if finding.round else ""), fontsize=10)
    save_figure(fig, path, dpi=110, tight=True)
    return path


def _table(df: pd.DataFrame) -> Table:
    return Table.from_frame(df, floatfmt=FLOAT_FORMAT)


def summary_blocks(diag: Diagnosis) -> list[Block]:
    """The one-screen summary: the verdict's status first, then the headline figures.

    Says "Unreliable" when the sample is too small for any claim and "Unsure" when no
    candidate helps significantly; otherwise names the most likely missing effect with
    its cross-validated RMSE reduction and simultaneous interval.
    """
    s = diag.settings
    level = f"{100 * s.get('simultaneous_confidence', s.get('confidence', CONFIDENCE)):.1f} %"
    items: list[str] = []
    cands = diag.candidates

    def red(r: Any) -> str:
        return f"{100 * r.estimate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"

    table = diag.selection_table()
    rows = table.set_index("candidate") if len(table) else table
    claims = diag.claims
    if not diag.reliable:
        items.append(f"Unreliable: {diag.data.n} cases in {s.get('folds', '?')} folds are too "
                     "few for any claim; the figures below are shown, not concluded from.")
    if not len(table):
        items.append("Unsure: no candidate effect was tested.")
    elif not claims:
        best = table.sort_values("alone", ascending=False, kind="stable").iloc[0]
        what = "candidate effect" if not (table["kind"] == "law").any() \
            else "candidate effect or learned law"
        shown = (f"`{best['candidate']}`, lowers the cross-validated RMSE by "
                 f"{100 * best['alone']:.1f} % [{100 * best['alone_low']:.1f}, "
                 f"{100 * best['alone_high']:.1f}] (simultaneous {level} interval)")
        items.append(
            f"Unsure: no {what} helps significantly. The best alone, {shown}: its interval "
            f"includes 0 or the reduction stays below {100 * s.get('min_reduction', 0):.0f} %."
            if diag.reliable else
            f"Unsure: nothing is claimed with so few cases. The best alone, {shown}, is not "
            "trustworthy at this size.")
    else:
        lead = claims[0]
        r = rows.loc[lead]
        alone = (f"{100 * r['alone']:.1f} % [{100 * r['alone_low']:.1f}, "
                 f"{100 * r['alone_high']:.1f}]")
        if r["kind"] == "law":
            items.append(f"Most likely missing physics: {claim_label(diag, lead)} (learned). "
                         f"It lowers the cross-validated RMSE of all outputs by {alone} "
                         f"(simultaneous {level} interval).")
        else:
            b = next(c for c in cands if c.name == lead)
            items.append(f"Most likely missing effect: `{lead}`. It lowers the cross-validated "
                         f"RMSE of all outputs by {red(b.overall)} (simultaneous {level} "
                         f"interval) and of its own outputs by {red(b.affected)}.")
        for n in claims[1:]:
            x = rows.loc[n]
            items.append(f"Also claimed: {claim_label(diag, n)}, {100 * x['on_top']:.1f} % "
                         f"[{100 * x['on_top_low']:.1f}, {100 * x['on_top_high']:.1f}] on top "
                         f"of {x['on_top_of']}.")
        steps = diag.ledger_steps()
        items.append("Error step by step (CV RMSE, standardised): " + " -> ".join(
            ("default" if a == "start" else f"{'+' if a == 'add' else '-'}{n}") + f" {v:.3g}"
            for a, n, v in zip(steps["action"], steps["candidate"], steps["cv_rmse"],
                               strict=True)) + ".")
    rejected = table[~table["status"].isin(("claimed", "not significant",
                                            "too few cases for any claim"))] \
        if len(table) else table
    if len(rejected):
        items.append("Tried and rejected: " + ", ".join(
            f"`{n}` ({st})" for n, st in zip(rejected["candidate"].head(5),
                                             rejected["status"].head(5), strict=True)) + ".")
    d = diag.data
    rmse = np.asarray(diag.default.rmse(), float)
    if rmse.size and np.isfinite(rmse).any():
        k = int(np.nanargmax(rmse))
        items.append(f"Default model: cross-validated RMSE {diag.default.overall_rmse():.3g} "
                     f"(residuals divided by each output's scale); worst output "
                     f"{d.group_names[k]} ({rmse[k]:.3g}).")
    rem = diag.remaining[diag.remaining["significant"]] if len(diag.remaining) else \
        diag.remaining
    who = "the default model" if diag.remaining_model == "default" else diag.remaining_model
    if len(rem):
        r = rem.iloc[0]
        items.append(f"Unexplained structure remains with {who}: {len(rem)} significant "
                     f"residual-feature association(s), strongest {r['residual']} ~ "
                     f"{r['feature']}.")
    else:
        items.append(f"No significant residual-feature association remains with {who}.")
    return [Heading("In short", 2), BulletList(tuple(items)),
            Paragraph(f"{d.n} cases with a reconstruction, {s.get('folds', '?')}-fold "
                      "cross-validation by case; details and the full verdict below.")]


def _answer_figures(diag: Diagnosis, figures: dict[str, str]) -> list[Block]:
    """The figures of the one screen: the error step by step within the selection and the
    learned law of each claimed channel (curve, identified values, spline band).
    """
    out: list[Block] = []
    if "steps" in figures and len(diag.ledger_steps()) > 1:
        out.append(Figure(figures["steps"], "The cross-validated RMSE of the selected model "
                          "after each step of the selection (default model first)"))
    for k, f in enumerate(diag.laws[:3]):
        if f.significant and f"law_{k}" in figures:
            out.append(Figure(figures[f"law_{k}"], f"Claimed: {f.learned.law['formula']}"))
    return out


def report_blocks(diag: Diagnosis, figures: dict[str, str]) -> list[Block]:
    """The blocks of the diagnosis report (``figures``: key -> path relative to the report)."""
    d = diag.data
    s = diag.settings
    doc: list[Block] = [
        Heading("Model diagnosis", 1),
        *summary_blocks(diag),
        *_answer_figures(diag, figures),
        Paragraph(f"Database: {diag.database or '(in memory)'}; {d.n} cases with a "
                  f"reconstruction; {s['folds']}-fold cross-validation by case (seed "
                  f"{s['seed']}); outputs: {', '.join(d.group_names)}. Errors are RMSEs of "
                  "standardised residuals (model - reconstruction) / scale; the scale of an "
                  "output is the RMS of its recorded standard deviations (`_sd` columns) or "
                  "else the standard deviation of its recorded values. Ground-truth files are "
                  "never read."),
        Heading("Verdict", 2),
        BulletList(tuple(diag.verdict)),
        Heading("Which effect is missing: one selection over library effects and learned "
                "laws", 2),
    ]
    st_ = diag.ledger_steps()
    if len(st_):
        doc.append(_table(pd.DataFrame({
            "step": st_["step"], "action": st_["action"], "candidate": st_["candidate"],
            "model": st_["model"], "CV RMSE": st_["cv_rmse"],
            "reduction [%]": [f"{_pct(v)} ({_pct(lo)} .. {_pct(hi)})" if np.isfinite(v) else ""
                              for v, lo, hi in zip(st_["reduction"], st_["low"], st_["high"],
                                                   strict=True)]})))
    t = diag.selection_table()

    def cis(prefix: str) -> list[str]:
        return [f"{_pct(v)} ({_pct(lo)} .. {_pct(hi)})" if np.isfinite(v) else ""
                for v, lo, hi in zip(t[prefix], t[f"{prefix}_low"], t[f"{prefix}_high"],
                                     strict=True)]

    if len(t):
        doc.append(_table(pd.DataFrame({
            "candidate": t["candidate"], "kind": t["kind"], "status": t["status"],
            "alone [%]": cis("alone"), "on top [%]": cis("on_top"),
            "on top of": t["on_top_of"], "claims refitted with it [%]": cis("refit"),
            "share in the selected model [%]": cis("share"), "model": t["model"]})))
    doc.append(Paragraph(
        f"Default model: CV RMSE {diag.default.overall_rmse():.3g} (standardised, all "
        f"outputs). Simultaneous "
        f"{100 * s['simultaneous_confidence']:.2f} % CIs (Bonferroni over all {len(t)} "
        "candidates). One forward stepwise selection: each step adds the candidate with the "
        "largest reduction on top of the claims if its CI lies above 0 and the reduction "
        f"reaches {100 * s['min_reduction']:.0f} %, and the claims refitted together with it "
        "still help; after each addition every earlier claim is re-tested given the others "
        "and dropped if it no longer helps. 'share': the selected model against it without "
        "the claim. 'mimics X': helped alone, not on top of X."
        + ("" if diag.reliable else " UNRELIABLE: too few cases or folds, nothing is "
           "claimed.")))
    if diag.candidates:
        per = pd.DataFrame({"output": list(d.group_names),
                            "default CV RMSE": diag.default.rmse()})
        for c in diag.candidates[:min(4, len(diag.candidates))]:
            per[f"{c.name} [%]"] = [
                f"{_pct(r.estimate)} ({_pct(r.low)} .. {_pct(r.high)})"
                for r in c.per_output.values()]
        doc += [Heading("Reduction per output (best candidates; pointwise CIs)", 3), _table(per)]
    for key, caption in (("ranking", "Candidate ranking: cross-validated RMSE reduction with "
                                     "simultaneous CIs (green: helps significantly)"),
                         ("heatmap", "Reduction per output"),
                         ("profiles", "Objective along each candidate's parameter")):
        if key in figures:
            doc.append(Figure(figures[key], caption))
    if diag.identification is not None:
        doc.append(Heading("Beyond the library: identified channels and learned laws", 2))
        if diag.laws:
            doc.append(_table(pd.DataFrame({
                "channel": [f.channel for f in diag.laws],
                "law": [f.learned.law["formula"] for f in diag.laws],
                "identified with": ["+".join(f.on_top_of) or "the default model"
                                    for f in diag.laws],
                "vs null on identified values [%]": [_pct(f.learned.reduction)
                                                     for f in diag.laws],
                "status": [f.status for f in diag.laws]})))
            doc.append(Paragraph(
                "Each law is a candidate of the one selection above (its outcome reductions "
                "are in that table); on top of claims its channel is re-identified with the "
                "claims applied and its law learned anew. The figures show the law with the "
                "identified values and the smoothing spline's bootstrap band."))
        else:
            doc.append(Paragraph("No identified channel shows a law."))
        for k, f in enumerate(diag.laws[:3]):
            if f"law_{k}" in figures and not f.significant:
                doc.append(Figure(figures[f"law_{k}"], f.text()))
    doc += [
        Heading("Where the model fails", 2),
        _table(pd.DataFrame({"output": list(d.group_names),
                             "CV RMSE (standardised)": diag.default.rmse(),
                             "scale": d.scales,
                             "scale from": list(d.scale_source),
                             "unit": [g.quantity.si_unit for g in d.groups]})),
    ]
    if "strata" in figures:
        doc.append(Figure(figures["strata"], "Standardised residuals of the default model by "
                          "impact type (reconstruction)"))
    st = diag.strata
    if len(st):
        piv = (st.drop_duplicates(["feature", "stratum", "output"])
               .pivot_table(index=["feature", "stratum"], columns="output", values="rmse_std",
                            sort=False))
        n = st.drop_duplicates(["feature", "stratum"]).set_index(["feature", "stratum"])["n"]
        piv.insert(0, "n", n.reindex(piv.index).to_numpy())
        piv = piv.reset_index()
        is_type = piv["feature"] == "accident_type"
        piv.loc[is_type, "stratum"] = [accident_type_label(s) for s in piv.loc[is_type, "stratum"]]
        doc += [Heading("Standardised RMSE by stratum (default model)", 3), _table(piv)]
    columns = ["residual", "feature", "test", "n", "statistic", "p_adj"]
    a = diag.associations
    sig = a[a["significant"]] if len(a) else a
    doc += [
        Heading("Residual-feature associations (default model)", 3),
        Paragraph(f"{len(sig)} of {len(a)} tests significant ({s['correction'].upper()}, "
                  f"alpha = {s['alpha']:g}); Spearman's rho for numeric features, "
                  "Kruskal-Wallis epsilon^2 for categorical ones."),
    ]
    if len(sig):
        doc.append(_table(sig.head(25)[columns]))
    doc.append(Heading(f"Residual structure after {diag.remaining_model}", 3))
    r = diag.remaining
    rs = r[r["significant"]] if len(r) else r
    doc.append(_table(rs.head(25)[columns]) if len(rs)
               else Paragraph("No significant association."))
    doc.append(Heading("Worst cases (default model)", 3))
    if len(diag.worst):
        worst = diag.worst.drop(columns=["index"])
        if "accident_type" in worst.columns:
            worst = worst.assign(accident_type=[accident_type_label(v)
                                                for v in worst["accident_type"]])
        doc.append(_table(worst))
    for k, key in enumerate(sorted(k for k in figures if k.startswith("case_")), start=1):
        doc.append(Figure(figures[key], f"Worst case {k}: top view of the default model, "
                          "zoomed on the impact (inset: the whole path); grey: the "
                          "reconstruction's POI, contact plane and rest positions"))
    st2 = diag.stats
    doc += [
        Heading("Cost", 2),
        Paragraph(f"{st2.get('variants', 0)} model variants simulated "
                  f"({st2.get('case_runs', 0)} case runs in {st2.get('calls', 0)} calls, "
                  f"{st2.get('seconds', 0):.1f} s); total {st2.get('total_seconds', 0):.1f} s."),
    ]
    return doc


__all__ = ["FLOAT_FORMAT", "diagnosis_figures", "report_blocks", "summary_blocks",
           "write_diagnosis_report"]
