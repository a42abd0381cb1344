"""A tropical cyclone met under way: the track known at each re-plan, and what the ship met in the truth.

Issue 19 item 4 (the typhoon-avoidance patent's R + 30 km rule in the voyage simulator). A
:class:`CycloneWatch` holds the TRUE track of the cyclone and the forecast tracks the ship
receives, each usable from its issue time on (like the weather forecasts of
:class:`~optroute.voyage.policy.ForecastSequence`). Every plan made at time ``t`` keeps out of the
circle of the newest track issued by ``t``: the force-7 radius R + ``margin_km`` + a cone growing
with the lead time past the issue (``cone_km_per_h`` × hours after the issue time;
:meth:`optroute.Exclusion.from_track`). Without forecast tracks the planner knows the true track
(its lead counted from the planning time, so the cone still widens ahead).

The truth is then judged by brute force along the track sailed (:func:`cyclone_encounter`): the
ship's position every ``sample_nm`` or less along each simulator step (great circle, time linear
in distance), against the TRUE centre and R interpolated at the same time
(:meth:`~optroute.weather.cyclone_tracks.CycloneTrack.at`): the closest approach to the centre
and the time inside R and inside R + margin.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.geo.tracks import Exclusion
from optroute.units import as_utc_time as _as_time
from optroute.units import h_to_timedelta as _h_to_td
from optroute.units import timedelta_to_h as _td_to_h
from optroute.weather.cyclone_tracks import DEFAULT_CONE_KM_PER_H, CycloneTrack

__all__ = ["CycloneEncounter", "CycloneWatch", "cyclone_encounter"]

KM_PER_NM = 1.852


@dataclass(frozen=True, eq=False)
class CycloneWatch:
    """The cyclone of a simulated voyage: its true track and the forecast tracks the ship receives.

    Parameters
    ----------
    truth : CycloneTrack
        Where the cyclone really went (a b-deck best track, an IBTrACS track; lead 0).
    forecasts : sequence of (issue time, CycloneTrack) or CycloneTrack
        Forecast tracks [UTC issue time]; a bare track (an a-deck aid read with
        :func:`~optroute.weather.cyclone_tracks.read_atcf`) is issued at its DTG, its first time
        minus its first lead. Empty: every plan knows the true track.
    margin_km : float
        Safety margin beyond the force-7 radius R [km], >= 0 (the patent: 30 km).
    cone_km_per_h : float, optional
        Growth of the circle with the hours past the track's issue [km/h], >= 0 (default
        :data:`~optroute.weather.cyclone_tracks.DEFAULT_CONE_KM_PER_H`).
    """

    truth: CycloneTrack
    forecasts: Sequence[Any] = ()
    margin_km: float = 30.0
    cone_km_per_h: float | None = None
    _issued: np.ndarray = field(init=False, repr=False)
    _tracks: tuple[CycloneTrack, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.truth, CycloneTrack):
            raise ConfigError(
                f"CycloneWatch.truth must be a CycloneTrack, got {type(self.truth).__name__}; read it with "
                "optroute.weather.cyclone_tracks.read_track"
            )
        object.__setattr__(
            self, "margin_km", float(finite("margin_km", self.margin_km, minimum=0.0, error=ConfigError))
        )
        cone = DEFAULT_CONE_KM_PER_H if self.cone_km_per_h is None else self.cone_km_per_h
        object.__setattr__(self, "cone_km_per_h", float(finite("cone_km_per_h", cone, minimum=0.0, error=ConfigError)))
        pairs = []
        for k, item in enumerate(self.forecasts):
            if isinstance(item, CycloneTrack):
                issued = item.time[0] - _h_to_td(float(item.lead_h[0]))
                track = item
            else:
                try:
                    issued, track = item
                except (TypeError, ValueError):
                    raise ConfigError(
                        f"CycloneWatch.forecasts[{k}] must be an (issue time, CycloneTrack) pair or a CycloneTrack, "
                        f"got {item!r}"
                    ) from None
                if not isinstance(track, CycloneTrack):
                    raise ConfigError(f"CycloneWatch.forecasts[{k}]: the track is a {type(track).__name__}")
            pairs.append((_as_time(issued, f"CycloneWatch.forecasts[{k}] issue time"), track))
        pairs.sort(key=lambda p: p[0])
        issued_all = np.array([p[0] for p in pairs], dtype="datetime64[ns]")
        if np.unique(issued_all).size != issued_all.size:
            raise ConfigError("CycloneWatch.forecasts: two tracks share an issue time; give each its own")
        object.__setattr__(self, "_issued", issued_all)
        object.__setattr__(self, "_tracks", tuple(p[1] for p in pairs))

    @property
    def issue_times(self) -> np.ndarray:
        """Issue times of the forecast tracks [UTC], increasing."""
        return self._issued.copy()

    def latest_index(self, when: Any) -> int | None:
        """Index of the newest forecast track issued by ``when``; None without forecast tracks."""
        if not self._tracks:
            return None
        t = _as_time(when, "when")
        k = int(np.searchsorted(self._issued, t, side="right")) - 1
        if k < 0:
            raise ConfigError(
                f"no cyclone track is issued by {units.format_utc(t)} (the first at "
                f"{units.format_utc(self._issued[0])}); give a track issued by the departure"
            )
        return k

    def exclusion(self, when: Any) -> tuple[Exclusion, int | None]:
        """The circle a plan made at ``when`` keeps out of, and the forecast track's index (None: the truth).

        R + margin along the track known then, + ``cone_km_per_h`` × the hours past its issue (past
        ``when`` for the true track).
        """
        t = _as_time(when, "when")
        k = self.latest_index(t)
        track, issued = (self.truth, t) if k is None else (self._tracks[k], self._issued[k])
        return _circle(track, issued, self.margin_km, float(self.cone_km_per_h)), k


def _circle(track: CycloneTrack, issued: np.datetime64, margin_km: float, cone_km_per_h: float) -> Exclusion:
    """R + margin + cone × hours past ``issued`` along ``track``, sampled hourly and at the track's points."""
    span_h = float(_td_to_h(track.time[-1] - track.time[0]))
    hours = np.unique(np.concatenate([np.arange(0.0, span_h, 1.0), _td_to_h(track.time - track.time[0])]))
    t = track.time[0] + _h_to_td(hours)
    s = track.at(t)
    lead_h = np.maximum(_td_to_h(t - issued), 0.0)
    radius_km = s["r7_km"] + margin_km + cone_km_per_h * lead_h
    return Exclusion(t, s["lat"], s["lon"], radius_km / KM_PER_NM)


@dataclass(frozen=True)
class CycloneEncounter:
    """What the ship met of the TRUE cyclone, by brute force along the track sailed.

    Attributes
    ----------
    closest_km : float
        Least distance from the ship to the true centre [km].
    closest_time : numpy.datetime64
        When [UTC].
    least_gap_km : float
        Least (distance − R) [km]: < 0 inside R, < margin inside R + margin.
    time_inside_r_h, time_inside_margin_h : float
        Time sailed inside R and inside R + margin [h].
    step_distance_km : ndarray
        Least distance to the true centre in every simulator step [km].
    step_r7_km : ndarray
        The true R at that closest point of every step [km].
    """

    closest_km: float
    closest_time: np.datetime64
    least_gap_km: float
    time_inside_r_h: float
    time_inside_margin_h: float
    step_distance_km: np.ndarray = field(repr=False)
    step_r7_km: np.ndarray = field(repr=False)

    def outcome_fields(self) -> dict[str, float]:
        """The fields of :class:`~optroute.voyage.policy.VoyageOutcome` this encounter fills."""
        return {
            "cyclone_closest_km": self.closest_km,
            "cyclone_least_gap_km": self.least_gap_km,
            "time_inside_r_h": self.time_inside_r_h,
            "time_inside_margin_h": self.time_inside_margin_h,
        }

    def into_log(self, log: xr.Dataset, watch: CycloneWatch) -> xr.Dataset:
        """The voyage log with the per-step distance to the true centre and R, and the encounter in its attrs."""
        log = log.assign(
            cyclone_distance_km=(
                "step",
                self.step_distance_km,
                {"units": "km", "long_name": "least distance to the TRUE cyclone centre in the step"},
            ),
            cyclone_r7_km=("step", self.step_r7_km, {"units": "km", "long_name": "true force-7 radius R there"}),
        )
        log.attrs.update(
            {
                "cyclone_name": watch.truth.name,
                "cyclone_margin_km": watch.margin_km,
                "cyclone_cone_km_per_h": float(watch.cone_km_per_h),  # type: ignore[arg-type]
                "cyclone_closest_time": units.format_utc(self.closest_time),
                **self.outcome_fields(),
            }
        )
        return log


def cyclone_encounter(
    records: Sequence[Any], truth: CycloneTrack, margin_km: float, sample_nm: float = 1.0
) -> CycloneEncounter:
    """Brute force along the steps sailed: distance to the TRUE centre every ``sample_nm`` or less.

    ``records`` are the simulator's :class:`~optroute.voyage.log.StepRecord` (start ``time``,
    ``lat``, ``lon``, ``end``, ``duration_h``): each step is the great circle from its start to its
    end, the time linear in distance. Time inside a circle is the share of a step's samples inside
    it (trapezoid over the samples) × its duration.
    """
    dist_k, r7_k = [], []
    best = (math.inf, None, math.inf)
    t_r = t_m = 0.0
    for r in records:
        d = float(geo.distance_nm(r.lat, r.lon, r.end[0], r.end[1]))
        f = np.linspace(0.0, 1.0, max(3, int(math.ceil(d / sample_nm)) + 1))
        la, lo = geo.intermediate_points(r.lat, r.lon, float(r.end[0]), float(r.end[1]), f)
        when = r.time + _h_to_td(f * r.duration_h)
        s = truth.at(when)
        dkm = geo.distance_nm(la, lo, s["lat"], s["lon"]) * KM_PER_NM
        gap = dkm - s["r7_km"]
        i = int(np.argmin(dkm))
        dist_k.append(float(dkm[i]))
        r7_k.append(float(s["r7_km"][i]))
        if dkm[i] < best[0]:
            best = (float(dkm[i]), when[i], best[2])
        best = (best[0], best[1], min(best[2], float(gap.min())))
        w = np.full(f.size, 1.0 / (f.size - 1))
        w[[0, -1]] *= 0.5
        t_r += float(np.sum(w * (gap < 0.0))) * r.duration_h
        t_m += float(np.sum(w * (gap < margin_km))) * r.duration_h
    if best[1] is None:
        raise ConfigError("cyclone_encounter: no step sailed")
    return CycloneEncounter(best[0], best[1], best[2], t_r, t_m, np.array(dist_k), np.array(r7_k))
