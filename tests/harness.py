"""Random-scenario harness (issue 14 item 7): seeded cases, and an independent check of every plan.

A *case* is drawn from its seed alone (:func:`make_case`): a short corridor (200–360 nm, 0–40 nm
wide) in the North Atlantic under one moving storm (:func:`optroute.scenarios.moving_storm`: waves
turning through 180° across its centre, peak Hs 7–14 m) or in the Philippine Sea under a tropical
cyclone (:func:`optroute.weather.cyclone.tropical_cyclone`, Holland 1980 winds, fetch-limited
waves), one of the built-in ships, and an ETA 5–50 % above the minimum time.  :func:`run_case`
solves it as a user would — minimum time, then least fuel with that ETA — and checks every plan
returned with :func:`check_plan`.

:func:`check_plan` is written independently of the plan's referee (``optroute/plan/evaluate.py``):

* the track is walked by brute force every ``step_nm`` (0.1 nm) along each leg's WGS84 geodesic
  (pyproj's ``Geod`` directly), at the time the plan's speed over ground puts the ship there;
* the weather is sampled directly from the dataset with xarray's own multilinear ``interp``
  (wave direction as unit vectors), not through :class:`optroute.weather.WeatherSampler`;
* the four danger bands are recomputed from their definitions (Boeing EP 2145155, ±20 % bands
  on T_E/T_R about 1 and 0.5, on V cos χ / c and V cos χ / c_g about 1, applied where
  Hs >= 0.04 L; encounter period of IMO MSC.1/Circ.1228 with g/2π exact); a band entered for
  0.1 nm or more is a violation (two consecutive samples, or a single sample whose stretch inside the band,
  walked every 0.001 nm between its neighbours, is 0.1 nm or longer), a shorter one a *graze*;
* power and fuel rate come from the ship's own performance model (one model, stated once) by its
  vectorised numpy path, and the fuel is integrated over the 0.1 nm samples (trapezoids in time);
* MCR and the engine's minimum load (power above or under it for 0.1 nm or more), the ETA (the arrival sailed on the ellipsoid at the
  plan's speeds), the schedule (leg duration = geodesic length / SOG) and the fuel accounting
  (legs sum to the total; the total within 1 % of the brute-force integral — the referee integrates
  every leg adaptively to about 0.1 % (:mod:`optroute.plan.evaluate`), Kwon's power being a step
  function of the Beaufort number and the wave sector; its 5 nm midpoints alone were 1–2 % off)
  are checked too.

The harness lives in ``tests/`` (not in the installed package): it is verification code whose
value is its independence from the referee, and ``benchmarks/bench_harness.py`` runs its large
sample from here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from pyproj import Geod

import optroute as orx
from optroute.errors import InfeasibleETA, NoSafePassage, OptrouteError, SolverFailure
from optroute.physics.passage import SeaState, evaluate_speeds
from optroute.physics.performance import KwonModel
from optroute.physics.safety import DEFAULT_RULES

__all__ = [
    "Case",
    "CaseResult",
    "Finding",
    "band_ratios",
    "case_weather",
    "centreline_passage",
    "check_plan",
    "corridor_passage",
    "decide_by_brute_force",
    "make_case",
    "passage_plan",
    "run_case",
    "summarise",
]

WGS84 = Geod(ellps="WGS84")
G_MS2 = 9.80665
KN = 1852.0 / 3600.0  # m/s per knot
K_KN_S = G_MS2 / (2.0 * math.pi) / KN  # g/2π in kn/s (3.0339)
SHIPS = ("container_54k_dwt", "container_8000teu", "general_cargo_25k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")


@dataclass(frozen=True)
class Case:
    """One random case; everything follows from ``seed``.

    Attributes
    ----------
    seed : int
    kind : {"storm", "cyclone"}
    ship : str
        A :meth:`optroute.Ship.preset` name.
    waypoints : tuple of (lat, lon)
        The corridor's centreline [deg].
    width_nm : float
        Corridor width [nm] (0: a fixed path).
    eta_factor : float
        ETA of the fuel solve = departure + factor × the minimum time [-].
    weather : dict
        Keyword arguments of the scenario function.
    """

    seed: int
    kind: str
    ship: str
    waypoints: tuple[tuple[float, float], ...]
    width_nm: float
    eta_factor: float
    weather: dict[str, Any] = field(hash=False)


@dataclass(frozen=True)
class Finding:
    """A constraint the independent check found broken: ``kind`` on ``leg`` at ``position``, ``value`` vs ``limit``."""

    kind: str
    leg: int
    position: tuple[float, float]
    value: float
    limit: float
    length_nm: float = 0.0

    def __str__(self) -> str:
        return (
            f"{self.kind} on leg {self.leg} at ({self.position[0]:.3f}, {self.position[1]:.3f}): {self.value:.6g} "
            f"against {self.limit:.6g}" + (f" over {self.length_nm:.2f} nm" if self.length_nm else "")
        )


@dataclass
class CaseResult:
    """What a case gave: each solve's outcome (``plan:<status>``, or the error's class name), the findings of
    :func:`check_plan`, and the number of violations the plan's own ``verify()`` reports (``referee``)."""

    case: Case
    outcomes: dict[str, str] = field(default_factory=dict)
    findings: dict[str, list[Finding]] = field(default_factory=dict)
    grazes: dict[str, int] = field(default_factory=dict)
    messages: dict[str, str] = field(default_factory=dict)
    referee: dict[str, int] = field(default_factory=dict)
    first_solve: dict[str, str] = field(default_factory=dict)
    # per plan: how many NLP samples its first verified start broke the NLP's bands at (the optimiser's record)
    start_in_bands: dict[str, dict[str, int] | None] = field(default_factory=dict)
    feasible: bool = False
    cpu_s: float = 0.0
    # a minimum-time SolverFailure without any plan, decided by :func:`decide_by_brute_force`: the arrival [h] of the
    # brute force's passage whose plan verify() and check_plan pass, None where its lattice found none (undecided)
    brute_force_h: float | None = None
    # that passage's verify() violations with its departure shifted [min -> count] (:func:`timing_margin`)
    brute_force_margin: dict[int, int] | None = None
    # per verified plan returned: its verify() violations with the departure a minute late
    margins: dict[str, dict[int, int]] = field(default_factory=dict)
    timing_cpu_s: float = 0.0  # the CPU of those re-judgements [s], not in cpu_s
    # per plan returned: the NLP model's fuel against the referee's, relative [-], at the NLP's warm start and at its
    # solution (``solver_stats["start_tabulation"]`` / ``["tabulation"]``; NaN where the call did not record one)
    tabulation: dict[str, tuple[float, float]] = field(default_factory=dict)


# --------------------------------------------------------------------------- the generator


def _geodesic_end(lat: float, lon: float, course: float, dist_nm: float) -> tuple[float, float]:
    lon2, lat2, _ = WGS84.fwd(lon, lat, course, dist_nm * 1852.0)
    return float(lat2), float(lon2)


def _open_water_leg(rng, length, width, lat_range, lon_range, draw_course):
    """A corridor start, course and end whose whole width (plus 15 nm) is at sea (GLOBE land mask), redrawn until so."""
    from optroute.geo.land import is_land

    for _ in range(200):
        a = (float(rng.uniform(*lat_range)), float(rng.uniform(*lon_range)))
        course = float(draw_course())
        b = _geodesic_end(*a, course, length)
        n = int(length / 5.0) + 2
        s = np.linspace(0.0, length, n) * 1852.0
        lon, lat, back = WGS84.fwd(np.full(n, a[1]), np.full(n, a[0]), np.full(n, course), s)
        ok = True
        for off in (-(0.5 * width + 15.0), 0.0, 0.5 * width + 15.0):
            lo2, la2, _ = WGS84.fwd(lon, lat, (np.asarray(back) + 180.0 + 90.0) % 360.0, np.full(n, off * 1852.0))
            ok &= not bool(np.any(is_land(np.asarray(la2), np.asarray(lo2))))
        if ok:
            return a, course, b
    raise RuntimeError("no open-water corridor drawn in 200 tries")


def make_case(seed: int) -> Case:
    """The case of ``seed`` (even seeds: a moving storm, odd: a tropical cyclone)."""
    rng = np.random.default_rng(seed)
    kind = "storm" if seed % 2 == 0 else "cyclone"
    ship = str(rng.choice(SHIPS))
    length = float(rng.uniform(200.0, 360.0))
    width = float(rng.choice([0.0, 20.0, 40.0]))
    eta_factor = float(rng.uniform(1.05, 1.5))
    if kind == "storm":
        a, course, b = _open_water_leg(
            rng,
            length,
            width,
            (36.0, 48.0),
            (-45.0, -25.0),
            lambda: rng.choice([rng.uniform(50.0, 130.0), rng.uniform(230.0, 310.0)]),
        )
        mid = _geodesic_end(*a, course, 0.5 * length)
        t_mid = 0.5 * length / 18.0  # the storm meets the corridor's middle about when a ship would
        off = float(rng.uniform(-120.0, 120.0))
        centre_mid = _geodesic_end(*mid, course + 90.0, off)
        s_course, s_speed = float(rng.uniform(0.0, 360.0)), float(rng.uniform(8.0, 30.0))
        c0 = _geodesic_end(*centre_mid, s_course + 180.0, s_speed * t_mid)
        lats, lons = [a[0], b[0]], [a[1], b[1]]
        bbox = (min(lats) - 3.0, max(lats) + 3.0, min(lons) - 4.0, max(lons) + 4.0)
        weather = {
            "lat_deg": c0[0],
            "lon_deg": c0[1],
            "course_deg": s_course,
            "speed_kn": s_speed,
            "peak_hs_m": float(rng.uniform(7.0, 14.0)),
            "radius_nm": float(rng.uniform(80.0, 200.0)),
            "start": str(T0),
            "duration_h": 60.0,
            "step_h": 3.0,
            "resolution_deg": 0.5,
            "bbox": bbox,
            "background_hs_m": float(rng.uniform(1.0, 3.0)),
            "background_from_deg": float(rng.uniform(0.0, 360.0)),
        }
    else:
        a, course, b = _open_water_leg(
            rng, length, width, (12.0, 24.0), (126.0, 134.0), lambda: rng.uniform(20.0, 100.0)
        )
        mid = _geodesic_end(*a, course, 0.5 * length)
        off = float(rng.uniform(-150.0, 150.0))
        centre_mid = _geodesic_end(*mid, course + 90.0, off)
        c_course, c_speed = float(rng.uniform(270.0, 360.0)), float(rng.uniform(6.0, 16.0))
        t_mid = 0.5 * length / 18.0
        c0 = _geodesic_end(*centre_mid, c_course + 180.0, c_speed * t_mid)
        weather = {
            "track": (c0[0], c0[1], c_course, c_speed),
            "pressure_deficit_hpa": float(rng.uniform(30.0, 70.0)),
            "rmax_km": float(rng.uniform(30.0, 60.0)),
            "holland_b": float(rng.uniform(1.2, 1.5)),
            "start": str(T0),
            "duration_h": 60.0,
            "step_h": 3.0,
            "resolution_deg": 0.25,
            "bbox": (min(a[0], b[0]) - 3.0, max(a[0], b[0]) + 3.0, min(a[1], b[1]) - 3.0, max(a[1], b[1]) + 3.0),
        }
    return Case(seed, kind, ship, (a, b), width, eta_factor, weather)


def case_weather(case: Case) -> xr.Dataset:
    """The case's weather dataset (in memory)."""
    w = dict(case.weather)
    if case.kind == "storm":
        return orx.scenarios.moving_storm(**w)
    from optroute.weather.cyclone import Cyclone, straight_track, tropical_cyclone

    lat, lon, course, speed = w.pop("track")
    cyc = Cyclone(
        track=straight_track(lat, lon, course, speed, duration_h=w["duration_h"], step_h=6.0),
        pressure_deficit_hpa=w.pop("pressure_deficit_hpa"),
        rmax_km=w.pop("rmax_km"),
        holland_b=w.pop("holland_b"),
        name=f"harness cyclone {case.seed}",
    )
    return tropical_cyclone(cyc, **w)


# --------------------------------------------------------------------------- the independent check


def _sample(ds: xr.Dataset, t: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> dict[str, np.ndarray]:
    """Multilinear interpolation in (time, lat, lon) by xarray; the wave direction as unit vectors."""
    rad = np.radians(ds["wave_from_deg"])
    fields = xr.Dataset(
        {
            "hs_m": ds["hs_m"],
            "tp_s": ds["tp_s"] if "tp_s" in ds else ds["tm_s"],
            "dir_s": np.sin(rad),
            "dir_c": np.cos(rad),
            **{k: ds[k] for k in ("wind_u_ms", "wind_v_ms") if k in ds},
        }
    )
    p = "points"
    out = fields.interp(
        time=xr.DataArray(t, dims=p), lat=xr.DataArray(lat, dims=p), lon=xr.DataArray(lon, dims=p), method="linear"
    )
    res = {k: np.asarray(out[k].values, dtype=float) for k in out.data_vars}
    res["wave_from_deg"] = np.degrees(np.arctan2(res.pop("dir_s"), res.pop("dir_c"))) % 360.0
    return res


def band_ratios(ship: orx.Ship, stw_kn, hs_m, period_s, wave_from_deg, heading_deg) -> dict[str, np.ndarray]:
    """The four Boeing EP 2145155 ratios from their definitions; NaN where Hs < 0.04 L (the band does not apply).

    α = wave_from − heading (0 head seas, IMO MSC.1/Circ.1228); u = −V cos α, the ship's speed along the
    waves' propagation [kn]; c = (g/2π) T the deep-water phase speed [kn], c_g = c/2;
    T_E = T² (g/2π) / |(g/2π) T + V cos α| [s].
    """
    cos_a = np.cos(np.radians(np.asarray(wave_from_deg) - np.asarray(heading_deg)))
    v = np.asarray(stw_kn, dtype=float)
    t = np.asarray(period_s, dtype=float)
    c = K_KN_S * t
    with np.errstate(divide="ignore", invalid="ignore"):
        t_e = t * c / np.abs(c + v * cos_a)
    u = -v * cos_a
    on = np.asarray(hs_m) >= 0.04 * ship.length_m
    nan = np.full(np.broadcast(v, t, cos_a).shape, np.nan)
    return {
        "synchronous_roll": np.where(on, t_e / ship.roll_period_s, nan),
        "parametric_roll": np.where(on, t_e / ship.roll_period_s, nan),
        "surf_riding": np.where(on, u / c, nan),
        "high_wave_attack": np.where(on, u / (0.5 * c), nan),
    }


BAND_RANGES = {
    "synchronous_roll": (0.8, 1.2),
    "parametric_roll": (0.4, 0.6),
    "surf_riding": (0.8, 1.2),
    "high_wave_attack": (0.8, 1.2),
}


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs [i, j] (inclusive) of True."""
    if not flag.any():
        return []
    d = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1, strict=True))


class _LegSampler:
    """One leg of a plan sampled at distances along its WGS84 geodesic: position, time, weather and band ratios.

    :meth:`run_length` measures a band entered at a single sample of the 0.1 nm walk: an excursion of 0.1–0.2 nm
    can hold one sample only (harness seed 53: a centreline passage inside the parametric-roll band for 0.143 nm
    between two 0.1 nm samples, found by the referee and counted here as a graze).
    """

    def __init__(self, weather: xr.Dataset, ship: orx.Ship, start, az: float, t0, stw_kn: float, sog_kn: float):
        self.weather, self.ship, self.start, self.az = weather, ship, start, az
        self.t0, self.stw_kn, self.sog_kn = t0, stw_kn, sog_kn

    def __call__(self, s_nm: np.ndarray):
        """(lat, lon, course, hours into the leg, weather, band ratios) at ``s_nm`` [nm along the leg]."""
        n = s_nm.size
        lon, lat, back = WGS84.fwd(
            np.full(n, self.start[1]), np.full(n, self.start[0]), np.full(n, self.az), s_nm * 1852.0
        )
        course = (np.asarray(back) + 180.0) % 360.0
        t_h = s_nm / self.sog_kn
        when = self.t0 + (t_h * 3.6e12).astype("timedelta64[ns]")
        w = _sample(self.weather, when, np.asarray(lat), np.asarray(lon))
        ratios = band_ratios(self.ship, self.stw_kn, w["hs_m"], w["tp_s"], w["wave_from_deg"], course)
        return np.asarray(lat), np.asarray(lon), course, t_h, w, ratios

    def run_length(self, band: str, s_nm: np.ndarray, i: int, fine_nm: float = 0.001) -> float:
        """Length [nm] of the stretch around sample ``i`` inside ``band``, walked every ``fine_nm`` between the
        samples either side of it (both outside the band)."""
        a, b = s_nm[max(i - 1, 0)], s_nm[min(i + 1, s_nm.size - 1)]
        fine = np.linspace(a, b, max(3, int(math.ceil((b - a) / fine_nm)) + 1))
        r = self(fine)[5][band]
        lo, hi = BAND_RANGES[band]
        return float(np.count_nonzero((r > lo) & (r < hi)) * (fine[1] - fine[0]))


def check_plan(
    plan: orx.Plan,
    weather: xr.Dataset,
    ship: orx.Ship,
    *,
    eta: np.datetime64 | None = None,
    step_nm: float = 0.1,
    fuel_rtol: float = 0.01,
) -> tuple[list[Finding], int]:
    """Check a plan by brute force, independently of its referee (module docstring).

    Returns
    -------
    findings : list of Finding
        Violations: ``band:<name>``, ``mcr`` and ``min_load`` (power under the engine's minimum load) held for
        ``step_nm`` or more, ``eta``, ``schedule``,
        ``fuel`` (accounting).
    grazes : int
        Single samples inside a band (entered for less than ``step_nm``).
    """
    legs = plan.legs
    wp = np.asarray(plan.waypoints, dtype=float)
    stw = legs["stw_kn"].to_numpy(dtype=float)
    sog = legs["sog_kn"].to_numpy(dtype=float)
    t_leg = np.asarray(legs["time"].to_numpy(), dtype="datetime64[ns]")
    dur_h = legs["duration_h"].to_numpy(dtype=float)
    fuel_leg = legs["fuel_t"].to_numpy(dtype=float)
    model = KwonModel(ship)
    findings: list[Finding] = []
    grazes = 0
    sailed_h = brute_total = 0.0
    for k in range(len(stw)):
        az, _, d_m = WGS84.inv(wp[k, 1], wp[k, 0], wp[k + 1, 1], wp[k + 1, 0])
        d_nm = d_m / 1852.0
        if abs(d_nm / sog[k] - dur_h[k]) > 1e-6 * max(1.0, dur_h[k]):
            findings.append(Finding("schedule", k, tuple(wp[k]), d_nm / sog[k], dur_h[k]))
        sailed_h += d_nm / sog[k]
        n = max(2, int(math.ceil(d_nm / step_nm)) + 1)
        s_nm = np.linspace(0.0, d_nm, n)
        leg_at = _LegSampler(weather, ship, wp[k], az, t_leg[k], stw[k], sog[k])
        lat, lon, course, t_h, w, ratios = leg_at(s_nm)
        for band, (lo, hi) in BAND_RANGES.items():
            r = ratios[band]
            inside = (r > lo) & (r < hi)
            for i, j in _runs(inside):
                length = float(s_nm[j] - s_nm[i]) if j > i else leg_at.run_length(band, s_nm, i)
                if j > i or length >= step_nm:  # inside for step_nm or more
                    seg = r[i : j + 1]
                    q = i + int(np.argmax(np.minimum(seg - lo, hi - seg)))  # the deepest sample
                    edge = lo if r[q] - lo < hi - r[q] else hi
                    pos = (float(lat[q]), float(lon[q]))
                    findings.append(Finding(f"band:{band}", k, pos, float(r[q]), edge, length))
                else:
                    grazes += 1
        sea = SeaState.from_sample(w)
        _, _, power, fuel_tph, _ = evaluate_speeds(
            ship, model, DEFAULT_RULES, course, sea, np.full(n, stw[k]), engine="numpy"
        )
        over = power > ship.mcr_kw * (1.0 + 1e-6)
        for i, j in _runs(over):
            if j > i:
                pos = (float(lat[i]), float(lon[i]))
                findings.append(Finding("mcr", k, pos, float(power[i : j + 1].max()), ship.mcr_kw, s_nm[j] - s_nm[i]))
        under = power < model.min_power_kw * (1.0 - 1e-6)
        for i, j in _runs(under):
            if j > i:
                pos = (float(lat[i]), float(lon[i]))
                lim = model.min_power_kw
                findings.append(Finding("min_load", k, pos, float(power[i : j + 1].min()), lim, s_nm[j] - s_nm[i]))
        brute_total += float(np.sum(0.5 * (fuel_tph[1:] + fuel_tph[:-1]) * np.diff(t_h)))
    if not abs(brute_total - plan.total_fuel_t) <= fuel_rtol * max(brute_total, 1e-3):
        findings.append(Finding("fuel", -1, tuple(wp[-1]), plan.total_fuel_t, brute_total))
    if abs(float(np.sum(fuel_leg)) - plan.total_fuel_t) > 1e-9 * max(1.0, plan.total_fuel_t):
        findings.append(Finding("fuel_total", -1, tuple(wp[-1]), float(np.sum(fuel_leg)), plan.total_fuel_t))
    if eta is not None:
        arrival_h = float((plan.departure - np.datetime64(eta, "ns")) / np.timedelta64(1, "h")) + sailed_h
        if arrival_h > 1.0 / 3600.0:
            findings.append(Finding("eta", len(stw) - 1, tuple(wp[-1]), arrival_h, 0.0))
    return findings, grazes


def _allowed(weather, ship, model, t_h: np.ndarray, speeds: np.ndarray, points: tuple, end_h: float) -> np.ndarray:
    """Whether each (state, speed, point) is allowed: inside the weather's span, outside every band, within the
    engine's range [minimum load, MCR]. ``t_h`` (states, speeds, points) [h]; ``speeds`` [kn]; ``points`` = (lat, lon,
    heading) [deg] along the segment."""
    shape, inside = t_h.shape, t_h <= end_h
    when = T0 + (np.minimum(t_h, end_h).ravel() * 3.6e12).astype("timedelta64[ns]")
    flat = [np.broadcast_to(np.asarray(a)[None, None, :], shape).ravel() for a in points]
    v = np.broadcast_to(speeds[None, :, None], shape).ravel()
    w = _sample(weather, when, flat[0], flat[1])
    ratios = band_ratios(ship, v, w["hs_m"], w["tp_s"], w["wave_from_deg"], flat[2])
    good = inside.ravel().copy()
    for band, (lo, hi) in BAND_RANGES.items():
        good &= ~((ratios[band] > lo) & (ratios[band] < hi))
    power = evaluate_speeds(ship, model, DEFAULT_RULES, flat[2], SeaState.from_sample(w), v, engine="numpy")[2]
    good &= (power <= ship.mcr_kw * (1.0 + 1e-6)) & (power >= model.min_power_kw * (1.0 - 1e-6))
    return good.reshape(shape)


def centreline_passage(
    case: Case,
    weather: xr.Dataset,
    ship: orx.Ship,
    *,
    block_nm: float = 10.0,
    speed_step_kn: float = 0.5,
    bucket_h: float = 0.5,
    step_nm: float = 0.5,
    v_min_kn: float = 3.0,
) -> tuple[float, np.ndarray] | None:
    """The earliest passage along the case's centreline by brute force, independently of the optimiser.

    The centreline (the WGS84 geodesic between the case's ends) is cut into blocks of at most ``block_nm``, each
    sailed at one speed through water from a ladder (``v_min_kn`` to the ship's top calm-water speed, every
    ``speed_step_kn``); a block at a speed entered at a time is allowed when every point ``step_nm`` apart (ends
    included), at the time the ship is there, is outside every band (:func:`band_ratios`, strictly inside a band
    range is out), within the engine's range [minimum load, MCR] and inside the weather's time span. Every arrival
    time at a block end is kept, one per ``bucket_h`` (the earliest). None: no passage on that lattice (a statement
    about the lattice only); else (arrival [h after departure], the block speeds [kn]). :func:`corridor_passage` on
    its one lane.
    """
    found = corridor_passage(
        case, weather, ship, block_nm=block_nm, lanes=0, speed_step_kn=speed_step_kn, bucket_h=bucket_h,
        step_nm=step_nm, v_min_kn=v_min_kn,
    )  # fmt: skip
    return None if found is None else (found[0], found[2])


def _station_points(case: Case, edges_nm: np.ndarray, offsets_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lat, lon) [deg] of each station (``edges_nm`` along the centreline geodesic) and lateral offset [nm, to
    starboard of the centreline's course positive], each (stations, offsets); the ends are the case's end points."""
    (lat0, lon0), (lat1, lon1) = case.waypoints
    az, _, _ = WGS84.inv(lon0, lat0, lon1, lat1)
    n = edges_nm.size
    clon, clat, cbaz = WGS84.fwd(np.full(n, lon0), np.full(n, lat0), np.full(n, az), edges_nm * 1852.0)
    normal = (np.asarray(cbaz) + 270.0) % 360.0  # the course + 90°
    lat, lon = np.empty((n, offsets_nm.size)), np.empty((n, offsets_nm.size))
    for k, y in enumerate(offsets_nm):
        lon[:, k], lat[:, k], _ = WGS84.fwd(clon, clat, normal, np.full(n, y * 1852.0))
    lat[0], lon[0], lat[-1], lon[-1] = lat0, lon0, lat1, lon1
    return lat, lon


def corridor_passage(
    case: Case,
    weather: xr.Dataset,
    ship: orx.Ship,
    *,
    block_nm: float = 5.0,
    lanes: int = 2,
    max_shift: int = 1,
    inside: float = 0.98,
    speed_step_kn: float = 0.5,
    bucket_h: float = 0.5,
    step_nm: float = 0.5,
    v_min_kn: float = 3.0,
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """The earliest passage through the case's corridor by brute force, across its width, independently of the
    optimiser (on one lane, ``lanes=0``, along the centreline: :func:`centreline_passage`).

    Stations every ``block_nm`` at most along the centreline carry ``2 lanes + 1`` lateral positions spread over
    ``inside`` of the corridor's width; a block joins a position to one at most ``max_shift`` lanes aside by the
    WGS84 geodesic between them, sailed at one speed through water from the ladder, and is allowed when every point
    ``step_nm`` apart (ends included) is, as in :func:`centreline_passage` (bands, engine range, weather span). The
    earliest arrival per lane and ``bucket_h`` is kept. None: no passage on that lattice (a statement about the
    lattice only); else (arrival [h after departure], waypoints (n, 2) [deg], the block speeds [kn]).
    """
    (lat0, lon0), (lat1, lon1) = case.waypoints
    d_nm = WGS84.inv(lon0, lat0, lon1, lat1)[2] / 1852.0
    edges = np.linspace(0.0, d_nm, int(math.ceil(d_nm / block_nm)) + 1)
    offsets = np.linspace(-1.0, 1.0, 2 * lanes + 1) * 0.5 * case.width_nm * inside
    plat, plon = _station_points(case, edges, offsets)
    speeds = np.unique(np.append(np.arange(v_min_kn, ship.max_calm_speed_kn, speed_step_kn), ship.max_calm_speed_kn))
    end_h = float((weather["time"].values[-1] - T0) / np.timedelta64(1, "h"))
    model = KwonModel(ship)
    states, back = {lanes: np.zeros(1)}, []  # lane -> arrival times [h]; per block, lane -> (lane, state, speed)
    for b in range(edges.size - 1):
        reached: dict[int, list] = {}
        for i, times in states.items():
            for j in range(max(0, i - max_shift), min(offsets.size, i + max_shift + 1)):
                az, _, seg_m = WGS84.inv(plon[b, i], plat[b, i], plon[b + 1, j], plat[b + 1, j])
                s_nm = np.linspace(0.0, seg_m / 1852.0, max(2, int(math.ceil(seg_m / 1852.0 / step_nm)) + 1))
                n = s_nm.size
                lon, lat, baz = WGS84.fwd(np.full(n, plon[b, i]), np.full(n, plat[b, i]), np.full(n, az), s_nm * 1852.0)
                t_h = times[:, None, None] + s_nm[None, None, :] / speeds[None, :, None]
                good = _allowed(weather, ship, model, t_h, speeds, (lat, lon, (np.asarray(baz) + 180.0) % 360.0), end_h)
                prev, spd = np.nonzero(good.all(axis=2))
                if prev.size:
                    arrive = times[prev] + s_nm[-1] / speeds[spd]
                    reached.setdefault(j, []).append((arrive, np.full(prev.size, i), prev, spd))
        if not reached:
            return None
        states, back_b = {}, {}
        for j, parts in reached.items():
            arrive, lane, prev, spd = (np.concatenate(x) for x in zip(*parts, strict=True))
            bucket = np.floor(arrive / bucket_h)
            order = np.lexsort((arrive, bucket))
            keep = order[np.concatenate([[True], np.diff(bucket[order]) != 0])]
            states[j], back_b[j] = arrive[keep], (lane[keep], prev[keep], spd[keep])
        back.append(back_b)
    lane = min(states, key=lambda k: float(states[k].min()))
    state = int(np.argmin(states[lane]))
    arrival, wp, stw = float(states[lane][state]), [(plat[-1, lane], plon[-1, lane])], []
    for b in range(len(back) - 1, -1, -1):
        prev_lane, prev, spd = (a[state] for a in back[b][lane])
        stw.append(speeds[spd])
        lane, state = int(prev_lane), int(prev)
        wp.append((plat[b, lane], plon[b, lane]))
    return arrival, np.array(wp[::-1]), np.array(stw[::-1])


def passage_plan(case: Case, weather: xr.Dataset, ship: orx.Ship, found: tuple) -> orx.Plan:
    """The plan of a :func:`corridor_passage` (its waypoints and block speeds) in the case's corridor, by the library's
    :meth:`optroute.Plan.from_schedule`, for :meth:`~optroute.Plan.verify` and :func:`check_plan` to judge."""
    corridor = orx.Corridor.from_waypoints(np.array(case.waypoints), width_nm=case.width_nm)
    return orx.Plan.from_schedule(
        found[1], found[2], departure=T0, ship=ship, weather=weather, corridor=corridor, use_land_mask=False
    )


#: Departure delays [min] at which :func:`timing_margin` re-judges a plan (the same waypoints and speeds). Only
#: delays: every case's weather begins at its departure, so an earlier one is a coverage violation, not a finding.
TIMING_SHIFTS_MIN = (1, 2, 5)


def timing_margin(plan: orx.Plan, shifts_min: tuple[int, ...] = TIMING_SHIFTS_MIN) -> dict[int, int]:
    """How many violations ``verify()`` finds in ``plan`` sailed with its departure shifted by each of ``shifts_min``
    [min]: the same waypoints and speeds through water, the same ship, model, rules, weather, corridor, exclusion
    and land check; no ETA (a later departure is late by its shift). Keyed by the shift.

    A plan whose safety depends on keeping its schedule to the minute through a storm's bands is one no ship can
    sail as planned: where leaving one minute late breaks it, the harness calls it a knife edge (:func:`knife_edge`).
    A brute-force passage that is one still makes its case feasible, and the case's SolverFailure still counts
    against the target; the count of knife edges is reported beside it, for the optimiser's plans as for the brute
    force's.
    """
    ctx = plan.context
    weather = ctx.dataset if ctx.dataset is not None else ctx.sampler
    out = {}
    for m in shifts_min:
        shifted = orx.Plan.from_schedule(
            plan.waypoints, plan.legs["stw_kn"].to_numpy(), departure=plan.departure + np.timedelta64(m * 60, "s"),
            ship=ctx.ship, weather=weather, model=ctx.model, rules=ctx.rules, corridor=ctx.corridor,
            exclusion=ctx.exclusion, use_land_mask=ctx.use_land_mask,
        )  # fmt: skip
        out[m] = len(shifted.verify())
    return out


def knife_edge(margin: dict[int, int] | None) -> bool:
    """Whether a :func:`timing_margin` shows the plan broken by a departure one minute late."""
    return margin is not None and margin.get(1, 0) > 0


# --------------------------------------------------------------------------- running a case


def _solve(
    res: CaseResult,
    name: str,
    corridor,
    wx,
    ship,
    *,
    eta=None,
    objective="fuel",
    max_leg_nm=50.0,
    rows=None,
    timing=False,
) -> orx.Plan | None:
    placement = {} if rows is None else {"constraint_rows": rows}
    try:
        plan = orx.optimise_corridor(
            corridor, wx, ship, departure=T0, eta=eta, objective=objective, max_leg_nm=max_leg_nm, **placement
        )
    except SolverFailure as exc:
        res.outcomes[name] = "SolverFailure"
        res.messages[name] = str(exc)[:300]
        best = getattr(exc, "best_plan", None)
        if best is not None:
            res.findings[name + ":best_plan"], res.grazes[name + ":best_plan"] = check_plan(best, wx, ship, eta=eta)
        return best
    except (InfeasibleETA, NoSafePassage) as exc:
        res.outcomes[name] = type(exc).__name__
        res.messages[name] = str(exc)[:300]
        return None
    except OptrouteError as exc:
        res.outcomes[name] = type(exc).__name__
        res.messages[name] = str(exc)[:300]
        return None
    res.outcomes[name] = f"plan:{plan.status}"
    res.findings[name], res.grazes[name] = check_plan(plan, wx, ship, eta=eta)
    res.referee[name] = len(plan.verify())  # the baseline: the plan's own referee at its default 5 nm
    if timing and res.referee[name] == 0:
        c0 = time.process_time()
        res.margins[name] = timing_margin(plan, (1,))
        res.timing_cpu_s += time.process_time() - c0
    res.first_solve[name] = str(plan.solver_stats.get("first_solve", "not recorded"))
    res.tabulation[name] = tuple(
        float(plan.solver_stats.get(key, {}).get("rel_error", np.nan)) for key in ("start_tabulation", "tabulation")
    )
    res.start_in_bands[name] = plan.solver_stats.get("verified_start_in_nlp_bands")
    return plan


def fuel_not_worse(plan: orx.Plan, verified: list[orx.Plan], eta, rtol: float = 1e-6) -> list[Finding]:
    """Issue 14 failure 5: a least-fuel plan is never worse than a verified plan that meets the same ETA.

    ``verified`` are plans the user already has from the same corridor (the minimum-time plan: the
    audit's case was a fuel plan of 300.4 t arriving 38 h later while the minimum-time plan met the
    ETA on 288.2 t); each that arrives by ``eta`` bounds the fuel plan's fuel (``rtol`` relative).
    Returns a ``fuel_worse`` finding per plan beaten, ``value`` the fuel plan's fuel and ``limit`` the other's [t].
    """
    out = []
    for other in verified:
        if other.arrival <= eta and plan.total_fuel_t > other.total_fuel_t * (1.0 + rtol):
            end = tuple(float(x) for x in np.asarray(plan.waypoints)[-1])
            out.append(Finding("fuel_worse", -1, end, plan.total_fuel_t, other.total_fuel_t))
    return out


def run_case(
    case: Case, *, max_leg_nm: float = 50.0, constraint_rows: str | None = None, timing: bool = False
) -> CaseResult:
    """Minimum time, then least fuel with the case's ETA; every plan checked (:func:`check_plan`).

    A case is *feasible* when a verified plan exists: the minimum-time plan, or a SolverFailure's
    ``best_plan``.  An :class:`InfeasibleETA` of the fuel solve is then itself a finding
    (``honest_eta``): the minimum-time plan meets that ETA; so is a fuel plan using more fuel than
    the minimum-time plan when that one passed the check (``fuel_worse``, :func:`fuel_not_worse`).
    ``constraint_rows`` is :func:`optroute.optimise_corridor`'s (where the NLP's rows sit; None: its default);
    ``timing`` also re-judges every verified plan with its departure a minute late (:func:`timing_margin`).
    """
    start = time.process_time()
    res = CaseResult(case)
    ship = orx.Ship.preset(case.ship)
    wx = case_weather(case)
    corridor = orx.Corridor.from_waypoints(np.array(case.waypoints), width_nm=case.width_nm)
    kw = {"max_leg_nm": max_leg_nm, "rows": constraint_rows, "timing": timing}
    fastest = _solve(res, "time", corridor, wx, ship, objective="time", **kw)
    if fastest is not None:
        res.feasible = True
        eta = T0 + np.timedelta64(int(round(fastest.duration_h * case.eta_factor * 3600.0)), "s")
        least = _solve(res, "fuel", corridor, wx, ship, eta=eta, objective="fuel", **kw)
        returned = all(res.outcomes.get(k, "").startswith("plan") for k in ("time", "fuel"))
        if least is not None and returned and not res.findings.get("time"):
            res.findings.setdefault("fuel", []).extend(fuel_not_worse(least, [fastest], eta))
        if res.outcomes.get("fuel") == "InfeasibleETA":
            res.findings["fuel"] = [Finding("honest_eta", -1, case.waypoints[-1], fastest.duration_h, 0.0)]
    res.cpu_s = time.process_time() - start - res.timing_cpu_s  # the solves and checks, as without ``timing``
    return res


def decide_by_brute_force(res: CaseResult, **lattice: Any) -> float | None:
    """Whether a minimum time that ended in SolverFailure without any plan was feasible after all: the case's
    :func:`corridor_passage` (``lattice`` its keywords), its plan judged by ``verify()`` and :func:`check_plan`.

    Where that plan passes both, the case is feasible (``res.feasible``; the SolverFailure then counts against the
    target) and ``res.brute_force_h`` is its arrival [h]; where the lattice finds no passage, or its plan fails a
    check, the case stays undetermined. Returns ``res.brute_force_h``.
    """
    if res.feasible or res.outcomes.get("time") != "SolverFailure":
        return res.brute_force_h
    case, ship = res.case, orx.Ship.preset(res.case.ship)
    wx = case_weather(case)
    found = corridor_passage(case, wx, ship, **{"lanes": 2 if case.width_nm > 0 else 0, **lattice})
    if found is not None:
        plan = passage_plan(case, wx, ship, found)
        if plan.verify() == [] and check_plan(plan, wx, ship) == ([], 0):
            res.feasible, res.brute_force_h = True, plan.duration_h
            res.brute_force_margin = timing_margin(plan)
    return res.brute_force_h


def summarise(results: list[CaseResult]) -> dict[str, Any]:
    """Counts over cases: plans, violations by kind, SolverFailure share of the feasible cases, outcomes."""
    kinds: dict[str, int] = {}
    violating: list[str] = []
    for r in results:
        for name, fs in r.findings.items():
            for f in fs:
                kinds[f.kind] = kinds.get(f.kind, 0) + 1
            if fs:
                violating.append(f"seed {r.case.seed} {name}: " + "; ".join(str(f) for f in fs[:3]))
    feasible = [r for r in results if r.feasible]
    failures = [r for r in feasible if "SolverFailure" in r.outcomes.values()]
    outcomes: dict[str, int] = {}
    for r in results:
        for name, o in r.outcomes.items():
            outcomes[f"{name}:{o}"] = outcomes.get(f"{name}:{o}", 0) + 1
    return {
        "cases": len(results),
        "feasible_cases": len(feasible),
        "plans_checked": sum(len(r.findings) for r in results),
        "violations": sum(kinds.values()),
        "violations_by_kind": kinds,
        "grazes": sum(sum(r.grazes.values()) for r in results),
        "referee_violations": sum(sum(r.referee.values()) for r in results),
        "solver_failure_cases": len(failures),
        "solver_failure_share": (len(failures) / len(feasible)) if feasible else float("nan"),
        "solver_failure_seeds": [r.case.seed for r in failures],
        # minimum time ended in SolverFailure without any verified plan: feasibility undetermined
        "undetermined_seeds": [
            r.case.seed for r in results if not r.feasible and r.outcomes.get("time") == "SolverFailure"
        ],
        # of those, the ones the harness's brute force across the corridor found a verified passage in
        "brute_force_feasible_seeds": [r.case.seed for r in results if r.brute_force_h is not None],
        # of those, the ones whose passage breaks with its departure a minute late (knife edges, :func:`knife_edge`)
        "knife_edge_seeds": [r.case.seed for r in results if knife_edge(r.brute_force_margin)],
        # verified plans the optimiser returned, and of those the ones a minute's shift of departure breaks
        "plans_timed": sum(len(r.margins) for r in results),
        "plans_knife_edge": sum(knife_edge(m) for r in results for m in r.margins.values()),
        "knife_edge_plans": [f"{r.case.seed} {k}" for r in results for k, m in r.margins.items() if knife_edge(m)],
        "violating": violating,
        "outcomes": outcomes,
        # plans whose NLP's first solve passed verify() as it was (issue 13 item 3), of the plans returned
        "first_solve_verified": sum(v == "verified" for r in results for v in r.first_solve.values()),
        "plans_returned": sum(len(r.first_solve) for r in results),
        # plans that are the verified start (the NLP did not improve on it), and of those the ones whose start lay
        # inside the NLP's own (backed-off) bands: where the NLP began outside its feasible set
        "start_plans": sum(o == "plan:start" for r in results for o in r.outcomes.values()),
        "start_plans_inside_nlp_bands": sum(
            r.outcomes.get(k) == "plan:start" and bool(v and v["samples"])
            for r in results
            for k, v in r.start_in_bands.items()
        ),
        # the NLP model's error against the referee (its stated bound, TABULATION_BOUND, is for a solution)
        **_tabulation_counts(results),
        "cpu_s": sum(r.cpu_s for r in results),
    }


def _tabulation_counts(results: list[CaseResult]) -> dict[str, Any]:
    """Over the plans returned: the largest |error| of the NLP model's fuel against the referee's at the NLP's start
    and at its solution, the plans measured, and those above the optimiser's stated bound at a solution."""
    from optroute.optimise.power_table import TABULATION_BOUND

    start = np.array([abs(v[0]) for r in results for v in r.tabulation.values()], dtype=float)
    sol = np.array([abs(v[1]) for r in results for v in r.tabulation.values()], dtype=float)
    start, sol = start[np.isfinite(start)], sol[np.isfinite(sol)]
    return {
        "tabulation_bound": TABULATION_BOUND,
        "tabulation_start_max": float(start.max()) if start.size else float("nan"),
        "tabulation_start_measured": int(start.size),
        "tabulation_solution_max": float(sol.max()) if sol.size else float("nan"),
        "tabulation_solution_measured": int(sol.size),
        "tabulation_solution_above_bound": int(np.sum(sol > TABULATION_BOUND)),
    }
