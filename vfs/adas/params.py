"""Parameters of the generic AEB systems: sensor, decision logic and driver.

Frozen dataclasses with validated defaults; every default names its source
(``docs/references.md``, section "Generic AEB and driver", and seed
004 for the driver) or says that it has none.  The presets built from them
live in :mod:`vfs.adas.systems`; the formulas are in docs/aeb.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vfs.errors import ParameterError
from vfs.units import KMH_PER_MS

#: Prediction models of the threat assessment (docs/aeb.md, section 3).
PREDICTION_MODELS = ("cv", "ctrv", "ca", "ctra")

#: Release rules of the braking stages (docs/aeb.md, section 4).
RELEASE_RULES = ("ttc", "standstill", "never")

#: At or below this speed [m/s] a vehicle stands still (release rule "standstill").  The
#: simulation's speed max(v_rec - dv, 0) reaches exactly 0 when braked to rest; releasing
#: at any residual speed would leave the vehicle creeping at it (dv stops growing).
STANDSTILL_SPEED = 1e-6


def _finite_positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ParameterError(f"{name}={value} must be finite and > 0")


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

    range: float = 150.0
    field_of_view: float = 0.35
    mount_x: float = 0.0
    mount_y: float = 0.0
    mount_yaw: float = 0.0
    cycle_time: float = 0.05
    latency: float = 0.0
    detection_probability: float = 1.0

    def __post_init__(self) -> None:
        if not (self.range > 0.0) or math.isnan(self.range):
            raise ParameterError(f"sensor range={self.range} m must be > 0 (inf allowed)")
        if not 0.0 < self.field_of_view <= 2.0 * math.pi:
            raise ParameterError(f"sensor field_of_view={self.field_of_view} rad outside "
                                 "(0, 2 pi]")
        for name in ("mount_x", "mount_y", "mount_yaw"):
            if not math.isfinite(getattr(self, name)):
                raise ParameterError(f"sensor {name}={getattr(self, name)} must be finite")
        if not 0.0 <= self.cycle_time <= 1.0:
            raise ParameterError(f"sensor cycle_time={self.cycle_time} s outside [0, 1]")
        if not 0.0 <= self.latency <= 2.0:
            raise ParameterError(f"sensor latency={self.latency} s outside [0, 2]")
        if not 0.0 <= self.detection_probability <= 1.0:
            raise ParameterError(f"detection_probability={self.detection_probability} outside "
                                 "[0, 1]")


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
    prediction: str = "cv"
    ttc_horizon: float = 4.0
    ctrv_tolerance: float = 0.05
    ctrv_step: float = 0.5
    warning_ttc: float | None = None
    partial_ttc: float | None = None
    partial_deceleration: float = 4.0
    full_ttc: float | None = 0.6
    full_deceleration: float = 10.0
    last_moment: bool = False
    release: str = "ttc"
    release_factor: float = 1.5
    box_margin_longitudinal: float = 0.0
    box_margin_lateral: float = 0.0
    min_speed: float = 5.0 / KMH_PER_MS
    max_speed: float = 250.0 / KMH_PER_MS

    def __post_init__(self) -> None:
        if self.prediction not in PREDICTION_MODELS:
            raise ParameterError(f"prediction={self.prediction!r}; use one of "
                                 f"{PREDICTION_MODELS}")
        if self.release not in RELEASE_RULES:
            raise ParameterError(f"release={self.release!r}; use one of {RELEASE_RULES}")
        _finite_positive("ttc_horizon", self.ttc_horizon)
        if self.ttc_horizon > 30.0:
            raise ParameterError(f"ttc_horizon={self.ttc_horizon} s above 30 s")
        if not 0.01 <= self.ctrv_step <= 1.0:
            raise ParameterError(f"ctrv_step={self.ctrv_step} s outside [0.01, 1]")
        if not 0.001 <= self.ctrv_tolerance <= 1.0:
            raise ParameterError(f"ctrv_tolerance={self.ctrv_tolerance} m outside [0.001, 1]")
        for name in ("warning_ttc", "partial_ttc", "full_ttc"):
            value = getattr(self, name)
            if value is not None:
                _finite_positive(name, value)
        _finite_positive("partial_deceleration", self.partial_deceleration)
        _finite_positive("full_deceleration", self.full_deceleration)
        if not (math.isfinite(self.release_factor) and self.release_factor >= 1.0):
            raise ParameterError(f"release_factor={self.release_factor} must be >= 1")
        for name in ("box_margin_longitudinal", "box_margin_lateral"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 <= value <= 20.0):
                raise ParameterError(f"{name}={value} m outside [0, 20]")
        if not (0.0 <= self.min_speed < self.max_speed):
            raise ParameterError(f"activation window [{self.min_speed}, {self.max_speed}] m/s "
                                 "needs 0 <= min_speed < max_speed")
        if self.thresholds == (None, None, None) and not self.last_moment:
            raise ParameterError("an AEB needs at least one stage (a TTC threshold or "
                                 "last_moment=True)")

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

    reaction_time: float | None = None
    reaction_shape: float = 7.0
    reaction_rate: float = 7.0
    brake_lag: float = 0.2
    brake_share: float = 0.7
    deceleration_mean: float = 6.4
    deceleration_sd: float = 1.0
    deceleration_min: float = 3.0
    deceleration_max: float = 9.0

    def __post_init__(self) -> None:
        if self.reaction_time is not None and not (
                math.isfinite(self.reaction_time) and self.reaction_time >= 0.0):
            raise ParameterError(f"reaction_time={self.reaction_time} s must be >= 0")
        _finite_positive("reaction_shape", self.reaction_shape)
        _finite_positive("reaction_rate", self.reaction_rate)
        if not (math.isfinite(self.brake_lag) and 0.0 <= self.brake_lag <= 2.0):
            raise ParameterError(f"brake_lag={self.brake_lag} s outside [0, 2]")
        if not 0.0 <= self.brake_share <= 1.0:
            raise ParameterError(f"brake_share={self.brake_share} outside [0, 1]")
        if not (math.isfinite(self.deceleration_sd) and self.deceleration_sd >= 0.0):
            raise ParameterError(f"deceleration_sd={self.deceleration_sd} must be >= 0")
        if not (0.0 < self.deceleration_min <= self.deceleration_mean
                <= self.deceleration_max) or not math.isfinite(self.deceleration_max):
            raise ParameterError("driver deceleration needs 0 < min <= mean <= max (finite), "
                                 f"got {self.deceleration_min}, {self.deceleration_mean}, "
                                 f"{self.deceleration_max}")
