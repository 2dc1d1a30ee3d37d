"""Figures; matplotlib is imported lazily, and physics modules never import this one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vfs.physics.geometry import vehicle_outline
from vfs.physics.impact import IMPACT_TYPE_NAMES
from vfs.units import KMH_PER_MS

COLORS = ("#1f77b4", "#d62728")


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _outline_patch(ax: Any, corners: np.ndarray, color: str, style: str, label: str | None,
                   fill_alpha: float = 0.0) -> None:
    ring = np.vstack([corners, corners[:1]])
    ax.plot(ring[:, 0], ring[:, 1], style, color=color, lw=1.4, label=label)
    if fill_alpha:
        ax.fill(corners[:, 0], corners[:, 1], color=color, alpha=fill_alpha)
    # mark the front edge
    ax.plot(corners[:2, 0], corners[:2, 1], "-", color=color, lw=3.0)


def plot_case_topview(batch: Any, results: Any, index: int = 0,
                      path: str | Path | None = None, title: str | None = None) -> Any:
    """Top view of one simulated case.

    Shows both recorded paths, the outlines at first contact and at impact,
    the POI and contact plane, velocity vectors before and after the impact,
    the run-out paths and the outlines at rest.  Returns the figure; writes
    it to ``path`` (PNG/SVG/PDF by suffix) when given.
    """
    plt = _pyplot()
    pre, imp, ro = results.precrash, results.impact, results.runout
    n = batch.size
    fig, ax = plt.subplots(figsize=(9, 7))
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
    pts = []
    for j in (0, 1):
        for state in (pre.impact_state, pre.end_state):
            pts.append([state.x[index, j], state.y[index, j]])
        r = ro.result1 if j == 0 else ro.result2
        pts.append([r.rest_x[index], r.rest_y[index]])
    pts = np.array(pts, float)
    pts = pts[~np.isnan(pts).any(axis=1)]
    if pts.size:
        lo, hi = pts.min(axis=0) - 8.0, pts.max(axis=0) + 8.0
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), fontsize=7, loc="best")
    fig.tight_layout()
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=120)
        plt.close(fig)
    return fig
