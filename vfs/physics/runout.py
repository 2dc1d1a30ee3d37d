"""Post-crash run-out: vehicles sliding and rolling from the separation to rest.

After the impact each vehicle moves as a planar rigid body with three degrees of freedom (CG
position x, y and yaw) on four wheels, front wheels straight or steered by a given angle
from a given onset, until the tyre forces have
dissipated its kinetic energy.  The Reconstruction chapter ("Postcrash movement"): whether a
vehicle was "rolling or sliding ... has a huge influence on the amount of energy
dissipated", which is why a time-forward vehicle model replaces an assumed mean
deceleration; the Collision Calculation Uncertainty paper: the rest positions are the
criterion a simulation is judged by (its Marquard run-out is the energy-only alternative);
the Modeling Head-On Collisions paper: frontal deformation can lock wheels, hence a brake
factor per wheel.

Wheels sit at (L1, +-track/2) and (-L2, +-track/2) in the vehicle frame, in the
order FL, FR, RL, RR (:data:`WHEEL_NAMES`).  Per wheel (docs/physics.md,
section 5):

* **normal load** (eq. R0): static axle split, N_front = m g L2 / L / 2 and
  N_rear = m g L1 / L / 2 per wheel; optionally (``load_transfer``) shifted by
  recent accelerations, dN_x = m a_x h / L between the axles and
  dN_y = m a_y h / track between the sides, shared by the axles in proportion
  to their static loads; clipped at >= 0;
* **locked wheel** (brake factor b = 1, eq. R1): the tyre slides,
  F = -mu N u / |u| with u the contact-point velocity;
* **rolling wheel** (b < 1): longitudinal F_x = -(b mu + f_r + f_d) N sgn(u_x)
  (braking plus rolling resistance plus the extra drag f_d of a damaged wheel or an
  engine in gear, default 0, eq. R2), lateral F_y = -C N alpha with
  alpha = atan2(u_y, max(|u_x|, v_alpha)) (linear tyre, eq. R3), the vector
  scaled down to mu N where it exceeds the friction circle (eq. R4);
* **steered front wheels** (steer angle delta, both wheels alike): the contact-point
  velocity is taken in the wheel frame, turned by delta, and the force turned back
  (eq. R5: K = R(delta) D R(delta)^T in place of D).  At low speed a car on steered
  rolling wheels follows the kinematic circle of radius L / tan(delta).

**Integration.**  Every force law above has the form F = -D u with a diagonal,
non-negative "secant damping" D(u) per wheel (in the wheel frame; R D R^T, still
symmetric positive semi-definite, in the body frame of a steered wheel).  For the
generalized body-frame velocity q = (u, v, r) the tyre forces are -A q with A = sum_i J_i^T D_i J_i,
symmetric positive semi-definite.  One step (:func:`_advance`) freezes A at a
predicted mid-step velocity and advances the frozen linear system
M dq/dt = -A q with R(-dt M^-1 A), R the stability function of Alexander's
L-stable two-stage SDIRK method.  Because every eigenvalue factor R lies in
[-0.21, 1], the kinetic energy can only decrease, whatever dt; the step is
second order, and it stays stable in the stiff regimes (a wheel about to stop,
a slowly rolling tyre) where explicit Euler would need dt < 1 ms.  Poses follow
by the trapezoidal rule, which makes a straight slide at constant
deceleration exact.

Everything is batched over N vehicles; the only Python loop runs over the
time steps.  Vehicles at rest are frozen with zero velocity (which the step
leaves exactly unchanged) and compacted out of the working arrays.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError
from vfs.physics import core_runout
from vfs.physics.numba_support import enabled
from vfs.physics.post_impact import PostImpactInputs as PostImpactInputs  # re-exported
from vfs.physics.post_impact import WheelInputs, check_wheel_inputs
from vfs.physics.runout_contacts import Contacts, Kick, SecondaryCollisions
from vfs.physics.vehicle import VehicleArrays
from vfs.settings import Rule, setting, validate
from vfs.units import G

#: The pair tracker under its former name (tests reach it here).
_SecondaryCollisions = SecondaryCollisions

#: Wheel order of every per-wheel array (columns of ``wheel_brake``).
WHEEL_NAMES = ("FL", "FR", "RL", "RR")

#: Speed v_eps [m/s] that regularises the sliding direction of a locked wheel
#: and the sign of the longitudinal slip of a rolling wheel, u / max(|u|, v_eps):
#: below 1 cm/s the Coulomb force becomes a viscous one.  Far below the stop
#: speed (5 cm/s), it changes run-out distances by less than 0.1 mm.
SLIP_SPEED_REGULARISATION = 0.01

#: Floor v_alpha [m/s] of the longitudinal speed in the slip angle
#: alpha = atan2(u_lat, max(|u_long|, v_alpha)), so that alpha stays defined for
#: a wheel at longitudinal standstill.  The linear tyre range then ends at
#: |u_lat| = (mu / C) v_alpha, about 7 mm/s for mu = 0.7 and C = 10 /rad.
SLIP_ANGLE_SPEED_FLOOR = 0.1

#: Guard against division by zero in atan(z)/z and in the friction-circle scale.
_TINY = 1e-30

#: Alexander's SDIRK constant gamma = 1 - 1/sqrt(2): R(z) = (1 + (1 - 2 gamma) z) /
#: (1 - gamma z)^2 is second order and L-stable, min over z <= 0 of R = -0.207.
_GAMMA = 1.0 - 1.0 / math.sqrt(2.0)

_REPORTED: list[bool] = []  # the numpy run-out of contacts was logged (once per process)
#: Compact the working arrays when fewer than this share of them still moves.
_COMPACT_SHARE = 0.8

#: Smallest working set [vehicles] worth compacting.
_COMPACT_MIN = 64


def _whole_multiple(interval: float, dt: float) -> bool:
    """True when ``interval`` is a whole multiple (>= 1) of ``dt`` (to 1e-6 relative)."""
    ratio = interval / dt
    return not (ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-6 * ratio)


@dataclass(frozen=True)
class RunoutParams:
    """Parameters of the run-out simulation, with their documented defaults.

    Attributes
    ----------
    dt : float
        Time step [s], in (0, 0.05].  Default 5 ms.  The step is stable and
        dissipative for every dt (module docstring), so dt sets only the
        accuracy: halving it moves the rest positions of realistic post-crash
        states by a few centimetres at most (docs/physics.md, section 5).
    wheel_brake : tuple of 4 floats
        Default brake factor b of the wheels FL, FR, RL, RR, each in [0, 1]:
        1 = locked, sliding wheel; b < 1 = rolling wheel braked with b mu N.
        Default 0.8 on every wheel: the driver brakes after the crash and ABS
        keeps the wheels rolling at 80 % of the friction limit.  There is no
        firm source for this value (the Reconstruction chapter leaves the post-crash driver
        action to the user, the Modeling Head-On Collisions paper shows wheels locked by frontal
        deformation); vary it, or pass ``wheel_brake`` per vehicle.
    rolling_resistance : float
        Rolling-resistance coefficient f_r of a rolling wheel [-], in [0, 0.5].
        Default 0.015 (passenger-car tyre on asphalt).
    cornering_stiffness : float
        Cornering stiffness per unit wheel load C [1/rad], in (0, 100]: the
        lateral force of a rolling wheel is C N alpha in the linear range.
        Default 10 /rad (passenger-car tyres: about 10-20 /rad).
    load_transfer : bool
        Shift the wheel loads with the accelerations of the previous steps
        (default False: static loads).
    v_stop : float
        Stop speed [m/s], in (0, 1].  A vehicle is at rest when its CG speed
        and |yaw rate| times the distance from the CG to its farthest outline
        corner (the "half diagonal",
        :func:`vfs.physics.vehicle.corner_radius`) are both below
        v_stop; it is then frozen with zero velocity.  Default 0.05 m/s.
    max_time : float
        Longest simulated run-out [s], in (0, 3600], rounded up to a whole
        number of path intervals.  Vehicles still moving then are reported
        with ``at_rest = False``.  Default 30 s.
    path_interval : float
        Time between the recorded path samples [s]; a whole multiple of dt.
        Default 0.05 s.
    contact : bool
        Resolve the contact of the two vehicles of a pair (:func:`run_out_pair`): where
        their outlines overlap and the contact points approach each other, an impulse of
        the impact model (:func:`vfs.physics.impact.solve_impact`, POI and contact plane
        of the overlap, restitution ``contact_restitution``, inter-vehicle friction
        ``ImpactParams().contact_friction``) stops the approach, every step it recurs:
        a second impact after separating, or the two moving together, hooked, until
        they separate.  Default False: vehicles pass through each other (secondary
        collisions are detected, not solved), as the published comparisons of vfs were
        made.
    contact_restitution : float
        Impulse ratio of those contact impulses [-], in [0, 1]; default 0 (plastic:
        the contact points share their normal velocity afterwards).
    """

    dt: float = setting(0.005, "time", "time step (sets the accuracy only: the step is "
                        "stable and dissipative for every dt)", lo=0.0, lo_open=True, hi=0.05)
    wheel_brake: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 0.8)
    rolling_resistance: float = setting(0.015, "ratio", "rolling-resistance coefficient of a "
                                        "rolling wheel", lo=0.0, hi=0.5)
    cornering_stiffness: float = setting(10.0, "ratio", "cornering stiffness per unit wheel "
                                         "load [1/rad]", lo=0.0, lo_open=True, hi=100.0)
    load_transfer: bool = setting(False, "bool", "shift the wheel loads with the "
                                  "accelerations of the previous steps")
    v_stop: float = setting(0.05, "speed", "a vehicle is at rest when its CG speed and "
                            "|yaw rate| x half diagonal are both below this",
                            lo=0.0, lo_open=True, hi=1.0)
    max_time: float = setting(30.0, "time", "longest simulated run-out",
                              lo=0.0, lo_open=True, hi=3600.0)
    path_interval: float = setting(0.05, "time", "time between the recorded path samples; "
                                   "a whole multiple of dt", lo=0.0, lo_open=True, hi=3600.0)
    contact: bool = setting(False, "bool", "resolve the contact of the two vehicles of a pair "
                            "(a second impact, or moving on together) instead of passing "
                            "through")
    contact_restitution: float = setting(0.0, "ratio", "impulse ratio of the run-out contact "
                                         "impulses", lo=0.0, hi=1.0)

    #: Rules between the settings.
    RULES: ClassVar[tuple[Rule, ...]] = (
        Rule(("path_interval", "dt"), lambda p: _whole_multiple(p.path_interval, p.dt),
             "path_interval a whole multiple of dt"),
        Rule(("max_time", "dt"), lambda p: p.max_time >= p.dt, "max_time >= dt"),
    )

    def __post_init__(self) -> None:
        validate(self)

        def check(name: str, value: object, lo: float, hi: float, lo_open: bool) -> float:
            if isinstance(value, (bool, np.bool_)):
                raise ParameterError(f"{name}={value!r} is not a number")
            try:
                v = float(value)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                raise ParameterError(f"{name}={value!r} is not a number") from None
            ok = math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi
            if not ok:
                bracket = "(" if lo_open else "["
                raise ParameterError(f"{name}={v:g} outside {bracket}{lo:g}, {hi:g}]")
            return v

        brake = self.wheel_brake
        if isinstance(brake, (str, bytes)) or np.ndim(brake) != 1 or len(brake) != 4:
            raise ParameterError(
                f"wheel_brake={brake!r} must be 4 brake factors (FL, FR, RL, RR)")
        for name, b in zip(WHEEL_NAMES, brake, strict=True):
            check(f"wheel_brake[{name}]", b, 0.0, 1.0, False)

    @property
    def steps_per_sample(self) -> int:
        """Time steps between two recorded path samples."""
        return max(1, round(self.path_interval / self.dt))

    @property
    def max_steps(self) -> int:
        """Largest number of time steps: max_time rounded up to whole path intervals."""
        samples = math.ceil(self.max_time / self.path_interval - 1e-9)
        return samples * self.steps_per_sample



class RunoutState(NamedTuple):
    """Kinematic state of N vehicles, arrays of shape (N,), SI units, global frame.

    Attributes
    ----------
    x, y : ndarray
        CG position [m].
    yaw : ndarray
        Heading of the vehicle x axis [rad], counter-clockwise from global x.
    vx, vy : ndarray
        CG velocity [m/s], global frame.
    yaw_rate : ndarray
        Yaw rate [rad/s], counter-clockwise positive.
    """

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    yaw_rate: np.ndarray

    @classmethod
    def from_arrays(cls, x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
                    vx: npt.ArrayLike, vy: npt.ArrayLike,
                    yaw_rate: npt.ArrayLike) -> RunoutState:
        """Build from array-likes (broadcast to a common 1-D shape, float copies)."""
        arrays = np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(a, float)) for a in (x, y, yaw, vx, vy, yaw_rate)))
        return cls(*(np.array(a, float) for a in arrays))


class RunoutResult(NamedTuple):
    """Result of :func:`run_out` for N vehicles.

    Attributes
    ----------
    rest_x, rest_y : ndarray (N,)
        CG rest position [m] (where ``at_rest`` is False: the position at the
        end of the simulated time).
    rest_yaw : ndarray (N,)
        Rest heading [rad], not wrapped (the accumulated yaw angle).
    time_to_rest : ndarray (N,)
        Time from the start of the run-out to rest [s]; NaN where the vehicle
        was still moving at the end of the simulated time.
    distance : ndarray (N,)
        Length of the CG path [m].
    at_rest : ndarray of bool (N,)
        True where the vehicle came to rest within ``max_time``.
    path : ndarray (N, K, 3)
        CG pose (x [m], y [m], yaw [rad]) every ``path_interval``, from t = 0;
        after a vehicle has stopped its samples repeat the rest pose.
    path_t : ndarray (K,)
        Times of the path samples [s].
    kinetic_energy : ndarray (N, K)
        Kinetic energy, translational plus rotational [J], at the path samples.
    """

    rest_x: np.ndarray
    rest_y: np.ndarray
    rest_yaw: np.ndarray
    time_to_rest: np.ndarray
    distance: np.ndarray
    at_rest: np.ndarray
    path: np.ndarray
    path_t: np.ndarray
    kinetic_energy: np.ndarray


class PairRunoutResult(NamedTuple):
    """Result of :func:`run_out_pair` for N collisions: the fields of :class:`RunoutResult`
    with a vehicle axis.

    Axis 1, after the case axis, is the vehicle (vehicle 1 at index 0), as in
    :class:`vfs.physics.precrash_result.KinematicState`: ``field[:, 0]`` is vehicle 1's
    :class:`RunoutResult` field and ``field[:, 1]`` vehicle 2's.

    Attributes
    ----------
    rest_x, rest_y : ndarray (N, 2)
        CG rest position [m] (where ``at_rest`` is False: the position at the
        end of the simulated time).
    rest_yaw : ndarray (N, 2)
        Rest heading [rad], not wrapped (the accumulated yaw angle).
    time_to_rest : ndarray (N, 2)
        Time from the start of the run-out to rest [s]; NaN where the vehicle
        was still moving at the end of the simulated time.
    distance : ndarray (N, 2)
        Length of the CG path [m].
    at_rest : ndarray of bool (N, 2)
        True where the vehicle came to rest within ``max_time``.
    path : ndarray (N, 2, K, 3)
        CG pose (x [m], y [m], yaw [rad]) every ``path_interval``, from t = 0;
        after a vehicle has stopped its samples repeat the rest pose.
    path_t : ndarray (K,)
        Times of the path samples [s] (both vehicles).
    kinetic_energy : ndarray (N, 2, K)
        Kinetic energy, translational plus rotational [J], at the path samples.
    secondary_collision : ndarray of bool (N,)
        True where the outlines, after having separated (overlap area <=
        :data:`vfs.physics.geometry.AREA_TOLERANCE`), overlapped again.
    secondary_collision_time : ndarray (N,)
        Time of the first secondary overlap [s] from the start of the run-out;
        NaN where there is none.
    """

    rest_x: np.ndarray
    rest_y: np.ndarray
    rest_yaw: np.ndarray
    time_to_rest: np.ndarray
    distance: np.ndarray
    at_rest: np.ndarray
    path: np.ndarray
    path_t: np.ndarray
    kinetic_energy: np.ndarray
    secondary_collision: np.ndarray
    secondary_collision_time: np.ndarray

    @classmethod
    def from_batch(cls, result: RunoutResult, secondary_collision: np.ndarray,
                   secondary_collision_time: np.ndarray) -> PairRunoutResult:
        """Pair result from the :class:`RunoutResult` of a batch of 2N vehicles that holds
        every vehicle 1 (rows 0..N-1) before every vehicle 2 (rows N..2N-1).
        """
        n = result.rest_x.shape[0] // 2
        fields = {name: a if name == "path_t" else np.stack([a[:n], a[n:]], axis=1)
                  for name, a in zip(RunoutResult._fields, result, strict=True)}
        return cls(**fields, secondary_collision=secondary_collision,
                   secondary_collision_time=secondary_collision_time)


# ----------------------------------------------------------------------------
# Small public helpers
# ----------------------------------------------------------------------------


def wheel_positions(vehicles: VehicleArrays) -> np.ndarray:
    """Wheel contact points (N, 4, 2) [m] in the vehicle frame, order FL, FR, RL, RR."""
    lf, lr = vehicles.cg_to_front_axle, vehicles.cg_to_rear_axle
    half = 0.5 * vehicles.track_width
    x = np.stack([lf, lf, -lr, -lr], axis=-1)
    y = np.stack([half, -half, half, -half], axis=-1)
    return np.stack([x, y], axis=-1)


def static_wheel_loads(vehicles: VehicleArrays) -> np.ndarray:
    """Static wheel loads (N, 4) [N], order FL, FR, RL, RR (eq. R0).

    N_f = m g L2 / (2 L) on each front wheel, N_r = m g L1 / (2 L) on each rear wheel.
    """
    m, wb = vehicles.mass, vehicles.wheelbase
    front = 0.5 * m * G * vehicles.cg_to_rear_axle / wb
    rear = 0.5 * m * G * vehicles.cg_to_front_axle / wb
    return np.stack([front, front, rear, rear], axis=-1)


def kinetic_energy(vehicles: VehicleArrays, state: RunoutState) -> np.ndarray:
    """Kinetic energy (N,) [J]: m (vx^2 + vy^2) / 2 + I yaw_rate^2 / 2."""
    return 0.5 * vehicles.mass * (state.vx**2 + state.vy**2) + 0.5 * (
        vehicles.yaw_inertia * state.yaw_rate**2)


# ----------------------------------------------------------------------------
# Input checks
# ----------------------------------------------------------------------------


def _check_vehicles(vehicles: VehicleArrays, n: int, label: str) -> VehicleArrays:
    arrays = [np.asarray(a, float) for a in vehicles]
    for name, a in zip(VehicleArrays._fields, arrays, strict=True):
        if a.shape != (n,):
            raise ParameterError(f"{label}.{name} has shape {a.shape}, expected ({n},)")
        ok = np.isfinite(a) & ((a >= 0.0) if name == "front_overhang" else (a > 0.0))
        if not ok.all():
            bad = int(np.flatnonzero(~ok)[0])
            bound = ">= 0" if name == "front_overhang" else "> 0"
            raise ParameterError(f"{label}.{name}[{bad}]={a[bad]!r} must be finite and {bound}")
    v = VehicleArrays(*arrays)
    lr = v.cg_to_rear_axle
    if not (lr > 0).all():
        bad = int(np.flatnonzero(~(lr > 0))[0])
        raise ParameterError(
            f"{label}: cg_to_front_axle[{bad}]={v.cg_to_front_axle[bad]:g} must be smaller "
            f"than wheelbase[{bad}]={v.wheelbase[bad]:g} (the CG lies between the axles)")
    return v


def _check_state(state: RunoutState, label: str) -> tuple[RunoutState, int]:
    if not isinstance(state, RunoutState):
        raise ParameterError(f"{label} must be a RunoutState, got {type(state).__name__}")
    arrays = [np.atleast_1d(np.asarray(a, float)) for a in state]
    n = arrays[0].shape[0] if arrays[0].ndim == 1 else -1
    for name, a in zip(RunoutState._fields, arrays, strict=True):
        if a.ndim != 1 or a.shape[0] != n:
            raise ParameterError(
                f"{label}.{name} has shape {a.shape}; all fields must have the same shape (N,)")
        if not np.isfinite(a).all():
            bad = int(np.flatnonzero(~np.isfinite(a))[0])
            raise ParameterError(f"{label}.{name}[{bad}]={a[bad]!r} is not finite")
    return RunoutState(*arrays), n


def _check_friction(road_friction: npt.ArrayLike, n: int) -> np.ndarray:
    mu = np.asarray(road_friction, float)
    if mu.ndim > 1 or (mu.ndim == 1 and mu.shape[0] != n):
        raise ParameterError(f"road_friction has shape {mu.shape}, expected () or ({n},)")
    mu = np.broadcast_to(mu, (n,)).copy()
    ok = np.isfinite(mu) & (mu > 0.0) & (mu <= 3.0)
    if not ok.all():
        bad = int(np.flatnonzero(~ok)[0])
        raise ParameterError(f"road_friction[{bad}]={mu[bad]!r} outside (0, 3]")
    return mu


def _check_brake(wheel_brake: npt.ArrayLike | None, params: RunoutParams, n: int,
                 label: str = "wheel_brake") -> np.ndarray:
    raw = params.wheel_brake if wheel_brake is None else wheel_brake
    b = np.asarray(raw, float)
    if b.shape not in ((4,), (n, 4)):
        raise ParameterError(f"{label} has shape {b.shape}, expected (4,) or ({n}, 4)")
    b = np.broadcast_to(b, (n, 4)).copy()
    ok = np.isfinite(b) & (b >= 0.0) & (b <= 1.0)
    if not ok.all():
        row, col = (int(i[0]) for i in np.nonzero(~ok))
        raise ParameterError(
            f"{label}[{row}, {WHEEL_NAMES[col]}]={b[row, col]!r} outside [0, 1]")
    return b


# ----------------------------------------------------------------------------
# The integrator
# ----------------------------------------------------------------------------


class _Working(NamedTuple):
    """Per-vehicle arrays of the working set (the vehicles not compacted away).

    Per-wheel arrays are wheel-major, (4, n), so that each wheel row is
    contiguous.  :func:`_compact` selects columns of every field alike.
    """

    rows: np.ndarray  # (n,) positions in the full arrays
    mass: np.ndarray  # [kg]
    inertia: np.ndarray  # [kg m^2]
    lf: np.ndarray  # CG to front axle L1 [m]
    lr: np.ndarray  # CG to rear axle L2 [m]
    half_track: np.ndarray  # [m]
    front_share: np.ndarray  # L2 / L [-], front axle share of the static load
    rear_share: np.ndarray  # L1 / L [-]
    lon_transfer: np.ndarray  # m h / L [kg]: axle load shift per unit a_x
    lat_transfer: np.ndarray  # m h / track [kg]: side load shift per unit a_y
    radius: np.ndarray  # CG to farthest outline corner [m]
    mu: np.ndarray  # road friction [-]
    brake_coef: np.ndarray  # (4, n) b mu + f_r [-] of rolling wheels (eq. R2)
    locked: np.ndarray  # (4, n) bool, b = 1
    static_load: np.ndarray  # (4, n) [N] (eq. R0)
    brake_load: np.ndarray  # (4, n) (b mu + f_r) N [N] at static load
    stiff_load: np.ndarray  # (4, n) C N [N/rad] at static load
    limit_load: np.ndarray  # (4, n) mu N [N] at static load
    steer: np.ndarray  # front-wheel steer angle [rad] once it has set in
    onset: np.ndarray  # time the steer angle sets in [s]
    scratch: np.ndarray  # (6, 4, n) work buffers of _secant_damping
    # state
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    vx: np.ndarray  # [m/s] global
    vy: np.ndarray  # [m/s]
    r: np.ndarray  # [rad/s]
    vx_prev: np.ndarray  # velocity at the start of the previous step (predictor)
    vy_prev: np.ndarray
    r_prev: np.ndarray
    acc_x: np.ndarray  # mean body-frame acceleration of the last step [m/s^2]
    acc_y: np.ndarray
    acc_x_prev: np.ndarray  # ... of the step before
    acc_y_prev: np.ndarray
    distance: np.ndarray  # CG path length [m]
    moving: np.ndarray  # bool


def _prepare(vehicles: VehicleArrays, state: RunoutState, mu: np.ndarray,
             brake: np.ndarray, params: RunoutParams, wheels: WheelInputs) -> _Working:
    n = state.x.shape[0]
    wb = vehicles.wheelbase
    lf, lr = vehicles.cg_to_front_axle, vehicles.cg_to_rear_axle
    static = static_wheel_loads(vehicles).T.copy()
    # eq. R2 with the extra drag of a damaged wheel (a drag of 0 adds exactly nothing)
    coef = (brake * mu[:, None] + params.rolling_resistance + wheels.drag).T.copy()
    zeros = np.zeros(n)
    return _Working(
        rows=np.arange(n), mass=vehicles.mass.copy(), inertia=vehicles.yaw_inertia.copy(),
        lf=lf.copy(), lr=lr.copy(), half_track=0.5 * vehicles.track_width,
        front_share=lr / wb, rear_share=lf / wb,
        lon_transfer=vehicles.mass * vehicles.cg_height / wb,
        lat_transfer=vehicles.mass * vehicles.cg_height / vehicles.track_width,
        radius=vehicles.corner_radius, mu=mu.copy(), brake_coef=coef,
        locked=(brake >= 1.0).T.copy(), static_load=static, brake_load=coef * static,
        stiff_load=params.cornering_stiffness * static, limit_load=mu * static,
        steer=wheels.steer.copy(), onset=wheels.onset.copy(), scratch=np.empty((6, 4, n)),
        x=state.x.copy(), y=state.y.copy(), yaw=state.yaw.copy(),
        vx=state.vx.copy(), vy=state.vy.copy(), r=state.yaw_rate.copy(),
        vx_prev=state.vx.copy(), vy_prev=state.vy.copy(), r_prev=state.yaw_rate.copy(),
        acc_x=zeros.copy(), acc_y=zeros.copy(), acc_x_prev=zeros.copy(),
        acc_y_prev=zeros.copy(), distance=zeros.copy(), moving=np.ones(n, bool),
    )


def _wheel_limits(w: _Working, params: RunoutParams) -> tuple[np.ndarray, ...]:
    """Per-wheel (b mu + f_r) N, C N and mu N, each (4, n), from the wheel loads.

    Static loads unless ``load_transfer``: then the loads follow the body-frame
    acceleration extrapolated from the last two steps to the middle of this
    one, a = 2 a_last - a_before (the plain previous-step value lags by one
    step, a first-order error; see docs/physics.md, section 5).
    """
    if not params.load_transfer:
        return w.brake_load, w.stiff_load, w.limit_load
    ax = 2.0 * w.acc_x - w.acc_x_prev
    ay = 2.0 * w.acc_y - w.acc_y_prev
    lon = 0.5 * w.lon_transfer * ax  # per wheel: half the axle shift m a_x h / L (eq. R0)
    lat = w.lat_transfer * ay  # side shift m a_y h / track, shared by the axles (eq. R0)
    lat_f, lat_r = lat * w.front_share, lat * w.rear_share
    s = w.static_load
    load = np.stack([s[0] - lon - lat_f, s[1] - lon + lat_f,
                     s[2] + lon - lat_r, s[3] + lon + lat_r])
    np.maximum(load, 0.0, out=load)
    return w.brake_coef * load, params.cornering_stiffness * load, w.mu * load


def _secant_damping(w: _Working, limits: tuple[np.ndarray, ...], u: np.ndarray,
                    v: np.ndarray, r: np.ndarray, any_locked: bool,
                    any_rolling: bool,
                    steer: tuple[np.ndarray, np.ndarray] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal and lateral secant damping D = |F| / |u| (4, n) [N s/m] of each wheel,
    in the wheel's own frame.

    (u, v, r) is the body-frame velocity at which the tyre forces are
    evaluated.  With steering angle 0 the wheels of a side share the
    longitudinal contact-point velocity u -+ r track/2 and the wheels of an
    axle the lateral one, v + r L1 or v - r L2.  ``steer`` = (cos delta, sin delta)
    of the front wheels' steer angle delta: their contact-point velocity (u_x, u_y) in
    the body frame is turned into the wheel frame, (c u_x + s u_y, -s u_x + c u_y).
    Only magnitudes enter: every force opposes its velocity component.  The results live
    in ``w.scratch``; they are valid until the next call.
    """
    brake_load, stiff_load, limit_load = limits
    a_long, a_lat, d_long, d_lat, t1, t2 = w.scratch
    rh = r * w.half_track
    if steer is None:
        np.abs(u - rh, out=a_long[0])
        np.abs(u + rh, out=a_long[1])
        a_long[2], a_long[3] = a_long[0], a_long[1]
        np.abs(v + r * w.lf, out=a_lat[0])
        np.abs(v - r * w.lr, out=a_lat[2])
        a_lat[1], a_lat[3] = a_lat[0], a_lat[2]
    else:
        c, s = steer
        vf = v + r * w.lf
        for k, ux in ((0, u - rh), (1, u + rh)):
            np.abs(c * ux + s * vf, out=a_long[k])
            np.abs(c * vf - s * ux, out=a_lat[k])
        np.abs(u - rh, out=a_long[2])
        np.abs(u + rh, out=a_long[3])
        np.abs(v - r * w.lr, out=a_lat[2])
        a_lat[3] = a_lat[2]
    if any_rolling:
        # eq. R2: |F_x| = (b mu + f_r) N |u_x| / max(|u_x|, v_eps)
        np.maximum(a_long, SLIP_SPEED_REGULARISATION, out=t1)
        np.divide(brake_load, t1, out=d_long)
        # eq. R3: |F_y| = C N atan(z), z = |u_y| / max(|u_x|, v_alpha); D = C N atan(z)/z / floor
        np.maximum(a_long, SLIP_ANGLE_SPEED_FLOOR, out=t1)
        np.divide(a_lat, t1, out=t2)
        np.maximum(t2, _TINY, out=t2)
        np.arctan(t2, out=d_lat)
        d_lat /= t2
        d_lat *= stiff_load
        d_lat /= t1
        # eq. R4: friction circle, |F| <= mu N, both components scaled alike
        np.multiply(d_long, a_long, out=t1)
        t1 *= t1
        np.multiply(d_lat, a_lat, out=t2)
        t2 *= t2
        t1 += t2
        np.sqrt(t1, out=t1)
        np.maximum(t1, _TINY, out=t1)
        np.divide(limit_load, t1, out=t1)
        np.minimum(t1, 1.0, out=t1)
        d_long *= t1
        d_lat *= t1
    if any_locked:
        # eq. R1: F = -mu N u / max(|u|, v_eps), the same damping in both directions
        lock = np.hypot(a_long, a_lat, out=t1)
        np.maximum(lock, SLIP_SPEED_REGULARISATION, out=lock)
        np.divide(limit_load, lock, out=lock)
        if not any_rolling:
            return lock, lock
        np.copyto(d_long, lock, where=w.locked)
        np.copyto(d_lat, lock, where=w.locked)
    return d_long, d_lat


class _Damping(NamedTuple):
    """Entries of the damping matrix A = sum_i J_i^T K_i J_i (3 x 3, symmetric).

    For q = (u, v, r) a wheel at (a, c) slips with u - r c (longitudinal) and
    v + r a (lateral), so J_i = [[1, 0, -c], [0, 1, a]].  K_i = R D_i R^T is the
    wheel's damping D_i = diag(d_long, d_lat) turned by its steer angle (R the rotation
    by delta); with every steer angle 0, K_i = D_i and A_uv = 0 (``uv`` None).
    K_i symmetric positive semi-definite keeps A so: the step only dissipates.
    """

    uu: np.ndarray  # [N s/m]
    vv: np.ndarray  # [N s/m]
    ur: np.ndarray  # [N s]
    vr: np.ndarray  # [N s]
    rr: np.ndarray  # [N m s]
    uv: np.ndarray | None = None  # [N s/m], None = 0 (no steered wheel)


def _damping_matrix(w: _Working, limits: tuple[np.ndarray, ...], u: np.ndarray,
                    v: np.ndarray, r: np.ndarray, any_locked: bool,
                    any_rolling: bool) -> _Damping:
    """Damping matrix at body-frame velocity (u, v, r).

    Sums pair left and right wheels first, which keeps mirror images exact
    in floating point.
    """
    ht, lf, lr = w.half_track, w.lf, w.lr
    d_long, d_lat = _secant_damping(w, limits, u, v, r, any_locked, any_rolling)
    sum_long = (d_long[0] + d_long[1]) + (d_long[2] + d_long[3])
    lat_front = d_lat[0] + d_lat[1]
    lat_rear = d_lat[2] + d_lat[3]
    return _Damping(
        uu=sum_long,
        vv=lat_front + lat_rear,
        ur=-ht * ((d_long[0] - d_long[1]) + (d_long[2] - d_long[3])),
        vr=lf * lat_front - lr * lat_rear,
        rr=ht * ht * sum_long + lf * lf * lat_front + lr * lr * lat_rear,
    )


def _damping_matrix_steered(w: _Working, limits: tuple[np.ndarray, ...], u: np.ndarray,
                            v: np.ndarray, r: np.ndarray, any_locked: bool,
                            any_rolling: bool, c: np.ndarray, s: np.ndarray) -> _Damping:
    """Damping matrix at body-frame velocity (u, v, r) with the front wheels steered by
    delta (c = cos delta, s = sin delta): K = R diag(d_long, d_lat) R^T on the front wheels.
    """
    ht, lf, lr = w.half_track, w.lf, w.lr
    d_long, d_lat = _secant_damping(w, limits, u, v, r, any_locked, any_rolling, (c, s))
    uu = d_long[2] + d_long[3]
    vv = d_lat[2] + d_lat[3]
    uv = np.zeros_like(uu)
    ur = -ht * (d_long[2] - d_long[3])
    vr = -lr * vv
    rr = ht * ht * uu + lr * lr * vv
    cc, ss, cs = c * c, s * s, c * s
    for k, y in ((0, ht), (1, -ht)):  # FL at +track/2, FR at -track/2
        kxx = d_long[k] * cc + d_lat[k] * ss
        kyy = d_long[k] * ss + d_lat[k] * cc
        kxy = (d_long[k] - d_lat[k]) * cs
        uu = uu + kxx
        vv = vv + kyy
        uv = uv + kxy
        ur = ur - y * kxx + lf * kxy
        vr = vr - y * kxy + lf * kyy
        rr = rr + y * y * kxx - 2.0 * lf * y * kxy + lf * lf * kyy
    return _Damping(uu=uu, vv=vv, ur=ur, vr=vr, rr=rr, uv=uv)


class _Solver(NamedTuple):
    """M + k A (M = diag(m, m, I)) eliminated for u and v: solves in closed form."""

    mass: np.ndarray
    inertia: np.ndarray
    p: np.ndarray  # m + k A_uu
    q: np.ndarray  # m + k A_vv
    ku: np.ndarray  # k A_ur
    kv: np.ndarray  # k A_vr
    schur: np.ndarray  # I + k A_rr - ku^2 / p - kv^2 / q > 0

    @classmethod
    def factor(cls, mass: np.ndarray, inertia: np.ndarray, a: _Damping, k: float) -> _Solver:
        p = mass + k * a.uu
        q = mass + k * a.vv
        ku = k * a.ur
        kv = k * a.vr
        return cls(mass, inertia, p, q, ku, kv, inertia + k * a.rr - (ku * ku / p + kv * kv / q))

    def solve(self, u: np.ndarray, v: np.ndarray,
              r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Q' = (M + k A)^-1 M q."""
        mu, mv = self.mass * u, self.mass * v
        r_new = (self.inertia * r - (self.ku * mu / self.p + self.kv * mv / self.q)) / self.schur
        return (mu - self.ku * r_new) / self.p, (mv - self.kv * r_new) / self.q, r_new


class _FullSolver(NamedTuple):
    """M + k A with A_uv != 0 (steered wheels): the symmetric 3 x 3 system solved by its
    cofactors, x = adj(P) b / det(P), P = M + k A symmetric positive definite.
    """

    mass: np.ndarray
    inertia: np.ndarray
    c11: np.ndarray
    c12: np.ndarray
    c13: np.ndarray
    c22: np.ndarray
    c23: np.ndarray
    c33: np.ndarray
    det: np.ndarray

    @classmethod
    def factor(cls, mass: np.ndarray, inertia: np.ndarray, a: _Damping,
               k: float) -> _FullSolver:
        uv = np.zeros_like(a.uu) if a.uv is None else a.uv
        p, q, t = mass + k * a.uu, mass + k * a.vv, inertia + k * a.rr
        w, ku, kv = k * uv, k * a.ur, k * a.vr
        c11 = q * t - kv * kv
        c12 = ku * kv - w * t
        c13 = w * kv - q * ku
        c22 = p * t - ku * ku
        c23 = w * ku - p * kv
        c33 = p * q - w * w
        det = p * c11 + w * c12 + ku * c13
        return cls(mass, inertia, c11, c12, c13, c22, c23, c33, det)

    def solve(self, u: np.ndarray, v: np.ndarray,
              r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Q' = (M + k A)^-1 M q."""
        bu, bv, br = self.mass * u, self.mass * v, self.inertia * r
        return ((self.c11 * bu + self.c12 * bv + self.c13 * br) / self.det,
                (self.c12 * bu + self.c22 * bv + self.c23 * br) / self.det,
                (self.c13 * bu + self.c23 * bv + self.c33 * br) / self.det)


def _advance(w: _Working, params: RunoutParams, first: bool, t: float = 0.0,
             steered: bool = False) -> None:
    """Advance the working set by one time step, in place.

    1. Predict the mid-step velocity, q_m = (3 q_n - q_{n-1}) / 2 (q_n on the
       first step), and freeze the damping there, A = A(q_m), in the vehicle
       frame at the predicted mid-step heading.
    2. Advance M dq/dt = -A q over dt with R(-dt M^-1 A),
       R(z) = (1 + (1 - 2 gamma) z) / (1 - gamma z)^2: two solves with
       M + gamma dt A, then q' = y - (1 - 2 gamma) dt M^-1 A y.  A symmetric
       positive semi-definite gives |R| <= 1 on every mode: energy never rises.
    3. Poses by the trapezoidal rule, x' = x + dt (v + v') / 2.

    Freezing A at the mid-step and the frame at the mid-step heading keeps
    the step second order; the predictor costs no extra force evaluation.
    ``steered``: some vehicle of the working set has a steer angle; the front wheels
    are turned (A_uv != 0) by the steer angle times the share of the step [t, t + dt]
    (t [s]) after the onset (0 before, 1 after it).
    """
    dt = params.dt
    limits = _wheel_limits(w, params)
    any_locked = bool(w.locked.any())
    any_rolling = not bool(w.locked.all())
    if first:
        vx_m, vy_m, r_m = w.vx, w.vy, w.r
    else:
        vx_m = 1.5 * w.vx - 0.5 * w.vx_prev
        vy_m = 1.5 * w.vy - 0.5 * w.vy_prev
        r_m = 1.5 * w.r - 0.5 * w.r_prev
    heading = w.yaw + (0.5 * dt) * r_m
    c, s = np.cos(heading), np.sin(heading)
    u0 = c * w.vx + s * w.vy  # body-frame velocity at the start of the step
    v0 = c * w.vy - s * w.vx
    um, vm = c * vx_m + s * vy_m, c * vy_m - s * vx_m
    k = (1.0 - 2.0 * _GAMMA) * dt
    a = _damping_matrix(w, limits, um, vm, r_m, any_locked, any_rolling)
    solver = _Solver.factor(w.mass, w.inertia, a, _GAMMA * dt)
    u1, v1, r1 = solver.solve(u0, v0, w.r)
    u2, v2, r2 = solver.solve(u1, v1, r1)
    u_new = u2 - k * (a.uu * u2 + a.ur * r2) / w.mass
    v_new = v2 - k * (a.vv * v2 + a.vr * r2) / w.mass
    r_new = r2 - k * (a.ur * u2 + a.vr * v2 + a.rr * r2) / w.inertia
    if steered:
        # the share of the step after the onset, so that the onset falls between steps
        # without a first-order error: the turned share of the step's impulse
        delta = w.steer * np.clip((t + dt - w.onset) / dt, 0.0, 1.0)
        a = _damping_matrix_steered(w, limits, um, vm, r_m, any_locked, any_rolling,
                                    np.cos(delta), np.sin(delta))
        full = _FullSolver.factor(w.mass, w.inertia, a, _GAMMA * dt)
        u1, v1, r1 = full.solve(u0, v0, w.r)
        u2, v2, r2 = full.solve(u1, v1, r1)
        uv = a.uv if a.uv is not None else 0.0
        # only the steered vehicles take the cofactor solution: a vehicle's run-out never
        # depends on the others of its batch, to the last bit (the memo relies on it)
        turned = w.steer != 0.0
        u_new = np.where(turned, u2 - k * (a.uu * u2 + uv * v2 + a.ur * r2) / w.mass, u_new)
        v_new = np.where(turned, v2 - k * (uv * u2 + a.vv * v2 + a.vr * r2) / w.mass, v_new)
        r_new = np.where(turned, r2 - k * (a.ur * u2 + a.vr * v2 + a.rr * r2) / w.inertia,
                         r_new)
    vx_new = c * u_new - s * v_new
    vy_new = s * u_new + c * v_new
    if params.load_transfer:
        w.acc_x_prev[:] = w.acc_x
        w.acc_y_prev[:] = w.acc_y
        np.divide(u_new - u0, dt, out=w.acc_x)
        np.divide(v_new - v0, dt, out=w.acc_y)
    dx = (0.5 * dt) * (w.vx + vx_new)
    dy = (0.5 * dt) * (w.vy + vy_new)
    w.x[:] += dx
    w.y[:] += dy
    w.yaw[:] += (0.5 * dt) * (w.r + r_new)
    w.distance[:] += np.sqrt(dx * dx + dy * dy)
    w.vx_prev[:] = w.vx
    w.vy_prev[:] = w.vy
    w.r_prev[:] = w.r
    w.vx[:] = vx_new
    w.vy[:] = vy_new
    w.r[:] = r_new


def _newly_at_rest(w: _Working, v_stop: float) -> np.ndarray:
    """Moving vehicles whose CG speed and outermost corner speed are below v_stop."""
    v2 = v_stop * v_stop
    corner = w.r * w.radius
    return w.moving & (w.vx * w.vx + w.vy * w.vy < v2) & (corner * corner < v2)


def _freeze(w: _Working, now: np.ndarray) -> None:
    """Zero the velocities (and their history) of the vehicles flagged in ``now``."""
    for a in (w.vx, w.vy, w.r, w.vx_prev, w.vy_prev, w.r_prev, w.acc_x, w.acc_y,
              w.acc_x_prev, w.acc_y_prev):
        a[now] = 0.0
    w.moving[now] = False


def _compact(w: _Working) -> _Working:
    """Drop the vehicles at rest from the working set."""
    keep = w.moving
    # compress keeps every wheel row contiguous (fancy indexing a[..., keep] does not)
    return _Working(*(a.compress(keep, axis=-1) for a in w))


#: Called after every step with the time [s], the state of all N vehicles
#: (read-only views) and the mask of the vehicles that moved during the step; it may
#: return new velocities of some vehicles (:class:`Kick`), which then move on from them
#: (a vehicle at rest starts again).
StepCallback = Callable[[float, RunoutState, np.ndarray], "Kick | None"]


def _simulate(vehicles: VehicleArrays, state: RunoutState, mu: np.ndarray, brake: np.ndarray,
              params: RunoutParams, wheels: WheelInputs, on_step: StepCallback | None = None,
              record: bool = True, compact: bool = True) -> RunoutResult:
    """Run N vehicles to rest: the engine of :func:`run_out` and :func:`run_out_pair`.

    This loop is the reference of the compiled kernel (:mod:`vfs.physics.core_runout`),
    which runs instead where nothing is called between the steps (``on_step`` None) unless
    ``VFS_COMPILED=0``.  ``record``: False leaves the path samples and kinetic energies
    empty (:func:`run_out`).
    """
    n = state.x.shape[0]
    w = _prepare(vehicles, state, mu, brake, params, wheels)
    steered = wheels.steered
    if on_step is None and n and enabled():
        return _simulate_compiled(w, params, record)[0]
    # full arrays: current state of the working set, rest state of the others
    x, y, yaw = state.x.copy(), state.y.copy(), state.yaw.copy()
    vx, vy, r = state.vx.copy(), state.vy.copy(), state.yaw_rate.copy()
    distance = np.zeros(n)
    time_to_rest = np.full(n, np.nan)
    moving = np.ones(n, bool)
    mass, inertia = vehicles.mass, vehicles.yaw_inertia
    poses: list[np.ndarray] = []
    energies: list[np.ndarray] = []

    def stop(t: float) -> None:
        now = _newly_at_rest(w, params.v_stop)
        if not now.any():
            return
        _freeze(w, now)
        idx = w.rows[now]
        x[idx], y[idx], yaw[idx] = w.x[now], w.y[now], w.yaw[now]
        vx[idx] = vy[idx] = r[idx] = 0.0
        distance[idx] = w.distance[now]
        time_to_rest[idx] = t
        moving[idx] = False

    def publish() -> None:
        idx = w.rows
        x[idx], y[idx], yaw[idx] = w.x, w.y, w.yaw
        vx[idx], vy[idx], r[idx] = w.vx, w.vy, w.r

    def sample() -> None:
        if not record:
            return
        publish()
        poses.append(np.stack([x, y, yaw], axis=-1))
        energies.append(0.5 * mass * (vx * vx + vy * vy) + 0.5 * inertia * r * r)

    stop(0.0)
    if params.load_transfer:
        # the accelerations "of the previous steps" at t = 0: those of a trial step
        trial = _Working(*(a.copy() for a in w))
        _advance(trial, params, True, 0.0, steered)
        for a in (w.acc_x, w.acc_x_prev):
            a[:] = trial.acc_x
        for a in (w.acc_y, w.acc_y_prev):
            a[:] = trial.acc_y
    sample()
    per_sample = params.steps_per_sample
    step = 0
    while step < params.max_steps and moving.any():
        size = w.rows.shape[0]
        if (compact and size > _COMPACT_MIN
                and np.count_nonzero(w.moving) < _COMPACT_SHARE * size):
            w = _compact(w)
        moved = moving.copy() if on_step is not None else moving
        _advance(w, params, step == 0, step * params.dt, steered)
        step += 1
        t = step * params.dt
        stop(t)
        if on_step is not None:
            publish()
            kick = on_step(t, RunoutState(x, y, yaw, vx, vy, r), moved)
            if kick is not None and kick.rows.size:
                # compaction is off with kicks: the working rows are the batch rows
                k = kick.rows
                for a, b, value in ((w.vx, w.vx_prev, kick.vx), (w.vy, w.vy_prev, kick.vy),
                                    (w.r, w.r_prev, kick.yaw_rate)):
                    a[k] = value
                    b[k] = value  # no predictor across the jump
                w.moving[k] = True
                moving[k] = True
                time_to_rest[k] = np.nan
                vx[k], vy[k], r[k] = kick.vx, kick.vy, kick.yaw_rate
        if step % per_sample == 0:
            sample()
    if step % per_sample != 0:
        sample()  # the rest poses (or the poses at max_time) at the next sample time
    publish()
    distance[w.rows] = w.distance
    path = np.stack(poses, axis=1) if n and poses else np.zeros((n, len(poses), 3))
    kinetic = np.stack(energies, axis=1) if n and poses else np.zeros((n, len(energies)))
    path_t = np.arange(len(poses)) * (per_sample * params.dt)
    return RunoutResult(x, y, yaw, time_to_rest, distance, ~moving, path, path_t, kinetic)


def _simulate_compiled(w: _Working, params: RunoutParams, record: bool,
                       pairs: VehicleArrays | None = None
                       ) -> tuple[RunoutResult, np.ndarray | None, np.ndarray | None]:
    """:func:`_simulate` by the compiled kernel (the same arithmetic); ``pairs``: the 2N
    vehicles of :func:`run_out_pair`, whose secondary collisions it checks (as
    :class:`SecondaryCollisions`: the flags and times are returned too).
    """
    par = core_runout.parameter_table(
        (w.mass, w.inertia, w.lf, w.lr, w.half_track, w.front_share, w.rear_share,
         w.lon_transfer, w.lat_transfer, w.radius, w.mu, w.steer, w.onset),
        (w.brake_coef, w.static_load, w.locked), pairs)
    consts = (params.dt, params.cornering_stiffness, params.v_stop, SLIP_SPEED_REGULARISATION,
              SLIP_ANGLE_SPEED_FLOOR, _TINY, _GAMMA)
    out = core_runout.run_to_rest(par, (w.x, w.y, w.yaw, w.vx, w.vy, w.r), consts,
                                  params.max_steps, params.steps_per_sample,
                                  params.load_transfer, record, pairs is not None)
    time_to_rest = np.where(out.moving, np.nan, out.steps * params.dt)
    path_t = np.arange(out.path.shape[1]) * (params.steps_per_sample * params.dt)
    return (RunoutResult(out.x, out.y, out.yaw, time_to_rest, out.distance, ~out.moving,
                         out.path, path_t, out.kinetic_energy),
            out.secondary, out.secondary_time)


# ----------------------------------------------------------------------------
# Public entry points
# ----------------------------------------------------------------------------


def run_out(vehicles: VehicleArrays, state: RunoutState, road_friction: npt.ArrayLike,
            params: RunoutParams | None = None,
            wheel_brake: npt.ArrayLike | None = None, paths: bool = True,
            memo: RunoutMemo | None = None, wheel_drag: npt.ArrayLike | None = None,
            steer: npt.ArrayLike | None = None,
            steer_onset: npt.ArrayLike | None = None) -> RunoutResult:
    """Simulate the post-crash run-out of N vehicles to rest.

    Parameters
    ----------
    vehicles : VehicleArrays
        The N vehicles (mass, yaw inertia, axle positions, track, CG height, outline).
    state : RunoutState
        State at the start of the run-out (just after the impact), arrays (N,).
    road_friction : array_like, () or (N,)
        Tyre-road friction coefficient mu [-], in (0, 3].
    params : RunoutParams, optional
        Time step, tyre and stop parameters (defaults: ``RunoutParams()``).
    wheel_brake : array_like (4,) or (N, 4), optional
        Brake factor b per wheel (FL, FR, RL, RR) in [0, 1]: 1 locked, < 1
        rolling and braked with b mu N.  Default: ``params.wheel_brake``.
    paths : bool
        Record the path samples and kinetic energies (default); False leaves ``path``,
        ``path_t`` and ``kinetic_energy`` empty (K = 0; searches that compare rest poses
        only); the other fields are the same to the last bit.
    memo : RunoutMemo, optional
        Rest results of vehicles run before (with ``paths`` False): a vehicle whose
        inputs equal those of one in the memo, bit for bit, gets its results.
    wheel_drag : array_like (4,) or (N, 4), optional
        Extra rolling drag per wheel (FL, FR, RL, RR) [-] in [0, 1], added to the
        rolling resistance of a rolling wheel (a damaged wheel, the engine in gear).
        Default 0.
    steer : array_like () or (N,), optional
        Steer angle delta of both front wheels [rad], positive to the left, |delta| <= 60
        deg.  Default 0.
    steer_onset : array_like () or (N,), optional
        Time from the start of the run-out at which ``steer`` sets in [s] (straight
        wheels before).  Default 0.

    Returns
    -------
    RunoutResult

    Examples
    --------
    A car sliding on locked wheels from 10 m/s on mu = 0.8 stops after
    v^2 / (2 mu g):

    >>> from vfs.physics.vehicle import VehicleParams, stack_vehicles
    >>> car = stack_vehicles([VehicleParams()])
    >>> start = RunoutState.from_arrays(0, 0, 0, 10.0, 0, 0)
    >>> res = run_out(car, start, 0.8, wheel_brake=(1, 1, 1, 1))
    >>> round(float(res.rest_x[0]), 2), round(10.0**2 / (2 * 0.8 * G), 2)
    (6.37, 6.37)
    """
    params = RunoutParams() if params is None else params
    if not isinstance(params, RunoutParams):
        raise ParameterError(f"params must be RunoutParams, got {type(params).__name__}")
    state, n = _check_state(state, "state")
    vehicles = _check_vehicles(vehicles, n, "vehicles")
    mu = _check_friction(road_friction, n)
    brake = _check_brake(wheel_brake, params, n)
    wheels = check_wheel_inputs(wheel_drag, steer, steer_onset, n)
    if memo is not None and paths:
        raise ParameterError("a RunoutMemo keeps rest poses only: call run_out with paths=False")
    table = row_table(*vehicles, *state, mu, brake, *wheels)
    first, inverse = distinct_rows(table) if n > 1 else (np.arange(n), np.arange(n))
    # the vehicles never interact here: each distinct one runs once (a batch of model
    # variants repeats most vehicles), and the copies get its result, bit for bit
    if memo is None:
        if first.size == n:
            return _simulate(vehicles, state, mu, brake, params, wheels, record=paths)
        res = _simulate(vehicles.take(first), RunoutState(*(a[first] for a in state)),
                        mu[first], brake[first], params, wheels.take(first), record=paths)
        return RunoutResult(*(a if name == "path_t" else a[inverse]
                              for name, a in zip(RunoutResult._fields, res, strict=True)))
    keys = [table[i].tobytes() for i in first]
    rest = memo.rest(keys)  # (D, 6) in the order of REST_FIELDS; NaN rows unknown
    todo = np.flatnonzero(np.isnan(rest[:, 5]))
    if todo.size:
        rows = first[todo]
        res = _simulate(vehicles.take(rows), RunoutState(*(a[rows] for a in state)), mu[rows],
                        brake[rows], params, wheels.take(rows), record=False)
        rest[todo] = np.stack([np.asarray(getattr(res, f), float) for f in REST_FIELDS], axis=1)
        memo.store([keys[i] for i in todo], rest[todo])
    out = rest[inverse]
    return RunoutResult(out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4], out[:, 5] > 0.5,
                        np.zeros((n, 0, 3)), np.zeros(0), np.zeros((n, 0)))


#: The per-vehicle fields of :class:`RunoutResult` without the path samples (what a
#: :class:`RunoutMemo` keeps, in this order; ``at_rest`` as 0 / 1).
REST_FIELDS: tuple[str, ...] = RunoutResult._fields[:6]


class RunoutMemo:
    """Rest results of :func:`run_out` by each vehicle's inputs (its data, state, friction
    and brake factors, bit for bit), kept across calls: a search over many model variants
    of the same cases meets the same post-impact vehicle again in other variants and
    other calls (a variant of one vehicle's run-out leaves the other's as it was).

    Holds rest x, y [m], yaw [rad], time to rest [s], path length [m] and the at-rest flag
    of at most ``max_vehicles`` vehicles (about 0.4 kB each); the first ones stay.
    """

    def __init__(self, max_vehicles: int = 500_000) -> None:
        self.max_vehicles = int(max_vehicles)
        self._index: dict[bytes, int] = {}
        self._values = np.empty((1024, 6))
        self.hits = 0
        self.misses = 0

    def rest(self, keys: Sequence[bytes]) -> np.ndarray:
        """The six rest results (len(keys), 6) of known vehicles, NaN rows for the others."""
        at = np.fromiter((self._index.get(k, -1) for k in keys), np.int64, len(keys))
        known = at >= 0
        out = np.full((len(keys), 6), np.nan)
        out[known] = self._values[at[known]]
        found = int(np.count_nonzero(known))
        self.hits += found
        self.misses += len(keys) - found
        return out

    def store(self, keys: Sequence[bytes], values: np.ndarray) -> None:
        """Keep the rest results (len(keys), 6) of new vehicles while there is room."""
        size = len(self._index)
        take = min(len(keys), self.max_vehicles - size)
        if take <= 0:
            return
        if size + take > self._values.shape[0]:  # room doubled
            grown = np.empty((max(2 * self._values.shape[0], size + take), 6))
            grown[:size] = self._values[:size]
            self._values = grown
        self._values[size:size + take] = np.asarray(values, float)[:take]
        self._index.update(zip(list(keys)[:take], range(size, size + take), strict=True))


def row_table(*columns: np.ndarray) -> np.ndarray:
    """The columns side by side as one contiguous float64 table (N, k), a row per item."""
    n = np.asarray(columns[0]).shape[0]
    return np.ascontiguousarray(np.concatenate(
        [np.asarray(c, np.float64).reshape(n, -1 if n else 1) for c in columns], axis=1))


def distinct_rows(table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first row of each distinct row of a table, and each row's index into those:
    ``first[inverse]`` repeats the rows.

    Parameters
    ----------
    table : ndarray (N, k)
        Contiguous float64 numbers (:func:`row_table`), compared bit for bit.

    Returns
    -------
    first : ndarray of int (D,)
        Rows in increasing order, one per distinct combination.
    inverse : ndarray of int (N,)
        For each row the position of its combination in ``first``.
    """
    rows = table.view(np.dtype((np.void, table.dtype.itemsize * table.shape[1]))).ravel()
    _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # distinct rows in their first order
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return first[order], rank[np.asarray(inverse).ravel()]


def run_out_pair(vehicles1: VehicleArrays, vehicles2: VehicleArrays, state1: RunoutState,
                 state2: RunoutState, road_friction: npt.ArrayLike,
                 params: RunoutParams | None = None,
                 wheel_brake1: npt.ArrayLike | None = None,
                 wheel_brake2: npt.ArrayLike | None = None,
                 wheel_drag1: npt.ArrayLike | None = None,
                 wheel_drag2: npt.ArrayLike | None = None,
                 steer1: npt.ArrayLike | None = None, steer2: npt.ArrayLike | None = None,
                 steer_onset1: npt.ArrayLike | None = None,
                 steer_onset2: npt.ArrayLike | None = None) -> PairRunoutResult:
    """Run out both vehicles of N collisions together and flag secondary collisions.

    The 2N vehicles are simulated as one batch.  After the impact the outlines
    of a pair usually still overlap; once the overlap area has fallen to
    <= :data:`vfs.physics.geometry.AREA_TOLERANCE` the pair counts as separated, and a
    later overlap is a secondary collision (checked after every step: a circle
    broad phase, a separating-axis test, then :func:`vfs.physics.geometry.overlap`).
    Secondary collisions are detected; they are solved only with
    ``params.contact`` (impulses of the impact model wherever the overlapping outlines
    approach each other: a second impact, or moving together until they separate),
    otherwise the vehicles pass through each other.

    Parameters
    ----------
    vehicles1, vehicles2 : VehicleArrays
        Vehicle 1 and vehicle 2 of each collision, (N,) each.
    state1, state2 : RunoutState
        Their states just after the impact.
    road_friction : array_like, () or (N,)
        Tyre-road friction mu [-] of each collision (both vehicles).
    params : RunoutParams, optional
    wheel_brake1, wheel_brake2 : array_like (4,) or (N, 4), optional
        Brake factors per wheel; default ``params.wheel_brake``.
    wheel_drag1, wheel_drag2, steer1, steer2, steer_onset1, steer_onset2 : array_like, optional
        Extra rolling drag per wheel [-], front-wheel steer angle [rad] and its onset [s]
        of vehicles 1 and 2, as in :func:`run_out`; default 0.

    Returns
    -------
    PairRunoutResult
    """
    params = RunoutParams() if params is None else params
    if not isinstance(params, RunoutParams):
        raise ParameterError(f"params must be RunoutParams, got {type(params).__name__}")
    s1, n = _check_state(state1, "state1")
    s2, n2 = _check_state(state2, "state2")
    if n2 != n:
        raise ParameterError(f"state1 has {n} vehicles but state2 has {n2}")
    v1 = _check_vehicles(vehicles1, n, "vehicles1")
    v2 = _check_vehicles(vehicles2, n, "vehicles2")
    mu = _check_friction(road_friction, n)
    b1 = _check_brake(wheel_brake1, params, n, "wheel_brake1")
    b2 = _check_brake(wheel_brake2, params, n, "wheel_brake2")
    w1 = check_wheel_inputs(wheel_drag1, steer1, steer_onset1, n, "1")
    w2 = check_wheel_inputs(wheel_drag2, steer2, steer_onset2, n, "2")
    wheels = WheelInputs(*(np.concatenate([a, b]) for a, b in zip(w1, w2, strict=True)))
    both = VehicleArrays(*(np.concatenate([a, b]) for a, b in zip(v1, v2, strict=True)))
    state = RunoutState(*(np.concatenate([a, b]) for a, b in zip(s1, s2, strict=True)))
    mu2, brake = np.concatenate([mu, mu]), np.concatenate([b1, b2])
    if not params.contact and n and enabled():
        res, secondary, time = _simulate_compiled(
            _prepare(both, state, mu2, brake, params, wheels), params, True, both)
        return PairRunoutResult.from_batch(res, secondary, time)  # type: ignore[arg-type]
    if params.contact:
        if enabled() and not _REPORTED:
            _REPORTED.append(True)
            logging.getLogger("vfs.physics.runout").info(
                "run-out: contacts solved (RunoutParams.contact): the numpy reference path")
        contacts = Contacts(both, state.x, state.y, state.yaw, params.contact_restitution)
        res = _simulate(both, state, mu2, brake, params, wheels, on_step=contacts,
                        compact=False)
        return PairRunoutResult.from_batch(res, contacts.flags.secondary,
                                           contacts.flags.time)
    tracker = SecondaryCollisions(both, state.x, state.y, state.yaw)
    res = _simulate(both, state, mu2, brake, params, wheels, on_step=tracker)
    return PairRunoutResult.from_batch(res, tracker.secondary, tracker.time)
