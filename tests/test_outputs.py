"""Plan outputs: GeoJSON against RFC 7946's rules, CSV units and arithmetic, CF NetCDF, atomic writes.

Independent references: the RFC's coordinate ranges and antimeridian rule (§3.1.9), the
latitude where a great circle meets a given longitude (the closed form of the Aviation
Formulary, Williams), leg arithmetic (SOG = distance / duration, end − start = duration),
and the bytes of the file written before an interrupted write.
"""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import optroute as orx
from optroute import _store
from optroute.plan import outputs
from optroute.plan.result import Plan

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
UNIT_SUFFIXES = ("_deg", "_kn", "_nm", "_h", "_kw", "_t", "_m", "_s", "_utc", "_t_per_h")


@pytest.fixture(scope="module")
def pacific() -> xr.Dataset:
    return orx.scenarios.uniform(
        hs_m=1.0, tp_s=6.0, bbox=(20, 50, 160, -160), start=T0, duration_h=120, resolution_deg=1.0
    )


@pytest.fixture(scope="module")
def zigzag(pacific) -> Plan:
    """East across the antimeridian, back west across it, and east again: three crossings."""
    wp = np.array([[35.0, 175.0], [36.0, -178.0], [38.0, 179.0], [39.0, -175.0]])
    return Plan.from_schedule(wp, [16.0, 15.0, 14.0], departure=T0, ship=SHIP, weather=pacific)


@pytest.fixture(scope="module")
def atlantic() -> Plan:
    wx = orx.scenarios.uniform(hs_m=2.0, tp_s=8.0, bbox=(-10, 10, -40, 0), start=T0, duration_h=120, resolution_deg=1.0)
    return Plan.from_schedule(
        [[0.0, -30.0], [1.0, -25.0], [0.5, -20.0]], [14.0, 12.0], departure=T0, ship=SHIP, weather=wx
    )


def positions(geometry: dict) -> list[list[list[float]]]:
    """The lines of a geometry as lists of positions (a Point as a one-position line)."""
    kind, coords = geometry["type"], geometry["coordinates"]
    if kind == "Point":
        return [[coords]]
    if kind == "LineString":
        return [coords]
    assert kind == "MultiLineString", kind
    return coords


def check_rfc7946(doc: dict) -> None:
    """The RFC 7946 rules a consumer relies on."""
    assert doc["type"] == "FeatureCollection"
    for feature in doc["features"]:
        assert feature["type"] == "Feature" and isinstance(feature["properties"], dict)
        for line in positions(feature["geometry"]):
            for pos in line:
                assert len(pos) == 2 and all(isinstance(v, float | int) for v in pos)  # [lon, lat], no altitude
                assert -180.0 <= pos[0] <= 180.0 and -90.0 <= pos[1] <= 90.0
            for a, b in zip(line, line[1:], strict=False):
                assert abs(b[0] - a[0]) <= 180.0  # §3.1.9: no segment spans more than 180° of longitude


def _geodesic_lat_at_antimeridian(la0, lo0, la1, lo1):
    from pyproj import Geod

    g = Geod(ellps="WGS84")
    az, _, d = g.inv(lo0, la0, lo1, la1)
    lo, hi = 0.0, d
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lon, _, _ = g.fwd(lo0, la0, az, mid)
        lo, hi = (mid, hi) if (lon > 0.0) == (lo0 > 0.0) else (lo, mid)
    return g.fwd(lo0, la0, az, 0.5 * (lo + hi))[1]


def test_geojson_follows_rfc7946_and_splits_every_antimeridian_crossing(zigzag):
    doc = json.loads(json.dumps(zigzag.to_geojson(), allow_nan=False))
    check_rfc7946(doc)
    track = doc["features"][0]
    assert track["properties"]["kind"] == "track"
    parts = track["geometry"]["coordinates"]
    assert track["geometry"]["type"] == "MultiLineString" and len(parts) == 4  # three crossings
    wp = zigzag.waypoints
    for k, (left, right) in enumerate(zip(parts, parts[1:], strict=False)):
        assert abs(left[-1][0]) == 180.0 and right[0][0] == -left[-1][0]
        assert left[-1][1] == right[0][1]
        # the crossing latitude on leg k's WGS84 geodesic, by bisection with pyproj's Geod directly
        expected = _geodesic_lat_at_antimeridian(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1])
        assert left[-1][1] == pytest.approx(expected, abs=1e-9)
    assert parts[0][0] == [175.0, 35.0] and parts[-1][-1] == [-175.0, 39.0]


def test_geojson_leg_and_waypoint_features_carry_unit_named_properties(zigzag):
    doc = zigzag.to_geojson()
    legs = [f for f in doc["features"] if f["properties"]["kind"] == "leg"]
    points = [f for f in doc["features"] if f["properties"]["kind"] == "waypoint"]
    assert len(legs) == 3 and len(points) == 4
    assert [f["geometry"]["type"] for f in legs] == ["MultiLineString"] * 3  # every leg crosses
    for k, f in enumerate(legs):
        p = f["properties"]
        assert p["leg"] == k
        for name in p:
            assert name in ("kind", "leg") or name.startswith("margin_") or name.endswith(UNIT_SUFFIXES), name
        assert p["distance_nm"] == pytest.approx(zigzag.legs["distance_nm"].iloc[k])
        assert p["sog_kn"] == pytest.approx(p["distance_nm"] / p["duration_h"], rel=1e-9)
        start = np.datetime64(p["start_time_utc"].rstrip("Z"))
        end = np.datetime64(p["end_time_utc"].rstrip("Z"))
        assert (end - start) / np.timedelta64(1, "s") == pytest.approx(p["duration_h"] * 3600.0, abs=1.0)
    for k, f in enumerate(points):
        assert f["geometry"]["coordinates"] == [float(zigzag.waypoints[k, 1]), float(zigzag.waypoints[k, 0])]
    # a calm-enough sea leaves bands that never apply: infinite margins are null, not "Infinity"
    assert all(
        v is None or math.isfinite(v) for f in legs for k, v in f["properties"].items() if k.startswith("margin_")
    )
    for name in ("departure_utc", "arrival_utc", "duration_h", "distance_nm", "total_fuel_t"):
        assert name in doc["features"][0]["properties"]


def test_a_route_that_stays_east_of_the_antimeridian_is_one_linestring(atlantic, tmp_path):
    path = outputs.write_geojson(atlantic, tmp_path / "plan.geojson")
    doc = json.loads(path.read_text())
    check_rfc7946(doc)
    assert doc["features"][0]["geometry"] == {
        "type": "LineString",
        "coordinates": [[-30.0, 0.0], [-25.0, 1.0], [-20.0, 0.5]],
    }


def test_csv_has_units_in_headers_and_consistent_rows(atlantic, tmp_path):
    path = atlantic.to_csv(tmp_path / "plan.csv")
    df = pd.read_csv(path)
    assert list(df.columns[:7]) == [
        "leg",
        "start_time_utc",
        "end_time_utc",
        "start_lat_deg",
        "start_lon_deg",
        "end_lat_deg",
        "end_lon_deg",
    ]
    for name in (
        "heading_deg",
        "sog_kn",
        "stw_kn",
        "distance_nm",
        "duration_h",
        "power_kw",
        "fuel_t",
        "hs_m",
        "period_s",
        "wave_from_deg",
        "encounter_period_s",
    ):
        assert name in df.columns
    for name in df.columns[1:]:
        assert name.startswith("margin_") or name.endswith(UNIT_SUFFIXES), name
    assert len(df) == 2
    np.testing.assert_allclose(df["start_lat_deg"], [0.0, 1.0])
    np.testing.assert_allclose(df["end_lon_deg"], [-25.0, -20.0])
    np.testing.assert_allclose(df["sog_kn"], df["distance_nm"] / df["duration_h"], rtol=1e-9)
    np.testing.assert_allclose(df["stw_kn"], [14.0, 12.0])
    start = pd.to_datetime(df["start_time_utc"]).dt.tz_localize(None)
    end = pd.to_datetime(df["end_time_utc"]).dt.tz_localize(None)
    assert df["start_time_utc"].str.endswith("Z").all()
    np.testing.assert_allclose((end - start).dt.total_seconds() / 3600.0, df["duration_h"], atol=1 / 3600)
    assert df["fuel_t"].sum() == pytest.approx(atlantic.total_fuel_t)


def test_netcdf_has_cf_attributes_and_time_encoding(atlantic, tmp_path):
    path = atlantic.to_netcdf(tmp_path / "plan.nc")
    raw = xr.open_dataset(path, decode_times=False)
    try:
        assert raw.attrs["Conventions"] == "CF-1.8"
        for name in ("title", "source", "history"):
            assert raw.attrs[name]
        for name, var in raw.variables.items():
            assert var.attrs.get("units") or name in ("leg_time", "waypoint_time"), name
            assert var.attrs.get("long_name"), name
        assert raw["waypoint_lat"].attrs["standard_name"] == "latitude"
        assert raw["waypoint_lat"].attrs["units"] == "degrees_north"
        assert raw["waypoint_lon"].attrs["units"] == "degrees_east"
        assert raw["hs_m"].attrs["standard_name"] == "sea_surface_wave_significant_height"
        assert raw["sog_kn"].attrs["units"] == "knot"
        assert raw["waypoint_time"].attrs["units"].startswith("hours since 2024-01-10")  # the departure
        assert raw["waypoint_time"].attrs["calendar"] == "proleptic_gregorian"
        assert raw["waypoint_time"].attrs["standard_name"] == "time"
        # hours since departure are the cumulative leg durations
        np.testing.assert_allclose(
            raw["waypoint_time"].values, np.concatenate([[0.0], np.cumsum(atlantic.legs["duration_h"])]), atol=1e-9
        )
    finally:
        raw.close()
    back = xr.load_dataset(path)
    deltas = (back["waypoint_time"].values - atlantic.times) / np.timedelta64(1, "ns")
    assert np.max(np.abs(deltas)) < 1e3  # within a microsecond
    np.testing.assert_allclose(back["fuel_t"].values, atlantic.legs["fuel_t"].to_numpy())


@pytest.mark.parametrize("fmt", ["geojson", "csv", "nc"])
def test_an_interrupted_write_leaves_the_old_file_intact(atlantic, tmp_path, monkeypatch, fmt):
    writer = {"geojson": outputs.write_geojson, "csv": outputs.write_csv, "nc": outputs.write_netcdf}[fmt]
    target = tmp_path / f"plan.{fmt}"
    target.write_bytes(b"the earlier, complete file")

    def half_then_fail(fh, data):
        fh.write(memoryview(data)[: len(data) // 2])
        fh.flush()
        raise KeyboardInterrupt  # Ctrl-C half-way through the write

    monkeypatch.setattr(_store, "_write_all", half_then_fail)
    with pytest.raises(KeyboardInterrupt):
        writer(atlantic, target)
    assert target.read_bytes() == b"the earlier, complete file"
    assert [p.name for p in tmp_path.iterdir()] == [f"plan.{fmt}"]  # no temporary file left behind
    monkeypatch.undo()
    writer(atlantic, target)
    assert target.read_bytes() != b"the earlier, complete file"


def test_writing_into_a_missing_folder_is_an_input_error(atlantic, tmp_path):
    with pytest.raises(orx.ConfigError, match="does not exist"):
        atlantic.to_csv(tmp_path / "nope" / "plan.csv")
    with pytest.raises(orx.ConfigError, match="is a directory"):
        outputs.write_geojson(atlantic, tmp_path)


def test_csv_text_round_trips_full_precision(atlantic):
    df = pd.read_csv(io.StringIO(outputs.csv_text(atlantic)))
    np.testing.assert_array_equal(df["fuel_t"].to_numpy(), atlantic.legs["fuel_t"].to_numpy())


def test_plan_plot_returns_the_profile_figure(atlantic):
    pytest.importorskip("optroute.plot.plan")
    from matplotlib.figure import Figure

    fig = atlantic.plot(title="test")
    assert isinstance(fig, Figure) and fig.axes


@pytest.mark.parametrize(
    ("latlon", "expected"),
    [
        # a waypoint on the antimeridian (stored as -180): the line breaks there, with no zero-length piece
        ([[35, 175], [35.5, -180], [36, -175]], [[[175, 35], [180, 35.5]], [[-180, 35.5], [-175, 36]]]),
        ([[35, -175], [35.5, 180], [36, 175]], [[[-175, 35], [-180, 35.5]], [[180, 35.5], [175, 36]]]),
        # starting on it: written on the side the first leg goes
        ([[35, 180], [36, 175]], [[[180, 35], [175, 36]]]),
        ([[35, 180], [36, -175]], [[[-180, 35], [-175, 36]]]),
        # touching it and turning back: one line
        ([[35, 170], [35.5, 180], [36, 175]], [[[170, 35], [180, 35.5], [175, 36]]]),
    ],
)
def test_vertices_on_the_antimeridian(latlon, expected):
    parts = outputs.split_antimeridian(np.array(latlon, dtype=float))
    assert parts == [[[float(x) for x in p] for p in part] for part in expected]
    check_rfc7946(
        {
            "type": "FeatureCollection",
            "features": [
                {"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": parts}}
            ],
        }
    )
