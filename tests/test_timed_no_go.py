"""A moving no-go area as time windows on the corridor NLP's waypoint times (optroute.optimise.timed_no_go).

The scenario is Shao et al.'s case II cut down (0.5° grid, 180 h): the bad-weather box (lon 50–70°) moves
north at 3 kn and covers latitude −2° from about 100 h; a fixed track along −2° from 40° E to 75° E crosses it.
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.geo.land import weather_nan
from optroute.optimise.nlp_inputs import build_frame
from optroute.optimise.timed_no_go import PAD_H, NoPassageWindows, no_passage_windows
from optroute.units import h_to_timedelta
from optroute.weather.scenarios import in_no_go_area

LAT = -2.0
ETA_H = 120.0


@pytest.fixture(scope="module")
def wx():
    return orx.scenarios.shao_case(2, bbox=(-6.0, 2.0, 38.0, 77.0), resolution_deg=0.5, duration_h=180.0)


@pytest.fixture(scope="module")
def corridor():
    return orx.Corridor([(LAT, 40.0), (LAT, 75.0)], half_width_nm=0.0)


def _track(waypoints: np.ndarray, hours: np.ndarray, step_nm: float = 1.0):
    """Points every ``step_nm`` or less along the legs, at the times of a constant speed on each leg."""
    lat, lon, t = [], [], []
    for k in range(len(waypoints) - 1):
        d = float(geo.distance_nm(*waypoints[k], *waypoints[k + 1]))
        f = np.linspace(0.0, 1.0, int(np.ceil(d / step_nm)) + 1)
        la, lo = geo.intermediate_points(*waypoints[k], *waypoints[k + 1], f)
        lat.append(la)
        lon.append(lo)
        t.append(hours[k] + f * (hours[k + 1] - hours[k]))
    return np.concatenate(lat), np.concatenate(lon), np.concatenate(t)


def test_windows_hold_every_time_the_referee_finds_a_leg_blocked(wx, corridor):
    """Brute force: every leg's points every 2 nm against the weather's no-passage rule every 0.5 h."""
    frame = build_frame(corridor.resample(150.0))
    t0 = wx.time.values[0]
    n = frame.n_legs
    w = no_passage_windows(frame, wx, t0, np.zeros(n + 1), np.zeros(n + 1))
    dt = 0.5
    hours = np.arange(0.0, 180.0, dt)
    wp = frame.corridor.waypoints
    blocked_legs = []
    for k in range(n):
        lat, lon, _ = _track(wp[k : k + 2], np.zeros(2), step_nm=2.0)
        when = np.broadcast_to((t0 + h_to_timedelta(hours))[:, None], (hours.size, lat.size))
        la, lo = np.broadcast_to(lat, when.shape), np.broadcast_to(lon, when.shape)
        hit = weather_nan(wx, la, lo, when).any(axis=1)
        if not hit.any():
            assert np.isnan(w.from_h[k]) and np.isnan(w.to_h[k]), f"leg {k} is never blocked"
            continue
        blocked_legs.append(k)
        first, last = hours[hit].min(), hours[hit].max()
        # the window holds every blocked time, and its edges are the blocked times' own (to the sampling)
        # (an interval open to the weather's start or end: blocked at its first or last time)
        if np.isfinite(w.from_h[k]):
            assert w.from_h[k] <= first < w.from_h[k] + dt + 1e-9
        else:
            assert first == 0.0
        if np.isfinite(w.to_h[k]):
            assert w.to_h[k] - dt - 1e-9 <= last < w.to_h[k]
        else:
            assert last == hours[-1]
    assert blocked_legs == list(w.legs)
    assert len(blocked_legs) >= 8  # lon 50–70° (and the stencil at its edges) on 150 nm legs


def test_sides_follow_the_start_and_bound_one_waypoint_time_each():
    w = NoPassageWindows(np.array([np.nan, 10.0, 50.0, -np.inf]), np.array([np.nan, 20.0, 60.0, 30.0]))
    times = np.array([0.0, 4.0, 8.0, 55.0, 70.0])  # leg 1 ends before 10 h; leg 2 starts inside [50, 60)
    sides = w.sides(times)
    assert sides.tolist() == [0, -1, -1, 1]  # leg 2: 3 h late to be before, 5 h early to be after -> before
    lo, hi = w.time_bounds(sides)
    assert hi.tolist() == [np.inf, np.inf, 10.0 - PAD_H, 50.0 - PAD_H, np.inf]
    assert lo.tolist() == [-np.inf, -np.inf, -np.inf, 30.0 + PAD_H, -np.inf]


def test_nlp_passes_the_moving_box_by_its_timing_on_a_fixed_track(wx, corridor):
    """The lateral bounds alone close the fixed track; the time windows pass it ahead of the box, and the
    NLP's plan never enters it (brute force, exact geometry and the weather's rule), verifies, and burns less
    than the constant speed that clears the box the same way."""
    t0 = wx.time.values[0]
    ship = orx.Ship.preset("container_54k_dwt")
    kw = {"departure": t0, "eta": t0 + h_to_timedelta(ETA_H), "objective": "fuel", "max_leg_nm": 150.0}
    with pytest.raises(orx.NoSafePassage):
        orx.optimise_corridor(corridor, wx, ship, **kw)
    plan = orx.optimise_corridor(corridor, wx, ship, timed_no_passage=True, **kw)
    assert plan.verify() == []
    hours = (plan.times - t0) / np.timedelta64(1, "h")
    lat, lon, t = _track(plan.waypoints, hours)
    assert not in_no_go_area(wx, lat, lon, t).any()
    assert not weather_nan(wx, lat, lon, t0 + h_to_timedelta(t)).any()
    # the box reaches the track (stencil: the 0.5° node at -2.5° at 96 h -> blocked from 90 h); the plan leaves
    # the last blocked leg just before, then slows: a constant speed clearing the box the same way burns more
    frame = build_frame(corridor.resample(150.0))
    n = frame.n_legs
    w = no_passage_windows(frame, wx, t0, np.zeros(n + 1), np.zeros(n + 1))
    last = int(w.legs.max())
    assert hours[last + 1] == pytest.approx(w.from_h[last] - PAD_H, abs=1e-6)
    v = float(frame.s_nm[last + 1]) / (w.from_h[last] - PAD_H)
    const = orx.Plan.from_schedule(plan.waypoints, np.full(n, v), departure=t0, ship=ship, weather=wx)
    assert const.verify() == []
    assert plan.total_fuel_t < const.total_fuel_t * (1.0 - 0.01)
