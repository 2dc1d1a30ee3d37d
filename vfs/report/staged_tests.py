"""The staged-test section of the ``vfs compare`` report (:mod:`vfs.analysis.staged_tests`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from vfs.analysis.staged_tests import staged_summary
from vfs.report.case_pages import case_link
from vfs.report.render import Block, Heading, Paragraph, Table
from vfs.units import KMH_PER_MS

if TYPE_CHECKING:  # pragma: no cover
    from vfs.analysis.compare import Comparison


def _num(value: float) -> str:
    """A number with one decimal for the table; empty for NaN."""
    return "" if not np.isfinite(value) else f"{value:.1f}"


def staged_blocks(c: Comparison, pages: dict[Any, str] | None = None) -> list[Block]:
    """Staged tests: delta-v, heading-change and range errors per test and vehicle, with the
    published errors of other codes on the same tests where the database gives them.
    """
    st = c.staged
    if st is None or len(st) == 0:
        return []
    codes = [name[: -len("_range_error")] for name in st.columns
             if name.endswith("_range_error") and name != "range_error"]

    def pct(v: float) -> str:
        return "" if not np.isfinite(v) else f"{100 * v:.1f} %"

    def deg(v: float) -> str:
        return "" if not np.isfinite(v) else f"{np.degrees(v):.1f}"

    rows = []
    for r in st.itertuples(index=False):
        d = r._asdict()
        rows.append((case_link(r.case_id, pages), f"{r.vehicle}",
                     _num(r.measured_delta_v * KMH_PER_MS),
                     _num(r.model_delta_v * KMH_PER_MS), pct(r.delta_v_error),
                     deg(r.measured_heading_change), deg(r.model_heading_change),
                     deg(r.heading_change_error), _num(r.runout_range),
                     _num(r.rest_distance), pct(r.range_error),
                     *(pct(d.get(f"{code}_range_error", np.nan)) for code in codes)))
    summary = staged_summary(st)
    srows = [(r.code, r.metric, f"{r.n}",
              deg(r.mean) if r.metric == "heading_change_error" else pct(r.mean))
             for r in summary.itertuples(index=False)]
    return [
        Heading("Staged tests: delta-v, heading change and rest positions", 2),
        Paragraph("Per test and vehicle: delta-v [km/h] and its relative error, the change "
                  "of heading from the impact to rest [deg] and its error, the measured "
                  "impact-to-rest distance [m], the distance between the model's and the "
                  "measured rest position [m] and the range error (that distance over the "
                  "measured one); the last columns: other codes' published range errors on "
                  "the same tests. Files: `staged_tests.csv`, `staged_summary.csv`."),
        Table(("case", "vehicle", "delta-v measured", "delta-v vfs", "delta-v error",
               "heading change measured", "heading change vfs", "heading error [deg]",
               "run-out [m]", "rest miss [m]", "range error",
               *(f"{code} range error" for code in codes)), tuple(rows)),
        Table(("code", "metric", "n", "mean"), tuple(srows)),
    ]
