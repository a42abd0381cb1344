"""Figures of a verified :class:`~optroute.plan.result.Plan`: the passage profile and the route over the sea state.

* :func:`plan_profile_figure` — along the passage (against distance sailed or
  time since departure): speed over ground and through the water, brake
  power against the MCR and the minimum load, the significant wave height
  against the danger bands' threshold 0.04 L, and the margin to each danger
  band (0 = the band's edge, below 0 inside it).
* :func:`plan_map_figure` — the plan over a map of significant wave height at
  a chosen time, with land, optionally beside a baseline (the great circle
  with forced slow-downs, another plan).

Every quantity drawn is the plan's own leg table (:attr:`Plan.legs`, the
true ship model on a dense resampling of each leg), drawn as steps: one
value per leg.  Figures are bare Agg :class:`~matplotlib.figure.Figure`
objects (no pyplot state, no display, no downloads); write them with
:func:`optroute.plot.common.save_png`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optroute.errors import ConfigError
from optroute.physics.safety import BANDS
from optroute.plot.common import BAND_COLOURS, BAND_LABELS
from optroute.plot.route import Track, fmt_duration, hs_map
from optroute.search.route import Route

if TYPE_CHECKING:  # the plot layer sits below the plan layer: plans are drawn, never built here
    from optroute.plan.result import Plan

__all__ = ["plan_map_figure", "plan_profile_figure"]


def _is_plan(obj: Any) -> bool:
    """Whether ``obj`` is an optroute Plan (its leg table and referee), without importing the plan layer."""
    return type(obj).__name__ == "Plan" and hasattr(obj, "legs") and callable(getattr(obj, "verify", None))


def _check_plan(plan: Any, what: str) -> Plan:
    if not _is_plan(plan):
        raise ConfigError(
            f"{what} needs an optroute Plan (optimise_corridor, plan_voyage, Plan.from_schedule), "
            f"got {type(plan).__name__}"
        )
    return plan


def _interp(x: Any, xp: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """Piecewise-linear map through (xp, fp), extended linearly beyond its ends (for secondary axes).

    ``np.interp`` alone clamps, which would pile the secondary axis's ticks beyond the passage on
    its last point with wrong labels.
    """
    x = np.asarray(x, dtype=float)
    slope = (fp[-1] - fp[0]) / (xp[-1] - xp[0])
    y = np.interp(x, xp, fp)
    return np.where(x < xp[0], fp[0] + (x - xp[0]) * slope, np.where(x > xp[-1], fp[-1] + (x - xp[-1]) * slope, y))


def plan_profile_figure(plan: Plan, *, title: str | None = None, x: Literal["time", "distance"] = "time") -> Figure:
    """The profile along the passage: speed, power, Hs and the margin to every danger band.

    Parameters
    ----------
    plan : Plan
        A plan; its :attr:`~Plan.legs` are drawn one step per leg.
    title : str, optional
        Default: distance [nm], passage time, fuel [t] and status.
    x : {"time", "distance"}
        Horizontal axis: time since departure [h] (with the distance sailed along the top) or
        distance sailed [nm] (with the days since departure along the top).

    Returns
    -------
    matplotlib.figure.Figure
        Four panels sharing the horizontal axis:

        1. speed over ground (SOG) and through the water (STW) [kn];
        2. brake power [MW] against the MCR and, when the ship has one, the minimum load, with a
           right-hand axis in % MCR;
        3. significant wave height Hs [m] (time mean over the leg) against the danger bands'
           threshold ``rules.hs_threshold_fraction`` × L (0.04 L by default: the bands apply above it);
        4. the smallest margin to each danger band on the leg (:func:`optroute.physics.safety.band_margins`,
           the signed distance of the band's ratio to the band's edge, ratio units: > 0 clear,
           0 on the edge, < 0 inside); legs where a band does not apply are left blank.

    Raises
    ------
    ConfigError
        ``plan`` is not a :class:`Plan` or ``x`` is unknown.
    """
    plan = _check_plan(plan, "plan_profile_figure")
    if x not in ("distance", "time"):
        raise ConfigError(f"x={x!r} is not known; use 'distance' (sailed [nm]) or 'time' (since departure [h])")
    legs = plan.legs
    ship, rules = plan.context.ship, plan.context.rules
    dist_nm = np.concatenate([[0.0], np.cumsum(legs["distance_nm"].to_numpy(dtype=float))])
    time_h = (plan.times - plan.times[0]) / np.timedelta64(1, "s") / 3600.0
    edges = dist_nm if x == "distance" else time_h

    fig = Figure(figsize=(11, 10), layout="constrained")
    FigureCanvasAgg(fig)
    ax_v, ax_p, ax_h, ax_m = fig.subplots(4, 1, sharex=True, height_ratios=[1.0, 1.0, 0.9, 1.2])

    _speed_panel(ax_v, legs, edges, x, dist_nm, time_h)
    _power_panel(ax_p, legs, edges, ship)
    threshold_m = _sea_panel(ax_h, legs, edges, ship, rules)
    _margin_panel(ax_m, legs, edges, rules, threshold_m)
    ax_m.set_xlabel("distance sailed [nm]" if x == "distance" else "time since departure [h]")
    ax_m.set_xlim(edges[0], edges[-1])

    fig.suptitle(
        title
        or f"Passage profile: {plan.distance_nm:,.0f} nm in {fmt_duration(plan.duration_h)}, "
        f"{plan.total_fuel_t:,.0f} t fuel ({plan.status}); {getattr(ship, 'name', 'ship')}, "
        f"{rules.rule_set} danger bands"
    )
    return fig


def _speed_panel(ax_v, legs, edges: np.ndarray, x: str, dist_nm: np.ndarray, time_h: np.ndarray) -> None:
    """Panel 1: SOG and STW [kn] per leg, the other of distance [nm] and days [d] along the top."""
    ax_v.stairs(
        legs["sog_kn"].to_numpy(dtype=float), edges, baseline=None, lw=2.0, color="C0", label="speed over ground (SOG)"
    )
    ax_v.stairs(
        legs["stw_kn"].to_numpy(dtype=float),
        edges,
        baseline=None,
        lw=1.3,
        ls="--",
        color="C1",
        label="speed through the water (STW)",
    )
    top_kn = float(np.nanmax(legs[["sog_kn", "stw_kn"]].to_numpy(dtype=float)))
    ax_v.set_ylim(0.0, 1.12 * max(top_kn, 1.0))
    ax_v.set_ylabel("speed [kn]")
    ax_v.legend(loc="lower left", fontsize=8, ncols=2)
    if x == "distance":
        top = ax_v.secondary_xaxis(
            "top",
            functions=(lambda d: _interp(d, dist_nm, time_h) / 24.0, lambda t: _interp(t * 24.0, time_h, dist_nm)),
        )
        top.set_xlabel("days since departure [d]")
    else:
        top = ax_v.secondary_xaxis(
            "top", functions=(lambda t: _interp(t, time_h, dist_nm), lambda d: _interp(d, dist_nm, time_h))
        )
        top.set_xlabel("distance sailed [nm]")


def _power_panel(ax_p, legs, edges: np.ndarray, ship) -> None:
    """Panel 2: brake power [MW] against the MCR and the minimum load, % MCR on the right."""
    mcr_mw = ship.mcr_kw / 1000.0
    ax_p.stairs(
        legs["power_kw"].to_numpy(dtype=float) / 1000.0,
        edges,
        baseline=None,
        color="C3",
        lw=1.8,
        label="brake power (leg mean)",
    )
    ax_p.axhline(mcr_mw, color="black", ls="-", lw=1.2, label=f"MCR {mcr_mw:.1f} MW")
    if ship.min_power_kw > 0:
        ax_p.axhline(
            ship.min_power_kw / 1000.0,
            color="black",
            ls=":",
            lw=1.2,
            label=f"minimum load {ship.min_power_kw / 1000:.1f} MW ({100 * ship.min_load_fraction:.0f} % MCR)",
        )
    ax_p.set_ylim(0.0, 1.08 * mcr_mw)
    ax_p.set_ylabel("power [MW]")
    right = ax_p.secondary_yaxis("right", functions=(lambda p: 100.0 * p / mcr_mw, lambda q: q * mcr_mw / 100.0))
    right.set_ylabel("[% MCR]")
    ax_p.legend(loc="lower left", fontsize=8, ncols=3)


def _sea_panel(ax_h, legs, edges: np.ndarray, ship, rules) -> float:
    """Panel 3: Hs [m] (leg mean) against the bands' threshold; returns that threshold [m]."""
    hs = legs["hs_m"].to_numpy(dtype=float)
    threshold_m = rules.hs_threshold_fraction * ship.length_m
    ax_h.stairs(hs, edges, baseline=0.0, fill=True, color="C0", alpha=0.35, label="Hs (leg mean)")
    ax_h.axhline(
        threshold_m,
        color="red",
        ls="--",
        lw=1.2,
        label=f"{rules.hs_threshold_fraction:g} L = {threshold_m:.1f} m: the danger bands apply above",
    )
    ax_h.set_ylim(0.0, 1.15 * max(threshold_m, float(np.nanmax(hs)) if np.isfinite(hs).any() else 0.0))
    ax_h.set_ylabel("Hs [m]")
    ax_h.legend(loc="upper left", fontsize=8, ncols=2)
    return threshold_m


def _margin_panel(ax_m, legs, edges: np.ndarray, rules, threshold_m: float) -> None:
    """Panel 4: the smallest margin to each danger band per leg [ratio units], blank where a band does not apply."""
    finite_margins: list[np.ndarray] = []
    for band in BANDS:
        col = f"margin_{band}"
        if col not in legs.columns:
            continue
        m = legs[col].to_numpy(dtype=float)
        shown = np.where(np.isfinite(m), m, np.nan)
        if not np.isfinite(shown).any():
            continue
        ax_m.stairs(shown, edges, baseline=None, color=BAND_COLOURS[band], lw=1.6, label=BAND_LABELS[band])
        finite_margins.append(shown)
    lowest = min([0.0] + [float(np.nanmin(m)) for m in finite_margins])
    ax_m.axhline(0.0, color="black", lw=1.0, label="band edge (margin 0)")
    ax_m.axhspan(min(-0.05, 1.3 * lowest), 0.0, color="red", alpha=0.08, label="inside the band: forbidden")
    if not finite_margins:
        ax_m.set_ylim(-0.25, 1.0)
        ax_m.text(
            0.5,
            0.55,
            f"no danger band applies on any leg: Hs stays below "
            f"{rules.hs_threshold_fraction:g} L = {threshold_m:.1f} m",
            transform=ax_m.transAxes,
            ha="center",
            va="center",
            fontsize=10,
            bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "grey"},
        )
    else:
        highest = max(float(np.nanmax(m)) for m in finite_margins)
        ax_m.set_ylim(min(-0.05, 1.3 * lowest), max(0.25, min(1.5, 1.1 * highest)))
    ax_m.set_ylabel("margin to band\n[ratio units, > 0 clear]")
    ax_m.legend(loc="upper left", fontsize=7.5, ncols=3)


def plan_map_figure(
    plan: Plan,
    weather: xr.Dataset,
    *,
    when: Any = None,
    title: str | None = None,
    compare: Route | Plan | Mapping[str, Route | Plan] | None = None,
    land_resolution_deg: float = 0.25,
) -> Figure:
    """The plan over a map of significant wave height at one time, with land and a baseline.

    Parameters
    ----------
    plan : Plan
        Drawn in bold white, with a dot where the ship is at the map time.
    weather : xarray.Dataset
        Canonical weather; ``hs_m`` [m] at the time step nearest ``when`` is shaded, and the
        contour Hs = 0.04 L (the plan's band threshold) is drawn in red where the sea reaches it.
    when : datetime64 or str, optional
        Map time [UTC]; default when the ship is halfway.
    title : str, optional
    compare : Route, Plan or mapping of str to Route or Plan, optional
        Baselines drawn dashed with their own dots at the map time; a bare Route or Plan is
        labelled "baseline".
    land_resolution_deg : float
        Raster step of the land shading [deg] (the coastline is optroute's offline land mask).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ConfigError
        ``plan`` is not a :class:`Plan`, a baseline is neither a Route nor a Plan, or the weather
        has no ``hs_m``.
    """
    plan = _check_plan(plan, "plan_map_figure")
    if compare is None:
        others: dict[str, Any] = {}
    elif isinstance(compare, Mapping):
        others = dict(compare)
    else:
        others = {"baseline": compare}
    tracks = [Track.of("optimised plan", plan)] + [Track.of(str(k), v) for k, v in others.items()]
    rules, ship = plan.context.rules, plan.context.ship
    fig = Figure(figsize=(12, 5.8), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    t_map = hs_map(
        ax,
        weather,
        tracks,
        when=None if when is None else np.datetime64(when, "ns"),
        hs_threshold_m=rules.hs_threshold_fraction * ship.length_m,
        land_resolution_deg=land_resolution_deg,
    )
    ax.set_title(title or f"Voyage plan over significant wave height at {str(t_map)[:16]} UTC")
    return fig
