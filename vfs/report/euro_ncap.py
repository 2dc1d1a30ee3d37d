"""Euro NCAP view of studies: the protocol's scores and the side-by-side table.

* :func:`euro_ncap_blocks`: the report section of a study on a Euro NCAP
  matrix (``vfs study --db euro-ncap-c2c``, or ``euro-ncap-c2c-2023``): scores
  per scenario and system, the total, and per system and scenario the result
  grid a test engineer reads (rows VUT speed, columns GVT speed and impact
  location / overlap / braking; each cell the measure in km/h, coloured by its
  band in HTML as the rating tool colours its matrices), with the FCW timing;
  :func:`vfs.report.effectiveness.write_effectiveness_report` adds it and
  writes ``euro_ncap_tests.csv`` and ``euro_ncap_scores.csv``.
* :func:`side_by_side` / :func:`write_side_by_side` (``vfs report side-by-side
  --ncap STUDY --accidents STUDY --out DIR``): for each system, its Euro
  NCAP-style result beside its avoided crashes and injury-risk reduction on an
  accident database, as ``side_by_side.csv``, ``side_by_side.md`` and
  ``side_by_side.html``.

Scoring: :mod:`vfs.analysis.euro_ncap`; protocol and sources:
``scenarios/euro-ncap-c2c/protocol.toml``; docs/euro-ncap.md.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd

from vfs.analysis.effectiveness import ALL, effectiveness
from vfs.analysis.euro_ncap import (
    assess_tests,
    is_euro_ncap_cases,
    protocols_of,
    scenario_scores,
    speed_grid,
)
from vfs.atomic import write_text
from vfs.errors import DataError, DataProblem
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
from vfs.study.manifest import StudyResult

#: Files written next to report.md for a study on the matrix.
TESTS_FILE = "euro_ncap_tests.csv"
SCORES_FILE = "euro_ncap_scores.csv"
#: Stem of the side-by-side files (.csv, .md, .html).
SIDE_BY_SIDE = "side_by_side"


def _table(frame: pd.DataFrame) -> Table:
    return Table(tuple(str(c) for c in frame.columns),
                 tuple(tuple("" if pd.isna(v) else str(v) for v in row)
                       for row in frame.itertuples(index=False)))


def study_tables(study: str | os.PathLike[str] | StudyResult
                 ) -> tuple[pd.DataFrame, pd.DataFrame] | None:
    """Test assessments and scenario scores of a finished study; None if not the NCAP matrix.

    Parameters
    ----------
    study : path or StudyResult
        Study folder, or the study already loaded (its runs are not read again).

    Raises
    ------
    DataError
        Not a study folder, or not complete.
    """
    from vfs.study import CASES_FILE, load_study

    result = study if isinstance(study, StudyResult) else load_study(study)
    cases_file = result.path / CASES_FILE
    cases = pd.read_parquet(cases_file) if cases_file.exists() else pd.DataFrame()
    if not is_euro_ncap_cases(cases):
        return None
    if result.table is None:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{result.path}: the study is not complete"))
    tests = assess_tests(result.table, cases)
    return tests, scenario_scores(tests)


def score_table(scores: pd.DataFrame) -> pd.DataFrame:
    """Systems x scenarios: ``score / max (pct)`` cells."""
    cells = scores.assign(cell=[f"{s:.2f} / {m:g} ({p:.0f} %)" for s, m, p in
                                zip(scores["score"], scores["max_score"], scores["score_pct"],
                                    strict=True)])
    table = cells.pivot_table(index="system", columns="scenario", values="cell",
                              aggfunc="first", sort=False)
    order = [s for s in cells["scenario"].unique()]
    return table[order].reset_index()


def _fcw_text(sub: pd.DataFrame) -> str:
    warned = sub["fcw_ttc_s"].dropna()
    if warned.empty:
        return "no warning"
    return (f"{len(warned)} of {len(sub)} tests warned, TTC at the warning "
            f"{warned.min():.2f}-{warned.max():.2f} s (median {warned.median():.2f} s)")


def euro_ncap_blocks(tests: pd.DataFrame, scores: pd.DataFrame) -> list[Block]:
    """Report section of a study on a Euro NCAP matrix (one protocol version)."""
    protocols = protocols_of(tests.rename(columns={"protocol": "ncap_protocol"}))
    blocks: list[Block] = [Heading("Euro NCAP Car-to-Car", 2)]
    for version, protocol in protocols.items():
        info = protocol["protocol"]
        mine = tests[tests["protocol"] == version]
        blocks += [
            Paragraph(f"Protocol version {version}. Test matrix: {info['test_protocol']}; "
                      f"assessment: {info['assessment']}. Every test is a case (participant "
                      "1 the VUT carrying the system, 2 the global vehicle target); each test "
                      "scores by its colour band (green 1, yellow 0.75, orange 0.5, brown "
                      "0.25, red 0 points), a scenario its maximum points times the mean of "
                      "its tests. Values not read in the protocol texts are ASSUMPTIONS "
                      "listed in the protocol file (scenarios/euro-ncap-c2c/) and "
                      "docs/euro-ncap.md."),
            Heading("Scores (points / maximum)", 3),
            _table(score_table(scores[scores["protocol"] == version])),
        ]
        items = []
        for name, sc in protocol["scenarios"].items():
            measure = sc["measure"].replace("_", " ")
            rule = {"mitigation": "bands of the speed reduction",
                    "avoidance": "avoidance: any contact red (a VUT hit while standing too)",
                    "mitigation_or_avoidance": "mitigation-or-avoidance bands, row by VUT "
                    "speed"}[sc["band"]]
            items.append(f"{name}: {sc['description']}; measure: {measure} [km/h]; {rule}")
        blocks.append(BulletList(tuple(items)))
        scored = "scored" if protocol["assessment"].get("fcw_scored") else "reported, not scored"
        for system in [s for s in mine["system"].unique() if s != "baseline"]:
            blocks.append(Heading(f"Result sheet: {system}", 3))
            for name in protocol["scenarios"]:
                values, colours = speed_grid(mine, system, name)
                if values.empty:
                    continue
                sub = mine[(mine["system"] == system) & (mine["scenario"] == name)]
                measure = protocol["scenarios"][name]["measure"].replace("_", " ")
                own = scores[(scores["system"] == system) & (scores["scenario"] == name)
                             & (scores["protocol"] == version)].iloc[0]
                blocks.append(Paragraph(
                    f"**{name}**: {own['score']:.2f} / {own['max_score']:g} points "
                    f"({own['score_pct']:.0f} %); rows VUT speed [km/h] (0: start from "
                    f"stop; with the GVT speed where one per row), cells the {measure} [km/h]"
                    f" and its colour; FCW ({scored}): {_fcw_text(sub)}."))
                rows = tuple((str(v), *(f"{c} {k}" if c else "" for c, k in
                                          zip(values.loc[v], colours.loc[v], strict=True)))
                             for v in values.index)
                classes = tuple(("", *(f"band-{k}" if k else "" for k in colours.loc[v]))
                                for v in values.index)
                blocks.append(Table(("VUT km/h", *map(str, values.columns)), rows,
                                    cell_classes=classes))
    return blocks


def write_euro_ncap_tables(folder: str | os.PathLike[str], tests: pd.DataFrame,
                           scores: pd.DataFrame) -> None:
    """Write :data:`TESTS_FILE` and :data:`SCORES_FILE` into ``folder``."""
    out = Path(folder)
    write_text(out / TESTS_FILE, tests.to_csv(index=False))
    write_text(out / SCORES_FILE, scores.to_csv(index=False))


def side_by_side(ncap_study: str | os.PathLike[str], accident_study: str | os.PathLike[str],
                 *, n_boot: int = 2000, seed: int = 0, confidence: float = 0.95
                 ) -> pd.DataFrame:
    """Each system's Euro NCAP result beside its effect on an accident database.

    Parameters
    ----------
    ncap_study : path
        Finished study on ``--db euro-ncap-c2c``.
    accident_study : path
        Finished study on an accident database (e.g. ``--db default``).
    n_boot, seed, confidence
        Bootstrap settings of the accident-based intervals.

    Returns
    -------
    pandas.DataFrame
        One row per system found in both studies: the Euro NCAP total
        (points, maximum, percent), the percent of each scenario, tests
        avoided; on the accident database the share of baseline crashes
        avoided and the net crash reduction (point estimates and interval
        bounds), and the relative reduction of the expected injured drivers
        per injury level.

    Raises
    ------
    DataError
        ``ncap_study`` is not a study on the Euro NCAP matrix, or a study is incomplete.
    """
    from vfs.study import load_study

    tables = study_tables(ncap_study)
    if tables is None:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{ncap_study}: not a study on the Euro NCAP matrix "
                                    "(run vfs study --db euro-ncap-c2c)"))
    _, scores = tables
    accidents = load_study(accident_study)
    if accidents.table is None:
        raise DataError(DataProblem("study", "", None, None,
                                    f"{accident_study}: the study is not complete"))
    eff = effectiveness(accidents.table, n_boot=n_boot, confidence=confidence, seed=seed)
    accident_systems = [p.system for p in eff.pairs]
    m = eff.metrics[eff.metrics["group"] == ALL]
    rows: list[dict[str, Any]] = []
    for system in [s for s in scores["system"].unique() if s != "baseline"]:
        if system not in accident_systems:
            continue
        own = scores[scores["system"] == system].set_index("scenario")
        row: dict[str, Any] = {"system": system,
                               "ncap_protocol": str(own.loc["total", "protocol"]),
                               "ncap_points": float(own.loc["total", "score"]),
                               "ncap_max_points": float(own.loc["total", "max_score"]),
                               "ncap_pct": float(own.loc["total", "score_pct"]),
                               "ncap_tests_avoided": int(own.loc["total", "avoided"]),
                               "ncap_tests": int(own.loc["total", "tests"])}
        for name in own.index:
            if name != "total":
                row[f"ncap_{name}_pct"] = float(own.loc[name, "score_pct"])
        mine = m[m["system"] == system].set_index("metric")
        for metric in ("avoided_share", "crash_reduction",
                       *sorted(x for x in mine.index if x.startswith("risk_")
                               and x.endswith("_reduction"))):
            if metric in mine.index:
                row[f"acc_{metric}"] = float(mine.loc[metric, "estimate"])
                row[f"acc_{metric}_low"] = float(mine.loc[metric, "low"])
                row[f"acc_{metric}_high"] = float(mine.loc[metric, "high"])
        rows.append(row)
    return pd.DataFrame(rows)


def _pct_ci(row: pd.Series, key: str) -> str:
    if f"acc_{key}" not in row or pd.isna(row[f"acc_{key}"]):
        return "-"
    return (f"{100 * row[f'acc_{key}']:.1f} [{100 * row[f'acc_{key}_low']:.1f}, "
            f"{100 * row[f'acc_{key}_high']:.1f}]")


def side_by_side_display(table: pd.DataFrame) -> pd.DataFrame:
    """The side-by-side table formatted for reading (percent, intervals in brackets)."""
    risks = sorted({c.removeprefix("acc_").removesuffix("_low") for c in table.columns
                    if c.startswith("acc_risk_") and c.endswith("_low")})
    scen = [c for c in table.columns if c.startswith("ncap_") and c.endswith("_pct")
            and c != "ncap_pct"]
    out = pd.DataFrame({"system": table["system"]})
    out["Euro NCAP points"] = [f"{p:.2f} / {m:g}" for p, m in
                               zip(table["ncap_points"], table["ncap_max_points"], strict=True)]
    out["Euro NCAP %"] = table["ncap_pct"].map(lambda v: f"{v:.1f}")
    for c in scen:
        out[f"{c.removeprefix('ncap_').removesuffix('_pct')} %"] = table[c].map(
            lambda v: f"{v:.0f}")
    out["NCAP tests avoided"] = [f"{a} / {n}" for a, n in
                                 zip(table["ncap_tests_avoided"], table["ncap_tests"],
                                     strict=True)]
    out["accidents: crashes avoided %"] = [_pct_ci(r, "avoided_share")
                                           for _, r in table.iterrows()]
    out["accidents: net crash reduction %"] = [_pct_ci(r, "crash_reduction")
                                               for _, r in table.iterrows()]
    for key in risks:
        level = key.removeprefix("risk_").removesuffix("_reduction")
        out[f"accidents: {level} risk reduction %"] = [_pct_ci(r, key)
                                                        for _, r in table.iterrows()]
    return out


def side_by_side_figure(table: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """The test score against the accident benefit, one labelled point per system (PNG).

    Two panels over the Euro NCAP total [%]: the share of the accident study's baseline
    crashes avoided [%], and the relative reduction of the expected MAIS3+ injured drivers
    [%] (where the study has it), each with its interval as a vertical bar.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`side_by_side`'s table.
    path : path
        The PNG file.
    """
    from vfs.report.figures import new_figure, save_figure

    panels = [("avoided_share", "accident crashes avoided [%]")]
    if "acc_risk_MAIS3+_reduction" in table.columns:
        panels.append(("risk_MAIS3+_reduction", "MAIS3+ risk reduction, accidents [%]"))
    fig = new_figure((4.6 * len(panels), 4.2), layout="constrained")
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    x = table["ncap_pct"].to_numpy(float)
    for ax, (key, label) in zip(axes, panels, strict=True):
        y = 100 * table[f"acc_{key}"].to_numpy(float)
        low = 100 * table[f"acc_{key}_low"].to_numpy(float)
        high = 100 * table[f"acc_{key}_high"].to_numpy(float)
        ax.errorbar(x, y, yerr=[y - low, high - y], fmt="o", color="#1f4e79", ecolor="#7a9cc6",
                    capsize=3, ms=6)
        for xi, yi, name in zip(x, y, table["system"].astype(str), strict=True):
            ax.annotate(name, (xi, yi), xytext=(6, 4), textcoords="offset points", fontsize=9)
        ax.set_xlabel("Euro NCAP test score [% of the maximum points]")
        ax.set_ylabel(label)
        ax.set_xlim(0, 105)
        ax.set_ylim(0, 105)
        ax.plot([0, 100], [0, 100], color="0.8", lw=0.8, ls="--", zorder=0)
        ax.grid(alpha=0.3)
    return save_figure(fig, path)


def write_side_by_side(ncap_study: str | os.PathLike[str],
                       accident_study: str | os.PathLike[str],
                       out: str | os.PathLike[str], *, n_boot: int = 2000, seed: int = 0,
                       confidence: float = 0.95) -> Path:
    """Write ``side_by_side.csv`` (raw), ``.md`` and ``.html`` (formatted) and the figure
    ``side_by_side.png`` (:func:`side_by_side_figure`) into ``out``.

    Returns
    -------
    Path
        The markdown file.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    table = side_by_side(ncap_study, accident_study, n_boot=n_boot, seed=seed,
                         confidence=confidence)
    write_text(folder / f"{SIDE_BY_SIDE}.csv", table.to_csv(index=False))
    side_by_side_figure(table, folder / f"{SIDE_BY_SIDE}.png")
    shown = side_by_side_display(table)
    ncap_cols = ["system", *(c for c in shown.columns if not c.startswith("accidents: ")
                             and c != "system")]
    accident_cols = ["system", *(c.removeprefix("accidents: ") for c in shown.columns
                                 if c.startswith("accidents: "))]
    accidents_shown = shown.rename(columns=lambda c: c.removeprefix("accidents: "))
    pct = int(round(100 * confidence))
    versions = ", ".join(sorted(table["ncap_protocol"].astype(str).unique()))
    blocks: list[Block] = [
        Heading("Euro NCAP result and accident-based effectiveness, side by side", 1),
        Paragraph(f"Euro NCAP: study `{Path(ncap_study).name}` on the Car-to-Car test "
                  f"matrix of protocol {versions} "
                  "(scenarios/euro-ncap-c2c/; colour bands, points and maxima of that "
                  f"version's file). Accidents: study `{Path(accident_study).name}`: share of its "
                  f"baseline crashes avoided, net crash reduction (avoided minus new) and "
                  f"relative reduction of the expected injured drivers per injury level, with "
                  f"{pct} % intervals ({n_boot} bootstrap resamples, seed {seed}; "
                  "docs/statistics.md)."),
        Figure(f"{SIDE_BY_SIDE}.png", "Test score against accident benefit, one point per "
               "system: share of the accident study's baseline crashes avoided and MAIS3+ "
               "risk reduction over the Euro NCAP total, with their intervals (dashed: equal "
               "percentages).", alt="Scatter plot of the accident benefit over the Euro "
               "NCAP score, one labelled point per system"),
        Heading("Euro NCAP", 2),
        _table(shown[ncap_cols]),
        Heading("Accidents", 2),
        _table(accidents_shown[accident_cols]),
    ]
    write_report(folder, Report("Euro NCAP and accidents, side by side", tuple(blocks)),
                 name=SIDE_BY_SIDE)
    return folder / f"{SIDE_BY_SIDE}.md"


__all__ = ["SCORES_FILE", "SIDE_BY_SIDE", "TESTS_FILE", "euro_ncap_blocks", "score_table",
           "side_by_side", "side_by_side_display", "side_by_side_figure", "study_tables",
           "write_euro_ncap_tables", "write_side_by_side"]
