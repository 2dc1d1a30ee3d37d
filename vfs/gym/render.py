"""Drawing an AEB episode: the ``rgb_array`` and ``ansi`` render modes, and animations.

A :class:`EpisodeTrace` records the state of one running case instance of an
:class:`~vfs.gym.env.EpisodeBatch` at every environment step (poses of both
participants, ego speed, delivered deceleration, brake demand, TTC and gap as the
sensor sees them).  :func:`draw_frame` draws one recorded step as a top view on a
matplotlib Figure with an Agg canvas (no pyplot, the global backend untouched):
both outlines, the recorded paths (thin, dashed), the path driven so far (thick),
the sensor's field of view, and a text box with time, ego speed, TTC, gap and brake
demand.  :func:`frame_to_rgb` turns it into an (H, W, 3) uint8 array;
:func:`ansi_line` gives the same state as one line of text.  ``vfs run-case
--animate`` (:mod:`vfs.gym.animation`) draws its frames with the same function.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vfs.adas.params import SensorParams
from vfs.units import KMH_PER_MS

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Colours of ego and object (the report's participant colours).
EGO_COLOR, OBJECT_COLOR = "#1f77b4", "#d62728"

#: Half width of the square view around the ego [m].
VIEW_HALF_WIDTH = 30.0


@dataclass
class EpisodeTrace:
    """The states of one episode, one entry per environment step (SI units).

    Attributes
    ----------
    case_id : object
        The case played.
    paths : ndarray (2, M, 2)
        Recorded CG paths (x, y) [m] of ego and object.
    dims : ndarray (2, 3)
        (CG to front, CG to rear, width) [m] of ego and object.
    sensor : SensorParams
        The ego's sensor (field of view [rad], range [m], mounting).
    t, x, y, yaw, speed, decel, demand, ttc, gap, seen : list
        Per step: time [s], CG poses of ego and object (pairs) [m, rad], ego speed
        [m/s], delivered ego deceleration [m/s^2], brake demand [0..1], TTC [s], gap
        [m], object seen by the sensor.
    outcome : str
        How the episode ended (empty while it runs).
    """

    case_id: Any
    paths: np.ndarray
    dims: np.ndarray
    sensor: SensorParams
    t: list[float] = field(default_factory=list)
    x: list[tuple[float, float]] = field(default_factory=list)
    y: list[tuple[float, float]] = field(default_factory=list)
    yaw: list[tuple[float, float]] = field(default_factory=list)
    speed: list[float] = field(default_factory=list)
    decel: list[float] = field(default_factory=list)
    demand: list[float] = field(default_factory=list)
    ttc: list[float] = field(default_factory=list)
    gap: list[float] = field(default_factory=list)
    seen: list[bool] = field(default_factory=list)
    outcome: str = ""

    def __len__(self) -> int:
        return len(self.t)


def start_trace(core: Any, row: int) -> EpisodeTrace:
    """An empty :class:`EpisodeTrace` for case instance ``row`` of ``core`` (an EpisodeBatch)."""
    cfg = core.config
    ci = int(core.case_index[row])
    n = core.batch.size
    p = core.batch.paths
    e, o = cfg.ego - 1, 2 - cfg.ego
    paths = []
    for col in (e, o):
        i = ci + col * n
        m = int(p.count[i])
        paths.append(np.stack([p.knots[:m, i, 2], p.knots[:m, i, 3]], axis=1))
    length = max(a.shape[0] for a in paths)
    padded = np.stack([np.concatenate([a, np.repeat(a[-1:], length - a.shape[0], 0)])
                       for a in paths])
    d = core.dims.take(np.array([row]))
    dims = np.array([[d.ego_front[0], d.ego_rear[0], d.ego_width[0]],
                     [d.obj_front[0], d.obj_rear[0], d.obj_width[0]]], dtype=float)
    return EpisodeTrace(core.case_id(row), padded, dims, cfg.sensor)


def record_step(trace: EpisodeTrace, core: Any, row: int, demand: float) -> None:
    """Append the current state of running instance ``row`` to ``trace``."""
    import dataclasses

    from vfs.gym.observation import OBSERVATION_NAMES, observe

    run = core.run
    p = run.observation()
    k = np.flatnonzero(p.rows == row)
    if k.size == 0:
        return
    j = int(k[0])
    e, o = core.config.ego - 1, 2 - core.config.ego
    sensor_cfg = core.config if not core.config.privileged else \
        dataclasses.replace(core.config, privileged=False)
    sub = p._replace(**{f: getattr(p, f)[k] for f in p._fields
                        if isinstance(getattr(p, f), np.ndarray) and f != "t"})
    if isinstance(p.t, np.ndarray):
        sub = sub._replace(t=p.t[k])
    obs = observe(sub, core.dims, sensor_cfg)[0]
    names = OBSERVATION_NAMES
    t = float(run.local_time(np.array([row]))[0])
    trace.t.append(t)
    trace.x.append((float(p.x[j, e]), float(p.x[j, o])))
    trace.y.append((float(p.y[j, e]), float(p.y[j, o])))
    trace.yaw.append((float(p.yaw[j, e]), float(p.yaw[j, o])))
    trace.speed.append(float(p.speed[j, e]))
    trace.decel.append(float(p.deceleration[j, e]))
    trace.demand.append(float(demand))
    trace.ttc.append(float(obs[names.index("ttc")]))
    trace.gap.append(float(obs[names.index("gap")]))
    trace.seen.append(bool(obs[names.index("object_seen")] > 0.5))


def _outline(x: float, y: float, yaw: float, front: float, rear: float,
             width: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[front, width / 2], [-rear, width / 2], [-rear, -width / 2],
                      [front, -width / 2]])
    return np.column_stack([x + c * local[:, 0] - s * local[:, 1],
                            y + s * local[:, 0] + c * local[:, 1]])


def view_box(ego: tuple[float, float], other: tuple[float, float],
             view: float = VIEW_HALF_WIDTH) -> tuple[float, float, float]:
    """Centre (x, y) [m] and half width [m] of a top view that frames both vehicles.

    Centred between ego and object, half width the half distance plus 10 m of margin, at least
    ``view`` / 2 and at most 4 ``view`` (both vehicles stay in the frame up to about
    8 ``view`` - 20 m apart, 220 m with the default, beyond the sensors' range); farther
    apart the view follows the ego alone.

    Examples
    --------
    >>> view_box((0.0, 0.0), (100.0, 0.0), 30.0)
    (50.0, 0.0, 60.0)
    """
    (ex, ey), (ox, oy) = ego, other
    dist = math.hypot(ox - ex, oy - ey)
    cap = 4.0 * view
    half = min(max(0.5 * dist + 10.0, 0.5 * view), cap)
    if dist <= 2.0 * cap - 20.0:
        return 0.5 * (ex + ox), 0.5 * (ey + oy), half
    return ex, ey, half


def draw_step(ax: Axes, trace: EpisodeTrace, step: int = -1, *, title: str = "",
              view: float = VIEW_HALF_WIDTH) -> None:
    """Draw step ``step`` of ``trace`` into ``ax``.

    A top view that frames ego and object (:func:`view_box`).
    """
    from matplotlib.patches import Polygon, Wedge

    k = step if step >= 0 else len(trace) + step
    ax.cla()
    ax.set_aspect("equal")
    ax.set_facecolor("#f4f4f4")
    ex, ox = trace.x[k]
    ey, oy = trace.y[k]
    eyaw, oyaw = trace.yaw[k]
    for path, color in zip(trace.paths, (EGO_COLOR, OBJECT_COLOR), strict=True):
        ax.plot(path[:, 0], path[:, 1], ls="--", lw=0.8, color=color, alpha=0.6)
    driven = np.array([[xx[0], yy[0]] for xx, yy in zip(trace.x[:k + 1], trace.y[:k + 1],
                                                          strict=True)])
    ax.plot(driven[:, 0], driven[:, 1], lw=2.0, color=EGO_COLOR)
    sn = trace.sensor
    front = trace.dims[0, 0]
    mx = ex + math.cos(eyaw) * (front + sn.mount_x) - math.sin(eyaw) * sn.mount_y
    my = ey + math.sin(eyaw) * (front + sn.mount_x) + math.cos(eyaw) * sn.mount_y
    bore = math.degrees(eyaw + sn.mount_yaw)
    half = math.degrees(0.5 * sn.field_of_view)
    ax.add_patch(Wedge((mx, my), min(sn.range, 3 * view), bore - half, bore + half,
                       color="#2ca02c", alpha=0.10 if not trace.seen[k] else 0.22, lw=0))
    for (x, y, yaw), dims, color in zip(((ex, ey, eyaw), (ox, oy, oyaw)), trace.dims,
                                        (EGO_COLOR, OBJECT_COLOR), strict=True):
        ax.add_patch(Polygon(_outline(x, y, yaw, *dims), closed=True, fc=color, ec="black",
                             lw=0.8, alpha=0.85))
    cx, cy, half = view_box((ex, ey), (ox, oy), view)  # both vehicles in the frame
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ttc = trace.ttc[k]
    text = (f"t {trace.t[k]:5.2f} s\nego {trace.speed[k] * KMH_PER_MS:5.1f} km/h\n"
            f"TTC {'-' if ttc >= 9.99 else f'{ttc:4.2f} s'}\n"
            f"gap {'-' if not trace.seen[k] else f'{trace.gap[k]:5.1f} m'}\n"
            f"brake demand {trace.demand[k]:4.2f}\n"
            f"decel {trace.decel[k]:4.1f} m/s$^2$")
    if trace.outcome and k == len(trace) - 1:
        text += f"\n{trace.outcome}"
    ax.text(0.02, 0.98, text, transform=ax.transAxes, va="top", ha="left", fontsize=8,
            family="monospace", bbox={"fc": "white", "ec": "0.6", "alpha": 0.9})
    ax.set_title(title or f"case {trace.case_id}", fontsize=10)


def frame_to_rgb(fig: Figure) -> np.ndarray:
    """The figure's pixels (H, W, 3) uint8 (it needs an Agg canvas)."""
    fig.canvas.draw()
    buf = np.asarray(fig.canvas.buffer_rgba())  # type: ignore[attr-defined]
    return np.ascontiguousarray(buf[..., :3])


class FrameRenderer:
    """Draws frames of a trace into one reused Agg figure of ``size`` pixels (W, H)."""

    def __init__(self, size: tuple[int, int] = (480, 480), dpi: int = 80) -> None:
        from vfs.report.figures import new_figure

        self.size = size
        self.fig = new_figure((size[0] / dpi, size[1] / dpi), dpi=dpi, agg=True,
                              layout="constrained")
        self.ax = self.fig.add_subplot()

    def rgb(self, trace: EpisodeTrace, step: int = -1) -> np.ndarray:
        """Frame (H, W, 3) uint8 of step ``step``."""
        draw_step(self.ax, trace, step)
        return frame_to_rgb(self.fig)


def ansi_line(trace: EpisodeTrace, step: int = -1) -> str:
    """One line of text for step ``step`` of ``trace`` (the ``ansi`` render mode)."""
    k = step if step >= 0 else len(trace) + step
    ttc = trace.ttc[k]
    line = (f"case {trace.case_id} t={trace.t[k]:6.2f} s  ego {trace.speed[k] * KMH_PER_MS:5.1f}"
            f" km/h  gap {trace.gap[k] if trace.seen[k] else float('nan'):6.1f} m  TTC "
            f"{'  -  ' if ttc >= 9.99 else f'{ttc:5.2f}'} s  demand {trace.demand[k]:4.2f}  "
            f"decel {trace.decel[k]:4.1f} m/s^2")
    if trace.outcome and k == len(trace) - 1:
        line += f"  [{trace.outcome}]"
    return line + "\n"


__all__ = [
    "EGO_COLOR", "OBJECT_COLOR", "VIEW_HALF_WIDTH", "EpisodeTrace", "FrameRenderer",
    "ansi_line", "draw_step", "frame_to_rgb", "record_step", "start_trace", "view_box",
]
