"""Animations of a case in the AEB environment (``vfs run-case --animate``).

:func:`play_traces` plays a case with the recorded behaviour and with an AEB system;
:func:`animate_traces` writes traces side by side as a GIF or MP4, each frame drawn by
:func:`vfs.gym.render.draw_step`, the drawing of the ``rgb_array`` render mode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vfs.gym.render import EpisodeTrace, draw_step


def play_traces(db: Any, case_id: Any, system: str = "three-stage", *, ego: int = 1,
                action_repeat: int = 5) -> tuple[EpisodeTrace, EpisodeTrace]:
    """The episode of ``case_id`` without (recorded behaviour) and with an AEB ``system`` on
    vehicle ``ego``, as traces of the AEB environment (one entry per ``action_repeat``
    simulation steps).
    """
    from vfs.adas.systems import get_system
    from vfs.gym.env import AEBEnv
    from vfs.gym.policies import AEBPolicy
    from vfs.physics.precrash import PrecrashParams

    sys_ = get_system(system)
    brake = sys_.precrash_params(PrecrashParams()).brake  # the system's actuator
    traces = []
    for with_system in (False, True):
        env = AEBEnv(render_mode="ansi", db=db, split="all", ego=ego,
                     action_repeat=action_repeat, brake=brake)
        obs, _ = env.reset(seed=0, options={"case_id": case_id})
        policy = AEBPolicy(sys_).bind(env) if with_system else None
        if policy is not None:
            policy.reset(1, np.random.default_rng(0))
        while True:
            action = policy.act(obs) if policy is not None else np.zeros(1)
            obs, _, term, trunc, _ = env.step(np.asarray(action, np.float32).reshape(1))
            if term or trunc:
                break
        if env.trace is None:  # pragma: no cover - render_mode is set
            raise RuntimeError("no trace recorded")
        traces.append(env.trace)
    return traces[0], traces[1]


def animate_traces(traces: list[EpisodeTrace], titles: list[str], path: str | Any, *,
                   fps: float = 20.0, dpi: int = 80) -> int:
    """Write the traces side by side as an animation (GIF via Pillow, MP4 via ffmpeg).

    Returns
    -------
    int
        Number of frames written (the longest trace's length; shorter ones hold their
        last frame).
    """
    from pathlib import Path

    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter

    from vfs.atomic import write_atomic
    from vfs.errors import ParameterError
    from vfs.report.figures import new_figure

    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ParameterError(f"--animate {target}: use a .gif or .mp4 file")
    if suffix == ".mp4" and not FFMpegWriter.isAvailable():
        raise ParameterError("--animate .mp4 needs ffmpeg on the PATH; write a .gif instead")
    n = max(len(t) for t in traces)
    fig = new_figure((4.2 * len(traces), 4.4), dpi=dpi, agg=True, layout="constrained")
    axes = fig.subplots(1, len(traces), squeeze=False)[0]

    def draw(k: int) -> list[Any]:
        for ax, trace, title in zip(axes, traces, titles, strict=True):
            draw_step(ax, trace, min(k, len(trace) - 1), title=title)
        return list(axes)

    anim = FuncAnimation(fig, draw, frames=n, blit=False)
    rate = max(1, round(fps))  # the writers take whole frames per second
    writer = PillowWriter(fps=rate) if suffix == ".gif" else FFMpegWriter(fps=rate)
    write_atomic(target, lambda tmp: anim.save(str(tmp), writer=writer, dpi=dpi))
    return n


__all__ = ["animate_traces", "play_traces"]
