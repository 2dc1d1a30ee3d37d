"""The settings of one diagnosis (:class:`DiagnoseSpec`), declared and validated once.

``vfs diagnose`` builds a :class:`DiagnoseSpec` from its flags (the choices are the
:class:`enum.StrEnum` members below, the ranges :data:`RANGES`); the Python API
:func:`vfs.diagnosis.diagnose.diagnose` takes one or the same keyword arguments.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from vfs.errors import DataError, DataProblem, ParameterError

#: Most claims of the selection by default (library effects and learned laws together).
MAX_STEPS = 4
#: Fewest cases for which the diagnosis claims anything (below: unreliable, nothing claimed).
MIN_CASES = 30
#: Fewest held-out cases per fold for which the diagnosis claims anything.
MIN_FOLD_CASES = 5


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


#: field -> (lowest, highest, what it is); ``math.inf``: no upper bound.
RANGES: Mapping[str, tuple[float, float, str]] = {
    "folds": (2, math.inf, "k of the k-fold cross-validation"),
    "grid_points": (3, 101, "coarse grid points per parameter"),
    "zoom_rounds": (0, 10, "refinement rounds"),
    "confidence": (0.5, 0.9999, "confidence level"),
    "n_boot": (100, 1_000_000, "bootstrap samples"),
    "alpha": (1e-6, 0.5, "test level"),
    "min_reduction": (0.0, 0.99, "smallest reduction that counts"),
    "worst": (0, 1000, "worst cases listed"),
    "min_cases": (2, math.inf, "fewest cases for a claim"),
    "law_grid": (3, 201, "grid values per channel"),
    "max_steps": (1, 20, "most claims of the selection"),
}


def _names(value: str | Iterable[str] | None) -> tuple[str, ...] | None:
    """A comma-separated list or names as a tuple; None / "" / "all" stay None (all)."""
    if value is None:
        return None
    if isinstance(value, str):
        v = value.strip()
        if v in ("", "all"):
            return None
        value = v.split(",")
    out = tuple(dict.fromkeys(s.strip() for s in value if s.strip()))
    return out or None


def _channels(value: str | Iterable[str] | None) -> tuple[str, ...]:
    """Channels to learn: None / "" / "none" none; "all" the channels
    :func:`vfs.diagnosis.identify.parse_channels` identifies by default.
    """
    from vfs.diagnosis.identify import parse_channels

    if value is None or (isinstance(value, str) and value.strip() in ("", "none")):
        return ()
    return parse_channels(value)


@dataclass(frozen=True)
class DiagnoseSpec:
    """Everything a diagnosis is asked to do (docs/diagnosis.md).

    Attributes
    ----------
    outputs : tuple of str or None
        Compared outputs (None: all the reconstruction has).
    effects : tuple of str or None
        Library candidates (None: every registered effect).
    laws : tuple of str
        Channels identified per case and learned (empty: none; "all" given: every channel).
    folds, seed : int
        k-fold cross-validation by case; seed of the folds and the bootstrap.
    parameters : Parameters
    grid_points, zoom_rounds : int
        Parameter search of the library effects.
    confidence : float
        Simultaneous level of the reductions' CIs (Bonferroni over all candidates).
    n_boot : int
    correction : Correction
    alpha : float
        Level of the association tests.
    min_reduction : float
        Smallest CV RMSE reduction that counts as helping.
    worst : int
    stepwise : bool
        False: only the first claim (the best candidate alone) is made.
    min_cases : int
        Fewest cases for any claim (and :data:`MIN_FOLD_CASES` held-out cases per fold).
    law_grid : int
        Grid values per channel of the identification.
    max_steps : int
        Most claims of the selection.
    database : str
        Name or path for the reports.
    """

    outputs: tuple[str, ...] | None = None
    effects: tuple[str, ...] | None = None
    laws: tuple[str, ...] = ()
    folds: int = 5
    seed: int = 0
    parameters: Parameters = Parameters.PRIMARY
    grid_points: int = 9
    zoom_rounds: int = 3
    confidence: float = 0.95
    n_boot: int = 2000
    correction: Correction = Correction.BH
    alpha: float = 0.05
    min_reduction: float = 0.01
    worst: int = 6
    stepwise: bool = True
    min_cases: int = MIN_CASES
    law_grid: int = 13
    max_steps: int = MAX_STEPS
    database: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "outputs", _names(self.outputs))
        set_(self, "effects", _names(self.effects))
        set_(self, "laws", _channels(self.laws))
        for name, enum in (("parameters", Parameters), ("correction", Correction)):
            value = getattr(self, name)
            try:
                set_(self, name, enum(value))
            except ValueError:
                raise ParameterError(f"{name}={value!r}; use one of "
                                     f"{', '.join(m.value for m in enum)}") from None
        for name, (lo, hi, what) in RANGES.items():
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) \
                    or not lo <= value <= hi:
                upper = "" if hi == math.inf else f", {hi:g}"
                raise ParameterError(f"{name} ({what}) = {value!r} must be in [{lo:g}{upper}]")

    @classmethod
    def from_kwargs(cls, **kwargs: Any) -> DiagnoseSpec:
        """A spec from the keyword arguments of :func:`vfs.diagnosis.diagnose.diagnose`
        (``law_rounds`` of earlier versions: most claims after the first).
        """
        if "law_rounds" in kwargs:
            kwargs["max_steps"] = int(kwargs.pop("law_rounds")) + 1
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ParameterError(f"unknown diagnose setting(s): {', '.join(unknown)}")
        return cls(**kwargs)

    def check_cases(self, n: int) -> None:
        """Raise a :class:`vfs.errors.DataError` if ``n`` cases cannot fill the folds."""
        if n < self.folds:
            raise DataError(DataProblem(
                "reconstruction", "", None, None,
                f"too few cases ({n}) for {self.folds} folds; need at least {self.folds} "
                f"(use --folds {max(2, n)} or fewer; any claim needs {self.min_cases} cases "
                f"and {MIN_FOLD_CASES} held-out cases per fold)" if n >= 2 else
                f"too few cases ({n}) for a cross-validation; need at least 2 (and "
                f"{self.min_cases} for any claim)"),
                header="the database cannot be diagnosed:")

    def reliable(self, n: int) -> bool:
        """Enough cases (and held-out cases per fold) for any claim."""
        return n >= self.min_cases and n // self.folds >= MIN_FOLD_CASES


__all__ = ["MAX_STEPS", "MIN_CASES", "MIN_FOLD_CASES", "RANGES", "Correction", "DiagnoseSpec",
           "Fixed", "Parameters"]
