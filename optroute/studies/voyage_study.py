"""Voyage studies: ships × weather (scenarios or ensemble members) × ETAs, on Dask — :func:`study`.

Built on the generic engine :func:`optroute.studies.study.run_study`: every case is
one :func:`optroute.optimise_corridor` solve (fuel or cost subject to the
case's ETA) whose totals and status are written to the study store as soon as
it finishes, atomically; a study that is interrupted resumes where it stopped
when it is called again with the same arguments and store, computing no case
twice and losing none (see :func:`optroute.studies.study.run_study`, "Resume
semantics").

Running on a cluster
--------------------
By default a :class:`distributed.LocalCluster` of worker processes bound to
127.0.0.1 runs for the call (``n_workers`` of them, default one per core);
``n_workers=0`` runs every case in this process.  To use an existing Dask
cluster, start a scheduler and workers where optroute is installed (same
version) — ``dask scheduler`` on one machine, ``dask worker
tcp://<scheduler>:8786`` on each worker machine — and pass
``scheduler_address="tcp://<scheduler>:8786"`` (on the command line:
``optroute study --scheduler tcp://<scheduler>:8786``).  The case function
and the bound weather datasets travel to each worker once; the store needs
to be visible only to this process.  An address that does not answer fails
at once with :class:`~optroute.studies.study.SchedulerUnreachable` naming it.

The case function :func:`voyage_case` is module-level and picklable; the
ships and weather are bound to it with :func:`functools.partial`, and the
axes carry only labels.
"""

from __future__ import annotations

import functools
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from optroute.errors import ConfigError
from optroute.physics.ship import Ship
from optroute.search.route import Corridor
from optroute.studies.fingerprint import CaseInput, dataset_digest, digest, file_digest
from optroute.studies.front_points import FORBIDDEN_OPTIONS, FrontSpec, solve_point
from optroute.studies.study import ProgressCallback, run_study
from optroute.studies.threads import solver_process
from optroute.units import as_utc_time, format_utc, h_to_timedelta, timedelta_to_h
from optroute.weather.catalogue import load_weather, scenario_names
from optroute.weather.scenarios import member

__all__ = ["study", "voyage_case"]

#: The per-case totals a study stores (plus ``plan_status`` and ``iterations``).
TOTALS = ("fuel_t", "duration_h", "distance_nm", "mean_power_kw", "max_power_kw", "eta_shadow_price_t_per_h")


# --------------------------------------------------------------------------- the case (runs on a worker)

_corridors: dict[tuple[Any, ...], tuple[Corridor, Any]] = {}  # per worker process: one search per ship × weather


def _weather(ref: xr.Dataset | str) -> xr.Dataset:
    """The weather of a case, in memory: a file is read and closed (a prepared corridor kept in the process holds
    the dataset, and must not hold the file open: it may be overwritten by the next forecast)."""
    if isinstance(ref, xr.Dataset):
        return ref
    ds = load_weather(ref)
    with ds:
        return ds.load()


def voyage_case(
    case: Mapping[str, Any],
    *,
    ships: Mapping[str, Ship],
    weathers: Mapping[str, xr.Dataset | str],
    corridor: Corridor | None,
    endpoints: tuple[tuple[float, float], tuple[float, float]] | None,
    departure: np.datetime64 | None,
    objective: str,
    corridor_width_nm: float,
    search_options: Mapping[str, Any] | None,
    optimise_kwargs: Mapping[str, Any],
    tokens: Mapping[tuple[str, str], str] | None = None,
) -> dict[str, Any]:
    """One case of a voyage study: optimise one ship through one weather for one ETA.

    Parameters
    ----------
    case : mapping
        ``{"ship": label, "scenario": label, "eta_h" or "eta": value}`` from the study's axes.
    ships, weathers : mapping
        Label → :class:`~optroute.Ship`; label → canonical dataset, or a scenario name / file path
        loaded on the worker (:func:`optroute.weather.load_weather`).
    corridor : Corridor, optional
        The corridor of every case; else ``endpoints`` are searched once per ship and weather in
        each worker process (:func:`optroute.search_route`, objective ``"time"``).
    departure : datetime64, optional
        [UTC]; default the weather's first time.
    objective, corridor_width_nm, search_options, optimise_kwargs
        As in :func:`study`.
    tokens : mapping, optional
        ``(ship label, weather label) →`` the fingerprint of every input of a case but its ETA
        (:func:`study` computes them from the inputs' digests): the cases of one ship and weather solve
        on the corridor prepared once per process for the weather's whole time span, as a front's points
        do (:func:`optroute.studies.front_points.prepared_corridor`).  Without it each case prepares its
        own, for its ETA.

    Returns
    -------
    dict
        The totals in :data:`TOTALS` (NaN when there is no plan), ``plan_status`` (``"optimal"``,
        ``"feasible"``, ``"infeasible: …"`` or ``"solver failure: <Ipopt status>"``) and ``iterations``.
    """
    solver_process()  # before the route search too: in a Dask worker, glibc's thresholds the nanny pinned
    ship = ships[case["ship"]]
    wx = _weather(weathers[case["scenario"]])
    t0 = departure if departure is not None else np.datetime64(wx["time"].values[0], "ns")
    eta_h = float(case["eta_h"]) if "eta_h" in case else timedelta_to_h(as_utc_time(case["eta"], "eta") - t0)
    route = None
    if corridor is None:
        if endpoints is None:
            raise ConfigError("voyage_case needs a corridor or endpoints; build the case function with study()")
        key = (case["ship"], case["scenario"], str(t0), endpoints, corridor_width_nm)
        if key not in _corridors:
            from optroute.search.routing import search_route

            opts = dict(search_options or {})
            opts.setdefault("objective", "time")
            found = search_route(
                *endpoints,
                wx,
                ship,
                departure=t0,
                model=optimise_kwargs.get("model"),
                rules=optimise_kwargs.get("rules"),
                **opts,
            )
            _corridors[key] = (found.corridor(width_nm=corridor_width_nm), found)
        corridor, route = _corridors[key]
    token = tokens.get((case["ship"], case["scenario"]), "") if tokens is not None else ""
    spec = FrontSpec(corridor, wx, ship, t0, objective, dict(optimise_kwargs), token=token)
    if eta_h <= 0:
        status = f"infeasible: the ETA is {eta_h:.2f} h after the departure {format_utc(t0)}"
        out: dict[str, Any] = {k: math.nan for k in TOTALS}
        return {**out, "plan_status": status, "iterations": 0}
    p = solve_point(spec, eta_h, "eta", None, route)
    return {
        **{k: float(p.totals.get(k, math.nan)) for k in TOTALS},
        "plan_status": p.status,
        "iterations": int(p.iterations),
    }


# --------------------------------------------------------------------------- axes


def _ship_axis(ships: Any) -> dict[str, Ship]:
    if isinstance(ships, str | Ship) or not isinstance(ships, Sequence | Mapping):
        ships = [ships]
    items = ships.items() if isinstance(ships, Mapping) else ((None, s) for s in ships)
    out: dict[str, Ship] = {}
    for label, s in items:
        ship = Ship.preset(s) if isinstance(s, str) else s
        if not isinstance(ship, Ship):
            raise ConfigError(f"ships: {s!r} is neither a preset name ({', '.join(Ship.presets())}) nor a Ship")
        name = str(label) if label is not None else ship.name
        if name in out:
            raise ConfigError(
                f"ships: {name!r} is given twice; give each ship once (or a mapping with distinct labels)"
            )
        out[name] = ship
    return out


def _weather_axis(scenarios: Any) -> dict[str, xr.Dataset | str]:
    if isinstance(scenarios, str | os.PathLike | xr.Dataset) or not isinstance(scenarios, Sequence | Mapping):
        scenarios = [scenarios]
    items = scenarios.items() if isinstance(scenarios, Mapping) else ((None, s) for s in scenarios)
    out: dict[str, xr.Dataset | str] = {}

    def add(label: str, value: xr.Dataset | str) -> None:
        if label in out:
            raise ConfigError(f"scenarios: the label {label!r} is given twice; pass a mapping with distinct labels")
        out[label] = value

    for i, (label, s) in enumerate(items):
        if isinstance(s, str | os.PathLike):
            ref = os.fspath(s)
            if ref not in scenario_names() and not Path(ref).exists():
                raise ConfigError(
                    f"scenarios: {ref!r} is neither a built-in scenario nor an existing file; use one of "
                    f"{', '.join(scenario_names())}, a weather file, or a dataset"
                )
            add(str(label) if label is not None else ref, ref)
        elif isinstance(s, xr.Dataset):
            base = (
                str(label)
                if label is not None
                else str(s.attrs.get("scenario_name") or s.attrs.get("scenario") or f"dataset_{i}")
            )
            if "member" in s.dims:  # a stacked ensemble: one case per member
                for k in range(s.sizes["member"]):
                    add(f"{base}[member={k}]", member(s, k))
            else:
                add(base, s)
        else:
            raise ConfigError(
                f"scenarios: {s!r} ({type(s).__name__}) is not a scenario name, a file, or an xarray.Dataset"
            )
    if not out:
        raise ConfigError("scenarios is empty; give at least one scenario name, file or dataset")
    return out


def _eta_axis(etas: Any, departure: np.datetime64 | None) -> tuple[str, list[Any]]:
    if isinstance(etas, str | bytes | numbers.Real) or not isinstance(etas, Sequence | np.ndarray):
        etas = [etas]
    values = list(etas)
    if not values:
        raise ConfigError("etas is empty; give at least one ETA (hours after departure, or UTC times)")
    if all(isinstance(e, numbers.Real) and not isinstance(e, bool) for e in values):
        hours = [float(e) for e in values]
        bad = [h for h in hours if not math.isfinite(h) or h <= 0]
        if bad:
            raise ConfigError(f"etas {bad} are not positive hours after departure; give hours > 0 or UTC times")
        return "eta_h", hours
    times = [as_utc_time(e, "etas") for e in values]
    if departure is not None:
        early = [format_utc(t) for t in times if t <= departure]
        if early:
            raise ConfigError(f"etas {early} are not after the departure {format_utc(departure)}; give later ETAs")
    return "eta", times


# --------------------------------------------------------------------------- what determines a case


def _ship_input(ship: Ship) -> CaseInput:
    return CaseInput(
        digest(ship),
        f"ship {ship.name!r} (L {ship.length_m:g} m, displacement {ship.displacement_t:g} t, "
        f"{ship.design_speed_kn:g} kn, MCR {ship.mcr_kw:g} kW)",
    )


def _weather_input(label: str, ref: xr.Dataset | str) -> CaseInput:
    """The weather's content: a file's bytes, a dataset's values and coordinates, a built-in scenario as built."""
    if isinstance(ref, str) and ref in scenario_names() and not Path(ref).exists():
        ds = load_weather(ref)
        return CaseInput(dataset_digest(ds), f"built-in scenario {ref!r} ({_span(ds)})")
    if isinstance(ref, str):
        stat = Path(ref).stat()
        when = np.datetime64(int(stat.st_mtime), "s")
        return CaseInput(file_digest(ref), f"weather file {ref!r} ({stat.st_size} bytes, modified {when} UTC)")
    return CaseInput(dataset_digest(ref), f"weather dataset {label!r} ({_span(ref)})")


def _span(ds: xr.Dataset) -> str:
    parts = []
    if "time" in ds.coords and ds.sizes.get("time", 0):
        t = ds["time"].values
        parts.append(f"{str(t[0])[:16]} to {str(t[-1])[:16]}")
    if "hs_m" in ds:
        parts.append(f"Hs up to {float(ds['hs_m'].max(skipna=True)):.3g} m")
    return ", ".join(parts) or "no time axis"


def _route_input(
    corridor: Corridor | None,
    endpoints: Any,
    corridor_width_nm: float,
    search_options: Mapping[str, Any],
) -> CaseInput:
    if corridor is not None:
        wp = corridor.waypoints
        return CaseInput(
            digest(corridor),
            f"corridor of {corridor.length_nm:.1f} nm, {wp.shape[0]} waypoints from "
            f"({wp[0, 0]:.4g}, {wp[0, 1]:.4g}) to ({wp[-1, 0]:.4g}, {wp[-1, 1]:.4g})",
        )
    (a, b) = endpoints
    return CaseInput(
        digest((endpoints, corridor_width_nm, dict(search_options))),
        f"route searched from {a} to {b} in a corridor {corridor_width_nm:g} nm wide"
        + (f" (search options {dict(search_options)})" if search_options else ""),
    )


def _inputs_fn(
    ships: Mapping[str, Ship],
    weathers: Mapping[str, xr.Dataset | str],
    route: CaseInput,
    departure: np.datetime64 | None,
    objective: str,
    optimise_kwargs: Mapping[str, Any],
) -> Any:
    """``case → {input name: CaseInput}`` for :func:`run_study`: each input digested once, here."""
    ship_in = {label: _ship_input(s) for label, s in ships.items()}
    weather_in = {label: _weather_input(label, ref) for label, ref in weathers.items()}
    dep = (
        CaseInput(digest(departure), f"departure {str(departure)[:19]} UTC")
        if departure is not None
        else CaseInput(digest(None), "departure at the weather's first time")
    )
    opts = {"objective": objective, **optimise_kwargs}
    opts_in = CaseInput(digest(opts), f"options {', '.join(f'{k}={v!r:.60}' for k, v in sorted(opts.items()))}")

    def inputs(case: Mapping[str, Any]) -> dict[str, CaseInput]:
        eta_name = "eta_h" if "eta_h" in case else "eta"
        return {
            "ship": ship_in[case["ship"]],
            "weather": weather_in[case["scenario"]],
            "route": route,
            "departure": dep,
            "eta": CaseInput(digest(case[eta_name]), f"{eta_name}={case[eta_name]}"),
            "options": opts_in,
        }

    return inputs


def _case_tokens(
    inputs: Any, ships: Mapping[str, Ship], weathers: Mapping[str, Any], eta_name: str, any_eta: Any
) -> dict[tuple[str, str], str]:
    """``(ship, weather) →`` the digest of every input of a case but the ETA: the key of its prepared corridor.

    Made of the digests the store records (:func:`_inputs_fn`), so two cases share a prepared corridor exactly
    when their ship, weather content, route, departure and options are equal.
    """
    out = {}
    for s in ships:
        for w in weathers:
            recorded = inputs({"ship": s, "scenario": w, eta_name: any_eta})
            out[(s, w)] = digest(("voyage-study", sorted((k, v.digest) for k, v in recorded.items() if k != "eta")))
    return out


# --------------------------------------------------------------------------- public API


def study(
    ships: Any,
    scenarios_or_members: Any,
    etas: Any,
    *,
    corridor: Corridor | None = None,
    start: tuple[float, float] | None = None,
    end: tuple[float, float] | None = None,
    departure: Any = None,
    store: str | os.PathLike[str],
    objective: str = "fuel",
    scheduler_address: str | None = None,
    n_workers: int | None = None,
    progress: ProgressCallback | bool | str | None = None,
    corridor_width_nm: float = 60.0,
    search_options: Mapping[str, Any] | None = None,
    resume: bool = True,
    retry_failed: bool = False,
    timeout_s: float = 10.0,
    on_changed_inputs: str = "error",
    **optimise_kwargs: Any,
) -> xr.Dataset:
    """Optimise every ship × weather × ETA combination on Dask, resumably; one stored case at a time.

    Parameters
    ----------
    ships : str, Ship, or a sequence or mapping of them
        Preset names (:meth:`optroute.Ship.presets`) or ships; labelled by name (or the mapping's keys).
    scenarios_or_members : str, path, Dataset, or a sequence or mapping of them
        Built-in scenario names (:func:`optroute.weather.scenario_names`, built on each worker),
        weather files (opened on each worker with :func:`optroute.weather.load_weather`), or canonical
        datasets (labelled by ``attrs["scenario_name"]``/``attrs["scenario"]``, or ``dataset_<i>``, or
        the mapping's keys).  A dataset with an ensemble ``member`` dimension
        (:func:`optroute.weather.scenarios.ensemble`) gives one scenario per member,
        labelled ``<label>[member=<k>]``.
    etas : sequence of float, or of datetime64/str
        Hours after departure [h] (axis ``eta_h``), or arrival times [UTC] (axis ``eta``).
    corridor : Corridor, optional
        The corridor of every case; or ``start`` and ``end`` (lat, lon) [deg] to search one per ship
        and weather (in each worker, once) and take its corridor ``corridor_width_nm`` wide.
    departure : datetime64 or str, optional
        [UTC]; default each weather's first time.
    store : path
        The study store (a directory): ``manifest.json``, one NetCDF file per finished case, and the
        combined ``study.nc``.  Calling again with the same axes resumes; see :func:`run_study`.
    objective : {"fuel", "cost"}
        What each case minimises subject to arriving by its ETA.
    scheduler_address, n_workers, progress, resume, retry_failed, timeout_s
        As in :func:`optroute.studies.study.run_study`: ``None`` starts a local cluster (``n_workers``
        processes on 127.0.0.1), ``"tcp://host:port"`` uses an existing one (module docstring),
        ``n_workers=0`` runs in this process; ``progress(done, total)``.
    on_changed_inputs : {"error", "recompute"}
        Every case records what it was computed from: the ship's particulars, the weather's
        content (a weather file's bytes, a dataset's values and coordinates, a built-in scenario
        as built), the corridor or the endpoints and search options, the departure, the ETA and
        the options.  A stored case whose record differs from this call is a
        :class:`~optroute.studies.study.StudyError` naming what changed (``"error"``, the
        default), or is computed again and replaced (``"recompute"``).  Corrupt or truncated
        case files are always moved aside and computed again, with a warning.
    corridor_width_nm, search_options
        With ``start``/``end``: the corridor's total width [nm] and :func:`optroute.search_route` options.
    **optimise_kwargs
        Passed to every :func:`optroute.optimise_corridor` (``model``, ``rules``, ``max_leg_nm``,
        ``fuel_price_per_t``, ...), but not ``eta``, ``objective`` and the like.

    Returns
    -------
    xarray.Dataset
        Dimensions ``ship``, ``scenario`` and ``eta_h`` (or ``eta``), with per case: ``fuel_t`` [t],
        ``duration_h`` [h], ``distance_nm`` [nm], ``mean_power_kw`` and ``max_power_kw`` [kW],
        ``eta_shadow_price_t_per_h`` [t/h], ``plan_status`` (the optimiser's outcome: ``"optimal"``,
        ``"infeasible: …"``, ``"solver failure: …"``), ``iterations``, and the engine's ``status``
        (``"ok"``, ``"missing"``, ``"failed: …"``) and ``runtime_s`` [s].

    Raises
    ------
    ConfigError
        Bad arguments (the message names the value).
    SchedulerUnreachable
        ``scheduler_address`` does not answer within ``timeout_s``; the message names the address.
    StudyError
        The store holds another study or cases computed from other inputs (the message names
        what changed), is not writable (the message names it), or the cluster was lost (run
        again to resume).
    """
    if objective not in ("fuel", "cost"):
        raise ConfigError(f"objective={objective!r} is not a study objective; use 'fuel' or 'cost'")
    bad = sorted(set(optimise_kwargs) & set(FORBIDDEN_OPTIONS))
    if bad:
        raise ConfigError(f"study sets {bad} itself for every case; drop them from the keyword arguments")
    if corridor is not None and (start is not None or end is not None):
        raise ConfigError("give either corridor= or start= and end=, not both")
    endpoints = None
    if corridor is None:
        if start is None or end is None:
            raise ConfigError("study needs corridor= (an optroute.Corridor) or both start= and end= as (lat, lon)")
        try:
            endpoints = ((float(start[0]), float(start[1])), (float(end[0]), float(end[1])))
        except (TypeError, ValueError, IndexError) as exc:
            raise ConfigError(f"start={start!r} and end={end!r} must be (lat, lon) pairs in degrees") from exc
    elif not isinstance(corridor, Corridor):
        raise ConfigError(f"corridor must be an optroute.Corridor, got {type(corridor).__name__}")
    t0 = as_utc_time(departure, "departure") if departure is not None else None
    ship_map = _ship_axis(ships)
    weather_map = _weather_axis(scenarios_or_members)
    eta_name, eta_values = _eta_axis(etas, t0)
    case_fn = functools.partial(
        voyage_case,
        ships=ship_map,
        weathers=weather_map,
        corridor=corridor,
        endpoints=endpoints,
        departure=t0,
        objective=objective,
        corridor_width_nm=float(corridor_width_nm),
        search_options=dict(search_options or {}),
        optimise_kwargs=dict(optimise_kwargs),
    )
    inputs = _inputs_fn(
        ship_map,
        weather_map,
        _route_input(corridor, endpoints, float(corridor_width_nm), dict(search_options or {})),
        t0,
        objective,
        dict(optimise_kwargs),
    )
    case_fn = functools.partial(case_fn, tokens=_case_tokens(inputs, ship_map, weather_map, eta_name, eta_values[0]))
    axes = {"ship": list(ship_map), "scenario": list(weather_map), eta_name: eta_values}
    ds = run_study(
        axes,
        case_fn,
        Path(store),
        scheduler_address=scheduler_address,
        n_workers=n_workers,
        progress=progress,
        resume=resume,
        retry_failed=retry_failed,
        timeout_s=timeout_s,
        case_inputs=inputs,
        on_changed_inputs=on_changed_inputs,
    )
    if t0 is not None and eta_name == "eta_h":
        ds = ds.assign_coords(eta=("eta_h", [t0 + h_to_timedelta(h) for h in eta_values]))
    return ds
