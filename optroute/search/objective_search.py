"""The search's objective: minimum time, fixed λ, or the least λ meeting an ETA; its errors stated for the user.

:func:`run_objective` runs a search callback ``run(lam)`` (λ in t of fuel per
hour, None for minimum time) for the objective asked; :func:`bisect_lambda`
finds the least λ whose least-cost route arrives by the ETA (the fuel
objective, as Boeing EP 2145155 trades fuel against time), and
:func:`bisect_on_coarse` finds it on a coarser grid first, for a caller that keeps only the track;
:func:`eta_as_time` and :func:`explain_uncovered` turn the searches' errors
into ones that name UTC times and the weather's extent.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from optroute import units
from optroute.errors import InfeasibleETA, NoSafePassage, WeatherCoverageError
from optroute.search.passage_physics import PassagePhysics
from optroute.units import h_to_timedelta as _h_to_td


def eta_as_time(exc: InfeasibleETA, t0: np.datetime64) -> InfeasibleETA:
    """The search's :class:`InfeasibleETA` with ``earliest_arrival`` as a UTC time (the searches give hours)."""
    early = exc.earliest_arrival
    if early is None or isinstance(early, np.datetime64):
        return exc
    out = InfeasibleETA(
        f"{exc} (at {units.format_utc(t0 + _h_to_td(float(early)))})", earliest_arrival=t0 + _h_to_td(float(early))
    )
    out.earliest_arrival_h = float(early)  # type: ignore[attr-defined]
    return out


def explain_uncovered(exc: NoSafePassage, physics: PassagePhysics) -> Exception:
    """Say when the weather's extent, not the sea, stopped the search."""
    if physics.uncovered:
        ext = physics.sampler.extent
        return NoSafePassage(
            f"{exc} — {physics.uncovered} sampled points fell outside the weather data "
            f"(lat {ext['lat']}, lon {ext['lon']}, time {units.format_utc(ext['time'][0])} to {units.format_utc(ext['time'][1])}) and counted as no "
            "passage; extend the forecast in space or time"
        )
    return exc


def run_objective(
    run, objective, eta_h, t0, lambda_t_per_h, hourly_cost_per_h, fuel_price_per_t, stop_at_track=False,
    calm_speed_kn=None, coarse_run=None,
):  # fmt: skip
    """The search result for the objective and the λ it used [t/h].

    ``run(lam)`` searches minimum time (``lam`` None) or least fuel + λ·time (``run(lam, ceiling)``: only
    routes cheaper than ``ceiling``, see :func:`bisect_lambda`).
    ``"time"`` runs it once; a given λ (or ``"cost"``: hourly cost / fuel price)
    runs it once and raises :class:`InfeasibleETA` if that route is later than
    ``eta_h`` [h from ``t0``]; ``"fuel"`` bisects λ (:func:`bisect_lambda`, with ``stop_at_track`` and
    ``calm_speed_kn``), on the coarser grid's search ``coarse_run`` first where one is given with
    ``stop_at_track`` (:func:`bisect_on_coarse`).
    """
    lam_used = 0.0
    if objective == "time":
        res = run(None)
    elif lambda_t_per_h is not None or objective == "cost":
        lam_used = float(lambda_t_per_h if lambda_t_per_h is not None else hourly_cost_per_h / fuel_price_per_t)
        res = run(lam_used)
        if eta_h is not None and res.arrival_h > eta_h + 1e-9:
            raise InfeasibleETA(
                f"with lambda {lam_used:.3g} t/h the least-cost route arrives after {res.arrival_h:.1f} h, later than "
                f"the ETA {eta_h:.1f} h after departure; raise the hourly cost or give a later ETA",
                earliest_arrival=t0 + _h_to_td(res.arrival_h),
            )
    elif coarse_run is not None and stop_at_track:
        res, lam_used = bisect_on_coarse(run, coarse_run, eta_h, t0, calm_speed_kn=calm_speed_kn)
    else:
        res, lam_used = bisect_lambda(run, eta_h, t0, stop_at_track=stop_at_track, calm_speed_kn=calm_speed_kn)
    return res, lam_used


def bisect_on_coarse(
    run: Callable,
    coarse_run: Callable,
    eta_h: float | None,
    t0: np.datetime64,
    *,
    calm_speed_kn: Callable[[float], float] | None = None,
):
    """The fuel objective's λ bisected on a coarser grid, then one search at that λ on the route's own grid.

    :func:`bisect_lambda` with ``stop_at_track`` runs on ``coarse_run`` (the same search on a grid of larger
    cells: each of its rounds costs a fraction of the route's grid's), and the route's own search ``run``
    then runs once, at the λ it found. Where that route arrives by the ETA (and inside the weather) it is
    returned; where it is late, or the coarse grid finds no λ (no passage between its larger cells, or no
    route by the ETA), the bisection runs on the route's own grid as :func:`bisect_lambda` does, the coarse
    rounds then only spent. Like ``stop_at_track`` this is a rule for a caller that keeps the track and sets
    the speeds again: a λ below the coarse grid's could also be in time on the finer grid and is not looked
    for there.

    Returns
    -------
    (result, λ [t/h])
        The route's own grid's search result and the λ it was searched at.
    """
    try:
        _, lam = bisect_lambda(coarse_run, eta_h, t0, stop_at_track=True, calm_speed_kn=calm_speed_kn)
    except (NoSafePassage, InfeasibleETA, WeatherCoverageError):
        lam = None
    if lam is not None:
        try:
            res = run(lam)
        except NoSafePassage:
            res = None
        if not _late(res, eta_h):
            return res, lam
    return bisect_lambda(run, eta_h, t0, stop_at_track=True, calm_speed_kn=calm_speed_kn)


def _late(result, eta_h: float | None) -> bool:
    """Whether a λ round counts as late: no route (None), or one arriving after the ETA [h] where there is one."""
    return result is None or (eta_h is not None and result.arrival_h > eta_h)


def bisect_lambda(
    run: Callable,
    eta_h: float | None,
    t0: np.datetime64,
    *,
    stop_at_track: bool = False,
    calm_speed_kn: Callable[[float], float] | None = None,
):
    """Least λ whose least-cost route arrives by the ETA (fuel objective).

    A λ whose route cannot be completed (too slow to finish inside the
    forecast, say) counts as arriving too late; only when even the fastest
    choice fails is the search's :class:`NoSafePassage` raised.

    The bracket is halved 12 times; with ``stop_at_track`` the bisection
    stops as soon as a λ's route in time takes the same grid nodes as the
    best route in time so far (``nodes``, cell by cell), for a caller that
    keeps only the route's track (the corridor about it) and sets the speeds
    again: further halvings would mostly change the speeds along that track
    (a track of a λ still lower is then not looked for).  Each halving's
    search then also looks only for routes no dearer at its λ than the best
    route in time (``run(lam, ceiling)``, ``shortest_path``'s
    ``cost_ceiling``): it finds that route or a cheaper one as it would
    without the bound, and a round that finds none stops early and counts as
    late.  That is the unbounded round's outcome when it finds no route or a
    late one; it differs only where the label-setting search would return an
    in-time route dearer at that λ than the best one, which is then not
    taken.  With ``stop_at_track`` and ``calm_speed_kn`` (λ → the speed the
    search sails at λ in calm water [kn],
    :meth:`~optroute.search.passage_physics.PassagePhysics.calm_cheapest_speed_kn`),
    once λ = 0's route is late a λ whose calm-water speed is no faster than
    λ = 0's is taken as late without a search: its route trades fuel against
    time as λ = 0's does wherever the weather is mild, and so is taken to be as
    late, as the bisection takes every λ below a late one to be.  (This is a
    rule, not a proof: where the weather makes such a λ sail faster than λ = 0
    and arrive in time, the λ found is a higher one.)  The route returned is the
    in-time route of the least λ tried.
    """
    failure: list[NoSafePassage] = []

    def attempt(lam: float, ceiling: float | None = None):
        try:
            return run(lam, ceiling) if ceiling is not None else run(lam)
        except NoSafePassage as exc:
            failure[:] = [exc]
            return None

    def late(r) -> bool:
        return _late(r, eta_h)

    slow = attempt(0.0)
    if not late(slow):
        return slow, 0.0
    rule = stop_at_track and calm_speed_kn is not None
    floor_kn = calm_speed_kn(0.0) if rule else np.nan

    def tried(lam: float, ceiling: float | None = None):  # None: taken as late (the calm-speed rule above)
        return None if rule and lam < 1e4 and calm_speed_kn(lam) <= floor_kn else attempt(lam, ceiling)

    lo, hi = 0.0, 1.0
    fast = tried(hi)
    while late(fast) and hi < 1e4:
        lo, hi = hi, hi * 4.0
        fast = tried(hi)
    if fast is None:
        raise failure[0]
    if late(fast):
        raise InfeasibleETA(
            f"even valuing an hour at {hi:.0f} t of fuel the route arrives {fast.arrival_h:.1f} h after departure, "
            f"later than the ETA {eta_h:.1f} h; give a later ETA",
            earliest_arrival=t0 + _h_to_td(fast.arrival_h),
        )
    best = fast
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        # the best route's own cost at mid (with room for rounding): a search bounded by it finds that route or a
        # cheaper one at mid, and a round that fails under it stops early
        cap = best.total_fuel_t + mid * best.arrival_h
        r = tried(mid, cap * (1.0 + 1e-9) + 1e-9 if stop_at_track else None)
        if late(r):
            lo = mid
            continue
        same_track = stop_at_track and np.array_equal(r.nodes, best.nodes)
        hi, best = mid, r
        if same_track:
            break
    return best, hi
