"""A moving no-go circle (a cyclone's R + margin) in the grid search: an edge-feasibility hook.

:func:`avoiding` wraps a segment-cost callback of :mod:`optroute.search.costs` so that a piece is
infeasible when any point of it comes within the :class:`~optroute.geo.tracks.Exclusion` at the
time the ship is there.  The kernels are not touched: the plain callback's pieces are checked
after costing, and a compiled ``leg_batch`` keeps its speed on the legs that cannot come near the
circle (a conservative space–time bound) while the few that can are walked piece by piece through
the checked plain callback, as :class:`~optroute.search.costs.LegEvaluator` walks them.

The check samples each piece every ``sample_nm`` or less, both ends included, at times linear in
distance between the piece's entry and exit; the circle is enlarged by ``sample_nm`` plus the
distance the centre moves in one sample's time, so that the space between samples is covered.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute.geo.tracks import Exclusion
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h

__all__ = ["avoiding", "centre_speed_kn", "piece_hits"]


def centre_speed_kn(exclusion: Exclusion) -> float:
    """Fastest motion of the circle's centre between its samples [kn] (0 for a fixed circle)."""
    if exclusion.time.size < 2:
        return 0.0
    d = geo.distance_nm(exclusion.lat_deg[:-1], exclusion.lon_deg[:-1], exclusion.lat_deg[1:], exclusion.lon_deg[1:])
    dt = np.diff(_td_to_h(exclusion.time - exclusion.time[0]))
    return float(np.max(d / dt))


def piece_hits(
    exclusion: Exclusion,
    departure: np.datetime64,
    lat: np.ndarray,
    lon: np.ndarray,
    course: np.ndarray,
    length_nm: np.ndarray,
    t_h: np.ndarray,
    duration_h: np.ndarray,
    sample_nm: float = 2.0,
    centre_kn: float | None = None,
) -> np.ndarray:
    """Whether each piece (midpoint, course, length, entry time, duration) comes within the circle.

    ``centre_kn`` is the circle's fastest motion [kn] (default :func:`centre_speed_kn`).
    """
    n = lat.size
    if n == 0:
        return np.zeros(0, dtype=bool)
    m = max(3, int(math.ceil(float(np.max(length_nm)) / sample_nm)) + 1)
    f = np.linspace(-0.5, 0.5, m)[None, :]
    off = f * length_nm[:, None]
    crs = np.where(off < 0, course[:, None] + 180.0, course[:, None])
    plat, plon = geo.destination(
        np.broadcast_to(lat[:, None], off.shape), np.broadcast_to(lon[:, None], off.shape), crs, np.abs(off)
    )
    when_h = t_h[:, None] + (f + 0.5) * duration_h[:, None]
    clat, clon, rad = exclusion.at(departure + _h_to_td(when_h))
    speed = centre_speed_kn(exclusion) if centre_kn is None else float(centre_kn)
    pad = sample_nm + speed * np.max(duration_h) / (m - 1)
    return np.any(geo.distance_nm(plat, plon, clat, clon) < rad + pad, axis=1)


def avoiding(cb: Callable, exclusion: Exclusion, departure: np.datetime64, sample_nm: float = 2.0) -> Callable:
    """The segment-cost callback ``cb`` with the pieces that enter ``exclusion`` made infeasible.

    Parameters
    ----------
    cb : callable
        A segment-cost callback (``segment_cost(lat, lon, course, length_nm, t_h)``), with or
        without a compiled ``leg_batch``.
    exclusion : Exclusion
        The moving circle.
    departure : numpy.datetime64
        Time zero of the search's clock [UTC].
    sample_nm : float
        Spacing of the check along a piece [nm].
    """
    speed = centre_speed_kn(exclusion)
    r_max = float(np.max(exclusion.radius_nm))

    def checked(lat, lon, course, length_nm, t_h):
        out = tuple(cb(lat, lon, course, length_nm, t_h))
        dur, fuel, feas = np.asarray(out[0], dtype=float), np.asarray(out[1], dtype=float), np.asarray(out[2])
        go = np.flatnonzero(feas & np.isfinite(dur))
        if go.size:
            hit = piece_hits(
                exclusion, departure, *(np.asarray(a, dtype=float)[go] for a in (lat, lon, course, length_nm, t_h)),
                dur[go], sample_nm, speed,
            )  # fmt: skip
            if hit.any():
                feas = feas.copy()
                feas[go[hit]] = False
        return (dur, fuel, feas, *out[3:])

    batch = getattr(cb, "leg_batch", None)
    if batch is None:
        return checked

    def leg_batch(lat, lon, course, length, n_pieces, t0_h):
        dur, fuel, feas = (np.array(a) for a in batch(lat, lon, course, length, n_pieces, t0_h))
        near = _near(lat, lon, length, n_pieces, t0_h, dur, feas)
        if near.size:
            d, fu, ok = _walk(checked, lat[near], lon[near], course[near], length[near], n_pieces[near], t0_h[near])
            dur[near], fuel[near], feas[near] = d, fu, ok
        return dur, fuel, feas

    def _near(lat, lon, length, n_pieces, t0_h, dur, feas) -> np.ndarray:
        """Feasible legs that may come within the circle: a piece midpoint within R + reach of the centre."""
        go = np.flatnonzero(feas & np.isfinite(dur))
        if go.size == 0:
            return go
        mid_h = t0_h[go] + 0.5 * dur[go]
        clat, clon, _ = exclusion.at(departure + _h_to_td(mid_h))
        kmax = lat.shape[1]
        real = np.arange(kmax)[None, :] < n_pieces[go, None]
        dist = geo.distance_nm(lat[go], lon[go], clat[:, None], clon[:, None])
        dist = np.where(real, dist, np.inf).min(axis=1)
        reach = r_max + speed * 0.5 * dur[go] + np.where(real, length[go], 0.0).max(axis=1) + 2.0 * sample_nm
        return go[dist < reach]

    checked.leg_batch = leg_batch  # type: ignore[attr-defined]
    return checked


def _walk(cb: Callable, lat, lon, course, length, n_pieces, t0_h) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Legs of (n, kmax) pieces costed piece by piece through ``cb``, the time carried forward."""
    n = lat.shape[0]
    t = np.array(t0_h, dtype=float, copy=True)
    fuel = np.zeros(n)
    feas = np.ones(n, dtype=bool)
    for k in range(lat.shape[1]):
        act = np.flatnonzero(feas & (n_pieces > k))
        if act.size == 0:
            break
        out: Any = cb(lat[act, k], lon[act, k], course[act, k], length[act, k], t[act])
        d, fu, ok = np.asarray(out[0], dtype=float), np.asarray(out[1], dtype=float), np.asarray(out[2], dtype=bool)
        feas[act] = ok
        t[act[ok]] += d[ok]
        fuel[act[ok]] += fu[ok]
    return t - t0_h, fuel, feas
