"""The 3-D DP's route (Shao et al.): ``search_route(method="dp")`` on the physics of :class:`PassagePhysics`."""

from __future__ import annotations

import time as _time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute.errors import ConfigError, InfeasibleETA, NoSafePassage
from optroute.geo import land
from optroute.physics.safety import BANDS
from optroute.search.dp import solve_dp
from optroute.search.edge_land import legs_on_land
from optroute.search.objective_search import eta_as_time, explain_uncovered
from optroute.search.passage_physics import PassagePhysics
from optroute.search.route import Route
from optroute.units import h_to_timedelta as _h_to_td


def dp_navigable(members: Sequence[PassagePhysics], exclusion: Any, coast: bool) -> Callable:
    """The DP's node predicate ``navigable(lat, lon, t_h)``: navigable in the weather of every one of ``members``
    (one for a route; an ensemble's members for a robust start), outside the moving ``exclusion`` and (``coast``)
    off land, as in the grid search."""

    def navigable(lat, lon, t_h):
        when = np.broadcast_to(t_h, np.shape(lat))
        ok = np.ones(np.shape(lat), dtype=bool)
        for ph in members:
            ok &= ph.sea(lat, lon, when).navigable
        if exclusion is not None:
            clat, clon, rad = exclusion.at(members[0].departure + _h_to_td(when))
            ok &= geo.distance_nm(lat, lon, clat, clon) >= rad
        return ok & ~land.is_land(lat, lon) if coast else ok

    return navigable


def search_dp(
    physics: PassagePhysics, start, end, eta_h, speeds, opts, objective, t_start, coast: bool, exclusion=None
) -> Route:
    """``search_route(method="dp")``: :func:`optroute.search.dp.solve_dp` on :meth:`PassagePhysics.dp_leg`, as a Route.

    ``opts`` are the caller's ``dp_options`` (``piece_nm`` [nm] is taken out for
    the leg costing; ``routes_for_eta_h``, ETAs [h from departure] on the run's bin
    edges, for the run's least-fuel routes for them too, in ``stats["routes_for_eta_h"]``
    by ETA, None where no route arrives by it: :meth:`optroute.search.dp.DPResult.path_for_eta`); nodes are navigable where the weather allows passage,
    outside the moving ``exclusion`` and (``coast``) off land; ``eta_h`` [h from
    departure] or None; with ``coast`` every lattice leg is also walked on the coastline
    (:func:`optroute.search.edge_land.legs_on_land`) and one that touches land does not exist.  With ``objective="time"`` (no ETA) the route is the DP's earliest arrival within the
    horizon, each bin keeping its earliest labels (``label_value="time"``: a band that clears can stop the earliest
    label and let a later one through), its ``cost`` that arrival [h]; else the least-fuel route.  Errors name the
    ETA's UTC time and the weather's extent.
    """
    if objective == "time" and eta_h is not None:
        raise ConfigError("the DP minimises fuel for an ETA; use objective='fuel' with method='dp'")
    piece_nm = float(opts.pop("piece_nm", 30.0))
    also = [float(e) for e in opts.pop("routes_for_eta_h", ())]
    sampler = physics.sampler

    navigable = dp_navigable([physics], exclusion, coast)
    if coast:  # the coastline between the lattice's states, walked on every leg
        opts.setdefault("legs_blocked", legs_on_land)
    t_last = (sampler.extent["time"][1] - physics.departure) / np.timedelta64(1, "s") / 3600.0
    opts.setdefault("horizon_h", float(t_last))
    if objective == "time":
        opts.setdefault("label_value", "time")
    try:
        res = solve_dp(start, end, physics.dp_leg(piece_nm), eta_h=eta_h, speeds_kn=speeds, navigable=navigable, **opts)
    except NoSafePassage as exc:
        raise explain_uncovered(exc, physics) from None
    except InfeasibleETA as exc:
        raise eta_as_time(exc, physics.departure) from None
    stats = {
        "n_states": res.n_states,
        "n_transitions": res.n_transitions,
        "earliest_arrival_h": res.earliest_arrival_h,
        "curve_bin_end_h": res.curve_bin_end_h,
        "curve_fuel_t": res.curve_fuel_t,
    }
    if also:  # the same run's least-fuel routes for other ETAs (bin edges of this run's lattice); None: none arrives
        stats["routes_for_eta_h"] = {}
        for e in also:
            try:
                stats["routes_for_eta_h"][e] = _route(res.path_for_eta(e), physics.departure, dict(stats))
            except InfeasibleETA:
                stats["routes_for_eta_h"][e] = None
    stats["runtime_s"] = _time.perf_counter() - t_start
    if objective == "time":
        return _route(res.path_for_eta(res.earliest_arrival_h), physics.departure, stats, objective="time")
    return _route(res.path, physics.departure, stats)


def _route(p, departure: np.datetime64, stats: dict, objective: str = "fuel") -> Route:
    """A :class:`Route` of a DP path (:class:`optroute.search.dp.DPPath`) departing at ``departure`` [UTC]; its
    ``cost`` is the fuel [t], or for ``objective="time"`` the arrival [h after departure]."""
    n_legs = p.lat_deg.size - 1
    return Route(
        waypoints=np.column_stack([p.lat_deg, p.lon_deg]),
        times=departure + _h_to_td(p.times_h),
        sog_kn=p.sog_kn,
        stw_kn=np.asarray(p.extra.get("stw_kn", np.full(n_legs, np.nan)), dtype=float),
        power_kw=np.asarray(p.extra.get("power_kw", np.full(n_legs, np.nan)), dtype=float),
        fuel_t=p.leg_fuel_t,
        duration_h=p.leg_duration_h,
        distance_nm=p.leg_distance_nm,
        cost=float(p.arrival_h if objective == "time" else p.total_fuel_t),
        objective=objective,
        method="dp",
        band_side={b: np.zeros(n_legs, dtype=np.int8) for b in BANDS},
        stats=stats,
    )
