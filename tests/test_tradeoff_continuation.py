"""The front's continuation: a verified neighbour is a point's only start.

Reference, independent of the NLP: calm water on a fixed path, where the least fuel to arrive by T is at
the constant speed D/T, fuel T · fuel_rate(calm_power(D/T)) from the Ship's own curves.
"""

from __future__ import annotations

import importlib
import inspect

import numpy as np
import pytest

import optroute as orx
from optroute.studies.tradeoff import tradeoff

points_mod = importlib.import_module("optroute.studies.front_points")
stage_mod = importlib.import_module("optroute.optimise.start_stage")
SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
KW = {"max_leg_nm": 150.0, "use_land_mask": False}
CORRIDOR = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -20.0]], width_nm=0.0)


def _count_centreline_starts(monkeypatch) -> list[float | None]:
    """The passage cap [h] of every centreline start the start stage builds, in order (filled as they are built)."""
    built: list[float | None] = []
    original = stage_mod._centre_candidate

    def counting(prepared, ctx, cap_h, objective, st):
        built.append(cap_h)
        return original(prepared, ctx, cap_h, objective, st)

    monkeypatch.setattr(stage_mod, "_centre_candidate", counting)
    return built


def test_a_verified_neighbour_is_the_only_start_and_the_front_stays_the_calm_optimum(monkeypatch):
    """Inside a chain each point starts from its neighbour's verified plan without building the centreline's
    safe start (only the two end solves and a chain's first point, whose warm plan is an end's, do); every
    point is still the calm-water optimum by hand."""
    built = _count_centreline_starts(monkeypatch)
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=6, chains=1, **KW)
    interior = front.solve.values == "eta"
    # the ends only: the chain's first point starts from the slow end, its neighbour, alone (main built one for every
    # point, then one for the chain's first point too)
    assert len(built) <= 2
    # the chain runs from the slow end: its first point is the latest ETA between the ends, the rest start from
    # the point before them
    assert interior.sum() == 4 and (front.warm_start.values[interior][:-1] == "warm plan").all()
    v = CORRIDOR.length_nm / front.eta_h.values[interior]
    by_hand = front.eta_h.values[interior] * SHIP.fuel_rate_tph(SHIP.calm_power_kw(v))
    np.testing.assert_allclose(front.fuel_t.values[interior], by_hand, rtol=1e-5)


def _calm():
    return orx.scenarios.uniform(
        hs_m=0.0, tp_s=6.0, bbox=(-10, 10, -40, 0), start=T0, duration_h=240, resolution_deg=1.0
    )


def test_a_mended_neighbour_is_verified_once_per_point(monkeypatch):
    """The front's start is the referee's verified plan for the point's ETA: the start stage takes it as the warm
    plan's verdict instead of evaluating and verifying the same track and speeds again. The chain's first point
    gets it from :func:`mended_start` (the end's plan evaluated for its ETA), the others from
    :meth:`~optroute.plan.result.Plan.for_later_eta` (the earlier neighbour's verified plan, not evaluated again).
    Counted against the interior points by hand; the front is still the calm-water optimum, and identical to the
    bit to the one whose start stage evaluates and verifies every start itself."""
    calls: list[int] = []
    original = stage_mod.verified_plan

    def counting(*args, **kwargs):  # the warm plan's verifications only (the ends' own starts verify theirs)
        if inspect.stack()[1].function == "_warm_plan_candidate":
            calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(stage_mod, "verified_plan", counting)
    evaluated: list[int] = []
    real_mended = points_mod.mended_start
    monkeypatch.setattr(points_mod, "mended_start", lambda *a: evaluated.append(1) or real_mended(*a))
    front = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=6, chains=1, **KW)
    interior = front.solve.values == "eta"
    assert interior.sum() == 4
    # the four points' warm plans come verified (the ends have none): the first by mended_start, three carried
    assert len(calls) == 0 and len(evaluated) == 1
    v = CORRIDOR.length_nm / front.eta_h.values[interior]
    by_hand = front.eta_h.values[interior] * SHIP.fuel_rate_tph(SHIP.calm_power_kw(v))
    np.testing.assert_allclose(front.fuel_t.values[interior], by_hand, rtol=1e-5)

    # the same front with the verdicts dropped (the start stage evaluates and verifies each start itself):
    # bit-identical, so the carried verdict is the one an evaluation gives
    mended = points_mod.mended_start
    monkeypatch.setattr(points_mod, "mended_start", lambda *a: points_mod.replace_fields(mended(*a), verified=None))
    monkeypatch.setattr(orx.Plan, "for_later_eta", lambda self, *a, **k: None)
    again = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=6, chains=1, **KW)
    assert len(calls) == interior.sum()
    np.testing.assert_array_equal(again.fuel_t.values, front.fuel_t.values)
    np.testing.assert_array_equal(again.leg_stw_kn.values, front.leg_stw_kn.values)


def test_a_chain_started_across_other_chains_etas_compares_the_centreline(monkeypatch):
    """Of two chains, the one next to the fast end starts from its plan alone; the other, whose first ETA the fast
    plan reaches long before it (across the first chain's ETAs), builds the centreline's start beside it. Both stay
    the calm optimum."""
    built = _count_centreline_starts(monkeypatch)
    one = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=6, chains=1, **KW)
    ends = len(built)
    built.clear()
    two = tradeoff(CORRIDOR, _calm(), SHIP, departure=T0, n=6, chains=2, **KW)
    interior = two.solve.values == "eta"
    # the second chain's first ETA (the earliest of the two latest interior ETAs) only
    assert len(built) == ends + 1 and built[-1] == pytest.approx(two.eta_h.values[interior][2], rel=1e-12)
    v = CORRIDOR.length_nm / two.eta_h.values[interior]
    by_hand = two.eta_h.values[interior] * SHIP.fuel_rate_tph(SHIP.calm_power_kw(v))
    np.testing.assert_allclose(two.fuel_t.values[interior], by_hand, rtol=1e-5)
    np.testing.assert_allclose(one.fuel_t.values, two.fuel_t.values, rtol=1e-5)


def test_a_plan_for_a_later_eta_is_the_plan_verified_there_and_never_for_an_earlier_one():
    """:meth:`~optroute.plan.result.Plan.for_later_eta` against the referee: the plan of a 40 h ETA, re-labelled for
    45 h, verifies there (``Plan.verify()`` in its new context) with the same legs; for 35 h, or from an exact-ETA
    plan, it is refused."""
    plan = orx.optimise_corridor(CORRIDOR, _calm(), SHIP, departure=T0, eta=T0 + np.timedelta64(40, "h"), **KW)
    later = plan.for_later_eta(T0 + np.timedelta64(45, "h"), status="start")
    assert later is not None and later.status == "start" and later.context.eta == T0 + np.timedelta64(45, "h")
    assert later.verify() == [] and later.total_fuel_t == plan.total_fuel_t
    np.testing.assert_array_equal(later.stw_kn, plan.stw_kn)
    assert plan.for_later_eta(T0 + np.timedelta64(35, "h"), status="start") is None  # an earlier ETA: not its verdict
    exact = orx.optimise_corridor(CORRIDOR, _calm(), SHIP, departure=T0, eta=T0 + np.timedelta64(40, "h"),
                                  eta_mode="eq", **KW)  # fmt: skip
    assert exact.for_later_eta(T0 + np.timedelta64(45, "h"), status="start") is None  # "eq": arriving early breaks it
