"""What :meth:`optroute.optimise.corridor_problem.PreparedCorridor.solve` reports of a solve.

* :func:`table_error`: the NLP's fuel against the referee's for the very same track and schedule — the
  measured error of the ship's power table (:mod:`optroute.optimise.power_table`), at the warm start
  and at the solution (``solver_stats["start_tabulation"]``, ``solver_stats["tabulation"]``);
* :func:`solution_stats`: the statistics of an NLP solution, with the NLP model's own dual bound on a
  fixed path in static weather (:func:`optroute.optimise.nlp_solve.certificate`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from formulations.speed_nlp import SpeedNLP
from optroute.errors import OptrouteError
from optroute.optimise.certificate import certificate_stats
from optroute.optimise.nlp_inputs import CorridorFrame
from optroute.optimise.nlp_solve import Solved, certificate
from optroute.optimise.power_table import sample_error
from optroute.optimise.rescue import certificate_reason
from optroute.physics.passage import SeaState
from optroute.physics.performance import PerformanceModel
from optroute.plan.result import Exclusion, Plan, PlanContext
from optroute.units import h_to_timedelta
from optroute.weather.sample import WeatherSampler

__all__ = ["CorridorReport", "leg_table_error", "solution_stats", "table_error"]


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
        cannot evaluate the track, it then gives no plan either, or finds a leg where no finite power makes the
        speed: a start the NLP's clipped speeds put out of the engine's reach).
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
    rel = float(nlp_fuel_t) / referee - 1.0 if 0.0 < referee < np.inf else float("nan")  # inf: no finite power
    return {"nlp_fuel_t": float(nlp_fuel_t), "referee_fuel_t": referee, "rel_error": rel}


def leg_table_error(
    nlp: SpeedNLP,
    frame: CorridorFrame,
    model: PerformanceModel,
    sampler: WeatherSampler,
    *,
    offset_nm: np.ndarray,
    stw_kn: np.ndarray,
    time_h: np.ndarray,
    departure: np.datetime64,
) -> dict[str, float | int]:
    """The NLP's power and leg fuel against the model's at the NLP's own samples of a track and schedule.

    :func:`optroute.optimise.power_table.sample_error` at the samples of ``nlp`` for offsets (N+1,) [nm, port +],
    leg speeds (N,) [kn] and waypoint times (N+1,) [h after departure]: each sample's position, time and
    heading (:attr:`formulations.nlp_result.SampleState.dev_deg` from the centreline direction there) in the
    referee's weather. Empty where the sampler cannot evaluate a sample (the referee then gives no plan either).
    """
    st = nlp.evaluate(offset_nm, stw_kn, time_h)
    lat, lon, along = frame.points(st.s_nm, st.y_nm)
    names = [v for v in ("hs_m", "tp_s", "tm_s", "wave_from_deg", "wind_u_ms", "wind_v_ms") if v in sampler.variables]
    try:
        sea = SeaState.from_sample(sampler.sample(departure + h_to_timedelta(st.time_h), lat, lon, variables=names))
    except OptrouteError:
        return {}
    weight = np.broadcast_to(np.asarray(nlp.sample_layout.weight, dtype=float), st.sog_kn.shape)
    return sample_error(
        model, nlp.power, sea, along - st.dev_deg, np.asarray(stw_kn, dtype=float), st.power_kw, st.fuel_rate_tph,
        weight / st.sog_kn,
    )  # fmt: skip


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
    model: PerformanceModel | None = None,
    sampler: WeatherSampler | None = None,
    tabulate: bool = True,
) -> dict[str, Any]:
    """Statistics of the returned NLP solution: its table error by the referee, the NLP model's certificate.

    ``fixed`` says the path is fixed (no lateral freedom); ``samples`` is the weather grid's summary
    (:func:`optroute.optimise.nlp_inputs.weather_grid`); ``eta_solve`` the ETA solved [h after departure].
    With the ship's ``model`` and the ``sampler``, ``tabulation`` also holds the per-leg and per-sample errors
    of :func:`leg_table_error`. ``tabulate=False``: ``tabulation`` is ``{}`` (no referee evaluation).
    """
    res = sol.res
    tab: dict[str, Any] = {}
    if tabulate:
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
        if model is not None and sampler is not None:
            tab.update(
                leg_table_error(
                    sol.nlp, frame, model, sampler, offset_nm=res.offset_nm, stw_kn=res.stw_kn, time_h=res.time_h,
                    departure=departure,
                )
            )  # fmt: skip
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


class CorridorReport:
    """The report stage of :class:`~optroute.optimise.corridor_problem.PreparedCorridor` (a base class): the ship's
    certificate of the returned plan, the power table's measured error at a start and the NLP solution's
    statistics, each read from the prepared corridor's own attributes (``problem``, ``frame``, ``table``,
    ``departure``, ``verify_step_nm``, ``model``, ``sampler``, prices and speed limits)."""

    fixed_path: bool

    def _ship_certificate(
        self, plan: Plan, stats: dict[str, Any], cap_h: float | None, eta_mode: str, objective: str
    ) -> dict[str, Any]:
        """The certificate of the ship itself for the returned plan (:mod:`optroute.optimise.certificate`).

        The Lagrangian dual bound of the true model, IMO SFOC and danger bands on a fixed path in static
        weather; the NLP model's own dual bound, where it was computed, is kept under ``"nlp_model"``.
        """
        nlp_model = stats.get("certificate", {"method": "not applicable", "gap": float("nan")})
        return certificate_stats(
            nlp_model,
            plan,
            fixed=self.fixed_path,
            objective=objective,
            eta_h=cap_h,
            eta_mode=eta_mode,
            fuel_price=self.fuel_price,
            hourly_cost=self.hourly,
            v_min_kn=self.v_min,
            v_max_kn=self.v_max,
            step_nm=self.verify_step_nm,
        )

    def _table_at(self, ctx: PlanContext, warm: Mapping[str, np.ndarray]) -> dict[str, float]:
        """The NLP's fuel [t] at its warm start against the referee's for the same track and schedule.

        Where the start sits on the cheap side of one of the model's steps (Kwon's Beaufort numbers and
        direction sectors) the smooth table misjudges it, and Ipopt may leave a start that is better by the
        referee: this figure says by how much the NLP's model sees the start differently.
        """
        nlp = self.problem.build(self._tightening())
        y = np.clip(np.asarray(warm["offset_nm"], dtype=float), *nlp.corridor.offset_bounds())
        v = np.clip(np.asarray(warm["stw_kn"], dtype=float), nlp.v_min_kn, nlp.v_max_kn)
        t = nlp.consistent_times(y, v)
        fuel = float(np.sum(nlp.leg_fuel_t(y, v, t)))
        tab = table_error(
            ctx,
            self.frame,
            offset_nm=y,
            stw_kn=v,
            time_h=t,
            nlp_fuel_t=fuel,
            departure=self.departure,
            step_nm=self.verify_step_nm,
        )
        legs = leg_table_error(
            nlp, self.frame, self.model, self.sampler, offset_nm=y, stw_kn=v, time_h=t, departure=self.departure
        )
        return {**tab, **legs}

    def _table_stats(self) -> dict[str, Any]:
        tb = self.table
        return {
            "speeds_kn": tb.speeds_kn.tolist(),
            "headings_deg": tb.headings_deg.tolist(),
            "capped_share": tb.capped_share,
            "evaluations": tb.evaluations,
            "sfoc_max_rel_error": tb.sfoc_max_rel_error,
            "speed_error": tb.speed_error,
        }

    def _solution_stats(self, call: Any, sol: Solved, eta_solve: float | None) -> dict[str, Any]:
        """Statistics of the returned NLP solution (:func:`optroute.optimise.corridor_stats.solution_stats`)."""
        return solution_stats(
            call.ctx,
            self.frame,
            sol,
            eta_solve=eta_solve,
            eta_mode=call.eta_mode,
            objective=call.objective,
            fixed=self.fixed_path,
            samples=self.samples,
            exclusion=self.exclusion,
            fuel_price=self.fuel_price,
            hourly_cost=self.hourly,
            band_names=tuple(self.problem.band_names),
            departure=self.departure,
            step_nm=self.verify_step_nm,
            model=self.model,
            sampler=self.sampler,
            tabulate=call.tabulate,
        )
