"""The timed safe start and the minimum-time solve through a place and time where no speed is allowed.

The planted sea: on an east-going fixed path along the equator, a 24 nm stretch has 12 m beam seas
from the north whose period is the ship's roll period for four hours. In beam seas the encounter
period is the wave period at every speed, so synchronous roll forbids *every* speed there and then
(physics.md §3): a ship must not be in the stretch during that window. At top speed it would be, so
the earliest arrival (worked by hand below) waits for the window to pass.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import geodesy as orx_geodesy
from optroute.optimise.api import optimise_corridor
from optroute.optimise.min_time import DeadEnd, TimedStart, timed_safe_start
from optroute.weather import schema

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
LON0, LON1 = -30.0, -26.0  # the path [deg east] along the equator
ZONE = (-28.2, -27.8)  # the stretch [deg east]
WINDOW_H = (3.0, 6.0)  # the grid times [h] with 12 m there (1 m at the neighbouring times)
KW = {"max_leg_nm": 30.0, "use_land_mask": False}


def _blocked_sea(window_h: tuple[float, float] = WINDOW_H) -> xr.Dataset:
    time = T0 + (np.arange(0, 49) * 3.6e12).astype("timedelta64[ns]")
    lat = np.arange(-2.0, 2.01, 0.5)
    lon = np.round(np.arange(-31.0, -24.99, 0.1), 6)
    h = np.arange(time.size, dtype=float)
    in_time = (h >= window_h[0]) & (h <= window_h[1])
    in_zone = (lon >= ZONE[0] - 1e-9) & (lon <= ZONE[1] + 1e-9)
    hs = np.where(in_time[:, None, None] & in_zone[None, None, :], 12.0, 1.0) * np.ones((1, lat.size, 1))
    return schema.canonical_dataset(
        time,
        lat,
        lon,
        {
            "hs_m": hs,
            "tp_s": np.full(hs.shape, SHIP.roll_period_s),
            "wave_from_deg": np.zeros(hs.shape),
            # still air stated (a swell without wind): Kwon's Beaufort number is 0, so the 1 m sea is
            # calm for the speed loss and the hand-worked top-speed passages below hold; a missing wind
            # would be "not known" and take the Beaufort number from Hs
            "wind_u_ms": np.zeros(hs.shape),
            "wind_v_ms": np.zeros(hs.shape),
        },
        {"title": "planted beam-sea window", "geography": "synthetic"},
    )


def _corridor() -> orx.Corridor:
    return orx.Corridor.from_waypoints([[0.0, LON0], [0.0, LON1]], width_nm=0.0)


def _nm(lon_a: float, lon_b: float) -> float:
    return float(orx_geodesy.distance_nm(0.0, lon_a, 0.0, lon_b))


def _earliest_by_hand(v_max: float) -> tuple[float, float]:
    """Bounds on the earliest arrival [h]: the ship is west of the stretch until the 12 m sea is gone.

    Hs is interpolated linearly between the hourly grid times and the 0.1° cells; the band applies from
    0.04 L = 10 m. Between the window's last hour (12 m) and the next (1 m) Hs falls below 10 m at
    6 + 2/11 h; in space the 12 m cells reach 10 m 0.1° × 2/11 outside the stretch. A verified passage
    reaches the stretch's western edge no earlier than that time and then sails the rest at most at
    ``v_max``: the lower bound, less a quarter hour for the verifier's 5 nm sampling. The upper bound
    allows three quarters of an hour more (the search's 0.5 kn speed ladder and its cautious threshold).
    """
    gone_h = WINDOW_H[1] + 2.0 / 11.0
    west_edge = ZONE[0] - 0.1 * 2.0 / 11.0
    low = gone_h + _nm(west_edge, LON1) / v_max - 0.25
    return low, low + 1.0


@pytest.fixture(scope="module")
def sea():
    return _blocked_sea()


def test_timed_safe_start_sails_calm_water_at_top_speed_and_waits_for_the_blocked_window(sea):
    from optroute.optimise.corridor_problem import PreparedCorridor
    from optroute.optimise.nlp_solve import warm_rules

    pc = PreparedCorridor(_corridor(), sea, SHIP, departure=T0, objective="time", **KW)
    ctx = pc.plan_context()
    rules = warm_rules(pc.rules, pc._tightening())
    # calm everywhere (the window moved past the end of the data): every block at the top speed, by hand L / v_max
    calm = orx.Corridor.from_waypoints([[0.0, LON0], [0.0, -29.0]], width_nm=0.0)
    pc_calm = PreparedCorridor(calm, sea, SHIP, departure=T0, objective="time", **KW)
    ctx_calm = pc_calm.plan_context()
    fast = timed_safe_start(ctx_calm, pc_calm.frame, T0, v_min_kn=pc.v_min, v_max_kn=pc.v_max, rules=rules)
    assert isinstance(fast, TimedStart)
    assert fast.arrival_h == pytest.approx(_nm(LON0, -29.0) / pc.v_max, rel=1e-9)
    # the blocked window: the passage arrives no earlier than the hand bound, and every leg keeps out of it
    timed = timed_safe_start(ctx, pc.frame, T0, v_min_kn=pc.v_min, v_max_kn=pc.v_max, rules=rules)
    assert isinstance(timed, TimedStart)
    low, _ = _earliest_by_hand(pc.v_max)
    assert timed.arrival_h >= low
    # Boeing's reduction from the top speed meets the stretch inside the window: no allowed speed there
    from optroute.optimise.nlp_solve import safe_warm_start

    stuck = safe_warm_start(ctx, pc.frame, T0, pc.v_max, pc.v_min, rules=rules)
    assert np.any(stuck["stw_kn"] <= pc.v_min + 1e-9)
    # a window that never ends (all 48 h): no passage, and the dead end names the stretch
    never = _blocked_sea((3.0, 48.0))
    pc_never = PreparedCorridor(_corridor(), never, SHIP, departure=T0, objective="time", **KW)
    dead = timed_safe_start(
        ctx.__class__(**{**ctx.__dict__, "sampler": pc_never.sampler, "dataset": never}),
        pc_never.frame,
        T0,
        v_min_kn=pc.v_min,
        v_max_kn=pc.v_max,
        rules=rules,
    )
    assert isinstance(dead, DeadEnd)
    assert dead.from_nm <= _nm(LON0, ZONE[1]) and dead.to_nm >= _nm(LON0, ZONE[0]) - 30.0


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 60),
    seed=st.integers(0, 10_000),
    bucket_h=st.sampled_from([0.25, 0.5, 2.0]),
    strike=st.floats(0.0, 1.0),
)
def test_refining_each_buckets_earliest_pair_keeps_the_states_that_refining_every_pair_keeps(n, seed, bucket_h, strike):
    """The timed start refines only each arrival bucket's earliest pair not yet struck, round by round; the
    reference (brute force) strikes every pair the refinement fails, then keeps each bucket's earliest (ties in
    the given order). The refinement is stood in for by a fixed random verdict per pair (arrivals with ties)."""
    from optroute.optimise import min_time

    rng = np.random.default_rng(seed)
    prev, spd = np.divmod(rng.permutation(400)[:n], 20)
    arrive = np.round(rng.uniform(0.0, 6.0, n), 1)  # ties within and across buckets
    bad = rng.uniform(size=n) < strike
    index = {(int(p), int(v)): i for i, (p, v) in enumerate(zip(prev, spd, strict=True))}
    asked = []

    def verdict(ctx, rules, frame, t0, block, ladder, pairs, first):
        idx = np.array([index[(int(p), int(v))] for p, v in zip(*pairs, strict=True)], dtype=int)
        asked.extend(idx.tolist())
        return bad[idx], idx.size

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(min_time, "_refined_bad", verdict)
        keep, count = min_time._earliest_refined(None, None, None, None, None, None, (prev, spd, arrive), None,
                                                 bucket_h)  # fmt: skip
    order = np.lexsort((arrive, np.floor(arrive / bucket_h)))
    order = order[~bad[order]]
    bucket = np.floor(arrive[order] / bucket_h)
    want = order[np.concatenate([[True], bucket[1:] != bucket[:-1]])] if order.size else order
    np.testing.assert_array_equal(keep, want)
    assert count == len(asked) == len(set(asked))  # no pair refined twice
    assert set(keep.tolist()) <= set(asked)  # every state kept was refined


def test_minimum_time_through_a_blocked_window_returns_the_verified_timed_passage_honestly(sea, monkeypatch):
    from optroute.optimise.nlp_solve import Problem

    tally = {"solves": 0, "iterations": 0}
    counted = Problem._count

    def count(self, res):  # an independent tally of every Ipopt call and its iterations
        tally["solves"] += 1
        tally["iterations"] += int(res.iterations)
        counted(self, res)

    monkeypatch.setattr(Problem, "_count", count)
    # the NLP imposes a band where it applies at its start's timing and cannot leave a band by timing alone
    # (Hs below the threshold is not one of its sides): each solve from the timed passage converges to a plan the
    # referee finds in the band, and each retry from such a plan is infeasible. The call returns the verified start —
    # the timed passage — with status "start", the referee's verdict and Ipopt's status verbatim (of the last
    # solve, from the start again), arriving within the hand bounds
    best = optimise_corridor(_corridor(), sea, SHIP, departure=T0, objective="time", **KW)
    st = best.solver_stats
    assert best.status == "start" and st["ipopt_status"] == "Solve_Succeeded"
    assert st["first_solve"] == "rejected: band:synchronous_roll" and "failed verification" in st["status_reason"]
    assert "attempt 1: Ipopt Infeasible_Problem_Detected" in st["tightening"]
    assert best.solver_stats["start"] == "centreline start"
    assert best.verify() == []
    v_max = float(min(SHIP.max_calm_speed_kn, 40.0))
    low, high = _earliest_by_hand(v_max)
    assert low <= best.duration_h <= high
    # solver_stats counts every solve of the call, the failed ones behind the returned start included
    assert tally["solves"] >= 2
    assert best.solver_stats["nlp_solves"] == tally["solves"]
    assert best.solver_stats["iterations"] == tally["iterations"]


def test_the_centreline_start_is_a_passage_the_referee_accepts_where_the_speed_reduction_is_not(sea):
    # harness seeds 3, 4, 5 (general_cargo_25k_dwt, minimum time): Boeing's reduction found an allowed speed at
    # each of its own points, so it was kept as the start, but the referee (grid-cell and time-slice crossings,
    # adaptive refinement) finds it in a band between them; Ipopt then starts on sides no plan keeps. Here at
    # 20 kn the reduction is clean (no leg at the lowest speed) and enters the window's edge between its points
    from optroute.optimise.corridor_problem import PreparedCorridor
    from optroute.optimise.min_time import clean_start
    from optroute.optimise.nlp_solve import safe_warm_start, warm_rules
    from optroute.optimise.starts import verified_plan

    pc = PreparedCorridor(_corridor(), sea, SHIP, departure=T0, objective="time", **KW)
    ctx, frame = pc.plan_context(), pc.frame
    rules = warm_rules(pc.rules, pc._tightening())

    def verify(warm):
        return verified_plan(ctx, frame.waypoints(warm["offset_nm"]), warm["stw_kn"], T0, 5.0, "start")

    reduction = safe_warm_start(ctx, frame, T0, 20.0, pc.v_min, rules=rules)
    assert np.all(reduction["stw_kn"] > pc.v_min + 1e-9) and verify(reduction) is None
    warm, plan = clean_start(
        ctx, frame, T0, desired_kn=20.0, v_min_kn=pc.v_min, v_max_kn=pc.v_max, eta_h=None, rules=rules, verify=verify
    )
    assert plan is not None and plan.verify() == []
    assert np.all(warm["stw_kn"] <= 20.0 + 1e-9)  # the timed passage at speeds up to the desired one
