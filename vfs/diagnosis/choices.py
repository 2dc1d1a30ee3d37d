"""The choices of the diagnosis' settings (:class:`vfs.diagnosis.diagnose_spec.DiagnoseSpec`,
:class:`vfs.diagnosis.calibrate.FitSpace`), each an :class:`enum.StrEnum` declared once.

A module of its own, importing nothing of the diagnosis, so that the fitting
(:mod:`vfs.diagnosis.calibrate`) and the job spec can both use them without a cycle.
"""

from __future__ import annotations

from enum import StrEnum


class Parameters(StrEnum):
    """Which parameters of a library effect are fitted."""

    PRIMARY = "primary"
    ALL = "all"


class Fixed(StrEnum):
    """Where the parameters of a library effect that are not fitted stay."""

    DEFAULT = "default"
    NEUTRAL = "neutral"


class Correction(StrEnum):
    """Multiplicity control of the residual-feature associations."""

    BH = "bh"
    HOLM = "holm"


__all__ = ["Correction", "Fixed", "Parameters"]
