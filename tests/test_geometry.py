"""Geometry: outlines, Sutherland-Hodgman overlap, POI and contact plane.

Oracles: shapely (GEOS) for areas, centroids and boundary intersections;
hand-computable configurations for the contact-plane rules.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import slow_scale
from vfs.physics.geometry import (
    AREA_TOLERANCE,
    contact_geometry,
    outline_corners,
    overlap,
    polygon_area_centroid,
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
