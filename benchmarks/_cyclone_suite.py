"""A seeded suite of synthetic cyclone crossings for ``bench_cyclone`` (issue 19): the patent's APF against optroute.

Each case is one encounter drawn the way real ones vary (seeded: :data:`SEED`): a typhoon moving
west to north-west at a speed of advance of 5–25 kn (some recurving to the north-east), of force-7
radius R ≈ 120–300 km (Holland 1980 profile, Δp 30–60 hPa, R_max 25–50 km), meets a ship on a 600–900 nm
passage at its design-like speed (the three presets).  The geometry is set by where the centre
crosses the ship's great circle relative to the ship:

* ``ahead`` / ``behind``: the centre crosses the route 6–18 h before / after the ship would be there;
* ``on the route``: the centre crosses exactly where and when the ship would be;
* ``head-on``: the typhoon moves against the ship, its course within 15–30° of the reciprocal of
  the ship's, passing 0–100 nm off the route;
* ``overtaking``: the typhoon moves with the ship, its course within 15–30° of the ship's, passing
  0–80 nm off the route, faster than the ship (20–25 kn: it overtakes the ship) or slower (0.3–0.45
  of the ship's speed: the ship overtakes it);
* ``recurving``: the track turns 60–100° to the right (north-west to north-east) over 24 h near the route;
* ``antimeridian``: a crossing at 180°, with the weather grid and track across it.

A draw is rejected (and redrawn from the same seeded stream) when the start lies within R + 80 km of
the centre at departure or the destination within R + 80 km while the ship could be arriving
(0.8–1.6 great-circle passages after departure): no
route can keep out of R + 30 km there, so such a case says nothing about either method.

The weather is :func:`optroute.weather.cyclone.tropical_cyclone` (Holland wind, fetch-limited sea
over a 1.5 m north-easterly background), synthetic geography: no coastline applies.  The circle is
the track written as an ATCF b-deck and read back (:func:`optroute.weather.cyclone_tracks.read_atcf`),
as in the Nesat-like case.

The closest approaches and the time inside R are checked by brute force, independently of the
planners' own checks (:func:`brute_force`): points every ``step_nm`` along each plan's legs, the
time interpolated along the leg, the centre and R interpolated in time from the track.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from optroute import geodesy as geo
from optroute import units
from optroute.weather.cyclone import Cyclone, holland_vmax_ms, tropical_cyclone
from optroute.weather.cyclone_tracks import CycloneTrack, read_atcf, write_atcf

SEED = 19
"""The suite's random stream (issue 19's number); every draw, rejected ones included, comes from it."""

SHIPS = {  # preset: (speeds sailed [kn], the ship's kind for the table)
    "general_cargo_25k_dwt": (11.0, 14.0),
    "container_54k_dwt": (16.0, 20.0),
    "container_8000teu": (15.0, 19.0),
}
KINDS = (
    "ahead",
    "behind",
    "head-on",
    "recurving",
    "on the route",
    "overtaking (typhoon faster)",
    "overtaking (ship faster)",
    "antimeridian",
    "ahead",
    "behind",
    "recurving",
    "head-on",
    "on the route",
    "recurving",
)
"""Encounter kinds in suite order: quick mode takes the first four, full mode the first twelve (``--suite`` too)."""


@dataclass(frozen=True)
class CrossingCase:
    """One synthetic encounter: ship, passage, typhoon.

    ``pass_point`` is where the centre crosses (or, head-on and overtaking, passes abeam of) the
    ship's great circle [deg]; ``lag_h`` how much later than the ship the centre gets there [h]
    (negative: it crosses ahead of the ship); ``course_deg`` the typhoon's initial course [deg true,
    to]; ``turn_deg`` its recurvature (to the right) spread over 24 h from ``turn_h`` after departure.
    """

    name: str
    kind: str
    ship: str
    speed_kn: float
    start: tuple[float, float]
    end: tuple[float, float]
    departure: np.datetime64
    cyclone: Cyclone
    advance_kn: float
    r7_km: float
    lag_h: float
    offset_nm: float
    turn_deg: float

    @property
    def t0(self) -> np.datetime64:
        """The weather's and the track's start: 6 h before departure."""
        return self.departure - np.timedelta64(6, "h")

    @property
    def length_nm(self) -> float:
        return float(geo.distance_nm(*self.start, *self.end))

    @property
    def duration_h(self) -> float:
        """The weather's span: 6 h before departure to 2.5 great-circle passages after it."""
        return 3.0 * math.ceil((6.0 + 2.5 * self.length_nm / self.speed_kn) / 3.0)


def _course_at(h: float, course0: float, turn_deg: float, turn_h: float) -> float:
    return course0 + turn_deg * min(max((h - turn_h) / 24.0, 0.0), 1.0)


def track_through(
    point: tuple[float, float], t_pass_h: float, course0: float, advance_kn: float, turn_deg: float, turn_h: float,
    duration_h: float,
) -> tuple[tuple[float, float, float], ...]:  # fmt: skip
    """(hours, lat, lon) every 6 h of a centre at ``point`` at ``t_pass_h``, integrated hourly both ways."""
    hours = np.arange(0.0, duration_h + 1e-9, 1.0)
    k0 = int(np.argmin(np.abs(hours - t_pass_h)))
    lat, lon = np.empty(hours.size), np.empty(hours.size)
    la, lo = geo.destination(point[0], point[1], _course_at(t_pass_h, course0, turn_deg, turn_h) + 180.0,
                             advance_kn * (t_pass_h - hours[k0]))  # fmt: skip
    lat[k0], lon[k0] = float(la), float(lo)
    for k in range(k0 + 1, hours.size):
        c = _course_at(hours[k] - 0.5, course0, turn_deg, turn_h)
        lat[k], lon[k] = (float(v) for v in geo.destination(lat[k - 1], lon[k - 1], c, advance_kn))
    for k in range(k0 - 1, -1, -1):
        c = _course_at(hours[k] + 0.5, course0, turn_deg, turn_h) + 180.0
        lat[k], lon[k] = (float(v) for v in geo.destination(lat[k + 1], lon[k + 1], c, advance_kn))
    keep = np.arange(0, hours.size, 6)
    return tuple((float(hours[k]), float(lat[k]), float(units.wrap_180(lon[k]))) for k in keep)


def b_deck(cyc: Cyclone, t0: np.datetime64, path: Path) -> CycloneTrack:
    """The typhoon as an ATCF b-deck (pressure, VMAX, RMW, POCI 1010 hPa; no radii), read back."""
    tr = np.asarray(cyc.track)
    n = tr.shape[0]
    dp, rmax = float(cyc.pressure_deficit_hpa), float(cyc.rmax_km)  # the suite's cyclones have one value each
    vmax_kn = cyc.surface_factor * holland_vmax_ms(dp, cyc.holland_b) * 3600.0 / 1852.0
    track = CycloneTrack(
        time=t0 + (tr[:, 0] * 3600).astype("timedelta64[s]"),
        lat_deg=tr[:, 1], lon_deg=tr[:, 2], vmax_kn=np.full(n, vmax_kn), pressure_hpa=np.full(n, 1010.0 - dp),
        r34_nm=np.full((n, 4), np.nan), r50_nm=np.full((n, 4), np.nan), r64_nm=np.full((n, 4), np.nan),
        rmax_nm=np.full(n, rmax / 1.852), env_pressure_hpa=np.full(n, 1010.0), lead_h=np.zeros(n),
        name=cyc.name.upper(),
    )  # fmt: skip
    write_atcf(track, path)
    return read_atcf(path)


def _geometry(kind: str, rng: np.random.Generator) -> tuple[float, float, float, float, float, float]:
    """(typhoon course, ship course, lag [h], offset [nm], advance [kn], turn [deg]) for one kind."""
    course = float(rng.uniform(275.0, 325.0))
    advance = float(rng.uniform(7.0, 18.0))
    turn, lag, offset = 0.0, 0.0, 0.0
    rel = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(60.0, 120.0))  # crossing angle, either side
    if kind == "ahead":
        lag = -float(rng.uniform(6.0, 18.0))
    elif kind == "behind":
        lag = float(rng.uniform(6.0, 18.0))
    elif kind == "head-on":
        rel, offset, advance = 180.0 + 0.25 * rel, float(rng.uniform(-100.0, 100.0)), float(rng.uniform(5.0, 15.0))
    elif kind.startswith("overtaking"):
        rel, offset = 0.25 * rel, float(rng.uniform(-80.0, 80.0))
        advance = float(rng.uniform(20.0, 25.0)) if "typhoon" in kind else advance
    elif kind == "recurving":
        course, turn, lag = float(rng.uniform(300.0, 320.0)), float(rng.uniform(60.0, 100.0)), float(rng.uniform(-6, 6))
    elif kind == "antimeridian":
        lag = float(rng.uniform(-6.0, 6.0))
    elif kind != "on the route":
        raise ValueError(kind)
    return course, course - rel, lag, offset, advance, turn


def _draw(kind: str, index: int, rng: np.random.Generator) -> CrossingCase:
    ship = str(rng.choice(sorted(SHIPS)))
    speed = float(round(rng.uniform(*SHIPS[ship]) * 2.0) / 2.0)
    course, ship_course, lag, offset, advance, turn = _geometry(kind, rng)
    if kind == "overtaking (ship faster)":
        advance = float(rng.uniform(0.3, 0.45)) * speed
    length = float(rng.uniform(600.0, 900.0))
    frac = float(rng.uniform(0.4, 0.6))
    p = (float(rng.uniform(14.0, 26.0)), 180.0 if kind == "antimeridian" else float(rng.uniform(128.0, 150.0)))
    start = tuple(float(v) for v in geo.destination(*p, ship_course + 180.0, frac * length))
    end = tuple(float(v) for v in geo.destination(*p, ship_course, (1.0 - frac) * length))
    side = tuple(float(v) for v in geo.destination(*p, ship_course + 90.0, offset)) if offset else p
    departure = np.datetime64("2024-08-01T00:00", "ns") + np.timedelta64(int(rng.integers(0, 60)) * 6, "h")
    dur = 3.0 * math.ceil((6.0 + 2.5 * length / speed) / 3.0)
    t_pass = 6.0 + frac * length / speed + lag
    turn_h = t_pass + float(rng.uniform(-18.0, 6.0))
    dp, rmax = float(rng.uniform(30.0, 60.0)), float(rng.uniform(25.0, 50.0))
    cyc = Cyclone(track=track_through(side, t_pass, course, advance, turn, turn_h, dur), pressure_deficit_hpa=dp,
                  rmax_km=rmax, holland_b=1.3, name=f"suite-{index:02d}")  # fmt: skip
    return CrossingCase(f"{index:02d} {kind}", kind, ship, speed, start, end, departure, cyc, advance, math.nan, lag,
                        offset, turn)  # fmt: skip


def _clear(case: CrossingCase, track: CycloneTrack) -> bool:
    """Start clear of R + 80 km at departure, the destination clear while the ship could be arriving (0.8–1.6 passages)."""
    t_go = case.departure + np.arange(0, 4) * np.timedelta64(1, "h")
    t_end = case.t0 + ((6.0 + np.arange(0.8, 1.6, 0.02) * case.length_nm / case.speed_kn) * 3600).astype(
        "timedelta64[s]"
    )
    for (lat, lon), times in ((case.start, t_go), (case.end, t_end)):
        s = track.at(times)
        d_km = np.asarray(geo.distance_nm(lat, lon, s["lat"], s["lon"])) * 1.852
        if np.any(d_km < s["r7_km"] + 80.0):
            return False
    return True


def suite(n: int, seed: int = SEED) -> list[tuple[CrossingCase, CycloneTrack]]:
    """The first ``n`` cases of the suite (kinds in :data:`KINDS` order), each with its read-back track."""
    if not 1 <= n <= len(KINDS):
        raise ValueError(f"n={n} cases: the suite has 1 to {len(KINDS)}")
    rng = np.random.default_rng(seed)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, kind in enumerate(KINDS[:n]):
            for _ in range(200):
                case = _draw(kind, i + 1, rng)
                track = b_deck(case.cyclone, case.t0, Path(tmp) / f"bwp{i + 1:02d}2024.dat")
                if _clear(case, track):
                    break
            else:
                raise RuntimeError(f"no clear draw for case {i + 1} ({kind}) in 200 tries")
            r7 = float(np.median(track.r7_km))
            out.append((_with(case, r7_km=r7), track))
    return out


def _with(case: CrossingCase, **kw: Any) -> CrossingCase:
    from dataclasses import replace

    return replace(case, **kw)


def weather(case: CrossingCase, resolution_deg: float) -> Any:
    """The case's weather: the typhoon over the background sea, on a box 6° around the passage."""
    lats = [case.start[0], case.end[0]]
    lons = geo.unwrap_lon_deg(np.array([case.start[1], case.end[1]]))
    mid = geo.intermediate_points(*case.start, *case.end, np.array([0.5]))
    lat_lo, lat_hi = min(*lats, float(mid[0][0])) - 6.0, max(*lats, float(mid[0][0])) + 6.0
    lon_lo, lon_hi = float(lons.min()) - 6.0, float(lons.max()) + 6.0
    r = resolution_deg
    bbox = (math.floor(lat_lo / r) * r, math.ceil(lat_hi / r) * r,
            float(units.wrap_180(math.floor(lon_lo / r) * r)), float(units.wrap_180(math.ceil(lon_hi / r) * r)))  # fmt: skip
    ds = tropical_cyclone(case.cyclone, start=case.t0, duration_h=case.duration_h, step_h=3.0, resolution_deg=r,
                          bbox=bbox)  # fmt: skip
    ds.attrs["geography"] = "synthetic"
    return ds


def brute_force(plan: Any, track: CycloneTrack, margin_km: float = 30.0, step_nm: float = 1.0) -> dict[str, float]:
    """Closest approaches and hours inside R / R + margin, by points every ``step_nm`` along the plan's legs.

    Independent of the planners' checks: positions on each leg's great circle
    (:func:`optroute.geodesy.intermediate_points`), the time linear along the leg, the centre and R
    interpolated in time from the track (:meth:`CycloneTrack.at`).  Hours inside are summed over
    the sample intervals whose midpoint is inside.
    """
    wp = plan.waypoints
    th = (plan.times - plan.times[0]) / np.timedelta64(1, "h")
    lats, lons, hours = [], [], []
    for k in range(wp.shape[0] - 1):
        d = float(geo.distance_nm(*wp[k], *wp[k + 1]))
        f = np.linspace(0.0, 1.0, max(2, int(d / step_nm) + 1))
        la, lo = geo.intermediate_points(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1], f)
        lats.append(np.atleast_1d(la)), lons.append(np.atleast_1d(lo)), hours.append(th[k] + f * (th[k + 1] - th[k]))
    la, lo, h = (np.concatenate(a) for a in (lats, lons, hours))
    s = track.at(plan.times[0] + (h * 3600.0).astype("timedelta64[s]"))
    dist = np.asarray(geo.distance_nm(la, lo, s["lat"], s["lon"])) * 1.852
    gap = dist - s["r7_km"]
    mid_gap = 0.5 * (gap[1:] + gap[:-1])
    dh = np.diff(h)
    return {
        "closest_centre_km": float(dist.min()),
        "closest_r_km": float(gap.min()),
        "closest_safe_km": float(gap.min() - margin_km),
        "inside_r_h": float(np.sum(dh * (mid_gap < 0.0))),
        "inside_safe_h": float(np.sum(dh * (mid_gap < margin_km))),
    }
