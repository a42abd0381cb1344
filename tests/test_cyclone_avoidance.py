"""Cyclone tracks, encounter geometry, the patent's APF baseline and the moving exclusion in the search (issue 19).

Hand-worked geometries for DCPA/TCPA; the trigger against its two conditions enumerated; readers
on small files written here (one crossing the antimeridian); brute-force checks that no APF track
enters R and no searched route enters R + margin, with the centre interpolated at every sampled time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import geodesy as geo
from optroute.geo.encounter import dcpa_tcpa, encounter, patent_trigger, risk_degree
from optroute.geo.tracks import Exclusion
from optroute.voyage.apf import apf_avoidance
from optroute.weather.cyclone import Cyclone, cyclone_radius_km, straight_track, tropical_cyclone
from optroute.weather.cyclone_tracks import (
    RANKINE_DECAY,
    CycloneTrack,
    TrackFormatError,
    read_atcf,
    read_ibtracs,
    read_track,
    write_atcf,
)

# ATCF b-deck lines in the documented layout (BASIN, CY, YYYYMMDDHH, TECHNUM, TECH, TAU, LatN/S, LonE/W, VMAX,
# MSLP, TY, RAD, WINDCODE, RAD1-4, RADP, RRP, MRD, ...): a storm crossing the antimeridian eastward.
BDECK_DATELINE = """\
WP, 30, 2022101300,   , BEST,   0, 152N, 1790E,  65,  975, TY,  34, NEQ,  120,  100,   80,  110, 1008,  200,  20,
WP, 30, 2022101300,   , BEST,   0, 152N, 1790E,  65,  975, TY,  50, NEQ,   50,   40,   30,   45, 1008,  200,  20,
WP, 30, 2022101306,   , BEST,   0, 160N, 1790W,  70,  970, TY,  34, NEQ,  130,  110,   90,  120, 1008,  200,  20,
WP, 30, 2022101312,   , BEST,   0, 168N, 1770W,  70,  970, TY,   0,    ,    0,    0,    0,    0, 1008,  200,  20,
"""

IBTRACS = """\
SID,SEASON,NUMBER,BASIN,SUBBASIN,NAME,ISO_TIME,NATURE,LAT,LON,WMO_WIND,WMO_PRES,USA_R34_NE,USA_R34_SE,USA_R34_SW,USA_R34_NW,USA_RMW,USA_POCI
 ,Year, , , , , ,degrees_north,degrees_east,kts,mb,nmile,nmile,nmile,nmile,nmile,mb
2022290N15180,2022,90,WP,MM,TEST,2022-10-13 06:00:00,TS,16.0,-179.0,70,970,130,110,90,120,20,1008
2022290N15180,2022,90,WP,MM,TEST,2022-10-13 00:00:00,TS,15.2,179.0,65,975,120,100,80,110,20,1008
2022290N15180,2022,90,WP,MM,TEST,2022-10-13 12:00:00,TS,16.8,-177.0,70,970,,,,,20,1008
"""


@pytest.fixture(scope="module")
def bdeck(tmp_path_factory):
    p = tmp_path_factory.mktemp("tracks") / "bwp302022.dat"
    p.write_text(BDECK_DATELINE)
    return p


def test_bdeck_reader_quadrants_and_antimeridian(bdeck):
    tr = read_atcf(bdeck)
    assert tr.time.size == 3 and tr.lead_h.tolist() == [0.0, 0.0, 0.0]
    assert tr.lon_deg.tolist() == [179.0, -179.0, -177.0]
    np.testing.assert_array_equal(tr.r34_nm[0], [120, 100, 80, 110])
    np.testing.assert_array_equal(tr.r50_nm[0], [50, 40, 30, 45])
    assert np.isnan(tr.r34_nm[2]).all()
    # midway between 179 E and 179 W the centre is on the antimeridian, not at 0 E
    s = tr.at(np.datetime64("2022-10-13T03:00"))
    assert abs(abs(float(s["lon"])) - 180.0) < 1e-9 and float(s["lat"]) == pytest.approx(15.6)
    # crossing eastward at 2 deg of longitude in 6 h at ~15.6 N: u = 120 cos(15.6) / 6 kn
    assert float(s["u_kn"]) == pytest.approx(120.0 * math.cos(math.radians(15.6)) / 6.0, rel=1e-9)


def test_force7_radius_from_34kn_radii_and_from_pressure(bdeck):
    tr = read_atcf(bdeck)
    # Rankine V r^x = const carried from 34 kn at the largest quadrant radius out to 13.9 m/s
    v7 = 13.9 * 3600 / 1852
    assert tr.r7_km[0] == pytest.approx(120 * 1.852 * (34 / v7) ** (1 / RANKINE_DECAY), rel=1e-12)
    # the last point has no radii: Holland with dp = POCI - p_c, R_max = MRD, B from VMAX
    vg = 70 / (3600 / 1852) / 0.8
    b = 1.15 * math.e * vg**2 / (38 * 100.0)
    assert tr.r7_km[2] == pytest.approx(cyclone_radius_km(38.0, 20 * 1.852, b, 16.8), rel=1e-9)


def test_ibtracs_reader_matches_the_bdeck(tmp_path, bdeck):
    p = tmp_path / "ibtracs.csv"
    p.write_text(IBTRACS)
    a, b = read_ibtracs(p), read_track(bdeck)
    assert read_track(p).time.size == 3
    np.testing.assert_array_equal(a.time, b.time)  # unsorted rows come back in time order
    np.testing.assert_allclose(a.lat_deg, [15.2, 16.0, 16.8])
    np.testing.assert_allclose(a.lon_deg, [179.0, -179.0, -177.0])
    np.testing.assert_allclose(a.r34_nm[:2], b.r34_nm[:2])
    np.testing.assert_allclose(a.r7_km[:2], b.r7_km[:2], rtol=1e-12)


def test_atcf_round_trip_and_aids(tmp_path, bdeck):
    tr = read_atcf(bdeck)
    back = read_atcf(write_atcf(tr, tmp_path / "out.dat"))
    np.testing.assert_allclose(back.r7_km, tr.r7_km, rtol=1e-12)
    adeck = tmp_path / "awp302022.dat"
    adeck.write_text(
        "WP, 30, 2022101300, 03, JTWC,   0, 152N, 1790E,  65,  975, TY,  34, NEQ,  120,  100,   80,  110,\n"
        "WP, 30, 2022101300, 03, JTWC,  24, 180N, 1750W,  75,  965, TY,  34, NEQ,  130,  110,   90,  120,\n"
        "WP, 30, 2022101300, 03, OFCL,  24, 181N, 1751W,  75,  965, TY,  34, NEQ,  130,  110,   90,  120,\n"
    )
    fc = read_atcf(adeck, tech="JTWC")
    assert fc.lead_h.tolist() == [0.0, 24.0] and fc.time[1] == np.datetime64("2022-10-14T00:00")
    # the cone: the radius grows by cone_km_per_h per hour of lead
    t = fc.time[1]
    assert float(fc.avoid_radius_km(t, 30.0, 3.0)) == pytest.approx(float(fc.at(t)["r7_km"]) + 30.0 + 72.0)
    with pytest.raises(TrackFormatError, match="OFCL"):
        read_atcf(adeck)


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("WP, 30, 2022101300,   , BEST,   0, 152Q, 1790E,  65,  975, TY,", "line 2: LatN/S '152Q'"),
        ("WP, 30, 20221013,   , BEST,   0, 152N, 1790E,  65,  975, TY,", "line 2: YYYYMMDDHH"),
        ("WP, 30, 2022101306,   , BEST,   0, 152N, 1790E,  6x,  975, TY,", "line 2: VMAX '6x'"),
        ("WP, 30, 2022101306,   , BEST,   0, 152N, 1790E,  65,  975, TY,  40, NEQ, 1, 1, 1, 1", "line 2: RAD '40'"),
    ],
)
def test_bad_atcf_lines_name_file_line_value(tmp_path, line, match):
    p = tmp_path / "bad.dat"
    p.write_text(BDECK_DATELINE.splitlines()[0] + "\n" + line + "\n")
    with pytest.raises(TrackFormatError, match=match) as exc:
        read_atcf(p)
    assert str(p) in str(exc.value)


# --------------------------------------------------------------------------- DCPA / TCPA, trigger, risk


def test_dcpa_tcpa_hand_worked():
    # head-on: centre 100 nm north coming south at 10 kn, ship north at 15: meet in 100 / 25 = 4 h
    d, t = dcpa_tcpa([0.0, 100.0], [0.0, -25.0])
    assert (float(d), float(t)) == pytest.approx((0.0, 4.0))
    # crossing at right angles: centre 60 nm east moving west at 10 kn, ship north at 10 kn:
    # relative velocity (-10, -10); closest at t = 3 h, |(60, 0) + 3 (-10, -10)| = |(30, -30)| = 42.43 nm
    d, t = dcpa_tcpa([60.0, 0.0], [-10.0, -10.0])
    assert float(t) == pytest.approx(3.0) and float(d) == pytest.approx(30 * math.sqrt(2))
    # receding: the closest point is past, t = -(50 * 4) / 25 = -8 h, at (0, 50) - 8 (3, 4) = (-24, 18): 30 nm
    d, t = dcpa_tcpa([0.0, 50.0], [3.0, 4.0])
    assert float(t) == pytest.approx(-8.0) and float(d) == pytest.approx(30.0)
    # no relative motion
    assert tuple(map(float, dcpa_tcpa([3.0, 4.0], [0.0, 0.0]))) == (5.0, 0.0)


def test_encounter_on_a_track_matches_the_plane_geometry():
    # a centre at 20 N moving west at 10 kn (track built by the same straight_track the scenarios use)
    pts = straight_track(20.0, 131.0, 270.0, 10.0, duration_h=24.0, step_h=6.0)
    t0 = np.datetime64("2022-10-13T00:00", "ns")
    times = t0 + (np.array([p[0] for p in pts]) * 3600).astype("timedelta64[s]")
    n = len(pts)
    tr = CycloneTrack(times, [p[1] for p in pts], [p[2] for p in pts], 80.0, 960.0, np.full((n, 4), 100.0),
                      np.nan, np.nan, np.nan, np.nan, 0.0)  # fmt: skip
    # ship 1 deg west of the centre, steaming east at 10 kn: head-on, closing at 20 kn over ~56.4 nm
    e = encounter(20.0, 130.0, 10.0, 90.0, t0, tr)
    gap_nm = float(geo.distance_nm(20.0, 130.0, 20.0, 131.0))
    assert float(e.tcpa_h) == pytest.approx(gap_nm / 20.0, rel=2e-3)
    assert float(e.dcpa_km) < 0.5 and float(e.closing_kn) == pytest.approx(20.0, rel=2e-3)


@given(
    dcpa=st.floats(0, 600), dist=st.floats(0, 800), r=st.floats(50, 400), margin=st.floats(0, 100),
)  # fmt: skip
@settings(max_examples=200, deadline=None)
def test_trigger_fires_exactly_when_both_conditions_hold(dcpa, dist, r, margin):
    assert bool(patent_trigger(dcpa, dist, r, margin)) == (dcpa <= r and dist <= r + margin)


def _enc(dcpa, tcpa, dist, closing, r=200.0):
    from optroute.geo.encounter import Encounter

    a = np.atleast_1d
    return Encounter(a(float(dist)), a(float(dcpa)), a(float(tcpa)), a(float(closing)), a(float(r)), a(0.0))


@given(dcpa=st.floats(0, 500), tcpa=st.floats(-50, 200), dist=st.floats(0, 2000), closing=st.floats(-30, 30))
@settings(max_examples=200, deadline=None)
def test_risk_degree_is_in_0_1_and_zero_when_receding(dcpa, tcpa, dist, closing):
    r = float(risk_degree(_enc(dcpa, tcpa, dist, closing))[0])
    assert 0.0 <= r <= 1.0
    if tcpa < 0 or closing <= 0 or dcpa >= 230.0:
        assert r == 0.0


def test_risk_degree_limits():
    # on a collision course, inside the safe circle: the circle cannot be avoided
    assert float(risk_degree(_enc(0.0, 5.0, 220.0, 20.0))[0]) == 1.0
    # same course, 1000 km out at 20 kn: (1000 - 230) km / 37.04 km/h = 20.79 h against T_S = 6 h
    assert float(risk_degree(_enc(0.0, 30.0, 1000.0, 20.0))[0]) == pytest.approx(6.0 / (770 / 37.04))
    # halfway across the DCPA band R..R+30: the sine membership is 1/2
    assert float(risk_degree(_enc(215.0, 5.0, 220.0, 20.0))[0]) == pytest.approx(0.5)


# --------------------------------------------------------------------------- APF and the search, brute force

T0 = np.datetime64("2022-10-13T00:00", "ns")


@pytest.fixture(scope="module")
def small_case():
    """A 150 km typhoon moving west at 8 kn across a 330 nm north-going passage (1 deg weather)."""
    cyc = Cyclone(track=straight_track(17.5, 128.5, 270.0, 8.0, duration_h=60.0, step_h=6.0),
                  pressure_deficit_hpa=40.0, rmax_km=30.0, holland_b=1.4, name="small")  # fmt: skip
    ds = tropical_cyclone(cyc, start=T0, duration_h=60.0, step_h=3.0, resolution_deg=1.0, bbox=(10, 26, 118, 134))
    ds.attrs["geography"] = "synthetic"
    tr = np.asarray(cyc.track)
    n = tr.shape[0]
    from optroute.weather.cyclone import cyclone_track

    r7 = cyclone_track(ds)["r7_km"][0]
    track = CycloneTrack(T0 + (tr[:, 0] * 3600).astype("timedelta64[s]"), tr[:, 1], tr[:, 2], np.nan, 970.0,
                         np.full((n, 4), np.nan), np.nan, np.nan, np.nan, 1010.0, 0.0)  # fmt: skip
    return ds, track, float(r7)


def _brute_min_gap_km(plan, track, step_nm=1.0):
    """min over points every ``step_nm`` along the plan of (distance to the centre − R), centre interpolated."""
    wp = plan.waypoints
    lats, lons, times = [], [], []
    th = (plan.times - plan.times[0]) / np.timedelta64(1, "h")
    for k in range(wp.shape[0] - 1):
        d = float(geo.distance_nm(*wp[k], *wp[k + 1]))
        f = np.linspace(0.0, 1.0, max(2, int(d / step_nm) + 1))
        la, lo = geo.intermediate_points(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1], f)
        lats.append(la), lons.append(lo), times.append(th[k] + f * (th[k + 1] - th[k]))
    la, lo, t = (np.concatenate(a) for a in (lats, lons, times))
    s = track.at(plan.times[0] + (t * 3600).astype("timedelta64[s]"))
    return float(np.min(geo.distance_nm(la, lo, s["lat"], s["lon"]) * 1.852 - s["r7_km"]))


def test_apf_track_never_enters_r(small_case):
    ds, track, r7 = small_case
    ship = orx.Ship.preset("general_cargo_25k_dwt")
    run = apf_avoidance((13.0, 126.0), (18.5, 126.0), ds, ship, track, departure=T0, speed_kn=12.0, step_h=0.5)
    assert run.trigger_time is not None  # the great circle meets the circle: the APF took over
    gap = _brute_min_gap_km(run.plan, track)
    assert gap > 0.0, gap
    assert [v for v in run.plan.verify() if v.kind == "exclusion"] == []


def test_search_route_keeps_out_of_r_plus_margin(small_case):
    ds, track, r7 = small_case
    ship = orx.Ship.preset("general_cargo_25k_dwt")
    excl = Exclusion.from_track(track, margin_km=30.0, cone_km_per_h=0.0)
    kw = dict(
        departure=T0, objective="time", cell_nm=30.0, angular_resolution_deg=None, directions=16, use_land_mask=False
    )
    free = orx.search_route((13.0, 126.0), (18.5, 126.0), ds, ship, **kw)
    route = orx.search_route((13.0, 126.0), (18.5, 126.0), ds, ship, exclusion=excl, **kw)
    plan = orx.Plan.from_schedule(route.waypoints, route.stw_kn, departure=T0, ship=ship, weather=ds,
                                  times=route.times, use_land_mask=False)  # fmt: skip
    assert _brute_min_gap_km(plan, track) >= 30.0
    assert _brute_min_gap_km(
        orx.Plan.from_schedule(free.waypoints, free.stw_kn, departure=T0, ship=ship, weather=ds, times=free.times,
                               use_land_mask=False), track) < 30.0  # fmt: skip


def test_cli_cyclone_option_builds_the_circle_and_names_bad_files(bdeck, tmp_path):
    import argparse

    from optroute.cli.voyage import cyclone_exclusion

    ns = argparse.Namespace(cyclone=str(bdeck), margin_km=30.0, cone_km_per_h=None)
    excl = cyclone_exclusion(ns)
    tr = read_atcf(bdeck)
    _, _, rad_nm = excl.at(tr.time[:1])
    assert float(rad_nm[0]) * 1.852 == pytest.approx(tr.r7_km[0] + 30.0)
    bad = tmp_path / "b.dat"
    bad.write_text("WP, 30, 2022101300,   , BEST,   0, 152N, 1790X,  65,  975, TY,\n")
    with pytest.raises(TrackFormatError, match=r"line 1: LonE/W '1790X'"):
        cyclone_exclusion(argparse.Namespace(cyclone=str(bad), margin_km=30.0, cone_km_per_h=None))
    with pytest.raises(orx.ConfigError, match="--margin-km"):
        cyclone_exclusion(argparse.Namespace(cyclone=str(bdeck), margin_km=-1.0, cone_km_per_h=None))


def test_piece_hits_by_hand():
    from optroute.search.exclusion import piece_hits

    # a 10 nm circle at (0, 0) for 10 h that then moves east at 60 nm/h to (0, 1) at hour 11
    t0 = np.datetime64("2022-10-13T00:00", "ns")
    excl = Exclusion(t0 + np.array([0, 10, 11], dtype="timedelta64[h]"), 0.0, [0.0, 0.0, 1.0], 10.0)
    one = np.ones(1)

    def hits(lon_mid, t_h):  # a 20 nm piece sailing north, centred on the equator, entered at t_h, 2 h long
        return bool(piece_hits(excl, t0, 0 * one, lon_mid * one, 0 * one, 20 * one, t_h * one, 2 * one, 1.0)[0])

    assert hits(0.1, 0.0)  # 6 nm abeam of the centre at closest: inside 10 nm
    assert not hits(0.5, 0.0)  # 30 nm abeam: outside 10 nm + the 1 nm sampling pad
    assert not hits(0.1, 20.0)  # the circle has moved to 1 E (held there after the track ends)
    assert hits(1.0, 20.0)


def test_dp_search_keeps_out_of_r_plus_margin(small_case):
    # without the exclusion this DP route (same options) passes 46 km inside R; with it, outside R + 30 km
    ds, track, _ = small_case
    ship = orx.Ship.preset("general_cargo_25k_dwt")
    excl = Exclusion.from_track(track, margin_km=30.0, cone_km_per_h=0.0)
    route = orx.search_route(
        (13.0, 126.0), (18.5, 126.0), ds, ship, departure=T0, objective="fuel", eta=T0 + np.timedelta64(40, "h"),
        method="dp", exclusion=excl, use_land_mask=False,
        dp_options={"dx_nm": 60.0, "dy_nm": 30.0, "half_width_nm": 240.0, "dt_h": 1.0},
    )  # fmt: skip
    plan = orx.Plan.from_schedule(route.waypoints, route.stw_kn, departure=T0, ship=ship, weather=ds,
                                  times=route.times, use_land_mask=False)  # fmt: skip
    assert _brute_min_gap_km(plan, track) >= 30.0
