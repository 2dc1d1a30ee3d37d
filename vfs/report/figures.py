"""Figures: one helper to make and save them, and the top view of a simulated case.

matplotlib is imported lazily inside the functions, and only the object-oriented
API is used: :func:`new_figure` returns a :class:`matplotlib.figure.Figure`
that belongs to no pyplot figure manager, so the global backend and the
figures of a notebook user stay untouched (no ``pyplot``, no
``matplotlib.use``).  :func:`save_figure` writes atomically through
:func:`vfs.atomic.write_figure`.  Physics modules never import this one.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vfs.atomic import write_figure
from vfs.physics.geometry import vehicle_outline
from vfs.physics.impact import IMPACT_TYPE_NAMES
from vfs.units import KMH_PER_MS

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

COLORS = ("#1f77b4", "#d62728")

#: Resolution of saved report figures [dots per inch].
DEFAULT_DPI = 110

#: Formats ``--figure-format`` accepts (matplotlib writers).
FIGURE_FORMATS: tuple[str, ...] = ("png", "svg", "pdf")


@dataclass(frozen=True)
class FigureOptions:
    """How report figures are saved (``--figure-format``, ``--dpi``).

    Attributes
    ----------
    formats : tuple of str
        Formats written for every figure, beside each other (same name, other suffix);
        the reports embed the PNG, which is therefore always written.
    dpi : float or None
        Resolution of raster output [dots per inch]; None = each figure's own.
    """

    formats: tuple[str, ...] = ("png",)
    dpi: float | None = None


_OPTIONS: ContextVar[FigureOptions] = ContextVar("vfs_figure_options",
                                                 default=FigureOptions())  # noqa: B039 (frozen)


@contextmanager
def figure_options(formats: Sequence[str] | str = ("png",),
                   dpi: float | None = None) -> Iterator[FigureOptions]:
    """Save the figures of the enclosed calls in ``formats`` at ``dpi`` (a context).

    Parameters
    ----------
    formats : sequence of str or "png,svg,pdf"
        Formats of :data:`FIGURE_FORMATS`; PNG is added (the reports embed it).
    dpi : float, optional
        Resolution [dots per inch], 30-1200.
    """
    from vfs.errors import ParameterError

    names = [f.strip().lower() for f in (formats.split(",") if isinstance(formats, str)
                                         else formats) if f.strip()]
    unknown = [f for f in names if f not in FIGURE_FORMATS]
    if unknown:
        raise ParameterError(f"--figure-format {','.join(names)}: unknown {unknown}; use "
                             f"{', '.join(FIGURE_FORMATS)}")
    if dpi is not None and not 30 <= dpi <= 1200:
        raise ParameterError(f"--dpi {dpi:g} outside 30-1200")
    ordered = tuple(dict.fromkeys(["png", *names]))
    token = _OPTIONS.set(FigureOptions(ordered, dpi))
    try:
        yield _OPTIONS.get()
    finally:
        _OPTIONS.reset(token)


def new_figure(figsize: tuple[float, float] | None = None, *, layout: Any = None,
               agg: bool = False, **kwargs: Any) -> Figure:
    """A new figure, independent of pyplot and of the global backend.

    Parameters
    ----------
    figsize : (float, float), optional
        Width and height [inch]; default ``rcParams["figure.figsize"]``.
    layout : str, optional
        ``"constrained"``, ``"tight"`` or None (as :class:`matplotlib.figure.Figure`).
    agg : bool
        Attach a :class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`, for
        callers that draw to a pixel buffer (``fig.canvas.buffer_rgba()``).
        Saving needs none: ``Figure.savefig`` chooses the canvas of the format.
    **kwargs
        Passed to :class:`matplotlib.figure.Figure` (``dpi``, ``facecolor``, ...).

    Returns
    -------
    matplotlib.figure.Figure
        Add axes with ``fig.subplots(...)`` or ``fig.add_subplot(...)``.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout, **kwargs)
    if agg:
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: str | os.PathLike[str], *, dpi: float = DEFAULT_DPI,
                tight: bool = False, **savefig: Any) -> Path:
    """Save a figure atomically (format from the suffix: PNG, SVG, PDF, ...).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : path
        Target file; its folder is created.
    dpi : float
        Resolution [dots per inch] (default :data:`DEFAULT_DPI`).
    tight : bool
        Call ``fig.tight_layout()`` first (for figures made without a layout
        engine).
    **savefig
        Passed to :meth:`matplotlib.figure.Figure.savefig`.

    Returns
    -------
    Path
        The file written (``path``).

    Notes
    -----
    Inside :func:`figure_options` (the commands' ``--figure-format`` and ``--dpi``) the
    other formats are written beside ``path`` (same name, their suffix), and its dpi
    replaces ``dpi``.
    """
    if tight:
        fig.tight_layout()
    opts = _OPTIONS.get()
    dpi = opts.dpi if opts.dpi is not None else dpi
    target = Path(path)
    out = write_figure(target, fig, dpi=dpi, **savefig)
    for fmt in opts.formats:
        if f".{fmt}" != target.suffix.lower():
            write_figure(target.with_suffix(f".{fmt}"), fig, dpi=dpi, **savefig)
    return out


def _outline_patch(ax: Any, corners: np.ndarray, color: str, style: str, label: str | None,
                   fill_alpha: float = 0.0) -> None:
    ring = np.vstack([corners, corners[:1]])
    ax.plot(ring[:, 0], ring[:, 1], style, color=color, lw=1.4, label=label)
    if fill_alpha:
        ax.fill(corners[:, 0], corners[:, 1], color=color, alpha=fill_alpha)
    # mark the front edge
    ax.plot(corners[:2, 0], corners[:2, 1], "-", color=color, lw=3.0)


def _impact_inset(ax: Any, batch: Any, results: Any, index: int,
                  half_width: float = 5.0) -> None:
    """An inset of the impact: both outlines at impact, POI and contact plane, +-
    ``half_width`` [m] around the POI, linked to its place in the main view.
    """
    pre = results.precrash
    poi = pre.poi[index]
    axin = ax.inset_axes((0.6, 0.02, 0.38, 0.38))
    n = batch.size
    for j, veh in enumerate((batch.vehicle1, batch.vehicle2)):
        st = pre.impact_state
        v = veh.take([index])
        o = vehicle_outline(v, st.x[index:index + 1, j], st.y[index:index + 1, j],
                            st.yaw[index:index + 1, j])[0]
        _outline_patch(axin, o, COLORS[j], "-", None, 0.25)
        row = index + j * n
        cnt = batch.paths.count[row]
        axin.plot(batch.paths.x[row, :cnt], batch.paths.y[row, :cnt], ":", color=COLORS[j],
                  lw=0.8)
    ang = pre.cp_angle[index]
    d = 2.5 * np.array([np.cos(ang), np.sin(ang)])
    axin.plot([poi[0] - d[0], poi[0] + d[0]], [poi[1] - d[1], poi[1] + d[1]], "k-", lw=1.0)
    axin.plot(*poi, "k*", ms=9)
    axin.set_xlim(poi[0] - half_width, poi[0] + half_width)
    axin.set_ylim(poi[1] - half_width, poi[1] + half_width)
    axin.set_aspect("equal")
    axin.tick_params(labelsize=6)
    axin.set_title(f"impact, +-{half_width:g} m", fontsize=7)
    ax.indicate_inset_zoom(axin, edgecolor="0.35")


def plot_case_topview(batch: Any, results: Any, index: int = 0,
                      path: str | os.PathLike[str] | None = None, title: str | None = None
                      ) -> Figure:
    """Top view of one simulated case.

    Shows both recorded paths, the outlines at first contact and at impact,
    the POI and contact plane, velocity vectors before and after the impact,
    the run-out paths and the outlines at rest.  Returns the figure; writes
    it to ``path`` (PNG/SVG/PDF by suffix) when given.
    """
    pre, imp, ro = results.precrash, results.impact, results.runout
    n = batch.size
    fig = new_figure((9, 7))
    ax = fig.subplots()
    for j, (veh, res) in enumerate(((batch.vehicle1, ro.result1), (batch.vehicle2, ro.result2))):
        color = COLORS[j]
        p = batch.paths
        row = index + j * n
        cnt = p.count[row]
        ax.plot(p.x[row, :cnt], p.y[row, :cnt], ":", color=color, lw=1.0,
                label=f"vehicle {j + 1} recorded path")
        v = veh.take([index])
        if pre.collided[index]:
            for state, style, lab, alpha in ((pre.contact_state, "--", "first contact", 0.0),
                                             (pre.impact_state, "-", "impact", 0.15)):
                o = vehicle_outline(v, state.x[index:index + 1, j], state.y[index:index + 1, j],
                                    state.yaw[index:index + 1, j])[0]
                _outline_patch(ax, o, color, style, f"vehicle {j + 1} at {lab}", alpha)
            st = pre.impact_state
            x0, y0 = st.x[index, j], st.y[index, j]
            scale = 0.3  # [s]: arrow length = velocity x 0.3 s
            ax.annotate("", xy=(x0 + scale * st.vx[index, j], y0 + scale * st.vy[index, j]),
                        xytext=(x0, y0),
                        arrowprops={"arrowstyle": "->", "color": color, "lw": 1.5})
            vxp = getattr(imp, f"vx{j + 1}_post")[index]
            vyp = getattr(imp, f"vy{j + 1}_post")[index]
            ax.annotate("", xy=(x0 + scale * vxp, y0 + scale * vyp), xytext=(x0, y0),
                        arrowprops={"arrowstyle": "->", "color": color, "lw": 1.5, "ls": "--"})
            if not np.isnan(res.rest_x[index]):
                traj = res.path[index]
                ax.plot(traj[:, 0], traj[:, 1], "-", color=color, lw=0.8, alpha=0.7)
                o = vehicle_outline(v, [res.rest_x[index]], [res.rest_y[index]],
                                    [res.rest_yaw[index]])[0]
                _outline_patch(ax, o, color, "-", f"vehicle {j + 1} at rest", 0.35)
        else:
            st = pre.end_state
            o = vehicle_outline(v, st.x[index:index + 1, j], st.y[index:index + 1, j],
                                st.yaw[index:index + 1, j])[0]
            _outline_patch(ax, o, color, "-", f"vehicle {j + 1} at the end", 0.25)
    if pre.collided[index]:
        poi = pre.poi[index]
        ang = pre.cp_angle[index]
        d = 2.5 * np.array([np.cos(ang), np.sin(ang)])
        ax.plot([poi[0] - d[0], poi[0] + d[0]], [poi[1] - d[1], poi[1] + d[1]], "k-", lw=1.2,
                label="contact plane")
        ax.plot(*poi, "k*", ms=12, label="POI")
        kind = IMPACT_TYPE_NAMES[int(imp.impact_type[index])]
        info = (f"{kind} impact, delta-v {imp.delta_v1[index] * KMH_PER_MS:.1f} / "
                f"{imp.delta_v2[index] * KMH_PER_MS:.1f} km/h, "
                f"EES {imp.ees1[index] * KMH_PER_MS:.1f} / "
                f"{imp.ees2[index] * KMH_PER_MS:.1f} km/h")
    else:
        info = f"no collision, closest approach {pre.min_distance[index]:.2f} m"
    ax.set_title(title or f"case {batch.case_id[index]}: {info}", fontsize=10)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.3)
    # zoom on the collision and rest area
    corners: list[list[float]] = []
    for j in (0, 1):
        for state in (pre.impact_state, pre.end_state):
            corners.append([state.x[index, j], state.y[index, j]])
        r = ro.result1 if j == 0 else ro.result2
        corners.append([r.rest_x[index], r.rest_y[index]])
    pts = np.array(corners, float)
    pts = pts[~np.isnan(pts).any(axis=1)]
    if pts.size:
        lo, hi = pts.min(axis=0) - 8.0, pts.max(axis=0) + 8.0
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    zoom = bool(pre.collided[index]) and pts.size > 0 and float(np.max(hi - lo)) > 30.0
    ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper left" if zoom else "best")
    if zoom:  # a long run-out shrinks the crash to a dot: the impact as an inset
        _impact_inset(ax, batch, results, index)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig


__all__ = ["COLORS", "DEFAULT_DPI", "FIGURE_FORMATS", "FigureOptions", "figure_options",
           "new_figure", "plot_case_topview", "save_figure"]
