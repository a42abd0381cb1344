"""What a ship can do at a point of its passage: speed, heading, power and fuel.

The route search's edge cost (Boeing EP 2145155 Figs. 21–22: within each
grid square "the speed starts at the desired speed and is reduced until
every condition holds"), the 3D DP's MCR loop (Shao et al., steps 2–4) and the
plan verifier all ask the same question at many points at once: given the
course to make good, the sea state there and a wanted speed, which speed
through water is allowed?  It is allowed when

* it lies outside every danger band (:mod:`optroute.physics.safety`), evaluated with
  the heading crabbed against the current;
* the brake power it needs (:class:`~optroute.physics.performance.PerformanceModel`)
  is within [minimum load, MCR];
* the course can be held against the current with positive speed over
  ground.

:func:`best_speed` evaluates a descending ladder of candidate speeds for all
points in one vectorised pass and keeps the fastest allowed one.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.physics import currents, pointwise, seaway
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import BandRules, is_speed_forbidden
from optroute.physics.ship import Ship


@dataclass(frozen=True)
class SeaState:
    """Sea state at N points, canonical names and units (``optroute.weather.schema``).

    Attributes
    ----------
    hs_m : ndarray
        Significant wave height [m]; NaN marks "no passage" (land, ice).
    period_s : ndarray
        Wave period used for the bands [s] (peak period where known).
    wave_from_deg : ndarray
        Mean wave direction, coming from [deg true].
    wind_u_ms, wind_v_ms : ndarray
        10 m wind, the vector it blows to, east/north [m/s]; NaN where not known (the
        performance model then takes the Beaufort number from Hs).
    current_u_ms, current_v_ms : ndarray
        Surface current, the vector it flows to, east/north [m/s].
    """

    hs_m: np.ndarray
    period_s: np.ndarray
    wave_from_deg: np.ndarray
    wind_u_ms: np.ndarray
    wind_v_ms: np.ndarray
    current_u_ms: np.ndarray
    current_v_ms: np.ndarray

    @classmethod
    def from_sample(cls, sample: Mapping[str, ArrayLike]) -> SeaState:
        """Build from a sampler's output (canonical names); a missing wind is NaN (not known), a missing current zero.

        The band period is ``tp_s`` where present, else ``tm_s``.
        """
        if "hs_m" not in sample or "wave_from_deg" not in sample:
            raise ConfigError(f"a sea-state sample needs hs_m and wave_from_deg; it has {sorted(sample)}")
        period_name = "tp_s" if "tp_s" in sample else "tm_s"
        if period_name not in sample:
            raise ConfigError(f"a sea-state sample needs tp_s or tm_s; it has {sorted(sample)}")
        hs = np.asarray(sample["hs_m"], dtype=float)
        zero, unknown = np.zeros_like(hs), np.full_like(hs, np.nan)
        get = lambda k, d=zero: np.broadcast_to(np.asarray(sample.get(k, d), dtype=float), hs.shape)  # noqa: E731
        return cls(
            hs_m=hs,
            period_s=get(period_name),
            wave_from_deg=get("wave_from_deg"),
            wind_u_ms=get("wind_u_ms", unknown),
            wind_v_ms=get("wind_v_ms", unknown),
            current_u_ms=get("current_u_ms"),
            current_v_ms=get("current_v_ms"),
        )

    @classmethod
    def uniform(
        cls,
        n: int = 1,
        *,
        hs_m: float = 0.0,
        period_s: float = 8.0,
        wave_from_deg: float = 0.0,
        wind_u_ms: float = 0.0,
        wind_v_ms: float = 0.0,
        current_u_ms: float = 0.0,
        current_v_ms: float = 0.0,
    ) -> SeaState:
        """The same sea state at ``n`` points (units as the attributes)."""
        f = lambda x: np.full(n, float(x))  # noqa: E731
        return cls(f(hs_m), f(period_s), f(wave_from_deg), f(wind_u_ms), f(wind_v_ms), f(current_u_ms), f(current_v_ms))

    @property
    def navigable(self) -> np.ndarray:
        """False where any wave field is NaN: land, ice, or outside the model."""
        return np.isfinite(self.hs_m) & np.isfinite(self.period_s) & np.isfinite(self.wave_from_deg)


@dataclass(frozen=True)
class SpeedChoice:
    """The speed chosen at each of N points; NaN where no speed is allowed.

    Attributes
    ----------
    stw_kn : ndarray
        Speed through water [kn].
    sog_kn : ndarray
        Speed over ground along the course [kn].
    heading_deg : ndarray
        Heading crabbed against the current [deg true, to].
    power_kw : ndarray
        Brake power [kW].
    fuel_tph : ndarray
        Fuel rate [t/h].
    feasible : ndarray of bool
        Whether any allowed speed was found.
    """

    stw_kn: np.ndarray
    sog_kn: np.ndarray
    heading_deg: np.ndarray
    power_kw: np.ndarray
    fuel_tph: np.ndarray
    feasible: np.ndarray


def evaluate_speeds(
    ship: Ship,
    model: PerformanceModel,
    rules: BandRules,
    course_deg: ArrayLike,
    sea: SeaState,
    stw_kn: ArrayLike,
    *,
    engine: str = "auto",
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Heading, SOG, power, fuel rate and allowedness of given speeds.

    Parameters
    ----------
    ship : Ship
        Length and roll period for the bands.
    model : PerformanceModel
        Brake power and fuel rate.
    rules : BandRules
        Danger-band rules.
    course_deg : array_like, shape (N,)
        Course to make good over ground [deg true, to].
    sea : SeaState
        Sea state at the N points.
    stw_kn : array_like, shape (N,) or (N, K)
        Candidate speeds through water [kn], > 0.
    engine : {"auto", "numpy"}
        ``"auto"``: for the built-in models (:func:`optroute.physics.pointwise.point_params`)
        the compiled one-point functions the search kernels share; otherwise, and with
        ``"numpy"``, the vectorised composition of ``model.brake_power_kw`` and
        :func:`~optroute.physics.safety.is_speed_forbidden` (the same numbers to rounding).

    Returns
    -------
    heading_deg, sog_kn, power_kw, fuel_tph : ndarray, shape of ``stw_kn``
        NaN where the course cannot be held; SOG and power also NaN (fuel rate inf) where the sea is
        not navigable (NaN waves: land, ice, outside the weather's area or time span), whatever the
        current there (NaN too, outside the data).
    allowed : ndarray of bool
        Band-free, power within [min load, MCR], course held, sea navigable.
    """
    stw = finite("stw_kn", stw_kn, minimum=0.0, strict=True)
    extra = (slice(None),) + (None,) * (stw.ndim - 1)
    n = np.asarray(sea.hs_m).shape[0]
    course = np.broadcast_to(finite("course_deg", course_deg), (n,))[extra]
    col = lambda a: np.asarray(a, dtype=float)[extra]  # noqa: E731
    if engine not in ("auto", "numpy"):
        raise ConfigError(f"engine={engine!r} is not known; use 'auto' or 'numpy'")
    params = pointwise.cached_point_params(ship, model, rules) if engine == "auto" else None
    if params is not None:  # the built-in models: the one-point functions every search kernel uses too
        fields = (course, *(col(getattr(sea, f)) for f in SeaState.__dataclass_fields__), stw)
        # np.array copies: every field arrives writable and C-contiguous, whatever broadcasting gave, so the
        # kernel compiles one signature (numba types read-only arrays apart, and a broadcast view is read-only)
        flat = [np.array(np.broadcast_to(a, stw.shape), dtype=float).ravel() for a in fields]
        return tuple(a.reshape(stw.shape) for a in pointwise.evaluate_speeds_flat(params, *flat))  # type: ignore[return-value]
    navigable = sea.navigable[extra]
    hs = np.where(navigable, col(sea.hs_m), 0.0)
    period = np.where(navigable, col(sea.period_s), 1.0)
    wave_from = np.where(navigable, col(sea.wave_from_deg), 0.0)
    # Where the sea is not navigable (no wave data: land, ice, or a point outside the weather's area or
    # time span, which samplers give as NaN) the current is NaN too; such a point is never allowed and
    # gets no power, so its current only has to be a number for the vector arithmetic.
    heading, sog = currents.heading_for_course(
        course,
        stw,
        np.where(navigable, col(sea.current_u_ms), 0.0),
        np.where(navigable, col(sea.current_v_ms), 0.0),
        on_unreachable="nan",
    )
    held = np.isfinite(heading)
    heading_ok = np.where(held, heading, course)
    power = power_at_heading(model, stw, heading_ok, hs, wave_from, col(sea.wind_u_ms), col(sea.wind_v_ms))
    power = np.broadcast_to(power, stw.shape)
    forbidden = is_speed_forbidden(
        ship, speed_kn=stw, hs_m=hs, period_s=period, wave_from_deg=wave_from, heading_deg=heading_ok, rules=rules
    )
    in_power = (power <= model.mcr_kw) & (power >= model.min_power_kw)
    allowed = navigable & held & ~forbidden & in_power
    power = np.where(navigable, power, np.nan)  # no sea state, no power: never the calm-water figure
    sog = np.where(navigable, sog, np.nan)
    finite_power = np.where(np.isfinite(power), power, 0.0)
    fuel = np.where(np.isfinite(power), model.fuel_rate_tph(finite_power), np.inf)
    return np.where(held, heading, np.nan), sog, power, fuel, allowed


def power_at_heading(
    model: PerformanceModel,
    stw_kn: ArrayLike,
    heading_deg: ArrayLike,
    hs_m: ArrayLike,
    wave_from_deg: ArrayLike,
    wind_u_ms: ArrayLike,
    wind_v_ms: ArrayLike,
    wave_sector_deg: tuple[float, float] | None = None,
) -> np.ndarray:
    """Brake power [kW] of ``model`` at a speed through water [kn] and heading [deg true, to] in a sea.

    ``model.brake_power_kw`` of the sea as :func:`model_sea` hands it to the model, its wave angle in
    ``wave_sector_deg`` (:func:`sector_angle`) where given. :func:`evaluate_speeds` (the plan's referee) and the
    corridor NLP's power table (:mod:`optroute.optimise.power_table`) both call it.
    """
    sea = model_sea(heading_deg, hs_m, wave_from_deg, wind_u_ms, wind_v_ms)
    sea["wave_angle_deg"] = sector_angle(sea["wave_angle_deg"], wave_sector_deg)
    return model.brake_power_kw(stw_kn, **sea)


def model_sea(
    heading_deg: ArrayLike,
    hs_m: ArrayLike,
    wave_from_deg: ArrayLike,
    wind_u_ms: ArrayLike,
    wind_v_ms: ArrayLike,
) -> dict[str, np.ndarray]:
    """A sea state as a :class:`~optroute.physics.performance.PerformanceModel`'s keyword arguments at a heading.

    The one place where a sea state becomes the model's arguments: the relative wave angle (IMO
    MSC.1/Circ.1228, 0 = head sea) from the heading [deg true, to] and the direction the waves come from
    [deg], the 10 m wind speed [m/s] and its angle off the bow from the wind vector (east/north, blowing
    to, [m/s]); Hs [m] as given.

    Returns
    -------
    dict
        ``hs_m``, ``wave_angle_deg``, ``wind_speed_ms`` and ``wind_angle_deg``, broadcast as the inputs give.
    """
    heading = np.asarray(heading_deg, dtype=float)
    wind_speed, wind_from = units.wind_uv_to_speed_from_deg(wind_u_ms, wind_v_ms)
    return {
        "hs_m": np.asarray(hs_m, dtype=float),
        "wave_angle_deg": seaway.relative_wave_angle_deg(heading, wave_from_deg),
        "wind_speed_ms": wind_speed,
        "wind_angle_deg": units.wrap_360(wind_from - heading),
    }


def sector_angle(wave_angle_deg: np.ndarray, wave_sector_deg: tuple[float, float] | None) -> np.ndarray:
    """The relative wave angle [deg, 0–360] as if the waves came from inside a sector of the folded angle.

    ``wave_sector_deg = (lo, hi)`` (0 ≤ lo < hi ≤ 180): α is clamped into it on its own side of the ship (the power
    table's sector fields; a model that steps at the sector's edges is then smooth in the heading). The edge
    ``lo > 0`` is excluded, 10⁻⁶° inside, as Kwon's sectors give each edge to the sector nearer the bow. None: α
    unchanged.
    """
    alpha = np.asarray(wave_angle_deg, dtype=float)
    if wave_sector_deg is None:
        return alpha
    lo, hi = float(wave_sector_deg[0]), float(wave_sector_deg[1])
    folded = np.clip(np.where(alpha > 180.0, 360.0 - alpha, alpha), lo + (1e-6 if lo > 0 else 0.0), hi)
    return np.where(alpha > 180.0, 360.0 - folded, folded)


def navigability_variables(names: Iterable[str]) -> tuple[str, ...]:
    """The weather variables among ``names`` whose NaN makes a point not navigable (:attr:`SeaState.navigable`).

    ``hs_m``, the band period (``tp_s`` where present, else ``tm_s``: :meth:`SeaState.from_sample`)
    and ``wave_from_deg``: the referee calls a point no passage when any of them is NaN there, and
    everything that keeps a plan off no-passage cells reads the same ones
    (:func:`optroute.optimise.lateral.wave_nan`).
    """
    have = set(names)
    period = "tp_s" if "tp_s" in have else "tm_s"
    return tuple(v for v in ("hs_m", period, "wave_from_deg") if v in have)


def power_regime(model: PerformanceModel, heading_deg: ArrayLike, sea: SeaState) -> np.ndarray:
    """Where a model's brake power may jump along a track: an int key per point, the same key, smooth power.

    The model's own ``power_regime`` (:meth:`optroute.physics.performance.KwonModel.power_regime`: Kwon's
    Beaufort number and direction sector) of the sea state as :func:`power_at_heading` hands it to the
    model; 0 for a model that declares none (its power is continuous in the sea state); -1 where the
    sea is not navigable (no power: the fuel rate is infinite there).

    Parameters
    ----------
    model : PerformanceModel
    heading_deg : array_like, shape (N,)
        Heading [deg true, to] (the course where the course cannot be held).
    sea : SeaState
        Sea state at the N points.
    """
    navigable = np.asarray(sea.navigable)
    fn = getattr(model, "power_regime", None)
    if fn is None:
        return np.where(navigable, 0, -1).astype(np.int64)
    return np.where(navigable, fn(**_regime_inputs(heading_deg, sea)), -1).astype(np.int64)


def _regime_inputs(heading_deg: ArrayLike, sea: SeaState) -> dict[str, np.ndarray]:
    """The sea state as a model's ``power_regime`` and ``regime_distances`` read it: Hs [m] (0 where not
    navigable), the relative wave angle [deg, 0 = head seas] and the wind speed [m/s] (NaN where not navigable)."""
    navigable = np.asarray(sea.navigable)
    at = model_sea(
        heading_deg,
        np.where(navigable, np.asarray(sea.hs_m, dtype=float), 0.0),
        np.where(navigable, np.asarray(sea.wave_from_deg, dtype=float), 0.0),
        sea.wind_u_ms,
        sea.wind_v_ms,
    )
    return {
        "hs_m": at["hs_m"],
        "wave_angle_deg": at["wave_angle_deg"],
        "wind_speed_ms": np.where(navigable, at["wind_speed_ms"], np.nan),
    }


def regime_distances(model: PerformanceModel, heading_deg: ArrayLike, sea: SeaState) -> tuple[np.ndarray, ...]:
    """How far each point's sea state is from a change of :func:`power_regime`: one array per driver.

    The model's own ``regime_distances`` (:meth:`optroute.physics.performance.KwonModel.regime_distances`:
    the Beaufort number's driver to its nearest edge, the wave angle to Kwon's nearest sector edge), of the
    sea state as :func:`power_regime` hands it to the model; an empty tuple for a model that declares no
    regimes. Each array is continuous along a track, zero where the regime can change; NaN where the sea
    is not navigable.

    Parameters
    ----------
    model : PerformanceModel
    heading_deg : array_like, shape (N,)
        Heading [deg true, to] (the course where the course cannot be held).
    sea : SeaState
        Sea state at the N points.
    """
    fn = getattr(model, "regime_distances", None)
    if fn is None:
        return ()
    navigable = np.asarray(sea.navigable)
    return tuple(np.where(navigable, d, np.nan) for d in fn(**_regime_inputs(heading_deg, sea)))


ACROSS_EDGE = 1e-6
"""How far past a regime edge :func:`across_regime_edges` puts a driver, beyond its distance to the edge
[the driver's unit: m/s, m or deg]."""


def across_regime_edges(
    model: PerformanceModel, heading_deg: ArrayLike, sea: SeaState
) -> tuple[tuple[SeaState, SeaState], ...]:
    """The sea state with each regime driver moved just past its nearest edge, down and up: one pair per driver.

    The drivers and their distances are those of :func:`regime_distances`, in the same order: the
    Beaufort number's driver (the wind speed [m/s], its direction kept, where the wind is known, else Hs
    [m]) and the folded relative wave angle [deg] (moved by turning the waves' direction, which moves the
    relative angle by as much). Each is moved by its distance plus :data:`ACROSS_EDGE`, so one of the two
    states lies just across the nearest edge, in the neighbouring regime, and the other as far on this
    side. The plan's fuel integration (:mod:`optroute.plan.evaluate`) evaluates the model there to bound
    what a regime excursion too short for the referee to see can cost. Empty for a model that declares
    no regimes.

    Parameters
    ----------
    model : PerformanceModel
    heading_deg : array_like, shape (N,)
        Heading [deg true, to].
    sea : SeaState
        Sea state at the N points.
    """
    dists = regime_distances(model, heading_deg, sea)
    if not dists:
        return ()
    step_bn, step_angle = (np.where(np.isfinite(m), m, 0.0) + ACROSS_EDGE for m in dists)
    speed, to_deg = units.uv_to_speed_to_deg(sea.wind_u_ms, sea.wind_v_ms)
    known = np.isfinite(speed)

    def beaufort(sign: float) -> SeaState:
        hs = np.asarray(sea.hs_m, dtype=float)
        # the wind's speed to the target, its direction kept (where the wind is not known, it stays NaN)
        u, v = units.speed_to_deg_to_uv(np.maximum(speed + sign * step_bn, 0.0), to_deg)
        return replace(sea, hs_m=np.where(known, hs, np.maximum(hs + sign * step_bn, 0.0)), wind_u_ms=u, wind_v_ms=v)

    def angle(sign: float) -> SeaState:
        return replace(sea, wave_from_deg=units.wrap_360(np.asarray(sea.wave_from_deg) + sign * step_angle))

    return (beaufort(-1.0), beaufort(1.0)), (angle(-1.0), angle(1.0))


def _pick(choice_idx: np.ndarray, feasible: np.ndarray, arrays: tuple[np.ndarray, ...]) -> list[np.ndarray]:
    """Entry ``choice_idx[i]`` of row i of each (N, K) array; NaN where not feasible."""
    return [np.where(feasible, np.take_along_axis(a, choice_idx[:, None], axis=1)[:, 0], np.nan) for a in arrays]


def _subset(sea: SeaState, idx: np.ndarray) -> SeaState:
    return SeaState(*(np.asarray(getattr(sea, f))[idx] for f in SeaState.__dataclass_fields__))


def best_speed(
    ship: Ship,
    model: PerformanceModel,
    rules: BandRules,
    course_deg: ArrayLike,
    sea: SeaState,
    desired_stw_kn: ArrayLike,
    *,
    step_kn: float = 0.25,
    min_stw_kn: float = 1.0,
    engine: str = "auto",
) -> SpeedChoice:
    """Boeing's speed reduction: the fastest allowed speed at or below the desired one.

    Candidates run from ``desired_stw_kn`` down to ``min_stw_kn`` in steps of
    ``step_kn`` (EP 2145155 Fig. 22, "reduce VELOCIDAD until every condition
    holds"; Shao et al.'s MCR loop reduces by Δu the same way).  The desired
    speed is tried first at every point; the ladder is evaluated only where
    it is not allowed.

    Parameters
    ----------
    ship, model, rules, course_deg, sea
        As in :func:`evaluate_speeds`; N points.
    desired_stw_kn : array_like, shape (N,) or scalar
        Speed through water wanted [kn].
    step_kn : float
        Speed decrement [kn], > 0.
    min_stw_kn : float
        Slowest speed considered [kn], > 0.
    engine : {"auto", "numpy"}
        As in :func:`evaluate_speeds`.

    Returns
    -------
    SpeedChoice
        Per point; ``feasible`` False (and NaN values) where no candidate is allowed.
    """
    step = float(finite("step_kn", step_kn, minimum=0.0, strict=True, error=ConfigError))
    vmin = float(finite("min_stw_kn", min_stw_kn, minimum=0.0, strict=True, error=ConfigError))
    n = np.asarray(sea.hs_m).shape[0]
    desired = np.broadcast_to(finite("desired_stw_kn", desired_stw_kn, minimum=0.0, strict=True), (n,))
    course = np.broadcast_to(finite("course_deg", course_deg), (n,))
    out = [np.full(n, np.nan) for _ in range(5)]
    feasible = np.zeros(n, dtype=bool)
    first = evaluate_speeds(ship, model, rules, course, sea, desired, engine=engine)
    ok = first[4] & (desired >= vmin)
    for o, a in zip(out, (desired,) + first[:4], strict=True):
        o[ok] = a[ok]
    feasible |= ok
    rest = np.flatnonzero(~ok)
    if rest.size:
        k = int(np.floor((float(desired[rest].max()) - vmin) / step)) + 1
        ladder = desired[rest, None] - step * np.arange(1, max(k, 1) + 1)[None, :]
        valid = ladder >= vmin - 1e-12
        ladder = np.where(valid, ladder, vmin)
        heading, sog, power, fuel, allowed = evaluate_speeds(
            ship, model, rules, course[rest], _subset(sea, rest), ladder, engine=engine
        )
        allowed &= valid
        feas = allowed.any(axis=1)
        picked = _pick(np.argmax(allowed, axis=1), feas, (ladder, heading, sog, power, fuel))
        for o, a in zip(out, picked, strict=True):
            o[rest] = a
        feasible[rest] = feas
    stw, heading, sog, power, fuel = out
    return SpeedChoice(stw_kn=stw, sog_kn=sog, heading_deg=heading, power_kw=power, fuel_tph=fuel, feasible=feasible)


def cheapest_speed(
    ship: Ship,
    model: PerformanceModel,
    rules: BandRules,
    course_deg: ArrayLike,
    sea: SeaState,
    speeds_kn: ArrayLike,
    lambda_t_per_h: float,
    *,
    engine: str = "auto",
) -> SpeedChoice:
    """The allowed speed minimising fuel + λ·time per mile made good.

    For a piece of length d the cost of sailing it at speed V is
    d (F(V) + λ) / SOG(V) [t], F the fuel rate; the piece length cancels, so
    the choice is per point.  λ = 0 is the fuel-minimal (slowest economic)
    speed; a large λ approaches the fastest allowed speed.  This is the
    discrete speed choice of the grid search (Shao et al.'s speed set;
    the λ weighting is the Lagrangian of an ETA constraint).

    Parameters
    ----------
    ship, model, rules, course_deg, sea
        As in :func:`evaluate_speeds`; N points.
    speeds_kn : array_like, shape (K,)
        The discrete speed set [kn], > 0.
    lambda_t_per_h : float
        Value of an hour in tonnes of fuel [t/h], >= 0.
    engine : {"auto", "numpy"}
        As in :func:`evaluate_speeds`.

    Returns
    -------
    SpeedChoice
    """
    lam = float(finite("lambda_t_per_h", lambda_t_per_h, minimum=0.0, error=ConfigError))
    speeds = finite("speeds_kn", speeds_kn, minimum=0.0, strict=True, error=ConfigError).ravel()
    n = np.asarray(sea.hs_m).shape[0]
    ladder = np.broadcast_to(speeds[None, :], (n, speeds.size))
    heading, sog, power, fuel, allowed = evaluate_speeds(ship, model, rules, course_deg, sea, ladder, engine=engine)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(allowed & (sog > 0), (fuel + lam) / sog, np.inf)
    feasible = np.isfinite(rate).any(axis=1)
    stw, heading, sog, power, fuel = _pick(np.argmin(rate, axis=1), feasible, (ladder, heading, sog, power, fuel))
    return SpeedChoice(stw_kn=stw, sog_kn=sog, heading_deg=heading, power_kw=power, fuel_tph=fuel, feasible=feasible)
