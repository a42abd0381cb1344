"""Figures of a passage: the route over a map of significant wave height, and the profile along it.

Drawn offline on bare Agg figures (no pyplot state, no map downloads): land
comes from optroute's own coastline mask (:func:`optroute.land.is_land`)
rasterised over the map, so nothing is fetched at run time.  Longitudes are
unwrapped so a Pacific crossing stays one piece.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from matplotlib import patheffects
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from optroute import geo, land
from optroute.errors import ConfigError
from optroute.plot import BAND_COLOURS, BAND_LABELS
from optroute.route import Route
from optroute.safety import BANDS


def _nearest_time(ds: xr.Dataset, when: Any) -> np.datetime64:
    times = ds["time"].values
    k = int(np.argmin(np.abs(times - np.datetime64(when, "ns"))))
    return times[k]


def route_map_figure(
    route: Route,
    weather: xr.Dataset,
    *,
    time: Any = None,
    others: dict[str, Route] | None = None,
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
    others : dict of str to Route, optional
        More routes to draw thinly, labelled by their keys (the great circle, say).
    title : str, optional
    land_resolution_deg : float
        Raster step of the land shading [deg].

    Returns
    -------
    matplotlib.figure.Figure
    """
    if "hs_m" not in weather:
        raise ConfigError("route_map_figure needs a canonical dataset with hs_m; open it with optroute.open_weather")
    when = route.times[len(route.times) // 2] if time is None else np.datetime64(time, "ns")
    t_map = _nearest_time(weather, when)
    hs = weather["hs_m"].sel(time=t_map)
    if "member" in hs.dims:
        hs = hs.isel(member=0)
    lat_w = weather["lat"].values
    lon_w = geo.unwrap_lon_deg(weather["lon"].values)
    routes = {"optimised": route, **(others or {})}
    lo_all = np.concatenate([geo.unwrap_lon_deg(r.waypoints[:, 1]) for r in routes.values()])
    shift = 360.0 * np.round((lon_w.mean() - lo_all.mean()) / 360.0)

    fig = Figure(figsize=(11, 6.5))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    mesh = ax.pcolormesh(lon_w, lat_w, np.asarray(hs.values, dtype=float), shading="auto", cmap="viridis",
                         vmin=0.0, vmax=max(1.0, float(np.nanmax(hs.values))))
    fig.colorbar(mesh, ax=ax, label="significant wave height Hs [m]", shrink=0.85)
    step = float(land_resolution_deg)
    glat = np.arange(lat_w.min(), lat_w.max() + step / 2, step)
    glon = np.arange(lon_w.min(), lon_w.max() + step / 2, step)
    la, lo = np.meshgrid(glat, glon, indexing="ij")
    if weather.attrs.get("geography") != land.SYNTHETIC_GEOGRAPHY:
        is_land = land.is_land(la.ravel(), geo.unwrap_lon_deg(lo.ravel()) - 0.0).reshape(la.shape)
        ax.pcolormesh(glon, glat, np.where(is_land, 1.0, np.nan), shading="auto",
                      cmap=ListedColormap(["#b8a98a"]), vmin=0, vmax=1)
    for k, (name, r) in enumerate(routes.items()):
        lon_r = geo.unwrap_lon_deg(r.waypoints[:, 1]) + shift
        outline = [patheffects.Stroke(linewidth=4.2, foreground="black"), patheffects.Normal()]
        style = dict(color="white", lw=2.6, path_effects=outline) if k == 0 else dict(color=f"C{k}", lw=1.4, ls="--")
        hours = r.total_duration_h
        ax.plot(lon_r, r.waypoints[:, 0], label=f"{name}: {r.total_distance_nm:,.0f} nm, {hours / 24:.2f} d, "
                f"{r.total_fuel_t:,.0f} t", **style)
        pos = np.searchsorted(r.times, t_map)
        if 0 < pos < len(r.times):
            ax.plot(lon_r[pos], r.waypoints[pos, 0], "o", color=style["color"], mec="black", ms=7, zorder=5)
    ax.plot([], [], "o", color="white", mec="black", label=f"ship position at the map time {str(t_map)[:16]} UTC")
    ax.set_xlim(lon_w.min(), lon_w.max())
    ax.set_ylim(lat_w.min(), lat_w.max())
    ticks = ax.get_xticks()
    ax.set_xticks(ticks)
    ax.set_xticklabels([f"{((t + 180) % 360) - 180:.0f}°" for t in ticks])
    ax.set_xlabel("longitude [deg E]")
    ax.set_ylabel("latitude [deg N]")
    ax.set_title(title or f"Route over significant wave height, {str(t_map)[:16]} UTC")
    ax.legend(loc="lower left", fontsize=8, framealpha=0.85)
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
    fig = Figure(figsize=(11, 7.5))
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
    fig.suptitle(title or f"Passage profile: {route.total_distance_nm:,.0f} nm in {route.total_duration_h:.1f} h, "
                 f"{route.total_fuel_t:,.0f} t fuel")
    return fig
