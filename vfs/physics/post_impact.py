"""What a reconstruction knows about the run-out of a case, per vehicle: wheel brakes, driver
braking, extra drag per wheel, front-wheel steer angle and its onset.

:class:`PostImpactInputs` carries the reconstruction's ``post_*`` columns
(``docs/data-format.md``) into the run-out (:func:`vfs.physics.runout.run_out`,
:func:`vfs.physics.runout.run_out_pair`, :class:`vfs.simulation.CaseBatch`); NaN = the run-out's
default.  The bounds here are the database columns' (:mod:`vfs.database.schema` reads them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.errors import ParameterError


@dataclass(frozen=True, eq=False)
class PostImpactInputs:
    """What a reconstruction knows about the run-out of N cases, per vehicle; NaN = not given.

    The inputs of the reconstruction columns ``post_*`` (``docs/data-format.md``), in SI
    units, vehicle 1 at index 0 of axis 1.  :meth:`wheel_brake`, :meth:`wheel_drag`,
    :meth:`steer` and :meth:`steer_onset` resolve NaN to the documented defaults, so a
    case without any of them runs exactly as before (bit for bit).

    Attributes
    ----------
    brake : ndarray (N, 2, 4)
        Brake factor per wheel (FL, FR, RL, RR) after the impact [-], in [0, 1]:
        1 locked, b < 1 rolling and braked with b mu N.  NaN: ``driver_brake``.
    driver_brake : ndarray (N, 2)
        Driver braking after the crash [-], the brake factor of every wheel without its
        own value.  NaN: the run-out default ``RunoutParams.wheel_brake``.
    drag : ndarray (N, 2, 4)
        Extra rolling drag per wheel [-], a coefficient of the wheel load added to the
        rolling resistance (a damaged wheel rubbing on the body, the engine in gear).
        NaN: 0.
    steer_angle : ndarray (N, 2)
        Steer angle of both front wheels after the impact [rad], positive to the left.
        NaN: 0.
    steer_onset : ndarray (N, 2)
        Time after the separation at which the steer angle sets in [s] (straight wheels
        before).  NaN: 0.
    """

    brake: np.ndarray
    driver_brake: np.ndarray
    drag: np.ndarray
    steer_angle: np.ndarray
    steer_onset: np.ndarray

    def __post_init__(self) -> None:
        shapes = {"brake": 3, "driver_brake": 2, "drag": 3, "steer_angle": 2,
                  "steer_onset": 2}
        n = np.shape(self.brake)[0] if np.ndim(self.brake) else -1
        for name, ndim in shapes.items():
            a = np.array(getattr(self, name), dtype=float)
            want = (n, 2, 4) if ndim == 3 else (n, 2)
            if a.shape != want:
                raise ParameterError(f"PostImpactInputs.{name} has shape {a.shape}, "
                                     f"expected {want}")
            lo, hi = POST_IMPACT_RANGES[name]
            bad = ~np.isnan(a) & ~((a >= lo) & (a <= hi))
            if bad.any():
                at = tuple(int(i[0]) for i in np.nonzero(bad))
                raise ParameterError(f"PostImpactInputs.{name}{list(at)}={a[at]!r} outside "
                                     f"[{lo:g}, {hi:g}]")
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    @property
    def size(self) -> int:
        """Number of cases N."""
        return int(self.brake.shape[0])

    @classmethod
    def unknown(cls, n: int) -> PostImpactInputs:
        """N cases of which nothing is known (every value NaN: the defaults)."""
        return cls(np.full((n, 2, 4), np.nan), np.full((n, 2), np.nan),
                   np.full((n, 2, 4), np.nan), np.full((n, 2), np.nan),
                   np.full((n, 2), np.nan))

    def take(self, index: npt.ArrayLike) -> PostImpactInputs:
        """Select cases by index (or mask)."""
        idx = np.arange(self.size)[index]
        return PostImpactInputs(self.brake[idx], self.driver_brake[idx], self.drag[idx],
                                self.steer_angle[idx], self.steer_onset[idx])

    @property
    def given(self) -> bool:
        """True if any value is given (not NaN)."""
        return any(not np.isnan(a).all() for a in (self.brake, self.driver_brake, self.drag,
                                                    self.steer_angle, self.steer_onset))

    def with_brakes(self, brake1: npt.ArrayLike, brake2: npt.ArrayLike) -> PostImpactInputs:
        """A copy with every wheel's brake factor given [-]: ``brake1``, ``brake2`` (N, 4)
        of vehicles 1 and 2 (checked against [0, 1]).
        """
        brake = np.stack([np.asarray(brake1, float), np.asarray(brake2, float)], axis=1)
        return PostImpactInputs(brake, self.driver_brake, self.drag, self.steer_angle,
                                self.steer_onset)

    def with_steer(self, vehicle: int, angle: npt.ArrayLike,
                   onset: npt.ArrayLike | None = None) -> PostImpactInputs:
        """A copy with the front-wheel steer angle [rad] (N,) of ``vehicle`` (1 or 2) set
        (NaN: the default, 0), and its onset [s] (N,) if given.
        """
        if vehicle not in (1, 2):
            raise ParameterError(f"vehicle must be 1 or 2, got {vehicle!r}")
        steer = np.array(self.steer_angle, float, copy=True)
        steer[:, vehicle - 1] = np.broadcast_to(np.asarray(angle, float), (self.size,))
        start = self.steer_onset
        if onset is not None:
            start = np.array(start, float, copy=True)
            start[:, vehicle - 1] = np.broadcast_to(np.asarray(onset, float), (self.size,))
        return PostImpactInputs(self.brake, self.driver_brake, self.drag, steer, start)

    @property
    def wheels_given(self) -> bool:
        """True if a drag, steer angle or onset is given (the run-out needs the wheel
        inputs beyond the brakes).
        """
        return any(not np.isnan(a).all() for a in (self.drag, self.steer_angle,
                                                    self.steer_onset))

    def wheel_brake(self, default: npt.ArrayLike) -> np.ndarray:
        """Brake factors (N, 2, 4) [-]: a wheel's own value, else the driver braking, else
        ``default`` (4,) (``RunoutParams.wheel_brake``).
        """
        base = np.broadcast_to(np.asarray(default, float), (self.size, 2, 4))
        driver = np.where(np.isnan(self.driver_brake)[..., None], base,
                          self.driver_brake[..., None])
        return np.where(np.isnan(self.brake), driver, self.brake)

    def wheel_drag(self) -> np.ndarray:
        """Extra rolling drag (N, 2, 4) [-], NaN -> 0."""
        return np.where(np.isnan(self.drag), 0.0, self.drag)

    def steer(self) -> np.ndarray:
        """Front-wheel steer angles (N, 2) [rad], NaN -> 0."""
        return np.where(np.isnan(self.steer_angle), 0.0, self.steer_angle)

    def onset(self) -> np.ndarray:
        """Steering onsets (N, 2) [s], NaN -> 0."""
        return np.where(np.isnan(self.steer_onset), 0.0, self.steer_onset)


#: The fields of :class:`PostImpactInputs`, in order.
POST_IMPACT_FIELDS: tuple[str, ...] = ("brake", "driver_brake", "drag", "steer_angle",
                                       "steer_onset")

#: Largest front-wheel steer angle of the run-out [rad] (60 deg: beyond the steering lock of a
#: passenger car, room for a wheel turned by the damage).
MAX_STEER = math.radians(60.0)
#: Latest onset of the steering [s] after the separation.
MAX_STEER_ONSET = 30.0
#: Largest extra rolling drag of a wheel [-] (a jammed wheel slides: brake factor 1).
MAX_WHEEL_DRAG = 1.0
#: Allowed ranges of the :class:`PostImpactInputs` fields (SI), the same as the database
#: columns' (:mod:`vfs.database.schema` reads the bounds from here).
POST_IMPACT_RANGES: dict[str, tuple[float, float]] = {
    "brake": (0.0, 1.0), "driver_brake": (0.0, 1.0), "drag": (0.0, MAX_WHEEL_DRAG),
    "steer_angle": (-MAX_STEER, MAX_STEER), "steer_onset": (0.0, MAX_STEER_ONSET),
}


class WheelInputs(NamedTuple):
    """Per-vehicle wheel inputs of the run-out beyond the brake factors, checked."""

    drag: np.ndarray  # (n, 4) extra rolling drag [-]
    steer: np.ndarray  # (n,) front-wheel steer angle [rad]
    onset: np.ndarray  # (n,) time the steer angle sets in [s]

    def take(self, rows: np.ndarray) -> WheelInputs:
        """The inputs of some vehicles (index array)."""
        return WheelInputs(self.drag[rows], self.steer[rows], self.onset[rows])

    @property
    def steered(self) -> bool:
        """True if some vehicle steers."""
        return bool(np.any(self.steer != 0.0))


def check_wheel_inputs(wheel_drag: npt.ArrayLike | None, steer: npt.ArrayLike | None,
                  steer_onset: npt.ArrayLike | None, n: int, suffix: str = "") -> WheelInputs:
    """Extra drag (4,) or (n, 4), steer angle and onset () or (n,), defaults 0, checked."""
    out = []
    for name, raw, shapes, (lo, hi) in (
            ("wheel_drag", wheel_drag, ((4,), (n, 4)), POST_IMPACT_RANGES["drag"]),
            ("steer", steer, ((), (n,)), POST_IMPACT_RANGES["steer_angle"]),
            ("steer_onset", steer_onset, ((), (n,)), POST_IMPACT_RANGES["steer_onset"])):
        label = name + suffix
        a = np.asarray(0.0 if raw is None else raw, float)
        if a.shape not in shapes and raw is not None:
            raise ParameterError(f"{label} has shape {a.shape}, expected one of "
                                 f"{', '.join(str(x) for x in shapes)}")
        a = np.broadcast_to(a, shapes[1]).copy()
        ok = np.isfinite(a) & (a >= lo) & (a <= hi)
        if not ok.all():
            at = tuple(int(i[0]) for i in np.nonzero(~ok))
            raise ParameterError(f"{label}{list(at)}={a[at]!r} outside [{lo:g}, {hi:g}]")
        out.append(a)
    return WheelInputs(*out)
