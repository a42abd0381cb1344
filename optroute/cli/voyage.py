"""``optroute plan`` (endpoints → searched and optimised plan) and ``optroute optimise`` (a corridor file → plan).

Both write the plan as GeoJSON, CSV and NetCDF (:mod:`optroute.plan.outputs`) and print a short
summary; the exit codes are :mod:`optroute.cli`'s (3 for an unreachable ETA or no safe
passage, 4 for a solver failure).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

from optroute.cli._parser import add_command, add_progress_option
from optroute.errors import ConfigError

OBJECTIVES = ("fuel", "time", "cost")


# --------------------------------------------------------------------------- shared options


def add_voyage_options(p: argparse.ArgumentParser, *, eta: bool = True) -> None:
    """Ship, weather, times, objective and solver options of every voyage command."""
    p.add_argument(
        "--ship",
        required=True,
        metavar="NAME|FILE.toml",
        help="ship preset name (container_54k_dwt, ...) or a ship TOML file (schema: Ship.from_toml)",
    )
    p.add_argument(
        "--weather",
        required=True,
        metavar="SCENARIO|FILE",
        help="built-in weather scenario name (calm, uniform, north_pacific_storms, ...) or a NetCDF/Zarr/GRIB file",
    )
    p.add_argument(
        "--departure", default=None, metavar="ISO", help="departure time, UTC (default: the first time of the weather)"
    )
    if eta:
        p.add_argument(
            "--eta",
            default=None,
            metavar="ISO|+HOURS",
            help="required arrival, UTC, or hours after departure (default: none; 'fuel' and 'cost' "
            "then stay within the weather's time span)",
        )
        p.add_argument(
            "--eta-mode", choices=("le", "eq"), default="le", help="arrive no later than the ETA (le) or at it (eq)"
        )
    p.add_argument(
        "--objective",
        choices=OBJECTIVES,
        default="fuel",
        help="least fuel, least passage time, or least fuel_price*fuel + hourly_cost*time",
    )
    p.add_argument(
        "--fuel-price", type=float, default=600.0, metavar="PER_T", help="fuel price for --objective cost [currency/t]"
    )
    p.add_argument(
        "--hourly-cost",
        type=float,
        default=0.0,
        metavar="PER_H",
        help="time cost (charter, crew) for --objective cost [currency/h]",
    )
    p.add_argument("--max-leg-nm", type=float, default=50.0, metavar="NM", help="longest optimiser leg [nm]")
    p.add_argument(
        "--band-leg-nm",
        type=float,
        default=None,
        metavar="NM",
        help="longest optimiser leg where a danger band can bind [nm] (default 20; 0 is refused: give --max-leg-nm "
        "or more to keep one length everywhere)",
    )
    p.add_argument(
        "--cyclone",
        default=None,
        metavar="TRACK",
        help="cyclone track to keep out of (ATCF b-deck/a-deck or IBTrACS CSV): its force-7 circle R + --margin-km",
    )
    p.add_argument(
        "--margin-km", type=float, default=30.0, metavar="KM", help="safety margin beyond R [km] (the patent: 30)"
    )
    p.add_argument(
        "--cone-km-per-h",
        type=float,
        default=None,
        metavar="KM_PER_H",
        help="growth of the circle with the forecast's lead time [km/h] (default 3; a best track has lead 0)",
    )
    p.add_argument(
        "--max-iter", type=int, default=None, metavar="N", help="Ipopt iteration limit per solve (default: Ipopt's)"
    )


def voyage_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """Ship, weather, departure and ETA from the options, all validated."""
    import numpy as np

    from optroute.cli._common import check_cost_options, load_ship, load_weather, parse_eta, parse_time

    ship = load_ship(args.ship)
    wx = load_weather(args.weather)
    if args.departure is None:
        departure = np.datetime64(wx["time"].values[0], "ns")
    else:
        departure = parse_time(args.departure, "--departure")
    eta = None
    if getattr(args, "eta", None) is not None:
        eta = parse_eta(args.eta, departure)
    check_cost_options(args)
    if args.max_iter is not None and args.max_iter < 1:
        raise ConfigError(f"--max-iter {args.max_iter} must be >= 1")
    return {"ship": ship, "weather": wx, "departure": departure, "eta": eta}


def optimise_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`optroute.optimise_corridor` from the options."""
    kw: dict[str, Any] = {
        "objective": args.objective,
        "fuel_price_per_t": args.fuel_price,
        "hourly_cost_per_h": args.hourly_cost,
        "max_leg_nm": args.max_leg_nm,
    }
    if getattr(args, "band_leg_nm", None) is not None:
        kw["band_leg_nm"] = args.band_leg_nm
    if getattr(args, "eta_mode", None) is not None:
        kw["eta_mode"] = args.eta_mode
    if args.max_iter is not None:
        kw["solver_options"] = {"ipopt.max_iter": int(args.max_iter)}
    if getattr(args, "cyclone", None) is not None:
        kw["exclusion"] = cyclone_exclusion(args)
    return kw


def cyclone_exclusion(args: argparse.Namespace) -> Any:
    """The moving circle R + ``--margin-km`` (+ the cone) of the ``--cyclone`` track."""
    import numpy as np

    from optroute.geo.tracks import Exclusion
    from optroute.weather.cyclone_tracks import read_track

    for name in ("margin_km", "cone_km_per_h"):
        value = getattr(args, name)
        if value is not None and not (np.isfinite(value) and value >= 0):
            raise ConfigError(f"--{name.replace('_', '-')} {value!r} must be a finite number >= 0 [km, km/h]")
    track = read_track(args.cyclone)
    return Exclusion.from_track(track, margin_km=args.margin_km, cone_km_per_h=args.cone_km_per_h)


def weather_name(wx: Any, spec: str) -> str:
    return str(wx.attrs.get("scenario_name") or spec)


def write_plan(plan: Any, out: str, stem: str) -> list[str]:
    """Write the plan's GeoJSON, CSV and NetCDF next to each other; return the paths."""
    from optroute.cli._common import output_paths
    from optroute.plan import outputs

    paths = output_paths(out, stem)
    written = [
        outputs.write_geojson(plan, paths["geojson"]),
        outputs.write_csv(plan, paths["csv"]),
        outputs.write_netcdf(plan, paths["nc"]),
    ]
    return [str(p) for p in written]


def plan_summary(plan: Any, inputs: dict[str, Any], args: argparse.Namespace, files: list[str]) -> list[str]:
    """The short summary printed after a plan is written."""
    import numpy as np

    from optroute import units
    from optroute.cli._common import fmt_duration
    from optroute.cli._status import explain_status

    ship = inputs["ship"]
    legs = plan.legs
    power = legs["power_kw"].to_numpy(dtype=float)
    wp = plan.waypoints
    sog = plan.distance_nm / plan.duration_h if plan.duration_h > 0 else float("nan")
    eta = inputs["eta"]
    eta_text = f" (ETA {units.format_utc(eta)}, {args.eta_mode})" if eta is not None else ""
    lines = [
        f"route      ({wp[0, 0]:.4f}, {wp[0, 1]:.4f}) -> ({wp[-1, 0]:.4f}, {wp[-1, 1]:.4f}): "
        f"{plan.distance_nm:,.1f} nm in {len(legs)} legs",
        f"status     {plan.status}: "
        + explain_status(plan.status, ipopt_status=plan.solver_stats.get("ipopt_status"), objective=args.objective),
        f"ship       {ship.name}; weather {weather_name(inputs['weather'], args.weather)}; objective {args.objective}",
        f"departure  {units.format_utc(plan.departure)}",
        f"arrival    {units.format_utc(plan.arrival)}{eta_text}",
        f"passage    {fmt_duration(plan.duration_h)}, mean SOG {sog:.2f} kn, "
        f"STW {legs['stw_kn'].min():.2f}-{legs['stw_kn'].max():.2f} kn",
        f"fuel       {plan.total_fuel_t:,.2f} t",
        f"power      max {power.max():,.0f} kW = {100 * power.max() / ship.mcr_kw:.1f} % MCR, "
        f"max Hs on the route {legs['hs_m'].max():.2f} m",
    ]
    if args.objective == "cost":
        cost = args.fuel_price * plan.total_fuel_t + args.hourly_cost * plan.duration_h
        lines.append(f"cost       {cost:,.0f} (fuel {args.fuel_price:g}/t, time {args.hourly_cost:g}/h)")
    price = plan.eta_shadow_price_t_per_h
    if np.isfinite(price):
        lines.append(f"ETA value  {price:.3f} t of fuel saved per extra hour of passage")
    lines.append(f"files      {', '.join(files)}")
    return lines


# --------------------------------------------------------------------------- plan


def add_plan(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "plan",
        help="search a route between two positions and optimise its speeds and waypoints",
        description=(
            "Search the route from --from to --to through the weather (time-dependent A* on a gnomonic grid, "
            "or the stage-wise DP), take the corridor around it, and optimise the waypoints and leg speeds in "
            "that corridor (CasADi/Ipopt) for least fuel, time or cost under the ETA, the engine's MCR and the "
            "wave-encounter danger bands. Writes the plan as GeoJSON, CSV and NetCDF and prints a summary."
        ),
        examples="""
  optroute plan --from 32.71,-117.17 --to 35.65,139.77 --ship container_8000teu \\
      --weather north_pacific_storms --eta +264 --out runs/sd_tokyo/
  optroute plan --from 10N,60E --to 5N,80E --ship my_ship.toml --weather era5.nc \\
      --departure 2024-01-10T06:00 --eta 2024-01-14T18:00 --objective cost \\
      --fuel-price 650 --hourly-cost 1500 --out runs/arabian_sea
""",
    )
    p.add_argument("--from", dest="start", required=True, metavar="LAT,LON", help="start position [deg]")
    p.add_argument("--to", dest="end", required=True, metavar="LAT,LON", help="end position [deg]")
    add_voyage_options(p)
    p.add_argument(
        "--corridor-width-nm",
        type=float,
        default=60.0,
        metavar="NM",
        help="total width of the corridor about the searched route [nm]",
    )
    p.add_argument("--cell-nm", type=float, default=40.0, metavar="NM", help="route-search grid cell [nm]")
    p.add_argument(
        "--search",
        choices=("grid", "dp"),
        default="grid",
        help="route search: time-dependent A* on a grid, or the stage-wise dynamic programme",
    )
    p.add_argument(
        "--search-objective",
        choices=("time", "plan"),
        default="time",
        help="what the route search minimises: passage time (one search; the optimiser then meets the ETA "
        "for the plan's objective inside the corridor), or the plan's own objective with the ETA (about 15 "
        "searches for the fuel or cost weight: minutes on an ocean grid); the DP always minimises fuel for the ETA",
    )
    p.add_argument(
        "--out",
        default="optroute_plan/",
        metavar="PREFIX|DIR",
        help="output prefix (PREFIX.geojson, .csv, .nc) or folder (DIR/plan.*)",
    )
    add_progress_option(p)
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute plan``."""
    import numpy as np

    import optroute as orx
    from optroute.cli._common import SEARCH_METHODS, Progress, output_paths, parse_position, progress_enabled

    out = out or sys.stdout
    start = parse_position(args.start, "--from")
    end = parse_position(args.end, "--to")
    inputs = voyage_inputs(args)
    for name in ("corridor_width_nm", "cell_nm"):
        value = getattr(args, name)
        if not (np.isfinite(value) and value > 0):
            raise ConfigError(f"--{name.replace('_', '-')} {value!r} must be a finite length > 0 [nm]")
    output_paths(args.out, "plan", create=False)  # a bad --out fails before the work, not after
    search = {"cell_nm": args.cell_nm, "method": SEARCH_METHODS[args.search]}
    if args.search_objective == "time" and search["method"] != "dp":  # the DP always minimises fuel for the ETA
        search["objective"] = "time"
    with Progress(progress_enabled(args), "plan") as bar:
        bar("route search", 0.0)
        plan = orx.plan_voyage(
            start,
            end,
            inputs["weather"],
            inputs["ship"],
            departure=inputs["departure"],
            eta=inputs["eta"],
            corridor_width_nm=args.corridor_width_nm,
            search_options=search,
            progress=bar,
            **optimise_kwargs(args),
        )
    files = write_plan(plan, args.out, "plan")
    print("\n".join(plan_summary(plan, inputs, args, files)), file=out)
    return 0


# --------------------------------------------------------------------------- optimise


def add_optimise(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "optimise",
        help="optimise speeds and waypoints inside a corridor read from a GeoJSON or CSV file",
        description=(
            "Read a corridor centreline from a GeoJSON file (a LineString, a Feature or a FeatureCollection "
            "with one; [lon, lat] positions) or a CSV file (columns lat,lon), and optimise the waypoints within "
            "--width-nm of it and the speed of every leg (CasADi/Ipopt) for least fuel, time or cost. "
            "Writes the plan as GeoJSON, CSV and NetCDF and prints a summary."
        ),
        examples="""
  optroute optimise --corridor route.geojson --width-nm 40 --ship container_54k_dwt \\
      --weather forecast.nc --departure 2024-01-10T00:00 --eta +72 --out runs/leg1
  optroute optimise --corridor waypoints.csv --width-nm 0 --weather uniform --objective time --out runs/
  (a CSV corridor: a header 'lat,lon' and one waypoint a row, in degrees; --width-nm 0 fixes the path)
""",
    )
    p.add_argument("--corridor", required=True, metavar="FILE.geojson|FILE.csv", help="corridor centreline")
    p.add_argument(
        "--width-nm",
        type=float,
        default=60.0,
        metavar="NM",
        help="total corridor width about the centreline [nm] (0 fixes the path)",
    )
    add_voyage_options(p)
    p.add_argument(
        "--out",
        default="optroute_plan/",
        metavar="PREFIX|DIR",
        help="output prefix (PREFIX.geojson, .csv, .nc) or folder (DIR/plan.*)",
    )
    add_progress_option(p)
    p.set_defaults(func=cmd_optimise)


def read_corridor(args: argparse.Namespace, weather: Any) -> Any:
    """The :class:`~optroute.search.route.Corridor` of ``--corridor`` and ``--width-nm``."""
    import numpy as np

    import optroute as orx
    from optroute.cli._common import read_waypoints

    if not (np.isfinite(args.width_nm) and args.width_nm >= 0):
        raise ConfigError(f"--width-nm {args.width_nm!r} must be a finite width >= 0 [nm]")
    wp = read_waypoints(args.corridor, weather)
    return orx.Corridor.from_waypoints(wp, width_nm=args.width_nm)


def cmd_optimise(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute optimise``."""
    import optroute as orx
    from optroute.cli._common import Progress, output_paths, progress_enabled

    out = out or sys.stdout
    inputs = voyage_inputs(args)
    corridor = read_corridor(args, inputs["weather"])
    output_paths(args.out, "plan", create=False)
    with Progress(progress_enabled(args), "optimise") as bar:
        plan = orx.optimise_corridor(
            corridor,
            inputs["weather"],
            inputs["ship"],
            departure=inputs["departure"],
            eta=inputs["eta"],
            progress=bar,
            **optimise_kwargs(args),
        )
    files = write_plan(plan, args.out, "plan")
    print("\n".join(plan_summary(plan, inputs, args, files)), file=out)
    return 0
