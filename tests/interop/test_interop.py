"""OpenSCENARIO / OpenDRIVE exchange: reference point, roads, schema validity, round trip."""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from vfs.database import open_database
from vfs.errors import DataError, MissingExtraError, ParameterError
from vfs.interop.opendrive import (
    ReferenceLine,
    RoadSegment,
    case_roads,
    fit_reference_line,
    read_opendrive,
)
from vfs.interop.openscenario import (
    bounding_box_center,
    reference_offset,
    to_cg,
    to_reference,
)
from vfs.interop.scenario_import import import_xosc
from vfs.physics.geometry import vehicle_outline
from vfs.physics.vehicle import VehicleParams, stack_vehicles

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def db():
    return open_database("default")


def _needs_extra() -> None:
    pytest.importorskip("scenariogeneration")
    pytest.importorskip("xmlschema")


# ----------------------------------------------------------------------------
# reference point and bounding box
# ----------------------------------------------------------------------------


@pytest.mark.parametrize("yaw", [0.0, 0.7, -2.5])
def test_reference_point_is_the_rear_axle_and_the_box_is_the_vfs_outline(yaw):
    v = VehicleParams(length=4.6, width=1.8, wheelbase=2.8, cg_to_front_axle=1.1,
                      front_overhang=0.95)
    x, y = 12.0, -3.0
    off = float(reference_offset(v.wheelbase, v.cg_to_front_axle, v.front_overhang, v.length))
    assert off == pytest.approx(-v.cg_to_rear_axle)  # rear axle: L2 behind the CG
    xr, yr = to_reference(x, y, yaw, off)
    assert math.hypot(xr - x, yr - y) == pytest.approx(v.cg_to_rear_axle)
    back = to_cg(xr, yr, yaw, off)
    assert np.allclose(back, (x, y), atol=1e-12)
    # the exported box (centre relative to the reference point) has the vfs outline's corners
    cx = float(bounding_box_center(v.wheelbase, v.front_overhang, v.length))
    c, s = math.cos(yaw), math.sin(yaw)
    corners = []
    for dx, dy in ((1, 1), (1, -1), (-1, -1), (-1, 1)):
        lx, ly = cx + dx * v.length / 2, dy * v.width / 2
        corners.append((float(xr) + c * lx - s * ly, float(yr) + s * lx + c * ly))
    outline = vehicle_outline(stack_vehicles([v]), [x], [y], [yaw])[0]
    for corner in corners:
        assert np.min(np.hypot(*(outline - corner).T)) < 1e-9


def test_misc_object_reference_point_is_the_box_centre():
    off = float(reference_offset(0.5, 0.25, 0.4, 1.0, fixed_object=True))
    assert off == pytest.approx(0.25 + 0.4 - 0.5)  # CG -> centre of the outline
    assert float(bounding_box_center(0.5, 0.4, 1.0, fixed_object=True)) == 0.0


# ----------------------------------------------------------------------------
# reference lines
# ----------------------------------------------------------------------------


def test_reference_line_geometry_matches_closed_forms():
    k, r = 0.02, 50.0
    line = ReferenceLine(1.0, 2.0, 0.3, (RoadSegment("line", 10.0),
                                         RoadSegment("arc", 30.0, k, k),
                                         RoadSegment("spiral", 20.0, k, -0.01)))
    x, y, h, kap = line.evaluate([0.0, 10.0, 25.0, 40.0, 50.0, 60.0])
    assert (x[1], y[1]) == pytest.approx((1 + 10 * math.cos(0.3), 2 + 10 * math.sin(0.3)))
    # on the arc: a circle of radius 1/k around the centre left of the start
    cx, cy = x[1] - r * math.sin(0.3), y[1] + r * math.cos(0.3)
    assert math.hypot(x[2] - cx, y[2] - cy) == pytest.approx(r, abs=1e-9)
    assert h[3] == pytest.approx(0.3 + 30 * k)
    # spiral: curvature linear, heading the integral of it
    assert kap[4] == pytest.approx(k + 0.5 * (-0.01 - k))
    assert h[5] == pytest.approx(0.3 + 30 * k + 20 * 0.5 * (k - 0.01))


def test_reference_line_starts_agree_with_scenariogeneration():
    xodr = pytest.importorskip("scenariogeneration.xodr")
    line = ReferenceLine(0.0, 0.0, 1.0, (RoadSegment("spiral", 25.0, 0.0, 0.04),
                                         RoadSegment("arc", 20.0, 0.04, 0.04),
                                         RoadSegment("spiral", 25.0, 0.04, -0.01)))
    starts = line.starts()
    for seg, (_, x0, y0, h0), nxt in zip(line.segments, starts, starts[1:] + [None],
                                         strict=True):
        geom = xodr.Spiral(seg.curvature_start, seg.curvature_end, length=seg.length) \
            if seg.kind == "spiral" else xodr.Arc(seg.curvature_start, length=seg.length)
        ex, ey, eh, _ = geom.get_end_data(x0, y0, h0)
        end = nxt[1:] if nxt is not None else tuple(float(v[0]) for v in
                                                   line.evaluate([line.length])[:3])
        assert (ex, ey) == pytest.approx(end[:2], abs=1e-6)
        assert eh == pytest.approx(end[2], abs=1e-9)


def test_fit_recovers_a_road_of_lines_arcs_and_spirals():
    k = 0.02
    true = ReferenceLine(10.0, 5.0, 0.3, (RoadSegment("line", 30), RoadSegment("spiral", 20, 0, k),
                                          RoadSegment("arc", 40, k, k),
                                          RoadSegment("spiral", 20, k, 0),
                                          RoadSegment("line", 30)))
    _, x, y, _, _ = true.sample(1.0)
    fitted, error = fit_reference_line(np.c_[x, y], margin=20.0)
    assert error < 0.05
    _, fx, fy, _, _ = fitted.sample(1.0)
    s, t = true.project(np.c_[fx, fy])
    inside = (s > 0) & (s < true.length)
    assert np.max(np.abs(t[inside])) < 0.05
    assert fitted.length == pytest.approx(true.length + 40.0, abs=1.0)  # + both margins
    assert {seg.kind for seg in fitted.segments} <= {"line", "arc", "spiral"}


def test_case_roads_straight_bend_and_crossing(db):
    def roads(cid, mode="auto"):
        t1, t2 = db.trajectory(cid, 1), db.trajectory(cid, 2)
        curvature = float(db.cases.set_index("case_id").loc[cid, "road_curvature"])
        return case_roads(t1.x, t1.y, t1.yaw, t2.x, t2.y, t2.yaw, road_curvature=curvature,
                          mode=mode), t1, t2

    straight, t1, t2 = roads(10)  # rear-end on a straight road
    assert straight.mode == "straight" and len(straight.roads) == 1
    road = straight.roads[0]
    # the ego starts in the middle of the right lane; both vehicles are on the road
    s, t = road.reference.project([[t1.x[0], t1.y[0]]])
    assert t[0] == pytest.approx(-road.lane_width / 2, abs=1e-9)
    assert road.contains(np.c_[t1.x, t1.y]) and road.contains(np.c_[t2.x, t2.y])
    bend, t1, t2 = roads(3)  # head-on in a bend: one road fitted to both paths
    assert bend.mode == "path" and len(bend.roads) == 1
    assert bend.roads[0].contains(np.c_[t2.x, t2.y])
    crossing, _, _ = roads(2)  # crossing paths: a road each
    assert len(crossing.roads) == 2
    with pytest.raises(ParameterError, match="road mode"):
        roads(2, mode="curvy")


def test_straight_road_follows_the_scene_not_a_lane_change(db):
    import pandas as pd

    truth = pd.read_parquet(
        ROOT / "scenarios" / "databases" / "default" / "ground_truth_cases.parquet")
    truth = truth.set_index("case_id")
    cases = db.cases[(db.cases.road_curvature == 0) & (db.cases.accident_type != 321)]
    worst = 0.0
    for cid in cases.case_id.iloc[::12]:  # 40 of the straight same-road cases
        t1, t2 = db.trajectory(cid, 1), db.trajectory(cid, 2)
        roads = case_roads(t1.x, t1.y, t1.yaw, t2.x, t2.y, t2.yaw)
        assert len(roads.roads) == 1
        heading = roads.roads[0].reference.heading
        # the generator's road direction (either way along the road)
        error = abs(math.remainder(heading - truth.loc[cid, "scene_rotation"], math.pi))
        worst = max(worst, error)
    assert worst < math.radians(0.5)


# ----------------------------------------------------------------------------
# export: schema validity and round trip
# ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def exported(db, tmp_path_factory):
    _needs_extra()
    from vfs.interop.openscenario import export_case

    out = tmp_path_factory.mktemp("xosc")
    return out, [export_case(db, cid, out) for cid in (1, 2, 3, 10)]


def test_exported_files_validate_against_the_asam_schemas(exported):
    from vfs.interop.schemas import schema_errors

    _, results = exported
    for r in results:
        assert schema_errors(r.xosc) == [], r.xosc
        assert schema_errors(r.xodr) == [], r.xodr


def test_schema_validation_catches_an_invalid_file(exported, tmp_path):
    from vfs.interop.schemas import validate_file

    _, results = exported
    root = ET.parse(results[0].xosc).getroot()
    root.find("Entities/ScenarioObject/Vehicle").attrib.pop("vehicleCategory")
    bad = tmp_path / "bad.xosc"
    ET.ElementTree(root).write(bad)
    with pytest.raises(DataError, match="vehicleCategory"):
        validate_file(bad)


def test_exported_scenario_content(exported, db):
    _, results = exported
    r = results[0]
    root = ET.parse(r.xosc).getroot()
    assert root.find("FileHeader").get("revMinor") == "3"
    names = [o.get("name") for o in root.findall("Entities/ScenarioObject")]
    assert names == ["Ego", "Target"]
    assert root.find("RoadNetwork/LogicFile").get("filepath") == r.xodr.name
    assert not root.findall("ParameterDeclarations/ParameterDeclaration")
    timing = root.find(".//FollowTrajectoryAction/TimeReference/Timing")
    assert timing.get("domainAbsoluteRelative") == "absolute"
    # init position = first vertex; end condition = last vertex time
    vertices = root.findall(".//ManeuverGroup/Actors/EntityRef[@entityRef='Ego']/../.."
                            "//Polyline/Vertex")
    first = vertices[0].find("Position/WorldPosition")
    tele = root.find("Storyboard/Init/Actions/Private[@entityRef='Ego']//WorldPosition")
    assert (tele.get("x"), tele.get("y")) == (first.get("x"), first.get("y"))
    last_times = [float(v.get("time")) for v in root.findall(".//Polyline/Vertex")]
    stop = root.find("Storyboard/StopTrigger//SimulationTimeCondition")
    assert float(stop.get("value")) == pytest.approx(max(last_times))
    # the ego vertex is the rear axle: CG - L2 along the yaw
    part = db.participants[(db.participants.case_id == 1) & (db.participants.participant == 1)]
    l2 = float(part.wheelbase.iloc[0] - part.cg_to_front_axle.iloc[0])
    tr = db.trajectory(1, 1)
    assert float(first.get("x")) == pytest.approx(tr.x[0] - l2 * math.cos(tr.yaw[0]), abs=1e-6)
    assert float(first.get("y")) == pytest.approx(tr.y[0] - l2 * math.sin(tr.yaw[0]), abs=1e-6)
    mass = float(root.find("Entities/ScenarioObject/Vehicle").get("mass"))
    assert mass == pytest.approx(float(part.mass.iloc[0]))


def test_round_trip_restores_the_case(exported, db, tmp_path):
    from vfs.database import load_database, save_database

    _, results = exported
    back = import_xosc([r.xosc for r in results])
    folder = save_database(back, tmp_path / "imported")
    back = load_database(folder)
    for cid in (1, 2, 3, 10):
        for p in (1, 2):
            a, b = db.trajectory(cid, p), back.trajectory(cid, p)
            assert len(a) == len(b)
            assert np.max(np.abs(a.t - b.t)) < 1e-9
            # 1 cm asked; positions are written to the micrometre, headings to 1e-9 rad
            assert np.max(np.hypot(a.x - b.x, a.y - b.y)) < 2e-6
            assert np.max(np.abs(a.yaw - b.yaw)) < 1e-9
            # speeds come from the positions: equal where the record is consistent
            assert np.max(np.abs(a.speed - b.speed)) < 0.1
    cols = ["mass", "length", "width", "wheelbase", "cg_to_front_axle", "front_overhang",
            "track_width", "cg_height"]
    pa = db.participants.set_index(["case_id", "participant"]).loc[
        back.participants.set_index(["case_id", "participant"]).index, cols]
    pb = back.participants.set_index(["case_id", "participant"])[cols]
    assert np.allclose(pa.to_numpy(float), pb.to_numpy(float), rtol=0, atol=1e-9)
    ca = db.cases.set_index("case_id").loc[[1, 2, 3, 10]]
    cb = back.cases.set_index("case_id").loc[[1, 2, 3, 10]]
    for col in ("accident_type", "road_friction", "road_curvature", "collision"):
        assert (ca[col] == cb[col]).all(), col


def test_crash_test_with_a_barrier_round_trips(tmp_path):
    _needs_extra()
    from vfs.interop.openscenario import export_case
    from vfs.interop.schemas import schema_errors

    tests = open_database(ROOT / "scenarios" / "databases" / "crash-tests")
    r = export_case(tests, 5, tmp_path)
    assert schema_errors(r.xosc) == []
    root = ET.parse(r.xosc).getroot()
    assert root.find("Entities/ScenarioObject/MiscObject").get("miscObjectCategory") == "barrier"
    back = import_xosc(r.xosc)
    assert bool(back.participants.fixed_object.iloc[1])
    a, b = tests.trajectory(5, 2), back.trajectory(5, 2)
    assert np.max(np.hypot(a.x - b.x, a.y - b.y)) < 2e-6


def test_study_motion_replays_the_study_and_exports(db, tmp_path):
    _needs_extra()
    from vfs.interop.motion import study_motion
    from vfs.interop.openscenario import export_case
    from vfs.interop.schemas import schema_errors
    from vfs.study import run_study

    study = run_study(db, "three-stage", tmp_path / "study", engine="serial",
                      where="case_id IN (3, 4)", chunk_size=2, seed=3, progress=False)
    runs = study.table.set_index(["case_id", "system"])
    for cid in (3, 4):
        m = study_motion(tmp_path / "study", "default", cid, "three-stage")
        row = runs.loc[(cid, "three-stage")]
        assert m.collided == bool(row["collided"])
        if m.collided:
            assert m.impact_time == pytest.approx(float(row["impact_time"]), abs=1e-9)
        assert "matches" in m.notes[-1]
        # the treated motion never moves faster than the recorded one at the same time
        rec = db.trajectory(cid, 1)
        p1 = m.participants[0]
        common = p1.t <= rec.t.iloc[-1]
        assert np.all(p1.speed[common] <= np.interp(p1.t[common], rec.t, rec.speed) + 1e-6)
        r = export_case(db, cid, tmp_path / "out", motion=m)
        assert r.xosc.name == f"case_{cid}_three-stage.xosc"
        assert schema_errors(r.xosc) == []
    with pytest.raises(ParameterError, match="no system"):
        study_motion(tmp_path / "study", "default", 3, "no-such-system")


# ----------------------------------------------------------------------------
# import of files written elsewhere
# ----------------------------------------------------------------------------

FOREIGN = """<?xml version="1.0" encoding="UTF-8"?>
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="0" date="2024-01-01T00:00:00" description="x" author="y"/>
  <ParameterDeclarations>
    <ParameterDeclaration name="HeroMass" parameterType="double" value="1800"/>
  </ParameterDeclarations>
  <CatalogLocations/>
  <RoadNetwork><LogicFile filepath="road.xodr"/></RoadNetwork>
  <Entities>
    <ScenarioObject name="Lead">
      <Vehicle name="lead" vehicleCategory="car">
        <BoundingBox><Center x="1.4" y="0" z="0.8"/>
          <Dimensions width="1.8" length="4.5" height="1.5"/></BoundingBox>
        <Performance maxSpeed="50" maxAcceleration="5" maxDeceleration="10"/>
        <Axles>
          <FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.7"
            positionZ="0.3"/>
          <RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0"
            positionZ="0.3"/>
        </Axles>
      </Vehicle>
    </ScenarioObject>
    <ScenarioObject name="hero">
      <Vehicle name="hero" vehicleCategory="car" mass="$HeroMass">
        <BoundingBox><Center x="1.5" y="0" z="0.8"/>
          <Dimensions width="1.9" length="4.8" height="1.5"/></BoundingBox>
        <Performance maxSpeed="50" maxAcceleration="5" maxDeceleration="10"/>
        <Axles>
          <FrontAxle maxSteering="0.5" wheelDiameter="0.6" trackWidth="1.6" positionX="2.9"
            positionZ="0.3"/>
          <RearAxle maxSteering="0" wheelDiameter="0.6" trackWidth="1.6" positionX="0"
            positionZ="0.3"/>
        </Axles>
      </Vehicle>
    </ScenarioObject>
  </Entities>
  <Storyboard>
    <Init><Actions/></Init>
    <Story name="s"><Act name="a">
      {groups}
      <StartTrigger/>
    </Act></Story>
    <StopTrigger/>
  </Storyboard>
</OpenSCENARIO>
"""

GROUP = """<ManeuverGroup name="{name}_g" maximumExecutionCount="1">
  <Actors selectTriggeringEntities="false"><EntityRef entityRef="{name}"/></Actors>
  <Maneuver name="m"><Event name="e" priority="overwrite"><Action name="f"><PrivateAction>
    <RoutingAction><FollowTrajectoryAction>
      <Trajectory name="t" closed="false">
        <Shape><Polyline>{vertices}</Polyline></Shape></Trajectory>
      <TimeReference>
        <Timing domainAbsoluteRelative="absolute" scale="1" offset="{offset}"/></TimeReference>
      <TrajectoryFollowingMode followingMode="position"/>
    </FollowTrajectoryAction></RoutingAction>
  </PrivateAction></Action><StartTrigger/></Event></Maneuver>
</ManeuverGroup>"""

ROAD = """<?xml version="1.0" encoding="UTF-8"?>
<OpenDRIVE><header revMajor="1" revMinor="6"/>
  <road id="7" length="200" junction="-1"><planView>
    <geometry s="0" x="-50" y="1.75" hdg="0" length="200"><line/></geometry></planView>
    <lanes><laneSection s="0"><center><lane id="0" type="none"/></center>
      <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/>
        <material sOffset="0" friction="0.55"/></lane></right>
    </laneSection></lanes></road>
</OpenDRIVE>
"""


def _vertices(xs, t_step, y=0.0, with_h=True):
    out = []
    for k, x in enumerate(xs):
        h = ' h="0"' if with_h else ""
        out.append(f'<Vertex time="{k * t_step}"><Position><WorldPosition x="{x}" y="{y}"'
                   f"{h}/></Position></Vertex>")
    return "".join(out)


def _foreign(tmp_path, lead_vertices=None, hero_vertices=None, name="f.xosc"):
    lead = lead_vertices or _vertices([20, 25, 30, 35, 40], 0.5)
    hero = hero_vertices or _vertices([0, 10, 20, 30, 40], 0.5, with_h=False)
    text = FOREIGN.replace("{groups}", GROUP.format(name="Lead", vertices=lead, offset=2)
                           + GROUP.format(name="hero", vertices=hero, offset=2))
    (tmp_path / "road.xodr").write_text(ROAD)
    (tmp_path / name).write_text(text)
    return tmp_path / name


def test_import_of_a_foreign_scenario(tmp_path):
    back = import_xosc(_foreign(tmp_path))
    case = back.cases.iloc[0]
    assert case.accident_type == 799 and case.road_friction == pytest.approx(0.55)
    assert case.road_curvature == 0.0
    parts = back.participants.set_index("participant")
    # the ego ("hero") is participant 1, its mass from the parameter declaration
    assert parts.loc[1, "mass"] == 1800.0 and parts.loc[1, "wheelbase"] == pytest.approx(2.9)
    assert parts.loc[1, "front_overhang"] == pytest.approx(1.5 + 2.4 - 2.9)
    tr = back.trajectory(case.case_id, 1)
    # vertices 0.5 s apart filled to the schema's spacing; times = time + Timing offset
    assert tr.t.iloc[0] == pytest.approx(2.0) and np.diff(tr.t).max() <= 0.1 + 1e-12
    # CG = rear axle + L2 ahead (heading from the direction of travel: +x)
    l2 = parts.loc[1, "wheelbase"] - parts.loc[1, "cg_to_front_axle"]
    assert tr.x.iloc[0] == pytest.approx(l2) and np.allclose(tr.yaw, 0.0)
    assert tr.speed.to_numpy() == pytest.approx(20.0)
    # the hero (20 m/s) reaches the lead (10 m/s) at the end: the replay finds the collision
    assert bool(case.collision)


@pytest.mark.parametrize("change, message", [
    (('<WorldPosition x="0" y="0.0"/>', '<LanePosition roadId="7" laneId="-1" s="0" '
      'offset="0"/>'), "LanePosition"),
    (('mass="$HeroMass"', 'mass="${$HeroMass * 2}"'), "expressions are not supported"),
    (('mass="$HeroMass"', 'mass="$Nope"'), "undeclared parameter"),
])
def test_import_errors_name_the_element(tmp_path, change, message):
    file = _foreign(tmp_path)
    file.write_text(file.read_text().replace(*change, 1))
    with pytest.raises(DataError, match=message):
        import_xosc(file)


def test_import_needs_two_entities_with_trajectories(tmp_path):
    file = _foreign(tmp_path)
    text = file.read_text()
    start = text.index('<ManeuverGroup name="Lead_g"')
    end = text.index("</ManeuverGroup>", start) + len("</ManeuverGroup>")
    file.write_text(text[:start] + text[end:])
    with pytest.raises(DataError, match="need two entities"):
        import_xosc(file)


def test_missing_extra_names_it(db, tmp_path, monkeypatch):
    from vfs.interop.openscenario import export_case

    monkeypatch.setitem(sys.modules, "scenariogeneration", None)
    monkeypatch.setitem(sys.modules, "scenariogeneration.xodr", None)
    with pytest.raises(MissingExtraError, match=r'vfs-accident\[xosc\]'):
        export_case(db, 1, tmp_path)


def test_opendrive_reader_reads_what_the_export_writes(exported):
    _, results = exported
    r = results[2]  # the bend: fitted road
    roads = read_opendrive(r.xodr)
    assert len(roads) == len(r.roads.roads)
    written = r.roads.roads[0].reference
    assert roads[0].reference.length == pytest.approx(written.length)
    pts = np.c_[written.sample(7.0)[1:3]]
    assert np.max(np.abs(roads[0].reference.project(pts)[1])) < 1e-6
    assert roads[0].friction == pytest.approx(r.roads.roads[0].friction)


# ----------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------


def test_cli_export_import_validate(tmp_path, capsys):
    _needs_extra()
    from vfs.cli import main

    out = tmp_path / "xo"
    assert main(["db", "export-xosc", "--db", "default", "--case", "4", "--out", str(out),
                 "--validate"]) == 0
    assert "validate against the ASAM schemas" in capsys.readouterr().out
    assert main(["db", "import-xosc", str(out / "case_4.xosc"), "--out",
                 str(tmp_path / "db")]) == 0
    assert main(["db", "validate", str(tmp_path / "db")]) == 0
    assert main(["db", "export-xosc", "--db", "default", "--case", "4", "--out", str(out),
                 "--run", str(tmp_path)]) == 2
    assert "--run needs --system" in capsys.readouterr().err
