"""Bring your own reef: GeoJSON in longitude/latitude -> scenario -> plan -> GeoJSON back."""

import copy
import json
import math

import numpy as np
import pytest
from pyproj import Geod
from shapely.geometry import LineString, Point, shape

from cotsfleet.cli import main
from cotsfleet.geo import LocalFrame, ReefOptions, scenario_from_geojson
from cotsfleet.geo.frame import utm_crs
from hfc_core.formats.scenario import problem_from_dict
from hfc_core.model.errors import ScenarioError

MOORE_REEF = (146.2, -16.87)  # lon, lat: a reef off Cairns, UTM zone 55 south


def _reef(frame: LocalFrame) -> dict:
    """A small reef in lon/lat: a no-go reef flat between the boat (north) and the
    rendezvous (south), a cay to the east, COTS spots on both sides of the flat."""

    def ll(x, y, z=None):
        lon, lat = frame.to_lonlat(x, y)
        out = [round(float(lon), 8), round(float(lat), 8)]
        return out if z is None else [*out, z]

    def poly(xy):
        ring = [ll(x, y) for x, y in xy]
        return {"type": "Polygon", "coordinates": [ring + ring[:1]]}

    def feature(geometry, **props):
        return {"type": "Feature", "properties": props, "geometry": geometry}

    flat = [(-300, -80), (300, -100), (320, 90), (0, 130), (-310, 70)]
    cay = [(420, -40), (520, -30), (510, 40), (430, 30)]
    features = [feature(poly(flat), role="no_go", name="reef flat"),
                feature(poly(cay), role="land", name="cay"),
                feature({"type": "Point", "coordinates": ll(0, 400)}, role="start"),
                feature({"type": "Point", "coordinates": ll(40, -400)}, role="rendezvous")]
    rng = np.random.default_rng(4)
    for i in range(16):
        side = 1 if i % 2 else -1
        x, y = rng.uniform(-250, 250), side * rng.uniform(160, 260)
        props = {"role": "cots", "priority": float(rng.integers(1, 100))}
        if i % 3 == 0:
            props["service_s"] = 70.0
        features.append(feature({"type": "Point", "coordinates": ll(x, y, -5.0)}, **props))
    features.append(feature({"type": "Point", "coordinates": ll(10, 200, -6)}, role="truth",
                            priority=40, task=None))
    return {"type": "FeatureCollection", "name": "moore-test", "features": features}


@pytest.fixture
def reef() -> dict:
    return _reef(LocalFrame.centred_on(*MOORE_REEF))


@pytest.fixture
def reef_file(tmp_path, reef):
    path = tmp_path / "reef.geojson"
    path.write_text(json.dumps(reef))
    return path


def _polygons(doc: dict) -> list:
    return [shape(f["geometry"]) for f in doc["features"]
            if f["properties"].get("role") in ("land", "no_go")]


def test_plan_projected_back_lies_in_the_water(reef, reef_file, tmp_path, capsys):
    scenario, plan = tmp_path / "s.json", tmp_path / "plan.geojson"
    assert main(["scenario", "--from-geojson", str(reef_file), "-o", str(scenario),
                 "--vehicles", "2", "--battery-s", "2400"]) == 0
    assert main(["plan", str(scenario), "--iterations", "40", "--geojson", str(plan)]) == 0
    capsys.readouterr()
    out = json.loads(plan.read_text())
    routes = [f for f in out["features"] if f["properties"]["role"] == "route"]
    assert [r["properties"]["vehicle"] for r in routes] == ["auv1", "auv2"]
    forbidden = _polygons(reef)
    start = reef["features"][2]["geometry"]["coordinates"]
    end = reef["features"][3]["geometry"]["coordinates"]
    # The fixture means something: going straight from the boat to the rendezvous hits land.
    assert LineString([start, end]).intersects(forbidden[0])
    treated = 0
    for r in routes:
        line = LineString(r["geometry"]["coordinates"])
        assert line.coords[0][:2] == pytest.approx(start, abs=1e-7)
        assert line.coords[-1][:2] == pytest.approx(end, abs=1e-7)
        for poly in forbidden:  # neither the line nor its ends inside any polygon
            assert poly.relate_pattern(line, "FF*******"), (r["properties"], poly)
        treated += len(r["properties"]["tasks"])
    assert treated > 0
    # Spots come back where the file put them (local metres are rounded to 1 cm).
    given = [f["geometry"]["coordinates"] for f in reef["features"]
             if f["properties"]["role"] == "cots"]
    back = [f["geometry"]["coordinates"] for f in out["features"]
            if f["properties"]["role"] == "cots"]
    assert np.allclose(np.array(back)[:, :2], np.array(given)[:, :2], atol=2e-7)
    assert all(p[2] == -5.0 for p in back)


def test_projection_round_trips_and_keeps_distances():
    rng = np.random.default_rng(0)
    lon = MOORE_REEF[0] + rng.uniform(-0.02, 0.02, 50)
    lat = MOORE_REEF[1] + rng.uniform(-0.02, 0.02, 50)
    frame = LocalFrame.around(lon, lat)
    x, y = frame.to_local(lon, lat)
    assert x.min() > 0 and y.min() > 0  # the origin sits south-west of the data
    lon2, lat2 = frame.to_lonlat(x, y)
    np.testing.assert_allclose(lon2, lon, atol=1e-9)
    np.testing.assert_allclose(lat2, lat, atol=1e-9)
    _, _, geodesic = Geod(ellps="WGS84").inv(lon[:-1], lat[:-1], lon[1:], lat[1:])
    local = np.hypot(np.diff(x), np.diff(y))
    np.testing.assert_allclose(local, geodesic, rtol=1e-3)  # UTM: < 0.1 % scale error
    assert LocalFrame.of_scenario({"geo": frame.to_dict()}) == frame


@pytest.mark.parametrize("lon,lat,epsg", [(146.2, -16.87, 32755), (145.4, -14.6, 32755),
                                          (151.9, -23.4, 32756), (3.0, 50.0, 32631),
                                          (-70.0, 40.0, 32619), (180.0, 1.0, 32660)])
def test_utm_zone_from_the_data(lon, lat, epsg):
    assert utm_crs(lon, lat) == f"EPSG:{epsg}"


def test_defaults_and_truth(reef):
    doc = scenario_from_geojson(reef, ReefOptions(seed=3))
    assert len(doc["vehicles"]) == 3 and doc["name"] == "moore-test"
    service = [t["service_s"] for t in doc["tasks"]]
    assert [service[i] for i in range(0, 16, 3)] == [70.0] * 6  # given in the file
    drawn = [s for i, s in enumerate(service) if i % 3]
    assert all(60.0 <= s <= 90.0 for s in drawn) and len(set(drawn)) > 1
    assert scenario_from_geojson(reef, ReefOptions(seed=3)) == doc  # seeded
    assert [t["service_s"] for t in scenario_from_geojson(
        reef, ReefOptions(seed=4))["tasks"]][::3] == [70.0] * 6
    fixed = scenario_from_geojson(reef, ReefOptions(service_s=80.0))
    assert {t["service_s"] for i, t in enumerate(fixed["tasks"]) if i % 3} == {80.0}
    assert doc["geo"]["crs"] == "EPSG:32755" and doc["geo"]["forbidden_roles"] == ["no_go",
                                                                                     "land"]
    truth = doc["truth"]
    assert truth["spots"][0]["task"] is None and truth["p_detect"] == 0.9
    assert [t["id"] for t in doc["tasks"]] == list(range(1, 17))
    problem_from_dict(doc)


def test_truth_refers_to_predicted_spots_by_id(reef):
    cots = [f for f in reef["features"] if f["properties"]["role"] == "cots"]
    for k, f in enumerate(cots):
        f["properties"]["id"] = 100 + k
    truth = reef["features"][-1]["properties"]
    truth["task"] = 105
    doc = scenario_from_geojson(reef, ReefOptions())
    assert doc["tasks"][5]["id"] == 105 and doc["truth"]["spots"][0]["task"] == 5


def test_one_start_per_vehicle(reef):
    frame = LocalFrame.centred_on(*MOORE_REEF)
    second = {"type": "Feature", "properties": {"role": "start"},
              "geometry": {"type": "Point", "coordinates": [float(c) for c in
                                                            frame.to_lonlat(-100, 450)]}}
    reef["features"].insert(3, second)
    doc = scenario_from_geojson(reef, ReefOptions())
    assert len(doc["vehicles"]) == 2  # one per start point
    assert doc["vehicles"][0]["start"] != doc["vehicles"][1]["start"]
    assert doc["vehicles"][0]["rendezvous"] == doc["vehicles"][1]["rendezvous"]  # shared
    with pytest.raises(ScenarioError, match="2 start points for 3 vehicles"):
        scenario_from_geojson(reef, ReefOptions(vehicles=3))


def test_multipolygon_and_simplify(reef):
    flat = reef["features"][0]["geometry"]
    cay = reef["features"][1]
    cay["geometry"] = {"type": "MultiPolygon",
                       "coordinates": [cay["geometry"]["coordinates"], flat["coordinates"]]}
    doc = scenario_from_geojson(reef, ReefOptions())
    assert doc["geo"]["forbidden_roles"] == ["no_go", "land", "land"]
    # Simplifying never shrinks a polygon: the simplified outline holds the original one.
    many = _circle(LocalFrame.centred_on(*MOORE_REEF), 200)
    reef["features"][0]["geometry"] = many
    coarse = scenario_from_geojson(reef, ReefOptions(simplify_m=5.0))
    fine = scenario_from_geojson(reef, ReefOptions())
    assert len(coarse["forbidden"][0]) < len(fine["forbidden"][0]) / 3
    from shapely.geometry import Polygon
    assert Polygon(coarse["forbidden"][0]).buffer(1e-6).contains(Polygon(fine["forbidden"][0]))


def _circle(frame: LocalFrame, n: int) -> dict:
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    lon, lat = frame.to_lonlat(250 * np.cos(t), 100 * np.sin(t))
    ring = [[float(a), float(b)] for a, b in zip(lon, lat)]
    return {"type": "Polygon", "coordinates": [ring + ring[:1]]}


def _set(path, value):
    def change(doc):
        target = doc
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
    return change


def _drop_role(role):
    def change(doc):
        doc["features"] = [f for f in doc["features"] if f["properties"].get("role") != role]
    return change


def _move_onto_flat(doc):
    flat = shape(doc["features"][0]["geometry"])
    doc["features"][5]["geometry"]["coordinates"] = [flat.centroid.x, flat.centroid.y]


def _with_hole(doc):
    outer = doc["features"][0]["geometry"]["coordinates"][0]
    c = shape(doc["features"][0]["geometry"]).centroid
    d = 0.0003
    hole = [[c.x - d, c.y - d], [c.x + d, c.y - d], [c.x + d, c.y + d], [c.x - d, c.y - d]]
    doc["features"][0]["geometry"]["coordinates"] = [outer, hole]


def _bow_tie(doc):
    ring = doc["features"][1]["geometry"]["coordinates"][0]
    ring[1], ring[2] = ring[2], ring[1]


def _projected(doc):
    for f in doc["features"][2:]:
        lon, lat = f["geometry"]["coordinates"][:2]
        f["geometry"]["coordinates"] = [lon * 3000.0, lat * -500000.0]


BAD = {
    "a list": (lambda d: d.clear() or d.update({"type": "Topology"}), "not a GeoJSON"),
    "no role": (_set(["features", 4, "properties"], {"priority": 3}), "feature 4: no 'role'"),
    "unknown role": (_set(["features", 4, "properties", "role"], "reef"), "unknown role 'reef'"),
    "point on the flat": (_move_onto_flat, "feature 5: the cots point at lon"),
    "lat out of range": (_set(["features", 6, "geometry", "coordinates"], [146.2, -96.0]),
                         "feature 6: [146.2, -96.0] is not longitude/latitude"),
    "projected metres": (_projected, "is not longitude/latitude"),
    "no cots": (_drop_role("cots"), "no feature with role 'cots'"),
    "no start": (_drop_role("start"), "no feature with role 'start'"),
    "hole": (_with_hole, "hole(s)"),
    "self-intersecting": (_bow_tie, "feature 1 ('cay'): invalid polygon"),
    "point as polygon": (_set(["features", 1, "geometry"], {"type": "Point",
                                                            "coordinates": [146.2, -16.87]}),
                         "needs a Polygon or MultiPolygon"),
    "cots without priority": (_set(["features", 7, "properties"], {"role": "cots"}),
                              "needs a numeric 'priority'"),
    "negative priority": (_set(["features", 7, "properties", "priority"], -1),
                          "priority must be a number >= 0"),
    "truth of an unknown spot": (_set(["features", -1, "properties", "task"], 999),
                                 "task 999 is not the id of a cots feature"),
    "declared projected crs": (_set(["crs"], {"type": "name", "properties": {
        "name": "urn:ogc:def:crs:EPSG::32755"}}), "must be WGS 84 longitude/latitude"),
    "feature not a feature": (_set(["features", 3], [1, 2]), "feature 3: not a GeoJSON Feature"),
}


@pytest.mark.parametrize("how", list(BAD))
def test_bad_reefs_exit_2_with_one_line(how, reef, tmp_path, capsys):
    change, phrase = BAD[how]
    doc = copy.deepcopy(reef)
    change(doc)
    path = tmp_path / "bad.geojson"
    path.write_text(json.dumps(doc))
    assert main(["scenario", "--from-geojson", str(path), "-o", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet scenario: error:") and "\n" not in err
    assert phrase in err
    assert not (tmp_path / "s.json").exists()


@pytest.mark.parametrize("content,phrase", [("{not json", "not valid JSON"),
                                            ("[1, 2]", "not a GeoJSON")])
def test_bad_files_exit_2(content, phrase, tmp_path, capsys):
    path = tmp_path / "x.geojson"
    path.write_text(content)
    assert main(["scenario", "--from-geojson", str(path)]) == 2
    assert phrase in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["--from-geojson", "/nonexistent/reef.geojson"],
                                  ["--from-geojson", "."],
                                  ["--paper"], ["--tasks", "5"], ["--p-detect", "2"],
                                  ["--vehicles", "0"], ["--battery-s", "nan"],
                                  ["--simplify-m", "-1"]])
def test_bad_reef_flags_exit_2(argv, reef_file, capsys):
    full = ["scenario", *(["--from-geojson", str(reef_file)]
                          if "--from-geojson" not in argv else []), *argv]
    assert main(full) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cotsfleet scenario: error:") and "\n" not in err


def test_reef_only_flags_need_a_reef(capsys):
    assert main(["scenario", "--detect-radius-m", "10"]) == 2
    assert "only with --from-geojson" in capsys.readouterr().err


def test_plan_geojson_needs_a_geo_section(tmp_path, capsys):
    path = tmp_path / "paper.json"
    assert main(["scenario", "--paper", "-o", str(path)]) == 0
    assert main(["plan", str(path), "--geojson", str(tmp_path / "p.geojson")]) == 2
    assert "no 'geo' section" in capsys.readouterr().err
    assert not (tmp_path / "p.geojson").exists()


def test_cots_points_inside_the_cay_are_refused(reef):
    cay = shape(reef["features"][1]["geometry"])
    point = Point(cay.centroid.x, cay.centroid.y)
    reef["features"][9]["geometry"]["coordinates"] = [point.x, point.y]
    with pytest.raises(ScenarioError, match="inside a land polygon"):
        scenario_from_geojson(reef, ReefOptions())


def test_a_geo_section_in_degrees_is_refused(reef, tmp_path, capsys):
    doc = scenario_from_geojson(reef, ReefOptions())
    doc["geo"]["crs"] = "EPSG:4326"  # the schema's form, but not a metric CRS
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    assert main(["plan", str(path), "--iterations", "5", "--geojson",
                 str(tmp_path / "p.geojson")]) == 2
    assert "not a projected (metric) CRS" in capsys.readouterr().err
    with pytest.raises(ScenarioError, match="geo: missing field 'origin_m'"):
        LocalFrame.of_scenario({"geo": {"crs": "EPSG:32755"}})
