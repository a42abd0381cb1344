"""The robust NLP's start (issue 16): the 3-D DP on the members' joint leg cost, checked by the referee.

``ensemble_dp_path`` claims a schedule safe in every member: sailed as a plan, :meth:`Plan.verify` in each member
(the referee, independent of the DP's piecewise checks) must find nothing, and the DP's fuel must be the members'
mean of the referee's fuel (to the quadrature's difference: 10 nm pieces against the referee's 5 nm steps).
The ensemble is ``tests/test_robust.py``'s three stationary 8.7 m storms (north of, on and south of the track).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
import xarray as xr

import optroute as orx
from formulations.robust_nlp import RobustSpeedNLP
from optroute.optimise import robust_start
from optroute.optimise.robust import member_datasets, prepare_members
from optroute.optimise.robust_start import ensemble_dp_path, members_with_passage
from optroute.plan.result import Plan
from optroute.search.dp_kernels import JointLegKernel, stacked_inputs
from optroute.weather import storms

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
ETA_H = 6.2  # 156 nm: about 25.2 kn, over the MCR in the on-track storm's member at a constant speed


def _shared(eta_h: float) -> dict:
    return {
        "departure": T0, "latest_eta": T0 + np.timedelta64(int(eta_h * 60), "m"), "objective": "fuel",
        "model": None, "rules": None, "max_leg_nm": 30.0, "samples_per_leg": 3, "fuel_price_per_t": 600.0,
        "hourly_cost_per_h": 0.0, "exclusion": None, "speed_range_kn": None, "band_margin": 0.005,
        "band_hs_margin": 0.05, "verify_step_nm": 5.0, "use_land_mask": False,
    }  # fmt: skip


@pytest.fixture(scope="module")
def members() -> list[xr.Dataset]:
    kw = {"start": T0, "duration_h": 12.0, "step_h": 3.0, "resolution_deg": 0.5, "background_hs_m": 1.5}
    out = []
    for dlat in (2.5, 0.0, -2.5):
        storm = storms.moving_storm_spec(30.0 + dlat, -148.5, 90.0, 0.5, peak_hs_m=8.7, radius_nm=40.0, duration_h=12.0)
        out.append(storms.storm_dataset([storm], bbox=(25, 35, -152, -145), **kw))
    ens = xr.concat(out, dim="member")
    ens.attrs = {k: v for k, v in out[0].attrs.items() if k != "storms"}
    return member_datasets(ens)


def _prepared(members: list[xr.Dataset], eta_h: float):
    corridor = orx.Corridor.from_waypoints([(30.0, -150.0), (30.0, -147.0)], width_nm=0.0)
    prepared, _, _ = prepare_members(corridor, members, SHIP, _shared(eta_h), 0)
    return prepared


def test_joint_dp_schedule_is_clean_in_every_member(members: list[xr.Dataset]) -> None:
    eta_h = 6.5  # the lattice's earliest safe arrival in all three is 6.32 h (1 kn speeds, 1 h bins)
    prepared = _prepared(members, eta_h)
    ref = prepared[0]
    path = ensemble_dp_path(prepared, ref.frame, eta_h, float(np.min(ref.v_min)), float(np.max(ref.v_max)))
    assert path.arrival_h <= eta_h + 1e-9
    eta = T0 + np.timedelta64(int(eta_h * 3600), "s")
    plan = Plan.from_context(
        ref.plan_context(eta, "le"), np.column_stack([path.lat_deg, path.lon_deg]), path.extra["stw_kn"],
        departure=T0, status="candidate", step_nm=5.0,
    )  # fmt: skip
    for m in members:
        assert plan.verify(weather=m) == []
    referee = np.mean([plan.in_weather(m).total_fuel_t for m in members])
    assert path.total_fuel_t == pytest.approx(referee, rel=0.01)


def test_the_lattice_is_no_proof_the_nlp_is_still_tried(members: list[xr.Dataset]) -> None:
    """By 6.2 h the lattice has no schedule in the on-track storm's member (its speeds every 1 kn): InfeasibleETA
    naming it; the robust call still returns a plan from the NLP (continuous speeds), clean in every member."""
    prepared = _prepared(members, ETA_H)
    ref = prepared[0]
    alone = members_with_passage(prepared, ref.frame, ETA_H, float(np.min(ref.v_min)), float(np.max(ref.v_max)))
    assert alone == [True, False, True]
    with pytest.raises(orx.InfeasibleETA, match=r"members with a schedule of their own .*: \[0, 2\]; without: \[1\]"):
        ensemble_dp_path(prepared, ref.frame, ETA_H, float(np.min(ref.v_min)), float(np.max(ref.v_max)))
    ens = xr.concat(members, dim="member")
    ens.attrs = dict(members[0].attrs)
    corridor = orx.Corridor.from_waypoints([(30.0, -150.0), (30.0, -147.0)], width_nm=0.0)
    eta = T0 + np.timedelta64(int(ETA_H * 60), "m")
    plan = orx.optimise_corridor(
        corridor, ens, SHIP, departure=T0, eta=eta, robust="all", max_leg_nm=30.0, samples_per_leg=3,
        use_land_mask=False,
    )  # fmt: skip
    for m in members:
        assert plan.verify(weather=m) == []  # the ETA too (to the referee's tolerance)
    assert plan.arrival - eta < np.timedelta64(1, "s")
    assert plan.solver_stats["start"] == "centreline" and "without: [1]" in plan.solver_stats["start_evidence"]


def test_compiled_joint_transitions_equal_every_transition_costed(
    members: list[xr.Dataset], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The joint DP's compiled transitions (best first under the members' mean fuel floor) against the same DP with
    every transition costed through the joint Python callback: the same schedule, fuel and times."""
    eta_h = 6.5
    prepared = _prepared(members, eta_h)
    ref = prepared[0]
    args = (prepared, ref.frame, eta_h, float(np.min(ref.v_min)), float(np.max(ref.v_max)))
    joint = robust_start._joint_cost
    kernel = joint([ph.dp_leg(10.0) for ph in robust_start._physics(prepared)]).dp_kernel
    assert isinstance(kernel, JointLegKernel) and stacked_inputs(kernel.members) is not None  # one grid: compiled
    compiled = ensemble_dp_path(*args)
    # a partial has no dp_kernel: solve_dp costs every transition through the callback
    monkeypatch.setattr(robust_start, "_joint_cost", lambda costs: functools.partial(joint(costs)))
    plain = ensemble_dp_path(*args)
    np.testing.assert_array_equal(compiled.lateral_index, plain.lateral_index)
    np.testing.assert_allclose(compiled.times_h, plain.times_h, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(compiled.extra["stw_kn"], plain.extra["stw_kn"], rtol=1e-12)
    assert compiled.total_fuel_t == pytest.approx(plain.total_fuel_t, rel=1e-12)


def test_where_no_solve_is_clean_the_lattice_schedule_clean_in_every_member_is_returned_as_the_start(
    members: list[xr.Dataset], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every robust solve made to fail (Ipopt's Infeasible_Problem_Detected, as bench_voyage's 200 nm east case): the
    call returns the joint DP's schedule, labelled 'start' (not optimal), clean in every member by the referee."""
    solve = RobustSpeedNLP.solve_sides

    def failing(self, **kw):
        res = solve(self, **kw)
        return dataclasses.replace(res, success=False, status="Infeasible_Problem_Detected", max_violation=0.28)

    monkeypatch.setattr(RobustSpeedNLP, "solve_sides", failing)
    ens = xr.concat(members, dim="member")
    ens.attrs = dict(members[0].attrs)
    corridor = orx.Corridor.from_waypoints([(30.0, -150.0), (30.0, -147.0)], width_nm=0.0)
    eta = T0 + np.timedelta64(int(6.5 * 60), "m")
    plan = orx.optimise_corridor(
        corridor, ens, SHIP, departure=T0, eta=eta, robust="all", max_leg_nm=30.0, samples_per_leg=3,
        use_land_mask=False,
    )  # fmt: skip
    assert plan.status == "start" and plan.solver_stats["start"] == "ensemble_dp"
    assert "Infeasible_Problem_Detected" in plan.solver_stats["status_reason"]
    for m in members:
        assert plan.verify(weather=m) == []
    assert plan.arrival <= eta
    stats = plan.solver_stats["robust"]
    assert stats["fuel_mean_t"] == pytest.approx(np.mean([plan.in_weather(m).total_fuel_t for m in members]))
