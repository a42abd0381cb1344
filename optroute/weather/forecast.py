"""Forecasts that differ from the truth the way real ones do (issue 16).

A storm forecast errs mostly in where the storm goes and when (track and timing error) and in how
strong it gets; successive forecasts converge on what happened as the lead time shrinks. Here a
storm (:class:`~optroute.weather.storms.Storm`) is moved, delayed and scaled with
:meth:`Storm.shifted` — the same perturbation :func:`optroute.scenarios.ensemble` draws at random —
and the weather is rebuilt with :func:`~optroute.weather.storms.storm_dataset`, so the truth and
the forecast differ only by the stated error.

* :func:`storm_forecast` — one forecast: every storm displaced by ``displacement_nm`` on the
  bearing ``bearing_deg``, delayed by ``delay_h`` and its peak H_s times ``intensity_factor``;
* :func:`converging_forecasts` — forecasts issued at given times whose error shrinks linearly to
  nothing at ``converged_h`` (a forecast issued then or later is the truth).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather._synth import as_start
from optroute.weather.storms import Storm, storm_dataset

__all__ = ["converging_forecasts", "displaced_storms", "storm_forecast"]


def displaced_storms(
    storms: Sequence[Storm],
    *,
    displacement_nm: float = 0.0,
    bearing_deg: float = 0.0,
    delay_h: float = 0.0,
    intensity_factor: float = 1.0,
) -> list[Storm]:
    """The storms as a forecast with a track, timing and intensity error sees them.

    Parameters
    ----------
    storms : sequence of Storm
        The true storms.
    displacement_nm : float
        Track error [nm], >= 0: every track point moves this far on ``bearing_deg`` (east-west
        converted at each storm's mean latitude).
    bearing_deg : float
        Direction of the displacement [deg true].
    delay_h : float
        Timing error [h]: > 0 the forecast storm runs late (its track and life cycle later).
    intensity_factor : float
        Peak H_s of the forecast over the truth's [-], > 0 (< 1 under-forecast).

    Returns
    -------
    list of Storm
    """
    d = float(finite("displacement_nm", displacement_nm, minimum=0.0, error=ConfigError))
    brg = math.radians(float(finite("bearing_deg", bearing_deg, error=ConfigError)))
    dt = float(finite("delay_h", delay_h, error=ConfigError))
    fac = float(
        finite(
            "intensity_factor", intensity_factor, minimum=0.0, strict=True, error=ConfigError, fix="pass a factor > 0"
        )
    )
    out = []
    for s in storms:
        if not isinstance(s, Storm):
            raise ConfigError(f"storms must be Storm specifications, got {type(s).__name__}")
        lat_ref = float(np.mean([p[1] for p in s.track]))
        dlat = d * math.cos(brg) / 60.0
        dlon = d * math.sin(brg) / (60.0 * max(math.cos(math.radians(lat_ref)), 0.05))
        out.append(s.shifted(dlat_deg=dlat, dlon_deg=dlon, dt_h=dt, intensity_factor=fac))
    return out


def storm_forecast(
    storms: Sequence[Storm],
    *,
    displacement_nm: float = 0.0,
    bearing_deg: float = 0.0,
    delay_h: float = 0.0,
    intensity_factor: float = 1.0,
    **dataset_kwargs: Any,
) -> xr.Dataset:
    """A forecast of the storms' weather with a track, timing and intensity error.

    Parameters
    ----------
    storms, displacement_nm, bearing_deg, delay_h, intensity_factor
        As in :func:`displaced_storms`.
    **dataset_kwargs
        Passed to :func:`~optroute.weather.storms.storm_dataset` (``bbox`` required; ``start``,
        ``duration_h``, ``step_h``, ``resolution_deg``, the background sea): give the truth the same.

    Returns
    -------
    xarray.Dataset
        Canonical; ``attrs["forecast_error"]`` states the error.
    """
    wrong = displaced_storms(
        storms,
        displacement_nm=displacement_nm,
        bearing_deg=bearing_deg,
        delay_h=delay_h,
        intensity_factor=intensity_factor,
    )
    ds = storm_dataset(wrong, **dataset_kwargs)
    ds.attrs["forecast_error"] = (
        f"track displaced {float(displacement_nm):g} nm towards {float(bearing_deg):g} deg, "
        f"delayed {float(delay_h):g} h, intensity x{float(intensity_factor):g}"
    )
    return ds


def converging_forecasts(
    storms: Sequence[Storm],
    issue_hours: Sequence[float],
    *,
    converged_h: float,
    displacement_nm: float = 0.0,
    bearing_deg: float = 0.0,
    delay_h: float = 0.0,
    intensity_factor: float = 1.0,
    **dataset_kwargs: Any,
) -> list[tuple[np.datetime64, xr.Dataset]]:
    """Forecasts issued as the voyage goes on, converging on the truth.

    The forecast issued ``h`` hours after the start carries the fraction ``max(0, 1 − h /
    converged_h)`` of the error at ``h = 0``: displacement and delay scale linearly, the intensity
    factor geometrically (``intensity_factor ** fraction``).

    Parameters
    ----------
    storms : sequence of Storm
        The true storms.
    issue_hours : sequence of float
        Issue times [h after ``start``], >= 0.
    converged_h : float
        When the forecasts have converged on the truth [h], > 0.
    displacement_nm, bearing_deg, delay_h, intensity_factor
        The error at h = 0 (:func:`displaced_storms`).
    **dataset_kwargs
        As in :func:`storm_forecast` (``start`` fixes t = 0, default :data:`DEFAULT_START`).

    Returns
    -------
    list of (numpy.datetime64, xarray.Dataset)
        (issue time [UTC], forecast), the form :func:`optroute.simulate_voyage` takes.
    """
    conv = float(finite("converged_h", converged_h, minimum=0.0, strict=True, error=ConfigError))
    hours = finite("issue_hours", issue_hours, minimum=0.0, error=ConfigError).ravel()
    t0 = as_start(dataset_kwargs.get("start"))
    out = []
    for h in hours:
        f = max(0.0, 1.0 - float(h) / conv)
        ds = storm_forecast(
            storms,
            displacement_nm=f * float(displacement_nm),
            bearing_deg=bearing_deg,
            delay_h=f * float(delay_h),
            intensity_factor=float(intensity_factor) ** f,
            **dataset_kwargs,
        )
        ds.attrs["forecast_issued_h"] = float(h)
        out.append((t0 + _h_to_td(float(h)), ds))
    return out
