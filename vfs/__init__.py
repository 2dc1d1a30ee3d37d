"""vfs: virtual forward simulation of real accidents for the assessment of ADAS.

SI units everywhere inside (m, s, kg, rad, m/s); km/h and degrees only at the
edges (reports, CLI flags named with the unit).
"""

from __future__ import annotations

from vfs.errors import DataError, GeometryError, ParameterError, SimulationError, VfsError
from vfs.vehicle import VehicleArrays, VehicleParams, stack_vehicles, vehicle_arrays

__version__ = "0.1.0"

from vfs.gym_registration import register_envs as _register_envs  # noqa: E402

_register_envs()  # gymnasium.make("vfs/AEB-v0", ...) works after ``import vfs``

__all__ = [
    "DataError",
    "GeometryError",
    "ParameterError",
    "SimulationError",
    "VehicleArrays",
    "VehicleParams",
    "VfsError",
    "__version__",
    "stack_vehicles",
    "vehicle_arrays",
]
