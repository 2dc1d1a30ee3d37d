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
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from vfs.atomic import write_figure
from vfs.physics.geometry import vehicle_outline
from vfs.physics.impact import IMPACT_TYPE_NAMES
from vfs.units import KMH_PER_MS

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: Colours of vehicles 1 and 2 in top views.
COLORS = ("#1f77b4", "#d62728")

#: Colours of the runs in charts: the baseline, then the systems in order.  None of them is a
#: vehicle colour (:data:`COLORS`): a case page shows top views (blue and red: vehicles 1 and
#: 2) above traces (one colour per run), and a colour means one thing on a page.
RUN_COLORS = ("#444444", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")

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


# ----------------------------------------------------------------------------
# Top views: a scene (what is shown) and one function that draws it
# ----------------------------------------------------------------------------

#: Colour of the reconstruction in top views drawn over a simulation.
RECONSTRUCTION_COLOR = "#555555"

#: Arrow length of the velocity vectors in top views: velocity x this time [s].
ARROW_TIME = 0.3


class Layer(NamedTuple):
    """One drawn element of a top view, in the global frame [m].

    Attributes
    ----------
    kind : {"path", "outline", "arrow", "marker", "segment"}
        A polyline (M, 2); a vehicle outline (4, 2) (front edge first, drawn
        thick); an arrow (2, 2) from its first to its second point; one marker
        (1, 2); a line segment (2, 2).
    xy : ndarray
        The points [m].
    color : str
    style : str
        Line style (``"-"``, ``"--"``, ``":"``) or marker (``"*"``, ``"o"``).
    label : str or None
        Legend entry (the same label is listed once).
    fill : float
        Fill opacity of an outline (0: none).
    size : float
        Line width [pt], or marker size [pt] of a marker.
    open_marker : bool
        Draw the marker without face colour.
    overview : bool
        Also drawn in the whole-path overview.
    """

    kind: str
    xy: np.ndarray
    color: str
    style: str = "-"
    label: str | None = None
    fill: float = 0.0
    size: float = 1.4
    open_marker: bool = False
    overview: bool = True


@dataclass(frozen=True)
class Scene:
    """What a top view shows: layers, the points the main view zooms on, a title.

    The main view of :func:`draw_scene` is zoomed on ``focus`` (the impact: the outlines at
    first contact and at impact) and also shows the outlines of ``nearby`` (the rest
    outlines, 4 corners each, nearest first) as long as it stays small
    (:data:`NEARBY_SPAN`); everything else is in the whole-path overview.
    """

    layers: tuple[Layer, ...] = ()
    focus: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    title: str = ""
    nearby: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def merged(self, other: Scene, *, focus: bool = False) -> Scene:
        """The scene with the layers of ``other`` on top (and its focus when ``focus``)."""
        pts = np.vstack([self.focus, other.focus]) if focus else self.focus
        near = np.vstack([self.nearby, other.nearby]) if focus else self.nearby
        return Scene(self.layers + other.layers, pts, self.title, near)

    def extent(self, overview_only: bool = True) -> np.ndarray:
        """All finite points of the layers (N, 2) [m] (those drawn in the overview)."""
        pts = [ly.xy.reshape(-1, 2) for ly in self.layers if ly.overview or not overview_only]
        allp = np.vstack(pts) if pts else np.zeros((0, 2))
        return allp[np.isfinite(allp).all(axis=1)]


def _outline_layer(corners: np.ndarray, color: str, style: str, label: str | None,
                   fill: float = 0.0, overview: bool = True) -> Layer:
    return Layer("outline", np.asarray(corners, float), color, style, label, fill,
                 overview=overview)


def _contact_plane(poi: np.ndarray, angle: float, color: str, label: str, half: float = 2.5
                   ) -> Layer:
    d = half * np.array([np.cos(angle), np.sin(angle)])
    return Layer("segment", np.array([poi - d, poi + d]), color, "-", label, size=1.2)


def case_scene(batch: Any, results: Any, index: int = 0, *, trace: Any = None,
               title: str | None = None, label: str | None = None) -> Scene:
    """The top view of one simulated case as a :class:`Scene`.

    Recorded paths, the outlines at first contact, at impact and at rest, POI and
    contact plane, velocity vectors before (solid) and after (dashed) the impact
    (velocity x :data:`ARROW_TIME`), the run-out paths; without a collision the
    outlines at the end and, given the run's ``trace``
    (:class:`vfs.study.traces.RunTrace`), at the closest approach.

    Parameters
    ----------
    batch : CaseBatch
    results : CaseResults
        Of ``batch`` (:func:`vfs.simulation.simulate_cases`).
    index : int
        The case's position in the batch.
    trace : RunTrace, optional
        The run's pre-crash trace (poses per step).
    title : str, optional
        Default: ``label`` (default "case <id>") and the impact in one line (km/h).
    label : str, optional
        Who ran (e.g. a system's name) for the default title.
    """
    pre, imp, ro = results.precrash, results.impact, results.runout
    n, i = batch.size, index
    hit = bool(pre.collided[i])
    layers: list[Layer] = []
    focus: list[np.ndarray] = []
    near: list[np.ndarray] = []
    for j, veh in enumerate((batch.vehicle1, batch.vehicle2)):
        color = COLORS[j]
        p = batch.paths
        row = i + j * n
        cnt = p.count[row]
        layers.append(Layer("path", np.c_[p.x[row, :cnt], p.y[row, :cnt]], color, ":",
                            "recorded path", size=1.0))
        v = veh.take([i])

        def outline(state: Any, jj: int = j, vv: Any = v) -> np.ndarray:
            return vehicle_outline(vv, state.x[i:i + 1, jj], state.y[i:i + 1, jj],
                                   state.yaw[i:i + 1, jj])[0]

        if hit:
            for state, style, lab, alpha in ((pre.contact_state, "--", "at first contact", 0.0),
                                             (pre.impact_state, "-", "at impact", 0.15)):
                o = outline(state)
                layers.append(_outline_layer(o, color, style, lab, alpha))
                focus.append(o)
            st = pre.impact_state
            x0 = np.array([st.x[i, j], st.y[i, j]])
            pre_v = np.array([st.vx[i, j], st.vy[i, j]])
            post_v = np.array([imp.vx_post[i, j], imp.vy_post[i, j]])
            layers.append(Layer("arrow", np.array([x0, x0 + ARROW_TIME * pre_v]), color, "-",
                                overview=False))
            layers.append(Layer("arrow", np.array([x0, x0 + ARROW_TIME * post_v]), color, "--",
                                overview=False))
            if not np.isnan(ro.rest_x[i, j]):
                layers.append(Layer("path", np.asarray(ro.path[i, j])[:, :2], color, "-",
                                    "run-out path", size=0.8))
                o = vehicle_outline(v, [ro.rest_x[i, j]], [ro.rest_y[i, j]], [ro.rest_yaw[i, j]])[0]
                layers.append(_outline_layer(o, color, "-", "at rest", 0.35))
                near.append(o)
        else:
            o = outline(pre.end_state)
            layers.append(_outline_layer(o, color, "-", "at the end", 0.25))
            if trace is not None and np.isfinite(pre.time_closest[i]) and len(trace.t):
                k = int(np.argmin(np.abs(np.asarray(trace.t) - pre.time_closest[i])))
                c = vehicle_outline(v, [trace.x[k, j]], [trace.y[k, j]], [trace.yaw[k, j]])[0]
                layers.append(_outline_layer(c, color, "--", "at the closest approach"))
                focus.append(c)
            else:
                focus.append(o)
    if hit:
        poi = np.asarray(pre.poi[i], float)
        layers.append(_contact_plane(poi, float(pre.cp_angle[i]), "black", "contact plane"))
        layers.append(Layer("marker", poi[None, :], "black", "*", "POI", size=12.0))
        kind = IMPACT_TYPE_NAMES[int(imp.impact_type[i])]
        info = (f"{kind} impact, delta-v {imp.delta_v[i, 0] * KMH_PER_MS:.1f} / "
                f"{imp.delta_v[i, 1] * KMH_PER_MS:.1f} km/h")
        if label is None:  # a panel of several (a label) has the EES in its page's table
            info += (f", EES {imp.ees[i, 0] * KMH_PER_MS:.1f} / "
                     f"{imp.ees[i, 1] * KMH_PER_MS:.1f} km/h")
    else:
        info = f"no collision, closest approach {pre.min_distance[i]:.2f} m"
    pts = np.vstack(focus) if focus else np.zeros((0, 2))
    return Scene(tuple(layers), pts, title or f"{label or f'case {batch.case_id[i]}'}: {info}",
                 np.vstack(near) if near else np.zeros((0, 2)))


def reconstruction_scene(batch: Any, index: int, rec: Any, *, overlay: bool = False,
                         title: str | None = None) -> Scene:
    """The reconstruction of one case as a :class:`Scene`.

    Parameters
    ----------
    batch : CaseBatch
        The case's vehicles and recorded paths.
    index : int
        The case's position in the batch.
    rec : mapping
        Its reconstruction row (columns of the database's reconstruction table, SI).
    overlay : bool
        Only what is drawn over a simulated case (:func:`case_scene`): the rest
        outlines, POI and contact plane, in :data:`RECONSTRUCTION_COLOR`.  Else the whole
        reconstruction in the vehicles' colours: recorded paths, outlines at impact,
        velocity vectors before and after it, POI, contact plane and rest outlines.
    title : str, optional
    """
    layers: list[Layer] = []
    focus: list[np.ndarray] = []
    near: list[np.ndarray] = []
    n = batch.size

    def val(name: str) -> float:
        try:
            return float(rec[name])
        except (KeyError, TypeError, ValueError):
            return float("nan")

    grey = RECONSTRUCTION_COLOR
    for j, veh in enumerate((batch.vehicle1, batch.vehicle2)):
        k = j + 1
        v = veh.take([index])
        color = grey if overlay else COLORS[j]
        if not overlay:
            row = index + j * n
            cnt = batch.paths.count[row]
            layers.append(Layer("path", np.c_[batch.paths.x[row, :cnt], batch.paths.y[row, :cnt]],
                                color, ":", "recorded path", size=1.0))
            pose = [val(f"x{k}"), val(f"y{k}"), val(f"yaw{k}")]
            if np.all(np.isfinite(pose)):
                o = vehicle_outline(v, [pose[0]], [pose[1]], [pose[2]])[0]
                layers.append(_outline_layer(o, color, "-", "at impact", 0.15))
                focus.append(o)
                x0 = np.array(pose[:2])
                for suffix, style in (("", "-"), ("_post", "--")):
                    vel = np.array([val(f"vx{k}{suffix}"), val(f"vy{k}{suffix}")])
                    if np.all(np.isfinite(vel)):
                        layers.append(Layer("arrow", np.array([x0, x0 + ARROW_TIME * vel]),
                                            color, style, overview=False))
        rest = [val(f"rest_x{k}"), val(f"rest_y{k}"), val(f"rest_yaw{k}")]
        if np.all(np.isfinite(rest)):
            o = vehicle_outline(v, [rest[0]], [rest[1]], [rest[2]])[0]
            layers.append(_outline_layer(o, color, "--" if overlay else "-",
                                         "reconstruction at rest" if overlay else "at rest",
                                         0.0 if overlay else 0.35))
            near.append(o)
    poi = np.array([val("poi_x"), val("poi_y")])
    if np.all(np.isfinite(poi)):
        if np.isfinite(val("cp_angle")):
            layers.append(_contact_plane(poi, val("cp_angle"), "#777777" if overlay else "black",
                                         "reconstruction contact plane" if overlay
                                         else "contact plane"))
        layers.append(Layer("marker", poi[None, :], "black", "o" if overlay else "*",
                            "reconstruction POI" if overlay else "POI",
                            size=10.0 if overlay else 12.0, open_marker=overlay))
        focus.append(poi[None, :])
    pts = np.vstack(focus) if focus else np.zeros((0, 2))
    kind = str(rec["impact_type"]) if "impact_type" in rec and rec["impact_type"] else "?"
    info = (f"reconstruction: {kind} impact, delta-v {val('delta_v1') * KMH_PER_MS:.1f} / "
            f"{val('delta_v2') * KMH_PER_MS:.1f} km/h")
    return Scene(tuple(layers), pts, title or info,
                 np.vstack(near) if near else np.zeros((0, 2)))


def _draw_layers(ax: Any, layers: Sequence[Layer], small: bool) -> None:
    """Draw layers on an axes (``small``: the overview, thinner, no arrows)."""
    from matplotlib.patches import Polygon

    scale = 0.6 if small else 1.0
    for ly in layers:
        if small and not ly.overview:
            continue
        xy = ly.xy
        if ly.kind == "path":
            ax.plot(xy[:, 0], xy[:, 1], ly.style, color=ly.color, lw=ly.size * scale)
        elif ly.kind == "outline":
            if ly.fill:
                ax.add_patch(Polygon(xy, closed=True, fc=ly.color, alpha=ly.fill, lw=0))
            ring = np.vstack([xy, xy[:1]])
            ax.plot(ring[:, 0], ring[:, 1], ly.style, color=ly.color, lw=1.4 * scale)
            ax.plot(xy[:2, 0], xy[:2, 1], "-", color=ly.color, lw=3.0 * scale)  # front edge
        elif ly.kind == "arrow":
            ax.annotate("", xy=tuple(xy[1]), xytext=tuple(xy[0]),
                        arrowprops={"arrowstyle": "->", "color": ly.color, "lw": 1.5,
                                    "ls": ly.style})
        elif ly.kind == "marker":
            ax.plot(xy[:, 0], xy[:, 1], ly.style, color=ly.color, ms=ly.size * scale,
                    mfc="none" if ly.open_marker else ly.color, mec=ly.color)
        elif ly.kind == "segment":
            ax.plot(xy[:, 0], xy[:, 1], ly.style, color=ly.color, lw=ly.size * scale)


def legend_handles(layers: Sequence[Layer]) -> tuple[list[Any], list[str]]:
    """Legend entries of the layers: one per label (drawn in grey), then the vehicles."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = []
    labels: list[str] = []
    colors = {ly.color for ly in layers}
    for ly in layers:
        if ly.label is None or ly.label in labels:
            continue
        neutral = ly.color if ly.color not in COLORS else "#444444"
        if ly.kind == "marker":
            h: Any = Line2D([], [], ls="", marker=ly.style, color=neutral, ms=8,
                            mfc="none" if ly.open_marker else neutral)
        elif ly.kind == "outline" and ly.fill:
            h = Patch(fc=neutral, alpha=ly.fill + 0.15, ec=neutral, ls=ly.style)
        else:
            h = Line2D([], [], ls=ly.style, color=neutral, lw=1.4)
        handles.append(h)
        labels.append(ly.label)
    for j, color in enumerate(COLORS):
        if color in colors:
            handles.append(Patch(color=color))
            labels.append(f"vehicle {j + 1}")
    return handles, labels


def _fit_limits(points: np.ndarray, margin: float, min_span: float, max_ratio: float = 1.6
                ) -> tuple[tuple[float, float], tuple[float, float]]:
    """Limits [m] around ``points``: ``margin`` beyond them, the longer side at least
    ``min_span``, the sides at most ``max_ratio`` : 1 (an equal-aspect view of a wide
    scene stays wide instead of a square with empty bands).
    """
    lo, hi = points.min(axis=0) - margin, points.max(axis=0) + margin
    centre = 0.5 * (lo + hi)
    span = hi - lo
    longer = max(float(span.max()), min_span)
    span = np.maximum(np.where(span >= span.max(), longer, span), longer / max_ratio)
    half = 0.5 * span
    return ((centre[0] - half[0], centre[0] + half[0]), (centre[1] - half[1], centre[1] + half[1]))


def _with_ratio(view: tuple[tuple[float, float], tuple[float, float]], ratio: float
                ) -> tuple[tuple[float, float], tuple[float, float]]:
    """``view`` [m] widened or heightened about its centre to height / width = ``ratio``."""
    (x0, x1), (y0, y1) = view
    w, h = x1 - x0, y1 - y0
    w, h = max(w, h / ratio), max(h, w * ratio)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    return (cx - 0.5 * w, cx + 0.5 * w), (cy - 0.5 * h, cy + 0.5 * h)


#: Longest side [m] of a main view that also shows the scene's ``nearby`` points (the rest
#: positions); beyond it the view keeps to the impact.
NEARBY_SPAN = 25.0


def view_limits(scenes: Sequence[Scene], *, margin: float = 3.0, min_span: float = 14.0
                ) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The main view [m] around the focus of the scenes (for panels that share it).

    3 m (``margin``) around the focus, the longer side at least ``min_span``; with the
    scenes' ``nearby`` outlines (the rest positions), nearest first, as long as the view
    stays within :data:`NEARBY_SPAN`.
    """
    def finite(parts: list[np.ndarray]) -> np.ndarray:
        allp = np.vstack(parts) if parts else np.zeros((0, 2))
        return allp[np.isfinite(allp).all(axis=1)]

    pts = finite([s.focus for s in scenes if s.focus.size])
    if not pts.size:
        pts = finite([s.extent() for s in scenes])
    if not pts.size:
        return None
    # the nearby outlines (4 corners each), nearest first, as long as the view stays small
    near = finite([s.nearby for s in scenes if s.nearby.size])
    groups = near[:near.shape[0] // 4 * 4].reshape(-1, 4, 2)
    centre = pts.mean(axis=0)
    for g in sorted(groups, key=lambda c: float(np.hypot(*(c.mean(axis=0) - centre)))):
        wider = np.vstack([pts, g])
        if float(np.max(np.ptp(wider, axis=0))) + 2 * margin <= NEARBY_SPAN:
            pts = wider
    return _fit_limits(pts, margin, min_span)


def _inset_corner(points: np.ndarray, xlim: tuple[float, float], ylim: tuple[float, float],
                  w: float, h: float) -> tuple[float, float]:
    """Lower-left corner (axes fraction) of the w x h corner box holding the fewest points."""
    fx = (points[:, 0] - xlim[0]) / (xlim[1] - xlim[0])
    fy = (points[:, 1] - ylim[0]) / (ylim[1] - ylim[0])
    pad = 0.02
    best, where = None, (1 - w - pad, pad)
    for x0, y0 in ((1 - w - pad, pad), (1 - w - pad, 1 - h - pad), (pad, pad),
                   (pad, 1 - h - pad)):
        inside = int(np.sum((fx >= x0 - pad) & (fx <= x0 + w + pad) & (fy >= y0 - pad)
                            & (fy <= y0 + h + pad)))
        if best is None or inside < best:
            best, where = inside, (x0, y0)
    return where


def draw_scene(ax: Any, scene: Scene, *, limits: Any = None, overview: bool = True,
               legend: str | None = "below", title: bool = True) -> Any:
    """Draw a :class:`Scene`: the main view zoomed on its focus, the whole path as an inset.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    scene : Scene
    limits : ((x0, x1), (y0, y1)), optional
        The main view [m]; default :func:`view_limits` of this scene (3 m around the
        outlines at first contact and impact, and the rest outlines when the view stays
        within 25 m; the longer side at least 14 m, at most 1.6 : 1).
    overview : bool
        Add the overview (every layer, the main view as a rectangle) in the emptiest
        corner when the scene reaches beyond the main view.
    legend : {"below", "inside"} or None
        Where the legend goes (None: none; see :func:`legend_handles` for a shared one).
    title : bool
        Set the scene's title.

    Returns
    -------
    matplotlib.axes.Axes or None
        The overview inset, if drawn.
    """
    from matplotlib.patches import Rectangle

    _draw_layers(ax, scene.layers, small=False)
    lim = limits if limits is not None else view_limits([scene])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.3)
    if title and scene.title:
        ax.set_title(scene.title, fontsize=9)
    if legend is not None:
        handles, labels = legend_handles(scene.layers)
        if legend == "below":
            ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=4,
                      fontsize=7, frameon=False)
        else:
            ax.legend(handles, labels, loc="best", fontsize=7)
    if lim is None:
        return None
    (x0, x1), (y0, y1) = lim
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ext = scene.extent()
    if not overview or ext.size == 0:
        return None
    e_lo, e_hi = ext.min(axis=0), ext.max(axis=0)
    if e_lo[0] >= x0 and e_hi[0] <= x1 and e_lo[1] >= y0 and e_hi[1] <= y1:
        return None  # everything is in the main view
    e_lo, e_hi = np.minimum(e_lo, [x0, y0]), np.maximum(e_hi, [x1, y1])
    span = e_hi - e_lo + 8.0  # 4 m around everything
    w = 0.4
    h = float(np.clip(w * span[1] / span[0], 0.14, 0.4))
    if h >= 0.4:
        w = float(np.clip(0.4 * span[0] / span[1], 0.14, 0.4))
    inside = scene.extent(overview_only=False)
    corner = _inset_corner(inside, (x0, x1), (y0, y1), w, h)
    axin = ax.inset_axes((corner[0], corner[1], w, h))
    _draw_layers(axin, scene.layers, small=True)
    axin.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="black", lw=1.0,
                             zorder=5))
    cx, cy = 0.5 * (e_lo + e_hi)
    axin.set_xlim(cx - 0.5 * span[0], cx + 0.5 * span[0])
    axin.set_ylim(cy - 0.5 * span[1], cy + 0.5 * span[1])
    axin.set_aspect("equal", adjustable="box")
    axin.set_anchor(("S" if corner[1] < 0.5 else "N") + ("W" if corner[0] < 0.5 else "E"))
    axin.set_xticks([])
    axin.set_yticks([])
    axin.set_facecolor("white")
    caption = (f"whole path, {span[0] - 8.0:.0f} m x {span[1] - 8.0:.0f} m "
               "(box: main view)")
    right, bottom = corner[0] > 0.5, corner[1] < 0.5
    # above an inset in a bottom corner, below one in a top corner; aligned with the
    # inset's outer edge so that it runs into the main view, not out of the figure
    axin.text(1.0 if right else 0.0, 1.02 if bottom else -0.02, caption,
              transform=axin.transAxes, ha="right" if right else "left",
              va="bottom" if bottom else "top", fontsize=6,
              bbox={"fc": "white", "ec": "none", "alpha": 0.85, "pad": 1.0})
    return axin


def plot_scenes(scenes: Sequence[Scene], path: str | os.PathLike[str] | None = None, *,
                ncols: int = 2, share: float = 20.0, dpi: float = 110) -> Figure:
    """Top views side by side (e.g. a case without and with each system), one legend.

    Parameters
    ----------
    scenes : sequence of Scene
        One panel each, in rows of ``ncols``; each zoomed on its focus with the whole
        path as an inset (:func:`draw_scene`).
    path : path, optional
        Write the figure there (PNG/SVG/PDF by suffix).
    ncols : int
        Panels per row.
    share : float
        The panels share one main view when the union of their focus spans at most
        this much [m] (so that positions compare at a glance); else each has its own.
    dpi : float
        Resolution of raster output [dots per inch].
    """
    n = len(scenes)
    ncols = max(1, min(ncols, n))
    nrows = -(-n // ncols)
    common = view_limits(scenes)
    if common is not None and common[0][1] - common[0][0] > share:
        common = None
    views = [common] if common is not None else [view_limits([s]) for s in scenes]
    ratios = [(v[1][1] - v[1][0]) / (v[0][1] - v[0][0]) for v in views if v is not None]
    # one height / width for every panel (the geometric mean of theirs): equal-aspect panels
    # of different shapes would otherwise leave gaps between them
    ratio = float(np.clip(np.exp(np.mean(np.log(ratios))), 0.55, 1.6)) if ratios else 1.0
    own = [None if v is None else _with_ratio(v, ratio) for v in views] \
        if common is None else None
    fig = new_figure((5.2 * ncols, nrows * (4.6 * ratio + 0.9) + 0.6), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for k, (ax, scene) in enumerate(zip(axes, scenes, strict=False)):
        draw_scene(ax, scene, limits=common if own is None else own[k], legend=None)
    handles, labels = legend_handles([ly for s in scenes for ly in s.layers])
    if n < len(axes):  # an empty slot: the legend goes there
        for ax in axes[n:]:
            ax.set_axis_off()
        axes[n].legend(handles, labels, loc="center", fontsize=8, frameon=False)
    else:
        fig.legend(handles, labels, loc="outside lower center", ncol=5, fontsize=8,
                   frameon=False)
    if path is not None:
        save_figure(fig, path, dpi=dpi)
    return fig


def plot_case_topview(batch: Any, results: Any, index: int = 0,
                      path: str | os.PathLike[str] | None = None, title: str | None = None,
                      *, overlay: Scene | None = None, trace: Any = None) -> Figure:
    """Top view of one simulated case: zoomed on the impact, the whole path as an inset.

    Draws :func:`case_scene` (with ``overlay``, e.g. :func:`reconstruction_scene`,
    on top) with :func:`draw_scene`.  Returns the figure; writes it to ``path``
    (PNG/SVG/PDF by suffix) when given.
    """
    scene = case_scene(batch, results, index, trace=trace, title=title)
    if overlay is not None:
        scene = scene.merged(overlay)
    lim = view_limits([scene])
    ratio = 1.0 if lim is None else (lim[1][1] - lim[1][0]) / (lim[0][1] - lim[0][0])
    fig = new_figure((8.5, float(np.clip(7.6 * ratio, 4.0, 9.0)) + 2.2), layout="constrained")
    ax = fig.subplots()
    draw_scene(ax, scene, limits=lim)
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig


__all__ = [
    "ARROW_TIME",
    "COLORS",
    "DEFAULT_DPI",
    "FIGURE_FORMATS",
    "NEARBY_SPAN",
    "RECONSTRUCTION_COLOR",
    "RUN_COLORS",
    "FigureOptions",
    "Layer",
    "Scene",
    "case_scene",
    "draw_scene",
    "figure_options",
    "legend_handles",
    "new_figure",
    "plot_case_topview",
    "plot_scenes",
    "reconstruction_scene",
    "save_figure",
    "view_limits",
]
