"""Case pages: one small HTML page per case linked from the report tables.

``vfs report effectiveness`` and ``vfs compare`` link every case id in their
tables (:func:`case_link`) to ``cases/<id>.html`` beside the report, written by
:func:`write_effectiveness_case_pages` and :func:`write_comparison_case_pages`:

* the outcome of every run in one sentence each and in a table (speeds in km/h,
  angles in degrees, times in seconds since the start of the record);
* the impact table per run and vehicle: impact speed, delta-v, EES, PDOF, impact type;
* top views of every run side by side, each zoomed on the impact with the whole path
  as an inset (:func:`vfs.report.figures.plot_scenes`); for ``vfs compare`` the
  simulation beside the reconstruction;
* speed and brake deceleration (delivered and demanded) over time per vehicle, the
  baseline and each system in one chart, the AEB events (warning, partial and full
  braking, the driver's braking) as vertical lines and the impact as a cross
  (:func:`plot_case_traces`).

The time series come from re-simulating only the linked cases
(:func:`vfs.study.replay.replay_study_cases`, :mod:`vfs.study.traces`); the tables
show the numbers of the study or comparison itself.  Pages are written atomically
and use the reports' stylesheet (:func:`vfs.report.render.render_html`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vfs.accident_types import accident_type_label
from vfs.atomic import write_text
from vfs.report.figures import (
    RUN_COLORS,
    case_scene,
    new_figure,
    plot_scenes,
    reconstruction_scene,
    save_figure,
)
from vfs.report.provenance import database_argument, database_label
from vfs.report.render import (
    Block,
    BulletList,
    Code,
    Figure,
    Heading,
    Note,
    Paragraph,
    Table,
    render_html,
)
from vfs.units import KMH_PER_MS

#: Folder of the case pages, beside the report.
CASES_DIR = "cases"

#: AEB events shown on the traces: run-table key -> (label, letter on the chart).
EVENT_STYLES: dict[str, tuple[str, str]] = {
    "warning_time": ("warning", "W"),
    "partial_time": ("partial braking", "P"),
    "full_time": ("full braking", "F"),
    "driver_brake_time": ("driver brakes", "D"),
}

#: Seconds shown before the first AEB event or, without one, before the first impact.
TRACE_LEAD_TIME = 3.0

_DEG = math.degrees(1.0)


def case_file(case_id: Any) -> str:
    """The page of a case relative to the report: ``cases/<id>.html``.

    Examples
    --------
    >>> case_file(42), case_file("A/7 b")
    ('cases/42.html', 'cases/A_7_b.html')
    """
    return f"{CASES_DIR}/{re.sub(r'[^A-Za-z0-9_.-]', '_', str(case_id))}.html"


def case_link(case_id: Any, pages: Mapping[Any, str] | None = None) -> str:
    """The case id as a table cell: a link to its page when ``pages`` has it, else plain.

    Examples
    --------
    >>> case_link(42, {42: "cases/42.html"})
    '[42](cases/42.html)'
    """
    if pages is not None and case_id in pages:
        return f"[{case_id}]({pages[case_id]})"
    return str(case_id)


@dataclass(frozen=True)
class PageRun:
    """One run shown on a case page.

    Attributes
    ----------
    label : str
        ``"baseline"``, a system's name or ``"VFS"``.
    color : str
        Its colour in the trace chart.
    row : pandas.Series or None
        Its outcome (a run-table row, SI units) shown in the tables.
    batch, results, index
        The re-simulated run (for the top view and the traces); None when it failed.
    trace : RunTrace or None
        Speeds, decelerations and poses per step.
    note : str
        Why the run is missing or differs from the table (empty when fine).
    """

    label: str
    color: str
    row: pd.Series | None
    batch: Any = None
    results: Any = None
    index: int = 0
    trace: Any = None
    note: str = ""


def _f(row: pd.Series | None, key: str) -> float:
    if row is None or key not in row.index:
        return float("nan")
    v = row[key]
    try:
        return float("nan") if pd.isna(v) else float(v)
    except (TypeError, ValueError):
        return float("nan")


def _num(v: float, digits: int = 1, factor: float = 1.0) -> str:
    return "-" if not math.isfinite(v) else f"{v * factor:.{digits}f}"


def _pair(row: pd.Series | None, key: str, digits: int = 1, factor: float = 1.0) -> str:
    one, two = (_num(_f(row, f"{key}{j}"), digits, factor) for j in (1, 2))
    return f"{one} / {two}"


def _true(row: pd.Series | None, key: str) -> bool:
    if row is None or key not in row.index or pd.isna(row[key]):
        return False
    return bool(row[key])


def _kind(row: pd.Series | None, default: str) -> str:
    """The run's impact type, or ``default`` where it has none."""
    if row is None or "impact_type" not in row.index:
        return default
    v = row["impact_type"]
    return default if v is None or (not isinstance(v, str) and pd.isna(v)) or not v else str(v)


def _collided(row: pd.Series | None) -> bool:
    return _true(row, "collided")


def _failed(row: pd.Series | None) -> str:
    if row is None:
        return "no result"
    err = row.get("error", "")
    return str(err) if isinstance(err, str) and err else ""


def _events_text(row: pd.Series | None) -> str:
    parts = []
    for j in (1, 2):
        ev = [f"{label} {_f(row, f'{key}{j}'):.2f} s" for key, (label, _) in EVENT_STYLES.items()
              if math.isfinite(_f(row, f"{key}{j}"))]
        if ev:
            parts.append(f"vehicle {j}: " + ", ".join(ev))
    return "; ".join(parts)


def outcome_sentence(run: PageRun, baseline: pd.Series | None = None) -> str:
    """One sentence on a run's outcome (km/h), compared with the baseline when given."""
    row = run.row
    err = _failed(row)
    if err:
        return f"`{run.label}`: the run failed ({err})."
    if _collided(row):
        kind = _kind(row, "no impulse")
        text = (f"`{run.label}`: {kind} impact at {_pair(row, 'impact_speed', 0, KMH_PER_MS)} "
                f"km/h (vehicle 1 / 2), delta-v {_pair(row, 'delta_v', 1, KMH_PER_MS)} km/h")
        if baseline is not None and _collided(baseline):
            before = max(_f(baseline, "impact_speed1"), _f(baseline, "impact_speed2"))
            now = max(_f(row, "impact_speed1"), _f(row, "impact_speed2"))
            if math.isfinite(before) and math.isfinite(now) and abs(before - now) > 1e-6:
                text += (f"; impact speed {(before - now) * KMH_PER_MS:.1f} km/h lower than "
                         "the baseline's" if now < before else
                         f"; impact speed {(now - before) * KMH_PER_MS:.1f} km/h higher than "
                         "the baseline's")
        elif baseline is not None:
            text += "; a new crash (the baseline has none)"
    else:
        text = (f"`{run.label}`: no collision, closest approach "
                f"{_num(_f(row, 'min_distance'), 2)} m")
        if baseline is not None and _collided(baseline):
            text += " (avoided)"
    events = _events_text(row)
    return text + (f"; {events}." if events else ".")


def runs_table(runs: Sequence[PageRun]) -> Table:
    """Outcome and AEB events of each run (one row per run)."""
    rows = []
    for r in runs:
        row = r.row
        err = _failed(row)
        outcome = ("failed" if err else
                   (_kind(row, "contact") + " impact") if _collided(row)
                   else "no collision")
        cells = [f"`{r.label}`", outcome,
                 _pair(row, "impact_speed", 1, KMH_PER_MS) if _collided(row) else "-",
                 _num(_f(row, "impact_time"), 2),
                 _num(_f(row, "min_distance"), 2) if not _collided(row) else "0"]
        for key in ("warning_time", "partial_time", "full_time", "driver_brake_time"):
            cells.append(_pair(row, key, 2) if any(math.isfinite(_f(row, f"{key}{j}"))
                                                   for j in (1, 2)) else "-")
        cells.append(_pair(row, "speed_reduction", 1, KMH_PER_MS))
        rows.append(tuple(cells))
    return Table(("run", "outcome", "impact speed 1 / 2 [km/h]", "impact time [s]",
                  "closest approach [m]", "warning 1 / 2 [s]", "partial braking 1 / 2 [s]",
                  "full braking 1 / 2 [s]", "driver brakes 1 / 2 [s]",
                  "speed taken off 1 / 2 [km/h]"), tuple(rows))


def impact_table(runs: Sequence[PageRun]) -> Table:
    """Impact per run and vehicle: impact speed, delta-v, EES [km/h], PDOF [deg], type."""
    rows = []
    for r in runs:
        row = r.row
        for j in (1, 2):
            if not _collided(row):
                rows.append((f"`{r.label}`", str(j), "-", "-", "-", "-", "no collision"))
                continue
            rows.append((f"`{r.label}`", str(j),
                         _num(_f(row, f"impact_speed{j}"), 1, KMH_PER_MS),
                         _num(_f(row, f"delta_v{j}"), 1, KMH_PER_MS),
                         _num(_f(row, f"ees{j}"), 1, KMH_PER_MS),
                         _num(_f(row, f"pdof{j}"), 0, _DEG),
                         _kind(row, "no impulse")))
    return Table(("run", "vehicle", "impact speed [km/h]", "delta-v [km/h]", "EES [km/h]",
                  "PDOF [deg]", "impact type"), tuple(rows))


# ----------------------------------------------------------------------------
# The speed and braking chart
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class ReferenceImpact:
    """A reference impact drawn on the speed chart (e.g. the reconstruction's).

    Attributes
    ----------
    label : str
    time : float
        Impact time [s] on the record's time axis.
    speed : tuple of float
        Impact speeds of vehicles 1 and 2 [m/s].
    """

    label: str
    time: float
    speed: tuple[float, float] = field(default=(float("nan"), float("nan")))


def plot_case_traces(runs: Sequence[PageRun], path: str | Path, *, title: str = "",
                     reference: ReferenceImpact | None = None, dpi: float = 110) -> Path:
    """Speed and brake deceleration over time, vehicle 1 left, vehicle 2 right.

    Each run in its colour; the brake deceleration the system and driver model add to
    the recorded behaviour, delivered (solid) and demanded (dashed); the AEB events of
    :data:`EVENT_STYLES` as thin vertical lines with their letter at the top, in the
    run's colour; the impact as a cross at the impact speed; ``reference`` as open
    circles.  The time axis starts :data:`TRACE_LEAD_TIME` before the first event (or
    the first impact).
    """
    from matplotlib.lines import Line2D

    braking = any(r.trace is not None and len(r.trace) and (
        np.nanmax(np.asarray(r.trace.deceleration, float), initial=0.0) > 0
        or np.nanmax(np.nan_to_num(np.asarray(r.trace.demand, float)), initial=0.0) > 0)
        for r in runs)
    nrows = 2 if braking else 1
    fig = new_figure((11.5, 6.6 if braking else 3.9), layout="constrained")
    axes = fig.subplots(nrows, 2, sharex=True, squeeze=False)
    top = 0.0
    used: dict[str, str] = {}
    demand_drawn = False
    starts: list[float] = []
    ends: list[float] = []
    for k, run in enumerate(runs):
        tr, row = run.trace, run.row
        if tr is None or len(tr) == 0:
            continue
        t = np.asarray(tr.t, float)
        ends.append(float(t[-1]))
        ti = _f(row, "impact_time")
        if _collided(row) and math.isfinite(ti):
            starts.append(ti - TRACE_LEAD_TIME)
        for j in (0, 1):
            ax_v = axes[0, j]
            speed = np.asarray(tr.speed[:, j], float) * KMH_PER_MS
            top = max(top, float(np.nanmax(speed, initial=0.0)))
            ax_v.plot(t, speed, "-", color=run.color, lw=1.6)
            if braking:
                ax_a = axes[1, j]
                ax_a.plot(t, tr.deceleration[:, j], "-", color=run.color, lw=1.6)
                dem = np.asarray(tr.demand[:, j], float)
                if np.isfinite(dem).any() and np.nanmax(dem) > 0:
                    ax_a.plot(t, dem, "--", color=run.color, lw=0.9)
                    demand_drawn = True
            if _collided(row) and math.isfinite(ti):
                ax_v.plot([ti], [_f(row, f"impact_speed{j + 1}") * KMH_PER_MS], "X",
                          color=run.color, ms=9, mec="black", mew=0.6, zorder=5)
            for key, (label, letter) in EVENT_STYLES.items():
                te = _f(row, f"{key}{j + 1}")
                if not math.isfinite(te):
                    continue
                starts.append(te - 1.0)
                used[letter] = label
                for ax in axes[:, j]:
                    ax.axvline(te, color=run.color, ls=":", lw=1.0)
                ax_v.text(te, 0.97 - 0.075 * k, letter, transform=ax_v.get_xaxis_transform(),
                          color=run.color, fontsize=8, weight="bold", ha="center", va="top",
                          bbox={"fc": "white", "ec": run.color, "lw": 0.6, "pad": 1.2})
    if reference is not None and math.isfinite(reference.time):
        starts.append(reference.time - TRACE_LEAD_TIME)
        for j in (0, 1):
            axes[0, j].plot([reference.time], [reference.speed[j] * KMH_PER_MS], "o",
                            mfc="none", mec="black", ms=9, mew=1.4, zorder=6)
            if math.isfinite(reference.speed[j]):
                top = max(top, reference.speed[j] * KMH_PER_MS)
    if ends:
        t0 = max(0.0, min(starts)) if starts else 0.0
        axes[0, 0].set_xlim(t0, max(ends) + 0.15)
    for j in (0, 1):
        equipped = [r.label for r in runs if _true(r.row, f"equipped{j + 1}")]
        axes[0, j].set_title(f"vehicle {j + 1}" + (" (equipped)" if equipped else ""),
                             fontsize=10)
        axes[0, j].set_ylabel("speed [km/h]")
        axes[-1, j].set_xlabel("time since the start of the record [s]")
        for ax in axes[:, j]:
            ax.grid(True, lw=0.3)
        # headroom above the curves for the event letters
        axes[0, j].set_ylim(0, max(10.0, (1.35 if used else 1.1) * top))  # [km/h]
        if braking:
            axes[1, j].set_ylabel("added brake deceleration [m/s^2]")
            axes[1, j].set_ylim(-0.3, max(2.0, axes[1, j].get_ylim()[1]))  # [m/s^2]
    handles: list[Any] = [Line2D([], [], color=r.color, lw=2) for r in runs]
    labels = [r.label for r in runs]
    handles.append(Line2D([], [], ls="", marker="X", color="#888888", mec="black", ms=8))
    labels.append("impact")
    if reference is not None:
        handles.append(Line2D([], [], ls="", marker="o", mfc="none", mec="black", ms=8))
        labels.append(reference.label)
    if demand_drawn:
        handles.append(Line2D([], [], ls="--", color="#444444", lw=0.9))
        labels.append("demanded deceleration")
    for letter, label in used.items():
        handles.append(Line2D([], [], ls="", marker=f"${letter}$", color="#444444", ms=7))
        labels.append(label)
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 7),
               fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    return save_figure(fig, path, dpi=dpi)


# ----------------------------------------------------------------------------
# Pages
# ----------------------------------------------------------------------------


def _stem(case_id: Any) -> str:
    return Path(case_file(case_id)).stem


def _write_page(folder: Path, case_id: Any, title: str, blocks: Sequence[Block]) -> Path:
    return write_text(folder / case_file(case_id), render_html(blocks, title))


def _topview_scenes(runs: Sequence[PageRun]) -> list[Any]:
    return [case_scene(r.batch, r.results, r.index, trace=r.trace, label=r.label)
            for r in runs if r.batch is not None and r.results is not None]


def effectiveness_case_page(folder: Path, case_id: Any, runs: Sequence[PageRun], *,
                            info: Mapping[str, Any], report: str = "../report.html"
                            ) -> Path:
    """Write the page of one case of an effectiveness report (baseline and each system).

    Parameters
    ----------
    folder : Path
        The report folder (the page goes to ``folder/cases/<id>.html``).
    case_id : object
    runs : sequence of PageRun
        The baseline first, then the systems.
    info : mapping
        ``accident_type``, ``weight``, ``study``, ``db``, ``where``, ``equip`` and
        ``animate`` (a command line) for the header.
    report : str
        Link back to the report, relative to the page.
    """
    figs = folder / CASES_DIR / "figures"
    stem = _stem(case_id)
    label = accident_type_label(info.get("accident_type", ""))
    base = runs[0].row if runs else None
    blocks: list[Block] = [
        Heading(f"Case {case_id}: {label}", 1),
        Paragraph(f"[Back to the report]({report}). Study `{info.get('study', '?')}` on "
                  f"`{info.get('db', '?')}`; case weight {info.get('weight', 1)!s}; equipped "
                  f"vehicles: {info.get('equip', '?')}. Speeds in km/h, angles in degrees, "
                  "times in seconds since the start of the record."),
        Heading("In short", 2),
        BulletList(tuple(outcome_sentence(r, None if k == 0 else base)
                         for k, r in enumerate(runs))),
    ]
    notes = [f"`{r.label}`: {r.note}" for r in runs if r.note]
    if notes:
        blocks.append(Note("The top views and traces re-simulate the case; "
                           + " ".join(notes), "warning"))
    blocks += [Heading("Runs and AEB events", 2), runs_table(runs),
               Paragraph("Event times: first time the stage acted (warning, partial braking, "
                         "full braking) and when the driver started to brake, per vehicle; "
                         "'-' where it never happened. Speed taken off: the speed braking "
                         "removed by the impact or the end of the run."),
               Heading("Impact", 2), impact_table(runs)]
    scenes = _topview_scenes(runs)
    if scenes:
        top = figs / f"{stem}_topview.png"
        plot_scenes(scenes, top)
        blocks += [Heading("Top views", 2), Figure(
            f"figures/{top.name}",
            "Each run zoomed on its impact (outlines at first contact dashed, at impact "
            "filled, at rest darker; star: POI; black line: contact plane; arrows: velocity "
            "x 0.3 s before (solid) and after (dashed) the impact) or, without a collision, "
            "on the closest approach; inset: the whole path with the main view as a box.")]
    if any(r.trace is not None and len(r.trace) for r in runs):
        speed = figs / f"{stem}_speed.png"
        plot_case_traces(runs, speed)
        blocks += [Heading("Speed and braking over time", 2), Figure(
            f"figures/{speed.name}",
            "Speed (top) and the brake deceleration the system and the driver model add to "
            "the recorded behaviour (bottom; solid delivered, dashed demanded) of each run "
            "until its impact (cross) or the end; dotted lines and letters in the run's "
            "colour: the AEB events (W warning, P partial braking, F full braking, D the "
            "driver brakes).")]
    if info.get("animate"):
        blocks += [Paragraph("The case moving, recorded behaviour and a system side by side:"),
                   Code(str(info["animate"]), "sh")]
    return _write_page(folder, case_id, f"Case {case_id}", blocks)


def comparison_case_page(folder: Path, case_id: Any, run: PageRun, rec: pd.Series, *,
                         info: Mapping[str, Any], report: str = "../report.html") -> Path:
    """Write the page of one case of ``vfs compare``: the simulation beside the reconstruction.

    Parameters
    ----------
    folder : Path
        The report folder.
    case_id : object
    run : PageRun
        The simulated (VFS) run.
    rec : pandas.Series
        The case's reconstruction row (SI units).
    info : mapping
        ``accident_type``, ``status``, ``source``, ``note`` for the header.
    report : str
        Link back to the report, relative to the page.
    """
    figs = folder / CASES_DIR / "figures"
    stem = _stem(case_id)
    row = run.row

    def rec_f(key: str) -> float:
        return _f(rec, key)

    rec_speed = (math.hypot(rec_f("vx1"), rec_f("vy1")), math.hypot(rec_f("vx2"), rec_f("vy2")))
    lines = []
    quantities = (("impact speed [km/h]", None, KMH_PER_MS, 1),
                  ("delta-v [km/h]", "delta_v", KMH_PER_MS, 1),
                  ("EES [km/h]", "ees", KMH_PER_MS, 1),
                  ("PDOF [deg]", "pdof", _DEG, 0),
                  ("change of velocity angle [deg]", "velocity_angle_change", _DEG, 1),
                  ("rest x [m]", "rest_x", 1.0, 1), ("rest y [m]", "rest_y", 1.0, 1),
                  ("rest yaw [deg]", "rest_yaw", _DEG, 0))
    for name, key, factor, digits in quantities:
        cells = [name]
        for j in (1, 2):
            r_v = rec_speed[j - 1] if key is None else rec_f(f"{key}{j}")
            m_v = _f(row, f"impact_speed{j}") if key is None else _f(row, f"{key}{j}")
            if not _collided(row):
                m_v = float("nan")
            diff = m_v - r_v
            cells += [_num(r_v, digits, factor), _num(m_v, digits, factor),
                      "-" if not math.isfinite(diff) else f"{diff * factor:+.{digits}f}"]
        lines.append(tuple(cells))
    kind_rec = str(rec.get("impact_type", "") or "?")
    kind_vfs = _kind(row, "none") if _collided(row) else "no collision"
    lines.insert(0, ("impact type", kind_rec, kind_vfs, "", kind_rec, kind_vfs, ""))
    table = Table(("quantity", "vehicle 1 reconstruction", "vehicle 1 VFS", "VFS - rec. 1",
                   "vehicle 2 reconstruction", "vehicle 2 VFS", "VFS - rec. 2"), tuple(lines),
                  align=("left", *(("right",) * 6)))
    summary = [f"Reconstruction: {kind_rec} impact; VFS: "
               + (f"{kind_vfs} impact." if _collided(row) else "no collision.")]
    if _collided(row):
        dv = [(_f(row, f"delta_v{j}") - rec_f(f"delta_v{j}")) * KMH_PER_MS for j in (1, 2)]
        if all(math.isfinite(d) for d in dv):
            summary.append(f"Delta-v VFS - reconstruction: {dv[0]:+.1f} / {dv[1]:+.1f} km/h "
                           "(vehicle 1 / 2).")
        poi = np.array([_f(row, "poi_x") - rec_f("poi_x"), _f(row, "poi_y") - rec_f("poi_y")])
        if np.isfinite(poi).all():
            summary.append(f"The POIs lie {float(np.hypot(*poi)):.2f} m apart (global frame).")
        rest = [math.hypot(_f(row, f"rest_x{j}") - rec_f(f"rest_x{j}"),
                           _f(row, f"rest_y{j}") - rec_f(f"rest_y{j}")) for j in (1, 2)]
        if all(math.isfinite(d) for d in rest):
            summary.append(f"Rest positions {rest[0]:.1f} / {rest[1]:.1f} m apart.")
    blocks: list[Block] = [
        Heading(f"Case {case_id}: VFS vs reconstruction", 1),
        Paragraph(f"[Back to the report]({report}). "
                  f"{accident_type_label(info.get('accident_type', ''))}; comparison status "
                  f"{info.get('status', '?')}; VFS: {info.get('source', 'simulation')}. Speeds "
                  "in km/h, angles in degrees, positions in m (global frame)."),
        Heading("In short", 2), BulletList(tuple(summary)),
    ]
    if info.get("note"):
        blocks.append(Note(str(info["note"])))
    blocks += [Heading("Impact: reconstruction and VFS side by side", 2), table]
    if run.batch is not None and run.results is not None:
        vfs_scene = case_scene(run.batch, run.results, run.index, trace=run.trace,
                               label="VFS")
        rec_scene = reconstruction_scene(run.batch, run.index, rec)
        top = figs / f"{stem}_topview.png"
        plot_scenes([vfs_scene, rec_scene], top)
        blocks += [Heading("Top views", 2), Figure(
            f"figures/{top.name}",
            "Left the simulation, right the reconstruction, same main view where both "
            "impacts fit (outlines at impact filled, at rest darker; star: POI; black line: "
            "contact plane; arrows: velocity x 0.3 s before and after the impact); inset: "
            "the whole path.")]
    if run.trace is not None and len(run.trace):
        speed = figs / f"{stem}_speed.png"
        plot_case_traces([run], speed, reference=ReferenceImpact(
            "reconstruction at impact", rec_f("t_impact"), rec_speed))
        blocks += [Heading("Speed over time", 2), Figure(
            f"figures/{speed.name}",
            "Speed of the simulation (the recorded behaviour, no system) until its impact "
            "(cross); open circles: the reconstruction's impact speeds at its impact "
            "time.")]
    return _write_page(folder, case_id, f"Case {case_id}: VFS vs reconstruction", blocks)


# ----------------------------------------------------------------------------
# Writing the pages of a report
# ----------------------------------------------------------------------------


def write_effectiveness_case_pages(folder: str | Path, study: Any, case_ids: Sequence[Any],
                                   *, say: Callable[[str], None] | None = None
                                   ) -> tuple[dict[Any, str], str]:
    """Replay the cases of a study and write their pages into ``folder/cases``.

    Parameters
    ----------
    folder : path
        The report folder.
    study : StudyResult
        The finished study (:func:`vfs.study.load_study`).
    case_ids : sequence
        The cases linked from the report's tables.
    say : callable, optional
        Progress lines.

    Returns
    -------
    pages : dict
        case id -> page path relative to the report (the cases with a page).
    problem : str
        Why no page could be written (empty when the pages are there).
    """
    from vfs.errors import DataError
    from vfs.study.layout import BASELINE
    from vfs.study.replay import replay_study_cases

    out = Path(folder)
    ids = list(dict.fromkeys(case_ids))
    if not ids:
        return {}, ""
    try:
        replays = replay_study_cases(study, ids, say=say)
    except DataError as exc:  # the problems without the error's header line
        return {}, "; ".join(str(p.message) for p in exc.problems) or str(exc)
    m = study.manifest
    table = study.table
    names = [BASELINE, *m.get("system_names", [])]
    colors = {name: RUN_COLORS[k % len(RUN_COLORS)] for k, name in enumerate(names)}
    meta = table.drop_duplicates("case_id").set_index("case_id")
    pages: dict[Any, str] = {}
    db, db_shown = database_argument(m), database_label(m)
    first_system = next(iter(m.get("system_names", [])), "three-stage")
    for cid, replayed in replays.items():
        runs = []
        for cr in replayed:
            stored = table[(table["case_id"] == cid) & (table["system"] == cr.system)]
            row = stored.iloc[0] if len(stored) else cr.row
            note = cr.error
            if not note and cr.reproduced is False:
                note = ("the re-simulation does not reproduce the study's run (other "
                        "simulation parameters or a changed database?); the tables show the "
                        "study's numbers.")
            runs.append(PageRun(cr.system, colors.get(cr.system, "#777777"), row, cr.batch,
                                cr.results, cr.index, cr.trace, note))
        info = {
            "accident_type": meta.loc[cid, "accident_type"] if cid in meta.index else "",
            "weight": f"{float(meta.loc[cid, 'weight']):g}" if cid in meta.index else "1",
            "study": Path(study.path).name, "db": db_shown, "equip": m.get("equip", "?"),
            "animate": (f"vfs run-case --db {db} --case {cid} --system {first_system} "
                        f"--animate case_{cid}.gif"),
        }
        effectiveness_case_page(out, cid, runs, info=info)
        pages[cid] = case_file(cid)
    return pages, ""


def write_comparison_case_pages(folder: str | Path, comparison: Any, database: Any,
                                case_ids: Sequence[Any]) -> dict[Any, str]:
    """Re-simulate the linked cases of a comparison and write their pages.

    Parameters
    ----------
    folder : path
        The report folder.
    comparison : Comparison
        :func:`vfs.analysis.compare.compare_database`'s result.
    database : Database
        The compared database.
    case_ids : sequence
        The cases linked from the report's tables (those without a reconstruction get
        no page).

    Returns
    -------
    dict
        case id -> page path relative to the report.
    """
    from vfs.simulation import CaseBatch, SimulationParams, results_table
    from vfs.study.traces import simulate_with_traces

    out = Path(folder)
    rec = database.reconstruction.drop_duplicates("case_id").set_index("case_id")
    known = set(database.case_ids.tolist())
    ids = [c for c in dict.fromkeys(case_ids) if c in rec.index and c in known]
    if not ids:
        return {}
    batch = CaseBatch.from_database(database, ids,
                                    impact_parameters=comparison.impact_parameters or "default")
    params = comparison.params or SimulationParams()
    cases = comparison.cases.drop_duplicates("case_id").set_index("case_id")
    types = database.cases.drop_duplicates("case_id").set_index("case_id")
    note = ("" if comparison.source == "simulation" else
            f"The comparison's VFS numbers come from {comparison.source}; this page "
            "re-simulates the case with the comparison's model (the default model with its "
            "effects), which gives the same numbers when the run used that model.")
    try:
        res, traces = simulate_with_traces(batch, params=params)
        table = results_table(batch, res)
        runs = {cid: PageRun("VFS", RUN_COLORS[1], table.iloc[k], batch, res, k, traces[k])
                for k, cid in enumerate(ids)}
    except Exception:  # one failing case: simulate one by one
        runs = {}
        for k, cid in enumerate(ids):
            one = batch.take([k])
            try:
                r1, t1 = simulate_with_traces(one, params=params)
                runs[cid] = PageRun("VFS", RUN_COLORS[1], results_table(one, r1).iloc[0], one,
                                    r1, 0, t1[0])
            except Exception as exc:
                runs[cid] = PageRun("VFS", RUN_COLORS[1], pd.Series({"error": str(exc)}),
                                    note=str(exc))
    pages: dict[Any, str] = {}
    for cid in ids:
        info = {"accident_type": types.loc[cid, "accident_type"]
                if "accident_type" in types.columns else "",
                "status": cases.loc[cid, "status"] if cid in cases.index else "?",
                "source": comparison.source, "note": note}
        comparison_case_page(out, cid, runs[cid], rec.loc[cid], info=info)
        pages[cid] = case_file(cid)
    return pages


__all__ = [
    "CASES_DIR",
    "EVENT_STYLES",
    "PageRun",
    "ReferenceImpact",
    "case_file",
    "case_link",
    "comparison_case_page",
    "effectiveness_case_page",
    "impact_table",
    "outcome_sentence",
    "plot_case_traces",
    "runs_table",
    "write_comparison_case_pages",
    "write_effectiveness_case_pages",
]
