"""``optroute observe``: the resonance level RL of a recorded or simulated motion log (EP 2377756).

Reads a motion log (CSV or NetCDF with time, heave, roll and optionally pitch, units named;
:func:`optroute.observer.io.read_motion_log`), runs the resonance observer of
:mod:`optroute.observer.level` over it and prints RL with the criteria K1–K5 as a compact
table, the first time RL reaches the alarm level and, with ``--plot``, a figure of the series
and the criteria (:func:`optroute.plot.observer.observer_figure`).  numpy, matplotlib and the
observer are imported inside the command, so ``optroute --help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from typing import TextIO

from optroute.cli._parser import add_command


def add_observe(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "observe",
        help="resonance level RL of a motion log (parametric-roll observer, EP 2377756)",
        description=(
            "Run the onboard parametric-roll observer of thyssenkrupp EP 2377756 over a motion log: the criteria "
            "K1 (roll at heave crossings), K2 (roll power), K3 (roll energy gain at upright passages), K4 (rise of "
            "the roll power) and K5 (closeness to the heave/roll state limits), normalised and combined into the "
            "resonance level RL in [0, 1]. The log is a CSV with columns time_s, heave_m, roll_deg (or roll_rad) "
            "and optionally pitch_deg, or a NetCDF file with variables time, heave, roll, pitch and units "
            "attributes; it must be evenly sampled."
        ),
        examples="""
  optroute observe motions.csv
  optroute observe motions.csv --ship container_8000teu --plot observer.png
  optroute observe log.nc --combine max --every 5 --moment-table gz_trials.csv
""",
    )
    p.add_argument("motions", metavar="MOTIONS.csv|.nc", help="the motion log")
    p.add_argument(
        "--ship", default="container_54k_dwt", metavar="NAME|FILE.toml", help="ship preset name or ship TOML file"
    )
    p.add_argument("--plot", default=None, metavar="FILE.png", help="write the series, criteria and RL as a figure")
    p.add_argument("--combine", choices=("product", "sum", "max"), default="product", help="how k1-k5 make RL")
    p.add_argument("--every", type=float, default=10.0, metavar="S", help="table row spacing [s]")
    p.add_argument("--threshold", type=float, default=1.0, metavar="RL", help="alarm level reported [0-1]")
    p.add_argument(
        "--moment-table",
        default=None,
        metavar="FILE.csv",
        help="righting-moment characteristic heave_m,roll_deg,moment_knm (default: wall-sided GZ from the ship)",
    )
    p.set_defaults(func=cmd_observe)


def cmd_observe(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute observe``: read the log, run the observer, print the table, draw the figure."""
    import math

    from optroute.cli._common import load_ship
    from optroute.errors import ConfigError
    from optroute.observer.io import read_motion_log, read_righting_moment
    from optroute.observer.level import ObserverSettings, RightingMoment, check_time, observe

    out = out or sys.stdout
    if not (math.isfinite(args.threshold) and 0.0 < args.threshold <= 1.0):
        raise ConfigError(f"--threshold {args.threshold!r} must be an RL level in (0, 1]")
    ship = load_ship(args.ship)
    log = read_motion_log(args.motions)
    dt = check_time(log.time_s, source=f"{log.source}: time")
    settings = ObserverSettings.for_ship(ship, sample_interval_s=dt, combine=args.combine)
    moment = RightingMoment.from_ship(ship) if args.moment_table is None else read_righting_moment(args.moment_table)
    result = observe(log.time_s, log.heave_m, log.roll_deg, settings=settings, moment=moment)
    duration = log.time_s[-1] - log.time_s[0]
    print(
        f"{log.source}: {log.time_s.size} samples every {dt:g} s ({duration:.1f} s); ship {ship.name} "
        f"(T_R {ship.roll_period_s:.2f} s, GM {ship.gm_m} m); RL = {args.combine} of k1-k5 with weights "
        f"{settings.weights}; RL is blank (nan) for the first {settings.warmup_s:.1f} s (warm-up)",
        file=out,
    )
    print(result.table(args.every), file=out)
    first = result.first_time_s(args.threshold)
    peak = float(max((v for v in result.rl if v == v), default=float("nan")))
    if math.isnan(first):
        print(f"RL stays below {args.threshold:g} (peak {peak:.2f})", file=out)
    else:
        print(f"RL reaches {args.threshold:g} first at t = {first:.1f} s (peak {peak:.2f})", file=out)
    if args.plot is not None:
        from optroute.plot.common import save_png
        from optroute.plot.observer import observer_figure

        fig = observer_figure(
            result,
            log.heave_m,
            log.roll_deg,
            log.pitch_deg,
            threshold=args.threshold,
            title=f"{log.source} — {ship.name}",
        )
        print(f"figure: {save_png(fig, args.plot)}", file=out)
    return 0
