"""``optroute bands``: the forbidden speed intervals of one heading in one sea state.

The forbidden speed intervals (:func:`optroute.physics.safety.forbidden_speed_intervals`), the safe
speed ranges up to the ship's calm-water speed at MCR, and optionally a polar diagram of the
dangerous zones for every heading (``--plot FILE.png``).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import TextIO

from optroute.cli._parser import add_command
from optroute.errors import ConfigError
from optroute.physics.names import PERIOD_FORMS, RULE_SETS


def add_bands(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "bands",
        help="forbidden speed intervals of one heading in one sea state",
        description=(
            "Print the ship and sea state, the speeds forbidden by the wave-encounter danger bands "
            "(synchronous roll, parametric roll, surf-riding, successive high-wave attack) and the safe "
            "speed ranges up to the ship's calm-water speed at MCR."
        ),
        examples="""
  optroute bands --ship container_8000teu --hs 14 --period 11 --heading 180 --wave-from 0
  optroute bands --ship my_ship.toml --hs 8 --period 9 --heading 200 --rules imo --plot polar.png
""",
    )
    p.add_argument(
        "--ship", default="container_54k_dwt", metavar="NAME|FILE.toml", help="ship preset name or ship TOML file"
    )
    p.add_argument("--hs", type=float, default=10.5, metavar="M", help="significant wave height [m]")
    p.add_argument("--period", type=float, default=12.0, metavar="S", help="wave period [s]")
    p.add_argument(
        "--wave-from", type=float, default=0.0, metavar="DEG", help="direction the waves come from [deg true]"
    )
    p.add_argument("--heading", type=float, default=160.0, metavar="DEG", help="ship heading, going to [deg true]")
    p.add_argument("--rules", choices=RULE_SETS, default="boeing", help="rule set: Boeing EP 2145155 or IMO Circ.1228")
    p.add_argument("--margin", type=float, default=0.2, help="relative half-width of the ratio bands [-]")
    p.add_argument("--hs-fraction", type=float, default=0.04, metavar="F", help="bands apply where Hs >= F * L [-]")
    p.add_argument("--period-form", choices=PERIOD_FORMS, default="exact", help="g/2pi in T_E: exact or IMO's 3")
    p.add_argument(
        "--max-speed", type=float, default=None, metavar="KN", help="top speed [kn] (default: calm-water speed at MCR)"
    )
    p.add_argument("--plot", default=None, metavar="FILE.png", help="write a polar diagram of the dangerous zones")
    p.set_defaults(func=cmd_bands)


def _sector(alpha_deg: float) -> str:
    """Plain-words name of an IMO angle of encounter α [deg, 0 = head sea]."""
    a = min(alpha_deg, 360.0 - alpha_deg)
    side = "" if a in (0.0, 180.0) else (" from starboard" if alpha_deg < 180.0 else " from port")
    if a <= 15.0:
        return "head seas" + side
    if a < 75.0:
        return "bow seas" + side
    if a <= 105.0:
        return "beam seas" + side
    if a < 165.0:
        return "quartering seas" + side
    return "following seas" + side


def _kn(value: float) -> str:
    return "inf" if math.isinf(value) else f"{value:.2f}"


def cmd_bands(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """Run ``optroute bands``: print the band table, optionally write the polar plot."""
    from optroute import units
    from optroute.cli._common import load_ship
    from optroute.physics import seaway
    from optroute.physics.safety import BandRules, forbidden_speed_intervals, safe_speed_ranges

    out = sys.stdout if out is None else out
    ship = load_ship(args.ship)
    rules = BandRules(
        rule_set=args.rules,
        margin=args.margin,
        hs_threshold_fraction=args.hs_fraction,
        period_form=args.period_form,
    )
    vmax = float(ship.max_calm_speed_kn) if args.max_speed is None else args.max_speed
    intervals = forbidden_speed_intervals(
        ship,
        hs_m=args.hs,
        period_s=args.period,
        wave_from_deg=args.wave_from,
        heading_deg=args.heading,
        rules=rules,
    )  # validates every sea-state input before anything is printed
    if not (math.isfinite(vmax) and vmax > 0):
        raise ConfigError(f"--max-speed {vmax!r} must be a finite speed > 0 [kn]")

    plot_path = None
    if args.plot is not None:
        from optroute.plot import common as plot

        fig = plot.band_polar_figure(
            ship,
            hs_m=args.hs,
            period_s=args.period,
            max_speed_kn=vmax,
            rules=rules,
            heading_deg=args.heading,
            wave_from_deg=args.wave_from,
        )
        plot_path = plot.save_png(fig, args.plot)

    alpha = float(seaway.relative_wave_angle_deg(args.heading, args.wave_from))
    c_kn = float(units.ms_to_kn(seaway.phase_speed_ms(args.period)))
    threshold = rules.hs_threshold_fraction * ship.length_m
    applies = args.hs >= threshold
    enabled = ", ".join(rules.enabled_bands) or "none"
    lines = [
        f"ship       {ship.name}: L {ship.length_m:.1f} m, T_R {ship.roll_period_s:.2f} s, "
        f"max calm speed {ship.max_calm_speed_kn:.2f} kn",
        f"sea        Hs {args.hs:.2f} m, T {args.period:.2f} s, from {args.wave_from:g} deg true: "
        f"lambda {float(seaway.wavelength_m(args.period)):.1f} m, c {c_kn:.2f} kn, c_g {c_kn / 2:.2f} kn",
        f"heading    {args.heading:g} deg true: alpha {alpha:g} deg ({_sector(alpha)}; IMO: 0 head, 180 following)",
        f"rules      {rules.rule_set}, margin +/-{100 * rules.margin:g} %, T_E {rules.period_form}, bands: {enabled}",
        f"threshold  Hs >= {rules.hs_threshold_fraction:g} L = {threshold:.2f} m: "
        + ("bands APPLY" if applies else f"bands do not apply (Hs {args.hs:.2f} m is below it)"),
        "",
    ]
    if intervals:
        lines.append("forbidden speeds [kn] (closed intervals)")
        lines.append(f"  {'band':<18} {'from':>8} {'to':>8}")
        for iv in intervals:
            note = "  (above max speed)" if iv.lo_kn > vmax else ""
            lines.append(f"  {iv.band:<18} {_kn(iv.lo_kn):>8} {_kn(iv.hi_kn):>8}{note}")
    else:
        lines.append("forbidden speeds [kn]: none")
    lines.append("")
    safe = safe_speed_ranges(intervals, vmax)
    lines.append(f"safe speeds [kn] up to {vmax:.2f} kn" + ("" if safe else ": none"))
    forbidden_ends = {e for iv in intervals for e in (iv.lo_kn, iv.hi_kn)}
    for lo, hi in safe:
        left = "(" if lo in forbidden_ends else "["
        right = ")" if hi in forbidden_ends else "]"
        lines.append(f"  {left}{_kn(lo)}, {_kn(hi)}{right}")
    if plot_path is not None:
        lines.extend(["", f"plot written to {plot_path}"])
    print("\n".join(lines), file=out)
    return 0


__all__ = ["add_bands", "cmd_bands"]
