"""What :meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` reports of a solve.

* :func:`table_error`: the NLP's fuel against the referee's for the very same track and schedule — the
  measured error of the ship's power table (:mod:`optroute.optimise.power_table`), at the warm start
  and at the solution (``solver_stats["start_tabulation"]``, ``solver_stats["tabulation"]``);
* :func:`solution_stats`: the statistics of an NLP solution, with the NLP model's own dual bound on a
  fixed path in static weather (:func:`optroute.optimise.nlp_solve.certificate`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from optroute.errors import OptrouteError
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.optimise.nlp_solve import Solved, certificate
from optroute.optimise.rescue import certificate_reason
from optroute.plan.result import Exclusion, Plan, PlanContext
from optroute.units import h_to_timedelta

__all__ = ["solution_stats", "table_error"]


def table_error(
    ctx: PlanContext,
    frame: CorridorFrame,
    *,
    offset_nm: np.ndarray,
    stw_kn: np.ndarray,
    time_h: np.ndarray,
    nlp_fuel_t: float,
    departure: np.datetime64,
    step_nm: float,
) -> dict[str, float]:
    """The NLP's fuel [t] of a track and schedule against the referee's fuel of the same.

    Parameters
    ----------
    ctx : PlanContext
        The referee's context.
    frame : CorridorFrame
        The corridor's frame: offsets (N+1,) [nm, port +] become waypoints.
    offset_nm, stw_kn, time_h : numpy.ndarray
        The NLP's offsets, leg speeds through water (N,) [kn] and waypoint times (N+1,) [h after departure].
    nlp_fuel_t : float
        The NLP model's fuel of the same [t].
    departure : numpy.datetime64
        [UTC].
    step_nm : float
        The referee's spacing [nm].

    Returns
    -------
    dict
        ``nlp_fuel_t``, ``referee_fuel_t`` [t] and ``rel_error`` = NLP / referee − 1 [-] (NaN where the referee
        cannot evaluate the track: it then gives no plan either).
    """
    try:
        same = Plan.from_context(
            ctx,
            frame.waypoints(np.asarray(offset_nm, dtype=float)),
            np.asarray(stw_kn, dtype=float),
            departure=departure,
            times=departure + h_to_timedelta(np.asarray(time_h, dtype=float)),
            status="candidate",
            step_nm=step_nm,
        )
    except OptrouteError:
        return {"nlp_fuel_t": float(nlp_fuel_t), "referee_fuel_t": float("nan"), "rel_error": float("nan")}
    referee = float(same.total_fuel_t)
    rel = float(nlp_fuel_t) / referee - 1.0 if referee > 0 else float("nan")
    return {"nlp_fuel_t": float(nlp_fuel_t), "referee_fuel_t": referee, "rel_error": rel}


def solution_stats(
    ctx: PlanContext,
    frame: CorridorFrame,
    sol: Solved,
    *,
    eta_solve: float | None,
    eta_mode: str,
    objective: str,
    fixed: bool,
    samples: Any,
    exclusion: Exclusion | None,
    fuel_price: float,
    hourly_cost: float,
    band_names: tuple[str, ...],
    departure: np.datetime64,
    step_nm: float,
) -> dict[str, Any]:
    """Statistics of the returned NLP solution: its table error by the referee, the NLP model's certificate.

    ``fixed`` says the path is fixed (no lateral freedom); ``samples`` is the weather grid's summary
    (:func:`optroute.optimise.nlp_inputs.weather_grid`); ``eta_solve`` the ETA solved [h after departure].
    """
    res = sol.res
    tab = table_error(
        ctx,
        frame,
        offset_nm=res.offset_nm,
        stw_kn=res.stw_kn,
        time_h=res.time_h,
        nlp_fuel_t=float(res.total_fuel_t),
        departure=departure,
        step_nm=step_nm,
    )
    cert: dict[str, Any] = {"method": "not applicable", "gap": float("nan")}
    reason = certificate_reason(fixed, samples, res, exclusion, objective)
    if reason is None:
        cert = certificate(
            sol.nlp,
            res,
            objective=objective,
            eta_h=eta_solve,
            eta_mode=eta_mode,
            fuel_price=fuel_price,
            hourly_cost=hourly_cost,
        )
    else:
        cert["reason"] = reason
    return {
        "ipopt_status": res.status,
        "outer_solves": sol.n_solves,
        "outer_flips": sol.flips,
        "outer_history": sol.history,
        "sides_settled": sol.sides_settled,
        "mended_legs": sol.mended_legs,
        "nlp_objective": float(res.objective),
        "nlp_fuel_t": float(res.total_fuel_t),
        "nlp_max_violation": float(res.max_violation),
        "tabulation": tab,
        "frame_max_rel_distance_error": frame.distance_error(res.offset_nm),
        "bands": list(band_names),
        "certificate": cert,
        "eta_h_solved": eta_solve,
    }
