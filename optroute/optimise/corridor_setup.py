"""The once-per-corridor set-up of :class:`~optroute.optimise.corridor_problem.PreparedCorridor`.

Everything that does not depend on the ETA of a solve: the checked weather and speed range, the
time window the weather covers, the NLP's weather grid with the ship's own power tabulated on it
(:func:`~optroute.optimise.nlp_inputs.weather_grid`, :mod:`optroute.optimise.power_table`: one
model, the referee's), the lateral bounds and land mask
(:func:`~optroute.optimise.nlp_inputs.lateral_bounds`) and the
:class:`~optroute.optimise.nlp_solve.Problem`. :func:`prepare_corridor` returns them as one frozen
:class:`CorridorSetup`; the solves of one ETA (start, solve, verify, plan) are
:mod:`optroute.optimise.corridor_problem`'s.
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import xarray as xr

from formulations.compiled import CACHE_ENV, cache_dir, compiler
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError, WeatherCoverageError
from optroute.optimise.lateral import reach_windows
from optroute.optimise.nlp_inputs import CorridorFrame, build_frame, dataset_spacing, lateral_bounds, weather_grid
from optroute.optimise.nlp_solve import Problem
from optroute.optimise.power_table import SPEED_TOL, PowerTable, baseline_power_model, heading_nodes, speed_nodes
from optroute.optimise.rows import binding_legs, cut_where_binding
from optroute.optimise.timed_no_go import no_passage_windows
from optroute.physics.performance import PerformanceModel, default_model
from optroute.physics.safety import BandRules
from optroute.physics.ship import Ship
from optroute.plan.result import Exclusion
from optroute.search.route import Corridor
from optroute.units import format_utc
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _hours
from optroute.weather.sample import WeatherSampler

__all__ = [
    "JIT_AUTO_LEGS",
    "CorridorSetup",
    "ProgressFn",
    "check_jit",
    "cut_frame",
    "emit",
    "prepare_corridor",
    "recut",
    "time_window",
]

ProgressFn = Callable[[str, float], None]


def emit(progress: ProgressFn | None, stage: str, fraction: float) -> None:
    """Report a stage and the fraction done [0, 1] to the caller's progress function, if any."""
    if progress is not None:
        progress(stage, float(fraction))


#: ``jit="auto"`` compiles the NLP's leg functions from this many legs on (where a C compiler runs): there the
#: interpreted Hessian and Jacobian are a large share of every Ipopt iteration (the 496-leg storm corridor of
#: ``benchmarks/_nlp_call.py``: Ipopt 6.0 s interpreted, 3.5 s compiled, the whole call 8.0 and 5.6 s), and the
#: compilation, once per machine and ship (:mod:`formulations.compiled`'s disk cache), is repaid within a few
#: calls. Below it the few milliseconds saved per solve would take hundreds of calls to repay a compilation.
JIT_AUTO_LEGS = 200


def check_jit(jit: bool | str, n_legs: int) -> bool:
    """Whether the NLP's leg functions are compiled (``jit`` True, False or ``"auto"``, :data:`JIT_AUTO_LEGS`, on
    ``n_legs`` legs); True needs a C compiler and a writable cache folder (ConfigError without either), ``"auto"``
    uses them where it finds them."""
    auto = isinstance(jit, str) and jit == "auto"
    if not (auto or isinstance(jit, bool | np.bool_)):
        raise ConfigError(f"jit={jit!r} is not known; use True, False or 'auto' (compiled from {JIT_AUTO_LEGS} legs)")
    found = shutil.which(compiler()[0]) is not None
    if auto:
        return bool(found and n_legs >= JIT_AUTO_LEGS)
    if jit and not found:
        raise ConfigError(
            f"jit=True compiles the NLP's derivatives with a C compiler, and {compiler()[0]!r} is not on the PATH; "
            "install gcc or name another compiler in the CC environment variable, or use jit='auto' or False"
        )
    if jit and cache_dir() is None:
        given = os.environ.get(CACHE_ENV)
        where = (
            f"{CACHE_ENV}={given!r} cannot be written"
            if given
            else f"neither ~/.cache/optroute/casadi nor the temporary folder can be written ({CACHE_ENV} is unset)"
        )
        raise ConfigError(
            f"jit=True keeps the compiled derivatives in a cache folder, and {where}; point {CACHE_ENV} at a "
            "writable folder, or use jit='auto' or False"
        )
    return bool(jit)


@dataclass(frozen=True)
class CorridorSetup:
    """What a :class:`~optroute.optimise.corridor_problem.PreparedCorridor` builds once for all its ETAs.

    Attributes
    ----------
    sampler, dataset
        The weather (``dataset`` None when a sampler was given).
    model, rules
        The ship's performance model and danger-band rules (defaults filled in).
    v_min, v_max : float
        The NLP's speed-through-water range [kn].
    data_end_h : float
        The weather's last time [h after departure] (inf under ``time_policy="hold"``).
    cap_h : float or None
        The passage cap the corridor is prepared for [h after departure] (the latest ETA, else the
        weather's end for fuel and cost, else None).
    horizon_h : float
        The end of the NLP's weather grid [h after departure].
    frame, grid, samples, power, table
        The corridor frame, the weather grid with its summary, the baseline power model and the
        tabulated power (:class:`~optroute.optimise.power_table.PowerTable`).
    y_lo, y_hi : numpy.ndarray
        Lateral bounds of every waypoint [nm, port +].
    length_nm : float
        Centreline length [nm] (WGS84).
    problem : Problem
        The NLP builder and solver.
    dt_h : float
        The weather grid's time step [h] (the lateral bounds' time window is taken at it).
    """

    sampler: WeatherSampler
    dataset: xr.Dataset | None
    model: PerformanceModel
    rules: BandRules
    v_min: float
    v_max: float
    data_end_h: float
    cap_h: float | None
    horizon_h: float
    frame: CorridorFrame
    grid: Any
    samples: Any
    power: Any
    table: PowerTable
    y_lo: np.ndarray
    y_hi: np.ndarray
    length_nm: float
    problem: Problem
    dt_h: float


def _weather(weather: Any) -> tuple[WeatherSampler, xr.Dataset | None]:
    if isinstance(weather, WeatherSampler):
        return weather, None
    if isinstance(weather, xr.Dataset):
        return WeatherSampler(weather), weather
    raise ConfigError(f"weather must be a canonical xarray.Dataset or a WeatherSampler, got {type(weather).__name__}")


def _speed_range(ship: Ship, speed_range_kn: tuple[float, float] | None) -> tuple[float, float]:
    if speed_range_kn is None:
        return 3.0, float(min(ship.max_calm_speed_kn, 40.0))
    v_min, v_max = (
        float(x) for x in finite("speed_range_kn", speed_range_kn, minimum=0.0, strict=True, error=ConfigError)
    )
    if v_max <= v_min:
        raise ConfigError(f"speed_range_kn={speed_range_kn!r} needs lower < upper")
    return v_min, v_max


def time_window(
    sampler: WeatherSampler, t0: np.datetime64, eta_t: np.datetime64 | None, objective: str
) -> tuple[float, float | None]:
    """The weather's end [h after ``t0``] and the passage cap [h] (the ETA; else the weather's end for fuel
    and cost; else None), with the coverage checked."""
    ext = sampler.extent
    data_end_h = _hours(ext["time"][1] - t0) if sampler.time_policy == "raise" else math.inf
    if sampler.time_policy == "raise" and _hours(ext["time"][0] - t0) > 1e-9:
        raise WeatherCoverageError(
            f"departure={format_utc(t0)} is before the weather's first time {format_utc(ext['time'][0])}; depart later "
            "or extend the forecast"
        )
    if data_end_h <= 0:
        raise WeatherCoverageError(
            f"departure={format_utc(t0)} is at or after the weather's last time {format_utc(ext['time'][1])}; "
            "extend the forecast"
        )
    eta_user_h = _hours(eta_t - t0) if eta_t is not None else None
    if eta_user_h is not None and eta_user_h > data_end_h + 1e-9:
        raise WeatherCoverageError(
            f"eta={format_utc(eta_t)} is after the weather's last time {format_utc(ext['time'][1])}: the passage could "
            "not be checked against the weather; extend the forecast, give an earlier eta, or open the weather with "
            "time_policy='hold'"
        )
    if eta_user_h is not None:
        return data_end_h, eta_user_h
    return data_end_h, (data_end_h if objective != "time" and math.isfinite(data_end_h) else None)


def _grid_steps(ds: xr.Dataset | None, corridor: Corridor, hw_max: float) -> tuple[float, float, float]:
    """The NLP weather grid's spacing: time [h], along [nm] and across [nm]."""
    dt_ds, ds_ds = dataset_spacing(ds)
    # the NLP's grid is twice as fine as the data's, so that its smooth interpolant stays within about a
    # quarter of its own O(h²) departure from the data's multilinear interpolation (the verifier's)
    dt_h = float(np.clip(0.5 * dt_ds if dt_ds else 1.5, 0.5, 3.0))
    # short NLP legs (a small max_leg_nm) do not refine it: the grid would grow with N and its spline's build
    # dominate the solve (15 s against 1 s at 500 legs); the corridor's own vertices (where it turns) bound it
    ds_nm = float(
        min(np.clip(0.5 * ds_ds if ds_ds else 15.0, 5.0, 30.0), max(float(np.max(corridor.leg_distance_nm)), 5.0))
    )
    dy_nm = float(np.clip(ds_nm / 2.0, 2.0, max(hw_max / 2.0, 2.0)))
    return dt_h, ds_nm, dy_nm


def _leg_windows(
    frame: CorridorFrame, sampler: WeatherSampler, ds: xr.Dataset | None, t0: np.datetime64, cap_h: float | None,
    v_max: float,
) -> np.ndarray | None:  # fmt: skip
    """:func:`~optroute.optimise.lateral.reach_windows` of the corridor's legs, or None (every leg over the whole
    window) without a passage cap or where the strongest current is unknown (a sampler without its dataset)."""
    has_current = any(v.startswith("current") for v in sampler.variables)
    if cap_h is None or not math.isfinite(cap_h) or (has_current and ds is None):
        return None
    current_kn = 0.0
    if has_current:
        speed = np.hypot(ds["current_u_ms"], ds["current_v_ms"]).max(skipna=True)
        current_kn = float(units.ms_to_kn(float(speed)))
    if not math.isfinite(current_kn):
        return None
    return reach_windows(frame, t0, cap_h, v_max + current_kn)


def _cut_legs(
    frame: CorridorFrame,
    grid: Any,
    ship_rules_exclusion: tuple[Ship, BandRules, Exclusion | None],
    hs_margin: float,
    t0: np.datetime64,
    band_leg_nm: float | None,
) -> CorridorFrame:
    """``frame`` with the legs where a band or the exclusion can bind (:func:`~optroute.optimise.rows.binding_legs` on
    the weather ``grid`` at the Hs back-off ``hs_margin`` [-]) cut to ``band_leg_nm`` [nm]
    (:func:`~optroute.optimise.rows.cut_where_binding`); ``frame`` itself where none is cut or ``band_leg_nm`` is None."""
    if band_leg_nm is None:
        return frame
    return cut_frame(frame, binding_legs(frame, grid.s_nm, grid.hs_m, ship_rules_exclusion, hs_margin, t0), band_leg_nm)


def cut_frame(frame: CorridorFrame, binding: np.ndarray, band_leg_nm: float) -> CorridorFrame:
    """``frame`` with its legs flagged in ``binding`` (N,) cut to ``band_leg_nm`` [nm] on their great circles
    (:func:`~optroute.optimise.rows.cut_where_binding`); ``frame`` itself where none is cut."""
    finer = cut_where_binding(binding, np.diff(frame.s_nm), band_leg_nm)
    return frame if finer is None else build_frame(frame.corridor.resample(finer))


def _lateral(
    frame: CorridorFrame,
    sampler: WeatherSampler,
    ds: xr.Dataset | None,
    t0: np.datetime64,
    horizon_dt_h: tuple[float, float],
    windows: np.ndarray | None,
    *,
    use_land_mask: bool | None,
    timed: bool,
) -> tuple[np.ndarray, np.ndarray, Any]:
    """The waypoints' lateral bounds [nm, port +] (:func:`~optroute.optimise.nlp_inputs.lateral_bounds`, over the
    grid's time window ``horizon_dt_h``: its end and step [h]) and, with ``timed``, the moving no-passage cells as the
    problem's time windows (:func:`~optroute.optimise.timed_no_go.no_passage_windows`; None otherwise)."""
    horizon, dt_h = horizon_dt_h
    n_window = int(min(25, max(2, horizon / dt_h + 1)))
    window = t0 + np.array([_h_to_td(h) for h in np.linspace(0.0, horizon, n_window)])
    hw_max = float(np.max(frame.corridor.half_width_nm))
    step_nm = max(1.0, min(5.0, hw_max / 10.0)) if hw_max > 0 else 1.0
    y_lo, y_hi = lateral_bounds(
        frame, sampler=sampler, dataset=ds, times=window, use_land_mask=use_land_mask, step_nm=step_nm,
        leg_windows=windows, static_only=timed,
    )  # fmt: skip
    no_passage = no_passage_windows(frame, ds, t0, y_lo, y_hi) if timed and ds is not None else None
    return y_lo, y_hi, no_passage


def prepare_corridor(
    corridor: Corridor,
    weather: xr.Dataset | WeatherSampler,
    ship: Ship,
    *,
    t0: np.datetime64,
    eta_t: np.datetime64 | None,
    objective: str,
    model: PerformanceModel | None,
    rules: BandRules | None,
    max_leg_nm: float,
    exclusion: Exclusion | None,
    speed_range_kn: tuple[float, float] | None,
    use_land_mask: bool | None,
    solver_options: Mapping[str, Any] | None,
    jit: bool | str,
    progress: ProgressFn | None,
    timed_no_passage: bool = False,
    speeds_kn: np.ndarray | None = None,
    band_leg_nm: float | None = None,
    hs_margin: float = 0.0,
) -> CorridorSetup:
    """Check the weather and speeds, build the NLP's weather grid, power table, lateral bounds and problem.

    Parameters as in :class:`~optroute.optimise.corridor_problem.PreparedCorridor` (``t0`` its
    departure [UTC], ``eta_t`` its latest ETA [UTC] or None). With ``timed_no_passage`` the lateral bounds
    keep off the weather's fixed no-passage cells only, and the moving ones become the problem's time
    windows (:func:`~optroute.optimise.timed_no_go.no_passage_windows`). With ``band_leg_nm`` [nm] the legs where a
    band or the exclusion can bind (:func:`~optroute.optimise.rows.binding_legs` at the Hs back-off ``hs_margin``
    [-], on the weather grid built for the whole legs) are cut to it; None: the legs of ``max_leg_nm``.
    """
    sampler, ds = _weather(weather)
    n_wp = len(corridor.waypoints)
    for k, (lat_k, lon_k) in enumerate(corridor.waypoints):  # named before any grid node is sampled
        role = "start, " if k == 0 else ("end, " if k == n_wp - 1 else "")
        sampler.require_area(lat_k, lon_k, what=f"{role}corridor point {k}")
    model = model if model is not None else default_model(ship)
    rules = rules if rules is not None else BandRules()
    v_min, v_max = _speed_range(ship, speed_range_kn)
    emit(progress, "corridor", 0.0)
    data_end_h, cap_h = time_window(sampler, t0, eta_t, objective)
    cor = corridor.resample(float(finite("max_leg_nm", max_leg_nm, minimum=0.0, strict=True, error=ConfigError)))
    frame = build_frame(cor)
    length = float(frame.s_nm[-1])
    horizon = cap_h * 1.02 + 1.0 if cap_h is not None else 1.3 * length / max(v_min, 0.5 * ship.design_speed_kn)
    horizon = min(horizon, data_end_h) if math.isfinite(data_end_h) else horizon
    hw_max = float(np.max(cor.half_width_nm))
    dt_h, ds_nm, dy_nm = _grid_steps(ds, corridor, hw_max)
    emit(progress, "weather grid and power table", 0.05)
    min_load = float(model.min_power_kw) / float(model.mcr_kw)
    base, sfoc_err = baseline_power_model(model, v_min_kn=v_min, v_max_kn=v_max, min_load=min_load)
    # the power table's speed nodes: checked and halved where the sea needs it, or given (a robust NLP's members share)
    speeds = speed_nodes(v_min, v_max) if speeds_kn is None else np.asarray(speeds_kn, dtype=float)
    fixed_path = bool(np.all(np.asarray(cor.half_width_nm) == 0.0))
    headings = heading_nodes(fixed_path, any(v.startswith("current") for v in sampler.variables))
    # the ship can be on each leg only between its reach windows: the grid's weather and power table are
    # evaluated only where a reachable sample's spline reads them (nlp_inputs.reachable_nodes)
    windows = _leg_windows(frame, sampler, ds, t0, cap_h, v_max)
    windows_h = None if windows is None else _hours(windows - t0)
    grid, samples = weather_grid(
        frame, sampler, departure=t0, t_end_h=horizon, dt_h=dt_h, ds_nm=ds_nm, dy_nm=dy_nm,
        model=model, base=base, speeds_kn=speeds, headings_deg=headings, leg_windows_h=windows_h,
        speed_tol=SPEED_TOL if speeds_kn is None else None,
    )  # fmt: skip
    cut = _cut_legs(frame, grid, (ship, rules, exclusion), hs_margin, t0, band_leg_nm)
    if cut is not frame:  # the same great circles: the weather grid, on (t, s, y), serves unchanged
        frame, windows = cut, _leg_windows(cut, sampler, ds, t0, cap_h, v_max)
    table = PowerTable(
        np.asarray(grid.ratio_speed_kn), np.asarray(grid.ratio_heading_deg), samples.power_capped_share,
        samples.power_evaluations, sfoc_err, samples.power_speed_error,
    )  # fmt: skip
    emit(progress, "lateral bounds", 0.1)
    y_lo, y_hi, no_passage = _lateral(
        frame, sampler, ds, t0, (horizon, dt_h), windows, use_land_mask=use_land_mask, timed=timed_no_passage
    )
    problem = Problem(
        frame=frame, grid=grid, samples=samples, power=base, ship=ship, rules=rules, y_lo=y_lo, y_hi=y_hi,
        v_min=v_min, v_max=v_max, exclusion=exclusion, departure=t0, solver_options=solver_options,
        jit=check_jit(jit, frame.n_legs), windows=no_passage,
    )  # fmt: skip
    return CorridorSetup(
        sampler, ds, model, rules, v_min, v_max, data_end_h, cap_h, horizon, frame, grid, samples, base, table,
        y_lo, y_hi, length, problem, dt_h,
    )  # fmt: skip


def recut(
    su: CorridorSetup,
    frame: CorridorFrame,
    *,
    ship: Ship,
    exclusion: Exclusion | None,
    departure: np.datetime64,
    use_land_mask: bool | None,
    timed_no_passage: bool,
    solver_options: Mapping[str, Any] | None,
    jit: bool | str,
) -> CorridorSetup:
    """``su`` on the legs of ``frame`` (the same centreline's legs cut further, on the same great circles): its
    weather grid and power table serve unchanged; the reach windows, lateral bounds and problem are the new legs'.
    An ensemble's members share one cut (:func:`optroute.optimise.robust.prepare_members`). Other parameters as in
    :func:`prepare_corridor` (``departure`` its ``t0``)."""
    windows = _leg_windows(frame, su.sampler, su.dataset, departure, su.cap_h, su.v_max)
    y_lo, y_hi, no_passage = _lateral(
        frame, su.sampler, su.dataset, departure, (su.horizon_h, su.dt_h), windows, use_land_mask=use_land_mask,
        timed=timed_no_passage,
    )  # fmt: skip
    problem = Problem(
        frame=frame, grid=su.grid, samples=su.samples, power=su.power, ship=ship, rules=su.rules, y_lo=y_lo, y_hi=y_hi,
        v_min=su.v_min, v_max=su.v_max, exclusion=exclusion, departure=departure, solver_options=solver_options,
        jit=check_jit(jit, frame.n_legs), windows=no_passage,
    )  # fmt: skip
    return replace(su, frame=frame, y_lo=y_lo, y_hi=y_hi, problem=problem)
