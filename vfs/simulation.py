"""One virtual forward simulation per case, for many cases at once.

    opening (vehicle hooks, penetration rule, impact parameters: open_cases)
    ->  pre-crash replay (+ controller)  ->  first contact, penetration
        ->  POI / contact plane (geometry)  ->  impulse impact  ->  run-out to rest

Every stage is a vectorised kernel over the cases of a :class:`CaseBatch`;
one case is a batch of one.  :func:`results_table` flattens the outcome into
one tidy row per case.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from vfs.effects.base import Effect, VelocityChange, apply_post_impact, check_effects, hooks
from vfs.effects.context import ContactContext, ImpactContext
from vfs.errors import ParameterError, SimulationError
from vfs.physics.impact import (
    CONFIG_IMPACT_FIELDS,
    CONFIG_VEHICLE_FIELDS,
    FIXED_OBJECT_MASS,
    RESULT_COLUMNS,
    ImpactConfig,
    ImpactParams,
    ImpactResult,
    deformation_energies,
    impact_type_names,
    solve_impact,
    with_outcome,
)
from vfs.physics.paths import PathArrays, concat_paths
from vfs.physics.precrash import (
    BrakeController,
    KinematicState,
    PrecrashParams,
    PrecrashResult,
    SegmentedRandom,
    simulate_precrash,
)
from vfs.physics.runout import (
    PairRunoutResult,
    PostImpactInputs,
    RunoutMemo,
    RunoutParams,
    RunoutResult,
    RunoutState,
    run_out,
    run_out_pair,
)
from vfs.physics.vehicle import VehicleArrays
from vfs.settings import Rule, member, setting, validate

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from vfs.database import Database


class ImpactParameterSource(StrEnum):
    """Where restitution and contact friction come from (``--impact-parameters``;
    :meth:`CaseBatch.from_database`).
    """

    RECONSTRUCTION = "reconstruction"
    DEFAULT = "default"


@dataclass(frozen=True)
class SimulationParams:
    """Parameters of the whole simulation chain (each part documents its defaults).

    Attributes
    ----------
    precrash, impact, runout
        Parameters of the three phases.
    effects : tuple of Effect
        Physical effects added to the default model (:mod:`vfs.effects`),
        applied at their stages in this order; default none.
    secondary_collisions : bool
        Flag pairs that touch again in the run-out (default True); False
        skips that check, a third of the run-out's cost: the rest poses are
        the same (secondary collisions are detected, not solved) and the
        results report none (the model-variant searches of :mod:`vfs.analysis`,
        whose outcomes do not include the flag).
    runout_paths : bool
        Record the run-out's path samples and kinetic energies (default True, the
        figures of a case); False leaves them empty and keeps every other result to
        the last bit (the model-variant searches: they compare rest poses); needs
        ``secondary_collisions`` False (the check follows the paths).
    """

    precrash: PrecrashParams = field(default_factory=PrecrashParams)
    impact: ImpactParams = field(default_factory=ImpactParams)
    runout: RunoutParams = field(default_factory=RunoutParams)
    effects: tuple[Effect, ...] = ()
    secondary_collisions: bool = setting(True, "bool", "flag pairs that touch again in the "
                                         "run-out (false: a third less run-out cost, none "
                                         "reported)")
    runout_paths: bool = setting(True, "bool", "record the run-out's path samples and "
                                 "kinetic energies (false: empty, every other result the same)")

    #: Rules between the settings.
    RULES = (Rule(("secondary_collisions", "runout_paths"),
                  lambda p: p.runout_paths or not p.secondary_collisions,
                  "runout_paths=False needs secondary_collisions=False: the "
                  "secondary-collision check follows the run-out paths"),)

    def __post_init__(self) -> None:
        object.__setattr__(self, "effects", check_effects(self.effects))
        validate(self)


class CaseBatch(NamedTuple):
    """N cases ready for simulation.

    Attributes
    ----------
    case_id : ndarray (N,)
        Case identifiers.
    vehicle1, vehicle2 : VehicleArrays
        The two vehicles of each case.
    paths : PathArrays
        Recorded paths, participant 1 of all cases then participant 2 (2N).
    road_friction : ndarray (N,)
        Tyre-road friction coefficient.
    restitution, contact_friction : ndarray (N,)
        Impact parameters per case; NaN = the default of :class:`ImpactParams`.
    yaw_inertia_known : ndarray of bool (N, 2), optional
        True where the data gave the yaw inertia (False: estimated by the
        default formula); None = all estimated.
    fixed_object : ndarray of bool (N, 2), optional
        True where a participant is a rigid fixed object (barrier, wall, pole):
        infinite mass and yaw inertia in the impact (:data:`vfs.physics.impact.FIXED_OBJECT_MASS`),
        hence no velocity change and no run-out; None = no fixed objects.
    post_impact : PostImpactInputs, optional
        What the reconstruction gives of the run-out (wheel brakes, driver braking, extra
        drag per wheel, steer angle and its onset; NaN = default); None = nothing, every
        vehicle runs out with ``RunoutParams``' defaults.
    """

    case_id: np.ndarray
    vehicle1: VehicleArrays
    vehicle2: VehicleArrays
    paths: PathArrays
    road_friction: np.ndarray
    restitution: np.ndarray
    contact_friction: np.ndarray
    yaw_inertia_known: np.ndarray | None = None
    fixed_object: np.ndarray | None = None
    post_impact: PostImpactInputs | None = None

    @property
    def size(self) -> int:
        """Number of cases N."""
        return int(self.case_id.shape[0])

    def take(self, index: npt.ArrayLike) -> CaseBatch:
        """Select cases by index (or mask)."""
        idx = np.arange(self.size)[index]
        both = np.concatenate([idx, idx + self.size])
        known = None if self.yaw_inertia_known is None else self.yaw_inertia_known[idx]
        return CaseBatch(self.case_id[idx], self.vehicle1.take(idx), self.vehicle2.take(idx),
                         self.paths.take(both), self.road_friction[idx],
                         self.restitution[idx], self.contact_friction[idx], known,
                         None if self.fixed_object is None else self.fixed_object[idx],
                         None if self.post_impact is None else self.post_impact.take(idx))

    @property
    def inertia_known(self) -> np.ndarray:
        """:attr:`yaw_inertia_known` with None expanded to all False (N, 2)."""
        if self.yaw_inertia_known is None:
            return np.zeros((self.size, 2), dtype=bool)
        return self.yaw_inertia_known

    @classmethod
    def from_database(cls, db: Database, case_ids: npt.ArrayLike | None = None,
                      impact_parameters: str = "reconstruction") -> CaseBatch:
        """Build a batch from a :class:`vfs.database.Database` (all cases by default).

        Parameters
        ----------
        db : Database
        case_ids : array_like, optional
            Cases in the wanted order (default: all, in database order).
        impact_parameters : {"reconstruction", "default"}
            Where restitution and contact friction come from:
            ``"reconstruction"`` takes the expert's per-case values where the
            database has them (the others use :class:`ImpactParams`);
            ``"default"`` uses :class:`ImpactParams` for every case.
        """
        impact_parameters = member(ImpactParameterSource, impact_parameters,
                                   owner="CaseBatch.from_database", name="impact_parameters")
        import pandas as pd  # the database's tables; imported here to keep the core light

        from vfs.database.paths import paths_from_trajectories
        from vfs.database.post_impact import post_impact_inputs

        ids = np.asarray(db.case_ids if case_ids is None else case_ids)
        sub = db.subset(ids) if case_ids is not None else db
        v1, v2 = sub.vehicles()
        order = pd.Index(sub.case_ids).get_indexer(ids)
        v1, v2 = v1.take(order), v2.take(order)
        cases = sub.cases.set_index("case_id").loc[ids]
        paths = concat_paths(paths_from_trajectories(sub.trajectories, ids, 1),
                             paths_from_trajectories(sub.trajectories, ids, 2))
        eps = np.full(ids.shape[0], np.nan)
        mu = eps.copy()
        rec = getattr(sub, "reconstruction", None)
        if (impact_parameters is ImpactParameterSource.RECONSTRUCTION and rec is not None
                and not rec.empty
                and {"restitution", "contact_friction"} <= set(rec.columns)):
            r = rec.drop_duplicates("case_id").set_index("case_id").reindex(ids)
            eps = r["restitution"].to_numpy(float)
            mu = r["contact_friction"].to_numpy(float)
        parts = sub.participants.drop_duplicates(["case_id", "participant"]).set_index(
            ["case_id", "participant"])["yaw_inertia"]
        known = np.stack([
            np.isfinite(parts.reindex(pd.MultiIndex.from_arrays(
                [ids, np.full(ids.shape[0], k)])).to_numpy(float)) for k in (1, 2)], axis=1)
        fixed = None
        if "fixed_object" in sub.participants.columns:
            flags = sub.participants.drop_duplicates(["case_id", "participant"]).set_index(
                ["case_id", "participant"])["fixed_object"].astype(bool)
            fixed = np.stack([flags.reindex(pd.MultiIndex.from_arrays(
                [ids, np.full(ids.shape[0], k)])).fillna(False).to_numpy(bool)
                for k in (1, 2)], axis=1)
            fixed = fixed if fixed.any() else None
        post = post_impact_inputs(rec, ids) if rec is not None and not rec.empty else None
        return cls(ids, v1, v2, paths, cases["road_friction"].to_numpy(float), eps, mu, known,
                   fixed, post if post is not None and post.given else None)


class CaseResults(NamedTuple):
    """Outcome of :func:`simulate_cases` for N cases (arrays aligned with the batch).

    Attributes
    ----------
    precrash : PrecrashResult
        Contact, impact configuration, closest approach, braking; its POI and
        contact plane are the geometric ones (before any effect).
    impact : ImpactResult
        Impact outcome; rows without a collision are NaN (impact_type 0).
    runout : PairRunoutResult
        Rest positions etc.; rows without a collision hold the pose at the
        end of the pre-crash phase with NaN run-out figures.
    restitution, contact_friction : ndarray (N,)
        The impact parameters used (after effects).
    poi : ndarray (N, 2)
        The POI the impact was solved at [m] (after effects).
    cp_angle : ndarray (N,)
        The contact-plane tangent used [rad] (after effects).
    wheel_brake : ndarray (N, 2, 4)
        Brake factors of the wheels FL, FR, RL, RR of both vehicles in the run-out.
    """

    precrash: PrecrashResult
    impact: ImpactResult
    runout: PairRunoutResult
    restitution: np.ndarray
    contact_friction: np.ndarray
    poi: np.ndarray
    cp_angle: np.ndarray
    wheel_brake: np.ndarray


def _scatter_impact(n: int, rows: np.ndarray, part: ImpactResult) -> ImpactResult:
    out = []
    for values in part:
        shape = (n,) + values.shape[1:]
        if values.dtype.kind in "iu":
            full = np.zeros(shape, dtype=values.dtype)
        else:
            full = np.full(shape, np.nan)
        full[rows] = values
        out.append(full)
    return ImpactResult(*out)


def _take_rows(state: KinematicState, rows: np.ndarray) -> KinematicState:
    return KinematicState(*(a[rows] for a in state))


PenetrationRule = Callable[[np.ndarray, KinematicState], np.ndarray]


def penetration_rule(batch: CaseBatch, effects: tuple[Effect, ...]) -> PenetrationRule | None:
    """The penetration-time callback of :func:`simulate_precrash` from the effects' hooks.

    Parameters
    ----------
    batch : CaseBatch
        The cases (after the ``vehicles`` hooks).
    effects : tuple of Effect
        Effects whose ``penetration`` hooks give the penetration time [s].

    Returns
    -------
    callable or None
        ``rule(rows, state) -> t`` [s] (NaN: the default), or None when no
        effect has a ``penetration`` hook.
    """
    stage = hooks(effects, "penetration")
    if not stage:
        return None

    def rule(rows: np.ndarray, state: KinematicState) -> np.ndarray:
        ctx = ContactContext(rows, batch.vehicle1.take(rows), batch.vehicle2.take(rows), state,
                             batch.road_friction[rows])
        t = np.full(rows.shape[0], np.nan)
        for hook in stage:
            t = np.asarray(hook(ctx, t), float)
        return t

    return rule


class ImpactInputs(NamedTuple):
    """What the impact stage reads of a pre-crash run (a :class:`PrecrashResult` is one).

    Attributes
    ----------
    impact_state : KinematicState
        State of both vehicles at the impact (N, 2) [m, rad, m/s, rad/s].
    poi : ndarray (N, 2)
        Geometric point of impact [m].
    cp_angle : ndarray (N,)
        Contact-plane tangent [rad].
    contact_time, impact_time : ndarray (N,)
        First contact and impact [s].
    """

    impact_state: KinematicState
    poi: np.ndarray
    cp_angle: np.ndarray
    contact_time: np.ndarray
    impact_time: np.ndarray


def impact_parameters_or_default(restitution: npt.ArrayLike, contact_friction: npt.ArrayLike,
                                 params: ImpactParams) -> tuple[np.ndarray, np.ndarray]:
    """Restitution and contact friction with NaN replaced by the defaults of ``params``.

    Parameters
    ----------
    restitution, contact_friction : array_like (N,)
        Per-case values [-]; NaN = no value of its own.
    params : ImpactParams
        Defaults for the cases without their own values.

    Returns
    -------
    restitution, contact_friction : ndarray (N,)
        [-]
    """
    eps = np.asarray(restitution, dtype=float)
    mu = np.asarray(contact_friction, dtype=float)
    return (np.where(np.isnan(eps), params.restitution, eps),
            np.where(np.isnan(mu), params.contact_friction, mu))


def impact_parameters(batch: CaseBatch, params: ImpactParams) -> tuple[np.ndarray, np.ndarray]:
    """Restitution and contact friction per case: the batch's values, NaN -> ``params``
    (:func:`impact_parameters_or_default`).

    Parameters
    ----------
    batch : CaseBatch
    params : ImpactParams
        Defaults for the cases without their own values.

    Returns
    -------
    restitution, contact_friction : ndarray (N,)
        [-]
    """
    return impact_parameters_or_default(batch.restitution, batch.contact_friction, params)


class ImpactCases(Protocol):
    """What :func:`impact_stage` reads of the cases (a :class:`CaseBatch` is one)."""

    @property
    def vehicle1(self) -> VehicleArrays:
        """Vehicle 1 of the N cases."""

    @property
    def vehicle2(self) -> VehicleArrays:
        """Vehicle 2 of the N cases."""

    @property
    def road_friction(self) -> np.ndarray:
        """Tyre-road friction coefficient (N,) [-]."""


def impact_stage(batch: ImpactCases, pre: ImpactInputs | PrecrashResult, hit: np.ndarray,
                 eps: np.ndarray, mu: np.ndarray, params: SimulationParams
                 ) -> tuple[ImpactConfig, ImpactResult, np.ndarray, np.ndarray]:
    """Impact configuration, solution and run-out brakes of the colliding rows ``hit``:
    :func:`impact_stage_inputs` with the run-out inputs cut to the brake factors
    ``wheel_brake1``, ``wheel_brake2`` (M, 4) [-] (for callers that steer no wheel).
    """
    config, result, inputs = impact_stage_inputs(batch, pre, hit, eps, mu, params)
    return config, result, np.array(inputs.brake[:, 0]), np.array(inputs.brake[:, 1])


def impact_stage_inputs(batch: ImpactCases, pre: ImpactInputs | PrecrashResult,
                        hit: np.ndarray, eps: np.ndarray, mu: np.ndarray,
                        params: SimulationParams
                        ) -> tuple[ImpactConfig, ImpactResult, PostImpactInputs]:
    """Impact configuration, solution and run-out inputs of the colliding rows ``hit``.

    Every effect hook of ``params.effects`` acts at its stage: impact
    configuration and parameters, contact-phase impulses, the EES energy
    split and the post-impact wheel brakes.

    Parameters
    ----------
    batch : ImpactCases
        All N cases (a :class:`CaseBatch`, or vehicles and road friction only).
    pre : ImpactInputs or PrecrashResult
        Impact state, geometric POI / contact plane and times of the N cases.
    hit : ndarray of int (M,)
        Rows that collide.
    eps, mu : ndarray (N,)
        Restitution and contact friction before effects [-]
        (:func:`impact_parameters`).
    params : SimulationParams

    Returns
    -------
    config : ImpactConfig
        The M impact configurations as solved (after effects).
    result : ImpactResult
        Their solution (with the contact-phase impulses and energy split).
    inputs : PostImpactInputs
        The M collisions' run-out inputs: the cases' post-impact inputs
        (``batch.post_impact``, where it has them), the brake factors of the wheels FL, FR,
        RL, RR [-] all given (else ``params.runout``'s), then the effects' ``post_impact``
        hooks (brakes, steer angles [rad]; :func:`vfs.effects.base.apply_post_impact`).
    """
    effects = params.effects
    st = _take_rows(pre.impact_state, hit)
    v1, v2 = batch.vehicle1.take(hit), batch.vehicle2.take(hit)
    mass = np.stack([v1.mass, v2.mass], axis=1)
    izz = np.stack([v1.yaw_inertia, v2.yaw_inertia], axis=1)
    # rigid fixed objects (N, 2) bool, where the cases say (a CaseBatch may; others have none)
    fixed_object = getattr(batch, "fixed_object", None)
    if fixed_object is not None:  # the limit 1/m = 0 (vfs.physics.impact)
        fixed = fixed_object[hit]
        mass, izz = (np.where(fixed, FIXED_OBJECT_MASS, a) for a in (mass, izz))
    config = ImpactConfig.from_arrays(
        m=mass, izz=izz, x=st.x, y=st.y, yaw=st.yaw, vx=st.vx, vy=st.vy, yaw_rate=st.yaw_rate,
        poi_x=pre.poi[hit, 0], poi_y=pre.poi[hit, 1], cp_angle=pre.cp_angle[hit],
        restitution=eps[hit], contact_friction=mu[hit],
    )
    ctx = ImpactContext(hit, v1, v2, st, batch.road_friction[hit],
                        pre.contact_time[hit], pre.impact_time[hit])
    for stage in ("impact_configuration", "impact_parameters"):
        for hook in hooks(effects, stage):
            config = hook(ctx, config)
    result = solve_impact(config, restitution_mode=params.impact.restitution_mode)
    impulse_hooks = hooks(effects, "contact_impulse")
    split_hooks = hooks(effects, "energy_split")
    change = VelocityChange.zeros(config.size)
    for hook in impulse_hooks:
        change = change + hook(ctx, config, result)
    # no impulse and no split (e.g. an impulse law at its neutral value): the result as
    # solved, bit for bit
    if split_hooks or any(np.any(a != 0.0) for a in change):
        e1, e2 = deformation_energies(config, result)
        for hook in split_hooks:
            e1, e2 = hook(ctx, config, result, e1, e2)
        active = (result.impact_type != 0)[:, None]
        change = VelocityChange(*(np.where(active, a, 0.0) for a in change))
        result = with_outcome(config, result, vx=result.vx_post + change.dvx,
                              vy=result.vy_post + change.dvy,
                              yaw_rate=result.yaw_rate_post + change.dw,
                              energy=np.stack([e1, e2], axis=1))
    post = getattr(batch, "post_impact", None)  # a CaseBatch may give them; others have none
    post = PostImpactInputs.unknown(hit.shape[0]) if post is None else post.take(hit)
    brake = post.wheel_brake(params.runout.wheel_brake)
    inputs = apply_post_impact(effects, ctx, config, result,
                               post.with_brakes(brake[:, 0], brake[:, 1]))
    return config, result, inputs


class OpenedCases(NamedTuple):
    """The cases as the pre-crash, impact and run-out stages see them (:func:`open_cases`).

    Attributes
    ----------
    batch : CaseBatch
        The cases after the effects' ``vehicles`` hooks.
    penetration : callable or None
        The penetration-time rule of the effects (:func:`penetration_rule`);
        None: ``PrecrashParams.penetration_time``.
    restitution, contact_friction : ndarray (N,)
        Impact parameters before the impact-stage effects [-]
        (:func:`impact_parameters`).
    """

    batch: CaseBatch
    penetration: PenetrationRule | None
    restitution: np.ndarray
    contact_friction: np.ndarray


def open_cases(batch: CaseBatch, params: SimulationParams) -> OpenedCases:
    """The opening of every simulation of ``batch``: the stages before the pre-crash run.

    In this order: the effects' ``vehicles`` hooks (vehicle data), their
    ``penetration`` rule, the impact parameters per case (the batch's values,
    NaN -> ``params.impact``).  :func:`simulate_cases` and the gym
    environments (:mod:`vfs.gym.env`) open their cases here, so a new stage
    is added once.

    Parameters
    ----------
    batch : CaseBatch
    params : SimulationParams

    Returns
    -------
    OpenedCases
    """
    for hook in hooks(params.effects, "vehicles"):
        batch = hook(batch)
    eps, mu = impact_parameters(batch, params.impact)
    return OpenedCases(batch, penetration_rule(batch, params.effects), eps, mu)


def check_record_spacing(batch: CaseBatch) -> None:
    """Refuse records whose samples lie further apart on average than a valid database allows.

    The pre-crash run steps every case through its whole record, so the steps a
    case needs follow from its duration [s]; a time column in milliseconds (or
    dates read as seconds) makes that a thousand to a billion times longer
    and the run would not end in any useful time.  A record that passed
    :func:`vfs.database.validation.validate_database` has sample spacings of at most
    :data:`vfs.database.schema.MAX_SAMPLE_SPACING` [s], so its duration is at
    most that times its samples less one: the cap on the steps of each case.

    Raises
    ------
    SimulationError
        Naming the cases, the record's duration [s], its samples and the cap.
    """
    from vfs.database.schema import MAX_SAMPLE_SPACING

    paths = batch.paths
    n = batch.size
    duration = paths.duration  # from the first sample [s]
    limit = MAX_SAMPLE_SPACING * np.maximum(paths.count - 1, 0) * (1.0 + 1e-6) + 1e-9
    bad = np.flatnonzero(~(duration <= limit))  # NaN durations too
    if bad.size == 0:
        return
    row = int(bad[0])
    ids = sorted({int(batch.case_id[i % n]) for i in bad})
    shown = ", ".join(map(str, ids[:5])) + (f" and {len(ids) - 5} more" if len(ids) > 5 else "")
    raise SimulationError(
        f"case_id {shown}: the record of participant {row // n + 1} lasts {duration[row]:.4g} s "
        f"over {int(paths.count[row])} samples, more than {MAX_SAMPLE_SPACING:g} s per sample "
        f"({limit[row]:.4g} s); the simulation would not end in useful time: is the time column "
        "in milliseconds or a date? (vfs db validate names the rows)")


def precrash_stage(opened: OpenedCases, params: SimulationParams,
                   controller: BrakeController | None = None,
                   rng: np.random.Generator | SegmentedRandom | None = None,
                   case_of: np.ndarray | None = None,
                   first_step: np.ndarray | None = None) -> PrecrashResult:
    """The pre-crash run of opened cases (:func:`open_cases`): along the records
    until contact and through the penetration time (:func:`simulate_precrash`).

    Parameters
    ----------
    opened : OpenedCases
    params : SimulationParams
    controller : BrakeController, optional
        Brake demand (None: replay the record).
    rng : numpy.random.Generator or SegmentedRandom, optional
    case_of, first_step : ndarray of int, optional
        Case instances and the step of its record each starts at (replay only;
        :func:`simulate_precrash`).

    Returns
    -------
    PrecrashResult
    """
    batch = opened.batch
    check_record_spacing(batch)
    return simulate_precrash(batch.vehicle1, batch.vehicle2, batch.paths, batch.road_friction,
                             controller=controller, params=params.precrash, rng=rng,
                             penetration=opened.penetration, case_of=case_of,
                             first_step=first_step)


def simulate_cases(batch: CaseBatch, controller: BrakeController | None = None,
                   params: SimulationParams | None = None,
                   rng: np.random.Generator | SegmentedRandom | None = None,
                   precrash: PrecrashResult | None = None,
                   runout_memo: RunoutMemo | None = None) -> CaseResults:
    """Simulate N cases end to end (pre-crash, impact, run-out to rest).

    The effects of ``params.effects`` act at their stages (:mod:`vfs.effects`):
    vehicle data, penetration time, impact configuration and parameters,
    external impulses of the contact phase, the EES energy split and the
    run-out inputs.

    Parameters
    ----------
    batch : CaseBatch
    controller : BrakeController, optional
        Brake demand during the pre-crash phase (None: replay the record).
    params : SimulationParams, optional
    rng : numpy.random.Generator or SegmentedRandom, optional
        Randomness for the controller (sensor noise, reaction times); a
        :class:`vfs.physics.precrash.SegmentedRandom` gives consecutive
        segments of the batch their own streams.
    precrash : PrecrashResult, optional
        The pre-crash phase of exactly these cases, run earlier
        (:func:`precrash_stage`) with the same controller, randomness,
        ``params.precrash``, ``vehicles`` hooks and penetration rule; the run
        is then skipped (the model-variant searches of :mod:`vfs.analysis`
        reuse one pre-crash run for every variant that leaves it unchanged).
    runout_memo : RunoutMemo, optional
        Rest results of run-outs met before (with ``params.runout_paths`` False): the
        variant searches keep one for all their calls.

    Returns
    -------
    CaseResults
    """
    params = params or SimulationParams()
    n = batch.size
    if n == 0:
        raise ParameterError("empty case batch")
    opened = open_cases(batch, params)
    batch, eps, mu = opened.batch, opened.restitution, opened.contact_friction
    if precrash is None:
        pre = precrash_stage(opened, params, controller, rng)
    elif precrash.collided.shape != (n,):
        raise ParameterError(f"precrash: a result of {precrash.collided.shape[0]} cases "
                             f"for a batch of {n}")
    else:
        pre = precrash
    hit = np.flatnonzero(pre.collided)
    poi = np.full((n, 2), np.nan)
    cp = np.full(n, np.nan)
    brakes = np.full((n, 2, 4), np.nan)
    st = pre.impact_state
    if hit.size:
        config, part, inputs = impact_stage_inputs(batch, pre, hit, eps, mu, params)
        b1, b2 = inputs.brake[:, 0], inputs.brake[:, 1]
        eps, mu = eps.copy(), mu.copy()
        eps[hit], mu[hit] = config.restitution, config.contact_friction
        poi[hit, 0], poi[hit, 1], cp[hit] = config.poi_x, config.poi_y, config.cp_angle
        brakes[hit, 0], brakes[hit, 1] = b1, b2
    else:
        part = solve_impact(ImpactConfig.from_arrays(
            **{f: np.zeros((0, 2)) for f in CONFIG_VEHICLE_FIELDS},
            **{f: np.zeros(0) for f in CONFIG_IMPACT_FIELDS}))
        b1 = b2 = np.zeros((0, 4))
    impact = _scatter_impact(n, hit, part)
    # run-out from the post-impact state (all cases; non-colliding ones are at
    # the pose where the pre-crash phase left them and are not run), with the yaw
    # inertias the impact used (an effect may have changed them at the impact stages)
    runout = _scatter_runout(
        n, hit,
        runout_stage(_with_inertia(batch.vehicle1.take(hit), config.izz[:, 0]),
                     _with_inertia(batch.vehicle2.take(hit), config.izz[:, 1]),
                     _take_rows(st, hit), part, batch.road_friction[hit], params.runout, b1, b2,
                     secondary_collisions=params.secondary_collisions,
                     paths=params.runout_paths, memo=runout_memo,
                     post_impact=inputs if inputs.wheels_given else None)
        if hit.size else None,
    )
    return CaseResults(pre, impact, runout, eps, mu, poi, cp, brakes)


def _with_inertia(vehicles: VehicleArrays, izz: np.ndarray) -> VehicleArrays:
    """Vehicles with the yaw inertias [kg m^2] of the impact (fixed objects, whose
    impact inertia is infinite, keep theirs).
    """
    izz = np.asarray(izz, float)
    if np.array_equal(izz, vehicles.yaw_inertia):
        return vehicles
    return vehicles._replace(yaw_inertia=np.where(np.isfinite(izz), izz, vehicles.yaw_inertia))


def runout_stage(vehicle1: VehicleArrays, vehicle2: VehicleArrays, impact_state: KinematicState,
                 result: ImpactResult, road_friction: np.ndarray, params: RunoutParams,
                 wheel_brake1: np.ndarray, wheel_brake2: np.ndarray,
                 secondary_collisions: bool = True, paths: bool = True,
                 memo: RunoutMemo | None = None,
                 post_impact: PostImpactInputs | None = None) -> PairRunoutResult:
    """Run-out to rest of M collisions from the poses at impact and the post-impact velocities.

    Parameters
    ----------
    vehicle1, vehicle2 : VehicleArrays
        The M vehicle pairs.
    impact_state : KinematicState
        Poses at impact ((M, 2) arrays) [m, rad]; the velocities are those of ``result``.
    result : ImpactResult
        The M impact solutions (post-impact velocities [m/s, rad/s]).
    road_friction : ndarray (M,)
        Tyre-road friction coefficient [-] (both vehicles).
    params : RunoutParams
    wheel_brake1, wheel_brake2 : ndarray (M, 4)
        Brake factors of the wheels FL, FR, RL, RR [-].
    secondary_collisions : bool
        Flag pairs that touch again after separating
        (:func:`vfs.physics.runout.run_out_pair`); False skips that check (the
        rest poses are the same: secondary collisions are detected, not solved),
        and the result reports none.  With ``params.contact`` (contacts solved) the pair
        always runs together; False then only leaves the flags out (and the memo unused).
    paths : bool
        Record the path samples and kinetic energies (default); False (only without
        the secondary-collision check) leaves them empty (:func:`vfs.physics.runout.run_out`).
    memo : RunoutMemo, optional
        Rest results of vehicles run before (only without paths).
    post_impact : PostImpactInputs, optional
        The M collisions' extra drag per wheel, steer angles and onsets (their brakes are
        ``wheel_brake1``, ``wheel_brake2``); None = none.

    Returns
    -------
    PairRunoutResult
    """
    st = impact_state
    post1, post2 = (RunoutState(st.x[:, j], st.y[:, j], st.yaw[:, j], result.vx_post[:, j],
                                result.vy_post[:, j], result.yaw_rate_post[:, j])
                    for j in (0, 1))
    if params.contact and not secondary_collisions:
        # the vehicles of a pair interact: no memo of single vehicles; the flags left out
        pair = runout_stage(vehicle1, vehicle2, impact_state, result, road_friction, params,
                            wheel_brake1, wheel_brake2, post_impact=post_impact)
        m = pair.rest_x.shape[0]
        pair = pair._replace(secondary_collision=np.zeros(m, dtype=bool),
                             secondary_collision_time=np.full(m, np.nan))
        if paths:
            return pair
        k = pair.path.shape[2]
        return pair._replace(path=pair.path[:, :, :0], path_t=pair.path_t[:0],
                             kinetic_energy=pair.kinetic_energy[:, :, :0]) if k else pair
    if secondary_collisions:
        if memo is not None or not paths:
            raise ParameterError("a run-out memo or paths=False needs "
                                 "secondary_collisions=False (the check follows the paths)")
        if post_impact is None:
            return run_out_pair(vehicle1, vehicle2, post1, post2, road_friction, params,
                                wheel_brake1=wheel_brake1, wheel_brake2=wheel_brake2)
        drag, steer, onset = (post_impact.wheel_drag(), post_impact.steer(),
                              post_impact.onset())
        return run_out_pair(vehicle1, vehicle2, post1, post2, road_friction, params,
                            wheel_brake1=wheel_brake1, wheel_brake2=wheel_brake2,
                            wheel_drag1=drag[:, 0], wheel_drag2=drag[:, 1],
                            steer1=steer[:, 0], steer2=steer[:, 1],
                            steer_onset1=onset[:, 0], steer_onset2=onset[:, 1])
    m = post1.x.shape[0]
    both = VehicleArrays(*(np.concatenate([a, b]) for a, b in zip(vehicle1, vehicle2,
                                                                   strict=True)))
    state = RunoutState(*(np.concatenate([a, b]) for a, b in zip(post1, post2, strict=True)))
    mu = np.broadcast_to(np.asarray(road_friction, dtype=float), (m,))
    extra = {}
    if post_impact is not None:
        drag, steer, onset = (post_impact.wheel_drag(), post_impact.steer(),
                              post_impact.onset())
        extra = {"wheel_drag": np.concatenate([drag[:, 0], drag[:, 1]]),
                 "steer": np.concatenate([steer[:, 0], steer[:, 1]]),
                 "steer_onset": np.concatenate([onset[:, 0], onset[:, 1]])}
    res = run_out(both, state, np.concatenate([mu, mu]), params,
                  wheel_brake=np.concatenate([wheel_brake1, wheel_brake2]), paths=paths,
                  memo=memo, **extra)
    return PairRunoutResult.from_batch(res, np.zeros(m, dtype=bool), np.full(m, np.nan))


def _scatter_runout(n: int, rows: np.ndarray, part: PairRunoutResult | None) -> PairRunoutResult:
    """Expand a run-out result of the colliding rows to all N cases (NaN elsewhere)."""
    fields = []
    for name in PairRunoutResult._fields:
        if name == "path_t":
            fields.append(np.zeros(1) if part is None else part.path_t)
            continue
        if part is None:
            shape = {"path": (n, 2, 1, 3), "kinetic_energy": (n, 2, 1),
                     "secondary_collision": (n,), "secondary_collision_time": (n,)
                     }.get(name, (n, 2))
            fields.append(np.zeros(shape, dtype=bool) if name in ("at_rest",
                                                                  "secondary_collision")
                          else np.full(shape, np.nan))
            continue
        values = getattr(part, name)
        shape = (n,) + values.shape[1:]
        full = np.zeros(shape, dtype=bool) if values.dtype == bool else np.full(shape, np.nan)
        full[rows] = values
        fields.append(full)
    return PairRunoutResult(*fields)


def runout_axis(runout: PairRunoutResult) -> dict[str, np.ndarray]:
    """The per-case fields of both vehicles' run-out as (N, 2) arrays (vehicle 1 in
    column 0); ``path``, ``path_t``, ``kinetic_energy`` and the secondary collision are
    left out.
    """
    return {name: getattr(runout, name) for name in RunoutResult._fields
            if name not in ("path", "path_t", "kinetic_energy")}


def vehicle_columns(pairs: list[tuple[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Table columns from (N, 2) arrays: vehicle 1's columns, then vehicle 2's, each named
    by its template with ``{i}`` = 1, 2 (the file edge of the axis convention).
    """
    return {name.format(i=i): values[:, i - 1] for i in (1, 2) for name, values in pairs}


def results_table(batch: CaseBatch, res: CaseResults) -> pd.DataFrame:
    """One tidy row per case with the main figures (SI units; angles in rad).

    Columns: case_id, collided, avoided, contact_time, impact_time,
    impact_type, impact_speed{i} [m/s], closing_speed, x{i}, y{i}, yaw{i},
    vx{i}, vy{i}, yaw_rate{i} at impact, poi_x, poi_y, cp_angle, cp_rule,
    overlap_area, restitution, contact_friction, delta_v{i}, ees{i},
    energy_loss, pdof{i}, velocity_angle_change{i}, vx{i}_post, vy{i}_post,
    yaw_rate{i}_post, rest_x{i}, rest_y{i}, rest_yaw{i}, time_to_rest{i},
    runout_distance{i}, at_rest{i}, secondary_collision,
    secondary_collision_time, min_distance, time_closest, brake_start{i},
    speed_reduction{i}.
    """
    import pandas as pd

    pre, imp, ro = res.precrash, res.impact, res.runout
    st = pre.impact_state
    cols: dict[str, object] = {
        "case_id": batch.case_id,
        "collided": pre.collided,
        "avoided": ~pre.collided,
        "contact_time": pre.contact_time,
        "impact_time": pre.impact_time,
        "impact_type": impact_type_names(imp.impact_type).astype(object),
    }
    state = st._asdict()  # (N, 2) arrays
    cols.update(vehicle_columns([("impact_speed{i}", st.speed), *(
        (f"{name}{{i}}", state[name]) for name in ("x", "y", "yaw", "vx", "vy", "yaw_rate"))]))
    cols.update({
        "closing_speed": imp.closing_speed, "poi_x": res.poi[:, 0], "poi_y": res.poi[:, 1],
        "cp_angle": res.cp_angle, "cp_rule": pre.cp_rule, "overlap_area": pre.overlap_area,
        "restitution": res.restitution, "contact_friction": res.contact_friction,
        "energy_loss": imp.energy_loss,
    })
    rest = runout_axis(ro)
    cols.update(vehicle_columns([
        *((RESULT_COLUMNS[name], getattr(imp, name))
          for name in ("delta_v", "ees", "pdof", "velocity_angle_change", "vx_post", "vy_post",
                       "yaw_rate_post")),
        ("rest_x{i}", rest["rest_x"]), ("rest_y{i}", rest["rest_y"]),
        ("rest_yaw{i}", rest["rest_yaw"]), ("time_to_rest{i}", rest["time_to_rest"]),
        ("runout_distance{i}", rest["distance"]), ("at_rest{i}", rest["at_rest"]),
    ]))
    cols.update({
        "secondary_collision": ro.secondary_collision,
        "secondary_collision_time": ro.secondary_collision_time,
        "min_distance": pre.min_distance, "time_closest": pre.time_closest,
    })
    cols.update(vehicle_columns([("brake_start{i}", pre.brake_start),
                                 ("speed_reduction{i}", pre.speed_reduction)]))
    return pd.DataFrame(cols)
