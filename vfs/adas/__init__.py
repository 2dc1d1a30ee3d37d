"""Generic driver-assistance systems for the virtual forward simulation.

Autonomous emergency braking (AEB) controllers implementing
:class:`vfs.physics.precrash.BrakeController`, their sensors, threat assessment and
driver reaction, and a registry of named systems::

    from vfs.adas import get_system
    from vfs.simulation import SimulationParams, simulate_cases
    system = get_system("three-stage")
    controller = system.controller(batch, equipped=[True, False])
    params = SimulationParams(precrash=system.precrash_params(PrecrashParams()))
    results = simulate_cases(batch, controller, params, rng=np.random.default_rng(1))
    events = controller.events()

The built-in systems are the TOML files of ``adas/`` (:mod:`vfs.adas.definition`);
``find_system("adas/my-aeb.toml")`` reads a user's file.  See docs/aeb.md for the models,
formulas and sources.
"""

from vfs.adas.contract import System, check_system
from vfs.adas.controller import EVENT_KEYS, STAGES, AEBController, actuator_delay
from vfs.adas.definition import AEBSystem, load_system
from vfs.adas.params import AEBParams, DriverParams, SensorParams
from vfs.adas.systems import (
    SYSTEM_NAMES,
    SYSTEMS,
    find_system,
    get_system,
    register_system,
    system_names,
)

__all__ = [
    "EVENT_KEYS",
    "STAGES",
    "SYSTEMS",
    "SYSTEM_NAMES",
    "AEBController",
    "AEBParams",
    "AEBSystem",
    "DriverParams",
    "SensorParams",
    "System",
    "actuator_delay",
    "check_system",
    "find_system",
    "get_system",
    "load_system",
    "register_system",
    "system_names",
]
