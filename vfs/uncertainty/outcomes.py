"""The outcomes of one run of the uncertainty model, per vehicle (``delta_v1``, ``ees2`` ...).

Each is a member of the vfs outcome vocabulary (:mod:`vfs.outcomes`: quantity,
SI and display unit, kind, derivation from reconstruction rows) for one
vehicle, or a case-level outcome, in the order of the reports.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from vfs.outcomes import OUTCOMES_BY_NAME as VOCABULARY
from vfs.outcomes import QUANTITIES


@dataclass(frozen=True)
class OutcomeInfo:
    """An outcome of one model run.

    Attributes
    ----------
    name, label : str
        Column name (``delta_v1``) and name in reports (``delta-v 1``).
    quantity : str
        ``speed``, ``angle``, ``length``, ``energy`` or ``probability``
        (:data:`vfs.outcomes.QUANTITIES`).
    kind : str
        ``ratio`` (non-negative magnitude: the relative half-width is
        reported), ``signed`` (coordinates, accumulated angles: absolute
        half-width only), ``circular`` (directions: quantiles after
        unwrapping around the nominal value) or ``indicator`` (0/1; the mean
        is a probability).
    vocabulary : str
        Name of the outcome in :mod:`vfs.outcomes` (``delta_v``).
    vehicle : int
        1 or 2; 0 for a case-level outcome.
    """

    name: str
    label: str
    quantity: str
    kind: str
    vocabulary: str
    vehicle: int


#: Per-vehicle outcomes (vocabulary name, label in reports), in report order.
_VEHICLE_OUTCOMES: tuple[tuple[str, str], ...] = (
    ("delta_v", "delta-v"),
    ("ees", "EES"),
    ("velocity_angle_change", "change of velocity angle"),
    ("post_speed", "post-impact speed"),
    ("post_direction", "post-impact direction"),
    ("pdof", "PDOF"),
    ("rest_x", "rest x"),
    ("rest_y", "rest y"),
    ("rest_yaw", "rest yaw"),
    ("runout_distance", "run-out distance"),
)
#: Case-level outcomes (vocabulary name, label in reports).
_CASE_OUTCOMES: tuple[tuple[str, str], ...] = (
    ("energy_loss", "energy loss"),
    ("closing_speed", "closing speed"),
    ("sliding", "sliding impact"),
)


def _info(stem: str, label: str, vehicle: int) -> OutcomeInfo:
    o = VOCABULARY[stem]
    suffix = f"{vehicle}" if vehicle else ""
    return OutcomeInfo(f"{stem}{suffix}", f"{label} {vehicle}" if vehicle else label,
                       o.quantity, o.kind, stem, vehicle)


#: Every outcome, in report order.
OUTCOMES: tuple[OutcomeInfo, ...] = (
    *(_info(stem, label, i) for stem, label in _VEHICLE_OUTCOMES for i in (1, 2)),
    *(_info(stem, label, 0) for stem, label in _CASE_OUTCOMES),
)
#: Outcome names in order.
OUTCOME_NAMES: tuple[str, ...] = tuple(o.name for o in OUTCOMES)
#: Outcomes by name.
OUTCOMES_BY_NAME: Mapping[str, OutcomeInfo] = MappingProxyType({o.name: o for o in OUTCOMES})
#: Outcome names before the run-out distance got its vocabulary name -> current name.
RENAMED_OUTCOMES: Mapping[str, str] = MappingProxyType(
    {f"rest_distance{i}": f"runout_distance{i}" for i in (1, 2)})

_USED = sorted({o.quantity for o in OUTCOMES})
#: Display units of reports: quantity -> (unit, factor from SI).
DISPLAY_UNITS: Mapping[str, tuple[str, float]] = MappingProxyType({
    q: (QUANTITIES[q].display_unit, QUANTITIES[q].display_factor) for q in _USED})
#: SI unit of each quantity.
SI_UNITS: Mapping[str, str] = MappingProxyType({q: QUANTITIES[q].si_unit for q in _USED})

__all__ = [
    "DISPLAY_UNITS", "OUTCOMES", "OUTCOMES_BY_NAME", "OUTCOME_NAMES", "RENAMED_OUTCOMES",
    "SI_UNITS", "OutcomeInfo",
]
