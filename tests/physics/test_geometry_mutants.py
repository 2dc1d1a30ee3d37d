"""Geometry tests written against the mutants a mutation run left alive
(benchmarks/mutation.py, docs/testing.md): the vehicle frame at points off both axes,
the swept overlap and the contact faces against closed forms and shapely, the broad
phase with a margin, the contact-plane rules, the polygon kernels for many blocks, and
the invariance of all of it under rotation, translation and mirroring of the scene.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import affinity

from vfs.physics import geometry
from vfs.physics.geometry import (
    FACE_FRONT,
    FACE_LEFT,
    FACE_NAMES,
    FACE_REAR,
    FACE_RIGHT,
    POINT_TOLERANCE,
    Polygons,
    contact_faces,
    contact_geometry,
    contact_plane,
    outline_corners,
    outline_distance,
    outline_intersections,
    outlines_may_overlap,
    overlap,
    polygon_area_centroid,
    pose_frame,
    rectangle_frame,
    swept_overlap,
    to_vehicle_frame,
    vehicle_outline,
)
from vfs.physics.vehicle import VehicleParams, stack_vehicles


def rot(angle: float) -> np.ndarray:
    return np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])


@settings(max_examples=60, deadline=None)
@given(x=st.floats(-50, 50), y=st.floats(-50, 50), yaw=st.floats(-7, 7),
       u=st.floats(-5, 5), v=st.floats(-5, 5))
def test_to_vehicle_frame_inverts_the_pose(x, y, yaw, u, v) -> None:
    """A point at (u, v) in the vehicle frame, placed in the world, comes back as (u, v)."""
    p = np.array([x, y]) + rot(yaw) @ np.array([u, v])
    np.testing.assert_allclose(to_vehicle_frame(p[None], [x], [y], [yaw])[0], [u, v],
                               atol=1e-9)


def test_to_vehicle_frame_closed_forms() -> None:
    # heading 90 deg: world +y is the vehicle's forward, world +x its right (-y_v)
    got = to_vehicle_frame([[3.0, 7.0], [1.0 + 2.0, 1.0], [0.0, 0.0]], [1.0, 1.0, 1.0],
                           [1.0, 1.0, 2.0], [np.pi / 2, np.pi / 2, np.pi])
    np.testing.assert_allclose(got, [[6.0, -2.0], [0.0, -2.0], [1.0, 2.0]], atol=1e-12)


def vehicles(n: int = 1, **over) -> object:
    v = VehicleParams(**{**dict(length=4.6, width=1.8, wheelbase=2.7, cg_to_front_axle=1.1,
                                front_overhang=0.9), **over})
    return stack_vehicles([v] * n)


def test_contact_faces_around_a_turned_vehicle() -> None:
    """Points just outside each face of a vehicle at yaw 30 deg with the CG off centre."""
    veh = vehicles(8)
    yaw, cx, cy = np.radians(30.0), 3.0, -2.0
    front, rear = 0.9 + 1.1, 4.6 - 2.0
    centre = 0.5 * (front - rear)  # outline centre ahead of the CG (negative: behind)
    local = np.array([[front + 0.1, 0.3], [-rear - 0.1, -0.3], [centre + 0.5, 1.0],
                      [centre - 0.5, -1.0], [centre + 2.2, 0.1], [centre - 2.2, -0.1],
                      [centre + 0.2, 0.95], [centre - 0.2, -0.95]])
    pts = np.array([cx, cy]) + local @ rot(yaw).T
    faces = contact_faces(pts, veh, np.full(8, cx), np.full(8, cy), np.full(8, yaw))
    assert faces.tolist() == [FACE_FRONT, FACE_REAR, FACE_LEFT, FACE_RIGHT, FACE_FRONT,
                              FACE_REAR, FACE_LEFT, FACE_RIGHT]
    assert [FACE_NAMES[int(f)] for f in faces[:4]] == ["front", "rear", "left", "right"]
    # on the diagonal |x| / (l / 2) == |y| / (w / 2): an end (front), and NaN gives front
    diag = np.array([cx, cy]) + np.array([centre + 2.3, 0.9]) @ rot(yaw).T
    nanp = np.array([np.nan, np.nan])
    faces = contact_faces(np.stack([diag, nanp]), vehicles(2), [cx, cx], [cy, cy], [yaw, yaw])
    assert faces.tolist() == [FACE_FRONT, FACE_FRONT]


def test_contact_faces_mirror_exchanges_left_and_right() -> None:
    rng = np.random.default_rng(3)
    n = 400
    veh = vehicles(n)
    x, y, yaw = rng.uniform(-9, 9, n), rng.uniform(-9, 9, n), rng.uniform(-4, 4, n)
    pts = rng.uniform(-12, 12, (n, 2))
    faces = contact_faces(pts, veh, x, y, yaw)
    mirrored = contact_faces(pts * [1, -1], veh, x, -y, -yaw)
    swap = {FACE_FRONT: FACE_FRONT, FACE_REAR: FACE_REAR, FACE_LEFT: FACE_RIGHT,
            FACE_RIGHT: FACE_LEFT}
    np.testing.assert_array_equal(mirrored, [swap[int(f)] for f in faces])
    assert set(faces.tolist()) == {FACE_FRONT, FACE_REAR, FACE_LEFT, FACE_RIGHT}


def box(x: float, y: float, yaw: float, length: float = 4.0, width: float = 2.0,
        front: float | None = None) -> np.ndarray:
    f = 0.5 * length if front is None else front
    return outline_corners(x, y, yaw, f, length - f, width)


def test_swept_overlap_closed_forms() -> None:
    # head-on, lateral offset 0.5 m of 2 m wide cars: overlap 1.5 / 2
    a, b = box(0.0, 0.0, 0.0), box(5.0, 0.5, np.pi)
    d = np.array([[10.0, 0.0]])
    assert swept_overlap(a, b, d)[0] == pytest.approx(0.75)
    # the direction's sign and length do not matter
    assert swept_overlap(a, b, -3 * d)[0] == pytest.approx(0.75)
    # far apart laterally: 0; full width: 1; narrower striker: engaged share of it
    assert swept_overlap(a, box(5.0, 3.0, np.pi), d)[0] == 0.0
    assert swept_overlap(a, box(5.0, 0.0, np.pi), d)[0] == pytest.approx(1.0)
    assert swept_overlap(a, box(5.0, 0.5, np.pi, width=1.0), d)[0] == pytest.approx(1.0)
    assert swept_overlap(a, box(5.0, 1.25, np.pi, width=1.0), d)[0] == pytest.approx(0.25)
    # front to side: a car (4 m long) crossing; approach along y, projections on x
    side = box(1.0, 5.0, 0.0, length=4.0)  # spans x in [-1, 3]
    striker = box(0.0, 0.0, np.pi / 2, length=4.0, width=2.0)  # spans x in [-1, 1]
    assert swept_overlap(striker, side, np.array([[0.0, 5.0]]))[0] == pytest.approx(1.0)
    striker = box(-1.5, 0.0, np.pi / 2)  # spans x in [-2.5, -0.5]: 0.5 of 2 engaged
    assert swept_overlap(striker, side, np.array([[0.0, 5.0]]))[0] == pytest.approx(0.25)
    assert np.isnan(swept_overlap(a, b, np.zeros((1, 2)))[0])


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(-np.pi, np.pi),
       dx=st.floats(-100, 100), dy=st.floats(-100, 100))
def test_swept_overlap_against_shapely_projections(seed, angle, dx, dy) -> None:
    rng = np.random.default_rng(seed)
    n = 16
    o1 = box(rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-4, 4, n))
    o2 = box(rng.uniform(-6, 6, n), rng.uniform(-6, 6, n), rng.uniform(-4, 4, n),
             width=rng.uniform(1.0, 2.5, n))
    d = rng.normal(size=(n, 2))
    got = swept_overlap(o1, o2, d)
    for k in range(n):
        # the projections by shapely: turn the scene so that d points along +y; the
        # outlines' x extents are then their projections
        theta = np.pi / 2 - np.arctan2(d[k, 1], d[k, 0])
        b1 = affinity.rotate(shapely.Polygon(o1[k]), theta, origin=(0, 0), use_radians=True)
        b2 = affinity.rotate(shapely.Polygon(o2[k]), theta, origin=(0, 0), use_radians=True)
        common = max(min(b1.bounds[2], b2.bounds[2]) - max(b1.bounds[0], b2.bounds[0]), 0.0)
        short = min(b1.bounds[2] - b1.bounds[0], b2.bounds[2] - b2.bounds[0])
        assert got[k] == pytest.approx(min(common / short, 1.0), abs=1e-9)
    # rotating and shifting the scene with its direction changes nothing; mirroring neither
    m = rot(angle)
    moved = swept_overlap(o1 @ m.T + [dx, dy], o2 @ m.T + [dx, dy], d @ m.T)
    np.testing.assert_allclose(moved, got, atol=1e-9)
    np.testing.assert_allclose(swept_overlap(o1 * [1, -1], o2 * [1, -1], d * [1, -1]), got,
                               atol=1e-12)
    np.testing.assert_allclose(swept_overlap(o2, o1, d), got, atol=1e-12)


def test_outlines_may_overlap_with_a_margin() -> None:
    a = box(0.0, 0.0, 0.0)
    for gap, margin, expected in ((1.0, 0.0, False), (1.0, 0.49, False), (1.0, 0.51, True),
                                  (0.0, 0.0, True), (-0.5, 0.0, True)):
        b = box(4.0 + gap, 0.7, 0.0)  # x spans [2 + gap, 6 + gap]
        assert outlines_may_overlap(a, b, margin)[0] == expected, (gap, margin)
        assert outlines_may_overlap(b, a, margin)[0] == expected
    # lateral separation and a turned rectangle
    b = box(0.0, 3.0, 0.0)  # 1 m apart in y
    assert not outlines_may_overlap(a, b)[0] and outlines_may_overlap(a, b, 0.6)[0]
    b = box(2.0 + np.sqrt(2.0) + 0.1, 0.0, np.pi / 4, length=2.0, width=2.0)  # corner 0.1 away
    assert not outlines_may_overlap(a, b)[0] and outlines_may_overlap(a, b, 0.06)[0]
    assert outline_distance(a, b)[0] == pytest.approx(0.1, abs=1e-9)


def test_pose_frame_and_rectangle_frame_agree() -> None:
    rng = np.random.default_rng(4)
    n = 50
    x, y, yaw = rng.uniform(-9, 9, n), rng.uniform(-9, 9, n), rng.uniform(-4, 4, n)
    length, width = rng.uniform(3, 6, n), rng.uniform(1.5, 2.5, n)
    corners = box(x, y, yaw, length, width)
    f = rectangle_frame(corners)
    g = pose_frame(x, y, yaw, 0.5 * length, 0.5 * width)
    np.testing.assert_allclose(f.centre, g.centre, atol=1e-12)
    np.testing.assert_allclose(f.axis, g.axis, atol=1e-12)
    np.testing.assert_allclose(f.half_length, 0.5 * length)
    np.testing.assert_allclose(f.half_width, 0.5 * width)
    lx, ly = f.to_local(corners)
    np.testing.assert_allclose(np.abs(lx), np.broadcast_to(0.5 * length[:, None], (n, 4)))
    np.testing.assert_allclose(f.to_global(lx, ly), corners, atol=1e-12)


def test_overlap_over_several_blocks_matches_shapely(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(geometry, "CHUNK", 7)
    rng = np.random.default_rng(5)
    n = 40
    o1 = box(rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-4, 4, n))
    o2 = box(rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-4, 4, n))
    ov = overlap(o1, o2)
    area, centroid = polygon_area_centroid(ov.polygon)
    for k in range(n):
        inter = shapely.Polygon(o1[k]).intersection(shapely.Polygon(o2[k]))
        assert ov.area[k] == pytest.approx(inter.area, abs=1e-9)
        assert area[k] == pytest.approx(inter.area, abs=1e-9)
        if inter.area > 1e-6:
            np.testing.assert_allclose(ov.centroid[k], [inter.centroid.x, inter.centroid.y],
                                       atol=1e-9)
            np.testing.assert_allclose(centroid[k], ov.centroid[k], atol=1e-9)
    assert (ov.area > 0).sum() > 10 and (ov.area == 0).sum() > 0
    # a clockwise polygon has a negative signed area; a degenerate one area 0, no centroid
    cw = Polygons(o1[:1, ::-1].copy(), np.array([True]))
    assert polygon_area_centroid(cw)[0][0] == pytest.approx(-8.0)
    flat = Polygons(np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 0.0]]]),
                    np.array([True]))
    a, c = polygon_area_centroid(flat)
    assert a[0] == 0.0 and np.isnan(c).all()


def test_intersections_drop_duplicates_within_the_tolerance() -> None:
    a = box(0.0, 0.0, 0.0)  # x in [-2, 2], y in [-1, 1]
    b = box(3.0, 0.0, 0.0)  # x in [1, 5]: crossing points (1, +-1) and (2, +-1)
    ov = overlap(a, b)
    pts = outline_intersections(ov.polygon, a, b)
    got = pts[0][~np.isnan(pts[0, :, 0])]
    assert sorted(map(tuple, np.round(got, 9))) == [(1.0, -1.0), (1.0, 1.0), (2.0, -1.0),
                                                    (2.0, 1.0)]
    # points closer than POINT_TOLERANCE are one
    near = np.array([[[0.0, 0.0], [0.5 * POINT_TOLERANCE, 0.0], [3.0, 0.0], [np.nan, np.nan]]])
    angle, n_points, rule = contact_plane(near, np.array([[0.0, 1.0]]),
                                          np.array([[0.0, -1.0]]), np.array([1.0]))
    assert n_points[0] == 3 and rule[0] == 2 and angle[0] == pytest.approx(0.0)


def test_contact_plane_rules_closed_forms() -> None:
    nan = np.nan
    pts = np.array([
        [[0.0, 0.0], [1.0, 1.0], [nan, nan], [nan, nan]],  # rule 1: 45 deg
        [[0.0, 0.0], [0.0, -2.0], [0.5, -0.3], [nan, nan]],  # rule 2: farthest pair, 90 deg
        [[nan, nan]] * 4,  # penetrating without points: rule 3, perpendicular to CG line
        [[2.0, 0.0], [2.0, 1.0], [nan, nan], [nan, nan]],  # touching, two points: rule 4
        [[2.0, 0.0], [nan, nan], [nan, nan], [nan, nan]],  # touching at one point: rule 3
        [[nan, nan]] * 4,  # nothing: rule 0
        [[0.0, 0.0], [1.0, -1e-17], [nan, nan], [nan, nan]],  # mod(-1e-17, pi) = pi -> 0
    ])
    cg1 = np.array([[0.0, 0.0]] * 7)
    cg2 = np.array([[3.0, 3.0]] * 7)
    area = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    angle, n_points, rule = contact_plane(pts, cg1, cg2, area)
    assert rule.tolist() == [1, 2, 3, 4, 3, 0, 1]
    assert sorted(geometry.CP_RULES) == [0, 1, 2, 3, 4]  # every code has its description
    assert geometry.CP_RULES[0] == "no contact"
    assert n_points.tolist() == [2, 3, 0, 2, 1, 0, 2]
    np.testing.assert_allclose(angle[[0, 1, 2, 3, 4]],
                               [np.pi / 4, np.pi / 2, 3 * np.pi / 4, np.pi / 2, 3 * np.pi / 4])
    assert np.isnan(angle[5])
    assert np.mod(-1e-17, np.pi) == np.pi and angle[6] == 0.0


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(-np.pi, np.pi),
       dx=st.floats(-100, 100), dy=st.floats(-100, 100))
def test_contact_geometry_under_mirroring(seed, angle, dx, dy) -> None:
    """Mirroring the scene (y -> -y, which reverses the corner order) mirrors POI and plane."""
    rng = np.random.default_rng(seed)
    n = 32
    x, y = rng.uniform(-2, 2, (2, n)), rng.uniform(-2, 2, (2, n))
    yaw = rng.uniform(-4, 4, (2, n))
    o1, o2 = box(x[0], y[0], yaw[0]), box(x[1], y[1], yaw[1])
    c1, c2 = np.stack([x[0], y[0]], 1), np.stack([x[1], y[1]], 1)
    g = contact_geometry(o1, o2, c1, c2)
    m1, m2 = box(x[0], -y[0], -yaw[0]), box(x[1], -y[1], -yaw[1])
    h = contact_geometry(m1, m2, c1 * [1, -1], c2 * [1, -1])
    np.testing.assert_array_equal(h.rule, g.rule)
    np.testing.assert_allclose(h.area, g.area, atol=1e-9)
    ok = g.rule > 0
    np.testing.assert_allclose(h.poi[ok], g.poi[ok] * [1, -1], atol=1e-9)
    # rule 2 picks the first of equally long diagonals in slot order, which mirroring
    # reverses: its plane is not mirror-invariant where two pairs tie (a known ambiguity)
    ok &= g.rule != 2
    diff = np.mod(h.cp_angle[ok] + g.cp_angle[ok] + np.pi / 2, np.pi) - np.pi / 2
    np.testing.assert_allclose(diff, 0.0, atol=1e-7)
    # turned and shifted: the POI moves with the scene (vehicle_outline path)
    veh = vehicles(n)
    v1 = vehicle_outline(veh, x[0], y[0], yaw[0])
    r = rot(angle)
    w1 = vehicle_outline(veh, *(np.stack([x[0], y[0]], 1) @ r.T + [dx, dy]).T, yaw[0] + angle)
    np.testing.assert_allclose(w1, v1 @ r.T + [dx, dy], atol=1e-9)


def test_separating_axes_of_both_rectangles() -> None:
    """A cross: b (6 m x 1 m, across a) reaches 0.5 m into a's band; on b's own long axis
    the projections overlap by 1 m, so no axis separates them; 1.1 m further they are apart."""
    a = geometry.pose_frame(0.0, 0.0, 0.0, 3.0, 0.5)
    for shift, expected in ((3.0, True), (3.4, True), (4.1, False)):
        b = geometry.pose_frame(0.0, shift, np.pi / 2, 3.0, 0.5)
        assert bool(geometry._frames_overlap(a, b)[0]) is expected  # noqa: SLF001
        assert bool(geometry._frames_overlap(b, a)[0]) is expected  # noqa: SLF001
        oa, ob = box(0.0, 0.0, 0.0, 6.0, 1.0), box(0.0, shift, np.pi / 2, 6.0, 1.0)
        assert bool(outlines_may_overlap(oa, ob)[0]) is expected


def test_first_contact_only_within_the_interval() -> None:
    """Unit squares 10 m apart closing by 9 m: contact at s = 8 / 9; by 6 m: none (s = 4/3)."""
    s = geometry.first_contact(10.0, 0.0, -9.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0)
    assert float(s) == pytest.approx(8.0 / 9.0)
    assert np.isinf(geometry.first_contact(10.0, 0.0, -6.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0))
    assert float(geometry.first_contact(10.0, 0.0, -8.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0,
                                        1.0)) == pytest.approx(1.0)
