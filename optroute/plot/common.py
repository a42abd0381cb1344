"""Figures: the polar diagram of dangerous (speed, heading) zones.

The figures are drawn on a bare :class:`matplotlib.figure.Figure` with the
Agg canvas, so nothing here touches pyplot's global state or needs a
display.  The polar diagram follows the style of IMO MSC.1/Circ.1228
Figs. 2–3: the angle is the direction the waves come from relative to the
bow, i.e. the IMO angle of encounter α (0° = head sea at the top, 90° =
waves from starboard on the right, 180° = following sea at the bottom), the
radius is the ship speed through the water [kn], and the region of each
band (where :func:`optroute.physics.safety.band_margins` is <= 0) is shaded.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from optroute import units
from optroute.errors import ConfigError
from optroute.physics import seaway
from optroute.physics.safety import BANDS, DEFAULT_RULES, BandRules, band_margins

BAND_COLOURS = {
    "synchronous_roll": "tab:red",
    "parametric_roll": "tab:orange",
    "surf_riding": "tab:blue",
    "high_wave_attack": "tab:purple",
}
_BIG = 1.0e3  # stands in for +inf margins (band does not apply) in the contoured field

BAND_LABELS = {
    "synchronous_roll": "synchronous roll",
    "parametric_roll": "parametric roll",
    "surf_riding": "surf-riding / broaching",
    "high_wave_attack": "successive high-wave attack",
}


def band_polar_figure(
    ship: Any,
    *,
    hs_m: float,
    period_s: float,
    max_speed_kn: float,
    rules: BandRules = DEFAULT_RULES,
    heading_deg: float | None = None,
    wave_from_deg: float = 0.0,
    speed_kn: float | None = None,
    angle_step_deg: float = 0.5,
    title: str | None = None,
) -> Figure:
    """Polar diagram of the forbidden (speed, relative heading) zones for one sea state.

    Parameters
    ----------
    ship : Ship
        Needs ``name``, ``length_m`` [m] and ``roll_period_s`` [s].
    hs_m : float
        Significant wave height [m].
    period_s : float
        Wave period [s].
    max_speed_kn : float
        Outer radius: the top speed drawn [kn], > 0 (the ship's speed at
        MCR in calm water is the natural choice).
    rules : BandRules
        Rule set, threshold, margin, enabled bands.
    heading_deg : float, optional
        A ship heading to mark [deg true]; drawn as a radial line at its
        α = wave_from − heading.
    wave_from_deg : float
        Direction the waves come from [deg true]; only used with
        ``heading_deg``.
    speed_kn : float, optional
        A speed to mark on that line [kn].
    angle_step_deg : float
        Angular resolution of the shaded field [deg] (speeds use 300 steps).
    title : str, optional
        A first title line (where and when this sea state is), above the ship and sea-state lines.

    Returns
    -------
    matplotlib.figure.Figure
        With an Agg canvas attached; save it with :func:`save_png`.
    """
    if not (math.isfinite(max_speed_kn) and max_speed_kn > 0):
        raise ConfigError(f"max_speed_kn={max_speed_kn!r} must be a finite speed > 0 [kn] for the plot radius")
    if not (math.isfinite(angle_step_deg) and 0 < angle_step_deg <= 30):
        raise ConfigError(f"angle_step_deg={angle_step_deg!r} must be in (0, 30] [deg]")
    fig = Figure(figsize=(8.0, 8.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)

    handles = _band_areas(ax, ship, hs_m, period_s, max_speed_kn, rules, angle_step_deg)
    if heading_deg is not None:
        handles.append(_ship_heading(ax, heading_deg, wave_from_deg, speed_kn, max_speed_kn))
    _polar_frame(ax, max_speed_kn)
    _polar_title(fig, ax, ship, hs_m, period_s, rules, title)
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=9, frameon=False)
    return fig


def _band_areas(
    ax, ship: Any, hs_m: float, period_s: float, max_speed_kn: float, rules: BandRules, angle_step_deg: float
) -> list:
    """Shade each danger band on the polar axes; returns their legend patches."""
    # Shade where each band's signed margin (optroute.physics.safety.band_margins, ratio units) is <= 0.  The
    # margin is continuous in (α, V) inside a band's domain, so contourf draws the straight band edges
    # (V cos(180° − α) = const) smoothly instead of as a staircase.  α = wave_from − heading; any pair with
    # this difference gives the same bands, so heading = −α with waves from north is used.
    alphas = np.linspace(0.0, 360.0, int(round(360.0 / angle_step_deg)) + 1)
    speeds = np.linspace(0.0, max_speed_kn, 301)
    theta, radius = np.meshgrid(np.radians(alphas), speeds, indexing="ij")
    margins = band_margins(
        ship,
        speed_kn=speeds[None, :],
        hs_m=hs_m,
        period_s=period_s,
        wave_from_deg=0.0,
        heading_deg=-alphas[:, None],
        rules=rules,
    )
    handles = []
    for band in BANDS:
        field = np.clip(np.nan_to_num(margins[band].margin, nan=_BIG, posinf=_BIG, neginf=-_BIG), -_BIG, _BIG)
        if not (field <= 0.0).any():
            continue
        ax.contourf(theta, radius, field, levels=[-_BIG, 0.0], colors=[BAND_COLOURS[band]], alpha=0.45)
        handles.append(Patch(facecolor=BAND_COLOURS[band], alpha=0.45, label=BAND_LABELS[band]))
    return handles


def _ship_heading(ax, heading_deg: float, wave_from_deg: float, speed_kn: float | None, max_speed_kn: float) -> Patch:
    """The ship's heading as a dashed ray (and its speed as a dot); returns its legend patch."""
    alpha_ship = float(seaway.relative_wave_angle_deg(heading_deg, wave_from_deg))
    ax.plot([math.radians(alpha_ship)] * 2, [0.0, max_speed_kn], color="black", linestyle="--", linewidth=1.2)
    label = f"heading {heading_deg:g}° true (α = {alpha_ship:g}°)"
    if speed_kn is not None:
        ax.plot([math.radians(alpha_ship)], [speed_kn], marker="o", color="black")
        label += f", {speed_kn:.1f} kn"
    return Patch(facecolor="none", edgecolor="black", linestyle="--", label=label)


def _polar_frame(ax, max_speed_kn: float) -> None:
    """Radius 0 to the top speed [kn]; the angle every 30° with head, beam and following seas named."""
    ax.set_ylim(0.0, max_speed_kn)
    ax.set_thetagrids(
        np.arange(0, 360, 30),
        [
            "0°\nhead",
            "30°",
            "60°",
            "90°\nbeam (stbd)",
            "120°",
            "150°",
            "180°\nfollowing",
            "210°",
            "240°",
            "270°\nbeam (port)",
            "300°",
            "330°",
        ],
    )
    ax.set_rlabel_position(112.5)


def _polar_title(fig: Figure, ax, ship: Any, hs_m: float, period_s: float, rules: BandRules, title: str | None) -> None:
    """The ship, the sea state and the rules above the diagram; a note in the middle when no band applies."""
    c_kn = float(units.ms_to_kn(seaway.phase_speed_ms(period_s)))
    threshold = rules.hs_threshold_fraction * ship.length_m
    text = (
        f"{getattr(ship, 'name', 'ship')} (L {ship.length_m:.0f} m, T_R {ship.roll_period_s:.1f} s): "
        f"Hs {hs_m:.1f} m, T {period_s:.1f} s, λ {float(seaway.wavelength_m(period_s)):.0f} m, c {c_kn:.1f} kn\n"
        f"{rules.rule_set} rules, margin ±{100 * rules.margin:.0f} %, bands where Hs ≥ "
        f"{rules.hs_threshold_fraction:g} L = {threshold:.1f} m\n"
        "angle: wave direction relative to the bow, α [deg] (IMO MSC.1/Circ.1228); radius: speed [kn]"
    )
    fig.suptitle(text if title is None else f"{title}\n{text}", fontsize=10)
    if hs_m < threshold:
        ax.text(
            0.0,
            0.0,
            f"Hs {hs_m:.1f} m < {rules.hs_threshold_fraction:g} L = {threshold:.1f} m:\nno band applies",
            ha="center",
            va="center",
            fontsize=10,
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "grey"},
        )


def save_png(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Write ``fig`` as a PNG atomically: to a temporary file in the same folder, then ``os.replace``.

    A reader never sees a half-written file, and a failed write leaves any
    earlier file at ``path`` untouched.

    Parameters
    ----------
    fig : Figure
        The figure.
    path : str or PathLike
        Destination; must end in ``.png`` and its folder must exist.

    Raises
    ------
    ConfigError
        Wrong suffix, or the folder cannot be written.
    """
    target = Path(path)
    if target.suffix.lower() != ".png":
        raise ConfigError(f"plot file {str(target)!r} must end in .png; e.g. --plot bands.png")
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise ConfigError(f"cannot write plot {str(target)!r}: folder {str(folder)!r} does not exist; create it first")
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
        with os.fdopen(fd, "wb") as fh:
            fig.savefig(fh, format="png", dpi=120)
        os.chmod(tmp, 0o644)  # mkstemp makes it 0600; a figure is not a secret
        os.replace(tmp, target)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(exc, OSError):
            raise ConfigError(f"cannot write plot {str(target)!r}: {exc.strerror or exc}") from exc
        raise
    return target
