"""Whether a band-safe passage exists by the ETA: brute force on fixed tracks for ``bench_bands`` (issue 13, item 4).

Independent of the optimiser and of the DP: along the corridor's centreline and parallel tracks at fixed lateral
offsets, the weather is sampled directly on a lattice of along-track positions (every ``ds_nm``) and times (every
``dt_h``), and every speed through water from 3 kn to the ship's top calm-water speed (every ``dv_kn``) is tested
against the enabled danger bands (:func:`optroute.physics.safety.is_speed_forbidden`, the rules' own conditions;
heading the track's course, no current). A lattice cell where no speed is allowed is *closed*. The earliest arrival
is a forward reachability in continuous time: from (s_i, τ) at a speed v allowed there to (s_{i+1}, τ + ds/v) where
v must be allowed too (each looked up at the nearest lattice time). It is a model of the passage, not a plan: it ignores the
engine's range and lateral moves between the tracks, so it can only show that an ETA is out of reach *on these
tracks*; with the destination itself closed around the ETA (the tracks meet there) no lateral freedom helps.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

RESOLUTION_H = 0.01
"""Reachable times closer than this are merged [h] (the schedule itself is continuous; the weather and the bands
are looked up at the nearest lattice time)."""


def earliest_safe_arrival(
    ship: Any, rules: Any, weather: Any, start: tuple[float, float], end: tuple[float, float], t0: np.datetime64,
    *, offsets_nm: tuple[float, ...] = (0.0, 20.0, -20.0), ds_nm: float = 5.0, dt_h: float = 0.25,
    dv_kn: float = 0.25, horizon_h: float = 72.0,
) -> dict[str, Any]:  # fmt: skip
    """Per fixed track, the earliest band-safe arrival [h] (None: none within ``horizon_h``) and the destination's
    closed hours [h after ``t0``] (the first and last closed lattice time at the end point)."""
    from optroute import geodesy as geo
    from optroute.physics.safety import is_speed_forbidden
    from optroute.plan.evaluate import sample_sea
    from optroute.weather.sample import WeatherSampler

    sampler = WeatherSampler(weather)
    length = float(geo.distance_nm(*start, *end))
    s = np.append(np.arange(0.0, length, ds_nm), length)
    t = np.arange(0.0, horizon_h, dt_h)
    speeds = np.arange(3.0, ship.max_calm_speed_kn + 1e-9, dv_kn)
    lat0, lon0 = geo.intermediate_points(*start, *end, s / length)
    course = np.append(geo.initial_course_deg(lat0[:-1], lon0[:-1], lat0[1:], lon0[1:]), 0.0)
    course[-1] = course[-2]
    out: dict[str, Any] = {"length_nm": length, "tracks": {}}
    for off in offsets_nm:
        lat, lon = geo.destination(lat0, lon0, course - 90.0, off) if off else (lat0, lon0)
        i_s, k_t = np.meshgrid(np.arange(s.size), np.arange(t.size), indexing="ij")
        when = t0 + (k_t.ravel() * dt_h * 3.6e12).astype("timedelta64[ns]")
        sea, _ = sample_sea(sampler, when, lat[i_s.ravel()], lon[i_s.ravel()])
        heading = course[i_s.ravel()]
        ok = np.stack([~is_speed_forbidden(ship, speed_kn=np.full(heading.size, v), hs_m=sea.hs_m,
                                           period_s=sea.period_s, wave_from_deg=sea.wave_from_deg,
                                           heading_deg=heading, rules=rules).reshape(i_s.shape)
                       for v in speeds], axis=-1)  # fmt: skip
        times = np.array([0.0])  # the arrival times reachable at s[i] [h], to RESOLUTION_H
        for i in range(s.size - 1):
            k = np.clip(np.rint(times / dt_h).astype(int), 0, t.size - 1)
            t2 = times[:, None] + (s[i + 1] - s[i]) / speeds[None, :]  # (n, m)
            k2 = np.rint(t2 / dt_h).astype(int)
            inside = k2 < t.size
            good = ok[i, k][:, :] & inside
            good[inside] &= ok[i + 1, k2[inside], np.nonzero(inside)[1]]
            times = np.unique(np.round(t2[good] / RESOLUTION_H)) * RESOLUTION_H
            if times.size == 0:
                break
        out["tracks"][f"{off:+.0f} nm"] = float(times.min()) if times.size else None
        if off == 0.0:  # the destination itself (the offset tracks end beside it)
            closed_end = np.flatnonzero(~ok[-1].any(axis=-1))
            out["closed_at_end_h"] = (float(t[closed_end[0]]), float(t[closed_end[-1]])) if closed_end.size else None
    best = [v for v in out["tracks"].values() if v is not None]
    out["earliest_h"] = min(best) if best else math.nan
    return out
