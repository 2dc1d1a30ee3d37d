"""One line describing an AEB system, generated from the parameters it runs with.

Reports show this line rather than the free-text ``description`` of a definition file, which a
user who copied a built-in and changed a threshold would otherwise see unchanged ("full 0.6 s"
after setting 1.0 s).  Units at the edge: s, m, degrees, km/h, m/s^2, m/s^3.
"""

from __future__ import annotations

import math
from typing import Any

from vfs.units import KMH_PER_MS


def _g(value: float) -> str:
    return f"{value:,.0f}" if abs(value) >= 1e4 else f"{value:.3g}"


def _aeb(aeb: Any) -> list[str]:
    parts = []
    stages = []
    if aeb.warning_ttc is not None:
        stages.append(f"warning at TTC {_g(aeb.warning_ttc)} s")
    if aeb.partial_ttc is not None:
        stages.append(f"partial braking (demand {_g(aeb.partial_deceleration)} m/s^2) at TTC "
                      f"{_g(aeb.partial_ttc)} s")
    if aeb.full_ttc is not None:
        stages.append(f"full braking (demand {_g(aeb.full_deceleration)} m/s^2) at TTC "
                      f"{_g(aeb.full_ttc)} s")
    if aeb.last_moment:
        stages.append(f"full braking (demand {_g(aeb.full_deceleration)} m/s^2) at the last moment "
                      "that still avoids the predicted contact")
    release = {"standstill": "held to standstill", "never": "never released",
               "ttc": f"released above {_g(aeb.release_factor)} x their TTC"}.get(
                   aeb.release, aeb.release)
    parts.append(", ".join(stages) + f" ({aeb.prediction.upper()} prediction; stages "
                 f"{release})")
    s = aeb.sensor
    cycle = f"{_g(1.0 / s.cycle_time)} Hz" if s.cycle_time > 0 else "every time step"
    reach = f"{_g(s.range)} m" if math.isfinite(s.range) else "unlimited range"
    sensor = (f"sensor {reach}, {_g(math.degrees(s.field_of_view))} deg field of view, "
              f"{cycle}, {_g(s.latency)} s latency")
    if s.detection_probability < 1.0:
        sensor += f", detects {100 * s.detection_probability:.0f} % of cycles"
    parts.append(sensor)
    parts.append(f"active from {_g(aeb.min_speed * KMH_PER_MS)} to "
                 f"{_g(aeb.max_speed * KMH_PER_MS)} km/h")
    return parts


def _driver(driver: Any) -> str:
    if driver is None:
        return "the driver does not react"
    reaction = (f"after {_g(driver.reaction_time)} s" if driver.reaction_time is not None else
                f"after a Gamma({_g(driver.reaction_shape)}, {_g(driver.reaction_rate)}/s) "
                f"reaction time (mean {_g(driver.reaction_shape / driver.reaction_rate)} s)")
    return (f"{100 * driver.brake_share:.0f} % of drivers brake {reaction} + "
            f"{_g(driver.brake_lag)} s at {_g(driver.deceleration_mean)} m/s^2 "
            f"(sd {_g(driver.deceleration_sd)})")


def describe_system(system: Any) -> str:
    """The parameters of an AEB system in one line (display units).

    Parameters
    ----------
    system : AEBSystem or any object with ``aeb``, ``driver`` and ``brake``
        The system as it runs (a controller plugin without these attributes gets its own
        ``description``).

    Returns
    -------
    str
        E.g. "warning at TTC 2.6 s, partial braking (4 m/s^2) at TTC 1.6 s, full braking
        (10 m/s^2) at TTC 1 s (...); sensor 150 m, ...; brake jerk 40 m/s^3, at most 10
        m/s^2; 70 % of drivers brake after ...".
    """
    if not all(hasattr(system, a) for a in ("aeb", "driver", "brake")):
        return str(getattr(system, "description", "") or "a controller plugin")
    if system.aeb is None:
        return "no AEB (the recorded behaviour)"
    b = system.brake
    brake = f"brake {b.model} actuator, at most {_g(b.max_deceleration)} m/s^2"
    if b.model == "jerk":
        brake += f", jerk {_g(b.jerk)} m/s^3"
    else:
        brake += f", time constant {_g(b.time_constant)} s"
    return "; ".join([*_aeb(system.aeb), brake, _driver(system.driver)])


__all__ = ["describe_system"]
