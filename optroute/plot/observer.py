"""The resonance observer's figure: motions, criteria K1–K5 and the resonance level RL over time.

Drawn on a bare Agg :class:`~matplotlib.figure.Figure` (no pyplot state, no
display); write it with :func:`optroute.plot.common.save_png`.  Panels, top to
bottom: heave z [m] and pitch θ [deg]; roll φ [deg]; K1 [deg] with K2 [kW];
K3 [kJ] with K4 [kW/s]; the normalised criteria k1–k5 and RL [0, 1], RL
thick (NaN during the observer's warm-up is left blank).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from optroute.errors import ConfigError
from optroute.observer.level import ObserverResult

__all__ = ["observer_figure"]


def observer_figure(
    result: ObserverResult,
    heave_m: np.ndarray,
    roll_deg: np.ndarray,
    pitch_deg: np.ndarray | None = None,
    *,
    threshold: float | None = None,
    title: str | None = None,
) -> Figure:
    """The motions, the five criteria and RL of one record.

    Parameters
    ----------
    result : ObserverResult
        What :func:`optroute.observer.level.observe` returned for the record.
    heave_m, roll_deg : ndarray
        The record's heave [m] and roll [deg], one value per ``result.time_s``.
    pitch_deg : ndarray, optional
        Pitch [deg], drawn with the heave when given.
    threshold : float, optional
        An RL alarm level to mark with a dashed line, in [0, 1].
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = result.time_s.size
    for name, arr in (("heave_m", heave_m), ("roll_deg", roll_deg), ("pitch_deg", pitch_deg)):
        if arr is not None and np.shape(arr) != (n,):
            raise ConfigError(f"{name} has shape {np.shape(arr)}; the figure needs one value per time ({n})")
    if threshold is not None and not 0.0 <= threshold <= 1.0:
        raise ConfigError(f"threshold={threshold!r} must be in [0, 1] (an RL level)")
    t = result.time_s
    fig = Figure(figsize=(10.0, 11.0), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(5, 1, sharex=True)
    ax = axes[0]
    ax.plot(t, heave_m, color="tab:blue", lw=0.8, label="heave z [m]")
    ax.set_ylabel("heave [m]")
    if pitch_deg is not None:
        twin = ax.twinx()
        twin.plot(t, pitch_deg, color="tab:green", lw=0.6, alpha=0.7)
        twin.set_ylabel("pitch θ [deg]", color="tab:green")
    axes[1].plot(t, roll_deg, color="black", lw=0.8)
    axes[1].set_ylabel("roll φ [deg]")
    c = result.criteria
    axes[2].plot(t, c[:, 0], color="tab:purple", lw=0.9)
    axes[2].set_ylabel("K1 [deg]", color="tab:purple")
    twin = axes[2].twinx()
    twin.plot(t, c[:, 1], color="tab:orange", lw=0.5, alpha=0.8)
    twin.set_ylabel("K2 roll power [kW]", color="tab:orange")
    axes[3].plot(t, c[:, 2], color="tab:red", lw=0.9)
    axes[3].set_ylabel("K3 [kJ]", color="tab:red")
    twin = axes[3].twinx()
    twin.plot(t, c[:, 3], color="tab:cyan", lw=0.8)
    twin.set_ylabel("K4 [kW/s]", color="tab:cyan")
    ax = axes[4]
    colours = ("tab:purple", "tab:orange", "tab:red", "tab:cyan", "tab:olive")
    for i, colour in enumerate(colours):
        ax.plot(t, result.normalised[:, i], color=colour, lw=0.7, alpha=0.8, label=f"k{i + 1}")
    ax.plot(t, result.rl, color="black", lw=2.0, label=f"RL ({result.settings.combine})")
    if threshold is not None:
        ax.axhline(threshold, color="black", ls="--", lw=0.8)
    ax.set_ylim(-0.05, 1.05)
    ax.set_ylabel("normalised")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper left", ncols=6, fontsize=8)
    for a in axes:
        a.grid(True, alpha=0.3)
    fig.suptitle(title or "resonance observer (EP 2377756)")
    return fig
