"""A discrete plan as the NLP's warm start (starts.track_warm_start): hand-worked leg speeds that keep its timing.

The 3-D DP's stages and the NLP's legs need not coincide: a DP plan of short stages that alternates speeds (around a
band) becomes one speed per longer NLP leg. Each NLP leg takes the speed that sails it in the time the plan takes
over the same stretch, so the warm start passes the stations when the plan does and arrives with it.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import geodesy as geo
from optroute.optimise.nlp_inputs import build_frame
from optroute.optimise.starts import Candidate, track_warm_start, warm_is_plan


def _equator(n_legs: int, length_deg: float = 2.0) -> orx.Corridor:
    lon = np.linspace(0.0, length_deg, n_legs + 1)
    return orx.Corridor.from_waypoints(np.column_stack([np.zeros_like(lon), lon]), width_nm=20.0)


def test_two_nlp_legs_over_four_dp_stages_take_the_harmonic_mean_of_their_speeds() -> None:
    frame = build_frame(_equator(2))
    track = np.column_stack([np.zeros(5), np.linspace(0.0, 2.0, 5)])  # four stages of equal length on the centreline
    stage_nm = float(frame.s_nm[-1]) / 4.0
    warm = track_warm_start(track, np.array([10.0, 20.0, 10.0, 20.0]), frame)
    # each NLP leg is two stages: 2 d / (d/10 + d/20) = 13.33 kn, whatever d
    np.testing.assert_allclose(warm["stw_kn"], [40.0 / 3.0, 40.0 / 3.0], rtol=1e-9)
    np.testing.assert_allclose(warm["offset_nm"], 0.0, atol=1e-9)
    hours = np.sum(np.diff(frame.s_nm) / warm["stw_kn"])
    np.testing.assert_allclose(hours, stage_nm * (2 / 10.0 + 2 / 20.0), rtol=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    stages=st.integers(min_value=1, max_value=9),
    legs=st.integers(min_value=1, max_value=7),
    speeds=st.lists(st.floats(min_value=3.0, max_value=25.0), min_size=9, max_size=9),
)
def test_the_warm_start_arrives_when_the_track_does(stages: int, legs: int, speeds: list[float]) -> None:
    frame = build_frame(_equator(legs))
    lon = np.linspace(0.0, 2.0, stages + 1)
    track = np.column_stack([np.zeros_like(lon), lon])
    stw = np.asarray(speeds[:stages])
    stage_nm = geo.distance_nm(track[:-1, 0], track[:-1, 1], track[1:, 0], track[1:, 1])
    warm = track_warm_start(track, stw, frame)
    np.testing.assert_allclose(np.sum(np.diff(frame.s_nm) / warm["stw_kn"]), np.sum(stage_nm / stw), rtol=1e-6)
    assert np.all(warm["stw_kn"] >= stw.min() - 1e-9) and np.all(warm["stw_kn"] <= stw.max() + 1e-9)


def test_a_warm_start_is_its_plan_only_on_the_nlps_own_legs() -> None:
    corridor = _equator(3)
    frame = build_frame(corridor)
    wx = orx.scenarios.calm(bbox=(-5, 5, -2, 5), start=np.datetime64("2024-01-10T00:00"), duration_h=48)
    ship = orx.Ship.preset("container_54k_dwt")
    t0 = np.datetime64("2024-01-10T00:00", "ns")
    on_legs = orx.Plan.from_schedule(frame.waypoints(np.zeros(4)), [12.0, 14.0, 13.0], departure=t0, ship=ship,
                                     weather=wx)  # fmt: skip
    warm = track_warm_start(on_legs.waypoints, on_legs.stw_kn, frame)
    assert warm_is_plan(Candidate("centreline start", warm, on_legs, on_legs.total_fuel_t), frame)
    track = np.column_stack([np.zeros(7), np.linspace(0.0, 2.0, 7)])  # six stages: mapped onto three legs
    staged = orx.Plan.from_schedule(track, [12.0, 14.0, 12.0, 14.0, 12.0, 14.0], departure=t0, ship=ship, weather=wx)
    mapped = track_warm_start(staged.waypoints, staged.stw_kn, frame)
    assert not warm_is_plan(Candidate("3-D DP", mapped, staged, staged.total_fuel_t), frame)
    assert not warm_is_plan(Candidate("3-D DP", mapped, None, float("inf")), frame)
