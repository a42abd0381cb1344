"""Ship–cyclone encounter geometry of the typhoon-avoidance patent: DCPA, TCPA, its trigger and risk degree.

The patent (the Chinese typhoon-avoidance route patent by dynamic artificial potential field,
paragraphs [0060]–[0076]) borrows collision avoidance: the typhoon's force-7 circle of radius R
moves with its centre; from the relative position and velocity of ship and centre follow the
distance to the closest point of approach (DCPA) and the time to it (TCPA).  Avoidance starts when
DCPA ≤ R (the ship will meet the circle if nothing changes) *and* the centre is within the safe
distance R + 30 km ([0084]).

Geometry: a local plane about the ship (east x, north y; x = Δlon · 60 cos φ̄, y = Δlat · 60 [nm],
φ̄ the mean latitude), good to a fraction of a percent over the few hundred kilometres where the
trigger matters; distances reported by :func:`encounter` are great-circle distances.

The risk degree r ∈ [0, 1] ([0089]–[0095]): the patent names its inputs (DCPA, TCPA, the current
distance D, the ship's safe distance D_S, the crew's time T_S from decision to helm, and weights
a1 (visibility), a2 (ship size, slow turning), a3 (waters), usually 1) and its limits (0: no
danger, 1: the circle cannot be avoided whatever the ship does), but its formula is a figure the
text we hold does not carry.  :func:`risk_degree` is our reconstruction from those inputs and
limits, with the sine membership of the classic collision-risk model (Zheng Zhongyi and Wu
Zhaolin's DCPA/TCPA membership functions):

* u_DCPA = 1 for DCPA ≤ R, 0 for DCPA ≥ R + a1 (D_S − R), ½ − ½ sin(π (DCPA − m) / w) between
  (m the middle, w the width of that band);
* u_T = 0 when the centre is receding (TCPA < 0 or no closing speed); else the time t_s to reach
  the safe circle a3 · D_S at the closing speed, and u_T = min(1, a2 T_S / t_s) (1 once the ship
  is within the crew's reaction time of it);
* r = u_DCPA · u_T.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.weather.cyclone_tracks import CycloneTrack

__all__ = [
    "Encounter",
    "best_closest_approach",
    "dcpa_tcpa",
    "encounter",
    "local_xy_nm",
    "patent_trigger",
    "risk_degree",
]

KM_PER_NM = 1.852
PATENT_MARGIN_KM = 30.0
"""The patent's safe distance beyond the force-7 circle, R + 30 km ([0084])."""


def local_xy_nm(lat0_deg: ArrayLike, lon0_deg: ArrayLike, lat_deg: ArrayLike, lon_deg: ArrayLike) -> np.ndarray:
    """Position of (lat, lon) seen from (lat0, lon0) on the local plane, (..., 2) east/north [nm]."""
    lat0, lon0 = np.asarray(lat0_deg, dtype=float), np.asarray(lon0_deg, dtype=float)
    lat, lon = np.asarray(lat_deg, dtype=float), np.asarray(lon_deg, dtype=float)
    dlon = units.wrap_180(lon - lon0)
    mid = np.radians(0.5 * (lat + lat0))
    return np.stack([dlon * 60.0 * np.cos(mid), (lat - lat0) * 60.0], axis=-1)


def dcpa_tcpa(rel_pos: ArrayLike, rel_vel: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """DCPA and TCPA of an object at ``rel_pos`` moving at ``rel_vel`` relative to the observer.

    Parameters
    ----------
    rel_pos : array_like, (..., 2)
        Object minus observer, in any length unit.
    rel_vel : array_like, (..., 2)
        Object's velocity minus the observer's, in that length unit per time unit.

    Returns
    -------
    dcpa, tcpa : ndarray
        Closest distance (length unit) and the time to it (time unit; negative when it is past).
        Without relative motion the distance never changes: DCPA = the distance, TCPA = 0.
    """
    p = np.asarray(rel_pos, dtype=float)
    w = np.asarray(rel_vel, dtype=float)
    ww = np.sum(w * w, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        tcpa = np.where(ww > 0, -np.sum(p * w, axis=-1) / np.where(ww > 0, ww, 1.0), 0.0)
    closest = p + w * tcpa[..., None]
    return np.sqrt(np.sum(closest * closest, axis=-1)), tcpa


def best_closest_approach(rel_pos: ArrayLike, centre_vel: ArrayLike, speed: float) -> float:
    """The largest closest approach to a centre moving at constant velocity that any heading at ``speed`` achieves.

    Hand-worked bound for "can any heading keep out of the circle?": in the centre's frame the
    ship's velocity is w = u − V (V the centre's, |u| ≤ ``speed``), a disk of radius ``speed`` about
    −V.  If ``speed`` ≥ |V| some w opens (or holds) the distance, and the best closest approach is
    the present distance d.  Otherwise every w lies within θ_m = asin(speed / |V|) of −V, and a
    straight relative track in a direction φ from the centre's bearing passes d·sin φ from it
    (d if φ ≥ 90°); the widest φ is β + θ_m, β the angle between the bearing of the centre and −V.
    Steering instead of holding a heading does not help: every later position lies in the cone of
    those directions from the ship, so a circle that every such ray meets bars every path to
    infinity within it.

    Parameters
    ----------
    rel_pos : array_like, (2,)
        Centre minus ship on the local plane (east, north), any length unit.
    centre_vel : array_like, (2,)
        Centre's velocity (east, north) in that unit per time unit.
    speed : float
        The ship's largest speed over ground, same unit per time unit.

    Returns
    -------
    float
        The best closest approach (the length unit): the circle of radius R can be kept out of
        iff R ≤ this.
    """
    p = np.asarray(rel_pos, dtype=float)
    v = np.asarray(centre_vel, dtype=float)
    d, vc = float(np.hypot(*p)), float(np.hypot(*v))
    s = float(finite("speed", speed, minimum=0.0, error=ConfigError))
    if s >= vc or d == 0.0:
        return d
    beta = float(np.arccos(np.clip(np.dot(p, -v) / (d * vc), -1.0, 1.0)))
    phi = beta + float(np.arcsin(s / vc))
    return d if phi >= 0.5 * np.pi else d * float(np.sin(phi))


@dataclass(frozen=True)
class Encounter:
    """A ship and a cyclone at one time (arrays of one shape).

    Attributes
    ----------
    distance_km : ndarray
        Great-circle distance ship–centre [km].
    dcpa_km, tcpa_h : ndarray
        Closest approach of the centre to the ship at the present velocities [km] and the time to it [h].
    closing_kn : ndarray
        Rate at which the distance shrinks [kn] (negative when opening).
    r7_km : ndarray
        Force-7 radius R at that time [km].
    bearing_deg : ndarray
        Bearing of the centre from the ship [deg true].
    """

    distance_km: np.ndarray
    dcpa_km: np.ndarray
    tcpa_h: np.ndarray
    closing_kn: np.ndarray
    r7_km: np.ndarray
    bearing_deg: np.ndarray

    def trigger(self, margin_km: float = PATENT_MARGIN_KM) -> np.ndarray:
        """The patent's start of avoidance: DCPA ≤ R and the centre within R + ``margin_km``."""
        return patent_trigger(self.dcpa_km, self.distance_km, self.r7_km, margin_km)


def encounter(
    lat_deg: ArrayLike, lon_deg: ArrayLike, sog_kn: ArrayLike, cog_deg: ArrayLike, time: Any, track: CycloneTrack
) -> Encounter:
    """DCPA, TCPA and distance between a ship (position, SOG, COG) and the cyclone's centre at ``time``.

    The centre's position and motion are the track's, interpolated in time
    (:meth:`~optroute.weather.cyclone_tracks.CycloneTrack.at`).
    """
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    s = track.at(time)
    rel = local_xy_nm(lat, lon, s["lat"], s["lon"])
    cog = np.radians(np.asarray(cog_deg, dtype=float))
    sog = np.asarray(sog_kn, dtype=float)
    v_ship = np.stack(np.broadcast_arrays(sog * np.sin(cog), sog * np.cos(cog)), axis=-1)
    v_c = np.stack(np.broadcast_arrays(s["u_kn"], s["v_kn"]), axis=-1)
    w = v_c - v_ship
    dcpa, tcpa = dcpa_tcpa(rel, w)
    dist_nm = np.sqrt(np.sum(rel * rel, axis=-1))
    with np.errstate(invalid="ignore", divide="ignore"):
        closing = np.where(dist_nm > 0, -np.sum(rel * w, axis=-1) / np.where(dist_nm > 0, dist_nm, 1.0), 0.0)
    return Encounter(
        distance_km=np.asarray(geo.distance_nm(lat, lon, s["lat"], s["lon"])) * KM_PER_NM,
        dcpa_km=dcpa * KM_PER_NM,
        tcpa_h=tcpa,
        closing_kn=closing,
        r7_km=np.broadcast_to(s["r7_km"], dcpa.shape).copy(),
        bearing_deg=np.asarray(geo.initial_course_deg(lat, lon, s["lat"], s["lon"])),
    )


def patent_trigger(
    dcpa_km: ArrayLike, distance_km: ArrayLike, r_km: ArrayLike, margin_km: float = PATENT_MARGIN_KM
) -> np.ndarray:
    """The patent's trigger (S1–S2, [0123]–[0124]): DCPA ≤ R and distance ≤ R + ``margin_km``."""
    m = float(finite("margin_km", margin_km, minimum=0.0, error=ConfigError))
    d, dist, r = (np.asarray(a, dtype=float) for a in (dcpa_km, distance_km, r_km))
    return (d <= r) & (dist <= r + m)


def risk_degree(
    enc: Encounter,
    *,
    margin_km: float = PATENT_MARGIN_KM,
    reaction_h: float = 6.0,
    a1: float = 1.0,
    a2: float = 1.0,
    a3: float = 1.0,
) -> np.ndarray:
    """Risk degree r ∈ [0, 1] of the encounter (our reconstruction, see the module docstring).

    Parameters
    ----------
    enc : Encounter
    margin_km : float
        Safe distance beyond R [km]: D_S = R + margin.
    reaction_h : float
        T_S, the crew's time from decision to helm [h] (6 h by default: a modelling choice; the
        patent gives none).
    a1, a2, a3 : float
        Weights for visibility (widens the DCPA band), ship size / slow turning (lengthens the
        reaction time) and waters (enlarges the safe distance), > 0; the patent's usual value 1.
    """
    for name, v in (("a1", a1), ("a2", a2), ("a3", a3), ("reaction_h", reaction_h)):
        finite(name, v, minimum=0.0, strict=True, error=ConfigError)
    m = float(finite("margin_km", margin_km, minimum=0.0, strict=True, error=ConfigError))
    r = enc.r7_km
    safe = r + m
    lo, hi = r, r + a1 * (safe - r)
    mid, width = 0.5 * (lo + hi), hi - lo
    d = enc.dcpa_km
    u_d = np.where(d <= lo, 1.0, np.where(d >= hi, 0.0, 0.5 - 0.5 * np.sin(np.pi * (d - mid) / width)))
    closing_kmh = enc.closing_kn * KM_PER_NM
    approaching = (enc.tcpa_h >= 0) & (closing_kmh > 0)
    with np.errstate(
        invalid="ignore", divide="ignore", over="ignore"
    ):  # a closing speed of ~1e-300 km/h: never reached
        t_s = np.maximum(enc.distance_km - a3 * safe, 0.0) / np.where(approaching, closing_kmh, 1.0)
        u_t = np.where(approaching, np.where(t_s > 0, np.minimum(1.0, a2 * reaction_h / t_s), 1.0), 0.0)
    return u_d * u_t
