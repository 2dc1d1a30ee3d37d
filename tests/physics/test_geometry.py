"""Geometry: outlines, Sutherland-Hodgman overlap, POI and contact plane.

Oracles: shapely (GEOS) for areas, centroids and boundary intersections;
hand-computable configurations for the contact-plane rules.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import slow_scale
from vfs.physics.geometry import (
    AREA_TOLERANCE,
    contact_geometry,
    first_contact,
    outline_corners,
    outline_distance,
    overlap,
    polygon_area_centroid,
    rectangle_distance,
    to_vehicle_frame,
    vehicle_outline,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles


def random_pairs(rng: np.random.Generator, n: int, spread: float = 3.0):
    x = rng.uniform(-spread, spread, (n, 2))
    y = rng.uniform(-spread, spread, (n, 2))
    yaw = rng.uniform(-np.pi, np.pi, (n, 2))
    length = rng.uniform(3.0, 6.0, (n, 2))
    width = rng.uniform(1.5, 2.2, (n, 2))
    front = length * rng.uniform(0.4, 0.6, (n, 2))
    o1 = outline_corners(x[:, 0], y[:, 0], yaw[:, 0], front[:, 0], length[:, 0] - front[:, 0],
                         width[:, 0])
    o2 = outline_corners(x[:, 1], y[:, 1], yaw[:, 1], front[:, 1], length[:, 1] - front[:, 1],
                         width[:, 1])
    return o1, o2, np.stack([x[:, 0], y[:, 0]], 1), np.stack([x[:, 1], y[:, 1]], 1)


def test_outline_places_cg_by_overhang_and_axle():
    v = VehicleParams(length=4.5, width=1.8, wheelbase=2.7, cg_to_front_axle=1.2,
                      front_overhang=0.9)
    corners = vehicle_outline(stack_vehicles([v]), [10.0], [5.0], [np.pi / 2])[0]
    # heading north: front bumper 0.9 + 1.2 = 2.1 m north of the CG, rear 2.4 m south
    np.testing.assert_allclose(corners[:, 1].max(), 5.0 + 2.1, atol=1e-12)
    np.testing.assert_allclose(corners[:, 1].min(), 5.0 - 2.4, atol=1e-12)
    np.testing.assert_allclose(corners[:, 0].max() - corners[:, 0].min(), 1.8, atol=1e-12)
    # counter-clockwise: positive shoelace area = length * width
    ring = np.vstack([corners, corners[:1]])
    area = 0.5 * np.sum(ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1])
    assert area == pytest.approx(4.5 * 1.8)


@pytest.mark.slow
def test_overlap_matches_shapely_on_random_pairs():
    n = max(10_000, int(50_000 * slow_scale()))
    rng = np.random.default_rng(12345)
    o1, o2, _, _ = random_pairs(rng, n)
    ov = overlap(o1, o2)
    inter = shapely.intersection(shapely.polygons(o1), shapely.polygons(o2))
    area = shapely.area(inter)
    np.testing.assert_allclose(ov.area, area, atol=1e-9, rtol=0)
    hit = area > AREA_TOLERANCE
    assert 0.3 < hit.mean() < 0.9  # both overlapping and separate pairs are exercised
    centroid = shapely.get_coordinates(shapely.centroid(inter[hit]))
    np.testing.assert_allclose(ov.centroid[hit], centroid, atol=1e-9, rtol=0)
    assert np.isnan(ov.centroid[~hit]).all()


def test_intersection_points_match_shapely():
    rng = np.random.default_rng(7)
    o1, o2, c1, c2 = random_pairs(rng, 10_000)
    g = contact_geometry(o1, o2, c1, c2)
    boundary = shapely.intersection(shapely.boundary(shapely.polygons(o1)),
                                    shapely.boundary(shapely.polygons(o2)))
    np.testing.assert_array_equal(g.n_intersections, shapely.get_num_coordinates(boundary))
    two = g.n_intersections == 2
    pts = shapely.get_coordinates(boundary[two]).reshape(-1, 2, 2)
    d = pts[:, 1] - pts[:, 0]
    expected = np.mod(np.arctan2(d[:, 1], d[:, 0]), np.pi)
    diff = np.mod(expected - g.cp_angle[two] + np.pi / 2, np.pi) - np.pi / 2
    np.testing.assert_allclose(diff, 0.0, atol=1e-9)
    assert (g.rule[two & (g.area > 0)] == 1).all()


def test_single_pair_and_batch_agree():
    rng = np.random.default_rng(3)
    o1, o2, c1, c2 = random_pairs(rng, 200)
    batch = contact_geometry(o1, o2, c1, c2)
    for k in range(0, 200, 17):
        one = contact_geometry(o1[k], o2[k], c1[k], c2[k])
        np.testing.assert_array_equal(one.poi[0], batch.poi[k])
        np.testing.assert_array_equal(one.cp_angle[0], batch.cp_angle[k])


def head_on(offset_y: float, gap: float):
    """Two 4 x 2 m boxes (CG at centre) facing each other; positive gap = apart."""
    o1 = outline_corners([0.0], [0.0], [0.0], [2.0], [2.0], [2.0])
    o2 = outline_corners([4.0 + gap], [offset_y], [np.pi], [2.0], [2.0], [2.0])
    return o1, o2, np.array([[0.0, 0.0]]), np.array([[4.0 + gap, offset_y]])


def test_head_on_partial_overlap_closed_form():
    # penetration 0.4 m, lateral offset 0.8 m: overlap 0.4 x 1.2 m centred at
    # x = 2 - 0.2 = 1.8, y = (1 + (0.8 - 1)) / 2 = 0.4
    o1, o2, c1, c2 = head_on(0.8, -0.4)
    g = contact_geometry(o1, o2, c1, c2)
    assert g.area[0] == pytest.approx(0.4 * 1.2)
    np.testing.assert_allclose(g.poi[0], [1.8, 0.4], atol=1e-12)
    # intersection points: (1.6, 1.0) and (2.0, -0.2): CP is the diagonal
    assert g.n_intersections[0] == 2 and g.rule[0] == 1
    assert g.cp_angle[0] == pytest.approx(np.mod(np.arctan2(-1.2, 0.4), np.pi))


def test_corner_penetrating_edge_gives_edge_as_plane():
    # vehicle 1 turned by 0.3 rad: only its front-right corner (x = 2.206)
    # crosses vehicle 2's side at x = 2.0; both intersection points lie on
    # that side, so the CP runs along it (the y axis)
    o1 = outline_corners([0.0], [0.0], [0.3], [2.0], [2.0], [2.0])
    o2 = outline_corners([3.0], [0.0], [np.pi / 2], [3.0], [3.0], [2.0])
    g = contact_geometry(o1, o2, [[0, 0]], [[3.0, 0.0]])
    assert g.rule[0] == 1 and g.n_intersections[0] == 2
    assert g.cp_angle[0] == pytest.approx(np.pi / 2)
    # POI: centroid of the triangle cut off the corner, right of vehicle 1's axis
    corner = np.array([2 * np.cos(0.3) + np.sin(0.3), 2 * np.sin(0.3) - np.cos(0.3)])
    assert g.poi[0, 0] == pytest.approx(2.0 + (corner[0] - 2.0) / 3.0)


def test_full_width_head_on_more_points_and_touching():
    # equal boxes exactly aligned: edges are collinear -> corners are the points
    o1, o2, c1, c2 = head_on(0.0, -0.3)
    g = contact_geometry(o1, o2, c1, c2)
    assert g.n_intersections[0] == 4 and g.rule[0] == 2
    # farthest pair is a diagonal of the 0.3 x 2 overlap, CP nearly lateral
    np.testing.assert_allclose(g.poi[0], [1.85, 0.0], atol=1e-12)
    touching = contact_geometry(*head_on(0.5, 0.0))
    assert touching.area[0] == 0.0 and touching.rule[0] == 4
    assert touching.cp_angle[0] == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(touching.poi[0], [2.0, 0.25], atol=1e-12)


def test_containment_and_no_contact():
    big = outline_corners([0.0], [0.0], [0.3], [5.0], [5.0], [3.0])
    small = outline_corners([0.5], [0.2], [1.0], [1.0], [1.0], [1.0])
    g = contact_geometry(big, small, [[0.0, 0.0]], [[0.5, 0.2]])
    assert g.n_intersections[0] == 0 and g.rule[0] == 3
    assert g.area[0] == pytest.approx(2.0)
    # perpendicular to the CG line
    assert g.cp_angle[0] == pytest.approx(np.mod(np.arctan2(0.2, 0.5) + np.pi / 2, np.pi))
    apart = contact_geometry(*head_on(0.0, 1.0))
    assert apart.rule[0] == 0 and np.isnan(apart.poi[0]).all() and np.isnan(apart.cp_angle[0])


@given(
    angle=st.floats(-np.pi, np.pi), dx=st.floats(-50, 50), dy=st.floats(-50, 50),
    seed=st.integers(0, 2**32 - 1),
)
def test_rigid_motion_invariance(angle: float, dx: float, dy: float, seed: int):
    rng = np.random.default_rng(seed)
    o1, o2, c1, c2 = random_pairs(rng, 64, spread=2.0)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    shift = np.array([dx, dy])
    g = contact_geometry(o1, o2, c1, c2)
    h = contact_geometry(o1 @ rot.T + shift, o2 @ rot.T + shift, c1 @ rot.T + shift,
                         c2 @ rot.T + shift)
    np.testing.assert_allclose(h.area, g.area, atol=1e-9)
    ok = g.rule > 0
    np.testing.assert_array_equal(h.rule[ok] > 0, True)
    np.testing.assert_allclose(h.poi[ok], g.poi[ok] @ rot.T + shift, atol=1e-7)
    diff = np.mod(h.cp_angle[ok] - g.cp_angle[ok] - angle + np.pi / 2, np.pi) - np.pi / 2
    np.testing.assert_allclose(diff, 0.0, atol=1e-6)


@given(seed=st.integers(0, 2**32 - 1))
def test_swapping_vehicles_keeps_poi_and_plane(seed: int):
    rng = np.random.default_rng(seed)
    o1, o2, c1, c2 = random_pairs(rng, 64, spread=2.0)
    g = contact_geometry(o1, o2, c1, c2)
    h = contact_geometry(o2, o1, c2, c1)
    np.testing.assert_allclose(h.area, g.area, atol=1e-9)
    np.testing.assert_array_equal(h.n_intersections, g.n_intersections)
    ok = g.rule > 0
    np.testing.assert_allclose(h.poi[ok], g.poi[ok], atol=1e-9)
    diff = np.mod(h.cp_angle[ok] - g.cp_angle[ok] + np.pi / 2, np.pi) - np.pi / 2
    np.testing.assert_allclose(diff, 0.0, atol=1e-9)


def test_area_centroid_of_known_polygon_and_frames():
    from vfs.physics.geometry import Polygons

    tri = np.array([[[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [0.0, 3.0]]])
    area, centroid = polygon_area_centroid(Polygons(tri, np.array([True])))
    assert area[0] == pytest.approx(4.5)
    np.testing.assert_allclose(centroid[0], [1.0, 1.0])
    local = to_vehicle_frame([[1.0, 2.0]], [1.0], [1.0], [np.pi / 2])
    np.testing.assert_allclose(local[0], [1.0, 0.0], atol=1e-12)


# ----------------------------------------------------------------------------
# Rectangle kernels (from the former tests/test_kernels.py)
# ----------------------------------------------------------------------------

_coord = st.floats(-8.0, 8.0)
_angle = st.floats(-math.pi, math.pi)
_half_length = st.floats(0.4, 3.0)
_half_width = st.floats(0.3, 1.5)


def _polygon(x: float, y: float, yaw: float, hl: float, hw: float) -> shapely.Polygon:
    c, s = math.cos(yaw), math.sin(yaw)
    return shapely.Polygon([(x + c * u - s * v, y + s * u + c * v)
                            for u, v in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))])


# ----------------------------------------------------------------------------
# Distance between two rectangles
# ----------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(ax=_coord, ay=_coord, ayaw=_angle, ahl=_half_length, ahw=_half_width, bx=_coord,
       by=_coord, byaw=_angle, bhl=_half_length, bhw=_half_width)
def test_rectangle_distance_equals_shapely(ax, ay, ayaw, ahl, ahw, bx, by, byaw, bhl, bhw):
    ref = _polygon(ax, ay, ayaw, ahl, ahw).distance(_polygon(bx, by, byaw, bhl, bhw))
    got = rectangle_distance([ax], [ay], [ayaw], [ahl], [ahw], [bx], [by], [byaw], [bhl],
                             [bhw])[0]
    assert got == pytest.approx(ref, abs=1e-9)
    # the corner form is the same kernel
    oa = outline_corners([ax], [ay], [ayaw], [ahl], [ahl], [2 * ahw])
    ob = outline_corners([bx], [by], [byaw], [bhl], [bhl], [2 * bhw])
    assert outline_distance(oa, ob)[0] == pytest.approx(ref, abs=1e-9)


def test_crossing_rectangles_without_a_corner_inside_have_distance_zero():
    # a plus sign: no corner of either rectangle lies in the other, yet they overlap
    gap = rectangle_distance([0.0], [0.0], [0.0], [3.0], [0.5], [0.0], [0.0], [math.pi / 2],
                             [3.0], [0.5])
    assert gap[0] == 0.0


# ----------------------------------------------------------------------------
# First contact of two moving rectangles
# ----------------------------------------------------------------------------


def _bisect_first_contact(a: shapely.Polygon, b: shapely.Polygon, ddx: float, ddy: float,
                          samples: int = 400, steps: int = 60) -> float:
    """First s in [0, 1] at which b translated by s (ddx, ddy) touches a: a fine scan for
    the first touching sample, then bisection between it and the sample before."""
    def touches(s: float) -> bool:
        return a.intersects(shapely.affinity.translate(b, s * ddx, s * ddy))

    if touches(0.0):
        return 0.0
    grid = np.linspace(0.0, 1.0, samples + 1)
    hits = [s for s in grid if touches(float(s))]
    if not hits:
        return math.inf
    hi = float(hits[0])
    lo = hi - 1.0 / samples
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if touches(mid) else (mid, hi)
    return hi


@settings(max_examples=150, deadline=None)
@given(dx=_coord, dy=_coord, ddx=st.floats(-16.0, 16.0), ddy=st.floats(-16.0, 16.0),
       yaw_a=_angle, hl_a=_half_length, hw_a=_half_width, yaw_b=_angle, hl_b=_half_length,
       hw_b=_half_width)
def test_first_contact_equals_bisection_on_shapely(dx, dy, ddx, ddy, yaw_a, hl_a, hw_a, yaw_b,
                                                   hl_b, hw_b):
    import shapely.affinity  # noqa: F401  (used by the reference)

    a = _polygon(0.0, 0.0, yaw_a, hl_a, hw_a)
    b = _polygon(dx, dy, yaw_b, hl_b, hw_b)
    s = first_contact(np.array([dx]), np.array([dy]), np.array([ddx]), np.array([ddy]),
                      np.array([yaw_a]), np.array([hl_a]), np.array([hw_a]),
                      np.array([yaw_b]), np.array([hl_b]), np.array([hw_b]))[0]
    ref = _bisect_first_contact(a, b, ddx, ddy)
    move = math.hypot(ddx, ddy)
    if math.isinf(ref):
        # no sample touches: the kernel may still find a graze between samples
        assert math.isinf(s) or a.distance(shapely.affinity.translate(
            b, s * ddx, s * ddy)) <= 1e-9
        return
    assert np.isfinite(s)
    assert abs(s - ref) * move <= 1e-6 + move / 400  # within one scan sample [m]
    # at s the rectangles touch, shortly before they are apart
    assert a.distance(shapely.affinity.translate(b, s * ddx, s * ddy)) <= 1e-9
    if s > 1e-6:
        back = max(s - 1e-4, 0.0)
        assert a.distance(shapely.affinity.translate(b, back * ddx, back * ddy)) > 0.0
