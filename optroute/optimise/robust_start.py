"""A start for the robust NLP that is safe in every member, or the evidence that no lattice schedule is.

The robust NLP (:mod:`formulations.robust_nlp`) is a local method: its band sides and the samples where a band
applies are fixed from its start, and from the centreline at the ETA's constant speed the members can ask for
opposite sides of one band (one member's storm is passed ahead of it, another's behind it), so Ipopt declares the
stacked problem infeasible where a schedule safe in every member exists. The discrete start of the single-weather
corridor NLP (:func:`optroute.optimise.starts.dp_route`) is the 3-D dynamic programme of Shao et al.; here the same
DP (:func:`optroute.search.dp.solve_dp`) runs on the members' *joint* leg cost: a leg is feasible only where it is in
every member (each member's :meth:`~optroute.search.passage_physics.PassagePhysics.dp_leg`: engine range and the
referee's danger bands, piece by piece), a node is navigable only where it is in every member, and the leg's fuel is
the members' mean (the robust objective's). Its least-fuel path by the ETA is the NLP's start, so the sides the NLP
keeps are those of a schedule safe in all members. Where the DP finds no schedule by the ETA safe in every member,
its answer is the evidence: the earliest arrival safe in all members (:class:`~optroute.errors.InfeasibleETA`), or
none at all within the weather's horizon (:class:`~optroute.errors.NoSafePassage`), with the members that each
alone has a lattice schedule by the ETA and those that have none.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute.errors import InfeasibleETA, NoSafePassage
from optroute.geo.tracks import inner_offset_nm
from optroute.search.dp import DPPath, solve_dp
from optroute.search.dp_kernels import JointLegKernel
from optroute.search.dp_route import dp_navigable
from optroute.search.dp_stages import in_every_member
from optroute.search.edge_land import legs_on_land
from optroute.search.passage_physics import PassagePhysics
from optroute.units import format_utc
from optroute.units import h_to_timedelta as _h_to_td

__all__ = ["ensemble_dp_path", "members_with_passage"]

#: Piece length of the DP's leg checks [nm] (as the search's default piece).
PIECE_NM = 10.0


def _physics(prepared: Sequence[Any]) -> list[PassagePhysics]:
    return [PassagePhysics(p.ship, p.model, p.rules, p.sampler, p.departure) for p in prepared]


def _joint_cost(costs: list[Callable]) -> Callable:
    """Leg cost feasible only where every member's is; fuel the members' mean (the robust objective's).

    Each member costs only the legs every member before it allowed (a leg one member forbids is not costed in the
    rest). Where every member's callback has its compiled form, the joint one has too
    (:class:`~optroute.search.dp_kernels.JointLegKernel`): :func:`~optroute.search.dp.solve_dp` then costs its
    transitions in compiled code, best first under the members' mean fuel floor, as it does for one weather."""

    def cost(lat0, lon0, lat1, lon1, t0_h, sog_kn):
        legs = (lat0, lon0, lat1, lon1, t0_h, sog_kn)
        dur = np.asarray(geo.distance_nm(lat0, lon0, lat1, lon1)) / np.asarray(sog_kn)  # commanded SOG: every member's

        def member(c: Callable) -> Callable[[np.ndarray], tuple]:
            def legs_of(idx: np.ndarray) -> tuple:
                _, f, ok, extra = c(*(np.ascontiguousarray(np.asarray(a)[idx]) for a in legs))
                return f, ok, extra

            return legs_of

        fuel, feas, extra = in_every_member(np.size(lat0), [member(c) for c in costs], ("stw_kn",))
        return dur, fuel, feas, extra

    kernels = [getattr(c, "dp_kernel", None) for c in costs]
    if all(k is not None for k in kernels):  # solve_dp's compiled transitions, costed in every member
        cost.dp_kernel = JointLegKernel(tuple(kernels))  # type: ignore[attr-defined]
    return cost


def _solve(physics: list[PassagePhysics], frame: Any, eta_h: float, speeds: np.ndarray, exclusion: Any, coast: bool):
    """The DP on these members' joint cost: (path by the ETA or None, earliest safe arrival [h] or None)."""
    wp = frame.corridor.waypoints
    length = float(frame.s_nm[-1])
    dx = max(20.0, length / 12.0)
    half = inner_offset_nm(float(np.max(frame.corridor.half_width_nm)), dx)  # legs between edge states stay inside
    t_last = float((physics[0].sampler.extent["time"][1] - physics[0].departure) / np.timedelta64(1, "h"))
    try:
        res = solve_dp(
            (float(wp[0, 0]), float(wp[0, 1])), (float(wp[-1, 0]), float(wp[-1, 1])),
            _joint_cost([ph.dp_leg(PIECE_NM) for ph in physics]), eta_h=None, dx_nm=dx,
            dy_nm=max(half / 5.0, 1.0), half_width_nm=half, speeds_kn=speeds, dt_h=1.0,
            navigable=dp_navigable(physics, exclusion, coast), horizon_h=max(t_last, eta_h),
            legs_blocked=legs_on_land if coast else None,
        )  # fmt: skip
    except NoSafePassage:
        return None, None
    earliest = float(res.earliest_arrival_h)
    try:
        return res.path_for_eta(eta_h), earliest
    except InfeasibleETA:
        return None, earliest


def ensemble_dp_path(
    prepared: Sequence[Any], frame: Any, eta_h: float, v_min_kn: float, v_max_kn: float, exclusion: Any = None
) -> DPPath:
    """The least-mean-fuel lattice schedule by the ETA that is safe in every member (module docstring).

    Parameters
    ----------
    prepared : sequence of PreparedCorridor
        The members, prepared on one corridor (:func:`optroute.optimise.robust.prepare_members`).
    frame : CorridorFrame
        The corridor's frame (the great circle from its start to its end is the DP's centreline).
    eta_h : float
        Latest arrival [h after departure].
    v_min_kn, v_max_kn : float
        The speed range of the DP's speed set (every 1 kn) [kn].
    exclusion : Exclusion, optional
        A moving area the nodes keep out of.

    Raises
    ------
    InfeasibleETA
        Every member's lattice schedule arrives after the ETA: the message gives the earliest arrival safe in all.
    NoSafePassage
        No lattice schedule within the weather's horizon is safe in all members; the message names the members with
        a schedule by the ETA alone and those without.
    """
    physics = _physics(prepared)
    speeds = _speeds(v_min_kn, v_max_kn)
    coast = bool(prepared[0].use_land_mask)
    path, earliest = _solve(physics, frame, eta_h, speeds, exclusion, coast)
    if path is not None:
        return path
    t0 = physics[0].departure
    eta = format_utc(t0 + _h_to_td(eta_h))
    alone = members_with_passage(prepared, frame, eta_h, v_min_kn, v_max_kn, exclusion)
    own = f"members with a schedule of their own by {eta}: {[k for k, a in enumerate(alone) if a]}; without: " + str(
        [k for k, a in enumerate(alone) if not a]
    )
    grid = f"on the 3-D DP's lattice ({speeds[0]:g}-{speeds[-1]:g} kn every 1 kn, 1 h bins, {PIECE_NM:g} nm checks)"
    if earliest is not None:
        raise InfeasibleETA(
            f"no schedule safe in all {len(physics)} members arrives by the ETA {eta} {grid}: the earliest safe in "
            f"every member arrives at {format_utc(t0 + _h_to_td(earliest))} ({own}); give an ETA after that, or plan "
            "on fewer members (robust='chance' lets a stated fraction be broken)"
        )
    raise NoSafePassage(
        f"no schedule {grid} is safe in all {len(physics)} members within the weather's horizon ({own}): their "
        "danger areas leave no common passage; widen the corridor, or plan on fewer members (robust='chance')"
    )


def _speeds(v_min_kn: float, v_max_kn: float) -> np.ndarray:
    return np.arange(max(float(v_min_kn), 3.0), float(v_max_kn) + 1e-9, 1.0)


def members_with_passage(
    prepared: Sequence[Any], frame: Any, eta_h: float, v_min_kn: float, v_max_kn: float, exclusion: Any = None
) -> list[bool]:
    """Per member, whether the 3-D DP on that member alone finds a safe schedule by the ETA (as
    :func:`ensemble_dp_path`'s lattice): a member without one cannot be in any plan robust over a set of members."""
    speeds = _speeds(v_min_kn, v_max_kn)
    coast = bool(prepared[0].use_land_mask)
    return [_solve([ph], frame, eta_h, speeds, exclusion, coast)[0] is not None for ph in _physics(prepared)]
