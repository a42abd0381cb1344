"""Figure of a simulated voyage: the track sailed over time with the re-plans marked.

Takes the voyage log (:func:`optroute.simulate_voyage`'s ``log``, an ``xarray.Dataset``) only, so
this module sits below the simulator in the layers. Top: the track (lon, lat) coloured by time,
each plan's waypoints as a thin line and the point of every re-plan marked; below, against time:
the speed through water sailed and commanded by the plan [kn] with the steps inside a danger band
shaded, and the H_s met in the truth [m]; vertical lines at the re-plans.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optroute.errors import ConfigError

__all__ = ["voyage_figure"]


def _hours(t: np.ndarray, t0: np.datetime64) -> np.ndarray:
    return (np.asarray(t, dtype="datetime64[ns]") - t0) / np.timedelta64(1, "h")


def voyage_figure(log: xr.Dataset, *, title: str | None = None) -> Figure:
    """The track sailed, the plans and the re-plans of a voyage log.

    Parameters
    ----------
    log : xarray.Dataset
        A voyage log (variables ``step_time``, ``lat``, ``lon``, ``stw_kn``, ``commanded_stw_kn``,
        ``hs_m``, ``in_band`` on ``step``; ``replan_time``, ``replan_waypoint_lat``/``_lon`` on
        ``replan``).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    need = ("step_time", "lat", "lon", "stw_kn", "commanded_stw_kn", "hs_m", "in_band", "replan_time")
    missing = [v for v in need if v not in log]
    if missing or log.sizes.get("step", 0) == 0:
        raise ConfigError(f"voyage_figure: not a voyage log with steps (missing {missing}); pass simulate_voyage().log")
    t = log["step_time"].values
    t0 = t[0]
    h = _hours(t, t0)
    rh = _hours(log["replan_time"].values, t0)
    fig = Figure(figsize=(9.0, 9.0))
    FigureCanvasAgg(fig)
    ax_map, ax_v, ax_hs = fig.subplots(3, 1, gridspec_kw={"height_ratios": [2.2, 1.0, 1.0]})
    for k in range(log.sizes.get("replan", 0)):
        wl, wo = log["replan_waypoint_lat"].values[k], log["replan_waypoint_lon"].values[k]
        ok = np.isfinite(wl) & np.isfinite(wo)
        if ok.any():
            ax_map.plot(wo[ok], wl[ok], lw=0.8, alpha=0.6, label=f"plan {k} ({rh[k]:+.1f} h)")
    sc = ax_map.scatter(log["lon"].values, log["lat"].values, c=h, s=8, cmap="viridis", zorder=3)
    inside = log["in_band"].values.astype(bool)
    if inside.any():
        ax_map.scatter(log["lon"].values[inside], log["lat"].values[inside], s=30, facecolors="none",
                       edgecolors="red", zorder=4, label="inside a danger band")  # fmt: skip
    idx = np.clip(np.searchsorted(h, rh), 0, h.size - 1)
    ax_map.scatter(log["lon"].values[idx], log["lat"].values[idx], marker="x", c="k", s=60, zorder=5, label="re-plan")
    fig.colorbar(sc, ax=ax_map, label="hours since departure")
    ax_map.set_xlabel("longitude [deg]")
    ax_map.set_ylabel("latitude [deg]")
    ax_map.legend(fontsize=7, loc="best")
    ax_v.step(h, log["commanded_stw_kn"].values, where="post", lw=1.0, ls="--", label="plan's STW")
    ax_v.step(h, log["stw_kn"].values, where="post", lw=1.2, label="STW sailed")
    ax_v.set_ylabel("speed [kn]")
    ax_hs.plot(h, log["hs_m"].values, lw=1.2, color="tab:blue")
    ax_hs.set_ylabel("Hs met [m]")
    ax_hs.set_xlabel("hours since departure")
    dur = np.append(np.diff(h), 0.0)
    for ax in (ax_v, ax_hs):
        for x in rh:
            ax.axvline(x, color="k", lw=0.8, ls=":")
        for i in np.flatnonzero(inside):
            ax.axvspan(h[i], h[i] + dur[i], color="red", alpha=0.15, lw=0)
    ax_v.legend(fontsize=7, loc="best")
    fig.suptitle(title or "simulated voyage: track, plans and re-plans")
    fig.tight_layout()
    return fig
