"""Lateral bounds over each leg's own reach window (optroute.optimise.lateral.reach_windows), by hand on the equator.

A no-go area (NaN waves) that sits across the whole corridor at departure and is gone before any ship
can get there: blocked over the whole passage it closes the corridor (the static window's
NoSafePassage, as on Shao et al.'s storm, issue 21); over the times a ship can be on each leg it
blocks nothing. Cheap: a 600 nm corridor on a 1° grid.
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import NoSafePassage
from optroute.optimise.lateral import lateral_bounds, reach_windows
from optroute.optimise.nlp_inputs import build_frame

T0 = np.datetime64("2024-01-10T00:00", "ns")
HW_NM = 30.0
V_KN = 20.0
CAP_H = 60.0


@pytest.fixture(scope="module")
def frame():
    wp = np.array([[0.0, 0.0], [0.0, 10.0]])
    return build_frame(orx.Corridor.from_waypoints(wp, width_nm=2 * HW_NM).resample(50.0))


@pytest.fixture(scope="module")
def sea():
    """Calm sea, 1° grid, 6 h steps; waves NaN over lon 5-7°, lat -2..2° at the first time only."""
    ds = orx.scenarios.calm((-5.0, 5.0, -2.0, 12.0), start=T0, duration_h=CAP_H + 12.0, resolution_deg=1.0)
    ds.attrs["geography"] = "synthetic"
    box = (ds.lat >= -2) & (ds.lat <= 2) & (ds.lon >= 5) & (ds.lon <= 7) & (ds.time == ds.time[0])
    ds["hs_m"] = ds["hs_m"].where(~box)
    return ds


def test_reach_windows_are_the_hand_worked_distance_over_speed(frame):
    """On the equator the nearest offset of a station is its centre: first = s / v - 1 h, last = cap - (L - s) / v + 1 h."""
    w = reach_windows(frame, T0, CAP_H, V_KN, margin_h=1.0)
    hours = (w - T0) / np.timedelta64(1, "s") / 3600.0
    lon = frame.corridor.waypoints[:, 1]
    s = geo.distance_nm(0.0, 0.0, 0.0, lon)
    rest = geo.distance_nm(0.0, lon, 0.0, 10.0)
    slack = HW_NM / 32.0 / V_KN  # the offsets' half spacing, taken off each distance
    np.testing.assert_allclose(hours[:, 0], np.clip(s[:-1] / V_KN - slack - 1.0, 0.0, CAP_H), atol=1e-6)
    np.testing.assert_allclose(hours[:, 1], np.clip(CAP_H - rest[1:] / V_KN + slack + 1.0, 0.0, CAP_H), atol=1e-6)


def test_a_no_go_area_gone_before_the_ship_can_arrive_blocks_only_the_static_window(frame, sea):
    smp = orx.WeatherSampler(sea)
    times = T0 + np.arange(0, int(CAP_H) + 1, 6).astype("timedelta64[h]")
    with pytest.raises(NoSafePassage):
        lateral_bounds(frame, sampler=smp, dataset=sea, times=times, use_land_mask=False)
    # the area is NaN only in the 0 h slice, so within (0, 6) h by interpolation; no ship reaches the leg into its
    # stencil (lon 4°, ~222 nm) before 222 / 20 - 1 = 10 h
    w = reach_windows(frame, T0, CAP_H, V_KN)
    lo, hi = lateral_bounds(frame, sampler=smp, dataset=sea, times=times, use_land_mask=False, leg_windows=w)
    np.testing.assert_allclose(lo[1:-1], -HW_NM)
    np.testing.assert_allclose(hi[1:-1], HW_NM)
    # a faster ship could be there in the 0-6 h slice: the area blocks its legs again
    with pytest.raises(NoSafePassage):
        lateral_bounds(frame, sampler=smp, dataset=sea, times=times, use_land_mask=False,
                       leg_windows=reach_windows(frame, T0, CAP_H, 60.0))  # fmt: skip
