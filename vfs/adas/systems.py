"""Generic AEB systems: a registry of named presets.

An :class:`AEBSystem` bundles the AEB logic and sensor (:class:`AEBParams`),
the reaction of the equipped vehicle's driver (:class:`DriverParams`) and the
brake actuator (:class:`vfs.physics.precrash.BrakeActuatorParams`).  Built-in
presets (:data:`SYSTEM_NAMES`; sources in docs/aeb.md and docs/references.md):

``none``
    No AEB; the record is replayed.
``openpass-like``
    openPASS Algorithm_AEB: one stage, full braking at 6 m/s^2 as a step
    when the TTC of the outlines enlarged by 4.0 m / 1.5 m falls to 2.0 s,
    released when it exceeds 1.5 x 2.0 s; sensor 150 m, 0.35 rad, latency 0;
    no driver reaction.
``three-stage``
    Warning at TTC 2.6 s, partial braking (4 m/s^2, about 40 %) at 1.6 s,
    full braking (friction limit) at 0.6 s, held to standstill; jerk-limited
    build-up (40 m/s^3); sensor 150 m, 0.35 rad, 20 Hz, latency 0.1 s;
    CTRV prediction; the driver (Gamma(7, 7) s reaction, 0.2 s lag, 70 %
    brake at N(6.4, 1) m/s^2 on [3, 9]) reacts to the warning.
``ideal``
    Perfect 360 deg sensor without latency, decision every step; instant
    full braking at the friction limit at the last moment that still
    avoids the contact under the CV prediction; held to standstill.

Also registered (not in :data:`SYSTEM_NAMES`): ``ideal-ctra``, the ideal
system with the CTRA prediction (path curvature and acceleration kept),
which also handles braking leads and turning objects.

:func:`register_system` adds user systems; :func:`get_system` looks one up.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy.typing as npt

from vfs.adas.controller import AEBController
from vfs.adas.params import AEBParams, DriverParams, SensorParams
from vfs.errors import ParameterError
from vfs.physics.precrash import BrakeActuatorParams, PrecrashParams
from vfs.registry import Registry

if TYPE_CHECKING:
    from vfs.simulation import CaseBatch

#: Build-up and release rate [m/s^3] standing for a step: 1000 m/s^2 per 10 ms step,
#: 10 m/s^2 per step even at the smallest step of 0.1 ms.
STEP_JERK = 1.0e5


@dataclass(frozen=True)
class AEBSystem:
    """A named AEB system: logic, sensor, driver reaction and brake actuator.

    Attributes
    ----------
    name : str
        Registry key.
    description : str
        One line for reports.
    aeb : AEBParams or None
        The AEB; None = no AEB.
    driver : DriverParams or None
        How the equipped vehicle's driver reacts to the first alert; None =
        no reaction.
    brake : BrakeActuatorParams
        The brake actuator of the equipped vehicles (the simulation uses one
        actuator for both participants; see :meth:`precrash_params`).
    """

    name: str
    description: str
    aeb: AEBParams | None
    driver: DriverParams | None
    brake: BrakeActuatorParams = dataclasses.field(default_factory=BrakeActuatorParams)

    def __post_init__(self) -> None:
        if not self.name or not isinstance(self.name, str):
            raise ParameterError("an AEB system needs a non-empty name")

    def controller(self, batch: CaseBatch, equipped: npt.ArrayLike) -> AEBController | None:
        """A fresh controller for ``batch``; None for a system without AEB.

        Parameters
        ----------
        batch : CaseBatch
        equipped : array_like of bool, broadcastable to (N, 2)
            Which participant of each case carries the system.
        """
        if self.aeb is None:
            return None
        return AEBController(batch, equipped, self.aeb, self.driver, self.brake)

    def precrash_params(self, base: PrecrashParams) -> PrecrashParams:
        """``base`` with this system's brake actuator."""
        return dataclasses.replace(base, brake=self.brake)


# ----------------------------------------------------------------------------
# Presets
# ----------------------------------------------------------------------------

_STEP_BRAKE = BrakeActuatorParams(model="jerk", jerk=STEP_JERK, release_jerk=STEP_JERK)

NONE = AEBSystem(
    name="none",
    description="no AEB: the record is replayed",
    aeb=None, driver=None, brake=BrakeActuatorParams(),
)

OPENPASS_LIKE = AEBSystem(
    name="openpass-like",
    description="openPASS-like single stage: 6 m/s^2 step at TTC 2.0 s (outlines +4.0/+1.5 m), "
                "release at 1.5 x TTC, 150 m / 0.35 rad sensor, no latency",
    aeb=AEBParams(
        sensor=SensorParams(range=150.0, field_of_view=0.35, cycle_time=0.01, latency=0.0),
        prediction="ctrv", ttc_horizon=4.0,
        warning_ttc=None, partial_ttc=None, full_ttc=2.0, full_deceleration=6.0,
        release="ttc", release_factor=1.5,
        box_margin_longitudinal=4.0, box_margin_lateral=1.5, min_speed=0.0,
    ),
    driver=None,
    brake=_STEP_BRAKE,
)

THREE_STAGE = AEBSystem(
    name="three-stage",
    description="warning 2.6 s, partial (4 m/s^2) 1.6 s, full 0.6 s; 150 m / 0.35 rad sensor, "
                "20 Hz, 0.1 s latency; jerk 40 m/s^3; Gamma(7,7) driver reacts to the warning",
    aeb=AEBParams(
        sensor=SensorParams(range=150.0, field_of_view=0.35, cycle_time=0.05, latency=0.1),
        prediction="ctrv", ttc_horizon=4.0,
        warning_ttc=2.6, partial_ttc=1.6, partial_deceleration=4.0,
        full_ttc=0.6, full_deceleration=10.0,
        release="standstill",
    ),
    driver=DriverParams(),
    brake=BrakeActuatorParams(model="jerk", jerk=40.0, release_jerk=40.0),
)

_IDEAL_AEB = AEBParams(
    sensor=SensorParams(range=math.inf, field_of_view=2.0 * math.pi, cycle_time=0.0,
                        latency=0.0),
    prediction="cv", ttc_horizon=6.0,
    warning_ttc=None, partial_ttc=None, full_ttc=None, full_deceleration=100.0,
    last_moment=True, release="standstill", min_speed=0.2,
)

IDEAL = AEBSystem(
    name="ideal",
    description="ideal: 360 deg perfect sensor, no latency, instant full braking at the friction "
                "limit at the last moment that avoids the CV-predicted contact",
    aeb=_IDEAL_AEB,
    driver=None,
    brake=BrakeActuatorParams(model="jerk", jerk=STEP_JERK, release_jerk=STEP_JERK,
                              max_deceleration=20.0),
)

IDEAL_CTRA = dataclasses.replace(
    IDEAL, name="ideal-ctra",
    description="ideal with the CTRA prediction (path curvature and acceleration kept): "
                "sees braking leads and turning objects; not one of SYSTEM_NAMES",
    aeb=dataclasses.replace(_IDEAL_AEB, prediction="ctra"),
)

#: Names of the built-in systems.
SYSTEM_NAMES: tuple[str, ...] = ("none", "openpass-like", "three-stage", "ideal")

def _check_system(name: str, system: AEBSystem) -> None:
    if not isinstance(system, AEBSystem):
        raise ParameterError(f"register_system needs an AEBSystem, got {type(system).__name__}")
    if name != system.name:
        raise ParameterError(f"AEB system {system.name!r} registered as {name!r}")


#: AEB systems by name (the built-in presets first); add one with :func:`register_system`.
SYSTEMS: Registry[AEBSystem] = Registry("AEB system", check=_check_system)
for _system in (NONE, OPENPASS_LIKE, THREE_STAGE, IDEAL, IDEAL_CTRA):
    SYSTEMS.add(_system.name, _system)


def register_system(system: AEBSystem) -> AEBSystem:
    """Add ``system`` to :data:`SYSTEMS` under its name and return it.

    Raises
    ------
    ParameterError
        If the name is taken by a different system.
    """
    if not isinstance(system, AEBSystem):
        raise ParameterError(f"register_system needs an AEBSystem, got {type(system).__name__}")
    return SYSTEMS.add(system.name, system)


def get_system(name: str) -> AEBSystem:
    """The registered system ``name``.

    Raises
    ------
    ParameterError
        Listing the known names if there is none of that name.
    """
    return SYSTEMS.get(name)


def system_names() -> tuple[str, ...]:
    """Names of all registered systems (built-in first, then in registration order)."""
    return SYSTEMS.names()
