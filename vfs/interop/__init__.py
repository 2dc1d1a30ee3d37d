"""File exchange with the simulators people use: OpenSCENARIO scenarios and OpenDRIVE roads.

:func:`export_case` writes a case (recorded, or re-simulated with an AEB
system: :func:`simulated_motion`, :func:`study_motion`) as ``.xosc`` +
``.xodr`` files; :func:`import_xosc` reads such files back into a database;
:func:`validate_file` checks them against the shipped ASAM schemas.  Writing
and validating need the optional extra ``xosc`` (``scenariogeneration``,
``xmlschema``), imported only when used; reading needs nothing beyond vfs.
See docs/interop.md.
"""

from vfs.interop.motion import (
    CaseMotion,
    ParticipantMotion,
    recorded_motion,
    simulated_motion,
    study_motion,
)
from vfs.interop.opendrive import CaseRoads, ReferenceLine, Road, RoadSegment, case_roads
from vfs.interop.openscenario import XoscExport, export_case, reference_offset
from vfs.interop.scenario_import import import_xosc
from vfs.interop.schemas import schema_errors, validate_file

__all__ = [
    "CaseMotion",
    "CaseRoads",
    "ParticipantMotion",
    "ReferenceLine",
    "Road",
    "RoadSegment",
    "XoscExport",
    "case_roads",
    "export_case",
    "import_xosc",
    "recorded_motion",
    "reference_offset",
    "schema_errors",
    "simulated_motion",
    "study_motion",
    "validate_file",
]
