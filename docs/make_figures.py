"""Regenerate the README's figures and their manifest: ``python docs/make_figures.py``.

Runs :func:`optroute.cli.demo.run_demo` (the same computation as ``optroute demo``:
San Diego → Tokyo through ``north_pacific_storms()``, searched and optimised)
in a temporary folder and copies its PNG figures to ``docs/figures/``, each
written atomically; then draws the fuel-versus-ETA front (:func:`front_png`, the
benchmarks' front corridor).  Nothing is drawn by hand; run it again after a
change to the physics, the search, the optimiser or the figures, and commit the
PNGs with ``docs/figures/manifest.json``.

The manifest records what the figures were drawn from and what they show:

* ``inputs`` and ``inputs_sha256``: every input of the figures (the ships, the
  demo's and the front's settings, and a hash of each weather dataset's values
  rounded to 1e-4), from :func:`figure_inputs`;
* ``figures``: each PNG's SHA-256 (so a PNG copied in from elsewhere, or left
  from an earlier run, does not match) and the numbers it shows;
* ``readme_quotes``: the demo's figures as the README's prose quotes them.

``tests/test_figures.py`` checks the manifest against the repository without
re-running the search and the optimiser (minutes): the inputs recomputed, the
PNG hashes, the README's quotes, and the great-circle baseline (the cheap,
deterministic part of the demo: Boeing's speed reduction along fixed waypoints)
re-sailed with the current physics.  Pixel comparisons are avoided on purpose:
they change with the matplotlib version.

Options: ``--out DIR`` (default ``docs/figures`` next to this script),
``--cell-nm`` (search grid cell [nm], default 40 as in ``optroute demo``).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import hashlib
import io
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MAX_BYTES = 300_000  # keep the repository light: every figure below 300 kB
FRONT_LEGS = 60  # legs of the front's corridor
FRONT_POINTS = 10  # ETAs of the front
MANIFEST = "manifest.json"
SHAO_FULL = True
"""``shao.png`` on the paper's lattice (minutes of DP per case) or on the benchmark's quick lattice (both cases)."""


def _front_case() -> tuple[Any, xr.Dataset, Any, dict[str, Any], np.datetime64]:
    """The benchmarks' front corridor (``benchmarks/bench_front.py``): corridor, weather, ship, options, departure."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks.bench_front import T0, case

    corridor, wx, ship, kw = case(FRONT_LEGS)
    return corridor, wx, ship, kw, T0


@functools.cache
def demo_weather() -> xr.Dataset:
    """The demo's weather, ``north_pacific_storms()`` (built once per process)."""
    from optroute import scenarios

    return scenarios.north_pacific_storms()


def dataset_sha256(ds: xr.Dataset) -> str:
    """SHA-256 of a dataset's coordinates and variables, values rounded to 1e-4 (names, shapes and values)."""
    h = hashlib.sha256()
    for name in sorted(ds.variables):
        values = ds[name].values
        if np.issubdtype(values.dtype, np.number):
            values = np.round(values.astype(float), 4)
        else:
            values = values.astype(str)
        h.update(f"{name}{values.shape}".encode())
        h.update(np.ascontiguousarray(values).tobytes())
    return h.hexdigest()


def _ship_fields(ship: Any) -> dict[str, Any]:
    """The ship's particulars (its free-text ``description`` is no input of any figure)."""
    fields = {k: v for k, v in dataclasses.asdict(ship).items() if k != "description"}
    return json.loads(json.dumps(fields, default=str))


def figure_inputs(cell_nm: float = 40.0) -> dict[str, Any]:
    """Every input of the figures as JSON-able values (a few seconds: it builds both weather datasets).

    Parameters
    ----------
    cell_nm : float
        The demo's search grid cell [nm].

    Returns
    -------
    dict
        ``demo``: ship, endpoints, speeds, ETA, corridor width, optimiser settings and the
        weather's hash; ``front``: ship, corridor waypoints and width, options, number of ETAs
        and the weather's hash.
    """
    from optroute.cli import demo
    from optroute.physics.ship import Ship

    corridor, wx_front, ship_front, kw, t0 = _front_case()
    run_demo_defaults = {
        p: v for p, v in demo.run_demo.__kwdefaults__.items() if p not in ("figures", "optimise", "cell_nm")
    }
    return {
        "demo": {
            "ship": _ship_fields(Ship.preset(demo.SHIP_PRESET).replace(min_load_fraction=0.0)),
            "model": "CalmWaterModel",
            "start": list(demo.SAN_DIEGO),
            "end": list(demo.TOKYO),
            "service_speed_kn": demo.SERVICE_SPEED_KN,
            "eta_h": demo.SEED_ETA_H,
            "corridor_width_nm": demo.CORRIDOR_WIDTH_NM,
            "band_solves": demo.BAND_SOLVES,
            "fuel_price_usd_per_t": demo.FUEL_PRICE_USD_PER_T,
            "cell_nm": float(cell_nm),
            **run_demo_defaults,
            "weather_sha256": dataset_sha256(demo_weather()),
        },
        "shao": shao_inputs(),
        "front": {
            "ship": _ship_fields(ship_front),
            "departure": str(t0),
            "waypoints": np.round(corridor.waypoints, 6).tolist(),
            "half_width_nm": np.round(corridor.half_width_nm, 6).tolist(),
            "options": kw,
            "n": FRONT_POINTS,
            "weather_sha256": dataset_sha256(wx_front),
        },
    }


def shao_settings() -> dict[str, Any]:
    """The settings ``shao.png`` is drawn with: the benchmark's (:data:`SHAO_FULL`: the paper's lattice) for both cases."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks import bench_shao

    return {**bench_shao.settings(not SHAO_FULL), "cases": (1, 2)}


def shao_inputs() -> dict[str, Any]:
    """The inputs of ``shao.png``: the ship, the settings (:func:`shao_settings`) and both cases' weather hashes."""
    from benchmarks import bench_shao
    from benchmarks._cli import jsonable
    from optroute import scenarios
    from optroute.physics.ship import Ship

    cfg = shao_settings()
    return {
        "ship": _ship_fields(Ship.preset(bench_shao.SHIP)),
        "settings": jsonable(cfg),
        "weather_sha256": [dataset_sha256(scenarios.shao_case(c)) for c in cfg["cases"]],
    }


def shao_png(result: dict[str, Any]) -> tuple[bytes, dict[str, Any]]:
    """Shao et al.'s fuel against required arrival time, both cases side by side: PNG bytes and its numbers.

    ``result`` is ``benchmarks.bench_shao.run(..., cfg=shao_settings())`` (or the JSON of such a run);
    its settings must be :func:`shao_settings`.
    """
    import matplotlib.pyplot as plt

    from benchmarks import bench_shao
    from benchmarks._cli import jsonable

    if jsonable(result["settings"]) != jsonable(shao_settings()):
        raise SystemExit("the Shao et al. result was not run with shao_settings(); run it again")
    fig, axes = plt.subplots(1, len(result["cases"]), figsize=(11.0, 4.4), squeeze=False)
    numbers = {}
    for ax, res in zip(axes[0], result["cases"], strict=True):
        bench_shao.draw(ax, res)
        numbers[f"case_{res['case']}"] = {
            "dp_window_h": res["dp_window_h"],
            "dp_best": {k: round(float(v), 3) for k, v in res["dp_best"].items()},
            "eta_h": [r["eta_h"] for r in res["rows"]],
            "baseline_t": [round(float(r["baseline_t"]), 3) for r in res["rows"]],
            "dp_t": [round(float(r["dp_t"]), 3) for r in res["rows"]],
        }
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue(), numbers


def inputs_sha256(inputs: dict[str, Any]) -> str:
    """SHA-256 of :func:`figure_inputs`'s result (canonical JSON, keys sorted)."""
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def great_circle_numbers(endpoints: list[list[float]]) -> dict[str, float]:
    """Re-sail the demo's great-circle baseline between its (snapped) ports: what ``profile_great_circle.png`` shows.

    Parameters
    ----------
    endpoints : [[lat, lon], [lat, lon]]
        The searched route's first and last waypoints [deg] (the ports snapped to open water).

    Returns
    -------
    dict
        ``duration_h`` [h], ``distance_nm`` [nm], ``fuel_t`` [t], ``min_stw_kn`` [kn].
    """
    from optroute import geodesy as geo
    from optroute.cli import demo
    from optroute.physics.performance import CalmWaterModel
    from optroute.physics.ship import Ship
    from optroute.search.routing import sail_route

    ship = Ship.preset(demo.SHIP_PRESET).replace(min_load_fraction=0.0)
    wx = demo_weather()
    (la0, lo0), (la1, lo1) = endpoints
    lat, lon = geo.great_circle_points(la0, lo0, la1, lo1, 60)
    route = sail_route(
        np.column_stack([lat, lon]),
        wx,
        ship,
        departure=wx.time.values[0],
        model=CalmWaterModel(ship),
        desired_speed_kn=demo.SERVICE_SPEED_KN,
    )
    return _route_numbers(route)


def _route_numbers(route: Any) -> dict[str, float]:
    return {
        "duration_h": round(route.total_duration_h, 3),
        "distance_nm": round(route.total_distance_nm, 3),
        "fuel_t": round(route.total_fuel_t, 3),
        "min_stw_kn": round(float(np.nanmin(route.stw_kn)), 3),
    }


def front_png() -> tuple[bytes, dict[str, Any]]:
    """The fuel-versus-ETA front of the benchmarks' corridor through a moving storm: PNG bytes and its numbers.

    The corridor and weather of ``benchmarks/bench_front.py`` (container_54k_dwt, 2 × ~1 700 nm
    across the equatorial Pacific, a 6 m storm drifting along it), :data:`FRONT_LEGS` legs,
    :data:`FRONT_POINTS` ETAs from the minimum-time passage to the slow-steaming limit.
    """
    import matplotlib.pyplot as plt

    from optroute.studies.tradeoff import tradeoff

    corridor, wx, ship, kw, t0 = _front_case()
    front = tradeoff(corridor, wx, ship, departure=t0, n=FRONT_POINTS, **kw)
    fig = front.plot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    print(front[["fuel_t", "duration_h"]].to_dataframe()[["fuel_t", "duration_h"]].round(2).to_string())
    numbers = {
        "eta_h": np.round(front.eta_h.values, 3).tolist(),
        "fuel_t": [None if not np.isfinite(f) else round(float(f), 3) for f in front.fuel_t.values],
        "status": [str(s) for s in front.status.values],
        "earliest_arrival_h": round(float(front.attrs["earliest_arrival_h"]), 3),
        "slow_steaming_limit_h": round(float(front.attrs["slow_steaming_limit_h"]), 3),
        "knee_eta_h": round(float(front.attrs["knee_eta_h"]), 3),
    }
    return buf.getvalue(), numbers


def _dh(hours: float) -> str:
    """``"8 d 8 h"`` [h → days and hours, rounded to the hour], as the README writes passage times."""
    whole = int(round(float(hours)))
    return f"{whole // 24} d {whole % 24} h"


def demo_numbers(result: Any) -> tuple[dict[str, dict[str, Any]], list[str]]:
    """What each demo figure shows, and the demo's figures as the README quotes them."""
    gc, searched, plan = result.great_circle, result.searched, result.plan
    plan_numbers = {
        "duration_h": round(plan.duration_h, 3),
        "distance_nm": round(plan.distance_nm, 3),
        "fuel_t": round(plan.total_fuel_t, 3),
        "min_stw_kn": round(float(np.min(plan.stw_kn)), 3),
        "status": plan.status,
    }
    saving = 100.0 * (searched.total_fuel_t - plan.total_fuel_t) / searched.total_fuel_t
    shows = {
        "route_map.png": {
            "great_circle": _route_numbers(gc),
            "searched": _route_numbers(searched),
            "plan": plan_numbers,
            "endpoints": np.round(searched.waypoints[[0, -1]], 6).tolist(),
        },
        "profile_plan.png": plan_numbers,
        "profile_great_circle.png": _route_numbers(gc),
        "polar_storm.png": {"min_stw_kn": round(float(np.nanmin(gc.stw_kn)), 3)},
    }
    quotes = [
        f"takes {_dh(gc.total_duration_h)}",
        f"in {_dh(searched.total_duration_h)}",
        f"saves a further {saving:.0f} % fuel",
    ]
    return shows, quotes


def main(argv: list[str] | None = None) -> int:
    """Run the demo and the front; write the PNGs and the manifest; print each figure's path and size [kB]."""
    from optroute import __version__
    from optroute.cli.demo import run_demo
    from optroute.plan.outputs import write_bytes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "figures", help="folder for the PNGs and the manifest")
    parser.add_argument("--cell-nm", type=float, default=40.0, help="search grid cell [nm]")
    parser.add_argument("--only-shao", action="store_true",
                        help="redraw only shao.png (the other figures' inputs must be unchanged)")  # fmt: skip
    parser.add_argument("--shao-json", type=Path, default=None,
                        help="shao.json of a bench_shao run with shao_settings(), instead of running it")  # fmt: skip
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    inputs = figure_inputs(args.cell_nm)
    pngs: dict[str, bytes] = {}
    figures = {}
    if args.only_shao:  # keep the other figures: their inputs must be those they were drawn from
        old = json.loads((args.out / MANIFEST).read_text(encoding="utf-8"))
        stale = [part for part in inputs if part != "shao" and inputs[part] != old["inputs"].get(part)]
        if stale:
            raise SystemExit(f"the inputs of {stale} changed: run `python docs/make_figures.py` without --only-shao")
        figures = {k: v for k, v in old["figures"].items() if k != "shao.png"}
        quotes = old["readme_quotes"]
        shows: dict[str, Any] = {}
    else:
        with tempfile.TemporaryDirectory(prefix="optroute-figures-") as tmp:
            result = run_demo(tmp, cell_nm=args.cell_nm)
            print(result.table())
            print(f"demo run {result.runtime_s:.0f} s")
            for src in result.files:
                if src.suffix == ".png":
                    pngs[src.name] = src.read_bytes()
        shows, quotes = demo_numbers(result)
        pngs["front.png"], shows["front.png"] = front_png()
    if args.shao_json is not None:
        shao = json.loads(args.shao_json.read_text(encoding="utf-8"))["result"]
    else:
        from benchmarks import bench_shao
        from benchmarks._cli import jsonable

        shao = jsonable(bench_shao.run(not SHAO_FULL, cfg=shao_settings()))
    pngs["shao.png"], shows["shao.png"] = shao_png(shao)
    too_big = []
    for name, data in sorted(pngs.items()):
        dst = write_bytes(args.out / name, data)
        print(f"{dst}  {len(data) / 1000:.0f} kB")
        if len(data) > MAX_BYTES:
            too_big.append(name)
        figures[name] = {"sha256": hashlib.sha256(data).hexdigest(), "shows": shows[name]}
    manifest = {
        "generator": "python docs/make_figures.py",
        "optroute_version": __version__,
        "inputs_sha256": inputs_sha256(inputs),
        "inputs": inputs,
        "figures": figures,
        "readme_quotes": quotes,
    }
    write_bytes(args.out / MANIFEST, (json.dumps(manifest, indent=1, sort_keys=True) + "\n").encode())
    print(f"{args.out / MANIFEST}; the README should say: {'; '.join(quotes)}")
    if too_big:
        print(f"larger than {MAX_BYTES // 1000} kB: {', '.join(too_big)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
