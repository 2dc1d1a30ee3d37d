"""Scene designers, one per kind of the catalogue: impact poses, speeds, manoeuvres, lanes."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from vfs.scenarios.catalogue import ScenarioSpec
from vfs.scenarios.placement import (
    ImpactPair,
    OutlineDims,
    place_gap,
    place_overlap,
    place_target,
    unit_vector,
)
from vfs.scenarios.road import LANE_WIDTH, new_part, road_coords
from vfs.scenarios.speed_profile import (
    IDLE_DECEL,
    IDLE_JERK,
    NO_BRAKE,
    SpeedProfile,
    brake_time_for_drop,
    draw_speed_profile,
)
from vfs.units import G, wrap_angle

#: Share of the road friction usable for lateral acceleration of manoeuvres [-].
_LATERAL_FRICTION_SHARE = 0.8


def _capped(u: np.ndarray, bounds: tuple[float, float], cap: np.ndarray) -> np.ndarray:
    """Uniform draw (quantile u) from [lo, min(hi, cap)]; cap where cap < lo."""
    lo, hi = bounds
    top = np.minimum(hi, cap)
    return np.where(top >= lo, lo + u * (top - lo), np.maximum(top, 0.0))


def _ramp_cap(distance: np.ndarray, speed: np.ndarray, a_lat: np.ndarray) -> np.ndarray:
    """Largest ramp amplitude [rad] over ``distance`` [m] at ``speed`` [m/s] within a_lat.

    The raised cosine A (1 + cos(pi sigma / S)) / 2 has the largest curvature A pi / (2 S),
    so the lateral acceleration v^2 A pi / (2 S) stays below a_lat [m/s^2].
    """
    with np.errstate(divide="ignore"):
        return np.where(speed > 0.1, 2.0 * a_lat * distance / (np.pi * speed**2), np.inf)


class DesignContext(NamedTuple):
    """Inputs of a scene designer for n cases of one type."""

    rng: np.random.Generator
    spec: ScenarioSpec
    dims1: OutlineDims
    dims2: OutlineDims
    mu: np.ndarray  # road friction [-]
    near: np.ndarray  # near miss (bool)

    @property
    def n(self) -> int:
        """Number of designs."""
        return int(self.mu.shape[0])

    @property
    def a_lat(self) -> np.ndarray:
        """Lateral acceleration bound of manoeuvres [m/s^2]."""
        return np.minimum(self.spec.max_lateral_accel, _LATERAL_FRICTION_SHARE * self.mu * G)


class Design(NamedTuple):
    """Scene of n cases in the local frame (P1's road frame), before the scene transform."""

    p1: dict[str, np.ndarray]
    p2: dict[str, np.ndarray]
    road_curvature: np.ndarray  # [1/m]
    extra: dict[str, np.ndarray]  # design columns
    ok: np.ndarray  # plausible and placeable


def _lanes(ctx: DesignContext, centre: float) -> np.ndarray:
    return centre + ctx.rng.uniform(-ctx.spec.lane_offset, ctx.spec.lane_offset, ctx.n)


def _set_motion(part: dict[str, np.ndarray], motion: SpeedProfile) -> None:
    for name in SpeedProfile._fields:
        part[name] = getattr(motion, name)


def _evasion(ctx: DesignContext, motion: SpeedProfile, prob: float,
             angle_range: tuple[float, float], time_range: tuple[float, float],
             a_lat: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Evasive steering: flag, amplitude [rad] (>= 0), build-up time [s] and distance [m].

    The amplitude is capped so that the lateral acceleration stays below ``a_lat``
    [m/s^2] (default: the scenario's bound).
    """
    rng, n = ctx.rng, ctx.n
    flag = rng.random(n) < prob
    lead = rng.uniform(*time_range, n)
    q = rng.random(n)
    dist = np.maximum(motion.distance_before(lead), 1e-3)
    bound = ctx.a_lat if a_lat is None else a_lat
    angle = _capped(q, angle_range, _ramp_cap(dist, motion.speed_at(-lead), bound))
    flag &= motion.speed_at(0.0) > 0.5
    return flag, angle, lead, dist


def _common_extra(ctx: DesignContext, m1: SpeedProfile, m2: SpeedProfile) -> dict[str, np.ndarray]:
    return {"travel_speed1": m1.v_travel, "travel_speed2": m2.v_travel,
            "impact_speed1": m1.speed_at(0.0), "impact_speed2": m2.speed_at(0.0)}


def _design_head_on(ctx: DesignContext, overtaking: bool = False) -> Design:
    """Head-on: participant 1 drifts (or has overtaken) into the oncoming lane.

    Participant 2 drives in its lane (and may steer to its right); participant 1's
    lateral position at t* follows from the contact placement, its drift width (or
    lane-change width) from its own lane position.  In bends the road's lateral
    acceleration (at the faster participant's travel speed at most half the budget)
    leaves the rest of ``max_lateral_accel`` to the manoeuvres.
    """
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = draw_speed_profile(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = draw_speed_profile(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    v1s, v2s = m1.speed_at(0.0), m2.speed_at(0.0)
    a_lat = ctx.a_lat
    a_bend = np.minimum(rng.uniform(*spec.bend_lateral_accel, n), 0.5 * a_lat)
    radius = np.clip(np.maximum(m1.v_travel, m2.v_travel) ** 2 / a_bend, *spec.bend_radius)
    k = spec.bend / radius
    budget1 = np.maximum(a_lat - m1.v_travel**2 * np.abs(k), 0.3)
    budget2 = np.maximum(a_lat - m2.v_travel**2 * np.abs(k), 0.3)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time, budget2)
    ramp2 = np.where(ev2, -e2, 0.0)  # participant 2 steers to its right
    lane1, lane2 = _lanes(ctx, -0.5 * LANE_WIDTH), _lanes(ctx, 0.5 * LANE_WIDTH)
    share = rng.uniform(*spec.overlap, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    q_angle = rng.random(n)
    l2_target = lane2 - ramp2 * s2 * 0.5  # moving in -u: l* = lane - shift
    straight = k == 0.0
    kk = np.where(straight, 1.0, k)
    yaw2 = k * (ctx.dims1.front + ctx.dims2.front) + np.pi + ramp2  # road direction estimate

    def place(yaw1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Participant 2 relative to 1, participant 1's lateral position, placement flag."""
        pair = ImpactPair(yaw1, v1s, ctx.dims1, yaw2, v2s, ctx.dims2)
        r, placed = place_overlap(pair, +1.0, share, np.ones(n))
        r = np.where(ctx.near[:, None], place_gap(pair, gap, np.ones(n)), r)
        # lateral position of participant 1 such that participant 2 is in its lane: on
        # the circle of participant 2's lane (straight: l2 - r_y)
        b = 1.0 / kk - l2_target
        a = r[:, 1] + np.sign(kk) * np.sqrt(np.maximum(b**2 - r[:, 0] ** 2, 0.0))
        l1 = np.where(straight, l2_target - r[:, 1], 1.0 / kk - a)
        return r, l1, placed | ctx.near

    p1, p2 = new_part(n), new_part(n)
    extra = _common_extra(ctx, m1, m2)
    if overtaking:
        # steer-back of the overtaker over the last t_back seconds, angle -delta
        t_back = rng.uniform(*spec.evasive_time, n)
        t_gap = rng.uniform(*spec.lane_change_gap, n)
        t_change = rng.uniform(*spec.lane_change_time, n)
        s_back = np.maximum(m1.distance_before(t_back), 1e-3)
        delta = _capped(q_angle, spec.heading_angle,
                        _ramp_cap(s_back, m1.speed_at(-t_back), budget1))
        r, l1, ok = place(-delta)
        s_gap = m1.distance_before(t_back + t_gap)
        s_start = m1.distance_before(t_back + t_gap + t_change)
        shift = l1 - lane1 + delta * s_back * 0.5
        bump_dist = s_start - s_gap
        p1.update(ramp_angle=-delta, ramp_dist=s_back, bump_start=s_gap, bump_dist=bump_dist,
                  bump_angle=2.0 * shift / bump_dist)
        extra.update(steer_back_angle=delta, steer_back_time=t_back,
                     lane_change_time=t_change, lane_change_width=shift)
        ok &= (shift >= spec.lane_change_width[0]) & (shift <= spec.lane_change_width[1])
    else:
        # raised-cosine drift of width D: lateral acceleration v^2 delta^2 pi / (4 D);
        # the angle is capped with the drift width of a first placement, then placed again
        w1, w2 = ctx.dims1.width, ctx.dims2.width
        offset_est = np.where(ctx.near, 0.5 * (w1 + w2) + gap,
                              0.5 * (w1 + w2) - share * np.minimum(w1, w2))
        drift = np.maximum(l2_target - offset_est - lane1, 0.5)
        for _ in range(2):
            cap = np.sqrt(4.0 * budget1 * drift / (np.pi * m1.v_travel**2))
            delta = _capped(q_angle, spec.heading_angle, cap)
            r, l1, ok = place(delta)
            drift = np.maximum(l1 - lane1, 0.3)
        peak = m1.v_travel**2 * delta**2 * np.pi / (4.0 * drift)
        ok &= peak <= 1.2 * budget1
        p1.update(ramp_angle=delta, ramp_dist=2.0 * drift / delta)
        extra.update(drift_angle=delta, drift_width=drift, drift_length=2.0 * drift / delta)
        extra["bend_radius"] = np.where(straight, np.nan, radius)
    u2, l2 = road_coords(k, r[:, 0], l1 + r[:, 1])
    ramp2_actual = wrap_angle(yaw2 - (k * u2 + np.pi))  # bend: correction of the estimate
    p2.update(u_star=u2, l_star=l2, direction=np.full(n, -1.0), road_k=k,
              ramp_angle=ramp2_actual, ramp_dist=s2)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(u_star=np.zeros(n), l_star=l1, road_k=k)
    extra.update(evasive2=ev2, evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 overlap=np.where(ctx.near, -gap, share), side=np.ones(n), lane1=lane1,
                 lane2=lane2)
    return Design(p1, p2, k, extra, ok)


def _design_overtaking(ctx: DesignContext) -> Design:
    return _design_head_on(ctx, overtaking=True)


def _design_rear_end(ctx: DesignContext) -> Design:
    """Rear-end: participant 1 runs into participant 2 ahead in the same lane.

    Crashes: both start in the lane; their lateral offset (from the designed overlap and
    any late swerve) is split evenly between their lane positions.  Near misses: the
    follower swerves around the lead; its swerve (angle at t*, raised cosine) is as long as
    needed to reach the designed gap from its lane position.
    """
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = draw_speed_profile(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = draw_speed_profile(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu, 0.0)
    standing = rng.random(n) < spec.standing2_share
    m2 = SpeedProfile(np.where(standing, 0.0, m2.v_travel),
                 np.where(standing, NO_BRAKE, m2.brake_time),
                 np.where(standing, IDLE_JERK, m2.jerk), np.where(standing, IDLE_DECEL,
                                                                   m2.decel))
    v1s, v2s = m1.speed_at(0.0), m2.speed_at(0.0)
    closing = spec.min_closing_speed
    ok = (v1s - v2s >= closing) & (m1.v_travel - m2.v_travel >= closing)
    ev1, e1, t1, s1 = _evasion(ctx, m1, spec.evasive_prob[0], spec.evasive_angle,
                               spec.evasive_time)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time)
    left = np.where(rng.random(n) < spec.swerve_left_share, 1.0, -1.0)
    random_side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    side2 = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    share = rng.uniform(*spec.overlap, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    noise = rng.uniform(-spec.lane_offset, spec.lane_offset, (2, n))
    q_swerve = rng.random(n)
    w1, w2 = ctx.dims1.width, ctx.dims2.width
    # near miss: the follower always swerves, over the distance its lateral shift needs
    shift_est = np.maximum(0.5 * (w1 + w2) + gap - spec.lane_offset, 0.5)
    e_near = _capped(q_swerve, spec.evasive_angle,
                     np.sqrt(4.0 * ctx.a_lat * shift_est / (np.pi * m1.v_travel**2)))
    ev1 |= ctx.near
    e1 = np.where(ctx.near, e_near, e1)
    ramp1 = np.where(ev1, left * e1, 0.0)
    # the lead steers away from the follower's side in a near miss, randomly otherwise
    ramp2 = np.where(ev2, np.where(ctx.near, -left, side2) * e2, 0.0)
    # participant 2 lies opposite to the follower's swerve
    side = np.where(ev1, -left, random_side)
    pair = ImpactPair(ramp1, v1s, ctx.dims1, ramp2, v2s, ctx.dims2)
    r, placed = place_overlap(pair, -1.0, share, side)
    r = np.where(ctx.near[:, None], place_gap(pair, gap, side), r)
    ok &= placed | ctx.near
    shift2 = ramp2 * s2 * 0.5
    # crashes: split the lateral mismatch between both lane positions
    shift1 = ramp1 * s1 * 0.5
    mismatch = r[:, 1] + shift1 - shift2
    lane1 = -0.5 * LANE_WIDTH + noise[0] - 0.5 * mismatch
    lane2 = -0.5 * LANE_WIDTH + noise[0] + 0.5 * mismatch
    # near misses: both in the lane, the follower's swerve bridges the offset
    near_lane1 = -0.5 * LANE_WIDTH + noise[0]
    near_lane2 = -0.5 * LANE_WIDTH + noise[1]
    near_shift1 = near_lane2 + shift2 - r[:, 1] - near_lane1
    ok &= ~ctx.near | (near_shift1 * left > 0.3)
    s1 = np.where(ctx.near, 2.0 * np.abs(near_shift1) / np.maximum(e1, 1e-3), s1)
    lane1 = np.where(ctx.near, near_lane1, lane1)
    lane2 = np.where(ctx.near, near_lane2, lane2)
    shift1 = np.where(ctx.near, near_shift1, shift1)
    l1 = lane1 + shift1
    p1, p2 = new_part(n), new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=l1, ramp_angle=ramp1, ramp_dist=s1)
    p2.update(u_star=r[:, 0], l_star=l1 + r[:, 1], ramp_angle=ramp2, ramp_dist=s2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(standing2=standing, evasive1=ev1, evasive2=ev2,
                 evasive_angle1=np.where(ev1, e1, np.nan),
                 evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time1=np.where(ev1 & ~ctx.near, t1, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 swerve_length1=np.where(ev1, s1, np.nan),
                 overlap=np.where(ctx.near, -gap, share), side=side, lane1=lane1,
                 lane2=lane2)
    return Design(p1, p2, np.zeros(n), extra, ok)


def _design_crossing(ctx: DesignContext) -> Design:
    """Crossing paths: the front of participant 1 strikes the side of participant 2."""
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    m1 = draw_speed_profile(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m2 = draw_speed_profile(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    from_right = rng.random(n) < spec.crossing_from_right_share
    angle = rng.uniform(*spec.crossing_angle, n)
    yaw2 = np.where(from_right, angle, -angle)
    position = rng.uniform(*spec.impact_position, n)
    aim = rng.uniform(-spec.striker_offset, spec.striker_offset, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    lane1, lane2 = _lanes(ctx, -0.5 * LANE_WIDTH), _lanes(ctx, -0.5 * LANE_WIDTH)
    pair = ImpactPair(np.zeros(n), m1.speed_at(0.0), ctx.dims1, yaw2, m2.speed_at(0.0), ctx.dims2)
    point1 = np.stack([ctx.dims1.front, aim * ctx.dims1.width], axis=1)
    # struck side faces participant 1: left side if 2 comes from 1's right
    point2 = np.stack([-ctx.dims2.rear + position * ctx.dims2.length,
                       np.where(from_right, 0.5, -0.5) * ctx.dims2.width], axis=1)
    r, ok = place_target(pair, point1, point2)
    r = np.where(ctx.near[:, None], place_gap(pair, gap, side), r)
    ok |= ctx.near
    p1, p2 = new_part(n), new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=lane1)
    # participant 2 on its own road through its impact position
    pos2 = r + np.stack([np.zeros(n), lane1], axis=1)
    normal2 = unit_vector(yaw2 + 0.5 * np.pi)
    origin2 = pos2 - lane2[:, None] * normal2
    p2.update(road_x=origin2[:, 0], road_y=origin2[:, 1], road_theta=yaw2, l_star=lane2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(crossing_angle=angle, from_right=from_right,
                 impact_position=np.where(ctx.near, np.nan, position),
                 overlap=np.where(ctx.near, -gap, np.nan), side=np.where(ctx.near, side, np.nan),
                 lane1=lane1, lane2=lane2)
    return Design(p1, p2, np.zeros(n), extra, ok)


def _design_left_turn(ctx: DesignContext) -> Design:
    """Left turn across the path of oncoming participant 2 (its front into 1's right)."""
    rng, spec, n = ctx.rng, ctx.spec, ctx.n
    radius = rng.uniform(*spec.turn_radius, n)
    v_cap = np.sqrt(ctx.a_lat * radius)
    q_speed = rng.random(n)
    v1 = _capped(q_speed, spec.speed1, v_cap)
    m1 = draw_speed_profile(rng, n, spec.speed1, spec.brake_prob[0], spec, ctx.mu,
                      spec.min_impact_speed_share)
    m1 = SpeedProfile(v1, m1.brake_time, m1.jerk, m1.decel)
    # re-apply the minimum impact speed to the capped travel speed
    lead = np.minimum(-m1.brake_time, brake_time_for_drop(
        v1 * (1.0 - spec.min_impact_speed_share), m1.jerk, m1.decel))
    m1 = m1._replace(brake_time=np.where(m1.braking, -lead, NO_BRAKE))
    m2 = draw_speed_profile(rng, n, spec.speed2, spec.brake_prob[1], spec, ctx.mu,
                      spec.min_impact_speed_share)
    beta = rng.uniform(*spec.turn_angle, n)
    ev2, e2, t2, s2 = _evasion(ctx, m2, spec.evasive_prob[1], spec.evasive_angle,
                               spec.evasive_time)
    ramp2 = np.where(ev2, -e2, 0.0)
    position = rng.uniform(*spec.impact_position, n)
    aim = rng.uniform(-spec.striker_offset, spec.striker_offset, n)
    gap = rng.uniform(*spec.near_miss_gap, n)
    side = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    lane2 = _lanes(ctx, 0.5 * LANE_WIDTH)
    pair = ImpactPair(beta, m1.speed_at(0.0), ctx.dims1, np.pi + ramp2, m2.speed_at(0.0),
                 ctx.dims2)
    # participant 2 (moving) aims its front at the turner's front-right / right side
    point1 = np.stack([ctx.dims1.front - position * ctx.dims1.length,
                       -0.5 * ctx.dims1.width], axis=1)
    point2 = np.stack([ctx.dims2.front, aim * ctx.dims2.width], axis=1)
    r, ok = place_target(pair, point1, point2)
    r = np.where(ctx.near[:, None], place_gap(pair, gap, side), r)
    ok |= ctx.near
    l2 = lane2 - ramp2 * s2 * 0.5  # moving in -u
    l1 = l2 - r[:, 1]
    lane1 = l1 - radius * (1.0 - np.cos(beta))
    ok &= (lane1 >= spec.turner_lane[0]) & (lane1 <= spec.turner_lane[1])
    p1, p2 = new_part(n), new_part(n)
    _set_motion(p1, m1)
    _set_motion(p2, m2)
    p1.update(l_star=l1, turn_curv=1.0 / radius, turn_dist=beta * radius)
    p2.update(u_star=r[:, 0], l_star=l2, direction=np.full(n, -1.0), ramp_angle=ramp2,
              ramp_dist=s2)
    extra = _common_extra(ctx, m1, m2)
    extra.update(turn_radius=radius, turn_angle=beta, evasive2=ev2,
                 evasive_angle2=np.where(ev2, e2, np.nan),
                 evasive_time2=np.where(ev2, t2, np.nan),
                 impact_position=np.where(ctx.near, np.nan, position),
                 overlap=np.where(ctx.near, -gap, np.nan), side=np.where(ctx.near, side, np.nan),
                 lane1=lane1, lane2=lane2)
    return Design(p1, p2, np.zeros(n), extra, ok)


DESIGNERS: dict[str, Callable[[DesignContext], Design]] = {
    "head_on": _design_head_on,
    "overtaking": _design_overtaking,
    "rear_end": _design_rear_end,
    "crossing": _design_crossing,
    "left_turn": _design_left_turn,
}
