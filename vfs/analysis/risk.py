"""Injury-risk curves: probability of an injury level as a function of delta-v.

Every curve is a frozen dataclass registered by name in :data:`RISK_CURVES`.
``curve.probability(delta_v_ms)`` takes delta-v in m/s (SI, like the rest of
vfs), converts it to the unit the curve was fitted in (:attr:`RiskCurve.input_unit`)
and returns probabilities in [0, 1], element-wise, with NaN for NaN.

Curves (coefficients from docs/references.md, "Injury risk from
delta-v"):

* NHTSA DOT HS 813 219 (2022), logistic in mph: all directions MAIS2+/MAIS3+/
  fatal, frontal MAIS2+/MAIS3+/fatal, rear MAIS3+;
* Kusano & Gabler, MAIS2+, logistic in km/h with a seat-belt term;
* Joksch (1993), driver fatality ``min(1, (dv / 71 mph)^4)``.

The default curve per injury level is named in :data:`DEFAULT_CURVES`; new
curves are added with :func:`register_risk_curve`.

Examples
--------
>>> curve = get_risk_curve("nhtsa2022_all_mais3")
>>> round(float(curve.probability(30 * MS_PER_MPH)), 4)  # 30 mph
0.1148
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt
from scipy.special import expit

from vfs.errors import ParameterError
from vfs.registry import Registry
from vfs.units import KMH_PER_MS

#: One mile per hour in m/s, exact by definition (1609.344 m / 3600 s).
MS_PER_MPH = 0.44704  # [m/s per mph]

#: Speed of one unit in m/s, for the units a curve can be fitted in; a value in
#: the curve's unit is ``delta_v_ms / MS_PER_UNIT[unit]``.
MS_PER_UNIT: dict[str, float] = {
    "m/s": 1.0,
    "km/h": 1.0 / KMH_PER_MS,
    "mph": MS_PER_MPH,
}


def _validated_delta_v(delta_v_ms: npt.ArrayLike) -> np.ndarray:
    """Delta-v as a float array [m/s]; NaN allowed, negative values rejected."""
    try:
        dv = np.asarray(delta_v_ms, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"delta-v must be numeric [m/s], got {delta_v_ms!r}") from exc
    negative = dv < 0.0  # False for NaN
    if np.any(negative):
        raise ParameterError(
            f"delta-v must be >= 0 m/s (a magnitude), got {dv[negative].ravel()[:5].tolist()}"
        )
    return dv


@dataclass(frozen=True, kw_only=True)
class RiskCurve(ABC):
    """Abstract base class of injury-risk curves.

    Subclasses implement :meth:`_probability_in_unit`; :meth:`probability`
    validates and converts the input.

    Attributes
    ----------
    name : str
        Registry key, e.g. ``"nhtsa2022_all_mais3"``.
    description : str
        One line: what the curve predicts, for which population.
    source : str
        Citation of the publication the coefficients come from.
    injury_level : str
        Predicted outcome, e.g. ``"MAIS2+"``, ``"MAIS3+"``, ``"fatal"``.
    input_unit : str
        Unit of delta-v the curve was fitted in, a key of :data:`MS_PER_UNIT`
        (``"mph"``, ``"km/h"`` or ``"m/s"``).
    impact_direction : str
        Impact direction the curve applies to (``"all"``, ``"frontal"``,
        ``"rear"``, or ``"unspecified"``).
    """

    name: str
    description: str
    source: str
    injury_level: str
    input_unit: str
    impact_direction: str = "all"

    def __post_init__(self) -> None:
        if not self.name:
            raise ParameterError("a risk curve needs a non-empty name")
        if not self.injury_level:
            raise ParameterError(f"risk curve {self.name!r} needs an injury level")
        if self.input_unit not in MS_PER_UNIT:
            raise ParameterError(
                f"risk curve {self.name!r}: unknown input unit {self.input_unit!r}; "
                f"known: {sorted(MS_PER_UNIT)}"
            )

    def to_input_unit(self, delta_v_ms: npt.ArrayLike) -> np.ndarray:
        """Convert delta-v from m/s to the curve's input unit (no validation)."""
        return np.asarray(delta_v_ms, dtype=float) / MS_PER_UNIT[self.input_unit]

    def probability(self, delta_v_ms: npt.ArrayLike) -> np.ndarray:
        """Probability of :attr:`injury_level` at the given delta-v.

        Parameters
        ----------
        delta_v_ms : array_like
            Magnitude of the velocity change [m/s], >= 0; NaN for unknown.

        Returns
        -------
        numpy.ndarray
            Probabilities in [0, 1], same shape as the input (0-d for a
            scalar), NaN where the input is NaN.

        Raises
        ------
        ParameterError
            If a delta-v is negative or the input is not numeric.
        """
        dv = _validated_delta_v(delta_v_ms)
        return self._probability_in_unit(self.to_input_unit(dv))

    @abstractmethod
    def _probability_in_unit(self, delta_v: np.ndarray) -> np.ndarray:
        """Probability for delta-v already in :attr:`input_unit`."""


@dataclass(frozen=True, kw_only=True)
class LogisticRiskCurve(RiskCurve):
    """Logistic curve ``P = 1 / (1 + exp(-(a + b dv)))``, dv in :attr:`input_unit`.

    Attributes
    ----------
    intercept : float
        a [-].
    slope : float
        b [1 / input unit]; must be > 0 so that risk grows with delta-v.
    """

    intercept: float
    slope: float

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (np.isfinite(self.intercept) and np.isfinite(self.slope) and self.slope > 0):
            raise ParameterError(
                f"risk curve {self.name!r}: need finite intercept and slope > 0, "
                f"got a={self.intercept}, b={self.slope}"
            )

    def _linear_predictor(self, delta_v: np.ndarray) -> np.ndarray:
        return self.intercept + self.slope * delta_v

    def _probability_in_unit(self, delta_v: np.ndarray) -> np.ndarray:
        # expit is the overflow-free logistic function; NaN stays NaN
        return np.asarray(expit(self._linear_predictor(delta_v)))


@dataclass(frozen=True, kw_only=True)
class BeltedLogisticRiskCurve(LogisticRiskCurve):
    """Logistic curve with a seat-belt term: ``P = 1 / (1 + exp(-(a + b dv + c belt)))``.

    ``belt`` is coded +1 for a belted and -1 for an unbelted occupant.

    Attributes
    ----------
    belt_coefficient : float
        c [-].
    """

    belt_coefficient: float

    def probability(
        self, delta_v_ms: npt.ArrayLike, *, belted: npt.ArrayLike = True
    ) -> np.ndarray:
        """Probability of :attr:`injury_level` at the given delta-v and belt use.

        Parameters
        ----------
        delta_v_ms : array_like
            Magnitude of the velocity change [m/s], >= 0; NaN for unknown.
        belted : bool or array_like of bool, optional
            Belt use per occupant (default True), broadcast against
            ``delta_v_ms``; coded +1 (belted) / -1 (unbelted).

        Returns
        -------
        numpy.ndarray
            Probabilities in [0, 1], NaN where the input is NaN.

        Raises
        ------
        ParameterError
            If a delta-v is negative or ``belted`` is not boolean.
        """
        belt = np.asarray(belted)
        if belt.dtype != np.bool_:
            raise ParameterError(f"belted must be boolean, got dtype {belt.dtype}")
        dv = self.to_input_unit(_validated_delta_v(delta_v_ms))
        belt_code = np.where(belt, 1.0, -1.0)
        return np.asarray(expit(self._linear_predictor(dv) + self.belt_coefficient * belt_code))

    def _probability_in_unit(self, delta_v: np.ndarray) -> np.ndarray:
        return np.asarray(expit(self._linear_predictor(delta_v) + self.belt_coefficient))


@dataclass(frozen=True, kw_only=True)
class PowerRiskCurve(RiskCurve):
    """Power law ``P = min(1, (dv / dv_ref)^k)``, dv in :attr:`input_unit`.

    Attributes
    ----------
    reference_speed : float
        dv_ref, the delta-v at which P reaches 1 [input unit].
    exponent : float
        k [-], > 0.
    """

    reference_speed: float
    exponent: float

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (self.reference_speed > 0 and self.exponent > 0):
            raise ParameterError(
                f"risk curve {self.name!r}: reference_speed and exponent must be > 0"
            )

    def _probability_in_unit(self, delta_v: np.ndarray) -> np.ndarray:
        return np.minimum(1.0, (delta_v / self.reference_speed) ** self.exponent)


# ----------------------------------------------------------------------------
# Registry
# ----------------------------------------------------------------------------


def _check_curve(name: str, curve: RiskCurve) -> None:
    if not isinstance(curve, RiskCurve):
        raise ParameterError(f"expected a RiskCurve, got {type(curve).__name__}")
    if name != curve.name:
        raise ParameterError(f"risk curve {curve.name!r} registered as {name!r}")


#: All registered curves, by name (registering a name twice needs ``replace=True``).
RISK_CURVES: Registry[RiskCurve] = Registry("risk curve", check=_check_curve,
                                            same=lambda old, new: False)

CurveT = TypeVar("CurveT", bound=RiskCurve)


def register_risk_curve(curve: CurveT, *, replace: bool = False) -> CurveT:
    """Add a curve to :data:`RISK_CURVES` under its name and return it.

    Parameters
    ----------
    curve : RiskCurve
        The curve.
    replace : bool, optional
        Allow replacing a curve of the same name (default False).

    Returns
    -------
    RiskCurve
        ``curve`` itself, so that ``MY_CURVE = register_risk_curve(...)`` works.

    Raises
    ------
    ParameterError
        If ``curve`` is not a RiskCurve or the name is taken and ``replace``
        is False.
    """
    if not isinstance(curve, RiskCurve):
        raise ParameterError(f"expected a RiskCurve, got {type(curve).__name__}")
    RISK_CURVES.add(curve.name, curve, replace=replace)
    return curve


def get_risk_curve(name: str) -> RiskCurve:
    """Return the registered curve ``name``.

    Raises
    ------
    ParameterError
        If no curve has that name; the message lists the known names.
    """
    return RISK_CURVES.get(name)


def default_risk_curve(injury_level: str) -> RiskCurve:
    """Return the default curve of an injury level (see :data:`DEFAULT_CURVES`).

    Raises
    ------
    ParameterError
        If the injury level has no default; the message lists the levels.
    """
    try:
        return get_risk_curve(DEFAULT_CURVES[injury_level])
    except KeyError:
        raise ParameterError(
            f"no default risk curve for injury level {injury_level!r}; "
            f"known: {', '.join(DEFAULT_CURVES)}"
        ) from None


_NHTSA_2022 = (
    "NHTSA (2022), report DOT HS 813 219: logistic injury-risk curves of "
    "delta-v [mph] (coefficients as listed in docs/references.md)"
)
_NHTSA_LOGISTIC: dict[tuple[str, str], tuple[float, float]] = {
    # (direction, level): (a, b), dv in mph
    ("all", "MAIS2+"): (-5.1331, 0.1479),
    ("all", "MAIS3+"): (-6.9540, 0.1637),
    ("all", "fatal"): (-8.9819, 0.1603),
    ("frontal", "MAIS2+"): (-4.9429, 0.1425),
    ("frontal", "MAIS3+"): (-6.9774, 0.1620),
    ("frontal", "fatal"): (-9.0422, 0.1571),
    ("rear", "MAIS3+"): (-8.0329, 0.1793),
}
_LEVEL_SUFFIX = {"MAIS2+": "mais2", "MAIS3+": "mais3", "fatal": "fatal"}



def _register_nhtsa_2022() -> None:
    """Register the NHTSA (2022) logistic curves of :data:`_NHTSA_LOGISTIC`."""
    for (direction, level), (intercept, slope) in _NHTSA_LOGISTIC.items():
        register_risk_curve(
            LogisticRiskCurve(
                name=f"nhtsa2022_{direction}_{_LEVEL_SUFFIX[level]}",
                description=(
                    f"{level} risk of an occupant, {direction} impact directions, "
                    "logistic in delta-v [mph]"
                ),
                source=_NHTSA_2022,
                injury_level=level,
                input_unit="mph",
                impact_direction=direction,
                intercept=intercept,
                slope=slope,
            )
        )


_register_nhtsa_2022()

register_risk_curve(
    BeltedLogisticRiskCurve(
        name="kusano_gabler_mais2",
        description=(
            "MAIS2+ risk of an occupant, logistic in delta-v [km/h] with a belt term "
            "(belt coded +1 belted / -1 unbelted; the +-1 coding and that belted "
            "lowers the risk are assumed from the sign of the coefficient)"
        ),
        source=(
            "Kusano K.D., Gabler H.C.: MAIS2+ injury-risk function of delta-v "
            "(coefficients as listed in docs/references.md; publication not verified here)"
        ),
        injury_level="MAIS2+",
        input_unit="km/h",
        impact_direction="unspecified",
        intercept=-6.068,
        slope=0.100,
        belt_coefficient=-0.6234,
    )
)

register_risk_curve(
    PowerRiskCurve(
        name="joksch1993_fatal",
        description="Driver fatality risk, P = min(1, (dv / 71 mph)^4), all directions",
        source=(
            "Joksch H.C. (1993): Velocity change and fatality risk in a crash - "
            "a rule of thumb. Accident Analysis and Prevention 25(1), 103-104"
        ),
        injury_level="fatal",
        input_unit="mph",
        impact_direction="all",
        reference_speed=71.0,
        exponent=4.0,
    )
)

#: Default curve per injury level: the NHTSA (2022) all-direction curves, the
#: most recent and the only set covering all three levels with one method.
DEFAULT_CURVES: dict[str, str] = {
    "MAIS2+": "nhtsa2022_all_mais2",
    "MAIS3+": "nhtsa2022_all_mais3",
    "fatal": "nhtsa2022_all_fatal",
}

__all__ = [
    "DEFAULT_CURVES",
    "MS_PER_MPH",
    "MS_PER_UNIT",
    "RISK_CURVES",
    "BeltedLogisticRiskCurve",
    "LogisticRiskCurve",
    "PowerRiskCurve",
    "RiskCurve",
    "default_risk_curve",
    "get_risk_curve",
    "register_risk_curve",
]
