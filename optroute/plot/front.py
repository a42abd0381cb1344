"""The fuel-versus-ETA front as a figure: :func:`front_figure`, and its knee (:func:`knee_index`).

Works on what :func:`optroute.studies.tradeoff` returns and on the same front read
back from NetCDF (``xarray.open_dataset``): it reads only the variables
``eta_h`` [h after departure], ``fuel_t`` [t], ``status`` and, when present,
``eta_shadow_price_t_per_h`` [t/h].  Drawn on a bare Agg
:class:`~matplotlib.figure.Figure`, so no pyplot state or display is needed;
write it with :func:`optroute.plot.common.save_png`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from optroute.errors import ConfigError

if TYPE_CHECKING:  # matplotlib loads when a figure is drawn, not with the tradeoff that imports knee_index
    from matplotlib.figure import Figure

__all__ = ["front_figure", "knee_index"]


def knee_index(eta_h: ArrayLike, fuel_t: ArrayLike) -> int | None:
    """The knee of a falling front: where the extra hours stop buying much fuel.

    The "Kneedle" rule of Satopää et al. (2011, ICDCS Workshops, "Finding a
    'kneedle' in a haystack"): both axes scaled to [0, 1] between the first
    and last points, the knee is the point farthest below the chord joining
    them.

    Parameters
    ----------
    eta_h : array_like
        ETAs [h], ascending.
    fuel_t : array_like
        Fuel at each ETA [t].

    Returns
    -------
    int or None
        Index of the knee; None with fewer than three points, a flat front,
        or no point below the chord.
    """
    x = np.asarray(eta_h, dtype=float)
    y = np.asarray(fuel_t, dtype=float)
    if x.size < 3 or x[-1] <= x[0] or y[0] == y[-1]:
        return None
    xs = (x - x[0]) / (x[-1] - x[0])
    ys = (y - y[-1]) / (y[0] - y[-1])  # 1 at the fast end, 0 at the slow end
    below = (1.0 - xs) - ys  # the chord runs from (0, 1) to (1, 0)
    k = int(np.argmax(below))
    return k if below[k] > 0 else None


def front_figure(front: xr.Dataset, *, title: str | None = None) -> Figure:
    """Fuel [t] against ETA [h after departure], with the knee and the ETA shadow price.

    Parameters
    ----------
    front : xarray.Dataset
        A :func:`optroute.studies.tradeoff` front (or one read back from NetCDF).
    title : str, optional
        Default: the ship, the objective and the number of points.

    Returns
    -------
    matplotlib.figure.Figure
        Solved points as a line with markers (points served by an earlier ETA's plan as
        red squares), ETAs without a plan as crosses along the bottom axis,
        the knee circled and annotated, and the shadow price −dF/dETA [t/h]
        on the right axis.

    Raises
    ------
    ConfigError
        ``front`` lacks ``fuel_t``, ``status`` or ``eta_h``.
    """
    missing = [v for v in ("fuel_t", "status", "eta_h") if v not in front.variables]
    if missing:
        raise ConfigError(f"front_figure: the dataset lacks {missing}; pass what optroute.studies.tradeoff returns")
    eta_h = np.asarray(front["eta_h"].values, dtype=float)
    fuel = np.asarray(front["fuel_t"].values, dtype=float)
    status = np.asarray(front["status"].values).astype(str)
    ok = np.isfinite(fuel)
    flagged = ok & (np.char.find(status, "the plan of the earlier ETA") >= 0)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 5.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    handles: list[Any] = []
    handles += ax.plot(eta_h[ok], fuel[ok], "o-", color="C0", ms=4, lw=1.6, label="least fuel arriving by the ETA")
    if flagged.any():
        handles += ax.plot(
            eta_h[flagged],
            fuel[flagged],
            "s",
            color="tab:red",
            ms=7,
            mfc="none",
            label="an earlier ETA's plan (own solves rose)",
        )
    if (~ok).any():
        lo = float(np.nanmin(fuel)) if ok.any() else 0.0
        handles += ax.plot(
            eta_h[~ok],
            np.full((~ok).sum(), lo),
            "x",
            color="tab:gray",
            ms=8,
            mew=2,
            clip_on=False,
            label="no plan (infeasible / solver failure)",
        )
    k = knee_index(eta_h[ok], fuel[ok])
    if k is not None:
        xk, yk = eta_h[ok][k], fuel[ok][k]
        handles += ax.plot([xk], [yk], "o", ms=13, mfc="none", mec="tab:green", mew=2, label="knee")
        ax.annotate(
            f"knee: {xk:.1f} h, {yk:,.1f} t", (xk, yk), xytext=(12, 12), textcoords="offset points", color="tab:green"
        )
    ax.set_xlabel("ETA [h after departure]")
    ax.set_ylabel("fuel [t]")
    ax.grid(True, alpha=0.3)
    if "eta_shadow_price_t_per_h" in front.variables:
        price = np.asarray(front["eta_shadow_price_t_per_h"].values, dtype=float)
        has = ok & np.isfinite(price)
        if has.any():
            ax2 = ax.twinx()
            handles += ax2.plot(
                eta_h[has], price[has], "^--", color="C1", ms=4, lw=1.0, label="shadow price −dF/dETA [t/h]"
            )
            ax2.set_ylabel("ETA shadow price [t/h]", color="C1")
            ax2.set_ylim(bottom=0.0)
    ax.legend(handles=handles, loc="upper right", fontsize=8)
    ship = front.attrs.get("ship", "")
    objective = front.attrs.get("objective", "fuel")
    fig.suptitle(
        title
        or f"Fuel versus ETA{f' — {ship}' if ship else ''} ({objective} objective, "
        f"{int(ok.sum())} of {eta_h.size} ETAs solved)"
    )
    return fig
