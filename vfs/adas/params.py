"""Parameters of the generic AEB systems: sensor, decision logic and driver.

Frozen dataclasses with validated defaults; every default names its source
(``docs/references.md``, section "Generic AEB and driver", and seed
004 for the driver) or says that it has none.  The presets built from them
live in :mod:`vfs.adas.systems`; the formulas are in docs/aeb.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import ClassVar

from vfs.settings import Rule, setting, validate
from vfs.units import KMH_PER_MS


class Prediction(StrEnum):
    """Prediction models of the threat assessment (docs/aeb.md, section 3)."""

    CV = "cv"
    CTRV = "ctrv"
    CA = "ca"
    CTRA = "ctra"


class Release(StrEnum):
    """Release rules of the braking stages (docs/aeb.md, section 4)."""

    TTC = "ttc"
    STANDSTILL = "standstill"
    NEVER = "never"


#: Prediction models of the threat assessment (the values of :class:`Prediction`).
PREDICTION_MODELS: tuple[str, ...] = tuple(m.value for m in Prediction)

#: Release rules of the braking stages (the values of :class:`Release`).
RELEASE_RULES: tuple[str, ...] = tuple(m.value for m in Release)

#: Longest time to collision [s] a system looks ahead (the bound of the horizon and of
#: every stage threshold).
MAX_TTC = 30.0

#: Bounds of a demanded or driver deceleration [m/s^2]: (0, 100], about 10 g; the road
#: friction and the actuator limit what is delivered.
_DECELERATION = dict(lo=0.0, lo_open=True, hi=100.0)
_DRIVER_DECELERATION = dict(hi=20.0)  # a driver brakes at most 2 g
_STAGE_TTC = dict(lo=0.0, lo_open=True, hi=MAX_TTC, optional=True,
                  optional_doc="the stage is off")
_MOUNT = dict(lo=-20.0, hi=20.0)  # within a vehicle length of the bumper
_SPEED_MAX = 100.0  # [m/s] (360 km/h): the upper bound of the activation window

#: At or below this speed [m/s] a vehicle stands still (release rule "standstill").  The
#: simulation's speed max(v_rec - dv, 0) reaches exactly 0 when braked to rest; releasing
#: at any residual speed would leave the vehicle creeping at it (dv stops growing).
STANDSTILL_SPEED = 1e-6


@dataclass(frozen=True)
class SensorParams:
    """An environment sensor that sees the other participant of a case.

    The object counts as seen in a cycle when its outline rectangle intersects
    the sensor's field-of-view sector (apex at the mounting point, opening
    ``field_of_view``, radius ``range``) -- not only when a corner lies inside
    (docs/aeb.md, section 2) -- and the detection draw of that cycle succeeds.

    Attributes
    ----------
    range : float
        Detection range [m] from the mounting point; ``inf`` allowed.  Default
        150 m (openPASS AEB sensor profiles: 150-300 m, docs/references.md).
    field_of_view : float
        Horizontal opening angle [rad], in (0, 2 pi]; 2 pi = all around.
        Default 0.35 rad (openPASS profiles: 0.26-0.35 rad, docs/references.md).
    mount_x : float
        Longitudinal position of the sensor [m] relative to the centre of the
        front bumper, positive forward.  Default 0 (on the front bumper).
    mount_y : float
        Lateral position [m] relative to the vehicle's centre line, positive
        to the left.  Default 0.
    mount_yaw : float
        Boresight direction [rad] relative to the vehicle's x axis.  Default 0.
    cycle_time : float
        Measurement cycle [s]; the decision is updated once per cycle and held
        in between; 0 = every simulation step.  Default 0.05 s (20 Hz; no firm
        source, typical of automotive radars and cameras).
    latency : float
        Time [s] from a measurement to the moment its decision acts (sensor
        processing, decision, bus).  Default 0 (openPASS: latency 0,
        docs/references.md).
    detection_probability : float
        Probability [-] that a visible object is detected in a cycle (one
        uniform draw per cycle and visible object).  Default 1 (no firm source).
    """

    range: float = setting(150.0, "length", "detection range from the mounting point; "
                           "inf = unlimited", lo=0.0, lo_open=True)
    field_of_view: float = setting(0.35, "angle", "horizontal opening angle of the sensor "
                                   "sector; 360 deg = all around",
                                   lo=0.0, lo_open=True, hi=2.0 * math.pi)
    mount_x: float = setting(0.0, "length", "mounting point ahead of the centre of the "
                             "front bumper", **_MOUNT)  # type: ignore[arg-type]
    mount_y: float = setting(0.0, "length", "mounting point left of the centre line",
                             **_MOUNT)  # type: ignore[arg-type]
    mount_yaw: float = setting(0.0, "angle", "boresight relative to the vehicle's x axis",
                               lo=-2.0 * math.pi, hi=2.0 * math.pi)
    cycle_time: float = setting(0.05, "time", "measurement cycle; the decision is held in "
                                "between; 0 = every simulation step", lo=0.0, hi=1.0)
    latency: float = setting(0.0, "time", "from a measurement to the moment its decision "
                             "acts (processing, decision, bus)", lo=0.0, hi=2.0)
    detection_probability: float = setting(1.0, "ratio", "probability that a visible object "
                                           "is detected in a cycle", lo=0.0, hi=1.0)

    def __post_init__(self) -> None:
        validate(self)


@dataclass(frozen=True)
class AEBParams:
    """Threat assessment and staged braking of a generic AEB.

    A stage is off where its TTC threshold is ``None``.  Stage 1 "warning"
    only alerts the driver (:class:`DriverParams`), stage 2 "partial" and
    stage 3 "full" demand a deceleration.  A stage triggers when the measured
    time to collision (TTC) falls to its threshold while the own speed is in
    the activation window; it stays active until the release rule ends it.
    The demand is the largest deceleration of the active stages.

    Attributes
    ----------
    sensor : SensorParams
    prediction : {"cv", "ctrv", "ca", "ctra"}
        Motion model of both outlines for the TTC: "cv" constant velocity
        (exact swept separating-axis test); "ctrv" constant turn rate and
        velocity; "ca" constant acceleration (straight, until standstill);
        "ctra" the current path curvature with constant acceleration (the
        last three by a sampled sweep, docs/aeb.md section 3).  Default "cv".
    ttc_horizon : float
        Prediction horizon [s]; contacts later than this count as "no TTC"
        (infinite).  Default 4 s (covers 1.5 x the 2.6 s warning threshold).
    ctrv_tolerance : float
        Accuracy [m] of the sampled sweep (models other than "cv"): pairs
        whose prediction differs from CV by less use the exact CV test; the
        others are sampled with steps that keep the outline corners within
        it (docs/aeb.md, eq. 3.5).  Default 0.05 m.
    ctrv_step : float
        Largest sampling step [s] of the sampled sweep.  Default 0.5 s.
    warning_ttc : float or None
        TTC threshold of the warning [s].  Default None.
    partial_ttc : float or None
        TTC threshold of partial braking [s].  Default None.
    partial_deceleration : float
        Partial-braking demand [m/s^2].  Default 4.0 (about 40 % of full
        braking on a dry road, Applied Sciences 2024, 14(1):173, docs/references.md).
    full_ttc : float or None
        TTC threshold of full braking [s].  Default 0.6 s (same source).
    full_deceleration : float
        Full-braking demand [m/s^2], limited to road friction x g (the
        simulation's actuator limits it too).  Default 10.
    last_moment : bool
        Also trigger full braking at the last moment at which braking with the
        available deceleration still avoids the predicted contact, i.e. when
        the required deceleration reaches the available one (docs/aeb.md,
        section 3.4); the "ideal" system.  Default False.
    release : {"ttc", "standstill", "never"}
        "ttc": a stage ends when the TTC exceeds ``release_factor`` x its
        threshold (no predicted contact counts as infinite TTC; openPASS);
        "standstill": stages hold until the own vehicle stands still
        (speed 0); "never": they hold to the end.  Default "ttc".
    release_factor : float
        See ``release``; >= 1.  Default 1.5 (openPASS Algorithm_AEB).
    box_margin_longitudinal, box_margin_lateral : float
        Added to the length / width [m] of both outlines for the TTC, half on
        each side (openPASS "CollisionDetection...Boundary").  Default 0.
    min_speed, max_speed : float
        Activation window of the own speed [m/s]: stages trigger only inside
        it (active stages are held outside it).  Defaults 5 and 250 km/h
        (no firm source: below walking pace no AEB acts, no upper limit).
    """

    sensor: SensorParams = field(default_factory=SensorParams)
    prediction: str = setting(
        "cv", "text", "motion model of both outlines for the TTC: cv constant velocity "
        "(exact), ctrv constant turn rate and velocity, ca constant acceleration, ctra path "
        "curvature with constant acceleration (docs/aeb.md, section 3)", choices=Prediction)
    ttc_horizon: float = setting(4.0, "time", "prediction horizon; contacts predicted later "
                                 "count as no TTC", lo=0.0, lo_open=True, hi=MAX_TTC)
    ctrv_tolerance: float = setting(0.05, "length", "accuracy of the sampled sweep of the "
                                    "models other than cv", lo=0.001, hi=1.0)
    ctrv_step: float = setting(0.5, "time", "largest sampling step of that sweep",
                               lo=0.01, hi=1.0)
    warning_ttc: float | None = setting(
        None, "time", "stage 1 (alerts the driver, no braking) triggers when the TTC falls "
        "to this; <= ttc_horizon", **_STAGE_TTC)  # type: ignore[arg-type]
    partial_ttc: float | None = setting(
        None, "time", "stage 2 (partial braking) triggers at this TTC; <= warning_ttc",
        **_STAGE_TTC)  # type: ignore[arg-type]
    partial_deceleration: float = setting(4.0, "acceleration", "partial braking's demanded "
                                          "deceleration; <= full_deceleration",
                                          **_DECELERATION)  # type: ignore[arg-type]
    full_ttc: float | None = setting(
        0.6, "time", "stage 3 (full braking) triggers at this TTC; <= partial_ttc",
        **_STAGE_TTC)  # type: ignore[arg-type]
    full_deceleration: float = setting(10.0, "acceleration", "full braking's demanded "
                                       "deceleration (road friction and the brake actuator "
                                       "limit it)", **_DECELERATION)  # type: ignore[arg-type]
    last_moment: bool = setting(False, "bool", "also trigger full braking at the last moment "
                                "at which braking still avoids the predicted contact (the "
                                "ideal system)")
    release: str = setting("ttc", "text", "when an active stage ends: ttc (the TTC exceeds "
                           "release_factor x its threshold), standstill (the own vehicle "
                           "stops), never", choices=Release)
    release_factor: float = setting(1.5, "ratio", "see release = ttc (openPASS: 1.5)",
                                    lo=1.0, hi=10.0)
    box_margin_longitudinal: float = setting(0.0, "length", "added to the length of both "
                                             "outlines for the TTC, half at each end "
                                             "(openPASS)", lo=0.0, hi=20.0)
    box_margin_lateral: float = setting(0.0, "length", "added to the width of both outlines "
                                        "for the TTC, half on each side", lo=0.0, hi=20.0)
    min_speed: float = setting(5.0 / KMH_PER_MS, "speed", "stages trigger only at or above "
                               "this own speed (active ones are held below it)",
                               lo=0.0, hi=_SPEED_MAX, hi_open=True)
    max_speed: float = setting(250.0 / KMH_PER_MS, "speed", "... and at or below this one; "
                               "> min_speed", lo=0.0, lo_open=True, hi=_SPEED_MAX)

    #: Rules between the settings.
    RULES: ClassVar[tuple[Rule, ...]] = (
        Rule(("min_speed", "max_speed"), lambda p: p.min_speed < p.max_speed,
             "min_speed < max_speed"),
        Rule(("warning_ttc", "partial_ttc", "full_ttc", "last_moment"),
             lambda p: p.thresholds != (None, None, None) or p.last_moment,
             "an AEB needs at least one stage (a TTC threshold or last_moment=True)"),
        Rule(("warning_ttc", "partial_ttc", "full_ttc"), lambda p: _ordered(p.thresholds),
             "stage order: warning_ttc >= partial_ttc >= full_ttc (of the stages that are on)"),
        Rule(("warning_ttc", "partial_ttc", "full_ttc", "ttc_horizon"),
             lambda p: all(t <= p.ttc_horizon for t in p.thresholds if t is not None),
             "every stage threshold <= ttc_horizon (beyond it no TTC is measured)"),
        Rule(("partial_ttc", "partial_deceleration", "full_deceleration"),
             lambda p: p.partial_ttc is None or p.partial_deceleration <= p.full_deceleration,
             "partial_deceleration <= full_deceleration (when partial braking is on)"),
    )

    def __post_init__(self) -> None:
        validate(self)

    @property
    def thresholds(self) -> tuple[float | None, float | None, float | None]:
        """TTC thresholds [s] of the stages warning, partial and full (None = off)."""
        return (self.warning_ttc, self.partial_ttc, self.full_ttc)


@dataclass(frozen=True)
class DriverParams:
    """The driver of an equipped vehicle reacting to the first AEB alert.

    After the first alert (any stage) the driver brakes, with probability
    ``brake_share``, after the reaction time plus the brake lag, and then
    demands the sampled deceleration until the end of the run.  All values
    are drawn once per case and participant in ``reset`` from the
    simulation's generator.

    Attributes
    ----------
    reaction_time : float or None
        Fixed reaction time [s]; None = drawn from Gamma(``reaction_shape``,
        rate ``reaction_rate``).  Default None.
    reaction_shape : float
        Gamma shape [-].  Default 7 (J. Adv. Transp. 2021, 4430730, Table 4,
        docs/references.md).
    reaction_rate : float
        Gamma rate [1/s] (mean = shape / rate = 1.0 s, within the Reconstruction chapter's
        0.5-1.5 s).  Default 7 (same source).
    brake_lag : float
        Time [s] from the end of the reaction to the start of the driver's
        braking demand (pedal travel); the system's actuator then builds the
        deceleration up.  Default 0.2 s (middle of the Reconstruction chapter's 0.1-0.3 s).
    brake_share : float
        Share [-] of drivers who brake at all.  Default 0.7 (J. Adv. Transp.
        2021, Table 4).
    deceleration_mean, deceleration_sd : float
        Normal distribution of the driver's deceleration [m/s^2]; sd 0 = the
        mean for everybody.  Defaults 6.4 and 1.0 (same source).
    deceleration_min, deceleration_max : float
        Clipping range [m/s^2].  Defaults 3 and 9 (same source).
    """

    reaction_time: float | None = setting(
        None, "time", "a fixed reaction time to the first alert", lo=0.0, hi=10.0,
        optional=True, optional_doc="drawn from Gamma(reaction_shape, reaction_rate)")
    reaction_shape: float = setting(7.0, "ratio", "Gamma shape of the reaction time",
                                    lo=0.0, lo_open=True, hi=100.0)
    reaction_rate: float = setting(7.0, "rate", "Gamma rate of the reaction time (mean = "
                                   "shape / rate)", lo=0.0, lo_open=True, hi=100.0)
    brake_lag: float = setting(0.2, "time", "from the end of the reaction to the driver's "
                               "braking demand (pedal travel)", lo=0.0, hi=2.0)
    brake_share: float = setting(0.7, "ratio", "share of drivers who brake at all",
                                 lo=0.0, hi=1.0)
    deceleration_mean: float = setting(6.4, "acceleration", "mean of the driver's "
                                       "deceleration (normal distribution, drawn per case)",
                                       lo=0.0, lo_open=True,
                                       **_DRIVER_DECELERATION)  # type: ignore[arg-type]
    deceleration_sd: float = setting(1.0, "acceleration", "its standard deviation; 0 = the "
                                     "mean for everybody", lo=0.0,
                                     **_DRIVER_DECELERATION)  # type: ignore[arg-type]
    deceleration_min: float = setting(3.0, "acceleration", "drawn decelerations are clipped "
                                      "to at least this (<= deceleration_mean)",
                                      lo=0.0, lo_open=True,
                                      **_DRIVER_DECELERATION)  # type: ignore[arg-type]
    deceleration_max: float = setting(9.0, "acceleration", "... and at most this "
                                      "(>= deceleration_mean)", lo=0.0, lo_open=True,
                                      **_DRIVER_DECELERATION)  # type: ignore[arg-type]

    #: Rules between the settings.
    RULES: ClassVar[tuple[Rule, ...]] = (
        Rule(("deceleration_min", "deceleration_mean", "deceleration_max"),
             lambda p: p.deceleration_min <= p.deceleration_mean <= p.deceleration_max,
             "deceleration_min <= deceleration_mean <= deceleration_max"),
    )

    def __post_init__(self) -> None:
        validate(self)


def _ordered(thresholds: tuple[float | None, ...]) -> bool:
    """True when the thresholds that are on do not increase (warning >= partial >= full)."""
    on = [t for t in thresholds if t is not None]
    return all(a >= b for a, b in zip(on, on[1:], strict=False))
