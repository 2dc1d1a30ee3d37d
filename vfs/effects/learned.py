"""Channel laws: a model channel set by a formula of a case feature.

A *channel* is a quantity of the model that an effect can move
(:data:`CHANNELS`): the restitution, the contact friction, the POI shift
along / across the contact plane, the turn of the contact plane, the
penetration time, the EES stiffness ratio, a factor on the yaw inertias,
the speed the tyres take from each vehicle during the contact phase, the
run-out brake factors (per vehicle, both vehicles, the impact-corner wheel) and
the run-out front-wheel steer angle (per vehicle or both, signed towards the
impact side: :func:`impact_sides`) (:data:`CHANNEL_OUTPUTS`: the outcomes each
moves).  A *law* sets a channel per
case from a *feature* of the case at impact (:data:`LAW_FEATURES`) by a
closed form (:data:`FORMS`) or a tabulated curve (linear interpolation,
held constant outside the table).

:func:`law_effect_class` makes an :class:`vfs.effects.Effect` subclass of a
law (a JSON-ready mapping, as ``vfs learn`` writes it); its parameters are
the closed form's coefficients (so ``vfs calibrate`` can refit them) or,
for a table, a ``strength`` (0 = off, 1 = the table).  ``vfs identify``
uses constant laws (one value for all cases) to scan a channel.

Units: SI (m, s, rad, m/s); features as in :data:`LAW_FEATURES`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vfs.effects.base import Effect, EffectParameter, VelocityChange
from vfs.effects.context import ContactContext, ImpactContext
from vfs.effects.library import braking_impulse
from vfs.errors import ParameterError
from vfs.physics.impact import ImpactConfig, ImpactResult, contact_frame, energy_split
from vfs.physics.post_impact import PostImpactInputs
from vfs.physics.precrash import PrecrashParams
from vfs.physics.runout import wheel_positions
from vfs.physics.vehicle import VehicleArrays


@dataclass(frozen=True)
class Channel:
    """A model quantity a law can set.

    Attributes
    ----------
    name : str
    unit : str
    lo, hi : float
        Range scanned by the identification and allowed for a law's value.
    mode : {"set", "shift"}
        "set": the law gives the value; "shift": the law gives an offset
        added to the model's value (0 = no change).
    stage : str
        The effect hook that applies it.
    description : str
    log_grid : bool
        Scan on a geometric grid (ratios).
    physical : (bool, bool)
        Whether ``lo`` / ``hi`` are limits of the physics (a brake factor between free
        rolling, 0, and locked wheels, 1; a restitution, a friction coefficient, a
        penetration time, a speed lost to the tyres of at least 0), not only of the scan:
        a case whose objective is lowest at such a bound is identified there (its
        interval one-sided), not beyond it.
    """

    name: str
    unit: str
    lo: float
    hi: float
    mode: str
    stage: str
    description: str
    log_grid: bool = False
    physical: tuple[bool, bool] = (False, False)


#: Largest steer angle of a run-out steer law [rad] (about 34 deg: the steering lock of a
#: passenger car's front wheels; :data:`vfs.physics.post_impact.MAX_STEER` allows more).
MAX_LAW_STEER = 0.6

#: The channels, by name.
CHANNELS: Mapping[str, Channel] = {c.name: c for c in (
    Channel("restitution", "-", 0.0, 0.8, "set", "impact_parameters",
            "coefficient of restitution", physical=(True, False)),
    Channel("contact_friction", "-", 0.0, 1.2, "set", "impact_parameters",
            "friction coefficient of the contact plane", physical=(True, False)),
    Channel("poi_along", "m", -1.5, 1.5, "shift", "impact_configuration",
            "POI shift along the contact plane (tangent)"),
    Channel("poi_across", "m", -0.5, 0.5, "shift", "impact_configuration",
            "POI shift across the contact plane (normal)"),
    Channel("cp_angle", "rad", -0.5, 0.5, "shift", "impact_configuration",
            "turn of the contact plane"),
    Channel("penetration_time", "s", 0.0, 0.2, "set", "penetration",
            "time from first contact to the impact configuration", physical=(True, False)),
    Channel("ees_stiffness_ratio", "-", 0.2, 5.0, "set", "energy_split",
            "stiffness ratio k1 / k2 of the energy split E1 / E2 = k2 / k1", log_grid=True),
    Channel("yaw_inertia_factor", "-", 0.4, 2.5, "set", "impact_configuration",
            "factor on both yaw inertias (impact and run-out); model 1", log_grid=True),
    Channel("tyre_impulse", "m/s", 0.0, 3.0, "shift", "contact_impulse",
            "speed each vehicle loses along its pre-impact motion to its tyres during "
            "the contact phase (b mu g T of :class:`vfs.effects.library.TyreImpulse`)",
            physical=(True, False)),
    Channel("runout_brake1", "-", 0.0, 1.0, "set", "post_impact",
            "brake factor of all four wheels of vehicle 1 in the run-out (1 = locked)",
            physical=(True, True)),
    Channel("runout_brake2", "-", 0.0, 1.0, "set", "post_impact",
            "brake factor of all four wheels of vehicle 2 in the run-out (1 = locked)",
            physical=(True, True)),
    Channel("runout_brake", "-", 0.0, 1.0, "set", "post_impact",
            "brake factor of all four wheels of both vehicles in the run-out, one law "
            "for both (1 = locked)", physical=(True, True)),
    Channel("corner_brake", "-", 0.0, 1.0, "set", "post_impact",
            "brake factor of the wheel at the impact corner (the wheel nearest the point "
            "of impact) of each vehicle in the run-out, the other wheels at the model's "
            "factor (1 = locked by damage)", physical=(True, True)),
    Channel("runout_steer1", "rad", -MAX_LAW_STEER, MAX_LAW_STEER, "set", "post_impact",
            "front-wheel steer angle of vehicle 1 in the run-out, positive towards the side "
            "of the vehicle the point of impact lies on (:func:`impact_sides`)"),
    Channel("runout_steer2", "rad", -MAX_LAW_STEER, MAX_LAW_STEER, "set", "post_impact",
            "front-wheel steer angle of vehicle 2 in the run-out, positive towards the side "
            "of the vehicle the point of impact lies on (:func:`impact_sides`)"),
    Channel("runout_steer", "rad", -MAX_LAW_STEER, MAX_LAW_STEER, "set", "post_impact",
            "front-wheel steer angle of both vehicles in the run-out, one law for both, "
            "each vehicle's positive towards the side the point of impact lies on"),
)}

#: The run-out channels (they act after separation only: :data:`CHANNEL_OUTPUTS`).
RUNOUT_CHANNELS: tuple[str, ...] = ("runout_brake1", "runout_brake2", "runout_brake",
                                    "corner_brake", "runout_steer1", "runout_steer2",
                                    "runout_steer")
#: The run-out steer channels (signed towards the impact side, :func:`impact_sides`).
STEER_CHANNELS: tuple[str, ...] = ("runout_steer1", "runout_steer2", "runout_steer")

#: Outcome columns each channel moves (the others stay as the default model has them).
CHANNEL_OUTPUTS: Mapping[str, tuple[str, ...]] = {
    **{name: ("delta_v", "ees", "energy_loss", "post_speed", "velocity_angle_change", "pdof",
              "rest_position", "rest_yaw", "runout_distance", "impact_type")
       for name in ("restitution", "contact_friction", "poi_along", "poi_across", "cp_angle",
                    "penetration_time", "yaw_inertia_factor")},
    "ees_stiffness_ratio": ("ees",),
    "tyre_impulse": ("delta_v", "post_speed", "velocity_angle_change", "rest_position",
                     "rest_yaw", "runout_distance"),
    **{name: ("rest_position", "rest_yaw", "runout_distance") for name in RUNOUT_CHANNELS},
}


def _pair_feature(ctx: ContactContext | ImpactContext, name: str) -> np.ndarray:
    s = ctx.state
    if name == "closing_speed":
        return np.asarray(ctx.relative_speed, float)
    if name == "overlap":
        return np.asarray(ctx.swept_overlap, float)
    if name == "mass_ratio":
        return np.asarray(ctx.vehicle1.mass / ctx.vehicle2.mass, float)
    if name == "impact_angle":
        return np.abs((s.yaw[:, 1] - s.yaw[:, 0] + np.pi) % (2 * np.pi) - np.pi)
    if name == "impact_speed1":
        return np.hypot(s.vx[:, 0], s.vy[:, 0])
    if name == "impact_speed2":
        return np.hypot(s.vx[:, 1], s.vy[:, 1])
    if name == "road_friction":
        return np.asarray(ctx.road_friction, float)
    raise ParameterError(f"unknown law feature {name!r}; known: {sorted(LAW_FEATURES)}")


def normal_closing_speed(config: ImpactConfig) -> np.ndarray:
    """Closing speed of the POIs normal to the contact plane [m/s] (>= 0)."""
    return np.maximum(-contact_frame(config).u_n, 0.0)


#: Features a law can use (name -> unit); all are evaluated at the impact.
LAW_FEATURES: Mapping[str, str] = {
    "closing_speed": "m/s", "normal_closing_speed": "m/s", "overlap": "-",
    "mass_ratio": "-", "impact_angle": "rad", "impact_speed1": "m/s",
    "impact_speed2": "m/s", "road_friction": "-",
}


def feature_values(ctx: ContactContext | ImpactContext, config: ImpactConfig | None,
                   name: str) -> np.ndarray:
    """Feature ``name`` of the cases of a hook's context (units of :data:`LAW_FEATURES`).

    ``normal_closing_speed`` needs the impact configuration; at first
    contact (no configuration) it falls back to the closing speed.
    """
    if name == "normal_closing_speed":
        if config is None:
            return _pair_feature(ctx, "closing_speed")
        return normal_closing_speed(config)
    return _pair_feature(ctx, name)


#: Each closed form written once: (coefficient names, numpy expression of ``x`` and the
#: coefficients, text for reports).  The functions of :data:`FORMS` are compiled from the
#: expressions, and the exported code of a law (:mod:`vfs.analysis.learn`) is written with
#: them, so both compute the same numbers.
FORM_EXPRESSIONS: Mapping[str, tuple[tuple[str, ...], str, str]] = {
    "constant": (("a",), "np.full_like(np.asarray(x, float), a)", "a"),
    "linear": (("a", "b"), "a + b * x", "a + b x"),
    "power": (("a", "b"), "a * np.maximum(x, 1e-9) ** b", "a x^b"),
    "exponential": (("a", "b"), "a * np.exp(b * x)", "a exp(b x)"),
    "saturating": (("a", "b", "c"), "a + b * (1.0 - np.exp(-np.maximum(x, 0.0) / max(c, 1e-9)))",
                   "a + b (1 - exp(-x / c))"),
    "step": (("a", "b", "c"), "np.where(x >= c, a + b, a)", "a + b [x >= c]"),
}


def _compiled(names: tuple[str, ...], expression: str) -> Callable[..., np.ndarray]:
    """``lambda x, <names>: <expression>`` (numpy as ``np``)."""
    code = f"lambda x, {', '.join(names)}: {expression}"
    fn: Callable[..., np.ndarray] = eval(code, {"np": np, "max": max})  # noqa: S307
    return fn


#: Closed forms: name -> (function of x and coefficients, coefficient names, text).
FORMS: Mapping[str, tuple[Callable[..., np.ndarray], tuple[str, ...], str]] = {
    form: (_compiled(names, expression), names, text)
    for form, (names, expression, text) in FORM_EXPRESSIONS.items()
}


def evaluate_law(law: Mapping[str, Any], x: np.ndarray,
                 coefficients: Sequence[float] | None = None) -> np.ndarray:
    """Value of a law at feature values ``x`` (the channel's unit).

    Parameters
    ----------
    law : mapping
        ``form`` (a :data:`FORMS` name or "table"), ``coefficients`` (closed
        form) or ``table`` ({"x": [...], "y": [...]}, increasing x).
    x : ndarray
        Feature values (unit of the law's feature).
    coefficients : sequence of float, optional
        Override of the closed form's coefficients.
    """
    x = np.asarray(x, float)
    form = law.get("form", "")
    if form == "table":
        t = law["table"]
        return np.interp(x, np.asarray(t["x"], float), np.asarray(t["y"], float))
    if form not in FORMS:
        raise ParameterError(f"law form {form!r}; use one of {sorted(FORMS)} or 'table'")
    fn, names, _ = FORMS[form]
    coef = list(law["coefficients"]) if coefficients is None else list(coefficients)
    if len(coef) != len(names):
        raise ParameterError(f"law form {form} needs {len(names)} coefficients {names}, "
                             f"got {len(coef)}")
    with np.errstate(over="ignore", invalid="ignore"):
        return np.asarray(fn(x, *coef), float)


def check_law(law: Mapping[str, Any]) -> dict[str, Any]:
    """Validate a law mapping (channel, feature, form); return a plain dict copy."""
    for key in ("name", "channel", "feature", "form"):
        if key not in law:
            raise ParameterError(f"law: missing key {key!r}")
    if law["channel"] not in CHANNELS:
        raise ParameterError(f"law: unknown channel {law['channel']!r}; "
                             f"known: {sorted(CHANNELS)}")
    if law["feature"] not in LAW_FEATURES:
        raise ParameterError(f"law: unknown feature {law['feature']!r}; "
                             f"known: {sorted(LAW_FEATURES)}")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", str(law["name"])):
        raise ParameterError(f"law: name {law['name']!r} must be letters, digits, _")
    evaluate_law(law, np.zeros(1))
    return dict(law)


class ChannelLaw(Effect):
    """Base class of the law effects (:func:`law_effect_class`).

    Subclasses set :attr:`law`; the parameters are the closed form's
    coefficients, or ``strength`` for a table.
    """

    law: Mapping[str, Any] = {}
    outputs = ("delta_v", "ees", "energy_loss", "post_speed", "velocity_angle_change", "pdof",
               "rest_position", "rest_yaw", "impact_type")

    def value(self, ctx: ContactContext | ImpactContext, config: ImpactConfig | None,
              base: np.ndarray) -> np.ndarray:
        """The channel's value per case (the model's ``base`` where the law gives NaN)."""
        ch = CHANNELS[self.law["channel"]]
        x = feature_values(ctx, config, self.law["feature"])
        if self.law["form"] == "table":
            v = evaluate_law(self.law, x)
            neutral = base if ch.mode == "set" else 0.0
            v = neutral + self["strength"] * (v - neutral)
        else:
            coef = [self[n] for n in FORMS[self.law["form"]][1]]
            v = evaluate_law(self.law, x, coef)
        v = np.clip(v, ch.lo, ch.hi)
        if ch.mode == "shift":
            v = base + v
        return np.where(np.isfinite(v), v, base)

    def penetration(self, ctx: ContactContext, penetration_time: np.ndarray) -> np.ndarray:
        """Penetration time from the law [s]."""
        if self.law["channel"] != "penetration_time":
            return penetration_time
        t = np.asarray(penetration_time, float)  # NaN: the model's default
        return self.value(ctx, None, np.where(np.isnan(t), PrecrashParams.penetration_time, t))

    def impact_configuration(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """POI shifts and contact-plane turn from the law."""
        ch = self.law["channel"]
        if ch in ("poi_along", "poi_across"):
            f = contact_frame(config)
            d = self.value(ctx, config, np.zeros(ctx.size))
            ex, ey = (f.tx, f.ty) if ch == "poi_along" else (f.nx, f.ny)
            return config._replace(poi_x=config.poi_x + d * ex, poi_y=config.poi_y + d * ey)
        if ch == "cp_angle":
            return config._replace(cp_angle=self.value(ctx, config, config.cp_angle))
        if ch == "yaw_inertia_factor":
            factor = self.value(ctx, config, np.ones(ctx.size))
            return config._replace(izz=config.izz * factor[:, None])
        return config

    def impact_parameters(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """Restitution or contact friction from the law."""
        ch = self.law["channel"]
        if ch == "restitution":
            return config._replace(restitution=self.value(ctx, config, config.restitution))
        if ch == "contact_friction":
            return config._replace(contact_friction=self.value(ctx, config,
                                                               config.contact_friction))
        return config

    def energy_split(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                     e1: np.ndarray, e2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Split E1 + E2 by the stiffness ratio k1 / k2 of the law."""
        if self.law["channel"] != "ees_stiffness_ratio":
            return e1, e2
        m1, m2 = config.m[:, 0], config.m[:, 1]
        ratio = self.value(ctx, config, m1 / m2)
        return energy_split(e1 + e2, m1, m2, stiffness_ratio=ratio)


    def contact_impulse(self, ctx: ImpactContext, config: ImpactConfig,
                        result: ImpactResult) -> VelocityChange:
        """Speed loss [m/s] of each vehicle along its pre-impact motion from the law."""
        if self.law["channel"] != "tyre_impulse":
            return VelocityChange.zeros(config.size)
        return braking_impulse(config, result, self.value(ctx, config, np.zeros(ctx.size)))

    def post_impact(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                    inputs: PostImpactInputs) -> PostImpactInputs:
        """Run-out inputs from the law: the brake factors [-] of all wheels of one vehicle
        (``runout_brake1/2``), of all wheels of both (``runout_brake``: the law's value,
        one per case, for each vehicle), or of the impact-corner wheel of each vehicle
        (``corner_brake``, :func:`impact_corner_wheels`); or the front-wheel steer angle
        [rad] of one vehicle or both (``runout_steer1/2``, ``runout_steer``), signed
        towards the side of each vehicle the point of impact lies on
        (:func:`impact_sides`), so that a mirrored scene steers mirrored.
        """
        ch = self.law["channel"]
        if ch not in RUNOUT_CHANNELS:
            return inputs
        if ch in STEER_CHANNELS:
            return self._steer(ctx, config, inputs, ch)
        brake1, brake2 = inputs.brake[:, 0], inputs.brake[:, 1]
        if ch == "runout_brake":
            b = self.value(ctx, config, 0.5 * (brake1.mean(axis=1) + brake2.mean(axis=1)))
            new = np.repeat(b[:, None], 4, axis=1)
            return inputs.with_brakes(new, new)
        if ch == "corner_brake":
            rows = np.arange(config.size)
            out = []
            for w, brake in zip(impact_corner_wheels(ctx, config), (brake1, brake2),
                                strict=True):
                b = np.array(brake, float, copy=True)
                b[rows, w] = self.value(ctx, config, b[rows, w])
                out.append(b)
            return inputs.with_brakes(out[0], out[1])
        old = brake1 if ch == "runout_brake1" else brake2
        b = self.value(ctx, config, old.mean(axis=1))
        new = np.repeat(b[:, None], 4, axis=1)
        return (inputs.with_brakes(new, brake2) if ch == "runout_brake1"
                else inputs.with_brakes(brake1, new))

    def _steer(self, ctx: ImpactContext, config: ImpactConfig, inputs: PostImpactInputs,
               ch: str) -> PostImpactInputs:
        """The steer angles [rad] of a steer law: the law's value (towards the impact
        side) times each vehicle's side (+1 left, -1 right); a vehicle whose point of impact
        lies on its centre line (side 0) keeps its angle.
        """
        side = impact_sides(config)
        toward = inputs.steer() * side  # the present angles, towards the impact side
        vehicles = (1, 2) if ch == "runout_steer" else (int(ch[-1]),)
        base = toward[:, [i - 1 for i in vehicles]].mean(axis=1)
        v = self.value(ctx, config, base)
        for i in vehicles:
            s = side[:, i - 1]
            inputs = inputs.with_steer(i, np.where(s != 0.0, v * s + 0.0,
                                                   inputs.steer_angle[:, i - 1]))
        return inputs


def impact_sides(config: ImpactConfig) -> np.ndarray:
    """Side of each vehicle the point of impact lies on, (n, 2): +1 left, -1 right, 0 on the
    centre line (the sign of the POI's lateral coordinate in the vehicle's frame, x forward,
    y left).  Mirroring the scene flips it, so that a law of the steer angle towards the
    impact side (the run-out steer channels) gives the mirrored angle.
    """
    return np.sign(poi_in_vehicle_frames(config)[..., 1])


def poi_in_vehicle_frames(config: ImpactConfig) -> np.ndarray:
    """The point of impact in each vehicle's frame (x forward, y left, origin at the CG)
    [m], (n, 2 vehicles, 2).
    """
    dx = config.poi_x[:, None] - config.x
    dy = config.poi_y[:, None] - config.y
    c, s = np.cos(config.yaw), np.sin(config.yaw)
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


def impact_corner_wheels(ctx: ImpactContext, config: ImpactConfig
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Index (0-3: FL, FR, RL, RR) of the wheel nearest the point of impact of vehicle 1
    and of vehicle 2 per case (:func:`corner_wheels` of the context's vehicles).
    """
    return corner_wheels(ctx.vehicle1, ctx.vehicle2, config)


def corner_wheels(vehicle1: VehicleArrays, vehicle2: VehicleArrays, config: ImpactConfig
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Index (0-3: FL, FR, RL, RR) of the wheel nearest the point of impact of vehicle 1
    and of vehicle 2 per case: the POI taken into each vehicle's frame (x forward, y
    left, origin at the CG) against the wheel contact points of
    :func:`vfs.physics.runout.wheel_positions`.
    """
    out = []
    poi = poi_in_vehicle_frames(config)
    for j, veh in enumerate((vehicle1, vehicle2)):
        local = poi[:, j]  # (n, 2)
        wheels = wheel_positions(veh)  # (n, 4, 2)
        out.append(np.argmin(np.sum((wheels - local[:, None, :]) ** 2, axis=-1), axis=1))
    return out[0], out[1]


#: Hooks of each channel (the others are dropped from the class so that the simulation
#: takes the same paths as without the law).
_HOOKS = {"penetration": "penetration", "impact_configuration": "impact_configuration",
          "impact_parameters": "impact_parameters", "contact_impulse": "contact_impulse",
          "energy_split": "energy_split", "post_impact": "post_impact"}


def law_effect_class(law: Mapping[str, Any], bounds: Mapping[str, tuple[float, float]]
                     | None = None) -> type[Effect]:
    """An :class:`Effect` subclass that applies ``law`` (not registered).

    Parameters
    ----------
    law : mapping
        ``name`` (the effect's name), ``channel`` (:data:`CHANNELS`),
        ``feature`` (:data:`LAW_FEATURES`), ``form`` and ``coefficients`` or
        ``table`` (:func:`evaluate_law`); optional ``summary``.
    bounds : mapping, optional
        Bounds of the coefficients (default: +-10 times their magnitude, at
        least +-1; the channel's range for a constant).

    Returns
    -------
    type
        Subclass of :class:`ChannelLaw` named ``law["name"]``.
    """
    law = check_law(law)
    ch = CHANNELS[law["channel"]]
    params: list[EffectParameter] = []
    if law["form"] == "table":
        params.append(EffectParameter("strength", 1.0, 0.0, 2.0, "-",
                                      "share of the tabulated law (0 = off)", 0.0))
    else:
        names = FORMS[law["form"]][1]
        for n, v in zip(names, law["coefficients"], strict=True):
            v = float(v)
            if bounds and n in bounds:
                lo, hi = bounds[n]
            elif law["form"] == "constant":
                lo, hi = ch.lo, ch.hi
            else:
                m = max(10.0 * abs(v), 1.0)
                lo, hi = -m, m
            lo, hi = min(lo, v), max(hi, v)
            params.append(EffectParameter(n, v, lo, hi, "", f"coefficient {n} of "
                                          f"{FORMS[law['form']][2]}"))
    stage = ch.stage
    ns: dict[str, Any] = {
        "name": law["name"], "law": law, "parameters": tuple(params),
        "outputs": CHANNEL_OUTPUTS[law["channel"]],
        "summary": law.get("summary", f"{law['channel']} = f({law['feature']})"),
        "__doc__": f"Learned law: {law['channel']} as a function of {law['feature']}.",
    }
    for hook in _HOOKS.values():
        if hook != stage:
            ns[hook] = getattr(Effect, hook)
    return type(f"Law_{law['name']}", (ChannelLaw,), ns)


def law_text(law: Mapping[str, Any]) -> str:
    """Readable formula of a law, e.g. ``restitution = 0.3 + -0.2 [x >= 12]; x = closing_speed``."""
    if law["form"] == "table":
        return f"{law['channel']} = table({law['feature']}, {len(law['table']['x'])} knots)"
    text = FORMS[law["form"]][2]
    for n, v in zip(FORMS[law["form"]][1], law["coefficients"], strict=True):
        text = re.sub(rf"\b{n}\b", f"{float(v):.4g}", text)
    unit = LAW_FEATURES.get(law["feature"], "")
    return f"{law['channel']} = {text}; x = {law['feature']} [{unit}]"


def finite(x: float) -> bool:
    """True for a finite float."""
    return math.isfinite(x)


__all__ = ["CHANNELS", "CHANNEL_OUTPUTS", "FORMS", "LAW_FEATURES", "MAX_LAW_STEER",
           "RUNOUT_CHANNELS", "STEER_CHANNELS", "Channel", "ChannelLaw", "check_law",
           "corner_wheels", "evaluate_law", "feature_values", "impact_corner_wheels",
           "impact_sides", "law_effect_class", "law_text", "normal_closing_speed",
           "poi_in_vehicle_frames"]
