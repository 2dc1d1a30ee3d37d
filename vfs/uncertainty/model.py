"""The model of the uncertainty analysis: impact configuration -> impact -> run-out.

The model starts from the reconstruction's impact configuration (the
expert's poses, velocities, POI and contact plane, as stored in the database;
docs/data-format.md), not from the pre-crash phase: the full chain
(:func:`vfs.simulation.simulate_cases`, about 2,000 cases/s) is too slow for
10^5-10^6 samples, and an uncertain pre-crash speed is an uncertain speed at
impact.  One sample is

1. the pose moved along the sampled velocities by the change of the
   penetration time (the contact pose is estimated by moving both vehicles
   back along their velocities until the outlines just touch,
   :func:`vfs.uncertainty.cases.estimate_penetration`); POI and contact plane
   move by the change of the geometric POI / contact plane (the Momentum Based Impact Model paper's
   Sutherland-Hodgman rule, :func:`vfs.physics.geometry.contact_geometry`)
   between the recorded and the moved pose, so that the expert's POI is kept
   at the nominal penetration;
2. the contact plane turned and the POI shifted along and normal to it (the
   normal from vehicle 2 towards vehicle 1 of :func:`vfs.physics.impact.contact_frame`);
3. speeds (direction kept; the yaw rate scaled with the speed, i.e. the path
   curvature kept), masses (yaw inertia scaled with the mass: same geometry,
   consistent with I = m L1 L2), restitution and contact friction;
4. the simulation's impact stage (:func:`vfs.simulation.impact_stage`: the
   Kudlich-Slibar impulse impact of :func:`vfs.physics.impact.solve_impact`,
   the Collision Calculation Uncertainty paper eqs. 6-11) and its run-out stage
   (:func:`vfs.simulation.runout_stage`)
   of both vehicles to rest with the sampled road friction and post-crash
   wheel brake factors, at a coarser time step than the simulation (20 ms:
   docs/uncertainty.md gives its accuracy).

Deliberate simplifications, as options of the shared stages: no physical
effects (:mod:`vfs.effects`; ``SimulationParams(effects=())``) and no check
for secondary collisions in the run-out (``secondary_collisions=False``; they
are detected, never solved, so the rest poses are the same).

All samples of all cases are flattened into one batch of S x N rows and
solved by the vectorised kernels (in memory-bounded chunks).  SI units.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from vfs.database.post_impact import post_impact_inputs
from vfs.effects.learned import corner_wheels
from vfs.errors import ParameterError
from vfs.outcomes import from_results
from vfs.physics.geometry import contact_geometry, vehicle_outline
from vfs.physics.impact import IMPACT_SLIDING, ImpactConfig, contact_frame
from vfs.physics.post_impact import PostImpactInputs
from vfs.physics.precrash import KinematicState
from vfs.physics.vehicle import VehicleArrays
from vfs.progress import progress
from vfs.simulation import ImpactInputs, SimulationParams, impact_stage, runout_stage
from vfs.uncertainty.cases import CaseSet
from vfs.uncertainty.config import INPUT_NAMES, UncertaintyConfig
from vfs.uncertainty.outcomes import OUTCOME_NAMES, OUTCOMES
from vfs.uncertainty.sampling import SampledInputs, resolve_inputs
from vfs.units import wrap_axial


class ModelRuns(NamedTuple):
    """Outcomes of M model runs (arrays (M,), SI units).

    Attributes
    ----------
    outcomes : mapping of str to ndarray
        One array per name of :data:`vfs.uncertainty.outcomes.OUTCOME_NAMES`.
    impact_type : ndarray of int
        0 none (separating), 1 full, 2 sliding
        (:data:`vfs.physics.impact.IMPACT_TYPE_NAMES`).
    at_rest : ndarray of bool (M, 2)
        Both vehicles came to rest within the run-out time.
    geometry_fallback : ndarray of bool
        The moved pose had no overlap; POI / contact plane kept unmoved.
    """

    outcomes: Mapping[str, np.ndarray]
    impact_type: np.ndarray
    at_rest: np.ndarray
    geometry_fallback: np.ndarray


#: Runs solved per chunk (bounds the memory of the run-out).
CHUNK_ROWS = 25_000


class _Cases(NamedTuple):
    """What the impact stage reads of the runs (:class:`vfs.simulation.ImpactCases`)."""

    vehicle1: VehicleArrays
    vehicle2: VehicleArrays
    road_friction: np.ndarray


def evaluate(cases: CaseSet, inputs: SampledInputs, config: UncertaintyConfig,
             chunk: int = CHUNK_ROWS, *, show: str = "") -> ModelRuns:
    """Run the impact and run-out model for M sampled input sets (vectorised).

    Parameters
    ----------
    cases : CaseSet
    inputs : SampledInputs
        Case positions and input values (SI) of the runs.
    config : UncertaintyConfig
        Model settings (run-out time step, horizon).
    chunk : int
        Runs per vectorised block.
    show : str
        What the runs are, for a progress bar or lines (:mod:`vfs.progress`); empty: none
        (the many small evaluations of a reconstruction).

    Returns
    -------
    ModelRuns
    """
    m = inputs.rows.shape[0]
    params = SimulationParams(runout=config.runout_params())
    post = post_impact_inputs(cases.reconstruction, cases.case_id)
    step = max(1, chunk)
    parts = []
    shown = progress(m, show, "run") if show else None
    for s in range(0, m, step):
        parts.append(_evaluate_block(cases, inputs.rows[s:s + step],
                                     inputs.values[s:s + step], params, post,
                                     config.wheel_brake))
        if shown is not None:
            shown.update(min(step, m - s))
    if shown is not None:
        shown.close()
    if not parts:
        raise ParameterError("no model runs to evaluate")
    outcomes = {k: np.concatenate([p.outcomes[k] for p in parts]) for k in OUTCOME_NAMES}
    return ModelRuns(MappingProxyType(outcomes),
                     np.concatenate([p.impact_type for p in parts]),
                     np.concatenate([p.at_rest for p in parts]),
                     np.concatenate([p.geometry_fallback for p in parts]))


def _velocities(c0: ImpactConfig, col: Mapping[str, np.ndarray]
                ) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Sampled CG velocities [m/s] and yaw rates [rad/s]: the recorded direction
    kept (the heading below 1 mm/s), the yaw rate scaled with the speed (path
    curvature kept).
    """
    vel = {}
    for i in (1, 2):
        vx, vy = c0.vx[:, i - 1], c0.vy[:, i - 1]
        speed = np.hypot(vx, vy)
        yaw = c0.yaw[:, i - 1]
        moving = speed > 1e-3
        dx = np.where(moving, vx / np.where(moving, speed, 1.0), np.cos(yaw))
        dy = np.where(moving, vy / np.where(moving, speed, 1.0), np.sin(yaw))
        s = col[f"speed{i}"]
        scale = np.where(speed > 0.5, s / np.where(speed > 0.5, speed, 1.0), 1.0)
        vel[i] = (dx * s, dy * s, c0.yaw_rate[:, i - 1] * scale)
    return vel


def _run_brakes(post: PostImpactInputs | None, rows: np.ndarray, sampled: np.ndarray,
                nominal: float, i: int) -> np.ndarray:
    """Brake factors (M, 4) [-] of vehicle ``i`` in the runs: the sampled factor on every
    wheel; where the case's data give the vehicle's post-impact brakes
    (:class:`vfs.physics.post_impact.PostImpactInputs`), those wheel by wheel, shifted by the
    sampled deviation from the nominal ``nominal`` and clipped to [0, 1].
    """
    plain = np.repeat(sampled[:, None], 4, axis=1)
    if post is None:
        return plain
    sub = post.take(rows)
    given = ~(np.isnan(sub.brake[:, i - 1]).all(axis=1) & np.isnan(sub.driver_brake[:, i - 1]))
    if not given.any():
        return plain
    data = sub.wheel_brake((nominal,) * 4)[:, i - 1]
    shifted = np.clip(data + (sampled - nominal)[:, None], 0.0, 1.0)
    return np.where(given[:, None], shifted, plain)


def _corner_brakes(brakes: list[np.ndarray], runs: _Cases, config: ImpactConfig,
                   extra1: np.ndarray, extra2: np.ndarray) -> None:
    """Add the sampled extra brake factor [-] to the impact-corner wheel of each vehicle
    (:func:`vfs.effects.learned.corner_wheels`), clipped to [0, 1], in place; nothing where
    it is 0 (the default).
    """
    if not (np.any(extra1 != 0.0) or np.any(extra2 != 0.0)):
        return
    rows = np.arange(config.size)
    for b, w, extra in zip(brakes, corner_wheels(runs.vehicle1, runs.vehicle2, config),
                           (extra1, extra2), strict=True):
        b[rows, w] = np.clip(b[rows, w] + extra, 0.0, 1.0)


def _run_wheels(post: PostImpactInputs | None, rows: np.ndarray, steer1: np.ndarray,
                steer2: np.ndarray) -> PostImpactInputs | None:
    """The run-out inputs beyond the brakes of the runs: the case's drag per wheel and
    steering onset (where the data give them) and the sampled steer angles [rad] (their
    nominal value is the data's, :func:`vfs.uncertainty.sampling.nominal_inputs`); None
    when nothing steers or drags (the run-out without wheel inputs, bit for bit the same).
    """
    if post is None and not (np.any(steer1 != 0.0) or np.any(steer2 != 0.0)):
        return None
    sub = PostImpactInputs.unknown(rows.shape[0]) if post is None else post.take(rows)
    return sub.with_steer(1, steer1).with_steer(2, steer2)


def _evaluate_block(cases: CaseSet, rows: np.ndarray, x: np.ndarray,
                    params: SimulationParams, post: PostImpactInputs | None = None,
                    nominal_brake: float = 0.8) -> ModelRuns:
    c0 = ImpactConfig(*(a[rows] for a in cases.config))
    v1, v2 = cases.vehicle1.take(rows), cases.vehicle2.take(rows)
    col = {name: x[:, k] for k, name in enumerate(INPUT_NAMES)}
    vel = _velocities(c0, col)
    # penetration: move the poses along the sampled velocities by the change of time
    tau = col["penetration_time"] - cases.penetration[rows]
    pose = {}
    for i in (1, 2):
        vx, vy, w = vel[i]
        pose[i] = (c0.x[:, i - 1] + tau * vx, c0.y[:, i - 1] + tau * vy,
                   c0.yaw[:, i - 1] + tau * w)
    poi_x, poi_y, cp = c0.poi_x.copy(), c0.poi_y.copy(), c0.cp_angle.copy()
    fallback = np.zeros(rows.shape[0], dtype=bool)
    moved = np.flatnonzero(np.abs(tau) > 1e-12)
    if moved.size:
        o1 = vehicle_outline(v1.take(moved), pose[1][0][moved], pose[1][1][moved],
                             pose[1][2][moved])
        o2 = vehicle_outline(v2.take(moved), pose[2][0][moved], pose[2][1][moved],
                             pose[2][2][moved])
        geo = contact_geometry(o1, o2, np.stack([pose[1][0][moved], pose[1][1][moved]], 1),
                               np.stack([pose[2][0][moved], pose[2][1][moved]], 1))
        base_poi = cases.geo_poi[rows[moved]]
        base_cp = cases.geo_cp[rows[moved]]
        dpx, dpy = geo.poi[:, 0] - base_poi[:, 0], geo.poi[:, 1] - base_poi[:, 1]
        dcp = wrap_axial(geo.cp_angle - base_cp)  # the plane's orientation is irrelevant
        bad = ~(np.isfinite(dpx) & np.isfinite(dpy) & np.isfinite(dcp))
        fallback[moved] = bad
        poi_x[moved] += np.where(bad, 0.0, dpx)
        poi_y[moved] += np.where(bad, 0.0, dpy)
        cp[moved] += np.where(bad, 0.0, dcp)
    cp = cp + col["cp_angle"]
    # masses; the yaw inertia keeps its radius of gyration
    m1, m2 = col["mass1"], col["mass2"]
    izz1, izz2 = c0.izz[:, 0] * m1 / c0.m[:, 0], c0.izz[:, 1] * m2 / c0.m[:, 1]

    def pair(one: np.ndarray, two: np.ndarray) -> np.ndarray:
        return np.stack([one, two], axis=1)

    # POI shift along the turned plane's angle and along its normal from vehicle 2
    # towards vehicle 1 (the impact model's contact frame)
    turned = ImpactConfig(
        m=pair(m1, m2), izz=pair(izz1, izz2), x=pair(pose[1][0], pose[2][0]),
        y=pair(pose[1][1], pose[2][1]), yaw=pair(pose[1][2], pose[2][2]),
        vx=pair(vel[1][0], vel[2][0]), vy=pair(vel[1][1], vel[2][1]),
        yaw_rate=pair(vel[1][2], vel[2][2]), poi_x=poi_x, poi_y=poi_y, cp_angle=cp,
        restitution=col["restitution"], contact_friction=col["contact_friction"])
    frame = contact_frame(turned)
    poi_x = poi_x + col["poi_shift_t"] * np.cos(cp) + col["poi_shift_n"] * frame.nx
    poi_y = poi_y + col["poi_shift_t"] * np.sin(cp) + col["poi_shift_n"] * frame.ny
    # the simulation's impact and run-out stages, without effects
    k = rows.shape[0]
    vx, vy = turned.vx, turned.vy
    state = KinematicState(turned.x, turned.y, turned.yaw, vx, vy, turned.yaw_rate,
                           np.hypot(vx, vy))
    runs = _Cases(v1._replace(mass=m1, yaw_inertia=izz1), v2._replace(mass=m2, yaw_inertia=izz2),
                  col["road_friction"])
    at = ImpactInputs(state, np.stack([poi_x, poi_y], axis=1), cp,
                      contact_time=-col["penetration_time"], impact_time=np.zeros(k))
    solved, res, _, _ = impact_stage(runs, at, np.arange(k), col["restitution"],
                                     col["contact_friction"], params)
    brakes = [_run_brakes(post, rows, col[f"wheel_brake{i}"], nominal_brake, i)
              for i in (1, 2)]
    _corner_brakes(brakes, runs, solved, col["corner_brake1"], col["corner_brake2"])
    ro = runout_stage(runs.vehicle1, runs.vehicle2, state, res, col["road_friction"],
                      params.runout, brakes[0], brakes[1],
                      secondary_collisions=False,
                      post_impact=_run_wheels(post, rows, col["steer1"], col["steer2"]))
    columns: dict[str, np.ndarray] = {"energy_loss": res.energy_loss,
                                      "closing_speed": res.closing_speed}
    for i in (1, 2):
        columns[f"x{i}"], columns[f"y{i}"] = pose[i][0], pose[i][1]
        for name in ("delta_v", "ees", "pdof", "velocity_angle_change"):
            columns[f"{name}{i}"] = getattr(res, name)[:, i - 1]
        columns[f"vx{i}_post"] = res.vx_post[:, i - 1]
        columns[f"vy{i}_post"] = res.vy_post[:, i - 1]
        columns[f"rest_x{i}"], columns[f"rest_y{i}"] = ro.rest_x[:, i - 1], ro.rest_y[:, i - 1]
        columns[f"rest_yaw{i}"] = ro.rest_yaw[:, i - 1]
    derived = from_results(columns, sorted({o.vocabulary for o in OUTCOMES} - {"sliding"}))
    out: dict[str, np.ndarray] = {}
    for o in OUTCOMES:
        if o.vocabulary != "sliding":
            out[o.name] = np.ascontiguousarray(derived[o.vocabulary][:, max(o.vehicle, 1) - 1])
    # an indicator over every run: a separating run is not sliding (0, not NaN)
    out["sliding"] = (res.impact_type == IMPACT_SLIDING).astype(float)
    ordered = {name: out[name] for name in OUTCOME_NAMES}
    return ModelRuns(ordered, res.impact_type, ro.at_rest, fallback)


def nominal_runs(cases: CaseSet, config: UncertaintyConfig) -> ModelRuns:
    """The model at the nominal inputs of every case (one run per case)."""
    res = resolve_inputs(cases, config)
    rows = np.arange(cases.size)
    x = SampledInputs(rows, res.nominal.T.copy(), np.zeros(len(INPUT_NAMES), dtype=int))
    return evaluate(cases, x, config)


__all__ = ["CHUNK_ROWS", "ModelRuns", "evaluate", "nominal_runs"]
