"""The voyage log: the track sailed and every plan made, as one ``xarray.Dataset``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from optroute.physics.safety import BANDS, BandRules
from optroute.plan.result import Plan
from optroute.voyage.policy import ForecastSequence

__all__ = ["StepRecord", "replan_record", "voyage_dataset"]

_STEP_UNITS = {
    "lat": ("degrees_north", "latitude at the start of the step"),
    "lon": ("degrees_east", "longitude at the start of the step"),
    "duration_h": ("h", "step duration"),
    "distance_nm": ("nmi", "distance made good over ground"),
    "commanded_stw_kn": ("kn", "speed through water of the plan's leg"),
    "stw_kn": ("kn", "speed through water sailed (Boeing speed reduction in the truth)"),
    "sog_kn": ("kn", "speed over ground"),
    "heading_deg": ("degree", "heading crabbed against the current, true, to"),
    "power_kw": ("kW", "brake power, true performance model"),
    "fuel_t": ("t", "fuel burnt in the step, true performance model"),
    "hs_m": ("m", "significant wave height met in the truth (step midpoint)"),
    "period_s": ("s", "wave period of the bands met in the truth"),
    "wave_from_deg": ("degree", "mean wave direction met in the truth, true, from"),
}


@dataclass(frozen=True)
class StepRecord:
    """One simulator step: where and when it started, what the ship did and met (sea at the step midpoint)."""

    time: np.datetime64
    lat: float
    lon: float
    duration_h: float
    distance_nm: float
    commanded_stw_kn: float
    leg: int
    end: np.ndarray = field(repr=False)
    reached: bool
    stw_kn: float
    sog_kn: float
    heading_deg: float
    power_kw: float
    fuel_tph: float
    hs_m: float
    period_s: float
    wave_from_deg: float
    in_band: bool
    band_met: bool
    slowed: bool
    margins: dict[str, float]
    rl_max: float = float("nan")
    roll_max_deg: float = float("nan")
    observer_alarm: bool = False
    intervention: bool = False


def replan_record(
    plan: Plan | None,
    reason: str,
    status: str,
    when: np.datetime64,
    forecast_index: int | None,
    forecasts: ForecastSequence,
    earliest: Any,
) -> dict[str, Any]:
    """One row of the log's ``replan`` dimension (``plan`` None: the re-plan failed; the ship kept its plan)."""
    issued = forecasts.issue_times[forecast_index] if forecast_index is not None else np.datetime64("NaT", "ns")
    nat = np.datetime64("NaT", "ns")
    return {
        "time": when,
        "reason": reason,
        "status": status,
        "forecast_index": -1 if forecast_index is None else int(forecast_index),
        "forecast_issued": issued,
        "fuel_t": float("nan") if plan is None else plan.total_fuel_t,
        "arrival": nat if plan is None else plan.arrival,
        "earliest_arrival": nat if earliest is None else np.datetime64(earliest, "ns"),
        "waypoints": np.zeros((0, 2)) if plan is None else np.asarray(plan.waypoints),
        "waypoint_times": np.zeros(0, dtype="datetime64[ns]") if plan is None else np.asarray(plan.times),
    }


def voyage_dataset(
    records: list[StepRecord], replans: list[dict[str, Any]], rules: BandRules, *, observed: bool = False
) -> xr.Dataset:
    """The log: ``step`` variables (track, speeds, power, fuel, sea and band margins met) and ``replan`` variables.

    With ``observed`` (the onboard parametric-roll observer ran, :mod:`optroute.voyage.onboard`)
    the steps also carry ``rl_max`` (the highest resonance level RL observed), ``roll_max_deg``
    (the largest simulated roll), ``observer_alarm`` (RL reached the threshold; the step ends at
    the alarm) and ``intervention`` (sailed at the intervention's speed).

    Band margins are :func:`optroute.physics.safety.band_margins` at the speed sailed (> 0 outside
    the band, in the band's ratio units, ``inf`` where it does not apply); ``in_band`` marks steps
    sailed inside an enforced band, ``slowed`` those where the Boeing speed reduction acted.
    """
    data: dict[str, Any] = {}
    data["step_time"] = ("step", np.array([r.time for r in records], dtype="datetime64[ns]"))
    for name, (unit, long) in _STEP_UNITS.items():
        if name == "fuel_t":
            values = [r.fuel_tph * r.duration_h for r in records]
        else:
            values = [getattr(r, name) for r in records]
        data[name] = ("step", np.array(values, dtype=float), {"units": unit, "long_name": long})
    data["leg"] = ("step", np.array([r.leg for r in records], dtype=np.int32))
    data["in_band"] = ("step", np.array([r.in_band for r in records], dtype=np.int8), {"long_name": "inside a band"})
    data["band_met"] = (
        "step",
        np.array([r.band_met for r in records], dtype=np.int8),
        {"long_name": "the plan's speed lies inside a band of the truth (heading of the course)"},
    )
    data["slowed"] = ("step", np.array([r.slowed for r in records], dtype=np.int8), {"long_name": "speed reduced"})
    if observed:
        data["rl_max"] = ("step", np.array([r.rl_max for r in records]), {"units": "1", "long_name": "highest RL"})
        data["roll_max_deg"] = (
            "step",
            np.array([r.roll_max_deg for r in records]),
            {"units": "degree", "long_name": "largest roll angle of the simulated motions (no noise)"},
        )
        for name, long in (
            ("observer_alarm", "RL reached the observer's threshold (the step ends at the alarm)"),
            ("intervention", "sailed at the speed of the observer's intervention"),
        ):
            data[name] = ("step", np.array([getattr(r, name) for r in records], dtype=np.int8), {"long_name": long})
    for band in BANDS:
        vals = np.array([r.margins.get(band, np.inf) for r in records], dtype=float)
        data[f"margin_{band}"] = ("step", vals, {"units": "1", "long_name": f"margin to the {band} band"})
    n_wp = max((rp["waypoints"].shape[0] for rp in replans), default=0)
    wlat = np.full((len(replans), n_wp), np.nan)
    wlon = np.full((len(replans), n_wp), np.nan)
    wtime = np.full((len(replans), n_wp), np.datetime64("NaT", "ns"), dtype="datetime64[ns]")
    for i, rp in enumerate(replans):
        m = rp["waypoints"].shape[0]
        wlat[i, :m], wlon[i, :m], wtime[i, :m] = rp["waypoints"][:, 0], rp["waypoints"][:, 1], rp["waypoint_times"]
    data["replan_time"] = ("replan", np.array([rp["time"] for rp in replans], dtype="datetime64[ns]"))
    data["replan_reason"] = ("replan", np.array([rp["reason"] for rp in replans], dtype=str))
    data["replan_status"] = ("replan", np.array([rp["status"] for rp in replans], dtype=str))
    data["replan_forecast_index"] = ("replan", np.array([rp["forecast_index"] for rp in replans], dtype=np.int32))
    data["replan_forecast_issued"] = ("replan", np.array([rp["forecast_issued"] for rp in replans], "datetime64[ns]"))
    data["replan_fuel_t"] = ("replan", np.array([rp["fuel_t"] for rp in replans]), {"units": "t"})
    data["replan_arrival"] = ("replan", np.array([rp["arrival"] for rp in replans], dtype="datetime64[ns]"))
    data["replan_earliest_arrival"] = (
        "replan",
        np.array([rp["earliest_arrival"] for rp in replans], dtype="datetime64[ns]"),
    )
    data["replan_waypoint_lat"] = (("replan", "replan_waypoint"), wlat, {"units": "degrees_north"})
    data["replan_waypoint_lon"] = (("replan", "replan_waypoint"), wlon, {"units": "degrees_east"})
    data["replan_waypoint_time"] = (("replan", "replan_waypoint"), wtime)
    if any("cyclone_track" in rp for rp in replans):
        data["replan_cyclone_track"] = (
            "replan",
            np.array([rp.get("cyclone_track", -1) for rp in replans], dtype=np.int32),
            {"long_name": "index of the cyclone forecast track the plan kept out of (-1: the true track)"},
        )
    ds = xr.Dataset(data)
    ds.attrs["title"] = "optroute simulated voyage log"
    ds.attrs["band_rules"] = rules.rule_set
    ds.attrs["enabled_bands"] = ",".join(rules.enabled_bands)
    return ds
