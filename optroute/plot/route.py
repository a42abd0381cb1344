"""Figures of a passage: the route over a map of significant wave height, and the profile along it.

Drawn offline on bare Agg figures (no pyplot state, no map downloads): land
comes from optroute's own coastline mask (:func:`optroute.geo.land.is_land`)
rasterised over the map, so nothing is fetched at run time.

Antimeridian: the map is drawn in one continuous longitude frame centred on
the first track (a North Pacific crossing from 120° E to 110° W is drawn
from 120 to 250 and labelled 120° E … 180° … 110° W).  The weather's
longitudes are mapped into that frame and sorted, whatever their convention
(−180–180, 0–360 or unwrapped), and every track is unwrapped into it, so no
line or shading jumps across the map.

The helpers here (:class:`Track`, :func:`hs_map`) are shared with
:mod:`optroute.plot.plan`, which draws the same figures for a verified
:class:`~optroute.plan.result.Plan`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from matplotlib import patheffects
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optroute import geodesy as geo
from optroute import units
from optroute.errors import ConfigError
from optroute.geo import land
from optroute.physics.safety import BANDS
from optroute.plot.common import BAND_COLOURS, BAND_LABELS
from optroute.search.route import Route

LAND_COLOUR = "#c9b991"
_GLOBAL_SPAN_DEG = 350.0  # a weather grid at least this wide in longitude is treated as global


@dataclass(frozen=True)
class Track:
    """A passage as the map draws it: positions, times and a one-line summary.

    Attributes
    ----------
    name : str
        Legend name ("optimised plan", "great circle, forced slow-downs").
    lat, lon : numpy.ndarray
        Waypoints [deg]; ``lon`` unwrapped (consecutive values differ by < 180°).
    times : numpy.ndarray of datetime64[ns]
        When the ship passes each waypoint [UTC].
    distance_nm, duration_h, fuel_t : float
        Totals [nm], [h], [t].
    """

    name: str
    lat: np.ndarray
    lon: np.ndarray
    times: np.ndarray
    distance_nm: float
    duration_h: float
    fuel_t: float

    @classmethod
    def of(cls, name: str, passage: Any) -> Track:
        """The track of a :class:`~optroute.search.route.Route` or a :class:`~optroute.plan.result.Plan`.

        Raises
        ------
        ConfigError
            ``passage`` is neither (it needs ``waypoints`` and ``times``).
        """
        if isinstance(passage, Route):
            dist, dur, fuel = passage.total_distance_nm, passage.total_duration_h, passage.total_fuel_t
        elif hasattr(passage, "legs") and hasattr(passage, "duration_h") and hasattr(passage, "waypoints"):
            dist, dur, fuel = float(passage.distance_nm), float(passage.duration_h), float(passage.total_fuel_t)
        else:
            raise ConfigError(
                f"{name!r}: cannot draw a {type(passage).__name__}; give an optroute Route (search_route, "
                "sail_route) or Plan (optimise_corridor)"
            )
        wp = np.asarray(passage.waypoints, dtype=float)
        return cls(
            name,
            wp[:, 0],
            geo.unwrap_lon_deg(wp[:, 1]),
            np.asarray(passage.times, dtype="datetime64[ns]"),
            float(dist),
            float(dur),
            float(fuel),
        )

    def label(self) -> str:
        """Legend text: name, distance [nm], passage time [d h], fuel [t]."""
        return f"{self.name}: {self.distance_nm:,.0f} nm, {fmt_duration(self.duration_h)}, {self.fuel_t:,.0f} t fuel"

    def position_at(self, when: np.datetime64) -> tuple[float, float] | None:
        """(lat, lon) [deg] at ``when`` by linear interpolation between waypoints; None outside the passage."""
        t = (self.times - self.times[0]) / np.timedelta64(1, "s")
        x = (np.datetime64(when, "ns") - self.times[0]) / np.timedelta64(1, "s")
        if not (t[0] <= x <= t[-1]):
            return None
        return float(np.interp(x, t, self.lat)), float(np.interp(x, t, self.lon))


def fmt_duration(hours: float) -> str:
    """``"8 d 8 h"`` for a duration in hours [h]."""
    whole = int(round(float(hours)))
    return f"{whole // 24} d {whole % 24} h"


def lon_label(lon_deg: float) -> str:
    """A longitude [deg, any convention] as a chart label: ``150°E``, ``180°``, ``120°W``."""
    x = ((float(lon_deg) + 180.0) % 360.0) - 180.0
    if abs(abs(x) - 180.0) < 1e-9 or abs(x) < 1e-9:
        return f"{abs(x):.0f}°"
    return f"{abs(x):.0f}°{'E' if x > 0 else 'W'}"


def nearest_time(ds: xr.Dataset, when: Any) -> np.datetime64:
    """The dataset's time step nearest ``when`` [UTC]."""
    times = ds["time"].values
    k = int(np.argmin(np.abs(times - np.datetime64(when, "ns"))))
    return times[k]


def _frame_lon(lon: np.ndarray, centre: float) -> np.ndarray:
    """Longitudes [deg] mapped into [centre − 180, centre + 180)."""
    return ((np.asarray(lon, dtype=float) - centre + 180.0) % 360.0) - 180.0 + centre


def _hs_field(weather: xr.Dataset, t_map: np.datetime64, centre: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lat, lon in the frame, Hs [m]) at one time, lon sorted; a NaN column fills any gap in coverage."""
    hs = weather["hs_m"].sel(time=t_map)
    if "member" in hs.dims:
        hs = hs.isel(member=0)
    hs = hs.transpose("lat", "lon")
    lat = np.asarray(weather["lat"].values, dtype=float)
    values = np.asarray(hs.values, dtype=float)
    if lat[0] > lat[-1]:
        lat, values = lat[::-1], values[::-1]
    lon = _frame_lon(weather["lon"].values, centre)
    order = np.argsort(lon, kind="stable")
    lon, values = lon[order], values[:, order]
    step = np.diff(lon)
    if step.size and np.any(step > 1.5 * np.median(step)):  # regional grid split by the frame's edge
        k = int(np.argmax(step)) + 1
        lon = np.insert(lon, k, 0.5 * (lon[k - 1] + lon[k]))
        values = np.insert(values, k, np.nan, axis=1)
    return lat, lon, values


def hs_map(
    ax: Axes,
    weather: xr.Dataset,
    tracks: Sequence[Track],
    *,
    when: Any = None,
    hs_threshold_m: float | None = None,
    land_resolution_deg: float = 0.25,
) -> np.datetime64:
    """Draw Hs at one time, land, and the tracks (the first in bold) on ``ax``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    weather : xarray.Dataset
        Canonical weather with ``hs_m`` [m].
    tracks : sequence of Track
        At least one; the map's longitude frame is centred on the first.
    when : datetime64, optional
        Map time [UTC]; the weather's nearest time step is drawn.  Default: when the first track is halfway.
    hs_threshold_m : float, optional
        Draw the contour Hs = this value [m] (the danger bands' threshold 0.04 L).
    land_resolution_deg : float
        Raster step of the land shading [deg].

    Returns
    -------
    numpy.datetime64
        The time step drawn [UTC].

    Raises
    ------
    ConfigError
        No track, no ``hs_m`` in the weather, or a non-positive raster step.
    """
    if not tracks:
        raise ConfigError("hs_map needs at least one track to draw")
    if "hs_m" not in weather:
        raise ConfigError("the map needs a canonical weather dataset with hs_m; open it with optroute.open_weather")
    if not (np.isfinite(land_resolution_deg) and land_resolution_deg > 0):
        raise ConfigError(f"land_resolution_deg={land_resolution_deg!r} must be a step > 0 [deg]")
    first = tracks[0]
    if when is None:
        when = first.times[0] + (first.times[-1] - first.times[0]) / 2
    t_map = nearest_time(weather, when)
    centre = 0.5 * (first.lon.min() + first.lon.max())
    lat_w, lon_w, hs = _hs_field(weather, t_map, centre)
    shifted = [(tr, tr.lon + 360.0 * np.round((centre - 0.5 * (tr.lon.min() + tr.lon.max())) / 360.0)) for tr in tracks]
    x0, x1, y0, y1 = _map_view(lat_w, lon_w, shifted, tracks)

    vmax = max(1.0, float(np.nanmax(hs)) if np.isfinite(hs).any() else 1.0)
    mesh = ax.pcolormesh(lon_w, lat_w, hs, shading="auto", cmap="viridis", vmin=0.0, vmax=vmax, rasterized=True)
    ax.figure.colorbar(mesh, ax=ax, label="significant wave height Hs [m]", shrink=0.8, pad=0.02)
    if hs_threshold_m is not None and np.nanmax(hs) >= hs_threshold_m:
        ax.contour(lon_w, lat_w, hs, levels=[hs_threshold_m], colors="red", linewidths=1.0)
        ax.plot([], [], color="red", lw=1.0, label=f"Hs = {hs_threshold_m:.1f} m: the danger bands apply inside")
    if land.coastline_applies(weather, None):
        _draw_land(ax, (x0, x1, y0, y1), float(land_resolution_deg))
    _draw_tracks(ax, shifted, t_map)
    _frame(ax, x0, x1, y0, y1)
    return t_map


def _map_view(lat_w: np.ndarray, lon_w: np.ndarray, shifted: list, tracks: Sequence[Track]) -> tuple[float, ...]:
    """The map's box (x0, x1, y0, y1) [deg]: the weather's, or about the tracks when the weather is global."""
    all_lon = np.concatenate([lo for _, lo in shifted])
    all_lat = np.concatenate([tr.lat for tr in tracks])
    x0, x1 = float(lon_w.min()), float(lon_w.max())
    y0, y1 = float(lat_w.min()), float(lat_w.max())
    if x1 - x0 >= _GLOBAL_SPAN_DEG:
        pad = max(10.0, 0.15 * float(np.ptp(all_lon)))
        x0, x1 = max(x0, all_lon.min() - pad), min(x1, all_lon.max() + pad)
    if y1 - y0 >= 150.0:
        y0, y1 = max(y0, all_lat.min() - 10.0), min(y1, all_lat.max() + 10.0)
    return x0, x1, y0, y1


def _draw_land(ax: Axes, box: tuple[float, ...], step: float) -> None:
    """Shade the land (GLOBE mask) in ``box`` (x0, x1, y0, y1) [deg] on a raster of ``step`` [deg]."""
    x0, x1, y0, y1 = box
    glat = np.arange(y0, y1 + step / 2, step)
    glon = np.arange(x0, x1 + step / 2, step)
    la, lo = np.meshgrid(glat, glon, indexing="ij")
    on_land = land.is_land(la.ravel(), ((lo.ravel() + 180.0) % 360.0) - 180.0).reshape(la.shape)
    if on_land.any():
        ax.contourf(glon, glat, on_land.astype(float), levels=[0.5, 1.5], colors=[LAND_COLOUR])
        ax.contour(glon, glat, on_land.astype(float), levels=[0.5], colors="#6b5d3f", linewidths=0.5)
        ax.fill_between([], [], color=LAND_COLOUR, label="land")


def _draw_tracks(ax: Axes, shifted: list, t_map: np.datetime64) -> None:
    """The tracks (the first in bold white), each ship's position at ``t_map``, the first track's ends."""
    first = shifted[0][0]
    outline = [patheffects.Stroke(linewidth=4.4, foreground="black"), patheffects.Normal()]
    for k, (tr, lon_r) in enumerate(shifted):
        if k == 0:
            style: dict[str, Any] = {"color": "white", "lw": 2.6, "path_effects": outline, "zorder": 4}
        else:
            style = {
                "color": ("#ff7f0e", "#e377c2", "#17becf", "#bcbd22")[(k - 1) % 4],
                "lw": 1.8,
                "ls": "--",
                "zorder": 3,
            }
        ax.plot(lon_r, tr.lat, label=tr.label(), **style)
        pos = tr.position_at(t_map)
        if pos is not None:
            ax.plot(pos[1] + (lon_r[0] - tr.lon[0]), pos[0], "o", color=style["color"], mec="black", ms=8, zorder=6)
    ax.plot(
        shifted[0][1][0],
        first.lat[0],
        marker="^",
        color="white",
        mec="black",
        ms=9,
        ls="none",
        zorder=7,
        label=f"departure {units.format_utc(first.times[0])}",
    )
    ax.plot(
        shifted[0][1][-1],
        first.lat[-1],
        marker="s",
        color="white",
        mec="black",
        ms=8,
        ls="none",
        zorder=7,
        label="arrival",
    )
    ax.plot(
        [],
        [],
        "o",
        color="white",
        mec="black",
        ms=8,
        ls="none",
        label=f"ship positions at the map time {str(t_map)[:16]} UTC",
    )


def _frame(ax: Axes, x0: float, x1: float, y0: float, y1: float) -> None:
    """Limits, aspect (true at the box's mid-latitude), ticks in degrees E/W and N/S, labels, legend."""
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect(1.0 / max(0.2, float(np.cos(np.radians(0.5 * (y0 + y1))))))
    ticks = [t for t in ax.get_xticks() if x0 <= t <= x1]
    ax.set_xticks(ticks)
    ax.set_xticklabels([lon_label(t) for t in ticks])
    yticks = [t for t in ax.get_yticks() if y0 <= t <= y1]
    ax.set_yticks(yticks)
    ax.set_yticklabels([f"{abs(t):.0f}°{'N' if t >= 0 else 'S'}" for t in yticks])
    ax.set_xlabel("longitude")
    ax.set_ylabel("latitude")
    ax.legend(loc="lower left", fontsize=7.5, framealpha=0.9)


def route_map_figure(
    route: Route,
    weather: xr.Dataset,
    *,
    time: Any = None,
    others: Mapping[str, Route] | None = None,
    title: str | None = None,
    land_resolution_deg: float = 0.25,
) -> Figure:
    """The route over a map of significant wave height at one time, with land.

    Parameters
    ----------
    route : Route
        The route drawn in bold, with a dot where the ship is at ``time``.
    weather : xarray.Dataset
        Canonical weather; its ``hs_m`` at the time slice nearest ``time`` is shaded [m].
    time : datetime64, optional
        Map time [UTC]; default the time the ship is halfway.
    others : mapping of str to Route, optional
        More routes to draw dashed, labelled by their keys (the great circle, say).
    title : str, optional
    land_resolution_deg : float
        Raster step of the land shading [deg].

    Returns
    -------
    matplotlib.figure.Figure
    """
    tracks = [Track.of("searched route", route)] + [Track.of(k, r) for k, r in (others or {}).items()]
    fig = Figure(figsize=(12, 5.8), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    t_map = hs_map(ax, weather, tracks, when=time, land_resolution_deg=land_resolution_deg)
    ax.set_title(title or f"Route over significant wave height, {str(t_map)[:16]} UTC")
    return fig


def route_profile_figure(route: Route, *, mcr_kw: float | None = None, title: str | None = None) -> Figure:
    """Speed, power against MCR and the danger-band sides along the passage.

    Parameters
    ----------
    route : Route
        Per-leg values are drawn as steps against elapsed time [h].
    mcr_kw : float, optional
        The engine's MCR [kW], drawn as a limit line.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    t_h = (route.times - route.times[0]) / np.timedelta64(1, "s") / 3600.0
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    ax1.stairs(route.sog_kn, t_h, baseline=None, label="speed over ground SOG", lw=1.8)
    ax1.stairs(route.stw_kn, t_h, baseline=None, label="speed through water STW", lw=1.2, ls="--")
    ax1.set_ylabel("speed [kn]")
    ax1.legend(loc="lower right", fontsize=8)
    ax2.stairs(route.power_kw / 1000.0, t_h, baseline=None, label="brake power", color="C3")
    if mcr_kw is not None:
        ax2.axhline(mcr_kw / 1000.0, color="black", ls=":", label=f"MCR {mcr_kw / 1000:.1f} MW")
    ax2.set_ylabel("power [MW]")
    ax2.legend(loc="lower right", fontsize=8)
    for k, band in enumerate(BANDS):
        side = np.asarray(route.band_side.get(band, np.zeros(len(route.sog_kn))), dtype=float)
        ax3.stairs(side + 0.08 * (k - 1.5), t_h, baseline=None, color=BAND_COLOURS[band], label=BAND_LABELS[band])
    ax3.set_yticks([-1, 0, 1])
    ax3.set_yticklabels(["below band", "not applying", "above band"])
    ax3.set_xlabel("time since departure [h]")
    ax3.legend(loc="lower right", fontsize=7, ncol=2)
    fig.suptitle(
        title
        or f"Passage profile: {route.total_distance_nm:,.0f} nm in {fmt_duration(route.total_duration_h)}, "
        f"{route.total_fuel_t:,.0f} t fuel"
    )
    return fig
