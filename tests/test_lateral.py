"""Lateral bounds of the corridor NLP against land (optroute.optimise.lateral), checked by brute force and geometry."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.geo import land
from optroute.optimise.lateral import avoid_point, lateral_bounds
from optroute.optimise.nlp_inputs import build_frame

T0 = np.datetime64("2024-01-01T00:00")


def _gc_points(wp: np.ndarray, step_nm: float) -> np.ndarray:
    """Points every <= step_nm along the great circles between consecutive waypoints (slerp, by hand)."""
    out = []
    for (la1, lo1), (la2, lo2) in zip(wp[:-1], wp[1:], strict=True):
        a = np.array(
            [
                np.cos(np.radians(la1)) * np.cos(np.radians(lo1)),
                np.cos(np.radians(la1)) * np.sin(np.radians(lo1)),
                np.sin(np.radians(la1)),
            ]
        )
        b = np.array(
            [
                np.cos(np.radians(la2)) * np.cos(np.radians(lo2)),
                np.cos(np.radians(la2)) * np.sin(np.radians(lo2)),
                np.sin(np.radians(la2)),
            ]
        )
        om = np.arccos(np.clip(a @ b, -1.0, 1.0))
        n = max(2, int(np.ceil(om * 3440.065 / step_nm)) + 1)
        f = np.linspace(0.0, 1.0, n)[:, None]
        p = (np.sin((1 - f) * om) * a + np.sin(f * om) * b) / np.sin(om) if om > 0 else np.repeat(a[None], n, 0)
        out.append(np.column_stack([np.degrees(np.arcsin(p[:, 2])), np.degrees(np.arctan2(p[:, 1], p[:, 0]))]))
    return np.vstack(out)


class _DiscMask:
    """A land mask with round islands [(lat, lon, radius nm)], or land everywhere east of ``wall_lon``."""

    name = "test"
    resolution_nm = 0.5

    def __init__(self, islands=(), wall_lon=None):
        self.islands, self.wall_lon = list(islands), wall_lon

    def is_land(self, lat, lon):
        lat, lon = np.asarray(lat, float), np.asarray(lon, float)
        out = np.zeros(np.broadcast(lat, lon).shape, dtype=bool)
        for la, lo, r in self.islands:
            out |= geo.distance_nm(lat, lon, la, lo) <= r
        if self.wall_lon is not None:
            out |= (lon >= self.wall_lon[0]) & (lon <= self.wall_lon[1])
        return out


def _weather():
    return orx.scenarios.uniform(
        hs_m=1.5, tp_s=7.0, wave_from_deg=270.0, bbox=(-5, 5, -32, -18), start=T0, duration_h=48, resolution_deg=1.0
    )


def test_an_island_between_two_waypoints_is_excluded_from_every_leg_the_bounds_admit(monkeypatch):
    # 40 nm legs along the equator; a 3 nm island 1 nm to port of the centreline half-way between waypoints 2 and 3
    # (the old bounds, sampled across the waypoints only, did not see it)
    frame = build_frame(orx.Corridor(np.array([[0.0, -30.0], [0.0, -26.0]]), 10.0).resample(40.0))
    k = 2
    mid = 0.5 * (frame.corridor.waypoints[k] + frame.corridor.waypoints[k + 1])
    island = (mid[0] + 1.0 / 60.0, mid[1], 3.0)  # port of an eastbound track = north
    monkeypatch.setattr(land, "land_mask", lambda name=None: _DiscMask([island]))
    wx = _weather()
    y_lo, y_hi = lateral_bounds(
        frame, sampler=orx.WeatherSampler(wx), dataset=wx, times=np.array([T0]), use_land_mask=True
    )
    # passed on the starboard side (nearer the centreline: its edge is 2 nm to starboard, 4 nm to port)
    assert y_hi[k] < -2.0 and y_hi[k + 1] < -2.0
    assert np.all(y_lo[1:-1] == -10.0)
    assert np.all(y_hi[[1, 4, 5]] == 10.0)
    # brute force: every leg between grid points of the boxes (corners included) stays off the island
    rng = np.random.default_rng(1)
    for leg in range(frame.n_legs):
        ys_a = np.unique(np.r_[y_lo[leg], y_hi[leg], rng.uniform(y_lo[leg], y_hi[leg], 6)])
        ys_b = np.unique(np.r_[y_lo[leg + 1], y_hi[leg + 1], rng.uniform(y_lo[leg + 1], y_hi[leg + 1], 6)])
        for a in ys_a:
            for b in ys_b:
                y = np.zeros(frame.n_legs + 1)
                y[leg], y[leg + 1] = a, b
                pts = _gc_points(frame.waypoints(y)[leg : leg + 2], 0.1)
                assert np.min(geo.distance_nm(pts[:, 0], pts[:, 1], island[0], island[1])) > island[2]


def test_a_corridor_closed_by_land_raises_no_safe_passage_naming_where(monkeypatch):
    frame = build_frame(orx.Corridor(np.array([[0.0, -30.0], [0.0, -26.0]]), 10.0).resample(40.0))
    monkeypatch.setattr(land, "land_mask", lambda name=None: _DiscMask(wall_lon=(-28.1, -27.9)))
    wx = _weather()
    s_wall = float(geo.distance_nm(0.0, -30.0, 0.0, -28.1))  # the wall's first meridian, along the equator
    k = int(np.searchsorted(frame.s_nm, s_wall)) - 1
    with pytest.raises(orx.NoSafePassage, match=rf"no navigable passage at 11[34]\.\d nm .* waypoints {k} and {k + 1}"):
        lateral_bounds(frame, sampler=orx.WeatherSampler(wx), dataset=wx, times=np.array([T0]), use_land_mask=True)


def test_avoid_point_moves_both_bounds_of_the_leg_to_the_roomier_side():
    lo, hi = np.array([0.0, -10.0, -10.0, 0.0]), np.array([0.0, 10.0, 10.0, 0.0])
    # point at +2 nm mid-leg 1: port would leave 7 + 7 nm, starboard 11 + 11 nm
    new_lo, new_hi = avoid_point(lo, hi, leg=1, fraction=0.5, offset_port_nm=2.0, margin_nm=1.0)
    np.testing.assert_array_equal(new_lo, lo)
    np.testing.assert_array_equal(new_hi, [0.0, 1.0, 1.0, 0.0])
    # first leg (start pinned): y(f) = f·y_1, so y_1 <= (2 − 1)/0.5 = 2 (port would need y_1 >= 6)
    new_lo, new_hi = avoid_point(lo, hi, leg=0, fraction=0.5, offset_port_nm=2.0, margin_nm=1.0)
    np.testing.assert_array_equal(new_hi, [0.0, 2.0, 10.0, 0.0])
    # no room on either side
    assert (
        avoid_point(
            np.array([0.0, -1.0, 0.0]),
            np.array([0.0, 1.0, 0.0]),
            leg=0,
            fraction=0.5,
            offset_port_nm=0.0,
            margin_nm=1.0,
        )
        is None
    )


SAN_CLEMENTE = [(32.5, -117.4), (33.2, -119.6), (34.0, -121.5)]  # passes San Clemente Island (32.9 N, 118.5 W)


def _san_clemente_plan(**kw):
    wx = orx.scenarios.uniform(
        hs_m=1.5, wave_from_deg=270.0, bbox=(25, 45, -130, -110), start=T0, duration_h=60, resolution_deg=1.0
    )
    cor = orx.Corridor.from_waypoints(SAN_CLEMENTE, width_nm=40.0)
    eta = T0 + np.timedelta64(int(cor.length_nm / 15.0 * 60), "m")
    ship = orx.Ship.preset("container_54k_dwt")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return orx.optimise_corridor(cor, wx, ship, departure=T0, eta=eta, use_land_mask=True, **kw)


def _assert_off_land(plan):
    assert plan.status in ("optimal", "feasible")
    assert plan.verify(step_nm=0.5) == []
    pts = _gc_points(np.asarray(plan.waypoints), 0.5)
    assert not land.is_land(pts[:, 0], pts[:, 1]).any()


def test_san_clemente_corridor_returns_a_verified_plan_off_land():
    """Was SolverFailure: land on leg 1 that halving the bounds about their middle never left."""
    plan = _san_clemente_plan()
    _assert_off_land(plan)
    assert plan.solver_stats["retries"] == 0  # the bounds alone keep it off land


def test_the_verification_loop_moves_a_leg_off_land_the_bounds_missed(monkeypatch):
    import optroute.optimise.corridor_setup as setup

    def corridor_wide(frame, **kw):  # the old failure: bounds blind to the island
        hi = np.asarray(frame.corridor.half_width_nm, float).copy()
        hi[[0, -1]] = 0.0
        return -hi, hi

    monkeypatch.setattr(setup, "lateral_bounds", corridor_wide)
    plan = _san_clemente_plan()
    _assert_off_land(plan)
    assert any(line.startswith("land cut on leg") for line in plan.solver_stats["tightening"])
