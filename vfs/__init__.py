"""vfs: virtual forward simulation of real accidents for the assessment of ADAS.

SI units everywhere inside (m, s, kg, rad, m/s); km/h and degrees only at the
edges (reports, CLI flags named with the unit).

The names below are the entry points a researcher needs; each is imported
from its module on first use (PEP 562), so ``import vfs`` or
``import vfs.physics.impact`` stays light (no pandas, no matplotlib)::

    import vfs

    db = vfs.open_database("default")
    study = vfs.run_study(db, ["three-stage"], "results/my-study", overwrite=True)
    eff = vfs.effectiveness(study.table)

docs/api.md shows a whole study script.  ``import vfs`` also registers the
gymnasium environment ``vfs/AEB-v0`` (:mod:`vfs.gym`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from vfs.errors import (
    ClusterError,
    DataError,
    GeometryError,
    ParameterError,
    SimulationError,
    TargetExistsError,
    VfsError,
)
from vfs.version import __version__

#: Public name -> module it lives in (imported on first access).
_LAZY: dict[str, str] = {
    # data
    "Database": "vfs.database",
    "open_database": "vfs.database",
    # physics
    "VehicleParams": "vfs.physics.vehicle",
    "VehicleArrays": "vfs.physics.vehicle",
    "stack_vehicles": "vfs.physics.vehicle",
    "vehicle_arrays": "vfs.physics.vehicle",
    "ImpactConfig": "vfs.physics.impact",
    "ImpactParams": "vfs.physics.impact",
    "solve_impact": "vfs.physics.impact",
    # simulation
    "CaseBatch": "vfs.simulation",
    "SimulationParams": "vfs.simulation",
    "simulate_cases": "vfs.simulation",
    "results_table": "vfs.simulation",
    # systems and studies
    "get_system": "vfs.adas",
    "StudySpec": "vfs.study",
    "run_study": "vfs.study",
    "load_study": "vfs.study",
    "read_runs": "vfs.study",
    # analysis
    "effectiveness": "vfs.analysis.effectiveness",
    "compare_database": "vfs.analysis.compare",
    # diagnosis
    "DiagnoseSpec": "vfs.diagnosis.diagnose_spec",
    "diagnose": "vfs.diagnosis.diagnose",
    # outcomes
    "OUTCOMES": "vfs.outcomes",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'vfs' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from vfs.adas import get_system
    from vfs.analysis.compare import compare_database
    from vfs.analysis.effectiveness import effectiveness
    from vfs.database import Database, open_database
    from vfs.diagnosis.diagnose import diagnose
    from vfs.diagnosis.diagnose_spec import DiagnoseSpec
    from vfs.outcomes import OUTCOMES
    from vfs.physics.impact import ImpactConfig, ImpactParams, solve_impact
    from vfs.physics.vehicle import VehicleArrays, VehicleParams, stack_vehicles, vehicle_arrays
    from vfs.simulation import CaseBatch, SimulationParams, results_table, simulate_cases
    from vfs.study import StudySpec, load_study, read_runs, run_study


def _register_gym_envs() -> None:
    from vfs.gym.registration import register_envs

    register_envs()  # gymnasium.make("vfs/AEB-v0", ...) works after ``import vfs``


_register_gym_envs()

__all__ = [
    "OUTCOMES",
    "CaseBatch",
    "ClusterError",
    "DataError",
    "Database",
    "DiagnoseSpec",
    "GeometryError",
    "ImpactConfig",
    "ImpactParams",
    "ParameterError",
    "SimulationError",
    "SimulationParams",
    "StudySpec",
    "TargetExistsError",
    "VehicleArrays",
    "VehicleParams",
    "VfsError",
    "__version__",
    "compare_database",
    "diagnose",
    "effectiveness",
    "get_system",
    "load_study",
    "open_database",
    "read_runs",
    "results_table",
    "run_study",
    "simulate_cases",
    "solve_impact",
    "stack_vehicles",
    "vehicle_arrays",
]
