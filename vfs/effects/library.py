"""The built-in physical effects the default model leaves out.

Each is a candidate for the diagnosis (``vfs diagnose``) and a hidden effect
of the synthetic database generator (``vfs generate --hidden NAME=VALUE``).
The parameter defaults are the *nominal strengths* used when an effect is
hidden without a value; the *neutral* values switch the physics off.
docs/effects.md lists them with equations and sources.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vfs.effects.base import Effect, EffectParameter, VelocityChange, register_effect
from vfs.effects.context import ContactContext, ImpactContext
from vfs.physics.geometry import FACE_FRONT, FACE_LEFT, FACE_REAR, FACE_RIGHT, to_vehicle_frame
from vfs.physics.impact import (
    ImpactConfig,
    ImpactResult,
    contact_frame,
    energy_split,
    poi_relative_velocity,
)
from vfs.physics.post_impact import PostImpactInputs
from vfs.physics.vehicle import VehicleArrays
from vfs.units import G, wrap_axial

#: Closing speed [m/s] below which the restitution law is held constant.
_MIN_CLOSING_SPEED = 2.0


@register_effect
class RestitutionSpeed(Effect):
    """Restitution falling with closing speed.

    eps = min(eps_0 (v_ref / max(v_c, 2 m/s))^k, eps_max), with eps_0 the case's
    restitution (the value the model uses), v_c the closing speed normal to
    the contact plane.  The Reconstruction chapter ("the higher the deformations, the lower
    the coefficient of restitution; only for very small deformations are
    values higher than 0.3 possible"), the Collision Calculation Uncertainty paper
    ("nonlinearly and inversely proportional to the relative velocity") and the
    Modeling Head-On Collisions paper (identified 0 -> 0.24); docs/references.md.
    The cap eps_max is 0.3 by default, the top of the range the reconstruction
    chapter gives for real deformations (0.1-0.3); raise it for contacts with
    very small deformations (bumper taps), where that chapter allows more.
    """

    name = "restitution_speed"
    summary = "restitution falls with closing speed"
    parameters = (
        EffectParameter("exponent", 0.8, 0.0, 3.0, "-", "exponent k of (v_ref / v_c)", 0.0),
        EffectParameter("reference_speed", 15.0, 3.0, 40.0, "m/s",
                        "closing speed v_ref at which eps equals the case's value"),
        EffectParameter("cap", 0.3, 0.1, 1.0, "-",
                        "largest restitution eps_max (0.1-0.3 for real deformations)"),
    )
    outputs = ("delta_v", "ees", "energy_loss", "post_speed", "rest_position")

    def impact_parameters(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """Scale eps by (v_ref / v_c)^k."""
        v_c = np.maximum(-contact_frame(config).u_n, _MIN_CLOSING_SPEED)
        factor = (self["reference_speed"] / v_c) ** self["exponent"]
        eps = np.minimum(config.restitution * factor, self["cap"])
        return config._replace(restitution=eps)


@register_effect
class TyreImpulse(Effect):
    """Tyre forces during a finite contact phase.

    The impulse model treats the contact as instantaneous; a real contact
    lasts about 0.08-0.15 s, during which braked tyres keep pulling against
    the motion.  Each vehicle receives the extra impulse
    -b mu_road m g T u/|u| (u: its velocity before the impact), never more
    than would stop it.  The Front-to-Side Energy Balance paper (Table 2): tyre-road work
    during the contact is 5-9 % of the initial kinetic energy.
    """

    name = "tyre_impulse"
    summary = "braked tyres act during the finite contact phase"
    parameters = (
        EffectParameter("duration", 0.10, 0.0, 0.4, "s", "contact duration T", 0.0),
        EffectParameter("brake_factor", 0.8, 0.0, 1.0, "-",
                        "share b of the friction limit the tyres use"),
    )
    outputs = ("delta_v", "post_speed", "velocity_angle_change", "rest_position")

    def contact_impulse(self, ctx: ImpactContext, config: ImpactConfig,
                        result: ImpactResult) -> VelocityChange:
        """Velocity change -b mu g T along each vehicle's pre-impact motion."""
        dv = self["brake_factor"] * ctx.road_friction * G * self["duration"]
        return braking_impulse(config, result, dv)


def braking_impulse(config: ImpactConfig, result: ImpactResult,
                    speed_loss: np.ndarray) -> VelocityChange:
    """Velocity change of tyres braking during the contact phase.

    Each vehicle loses ``speed_loss`` [m/s] (n,) along its pre-impact motion
    u / |u|, never more than its post-impact velocity component along u (the
    tyres stop, they do not reverse the motion); no yaw change.
    """
    vx, vy = config.vx, config.vy
    speed = np.hypot(vx, vy)
    with np.errstate(invalid="ignore", divide="ignore"):
        ux, uy = np.where(speed > 0, vx / speed, 0.0), np.where(speed > 0, vy / speed, 0.0)
    # no more than the post-impact velocity component along u
    along = np.maximum(result.vx_post * ux + result.vy_post * uy, 0.0)
    mag = np.minimum(np.asarray(speed_loss, float)[..., None], along)
    return VelocityChange(-mag * ux, -mag * uy, np.zeros_like(mag))


@register_effect
class BodyFriction(Effect):
    """Friction work between the bodies.

    Part of the energy the impulse exchange dissipates is friction between the sliding
    bodies, not deformation; the EES (which measures deformation energy) is smaller than the
    model's, which attributes the whole loss to deformation.  Friction work
    W = |S_t| |u_t + u_t'| / 2 (tangential impulse times the mean tangential sliding speed at
    the POI); a share f of it is taken from the deformation energies in proportion to their
    split.  The Front-to-Side Energy Balance paper (Table 2): friction between the bodies
    is 2-5 % of the initial energy and deformation work only 70-75 % of the contact-phase
    loss.
    """

    name = "body_friction"
    summary = "part of the impact loss is friction between the bodies, not deformation"
    parameters = (
        EffectParameter("share", 0.6, 0.0, 1.0, "-",
                        "share f of the tangential work that is friction", 0.0),
    )
    outputs = ("ees",)

    def energy_split(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                     e1: np.ndarray, e2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Remove f W from the deformation energies."""
        f = contact_frame(config)
        ux, uy = poi_relative_velocity(config, result.vx_post[:, 0], result.vy_post[:, 0],
                                       result.yaw_rate_post[:, 0], result.vx_post[:, 1],
                                       result.vy_post[:, 1], result.yaw_rate_post[:, 1])
        u_t_post = ux * f.tx + uy * f.ty
        work = np.abs(result.impulse_t) * np.abs(f.u_t + u_t_post) / 2.0
        total = e1 + e2
        removed = np.minimum(self["share"] * work, total)
        with np.errstate(invalid="ignore", divide="ignore"):
            keep = np.where(total > 0, (total - removed) / total, 1.0)
        return e1 * keep, e2 * keep


@register_effect
class PenetrationDepth(Effect):
    """Penetration depth growing with closing speed and falling overlap.

    Instead of a fixed time (30 ms, the Momentum Based Impact Model paper) the outlines
    penetrate to a depth d = d_0 (v_c / 20 m/s)^a (1 + c (1 - overlap)), i.e. for the time
    d / v_c, clipped to [5, 150] ms; v_c = |v1 - v2| at first contact,
    overlap = :func:`vfs.physics.geometry.swept_overlap` at first contact.  The Momentum
    Based Impact Model paper (outlook): "it would be necessary to find a correlation between
    the closing speed, the overlap and the penetration depth".  With d_0 = 0.6 m, a = 1,
    c = 0 it is the fixed 30 ms.
    """

    name = "penetration_depth"
    summary = "penetration depth grows with closing speed and small overlap"
    parameters = (
        EffectParameter("overlap_factor", 0.8, 0.0, 3.0, "-",
                        "growth c of the depth as the overlap falls", 0.0),
        EffectParameter("speed_exponent", 1.3, 0.3, 3.0, "-",
                        "exponent a of the closing speed"),
        EffectParameter("depth", 0.6, 0.1, 2.0, "m", "depth d_0 at 20 m/s and full overlap"),
    )
    outputs = ("delta_v", "ees", "impact_type", "velocity_angle_change", "rest_position")

    def penetration(self, ctx: ContactContext, penetration_time: np.ndarray) -> np.ndarray:
        """Penetration time d / v_c [s]."""
        v_c = np.maximum(ctx.relative_speed, _MIN_CLOSING_SPEED)
        ov = np.nan_to_num(ctx.swept_overlap, nan=1.0)
        depth = self["depth"] * (v_c / 20.0) ** self["speed_exponent"] * (
            1.0 + self["overlap_factor"] * (1.0 - ov))
        return np.clip(depth / v_c, 0.005, 0.15)


def _axial_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean of two axial directions (defined modulo pi) [rad]."""
    return 0.5 * np.arctan2(np.sin(2 * a) + np.sin(2 * b), np.cos(2 * a) + np.cos(2 * b))


#: Lateral position of the longitudinal rails, as a share of the half width.
RAIL_POSITION = 0.6


def _structure_point(vehicles: VehicleArrays, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
                     face: np.ndarray, local: np.ndarray, centroid: np.ndarray) -> np.ndarray:
    """Load-carrying point of each vehicle's engaged face (global (n, 2)) [m].

    Front and rear faces: the longitudinal rails at +-0.6 half widths; side
    faces: the axles and the B pillar (at 45 % of the wheelbase behind the
    front axle).  The point is the mean of the members inside the overlap's
    extent along the face, else the extent's end nearest to a member; across
    the face it stays at the centroid.  ``local``: the overlap polygon in the
    vehicle's frame (n, W, 2) [m].
    """
    n = x.shape[0]
    c_loc = to_vehicle_frame(centroid, x, y, yaw)
    ends = (face == FACE_FRONT) | (face == FACE_REAR)
    # coordinate along the face: y for front/rear, x for the sides
    along = np.where(ends[:, None], local[..., 1], local[..., 0])
    lo, hi = along.min(axis=1), along.max(axis=1)
    rail = RAIL_POSITION * 0.5 * vehicles.width
    lf, wb = vehicles.cg_to_front_axle, vehicles.wheelbase
    members = np.where(ends[:, None], np.stack([-rail, rail, np.full(n, np.nan)], axis=1),
                       np.stack([lf, lf - 0.45 * wb, lf - wb], axis=1))
    inside = (members >= lo[:, None]) & (members <= hi[:, None])
    count = inside.sum(axis=1)
    mean_inside = np.where(inside, members, 0.0).sum(axis=1) / np.maximum(count, 1)
    clipped = np.clip(members, lo[:, None], hi[:, None])
    dist = np.where(np.isnan(members), np.inf, np.abs(clipped - members))
    nearest = np.take_along_axis(clipped, np.argmin(dist, axis=1)[:, None], axis=1)[:, 0]
    target = np.where(count > 0, mean_inside, nearest)
    px = np.where(ends, c_loc[:, 0], target)
    py = np.where(ends, target, c_loc[:, 1])
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([x + c * px - s * py, y + s * px + c * py], axis=1)


def _face_tangent(yaw: np.ndarray, face: np.ndarray) -> np.ndarray:
    """Direction of the engaged face [rad]: across the vehicle for front/rear, along it
    for the sides.
    """
    ends = (face == FACE_FRONT) | (face == FACE_REAR)
    return np.where(ends, yaw + 0.5 * np.pi, yaw)


@register_effect
class StructurePOI(Effect):
    """Point of impact and contact plane placed by the structures (the expert's rule).

    A reconstruction expert reads the POI and the contact plane from the
    damage: the force goes through the load-carrying members (longitudinal
    rails of a front or rear, axles and B pillar of a side) and the contact
    plane follows the deformed faces.  The POI moves from the overlap
    centroid towards the mean of the two vehicles' structure points by the
    share p; the contact plane turns from the line through the outline
    intersections towards the mean direction of the two engaged faces by
    the share s.
    The Momentum Based Impact Model paper: the geometric rules give more sliding impacts than the
    reconstructions and POIs 0.19 m away on average.
    """

    name = "structure_poi"
    summary = "POI and contact plane follow the load-carrying structures"
    parameters = (
        EffectParameter("strength", 0.3, 0.0, 1.0, "-",
                        "share s of the turn of the contact plane towards the faces", 0.0),
        EffectParameter("poi_share", 1.0, 0.0, 1.0, "-",
                        "share p of the move of the POI towards the structure point", 0.0),
    )
    outputs = ("impact_type", "delta_v", "ees", "velocity_angle_change", "pdof",
               "rest_position")

    def impact_configuration(self, ctx: ImpactContext, config: ImpactConfig) -> ImpactConfig:
        """Move the POI by the share p and turn the contact plane by the share s."""
        s, share = self["strength"], self["poi_share"]
        st = ctx.state
        ov = ctx.overlap
        ok = ov.polygon.nonempty & ~np.isnan(ov.centroid[:, 0])
        faces = ctx.faces
        local1, local2 = ctx.overlap_local
        cen = np.where(ok[:, None], ov.centroid, np.stack([config.poi_x, config.poi_y], axis=1))
        p1 = _structure_point(ctx.vehicle1, st.x[:, 0], st.y[:, 0], st.yaw[:, 0], faces[:, 0],
                              local1, cen)
        p2 = _structure_point(ctx.vehicle2, st.x[:, 1], st.y[:, 1], st.yaw[:, 1], faces[:, 1],
                              local2, cen)
        target = 0.5 * (p1 + p2)
        poi_x = np.where(ok, config.poi_x + share * (target[:, 0] - config.poi_x), config.poi_x)
        poi_y = np.where(ok, config.poi_y + share * (target[:, 1] - config.poi_y), config.poi_y)
        face_dir = _axial_mean(_face_tangent(st.yaw[:, 0], faces[:, 0]),
                               _face_tangent(st.yaw[:, 1], faces[:, 1]))
        cp = config.cp_angle + s * wrap_axial(face_dir - config.cp_angle)
        cp = np.where(ok, cp, config.cp_angle)
        return config._replace(poi_x=poi_x, poi_y=poi_y, cp_angle=cp)


@register_effect
class WheelLock(Effect):
    """Front wheels locked by frontal deformation.

    The Modeling Head-On Collisions paper: in a frontal crash test the front wheels of the car were
    blocked 35 ms into the impact by the deforming front, which made it
    pull back after the impact; its conclusions ask for "automatic
    identification of wheel blocking in the function of the body depth
    deformations".  A vehicle whose engaged face is its front and whose
    overlap reaches deeper than ``depth`` behind the front bumper runs out
    with both front wheels locked (brake factor 1).
    """

    name = "wheel_lock"
    summary = "deep frontal deformation locks the front wheels in the run-out"
    parameters = (
        EffectParameter("depth", 0.35, 0.05, 3.0, "m",
                        "deformation depth behind the bumper that locks the wheels", 3.0),
    )
    outputs = ("rest_position", "rest_yaw", "runout_distance")

    def post_impact(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                    inputs: PostImpactInputs) -> PostImpactInputs:
        """Set the front brake factors to 1 where the depth is exceeded."""
        poly = ctx.overlap.polygon
        out = []
        for j, veh in enumerate((ctx.vehicle1, ctx.vehicle2)):
            local = ctx.overlap_local[j]
            depth = veh.cg_to_front - local[..., 0].min(axis=1)
            lock = poly.nonempty & (ctx.faces[:, j] == FACE_FRONT) & (depth > self["depth"])
            b = np.array(inputs.brake[:, j], float, copy=True)
            b[lock, 0:2] = 1.0
            out.append(b)
        return inputs.with_brakes(out[0], out[1])


@register_effect
class EESStiffness(Effect):
    """Energy split by structural stiffness instead of mass.

    The model splits the deformation energy E1 / E2 = m2 / m1 (stiffness
    proportional to mass).  Here k_i = m_i^a * (side factor if the engaged
    face is a side), E1 / E2 = k2 / k1 (docs/references.md: with known
    stiffness E1 / E2 = k2 / k1; sides are softer than fronts).  Nominal
    a = 0.2, side factor 0.2: at 0.5 / 0.5 the change of the EES (0.85 of
    the recorded 8 % EES noise, standardised RMS) was too small to be found
    reliably in 300 noisy cases (``vfs diagnose`` cut the EES RMSE by only
    ~25 %); at 0.2 / 0.2 it is ~1.7 noise SDs (stiffness nearly independent
    of mass, sides a fifth as stiff as fronts).
    """

    name = "ees_stiffness"
    summary = "EES energy split by structural stiffness (sides softer), not mass"
    parameters = (
        EffectParameter("mass_exponent", 0.2, 0.0, 2.0, "-",
                        "exponent a of the mass in the stiffness", 1.0),
        EffectParameter("side_factor", 0.2, 0.1, 1.0, "-",
                        "stiffness of a side relative to a front or rear", 1.0),
    )
    outputs = ("ees",)

    def energy_split(self, ctx: ImpactContext, config: ImpactConfig, result: ImpactResult,
                     e1: np.ndarray, e2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Re-split the total E1 + E2 with E1 / E2 = k2 / k1."""
        side = (ctx.faces == FACE_LEFT) | (ctx.faces == FACE_RIGHT)
        f = np.where(side, self["side_factor"], 1.0)
        k = config.m ** self["mass_exponent"] * f
        return energy_split(e1 + e2, config.m[:, 0], config.m[:, 1],
                            stiffness_ratio=k[:, 0] / k[:, 1])


@register_effect
class YawInertia(Effect):
    """Yaw inertia different from the model's default formula.

    Where the data give no yaw inertia the model uses I = m L1 L2 (the Front-to-Side Energy
    Balance paper); the box formula m (l^2 + w^2) / 12 (openPASS) and 0.1269 m R L (Zeidler)
    differ from it by 10-30 %.  This effect scales the unknown inertias by a factor.  Its
    nominal value 0.86 is the one measured yaw inertia in the source papers: the NHTSA
    Mercedes C300 of "Modeling head-on collisions", 2771 kg m^2 against
    m L1 L2 = 3243 kg m^2 for its 1703 kg and 2.76 m wheelbase with the centre of gravity at
    mid-wheelbase (the paper gives no CG position; 10 % of the wheelbase forward of it gives
    3188 kg m^2): 13-15 % below the default formula.
    """

    name = "yaw_inertia"
    summary = "unknown yaw inertias differ from I = m L1 L2 by a factor"
    parameters = (
        EffectParameter("factor", 0.86, 0.3, 3.0, "-", "true / default yaw inertia", 1.0),
    )
    outputs = ("velocity_angle_change", "rest_yaw", "rest_position", "delta_v")

    def vehicles(self, batch: Any) -> Any:
        """Scale the yaw inertia of the vehicles whose inertia is unknown."""
        known = batch.inertia_known
        v1 = batch.vehicle1._replace(yaw_inertia=np.where(
            known[:, 0], batch.vehicle1.yaw_inertia, batch.vehicle1.yaw_inertia * self["factor"]))
        v2 = batch.vehicle2._replace(yaw_inertia=np.where(
            known[:, 1], batch.vehicle2.yaw_inertia, batch.vehicle2.yaw_inertia * self["factor"]))
        return batch._replace(vehicle1=v1, vehicle2=v2)


#: Names of the built-in effects, in documentation order.
BUILTIN_EFFECTS: tuple[str, ...] = (
    RestitutionSpeed.name, TyreImpulse.name, BodyFriction.name, PenetrationDepth.name,
    StructurePOI.name, WheelLock.name, EESStiffness.name, YawInertia.name,
)

__all__ = ["BUILTIN_EFFECTS", "braking_impulse", "BodyFriction", "EESStiffness", "PenetrationDepth",
           "RestitutionSpeed", "StructurePOI", "TyreImpulse", "WheelLock", "YawInertia"]
