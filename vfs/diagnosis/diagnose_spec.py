"""The settings of one diagnosis (:class:`DiagnoseSpec`), declared and validated once.

``vfs diagnose`` builds a :class:`DiagnoseSpec` from its flags; each field is declared
once with :func:`vfs.settings.setting` (bounds, default, choices as the
:class:`enum.StrEnum` classes below, one line of doc), from which the checks, the
command line's choices, defaults and help and the table of docs/diagnosis.md are
derived.  The Python API :func:`vfs.diagnosis.diagnose.diagnose` takes one or the same
keyword arguments.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from vfs.diagnosis.choices import Correction, Fixed, Parameters, parse_channels
from vfs.errors import DataError, DataProblem, ParameterError
from vfs.settings import setting, validate

#: Most claims of the selection by default (library effects and learned laws together).
MAX_STEPS = 4
#: Fewest cases for which the diagnosis claims anything (below: unreliable, nothing claimed).
MIN_CASES = 30
#: Fewest held-out cases per fold for which the diagnosis claims anything.
MIN_FOLD_CASES = 5


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
    :func:`vfs.diagnosis.choices.parse_channels` identifies by default.
    """
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
    folds: int = setting(5, "int", "k of the k-fold cross-validation by case", lo=2)
    seed: int = setting(0, "int", "seed of the folds and the bootstrap")
    parameters: Parameters = setting(
        Parameters.PRIMARY, "text", "fit each effect's primary parameter (diagnose: the "
        "others at their neutral values, calibrate: at their defaults) or all",
        choices=Parameters)
    grid_points: int = setting(9, "int", "coarse grid points per parameter", lo=3, hi=101)
    zoom_rounds: int = setting(3, "int", "refinement rounds halving the grid spacing",
                               lo=0, hi=10)
    confidence: float = setting(0.95, "ratio", "simultaneous level of the reductions' CIs "
                                "(Bonferroni over all candidates)", lo=0.5, hi=0.9999)
    n_boot: int = setting(2000, "int", "bootstrap samples", lo=100, hi=1_000_000)
    correction: Correction = setting(Correction.BH, "text", "multiplicity control of the "
                                     "residual-feature associations", choices=Correction)
    alpha: float = setting(0.05, "ratio", "level of the association tests", lo=1e-6, hi=0.5)
    min_reduction: float = setting(0.01, "ratio", "smallest CV RMSE reduction that counts "
                                   "as helping", lo=0.0, hi=0.99)
    worst: int = setting(6, "int", "worst cases listed and sketched", lo=0, hi=1000)
    stepwise: bool = setting(True, "bool", "false: only the first claim (the best candidate "
                             "alone) is made")
    min_cases: int = setting(MIN_CASES, "int", "fewest cases for any claim", lo=2)
    law_grid: int = setting(13, "int", "grid values per channel of the identification",
                            lo=3, hi=201)
    max_steps: int = setting(MAX_STEPS, "int", "most claims of the selection", lo=1, hi=20)
    database: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "outputs", _names(self.outputs))
        set_(self, "effects", _names(self.effects))
        set_(self, "laws", _channels(self.laws))
        validate(self)
        set_(self, "parameters", Parameters(self.parameters))
        set_(self, "correction", Correction(self.correction))

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


__all__ = ["MAX_STEPS", "MIN_CASES", "MIN_FOLD_CASES", "Correction", "DiagnoseSpec",
           "Fixed", "Parameters"]
