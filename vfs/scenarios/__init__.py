"""Scenario catalogue, synthetic accident database generator and the bundled database.

The scenes (:func:`generate_scenes`) are built from the car fleet (:mod:`.fleet`), the
accident-type catalogue (:mod:`.catalogue`), speed profiles (:mod:`.speed_profile`),
roads and manoeuvres (:mod:`.road`), contact placement (:mod:`.placement`) and one
designer per kind (:mod:`.designs`); :mod:`.generator` adds the reconstructions.
"""

from vfs.scenarios.catalogue import SCENARIO_TYPES, ScenarioSpec
from vfs.scenarios.fleet import FLEET, FleetClass, sample_fleet
from vfs.scenarios.scenes import SceneTables, generate_scenes

__all__ = [
    "FLEET",
    "SCENARIO_TYPES",
    "FleetClass",
    "ScenarioSpec",
    "SceneTables",
    "generate_scenes",
    "sample_fleet",
]
