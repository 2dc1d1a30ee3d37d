"""The choices of the diagnosis' settings (:class:`vfs.diagnosis.diagnose_spec.DiagnoseSpec`,
:class:`vfs.diagnosis.calibrate.FitSpace`): the :class:`enum.StrEnum` classes, each
declared once, and the channels a diagnosis may learn (:func:`parse_channels`).

A module of its own, importing nothing of the diagnosis, so that the job spec imports no
part of the diagnosis and every part of it (the fitting, the identification) can take
its defaults from the spec without a cycle.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import StrEnum

from vfs.effects.learned import CHANNELS
from vfs.errors import ParameterError

#: Channels identified by default (all).
DEFAULT_CHANNELS: tuple[str, ...] = tuple(CHANNELS)


def parse_channels(spec: str | Iterable[str] | None) -> tuple[str, ...]:
    """Channel names from ``"a,b"`` / a list / None or "all" (all channels)."""
    if spec is None or (isinstance(spec, str) and spec.strip() in ("", "all")):
        return DEFAULT_CHANNELS
    names = [s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec)]
    names = [s for s in names if s]
    bad = [s for s in names if s not in CHANNELS]
    if bad:
        raise ParameterError(f"unknown channel(s) {bad}; known: {sorted(CHANNELS)}")
    return tuple(dict.fromkeys(names))


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


__all__ = ["DEFAULT_CHANNELS", "Correction", "Fixed", "Parameters", "parse_channels"]
