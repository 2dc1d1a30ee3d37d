"""Case pages: traces, exact replays of study cases, links from every report table, top views."""

from __future__ import annotations

import dataclasses
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from vfs.adas import get_system
from vfs.analysis.compare import compare_database
from vfs.database import open_database
from vfs.report.compare import write_comparison_report
from vfs.report.effectiveness import write_effectiveness_report
from vfs.report.figures import plot_case_topview
from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases
from vfs.study import load_study, run_study
from vfs.study.replay import replay_study_cases
from vfs.study.traces import simulate_with_traces

CASES = (10, 20, 50, 60, 150, 480)
WHERE = f"case_id IN {CASES}"


class _Page(HTMLParser):
    """Tables (header texts, rows of (cell text, hrefs)) and image sources of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[tuple[list[str], list[list[tuple[str, list[str]]]]]] = []
        self.images: list[str] = []
        self.links: list[str] = []
        self._cell: list[str] | None = None
        self._hrefs: list[str] = []
        self._row: list[tuple[str, list[str]]] | None = None
        self._in_head = False

    def handle_starttag(self, tag: str, attrs: list) -> None:
        a = dict(attrs)
        if tag == "table":
            self.tables.append(([], []))
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell, self._hrefs = [], []
        elif tag == "a":
            self.links.append(a.get("href", ""))
            if self._cell is not None:
                self._hrefs.append(a.get("href", ""))
        elif tag == "img":
            self.images.append(a.get("src", ""))

    def handle_endtag(self, tag: str) -> None:
        if tag == "thead":
            self._in_head = False
        elif tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append(("".join(self._cell).strip(), self._hrefs))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            head, rows = self.tables[-1]
            if self._in_head:
                head.extend(text for text, _ in self._row)
            else:
                rows.append(self._row)
            self._row = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def case_cells(page: _Page) -> list[tuple[str, list[str]]]:
    """Every cell of a column headed 'case' or 'case_id'."""
    cells = []
    for head, rows in page.tables:
        for k, name in enumerate(head):
            if name in ("case", "case_id"):
                cells += [row[k] for row in rows]
    return cells


def assert_linked(report: Path) -> int:
    """Every case id in a table of ``report`` links to an existing page whose images exist."""
    cells = case_cells(parse(report))
    assert cells, "no case column in the report"
    for text, hrefs in cells:
        assert hrefs, f"case {text} is not linked"
        target = report.parent / hrefs[0]
        assert target.is_file(), f"case {text}: {hrefs[0]} missing"
        assert target.name == f"{text}.html"
        page = parse(target)
        assert page.images, f"{target} has no figure"
        for src in page.images:
            assert (target.parent / src).is_file(), f"{target}: image {src} missing"
        assert any((target.parent / h).resolve() == report.resolve() for h in page.links)
    return len(cells)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Six cases, two systems (three-stage draws driver reactions), chunks of four."""
    out = tmp_path_factory.mktemp("study") / "s"
    run_study("default", ["three-stage", "ideal"], out, engine="serial", where=WHERE,
              chunk_size=4, progress=False)
    return load_study(out)


def test_recorder_changes_nothing_and_traces_the_braking():
    db = open_database("default", "case_id IN (10, 150)")
    batch = CaseBatch.from_database(db)
    system = get_system("three-stage")
    params = dataclasses.replace(SimulationParams(),
                                 precrash=system.precrash_params(SimulationParams().precrash))
    equipped = np.ones((batch.size, 2), bool)
    plain = simulate_cases(batch, system.controller(batch, equipped), params,
                           np.random.default_rng(3))
    traced, traces = simulate_with_traces(batch, system.controller(batch, equipped), params,
                                          np.random.default_rng(3))
    pd.testing.assert_frame_equal(results_table(batch, plain), results_table(batch, traced))
    dt = params.precrash.dt
    for k, trace in traces.items():
        assert np.allclose(np.diff(trace.t), dt)
        assert trace.t[0] == 0.0
        end = traced.precrash.impact_time[k]
        if np.isfinite(end):
            assert trace.t[-1] <= end + 1e-9
        for j in (0, 1):
            start = traced.precrash.brake_start[k, j]
            on = trace.t[trace.deceleration[:, j] > 0]
            if np.isnan(start):
                assert on.size == 0
            else:  # demanded at the brake start, delivered from the next step on
                asked = trace.t[np.nan_to_num(trace.demand[:, j]) > 0]
                assert asked.min() == pytest.approx(start, abs=1e-9)
                assert on.min() == pytest.approx(start + dt, abs=1e-9)
    base, btraces = simulate_with_traces(batch)
    pd.testing.assert_frame_equal(results_table(batch, simulate_cases(batch)),
                                  results_table(batch, base))
    assert np.isnan(btraces[0].demand).all() and (btraces[0].deceleration == 0).all()


def test_replay_reproduces_every_run_of_the_study(study):
    replays = replay_study_cases(study, [*CASES, 999999])
    assert list(replays) == list(CASES)
    for runs in replays.values():
        assert [r.system for r in runs] == ["baseline", "three-stage", "ideal"]
        for r in runs:
            assert r.reproduced is True and not r.error, (r.case_id, r.system)
            assert len(r.trace) > 0


def test_effectiveness_report_links_every_case_to_its_page(study, tmp_path):
    write_effectiveness_report(study.path, n_boot=50, out=tmp_path / "r", list_cases=1)
    assert assert_linked(tmp_path / "r" / "report.html") >= 2
    page = next((tmp_path / "r" / "cases").glob("*.html")).read_text(encoding="utf-8")
    for text in ("Runs and AEB events", "Impact", "Speed and braking over time",
                 "three-stage", "vfs run-case"):
        assert text in page
    write_effectiveness_report(study.path, n_boot=50, out=tmp_path / "plain", list_cases=2,
                               case_pages=False)
    assert not (tmp_path / "plain" / "cases").exists()
    cells = case_cells(parse(tmp_path / "plain" / "report.html"))
    assert cells and not any(hrefs for _, hrefs in cells)


def test_comparison_report_links_every_case_to_its_page(tmp_path):
    db = open_database("default", WHERE)
    comparison = compare_database(db)
    write_comparison_report(comparison, tmp_path / "c", database=db, top=2, sketches=0)
    assert assert_linked(tmp_path / "c" / "report.html") >= 2
    page = (tmp_path / "c" / "cases" / f"{comparison.case_errors['case_id'].iloc[0]}.html")
    text = page.read_text(encoding="utf-8")
    assert "vehicle 1 reconstruction" in text and "VFS - rec. 1" in text


def test_top_view_is_zoomed_on_the_impact_with_the_whole_path_inset():
    db = open_database("default", "case_id IN (150)")
    batch = CaseBatch.from_database(db)
    res = simulate_cases(batch)
    fig = plot_case_topview(batch, res, 0)
    ax = fig.axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    poi = res.precrash.poi[0]
    assert x0 < poi[0] < x1 and y0 < poi[1] < y1
    assert x1 - x0 <= 30.0 and y1 - y0 <= 30.0  # the crash, not the 100 m path
    path = np.c_[batch.paths.x[0, :batch.paths.count[0]], batch.paths.y[0, :batch.paths.count[0]]]
    assert np.ptp(path[:, 0]) > 2 * (x1 - x0) or np.ptp(path[:, 1]) > 2 * (y1 - y0)
    (inset,) = ax.child_axes
    (ix0, ix1), (iy0, iy1) = inset.get_xlim(), inset.get_ylim()
    assert ix0 <= path[:, 0].min() and path[:, 0].max() <= ix1
    assert iy0 <= path[:, 1].min() and path[:, 1].max() <= iy1
