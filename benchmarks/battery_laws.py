"""Hidden laws of the diagnosis battery (benchmarks/diagnosis_battery.py).

Each law sets one channel of :data:`vfs.effects.learned.CHANNELS` per case by
a formula of one or two case features in a form that is *not* one of the
closed forms of :data:`vfs.effects.learned.FORMS` and not a library effect:
bell curves, logistic thresholds, hinges, tanh steps, products of two
features.  They were written for the battery, before any run of it, from
the physics each channel stands for; none was tuned on a result.

A law becomes an effect by :func:`hidden_effect` (a :class:`ChannelLaw`
subclass whose ``value`` evaluates the formula, with one parameter
``strength``: 0 = the default model, 1 = the law); the generator takes it
as a hidden effect (``generate_database(..., hidden=[effect])``) and the
battery registers it to measure the truth's own cross-validated reduction.

Units: SI (features as in :data:`vfs.effects.learned.LAW_FEATURES`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from vfs.effects.base import EffectParameter
from vfs.effects.learned import CHANNELS, ChannelLaw, feature_values, law_effect_class


@dataclass(frozen=True)
class HiddenLaw:
    """One hidden law.

    Attributes
    ----------
    name : str
        Effect name (letters, digits, _).
    channel : str
        Channel it sets.
    features : tuple of str
        Features the formula reads (first = leading).
    formula : callable
        f(x1[, x2]) -> channel value ("set") or offset ("shift"), SI.
    text : str
        The formula as a reader sees it.
    accept_features : tuple of str
        Leading features of a learned law that count as right (the leading
        feature and its near-equivalents, e.g. the closing speed and the normal
        closing speed).
    """

    name: str
    channel: str
    features: tuple[str, ...]
    formula: Callable[..., np.ndarray]
    text: str
    accept_features: tuple[str, ...] = ()

    def accepted_features(self) -> tuple[str, ...]:
        """Features a claimed law of this channel may lead with."""
        return tuple(dict.fromkeys((*self.features, *self.accept_features)))


def hidden_effect(law: HiddenLaw, strength: float = 1.0) -> Any:
    """An effect instance applying ``law`` (class named ``law.name``, not registered)."""
    ch = CHANNELS[law.channel]
    neutral = 0.0 if ch.mode == "shift" else 0.5 * (ch.lo + ch.hi)
    base = law_effect_class({"name": law.name, "channel": law.channel,
                             "feature": law.features[0], "form": "constant",
                             "coefficients": [neutral]})

    def value(self: ChannelLaw, ctx: Any, config: Any, base_value: np.ndarray) -> np.ndarray:
        xs = [feature_values(ctx, config, f) for f in law.features]
        with np.errstate(all="ignore"):
            v = np.asarray(law.formula(*xs), float)
        s = self["strength"]
        if ch.mode == "shift":
            v = base_value + np.clip(s * v, ch.lo, ch.hi)
        else:
            v = np.clip(base_value + s * (v - base_value), ch.lo, ch.hi)
        return np.where(np.isfinite(v), v, base_value)

    cls = type(f"Hidden_{law.name}", (base,), {
        "name": law.name, "value": value, "summary": law.text,
        "parameters": (EffectParameter("strength", 1.0, 0.0, 2.0, "-",
                                       "share of the hidden law (0 = default model)", 0.0),),
        "__doc__": f"Hidden battery law: {law.text}.",
    })
    return cls(strength=strength)


def _logistic(x: np.ndarray, centre: float, width: float) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-(x - centre) / width))


def _bell(x: np.ndarray, centre: float, width: float) -> np.ndarray:
    return np.exp(-((x - centre) / width) ** 2)


_SPEED = ("closing_speed", "normal_closing_speed")

#: The singles (>= 14), each with its own seed in the battery.
SINGLES: tuple[HiddenLaw, ...] = (
    HiddenLaw("eps_bell", "restitution", ("normal_closing_speed",),
              lambda v: 0.04 + 0.30 * _bell(v, 5.0, 4.0),
              "eps = 0.04 + 0.30 exp(-((v_n - 5 m/s) / 4 m/s)^2)", _SPEED),
    HiddenLaw("eps_overlap_speed", "restitution", ("closing_speed", "overlap"),
              lambda v, o: 0.32 * np.exp(-v / 9.0) * (0.4 + o),
              "eps = 0.32 exp(-v / 9 m/s) (0.4 + overlap)", _SPEED),
    HiddenLaw("mu_angle_logistic", "contact_friction", ("impact_angle",),
              lambda a: 0.15 + 0.55 * _logistic(a, 1.2, 0.12),
              "mu = 0.15 + 0.55 / (1 + exp(-(angle - 1.2 rad) / 0.12 rad))"),
    HiddenLaw("mu_overlap_bell", "contact_friction", ("overlap",),
              lambda o: 0.15 + 0.65 * _bell(o, 0.3, 0.18),
              "mu = 0.15 + 0.65 exp(-((overlap - 0.3) / 0.18)^2)"),
    HiddenLaw("poi_along_tanh", "poi_along", ("overlap",),
              lambda o: 0.45 * np.tanh((0.5 - o) / 0.12),
              "POI along += 0.45 m tanh((0.5 - overlap) / 0.12)"),
    HiddenLaw("poi_across_hinge", "poi_across", ("closing_speed",),
              lambda v: -0.02 * np.maximum(v - 10.0, 0.0),
              "POI across += -0.02 s max(v - 10 m/s, 0)", _SPEED),
    HiddenLaw("cp_sin_angle", "cp_angle", ("impact_angle",),
              lambda a: 0.22 * np.sin(2.0 * a),
              "contact plane += 0.22 rad sin(2 angle)"),
    HiddenLaw("tp_hinge", "penetration_time", ("closing_speed",),
              lambda v: 0.015 + 0.0012 * np.maximum(v - 12.0, 0.0),
              "t_p = 15 ms + 1.2 ms s/m max(v - 12 m/s, 0)", _SPEED),
    HiddenLaw("ees_mass_side", "ees_stiffness_ratio", ("impact_angle", "mass_ratio"),
              lambda a, q: q ** 0.3 * (1.0 + 1.5 * _logistic(a, 1.1, 0.1)),
              "k1/k2 = (m1/m2)^0.3 (1 + 1.5 / (1 + exp(-(angle - 1.1 rad) / 0.1 rad)))",
              ("mass_ratio",)),
    HiddenLaw("inertia_mass_logistic", "yaw_inertia_factor", ("mass_ratio",),
              lambda q: 0.6 + 0.8 * _logistic(q, 1.0, 0.08),
              "I / I_model = 0.6 + 0.8 / (1 + exp(-(m1/m2 - 1) / 0.08))"),
    HiddenLaw("tyre_friction_speed", "tyre_impulse", ("closing_speed", "road_friction"),
              lambda v, m: 1.6 * m * (1.0 - np.exp(-v / 12.0)),
              "dv = 1.6 m/s mu_road (1 - exp(-v / 12 m/s))", ("road_friction", *_SPEED)),
    HiddenLaw("brake1_logistic", "runout_brake1", ("closing_speed",),
              lambda v: 0.25 + 0.75 * _logistic(v, 16.0, 2.0),
              "b1 = 0.25 + 0.75 / (1 + exp(-(v - 16 m/s) / 2 m/s))", _SPEED),
    HiddenLaw("brake2_bell_angle", "runout_brake2", ("impact_angle",),
              lambda a: 0.2 + 0.7 * _bell(a, 1.57, 0.45),
              "b2 = 0.2 + 0.7 exp(-((angle - pi/2) / 0.45 rad)^2)"),
    HiddenLaw("brake1_speed_hinge", "runout_brake1", ("impact_speed1",),
              lambda s: np.clip(0.15 + 0.05 * np.maximum(s - 8.0, 0.0), 0.0, 1.0),
              "b1 = min(0.15 + 0.05 s/m max(v1 - 8 m/s, 0), 1)", ("closing_speed",)),
)

#: Pairs (>= 4): names of two singles hidden together.
PAIRS: tuple[tuple[str, str], ...] = (
    ("eps_bell", "brake1_logistic"),
    ("mu_angle_logistic", "ees_mass_side"),
    ("tyre_friction_speed", "cp_sin_angle"),
    ("tp_hinge", "brake2_bell_angle"),
)

#: Held out: laws and a pair run only at the end (not looked at while building).
HELD_OUT: tuple[HiddenLaw, ...] = (
    HiddenLaw("eps_angle_step_smooth", "restitution", ("impact_angle",),
              lambda a: 0.05 + 0.2 * _logistic(a, 2.2, 0.15),
              "eps = 0.05 + 0.2 / (1 + exp(-(angle - 2.2 rad) / 0.15 rad))"),
    HiddenLaw("tyre_overlap_threshold", "tyre_impulse", ("overlap",),
              lambda o: 1.4 * _logistic(0.45 - o, 0.0, 0.06),
              "dv = 1.4 m/s / (1 + exp(-(0.45 - overlap) / 0.06))"),
    HiddenLaw("brake2_speed2_sat", "runout_brake2", ("impact_speed2",),
              lambda s: 0.2 + 0.8 * (1.0 - np.exp(-np.maximum(s - 5.0, 0.0) / 6.0)),
              "b2 = 0.2 + 0.8 (1 - exp(-max(v2 - 5 m/s, 0) / 6 m/s))"),
    HiddenLaw("inertia_speed_bell", "yaw_inertia_factor", ("closing_speed",),
              lambda v: 1.5 - 0.8 * _bell(v, 15.0, 6.0),
              "I / I_model = 1.5 - 0.8 exp(-((v - 15 m/s) / 6 m/s)^2)", _SPEED),
)
HELD_OUT_PAIRS: tuple[tuple[str, str], ...] = (
    ("eps_angle_step_smooth", "brake2_speed2_sat"),
)

#: The second held-out part, written on 2026-11-27 after the first one had been run and its
#: one failure looked into, before any run of these: laws, a pair and a null database kept
#: out of every run but the final one.
HELD_OUT_2: tuple[HiddenLaw, ...] = (
    HiddenLaw("mu_speed_tanh_drop", "contact_friction", ("normal_closing_speed",),
              lambda v: 0.6 - 0.175 * (1.0 + np.tanh((v - 9.0) / 2.5)),
              "mu = 0.6 - 0.175 (1 + tanh((v_n - 9 m/s) / 2.5 m/s))", _SPEED),
    HiddenLaw("poi_across_angle_bell", "poi_across", ("impact_angle",),
              lambda a: 0.3 * _bell(a, 0.8, 0.35),
              "POI across += 0.3 m exp(-((angle - 0.8 rad) / 0.35 rad)^2)"),
    HiddenLaw("tp_overlap_speed", "penetration_time", ("overlap", "closing_speed"),
              lambda o, v: 0.01 + 0.04 * o * np.minimum(v / 20.0, 1.5),
              "t_p = 10 ms + 40 ms overlap min(v / 20 m/s, 1.5)", _SPEED),
    HiddenLaw("brake1_angle_drop", "runout_brake1", ("impact_angle",),
              lambda a: 0.85 - 0.6 * _logistic(a, 1.3, 0.15),
              "b1 = 0.85 - 0.6 / (1 + exp(-(angle - 1.3 rad) / 0.15 rad))"),
)
HELD_OUT_2_PAIRS: tuple[tuple[str, str], ...] = (
    ("mu_speed_tanh_drop", "brake1_angle_drop"),
)


#: The run-out part (issue 36), written on 2026-11-27 before any run of it: laws of what
#: happens after separation that act on both vehicles or on single wheels, the three kinds
#: the diagnosis failed on (a brake law of crash severity on both cars; the wheel at the
#: impact corner locked by damage; the latter paired with a restitution law).  The corner
#: laws move the wheel nearest the point of impact of each car
#: (:func:`vfs.effects.learned.impact_corner_wheels`); the other wheels keep the default
#: run-out's brake factor 0.8.
RUNOUT: tuple[HiddenLaw, ...] = (
    HiddenLaw("brake_both_severity", "runout_brake", ("closing_speed",),
              lambda v: 0.1 + 0.85 * _logistic(v, 14.0, 2.0),
              "b1 = b2 = 0.1 + 0.85 / (1 + exp(-(v - 14 m/s) / 2 m/s))", _SPEED),
    HiddenLaw("corner_lock_speed", "corner_brake", ("closing_speed",),
              lambda v: _logistic(v, 11.0, 1.5),
              "impact-corner wheels: b = 1 / (1 + exp(-(v - 11 m/s) / 1.5 m/s))", _SPEED),
)
RUNOUT_PAIRS: tuple[tuple[str, str], ...] = (
    ("corner_lock_speed", "eps_bell"),
)

#: Held out of the run-out part: run once, at the end of the session that wrote them.
HELD_OUT_3: tuple[HiddenLaw, ...] = (
    HiddenLaw("brake_both_overlap", "runout_brake", ("overlap",),
              lambda o: 0.15 + 0.75 * np.exp(-o / 0.3),
              "b1 = b2 = 0.15 + 0.75 exp(-overlap / 0.3)"),
    HiddenLaw("corner_lock_angle", "corner_brake", ("impact_angle",),
              lambda a: 0.1 + 0.9 * _logistic(a, 1.0, 0.15),
              "impact-corner wheels: b = 0.1 + 0.9 / (1 + exp(-(angle - 1 rad) / 0.15 rad))"),
)
HELD_OUT_3_PAIRS: tuple[tuple[str, str], ...] = (
    ("brake_both_overlap", "mu_overlap_bell"),
)


#: The run-out steer part (issue 36, "steering after impact"), written on 2026-11-28 before
#: any run of it, from the physics: a blow on a car's front axle turns its front wheels about
#: the kingpins; the angle is signed towards the side of each car the point of impact lies on
#: (:func:`vfs.effects.learned.impact_sides`: positive towards the impact side, so that a
#: mirrored scene steers mirrored).  The first: vehicle 2's front wheels pushed away from the
#: impact side (the wheel struck from the side turns its leading edge inwards) by up to
#: 0.4 rad, more in the harder crashes; the second: both cars' wheels turned towards the impact
#: side in side impacts (an impact angle about 90 deg; a frontal or rear blow turns no wheel).
STEER: tuple[HiddenLaw, ...] = (
    HiddenLaw("steer2_away_speed", "runout_steer2", ("closing_speed",),
              lambda v: -0.4 * _logistic(v, 12.0, 2.0),
              "delta2 = -0.4 rad / (1 + exp(-(v - 12 m/s) / 2 m/s)) (towards the impact side)",
              _SPEED),
    HiddenLaw("steer_both_side_bell", "runout_steer", ("impact_angle",),
              lambda a: 0.35 * _bell(a, 0.5 * np.pi, 0.45),
              "delta1 = delta2 = 0.35 rad exp(-((angle - pi/2) / 0.45 rad)^2) (towards the "
              "impact side)"),
)
STEER_PAIRS: tuple[tuple[str, str], ...] = (
    ("steer2_away_speed", "eps_bell"),
)

#: Held out of the steer part: run once, after the steer part, with no change in between.
HELD_OUT_4: tuple[HiddenLaw, ...] = (
    HiddenLaw("steer1_overlap_sat", "runout_steer1", ("overlap",),
              lambda o: -0.3 * (1.0 - np.exp(-o / 0.25)),
              "delta1 = -0.3 rad (1 - exp(-overlap / 0.25)) (towards the impact side)"),
)
HELD_OUT_4_PAIRS: tuple[tuple[str, str], ...] = ()


def law_by_name(name: str) -> HiddenLaw:
    """The single or held-out law named ``name``."""
    for law in (*SINGLES, *HELD_OUT, *HELD_OUT_2, *RUNOUT, *HELD_OUT_3, *STEER,
                *HELD_OUT_4):
        if law.name == name:
            return law
    raise KeyError(name)


__all__ = ["HELD_OUT", "HELD_OUT_2", "HELD_OUT_2_PAIRS", "HELD_OUT_3", "HELD_OUT_3_PAIRS",
           "HELD_OUT_4", "HELD_OUT_4_PAIRS", "HELD_OUT_PAIRS", "PAIRS", "RUNOUT",
           "RUNOUT_PAIRS", "SINGLES", "STEER", "STEER_PAIRS", "HiddenLaw", "hidden_effect",
           "law_by_name"]
