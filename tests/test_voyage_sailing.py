"""The sailing simulator (issue 18 item 4): a yacht sailed through a truth wind, re-planning on the wind met.

References, independent of the simulator's stepping:

* truth = forecast: the passage time of the sailing search's own route
  (:func:`optroute.search.sailing.search_sailing_route`), to one simulator step, and the beat
  worked by hand: six lattice diagonals, each the WGS84 geodesic of pyproj's ``Geod`` (heading
  45.19 deg at the equator), at the polar's own speed for that true wind angle;
* a 90° wind shift (the forecast's northerly is really a westerly): the route searched on the
  northerly beats to windward; sailed blind in the westerly its legs stay sailable but slow
  (three diagonals at TWA 135.19, three at 44.81), while the destination due north lies on a
  beam reach (TWA 90, 7.0 kn, a node of the polar's table).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyproj import Geod

from optroute import units
from optroute.errors import ConfigError
from optroute.physics.polar import Polar
from optroute.physics.yacht import SailingVessel
from optroute.search.sailing import search_sailing_route
from optroute.voyage import ReplanPolicy
from optroute.voyage.sailing_sim import simulate_sailing
from optroute.weather.schema import canonical_dataset

T0 = np.datetime64("2024-06-01T00:00", "ns")
CELL_DEG = 1.0 / 60.0  # SailingGrid.around with cell_nm = 1: rows 1 arc-minute apart, columns 1/cos(0.05 deg) of one
_AZ, _, _DIAG_M = Geod(ellps="WGS84").inv(0.0, 0.0, CELL_DEG, CELL_DEG)
DIAG_NM, DIAG_DEG = _DIAG_M / 1852.0, float(_AZ)
A, B = (0.0, 0.0), (6 * CELL_DEG, 0.0)  # six rows due north
# the hand-made beating polar of tests/test_sailing_search.py (kn): no-go below 40 deg
BEAT_TWA = [0.0, 40.0, 45.0, 60.0, 90.0, 135.0, 180.0]
BEAT_TWS = [5.0, 10.0, 20.0]
BEAT_BSP = [[0, 0, 0], [2.0, 4.0, 5.0], [3.0, 6.0, 7.0], [3.3, 6.6, 7.7], [3.5, 7.0, 8.0], [3.0, 6.5, 8.0],
            [2.5, 5.0, 7.0]]  # fmt: skip
YACHT = SailingVessel(Polar(BEAT_TWA, BEAT_TWS, BEAT_BSP, name="beater"), name="beater")
SEARCH = {"cell_nm": 1.0, "margin_nm": 3.0, "directions": 8}
STEP_H = 0.1


def _wind(from_deg: float, kn: float = 10.0):
    u, v = -kn * math.sin(math.radians(from_deg)), -kn * math.cos(math.radians(from_deg))
    return canonical_dataset(np.array([T0], dtype="datetime64[ns]"), np.linspace(-0.2, 0.3, 6),
                             np.linspace(-0.2, 0.2, 5),
                             {"wind_u_ms": units.kn_to_ms(u), "wind_v_ms": units.kn_to_ms(v)},
                             attrs={"source": f"wind from {from_deg:g}", "geography": "synthetic"})  # fmt: skip


def _speed(twa_deg: float) -> float:
    return float(YACHT.polar.speed_kn_at(twa_deg, 10.0))


@pytest.fixture(scope="module")
def shifted():
    north, west = _wind(0.0), _wind(270.0)
    common = dict(forecasts=[(T0, north)], departure=T0, step_h=STEP_H, search_options=SEARCH)
    blind = simulate_sailing((A, B), west, YACHT, replan=ReplanPolicy.never(), **common)
    policy = ReplanPolicy(on_forecast=False, wind_direction_threshold_deg=30.0, wind_speed_threshold_kn=3.0)
    replanned = simulate_sailing((A, B), west, YACHT, replan=policy, **common)
    return blind, replanned


def test_truth_equal_to_the_forecast_sails_the_searched_route_in_its_passage_time():
    wind = _wind(0.0)
    route = search_sailing_route(A, B, wind, YACHT, departure=T0, **SEARCH)
    policy = ReplanPolicy(wind_direction_threshold_deg=5.0, wind_speed_threshold_kn=0.5)
    res = simulate_sailing((A, B), wind, YACHT, forecasts=[(T0, wind)], departure=T0, replan=policy, step_h=STEP_H,
                           search_options=SEARCH)  # fmt: skip
    assert res.outcome.n_replans == 0  # the wind met is the forecast: the trigger never fires
    assert abs(res.outcome.passage_h - route.passage_h) <= STEP_H
    assert res.outcome.n_manoeuvres == route.n_manoeuvres
    # beating on the lattice diagonals: six of them at the polar's speed for their TWA
    assert res.outcome.passage_h == pytest.approx(6 * DIAG_NM / _speed(DIAG_DEG), rel=1e-3)
    assert np.all(np.abs(res.log["twa_deg"].values) >= YACHT.polar.no_go_deg)  # no step inside the no-go sector


def test_a_wind_shift_triggers_a_replan_and_the_new_route_is_faster_in_the_truth(shifted):
    blind, replanned = shifted
    assert blind.outcome.n_replans == 0
    assert replanned.outcome.n_replans == 1
    reason = str(replanned.log["replan_reason"].values[1])
    assert reason.startswith("wind met: wind direction differs") and "90 deg > 30 deg" in reason
    assert replanned.log["replan_time"].values[1] == T0 + np.timedelta64(6, "m")  # after the first step
    assert replanned.outcome.passage_h < blind.outcome.passage_h
    # hand-worked: blind sails three diagonals on each tack, TWA 180 - 44.81 and 90 - 45.19 in the westerly
    blind_h = 3 * DIAG_NM / _speed(180.0 - DIAG_DEG) + 3 * DIAG_NM / _speed(90.0 - DIAG_DEG)
    assert blind.outcome.passage_h == pytest.approx(blind_h, rel=1e-3)
    # the re-planned route reaches north on the beam (TWA -90 at 7 kn) from the first step on, but for the last
    # leg from its lattice node nearest the destination
    new = replanned.log["leg"].values[1:] < replanned.routes[1].lat_deg.size - 1
    assert np.all(np.abs(replanned.log["twa_deg"].values[1:][new] + 90.0) < 1e-6)
    assert replanned.outcome.passage_h < 0.85 * blind.outcome.passage_h
    assert np.all(np.abs(replanned.log["twa_deg"].values) >= YACHT.polar.no_go_deg)


def test_bad_policies_and_arguments_name_the_value():
    with pytest.raises(ConfigError, match="wind_direction_threshold_deg=200.0"):
        ReplanPolicy(wind_direction_threshold_deg=200.0)
    with pytest.raises(ConfigError, match="wind_speed_threshold_kn=-1"):
        ReplanPolicy(wind_speed_threshold_kn=-1)
    with pytest.raises(ConfigError, match="step_h"):
        simulate_sailing((A, B), _wind(0.0), YACHT, forecasts=[(T0, _wind(0.0))], departure=T0, step_h=0.0)
    with pytest.raises(ConfigError, match="vessel must be a SailingVessel"):
        simulate_sailing((A, B), _wind(0.0), "yacht", forecasts=[(T0, _wind(0.0))], departure=T0)  # type: ignore[arg-type]


def test_a_leg_the_truth_puts_in_the_no_go_sector_forces_a_replan_even_sailing_blind():
    # the forecast easterly puts the destination due north on the beam; the true northerly puts it dead upwind
    res = simulate_sailing((A, B), _wind(0.0), YACHT, forecasts=[(T0, _wind(90.0))], departure=T0,
                           replan=ReplanPolicy.never(), step_h=STEP_H, search_options=SEARCH)  # fmt: skip
    assert res.outcome.n_replans == 1 and "no-go sector" in str(res.log["replan_reason"].values[1])
    assert res.log["replan_time"].values[1] == T0  # before the first step: the first leg cannot be sailed
    assert np.all(np.abs(res.log["twa_deg"].values) >= YACHT.polar.no_go_deg)
    # then it beats as in the steady northerly
    assert res.outcome.passage_h == pytest.approx(6 * DIAG_NM / _speed(DIAG_DEG), rel=1e-3)


def test_the_ship_simulator_refuses_the_wind_thresholds_it_does_not_use():
    import optroute as orx

    wind = _wind(0.0)
    with pytest.raises(ConfigError, match="wind thresholds are the sailing simulator's trigger"):
        orx.simulate_voyage((A, B), wind, orx.Ship.preset("container_54k_dwt"), forecasts=[(T0, wind)],
                            departure=T0, replan=ReplanPolicy(wind_speed_threshold_kn=2.0))  # fmt: skip
