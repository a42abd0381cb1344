"""``optroute simulate``: sail a voyage through a "truth" weather, re-planning on each new forecast (issue 16).

Reads the truth and the forecasts (built-in scenario names or files, each forecast with its issue
time as ``ISSUE=WEATHER``), sails the ship with :func:`optroute.simulate_voyage` and writes the
voyage log as NetCDF, CSV and GeoJSON (atomically; :func:`optroute.voyage.outputs.write_log`) and,
with ``--plot``, the figure of the track over time with the re-plans marked
(:func:`optroute.plot.voyage.voyage_figure`). numpy, xarray and the optimiser are imported inside
the command, so ``optroute --help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from typing import TextIO

from optroute.cli._parser import add_command


def add_simulate(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "simulate",
        help="sail a voyage through a truth weather, re-planning on each forecast",
        description=(
            "Plan a voyage on the forecast issued by the departure, sail it through the truth weather in time steps "
            "(the plan's speed reduced where the truth's danger bands or MCR forbid it, Boeing EP 2145155), and "
            "re-plan from the current position under the policy: on each new forecast, every N hours, or when the "
            "sea met differs from the plan's forecast. Writes the voyage log (NetCDF, CSV, GeoJSON)."
        ),
        examples="""
  optroute simulate --truth truth.nc --forecast 2024-01-10T00:00=fc00.nc --forecast 2024-01-10T06:00=fc06.nc \\
      --from 30,-150 --to 30,-140 --depart 2024-01-10T00:00 --eta +42 --out voyage/
  optroute simulate --truth truth.nc --forecast 2024-01-10T00:00=fc00.nc --from 30,-150 --to 30,-140 \\
      --depart 2024-01-10T00:00 --eta +42 --replan never --plot voyage.png
""",
    )
    p.add_argument("--truth", required=True, metavar="SCENARIO|FILE", help="the weather the ship really meets")
    p.add_argument("--forecast", action="append", default=[], metavar="[ISSUE=]SCENARIO|FILE",
                   help="a forecast and its issue time (UTC), or a file that states its issue time "
                        "(forecast_reference_time, GRIB time + step); repeat for each forecast")  # fmt: skip
    p.add_argument("--from", dest="start", required=True, metavar="LAT,LON", help="start position [deg]")
    p.add_argument("--to", dest="end", required=True, metavar="LAT,LON", help="end position [deg]")
    p.add_argument("--depart", required=True, metavar="TIME", help="departure, ISO 8601 UTC")
    p.add_argument(
        "--eta", default=None, metavar="TIME|+HOURS", help="required arrival (UTC, or hours after departure)"
    )
    p.add_argument("--ship", default="container_54k_dwt", metavar="NAME|FILE.toml", help="ship preset or TOML file")
    p.add_argument("--replan", choices=("forecast", "never"), default="forecast", help="re-plan on new forecasts")
    p.add_argument("--every-h", type=float, default=None, metavar="H", help="also re-plan every H hours")
    p.add_argument("--hs-threshold-m", type=float, default=None, metavar="M",
                   help="also re-plan when the Hs met differs from the plan's by more than M")  # fmt: skip
    p.add_argument("--step-h", type=float, default=0.5, metavar="H", help="simulator time step [h]")
    p.add_argument("--min-stw-kn", type=float, default=8.0, metavar="KN", help="slowest speed of the speed reduction")
    p.add_argument("--corridor-width-nm", type=float, default=300.0, metavar="NM", help="re-planning corridor width")
    p.add_argument("--max-leg-nm", type=float, default=50.0, metavar="NM", help="longest optimiser leg [nm]")
    p.add_argument(
        "--observer", type=float, default=None, metavar="RL",
        help="run the parametric-roll observer (thyssenkrupp EP 2377756) on the simulated motions; act at this RL",
    )  # fmt: skip
    p.add_argument("--cell-nm", type=float, default=None, metavar="NM",
                   help="plan with the route search on this grid cell, then the optimiser about the route "
                        "(default: the optimiser about the great circle)")  # fmt: skip
    p.add_argument("--cyclone", default=None, metavar="TRACK",
                   help="the cyclone's TRUE track (ATCF b-deck or IBTrACS CSV): every plan keeps out of R + "
                        "--margin-km of the track known then; the outcome reports the closest approach")  # fmt: skip
    p.add_argument("--cyclone-forecast", action="append", default=[], metavar="[ISSUE=]TRACK",
                   help="a forecast track and its issue time (UTC); an a-deck without ISSUE= is issued at its "
                        "DTG; repeat for each (default: the plans know the true track)")  # fmt: skip
    p.add_argument("--margin-km", type=float, default=30.0, metavar="KM", help="safety margin beyond R [km]")
    p.add_argument("--cone-km-per-h", type=float, default=None, metavar="KM_PER_H",
                   help="growth of the circle with the hours past a track's issue [km/h] (default 3)")  # fmt: skip
    p.add_argument("--out", default="voyage_log", metavar="PREFIX|DIR/", help="where the log files go")
    p.add_argument("--plot", default=None, metavar="FILE.png", help="write the track and re-plans as a figure")
    p.set_defaults(func=cmd_simulate)


def _forecasts(specs: list[str]) -> list[tuple[object, object]]:
    from optroute.cli._common import load_weather, parse_time
    from optroute.errors import ConfigError

    out = []
    for spec in specs:
        issue, sep, source = spec.partition("=")
        if not sep:  # a file that states its own issue time (forecast_reference_time, GRIB time + step)
            from optroute.weather.forecast_files import open_forecasts

            out.extend(open_forecasts([spec]))
            continue
        if not source:
            raise ConfigError(f"--forecast {spec!r} is not ISSUE=WEATHER; e.g. --forecast 2024-01-10T06:00=fc06.nc")
        out.append((parse_time(issue, f"--forecast {spec!r} issue time"), load_weather(source)))
    return out


def _cyclone(args: argparse.Namespace) -> object:
    """The :class:`~optroute.voyage.cyclone.CycloneWatch` of ``--cyclone`` and ``--cyclone-forecast``, or None."""
    from optroute.cli._common import parse_time
    from optroute.errors import ConfigError
    from optroute.voyage.cyclone import CycloneWatch
    from optroute.weather.cyclone_tracks import read_track

    if args.cyclone is None:
        if args.cyclone_forecast:
            raise ConfigError("--cyclone-forecast needs --cyclone TRACK, the true track the voyage is judged against")
        return None
    tracks: list[object] = []
    for spec in args.cyclone_forecast:
        issue, sep, source = spec.partition("=")
        if not sep:
            tracks.append(read_track(spec))
        elif not source:
            raise ConfigError(f"--cyclone-forecast {spec!r} is not ISSUE=TRACK; e.g. 2022-10-13T06:00=aal01.dat")
        else:
            tracks.append((parse_time(issue, f"--cyclone-forecast {spec!r} issue time"), read_track(source)))
    return CycloneWatch(read_track(args.cyclone), tracks, margin_km=args.margin_km, cone_km_per_h=args.cone_km_per_h)


def cmd_simulate(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute simulate``: load, sail, write the log and the figure, print the outcome."""
    from optroute import units
    from optroute.cli._common import load_ship, load_weather, output_paths, parse_eta, parse_position, parse_time
    from optroute.errors import ConfigError
    from optroute.voyage import OnboardObserver, ReplanPolicy, simulate_voyage
    from optroute.voyage.outputs import write_log

    out = out or sys.stdout
    if not args.forecast:
        raise ConfigError("no --forecast given; pass at least one, e.g. --forecast 2024-01-10T00:00=fc00.nc")
    paths = output_paths(args.out, "voyage_log", create=False)
    if args.cell_nm is not None and not (args.cell_nm > 0 and args.cell_nm < float("inf")):
        raise ConfigError(f"--cell-nm {args.cell_nm!r} must be a finite length > 0 [nm]")
    cyclone = _cyclone(args)
    departure = parse_time(args.depart, "--depart")
    eta = parse_eta(args.eta, departure) if args.eta else None
    policy = (
        ReplanPolicy.never()
        if args.replan == "never"
        else ReplanPolicy(every_h=args.every_h, hs_threshold_m=args.hs_threshold_m)
    )
    res = simulate_voyage(
        (parse_position(args.start, "--from"), parse_position(args.end, "--to")),
        load_weather(args.truth),
        load_ship(args.ship),
        forecasts=_forecasts(args.forecast),
        replan=policy,
        departure=departure,
        eta=eta,
        step_h=args.step_h,
        min_stw_kn=args.min_stw_kn,
        corridor_width_nm=args.corridor_width_nm,
        optimise_options={"max_leg_nm": args.max_leg_nm},
        search_options=None if args.cell_nm is None else {"cell_nm": args.cell_nm},
        observer=None if args.observer is None else OnboardObserver(threshold=args.observer),
        cyclone=cyclone,
    )
    paths = output_paths(args.out, "voyage_log")
    files = [str(p) for p in write_log(res.log, paths["nc"].with_suffix(""))]
    if args.plot:
        from optroute.plot.common import save_png
        from optroute.plot.voyage import voyage_figure

        files.append(str(save_png(voyage_figure(res.log), args.plot)))
    o = res.outcome
    eta_text = "no ETA" if o.eta is None else f"ETA {units.format_utc(o.eta)} {'met' if o.eta_met else 'MISSED'}"
    print(
        f"arrived {units.format_utc(o.arrival)} after {o.duration_h:.2f} h ({eta_text}); fuel {o.fuel_t:.2f} t; "
        f"{o.distance_nm:.1f} nm; inside a danger band {o.time_in_band_h:.2f} h; the plan's speed met a band "
        f"{o.time_band_met_h:.2f} h; {o.n_replans} re-plan(s)",
        file=out,
    )
    if args.observer is not None:
        print(
            f"parametric-roll observer: {o.n_observer_alarms} alarm(s) at RL >= {args.observer:g}; "
            f"largest simulated roll {o.max_roll_deg:.1f} deg",
            file=out,
        )
    if cyclone is not None:
        print(
            f"cyclone {res.log.attrs['cyclone_name']}: closest approach {o.cyclone_closest_km:.1f} km from the true "
            f"centre at {res.log.attrs['cyclone_closest_time']} (distance - R {o.cyclone_least_gap_km:.1f} km); "
            f"inside R {o.time_inside_r_h:.2f} h, inside R + {args.margin_km:g} km {o.time_inside_margin_h:.2f} h",
            file=out,
        )
    if o.earliest_arrival is not None:
        print(f"the ETA became infeasible; earliest arrival {units.format_utc(o.earliest_arrival)}", file=out)
    for k in range(res.log.sizes["replan"]):
        print(
            f"  plan {k} at {units.format_utc(res.log['replan_time'].values[k])}: "
            f"{res.log['replan_reason'].values[k]} -> {str(res.log['replan_status'].values[k])[:120]}",
            file=out,
        )
    print("wrote " + ", ".join(files), file=out)
    return 0
