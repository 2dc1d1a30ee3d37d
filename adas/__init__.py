"""Generic driver-assistance systems for the virtual forward simulation.

Autonomous emergency braking (AEB) controllers implementing
:class:`vfs.precrash.BrakeController`, their sensors, threat assessment and
driver reaction, and a registry of named systems::

    from adas import get_system
    system = get_system("three-stage")
    controller = system.controller(batch, equipped=[True, False])
    params = SimulationParams(precrash=system.precrash_params(PrecrashParams()))
    results = simulate_cases(batch, controller, params, rng=np.random.default_rng(1))
    events = controller.events()

See docs/aeb.md for the models, formulas and sources.
"""

from adas.controller import EVENT_KEYS, STAGES, AEBController, actuator_delay
from adas.params import AEBParams, DriverParams, SensorParams
from adas.systems import (
    SYSTEM_NAMES,
    AEBSystem,
    get_system,
    register_system,
    system_names,
)
from vfs.gym_registration import register_envs as _register_envs

_register_envs()  # gymnasium.make("vfs/AEB-v0", ...)

#: Version of the AEB models (recorded by ``vfs study`` next to the results).
__version__ = "0.1.0"

__all__ = [
    "EVENT_KEYS",
    "STAGES",
    "SYSTEM_NAMES",
    "AEBController",
    "AEBParams",
    "AEBSystem",
    "DriverParams",
    "SensorParams",
    "actuator_delay",
    "get_system",
    "register_system",
    "system_names",
]
