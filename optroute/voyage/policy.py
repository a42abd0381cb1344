"""The re-planning policy, the forecasts a voyage receives, and the voyage's outcome.

Times are timezone-naive UTC ``datetime64[ns]`` (optroute's convention); durations in hours.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from optroute import units
from optroute.errors import ConfigError
from optroute.units import as_utc_time as _as_time
from optroute.units import timedelta_to_h as _td_to_h

__all__ = ["ForecastSequence", "ForecastTimeError", "ReplanPolicy", "VoyageOutcome"]


class ForecastTimeError(ConfigError):
    """A forecast was asked for at a time before it was issued (it did not exist yet)."""


def _positive_or_none(owner: str, name: str, value: Any) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{owner}.{name}={value!r} is not a number; pass a number > 0 or None (off)") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ConfigError(f"{owner}.{name}={value!r} must be a finite number > 0; pass None to switch it off")
    return v


@dataclass(frozen=True)
class ReplanPolicy:
    """When the voyage re-plans from the current position, time and remaining ETA.

    Boeing EP 2145155 re-plans "periodically, or when a new forecast arrives"; Życkowski's sailing
    router re-plans whenever the weather met differs from the forecast used. Any trigger that is
    on may fire; ``min_interval_h`` spaces the re-plans.

    Attributes
    ----------
    every_h : float or None
        Re-plan every so many hours of voyage [h], > 0 (None: off).
    on_forecast : bool
        Re-plan when a new forecast has been issued since the last plan.
    hs_threshold_m : float or None
        Re-plan when the H_s met in the truth differs from the current plan's forecast at the
        ship's position and time by more than this [m], > 0 (None: off).
    direction_threshold_deg : float or None
        The same for the wave direction (smallest angle between the two "from" directions)
        [deg], in (0, 180] (None: off).
    period_threshold_s : float or None
        The same for the wave period (the band period: T_p, else T_m) [s], > 0 (None: off).
    min_interval_h : float
        Least time between two re-plans [h], >= 0.
    wind_speed_threshold_kn : float or None
        Re-plan when the true wind speed met differs from the route's forecast at the boat's
        position and time by more than this [kn], > 0 (None: off). The sailing simulator's
        trigger (:func:`optroute.voyage.sailing_sim.simulate_sailing`, Życkowski).
    wind_direction_threshold_deg : float or None
        The same for the wind direction (smallest angle between the two "from" directions)
        [deg], in (0, 180] (None: off).
    """

    every_h: float | None = None
    on_forecast: bool = True
    hs_threshold_m: float | None = None
    direction_threshold_deg: float | None = None
    period_threshold_s: float | None = None
    min_interval_h: float = 0.0
    wind_speed_threshold_kn: float | None = None
    wind_direction_threshold_deg: float | None = None

    def __post_init__(self) -> None:
        for name in (
            "every_h", "hs_threshold_m", "direction_threshold_deg", "period_threshold_s", "wind_speed_threshold_kn",
            "wind_direction_threshold_deg",
        ):  # fmt: skip
            object.__setattr__(self, name, _positive_or_none("ReplanPolicy", name, getattr(self, name)))
        for name in ("direction_threshold_deg", "wind_direction_threshold_deg"):
            value = getattr(self, name)
            if value is not None and value > 180.0:
                raise ConfigError(
                    f"ReplanPolicy.{name}={value!r} exceeds 180 deg, the largest difference of two directions; "
                    "pass a value in (0, 180]"
                )
        if not isinstance(self.on_forecast, bool):
            raise ConfigError(f"ReplanPolicy.on_forecast={self.on_forecast!r} must be True or False")
        mi = self.min_interval_h
        if isinstance(mi, bool) or not isinstance(mi, (int, float)) or not math.isfinite(mi) or mi < 0:
            raise ConfigError(f"ReplanPolicy.min_interval_h={mi!r} must be a finite number of hours >= 0")
        object.__setattr__(self, "min_interval_h", float(mi))

    @classmethod
    def never(cls) -> ReplanPolicy:
        """Plan once and sail that plan blind."""
        return cls(on_forecast=False)

    @property
    def replans(self) -> bool:
        """Whether any trigger is on."""
        thresholds = (
            self.hs_threshold_m, self.direction_threshold_deg, self.period_threshold_s, self.wind_speed_threshold_kn,
            self.wind_direction_threshold_deg,
        )  # fmt: skip
        return self.on_forecast or self.every_h is not None or any(t is not None for t in thresholds)


class ForecastSequence:
    """Forecasts as (issue time, dataset) pairs, each usable only from its issue time on.

    Parameters
    ----------
    forecasts : iterable of (time, xarray.Dataset)
        Issue time [UTC] and the canonical dataset it issued; any order (sorted here), no two
        with the same issue time.

    Raises
    ------
    ConfigError
        A pair is malformed, a dataset is not an ``xarray.Dataset`` or two issue times repeat.
    """

    def __init__(self, forecasts: Iterable[tuple[Any, xr.Dataset]]) -> None:
        pairs = []
        for k, item in enumerate(forecasts):
            try:
                issued, ds = item
            except (TypeError, ValueError):
                raise ConfigError(f"forecasts[{k}] must be an (issue time, dataset) pair, got {item!r}") from None
            if not isinstance(ds, xr.Dataset):
                raise ConfigError(
                    f"forecasts[{k}]: the dataset is a {type(ds).__name__}, not an xarray.Dataset; "
                    "load it with optroute.open_weather"
                )
            pairs.append((_as_time(issued, f"forecasts[{k}] issue time"), ds))
        pairs.sort(key=lambda p: p[0])
        issued_all = [p[0] for p in pairs]
        if len(set(issued_all)) != len(issued_all):
            raise ConfigError("forecasts: two forecasts share an issue time; give each its own issue time")
        self._issued = np.array(issued_all, dtype="datetime64[ns]")
        self._data = [p[1] for p in pairs]

    def __len__(self) -> int:
        return len(self._data)

    @property
    def issue_times(self) -> np.ndarray:
        """Issue times [UTC], increasing."""
        return self._issued.copy()

    def index_of(self, dataset: Any) -> int | None:
        """Index of the forecast that is this very dataset object; None when it is none of them."""
        for k, ds in enumerate(self._data):
            if ds is dataset:
                return k
        return None

    def latest_index(self, when: Any) -> int | None:
        """Index of the newest forecast issued at or before ``when``; None when none is yet."""
        t = _as_time(when, "when")
        k = int(np.searchsorted(self._issued, t, side="right")) - 1
        return None if k < 0 else k

    def get(self, index: int, when: Any) -> xr.Dataset:
        """Forecast ``index`` for use at ``when``.

        Raises
        ------
        ForecastTimeError
            ``when`` is before the forecast's issue time (the message names both times).
        """
        t = _as_time(when, "when")
        issued = self._issued[index]
        if t < issued:
            raise ForecastTimeError(
                f"forecast {index} issued at {units.format_utc(issued)} cannot be used at {units.format_utc(t)}, "
                f"{float(_td_to_h(issued - t)):.3g} h before it was issued; use a forecast issued by then "
                "or start the voyage later"
            )
        return self._data[index]

    def latest(self, when: Any) -> tuple[int, xr.Dataset]:
        """The newest forecast issued at or before ``when``.

        Raises
        ------
        ForecastTimeError
            No forecast is issued by ``when`` (the message names ``when`` and the first issue time).
        """
        t = _as_time(when, "when")
        k = self.latest_index(t)
        if k is None:
            if not len(self):
                raise ConfigError("no forecast given; pass forecasts=[(issue time, dataset), ...]")
            return 0, self.get(0, t)
        return k, self._data[k]


@dataclass(frozen=True)
class VoyageOutcome:
    """What a simulated voyage achieved in the truth weather.

    Attributes
    ----------
    departure : numpy.datetime64
        [UTC].
    arrival : numpy.datetime64
        When the ship reached the destination [UTC].
    fuel_t : float
        Fuel burnt, by the true performance model [t], >= 0.
    distance_nm : float
        Distance sailed over ground [nm], >= 0.
    time_in_band_h : float
        Time sailed at a speed inside a danger band of the truth [h] (no band-free speed between
        the plan's and the slowest speed the master will use), >= 0.
    time_slowed_h : float
        Time the plan's speed was forbidden in the truth (a band or MCR) and the ship slowed by
        the Boeing speed reduction [h], >= 0.
    eta : numpy.datetime64 or None
        Required arrival [UTC].
    n_replans : int
        Plans made after the first, >= 0.
    earliest_arrival : numpy.datetime64 or None
        When a re-plan found the ETA infeasible: the earliest arrival it could make (the last
        such) [UTC].
    time_band_met_h : float
        Time the plan's own speed lay inside a danger band of the truth [h], >= 0: the bands the
        plan met, whether the ship slowed out of them or not.
    n_observer_alarms : int
        Alarms of the onboard parametric-roll observer (0 without it), >= 0.
    max_roll_deg : float
        Largest roll angle of the simulated motions [deg] (NaN without the observer).
    cyclone_closest_km : float
        Closest approach to the TRUE cyclone centre [km] (NaN without a cyclone).
    cyclone_least_gap_km : float
        Least distance to the true centre minus the true force-7 radius R [km]: < 0 the ship
        entered R (NaN without a cyclone).
    time_inside_r_h, time_inside_margin_h : float
        Time sailed inside the true R and inside the true R + margin [h], >= 0.
    """

    departure: np.datetime64
    arrival: np.datetime64
    fuel_t: float
    distance_nm: float
    time_in_band_h: float
    time_slowed_h: float
    eta: np.datetime64 | None
    n_replans: int
    earliest_arrival: np.datetime64 | None = None
    time_band_met_h: float = 0.0
    n_observer_alarms: int = 0
    max_roll_deg: float = math.nan
    cyclone_closest_km: float = math.nan
    cyclone_least_gap_km: float = math.nan
    time_inside_r_h: float = 0.0
    time_inside_margin_h: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "departure", _as_time(self.departure, "VoyageOutcome.departure"))
        object.__setattr__(self, "arrival", _as_time(self.arrival, "VoyageOutcome.arrival"))
        if self.arrival < self.departure:
            raise ConfigError(
                f"VoyageOutcome.arrival {units.format_utc(self.arrival)} is before the departure "
                f"{units.format_utc(self.departure)}"
            )
        for name in (
            "fuel_t", "distance_nm", "time_in_band_h", "time_slowed_h", "time_band_met_h", "time_inside_r_h",
            "time_inside_margin_h",
        ):  # fmt: skip
            v = getattr(self, name)
            if not math.isfinite(float(v)) or float(v) < 0:
                raise ConfigError(f"VoyageOutcome.{name}={v!r} must be a finite number >= 0")
            object.__setattr__(self, name, float(v))
        for name in ("n_replans", "n_observer_alarms"):
            v = getattr(self, name)
            if int(v) != v or v < 0:
                raise ConfigError(f"VoyageOutcome.{name}={v!r} must be an integer >= 0")
        c = float(self.cyclone_closest_km)
        if not (math.isnan(c) or 0.0 <= c < math.inf) or math.isinf(float(self.cyclone_least_gap_km)):
            raise ConfigError(
                f"VoyageOutcome.cyclone_closest_km={self.cyclone_closest_km!r} / cyclone_least_gap_km="
                f"{self.cyclone_least_gap_km!r} must be finite (>= 0 for the distance) or NaN (no cyclone)"
            )
        if not (math.isnan(float(self.max_roll_deg)) or 0.0 <= float(self.max_roll_deg) < 90.0):
            raise ConfigError(f"VoyageOutcome.max_roll_deg={self.max_roll_deg!r} must be in [0, 90) deg or NaN")
        for name in ("eta", "earliest_arrival"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _as_time(getattr(self, name), f"VoyageOutcome.{name}"))

    @property
    def duration_h(self) -> float:
        """Passage time [h]."""
        return float(_td_to_h(self.arrival - self.departure))

    @property
    def eta_miss_h(self) -> float:
        """Arrival − ETA [h] (> 0 late); NaN without an ETA."""
        return float("nan") if self.eta is None else float(_td_to_h(self.arrival - self.eta))

    @property
    def eta_met(self) -> bool | None:
        """Arrived by the ETA (to one minute); None without an ETA."""
        return None if self.eta is None else self.eta_miss_h <= 1.0 / 60.0
