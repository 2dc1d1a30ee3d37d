"""Random but car-like configurations, outlines and case batches (tests and benchmarks).

Everything is drawn from the ``numpy.random.Generator`` passed in and built
with array operations (no per-case loop).
"""

from __future__ import annotations

from typing import Any

import numpy as np


def random_outline_pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """N random car-sized outline pairs in a 6 x 6 m square (about 60 % overlap)."""
    from vfs.physics.geometry import outline_corners

    x = rng.uniform(-3, 3, (n, 2))
    y = rng.uniform(-3, 3, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, (n, 2))
    length = rng.uniform(3.5, 5.5, (n, 2))
    width = rng.uniform(1.5, 2.1, (n, 2))
    front = length * rng.uniform(0.45, 0.6, (n, 2))
    o1 = outline_corners(x[:, 0], y[:, 0], yaw[:, 0], front[:, 0], length[:, 0] - front[:, 0],
                         width[:, 0])
    o2 = outline_corners(x[:, 1], y[:, 1], yaw[:, 1], front[:, 1], length[:, 1] - front[:, 1],
                         width[:, 1])
    return o1, o2


def random_impact_configs(rng: np.random.Generator, n: int) -> Any:
    """N random but car-like impact configurations."""
    from vfs.physics.impact import ImpactConfig

    m = rng.uniform(800, 2600, (2, n))
    return ImpactConfig.from_columns(
        m1=m[0], izz1=m[0] * rng.uniform(1.5, 2.2, n), x1=rng.uniform(-2, 0, n),
        y1=rng.uniform(-1, 1, n), yaw1=rng.uniform(-np.pi, np.pi, n),
        vx1=rng.uniform(-30, 30, n), vy1=rng.uniform(-30, 30, n),
        yaw_rate1=rng.uniform(-0.5, 0.5, n), m2=m[1], izz2=m[1] * rng.uniform(1.5, 2.2, n),
        x2=rng.uniform(0, 2, n), y2=rng.uniform(-1, 1, n), yaw2=rng.uniform(-np.pi, np.pi, n),
        vx2=rng.uniform(-30, 30, n), vy2=rng.uniform(-30, 30, n),
        yaw_rate2=rng.uniform(-0.5, 0.5, n), poi_x=rng.uniform(-1, 1, n),
        poi_y=rng.uniform(-1, 1, n), cp_angle=rng.uniform(0, np.pi, n),
        restitution=rng.uniform(0.05, 0.3, n), contact_friction=rng.uniform(0.2, 0.8, n),
    )


def synthetic_case_batch(n: int, rng: np.random.Generator, duration: float = 5.0,
                         dt: float = 0.01) -> Any:
    """N varied frontal/oblique cases with 10 ms records of ``duration`` s before contact.

    Vehicle 1 drives along a gentle arc or a straight line, vehicle 2 comes
    from the front at an angle of up to 30 deg with a lateral offset, so the
    batch mixes full and sliding impacts.  Built with array operations (no
    per-case loop); for benchmarks and tests.
    """
    from vfs.physics.paths import concat_paths, pack_paths
    from vfs.physics.vehicle import vehicle_arrays
    from vfs.simulation import CaseBatch

    t = np.arange(0.0, duration + 0.5 + 1e-9, dt)
    m = t.size

    def fleet() -> Any:
        mass = rng.uniform(900, 2300, n)
        length = 3.6 + (mass - 900) / 1400 * 1.4
        wheelbase = 0.6 * length
        return vehicle_arrays(mass=mass, length=length, width=1.65 + 0.15 * (mass - 900) / 1400,
                              wheelbase=wheelbase, cg_to_front_axle=0.45 * wheelbase,
                              front_overhang=0.2 * length, track_width=1.5,
                              cg_height=0.55)

    v1, v2 = fleet(), fleet()
    speed1 = rng.uniform(8, 28, n)
    speed2 = rng.uniform(8, 28, n)
    curvature = rng.choice([0.0, 1.0], n) * rng.uniform(-1 / 300, 1 / 300, n)
    angle = np.radians(rng.uniform(-30, 30, n))
    offset = rng.uniform(-1.2, 1.2, n)
    tau = t[None, :] - duration  # 0 at the planned contact
    s1 = speed1[:, None] * tau
    arc = curvature[:, None] * s1
    safe = np.where(np.abs(curvature) < 1e-9, 1.0, curvature)[:, None]
    straight = (np.abs(curvature) < 1e-9)[:, None]
    x1 = np.where(straight, s1, np.sin(arc) / safe)
    y1 = np.where(straight, 0.0, (1 - np.cos(arc)) / safe)
    yaw2 = np.pi + angle
    reach = v1.cg_to_front + v2.cg_to_front
    x2c = reach * np.cos(angle) * 0.5 + 0.5 * reach
    x2 = x2c[:, None] + speed2[:, None] * np.cos(yaw2)[:, None] * tau
    y2 = offset[:, None] + speed2[:, None] * np.sin(yaw2)[:, None] * tau
    group = np.repeat(np.arange(n), m)

    def pack(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, speed: np.ndarray) -> Any:
        return pack_paths(np.tile(t, n), x.ravel(), y.ravel(), yaw.ravel(),
                          np.repeat(speed, m), group)

    p1 = pack(x1, y1, np.broadcast_to(arc, (n, m)), speed1)
    p2 = pack(x2, y2, np.broadcast_to(yaw2[:, None], (n, m)), speed2)
    nan = np.full(n, np.nan)
    return CaseBatch(np.arange(n), v1, v2, concat_paths(p1, p2),
                     rng.uniform(0.5, 0.95, n), nan, nan.copy())


__all__ = ["random_impact_configs", "random_outline_pairs", "synthetic_case_batch"]
