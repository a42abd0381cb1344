"""``optroute tradeoff`` (the fuel-versus-ETA front of one voyage) and ``optroute study`` (ships × weather × ETAs on Dask)."""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from optroute.cli._parser import add_command, add_progress_option
from optroute.errors import ConfigError

if TYPE_CHECKING:
    import xarray as xr

# --------------------------------------------------------------------------- shared


def _add_route_options(p: argparse.ArgumentParser) -> None:
    where = p.add_argument_group("route (either endpoints or a corridor file)")
    where.add_argument("--from", dest="start", default=None, metavar="LAT,LON", help="start position [deg]")
    where.add_argument("--to", dest="end", default=None, metavar="LAT,LON", help="end position [deg]")
    where.add_argument(
        "--corridor",
        default=None,
        metavar="FILE.geojson|FILE.csv",
        help="corridor centreline instead of endpoints (see 'optroute optimise --help')",
    )
    where.add_argument(
        "--width-nm",
        "--corridor-width-nm",
        dest="width_nm",
        type=float,
        default=60.0,
        metavar="NM",
        help="total corridor width [nm]",
    )
    where.add_argument("--cell-nm", type=float, default=40.0, metavar="NM", help="route-search grid cell [nm]")
    where.add_argument("--search", choices=("grid", "dp"), default="grid", help="route search method (endpoints)")


def _add_cost_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--objective", choices=("fuel", "cost"), default="fuel", help="what each point minimises subject to its ETA"
    )
    p.add_argument("--fuel-price", type=float, default=600.0, metavar="PER_T", help="[currency/t], for cost")
    p.add_argument("--hourly-cost", type=float, default=0.0, metavar="PER_H", help="[currency/h], for cost")
    p.add_argument("--max-leg-nm", type=float, default=50.0, metavar="NM", help="longest optimiser leg [nm]")
    p.add_argument("--max-iter", type=int, default=None, metavar="N", help="Ipopt iteration limit per solve")


def _route(args: argparse.Namespace, weather: Any) -> tuple[Any, dict[str, Any]]:
    """Endpoints or a corridor from the options; and the search options for endpoints."""
    import numpy as np

    from optroute.cli._common import SEARCH_METHODS, parse_position
    from optroute.cli.voyage import read_corridor

    if args.corridor is not None:
        if args.start is not None or args.end is not None:
            raise ConfigError("give either --from/--to or --corridor, not both")
        return read_corridor(args, weather), {}
    if args.start is None or args.end is None:
        raise ConfigError("give the route: --from LAT,LON --to LAT,LON, or --corridor FILE")
    for name in ("width_nm", "cell_nm"):
        value = getattr(args, name)
        if not (np.isfinite(value) and value > 0):
            raise ConfigError(f"--{name.replace('_', '-')} {value!r} must be a finite length > 0 [nm]")
    ends = (parse_position(args.start, "--from"), parse_position(args.end, "--to"))
    return ends, {
        "corridor_width_nm": args.width_nm,
        "search_options": {"cell_nm": args.cell_nm, "method": SEARCH_METHODS[args.search]},
    }


def _cost_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The cost and solver keyword arguments of the options, validated."""
    from optroute.cli._common import check_cost_options

    check_cost_options(args)
    kw: dict[str, Any] = {"max_leg_nm": args.max_leg_nm}
    if args.objective == "cost":
        kw.update(fuel_price_per_t=args.fuel_price, hourly_cost_per_h=args.hourly_cost)
    if args.max_iter is not None:
        if args.max_iter < 1:
            raise ConfigError(f"--max-iter {args.max_iter} must be >= 1")
        kw["solver_options"] = {"ipopt.max_iter": int(args.max_iter)}
    return kw


def _workers(args: argparse.Namespace) -> dict[str, Any]:
    if args.scheduler is not None and args.workers is not None:
        raise ConfigError(
            f"--workers {args.workers} sizes a local cluster; with --scheduler {args.scheduler!r} the cluster's own "
            "workers are used: drop --workers"
        )
    if args.workers is not None and args.workers < 0:
        raise ConfigError(f"--workers {args.workers} must be >= 0 (0 or 1: serial, in this process)")
    return {"scheduler_address": args.scheduler, "n_workers": args.workers}


@contextlib.contextmanager
def _quiet_dask(args: argparse.Namespace) -> Iterator[None]:
    """Dask's own log lines (worker restarts, nanny warnings) only with ``--debug``."""
    if getattr(args, "debug", False):
        yield
        return
    import logging  # here, not at the top: ``optroute --help`` does not need it

    loggers = [logging.getLogger(name) for name in ("distributed", "dask")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _add_cluster_options(p: argparse.ArgumentParser, default_workers: str) -> None:
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (its workers need optroute installed)",
    )
    p.add_argument("--workers", type=int, default=None, metavar="N", help=f"local Dask workers ({default_workers})")


def front_frame(front: xr.Dataset) -> Any:
    """The front's per-ETA variables as a table: ``eta_utc``, ``eta_h`` then every 1-D variable on ``eta``."""
    import pandas as pd

    from optroute import units

    table: dict[str, Any] = {"eta_utc": [units.format_utc(t) for t in front["eta"].values]}
    if "eta_h" in front.coords or "eta_h" in front:
        table["eta_h"] = front["eta_h"].values
    for name, var in front.data_vars.items():
        if var.dims == ("eta",):
            table[str(name)] = var.values
    return pd.DataFrame(table)


def write_front(front: xr.Dataset, paths: dict[str, Path]) -> list[str]:
    """The front as NetCDF, CSV and a PNG figure, each written atomically."""
    from optroute.plan import outputs
    from optroute.plot.common import save_png

    buf = io.StringIO()
    front_frame(front).to_csv(buf, index=False, lineterminator="\n")
    written = [
        outputs.write_netcdf(front, paths["nc"]),
        outputs.write_bytes(paths["csv"], buf.getvalue().encode()),
    ]
    written.append(save_png(front.plot(), paths["png"]))  # a pyplot-free Figure: nothing to close
    return [str(p) for p in written]


# --------------------------------------------------------------------------- tradeoff


def add_tradeoff(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "tradeoff",
        help="the fuel-versus-ETA front of one voyage (how much fuel each extra hour saves)",
        description=(
            "Solve the corridor optimisation for a sequence of ETAs, each warm-started from its neighbour, from "
            "the earliest feasible arrival to the slow-steaming limit (or for the --etas given), and write the "
            "front as NetCDF, CSV and a PNG figure with the knee marked. ETAs that cannot be met are reported "
            "per point in the 'status' column, never dropped."
        ),
        examples="""
  optroute tradeoff --from 32.71,-117.17 --to 35.65,139.77 --ship container_8000teu \\
      --weather north_pacific_storms --n 20 --out runs/front/
  optroute tradeoff --corridor route.geojson --width-nm 40 --weather forecast.nc \\
      --etas +240:+300:10 --workers 2 --out runs/front_leg1
  (--etas: ISO times or +HOURS separated by commas, or +FIRST:+LAST:STEP in hours)
""",
    )
    _add_route_options(p)
    p.add_argument("--ship", required=True, metavar="NAME|FILE.toml", help="ship preset name or ship TOML file")
    p.add_argument("--weather", required=True, metavar="SCENARIO|FILE", help="weather scenario name or weather file")
    p.add_argument(
        "--departure", default=None, metavar="ISO", help="departure, UTC (default: the weather's first time)"
    )
    p.add_argument(
        "--etas", default=None, metavar="LIST", help="the ETAs (default: --n evenly over the feasible range)"
    )
    p.add_argument("--n", type=int, default=30, help="points of the default front")
    _add_cost_options(p)
    _add_cluster_options(p, "default: serial, in this process")
    p.add_argument(
        "--out",
        default="optroute_front/",
        metavar="PREFIX|DIR",
        help="output prefix (PREFIX.nc, .csv, .png) or folder (DIR/front.*)",
    )
    add_progress_option(p)
    p.set_defaults(func=cmd_tradeoff)


def cmd_tradeoff(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute tradeoff``."""
    import numpy as np

    from optroute import units
    from optroute.cli._common import (
        Progress,
        load_ship,
        load_weather,
        output_paths,
        parse_etas,
        parse_time,
        progress_enabled,
    )
    from optroute.cli._status import status_legend
    from optroute.studies.tradeoff import tradeoff

    out = out or sys.stdout
    ship = load_ship(args.ship)
    wx = load_weather(args.weather)
    departure = (
        np.datetime64(wx["time"].values[0], "ns")
        if args.departure is None
        else parse_time(args.departure, "--departure")
    )
    etas = parse_etas(args.etas, departure) if args.etas is not None else None
    if etas is None and args.n < 2:
        raise ConfigError(f"--n {args.n} must be >= 2 (the front's two ends and the points between)")
    route, route_kw = _route(args, wx)
    kw = {**_cost_kwargs(args), **_workers(args), **route_kw}
    output_paths(args.out, "front", create=False)
    with Progress(progress_enabled(args), "front", unit="ETA") as bar, _quiet_dask(args):
        front = tradeoff(
            route, wx, ship, departure=departure, etas=etas, n=args.n, objective=args.objective, progress=bar, **kw
        )
    files = write_front(front, output_paths(args.out, "front"))
    table = front_frame(front)
    lines = [
        f"front      {len(table)} ETAs, ship {ship.name}, objective {args.objective}, "
        f"departure {units.format_utc(departure)}",
        f"{'eta [UTC]':<22}{'eta [h]':>9}{'fuel [t]':>11}{'t/h saved':>11}  status",
    ]
    for _, row in table.iterrows():
        price = float(row.get("eta_shadow_price_t_per_h", float("nan")))
        price_text = f"{price:11.3f}" if np.isfinite(price) else f"{'-':>11}"
        lines.append(
            f"{row['eta_utc']:<22}{row.get('eta_h', float('nan')):9.1f}"
            f"{row.get('fuel_t', float('nan')):11.2f}{price_text}  {row.get('status', '')}"
        )
    lines.append(
        "status     "
        + "\n           ".join(x.strip() for x in status_legend(table["status"], objective=args.objective))
    )
    knee = front.attrs.get("knee_eta_h")
    if isinstance(knee, int | float):
        lines.append(f"knee       at {knee:.1f} h after departure")
    lines.append(f"files      {', '.join(files)}")
    print("\n".join(lines), file=out)
    return 0


# --------------------------------------------------------------------------- study


def add_study(sub: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    p = add_command(
        sub,
        common,
        "study",
        help="ships x weather x ETAs on Dask, resumable, one stored case at a time",
        description=(
            "Optimise every combination of the ships, the weather scenarios (or files) and the ETAs on one route, "
            "on a local Dask cluster or an existing one (--scheduler). Every finished case is written to the store "
            "atomically; a study stopped half-way (Ctrl-C, a killed worker) resumes where it stopped when run "
            "again with the same arguments. The combined results go to DIR/study.nc."
        ),
        examples="""
  optroute study --ships container_54k_dwt,my_ship.toml --scenarios north_pacific_storms,calm \\
      --from 32.71,-117.17 --to 35.65,139.77 --etas +250,+264,+280 --store runs/study1
  optroute study --ships container_8000teu --scenarios ens_m00.nc,ens_m01.nc,ens_m02.nc \\
      --corridor route.geojson --etas 2024-01-20T00:00,2024-01-21T00:00 \\
      --store runs/ens --scheduler tcp://10.0.0.5:8786
""",
    )
    p.add_argument(
        "--ships", required=True, metavar="A,B|FILES", help="ship presets and/or TOML files, comma-separated"
    )
    p.add_argument(
        "--scenarios", required=True, metavar="A,B|FILES", help="weather scenario names and/or files, comma-separated"
    )
    p.add_argument("--etas", required=True, metavar="LIST", help="ISO times or +HOURS, comma-separated, or +A:+B:STEP")
    p.add_argument(
        "--departure", default=None, metavar="ISO", help="departure, UTC (default: the first time of the first weather)"
    )
    p.add_argument("--store", required=True, metavar="DIR", help="study store (created; resumed when it exists)")
    p.add_argument(
        "--recompute-changed",
        action="store_true",
        help="recompute stored cases whose inputs (ship, weather content, route, departure, options) changed, "
        "instead of stopping with an error naming the change",
    )
    _add_route_options(p)
    _add_cost_options(p)
    _add_cluster_options(p, "default: one per core")
    add_progress_option(p)
    p.set_defaults(func=cmd_study)


def _study_etas(text: str, departure: Any, first_time: Any) -> list[Any]:
    """``+HOURS`` lists → hours after departure [h] (floats); ISO lists → UTC times, after the departure."""
    import numpy as np

    from optroute import units
    from optroute.cli._common import parse_etas

    raw = str(text).strip()
    items = [x.strip() for x in raw.split(",") if x.strip()]
    relative = [x.startswith("+") for x in items]
    if any(relative) and not all(relative):
        raise ConfigError(f"--etas {text!r} mixes +HOURS and times; give all ETAs one way")
    if all(relative):
        ref = np.datetime64("2000-01-01T00:00", "ns")
        return [float(units.timedelta_to_h(t - ref)) for t in parse_etas(raw, ref)]
    return parse_etas(raw, departure if departure is not None else first_time)


def cmd_study(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``optroute study``."""
    import numpy as np

    from optroute.cli._common import Progress, load_ship, load_weather, parse_time, progress_enabled, split_list
    from optroute.cli._status import status_legend
    from optroute.studies.voyage_study import study

    out = out or sys.stdout
    ships = [load_ship(s) for s in split_list(args.ships, "--ships")]
    names = [s.name for s in ships]
    if len(set(names)) != len(names):
        raise ConfigError(f"--ships {args.ships!r} names a ship twice ({names}); give each ship once")
    specs = split_list(args.scenarios, "--scenarios")
    if len(set(specs)) != len(specs):
        raise ConfigError(f"--scenarios {args.scenarios!r} names a weather twice; give each once")
    weathers = [load_weather(spec) for spec in specs]  # fail fast here, not on a worker
    first_time = np.datetime64(weathers[0]["time"].values[0], "ns")
    departure = None if args.departure is None else parse_time(args.departure, "--departure")
    etas = _study_etas(args.etas, departure, first_time)
    route, route_kw = _route(args, weathers[0])
    where = {"corridor": route} if args.corridor is not None else {"start": route[0], "end": route[1]}
    kw = {**_cost_kwargs(args), **_workers(args), **where, **route_kw}
    with Progress(progress_enabled(args), "study") as bar, _quiet_dask(args):
        ds = study(
            ships,
            specs,
            etas,
            departure=departure,
            store=args.store,
            objective=args.objective,
            progress=bar,
            on_changed_inputs="recompute" if args.recompute_changed else "error",
            **kw,
        )
    lines = [
        f"study      {len(ships)} ship(s) x {len(specs)} weather x {len(etas)} ETA(s) = "
        f"{len(ships) * len(specs) * len(etas)} cases",
        f"store      {args.store}",
    ]
    table = ds[[v for v in ("fuel_t", "duration_h", "plan_status", "status") if v in ds]].to_dataframe()
    if "plan_status" in table:
        counts = table["plan_status"].astype(str).str.split(":").str[0].value_counts()
        lines.append("outcome    " + ", ".join(f"{n} {k or 'missing'}" for k, n in counts.items()))
        legend = status_legend(table["plan_status"].astype(str), objective=args.objective)
        lines.append("status     " + "\n           ".join(x.strip() for x in legend))
    lines.append("")
    lines.append(table.head(50).to_string(float_format=lambda x: f"{x:,.2f}"))
    if len(table) > 50:
        lines.append(f"... {len(table) - 50} more cases in the store's study.nc")
    print("\n".join(lines), file=out)
    return 0
