"""Weather benchmark: sampling speed against xarray, and memory of a lazily opened big file.

1. Sampling: one million (time, lat, lon) points from a synthetic 0.25 deg
   global, 7-day, 3-hourly dataset (1440 x 721 x 57, float32; hs, tp and wave
   direction), by :class:`optroute.weather.WeatherSampler` and by plain
   ``xarray.Dataset.interp`` with DataArray indexers on the same points, timed
   side by side in one run.  (xarray interpolates the direction linearly in
   degrees — wrong at 0/360 but the same amount of work.)
2. Lazy opening: a NetCDF file of a few GB (full mode; a small one in quick
   mode) is written to a temporary directory, opened with
   :func:`optroute.weather.open_weather` in a fresh process and sampled at
   some points; the increase in resident memory is compared with the file size.
   The file is deleted afterwards; the case is skipped when the disk is short.

Run ``python -m benchmarks.bench_weather [--quick]``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from benchmarks._cli import bench_main
from benchmarks._measure import alternate, load_line, timed_once
from optroute.weather.sample import _NUMBA_PARALLEL_POINTS

ROOT = Path(__file__).resolve().parents[1]
T0 = np.datetime64("2024-01-01T00:00", "ns")


def _grid(step_deg: float, days: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    times = T0 + np.arange(days * 8 + 1) * np.timedelta64(3, "h")
    lat = np.linspace(-90.0, 90.0, int(round(180.0 / step_deg)) + 1)
    lon = np.arange(-180.0, 180.0, step_deg)
    return times, lat, lon


def _synthetic(step_deg: float, days: int, seed: int = 0) -> xr.Dataset:
    """A canonical float32 dataset with smooth fields (hs, tp, wave direction), built in memory."""
    from optroute.weather.schema import VARIABLES

    times, lat, lon = _grid(step_deg, days)
    nt, ny, nx = times.size, lat.size, lon.size
    rng = np.random.default_rng(seed)
    coslat = np.cos(np.radians(lat)).astype(np.float32)[:, None]
    sinlon = np.sin(np.radians(lon)).astype(np.float32)[None, :]
    data = {name: np.empty((nt, ny, nx), dtype=np.float32) for name in ("hs_m", "tp_s", "wave_from_deg")}
    for k in range(nt):
        phase = np.float32(rng.uniform(0, 2 * np.pi))
        wave = np.sin(np.radians(lon)[None, :] * 3 + phase).astype(np.float32) * coslat
        data["hs_m"][k] = 2.5 + 1.5 * wave + 0.5 * sinlon
        data["tp_s"][k] = 9.0 + 2.0 * wave
        data["wave_from_deg"][k] = np.mod(180.0 + 170.0 * wave + 20.0 * sinlon, 360.0)
    return xr.Dataset(
        {n: (("time", "lat", "lon"), a, dict(VARIABLES[n])) for n, a in data.items()},
        coords={"time": times, "lat": lat, "lon": lon},
        attrs={"source": "synthetic benchmark field"},
    )


def _points(ds: xr.Dataset, n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    span = (ds["time"].values[-1] - ds["time"].values[0]).astype(np.int64)
    t = ds["time"].values[0] + rng.integers(0, span, n).astype("timedelta64[ns]")
    lat = rng.uniform(-89.0, 89.0, n)
    lon = rng.uniform(-180.0, float(ds["lon"].values[-1]), n)  # inside xarray's non-periodic range
    return t, lat, lon


def bench_sampling(quick: bool) -> dict[str, Any]:
    """Time WeatherSampler (numba and numpy kernels) against xarray.Dataset.interp on the same points, alternated.

    Each variant's exact call is made once untimed first (with a million points that is the *parallel*
    numba kernel, whose compilation is reported as the warm-up, not as sampling time); then the three run
    in turn, numba numpy xarray × ``repeats``, and the minimum and median of each are compared.
    """
    from optroute.weather import WeatherSampler

    step, days, n, repeats = (1.0, 7, 100_000, 3) if quick else (0.25, 7, 1_000_000, 3)
    ds = _synthetic(step, days)
    t, lat, lon = _points(ds, n)
    sampler, setup_s = timed_once(lambda: WeatherSampler(ds))
    numpy_sampler = WeatherSampler(ds, engine="numpy")
    idx = {"time": xr.DataArray(t, dims="p"), "lat": xr.DataArray(lat, dims="p"), "lon": xr.DataArray(lon, dims="p")}

    def by_xarray() -> dict[str, np.ndarray]:
        out = ds.interp(idx, method="linear")
        return {v: out[v].values for v in ds.data_vars}

    alt = alternate(
        {
            "sampler": lambda: sampler.sample(t, lat, lon),
            "numpy": lambda: numpy_sampler.sample(t, lat, lon),
            "xarray": by_xarray,
        },
        repeats=repeats,
    )
    ours, theirs = alt.results["sampler"], alt.results["xarray"]
    diff = float(np.max(np.abs(ours["hs_m"] - theirs["hs_m"])))
    tm = alt.timings
    return {
        "grid": f"{step:g} deg global, {days} d 3-hourly ({ds.sizes['lon']}x{ds.sizes['lat']}x{ds.sizes['time']}), 3 vars float32",
        "points": n,
        "parallel_kernel": sampler.engine == "numba" and n >= _NUMBA_PARALLEL_POINTS,
        "alternated": alt.as_dict(),
        "sampler_s": tm["sampler"].median_s,
        "sampler_min_s": tm["sampler"].min_s,
        "sampler_warmup_s": alt.warmup_s["sampler"],
        "sampler_setup_s": setup_s,
        "xarray_interp_s": tm["xarray"].median_s,
        "xarray_interp_min_s": tm["xarray"].min_s,
        "engine": sampler.engine,
        "numpy_engine_s": tm["numpy"].median_s,
        "numpy_engine_min_s": tm["numpy"].min_s,
        "speedup_vs_xarray": tm["xarray"].median_s / tm["sampler"].median_s,
        "speedup_vs_xarray_min": tm["xarray"].min_s / tm["sampler"].min_s,
        "numpy_speedup_vs_xarray": tm["xarray"].median_s / tm["numpy"].median_s,
        "speedup_incl_setup": tm["xarray"].median_s / (tm["sampler"].median_s + setup_s),
        "max_abs_diff_hs_m": diff,
    }


def _rss_bytes(field: str = "VmRSS") -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1]) * 1024
    return 0


def _child(path: str, n: int, load_bytes: int) -> None:
    """In a fresh process: open lazily, sample ``n`` points, report resident memory (JSON on stdout)."""
    import dask.array  # noqa: F401 - imported before the baseline so that library code is not counted
    import netCDF4  # noqa: F401

    from optroute.weather import WeatherSampler, open_weather

    # warm up on a tiny file first, so that library start-up and the JIT are not counted against the big file
    tiny = Path(path).with_name("tiny.nc")
    _synthetic(30.0, 1).to_netcdf(tiny)
    warm = open_weather(tiny)
    WeatherSampler(warm, load_bytes=0).sample(*_points(warm, 1000))
    del warm
    if load_bytes == 0:  # quick mode: treat the small file as a big one all through
        from optroute.weather import io

        io._CHECK_ALL_BYTES = 0
    base = _rss_bytes()
    ds = open_weather(path)
    dask_backed = all(ds[v].chunks is not None for v in ds.data_vars)
    opened = _rss_bytes()
    sampler = WeatherSampler(ds, load_bytes=load_bytes)
    rng = np.random.default_rng(2)
    t = ds["time"].values[0] + rng.integers(0, 2 * 3 * 3600, n).astype("timedelta64[s]")  # within the first 6 h
    t0 = time.perf_counter()
    sampler.sample(t, rng.uniform(-60, 60, n), rng.uniform(-180, 180, n))
    sample_s = time.perf_counter() - t0
    sampled = _rss_bytes()
    print(
        json.dumps(
            {
                "base": base,
                "opened": opened,
                "sampled": sampled,
                "peak": _rss_bytes("VmHWM"),
                "dask_backed": dask_backed,
                "lazy": sampler.lazy,
                "slices": len(sampler._cache),
                "sample_s": sample_s,
            }
        )
    )


def _write_big(path: Path, step: float, nt: int) -> None:
    """Write a canonical file slice by slice (never the whole array in memory)."""
    import netCDF4

    from optroute.weather.schema import COORD_ATTRS, VARIABLES

    _, lat, lon = _grid(step, 1)
    rng = np.random.default_rng(0)
    with netCDF4.Dataset(path, "w") as nc:
        for name, size in (("time", nt), ("lat", lat.size), ("lon", lon.size)):
            nc.createDimension(name, size)
        tv = nc.createVariable("time", "f8", ("time",))
        tv.units, tv.calendar = "hours since 2024-01-01 00:00:00", "standard"
        tv[:] = np.arange(nt) * 3.0
        for name, values in (("lat", lat), ("lon", lon)):
            v = nc.createVariable(name, "f8", (name,))
            v.setncatts(COORD_ATTRS[name])
            v[:] = values
        fields = {}
        for name in ("hs_m", "tp_s", "wave_from_deg"):
            v = nc.createVariable(name, "f4", ("time", "lat", "lon"), chunksizes=(1, lat.size, lon.size))
            v.setncatts(VARIABLES[name])
            fields[name] = v
        base = rng.uniform(0.0, 1.0, (lat.size, lon.size)).astype(np.float32)
        for k in range(nt):
            fields["hs_m"][k] = 1.0 + 3.0 * base
            fields["tp_s"][k] = 6.0 + 6.0 * base
            fields["wave_from_deg"][k] = 359.0 * base


def bench_lazy(quick: bool) -> dict[str, Any]:
    """Resident memory of open_weather + sampling on a file much larger than memory use should be."""
    step, nt, n = (1.0, 57, 10_000) if quick else (0.25, 230, 100_000)
    size = nt * 3 * int(round(180 / step) + 1) * int(round(360 / step)) * 4
    tmp = Path(tempfile.mkdtemp(prefix="optroute-bench-"))
    try:
        free = shutil.disk_usage(tmp).free
        if free < 2 * size:
            return {"skipped": f"needs {2 * size / 1e9:.1f} GB free in {tmp}, has {free / 1e9:.1f} GB"}
        path = tmp / "big.nc"
        t0 = time.perf_counter()
        _write_big(path, step, nt)
        write_s = time.perf_counter() - t0
        load_bytes = 0 if quick else 512 * 2**20  # quick: force the slice-by-slice path on the small file
        code = f"from benchmarks.bench_weather import _child; _child({str(path)!r}, {n}, {load_bytes})"
        out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        file_bytes = path.stat().st_size
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    slice_bytes = file_bytes / nt
    return {
        "file_gb": file_bytes / 1e9,
        "write_s": write_s,
        "points": n,
        "dask_backed": r["dask_backed"],
        "lazy": r["lazy"],
        "slices_read": r["slices"],
        "rss_open_mb": (r["opened"] - r["base"]) / 1e6,
        "rss_sampled_mb": (r["sampled"] - r["base"]) / 1e6,
        "rss_peak_mb": (r["peak"] - r["base"]) / 1e6,
        "peak_over_file": (r["peak"] - r["base"]) / file_bytes,
        "peak_over_slice": (r["peak"] - r["base"]) / slice_bytes,
        "sample_s": r["sample_s"],
    }


def run(quick: bool) -> dict[str, Any]:
    """Run both cases, print a markdown table, return the figures."""
    print(load_line("load average at start"))
    s = bench_sampling(quick)
    lz = bench_lazy(quick)
    print(f"\n### Weather sampling — {s['grid']}, {s['points']:,} random points\n")
    a = s["alternated"]
    kernel = f"{s['engine']} kernel" + (", parallel" if s["parallel_kernel"] else ", serial")
    print(f"_The same points sampled by each; the three alternated {' '.join(a['order'])} × {a['repeats']} after "
          "one untimed call of each (the exact kernel timed, compiled there); ratios to xarray (baseline)._\n")  # fmt: skip
    print("| method | min [s] | median [s] | xarray / method (medians) | xarray / method (minima) |")
    print("|---|---:|---:|---:|---:|")
    print(f"| `xarray.Dataset.interp` (DataArray indexers), baseline | {s['xarray_interp_min_s']:.3f} | "
          f"{s['xarray_interp_s']:.3f} | 1.0 | 1.0 |")  # fmt: skip
    print(f"| `WeatherSampler.sample` ({kernel}) | {s['sampler_min_s']:.3f} | {s['sampler_s']:.3f} | "
          f"{s['speedup_vs_xarray']:.1f} | {s['speedup_vs_xarray_min']:.1f} |")  # fmt: skip
    print(f"| `WeatherSampler.sample` (numpy kernel) | {s['numpy_engine_min_s']:.3f} | {s['numpy_engine_s']:.3f} | "
          f"{s['numpy_speedup_vs_xarray']:.1f} | {s['xarray_interp_min_s'] / s['numpy_engine_min_s']:.1f} |")  # fmt: skip
    print(f"\none-off costs, not in the timings: `WeatherSampler` set-up {s['sampler_setup_s']:.3f} s (xarray / "
          f"(set-up + median sample) {s['speedup_incl_setup']:.1f}); first call of the {kernel} (compilation or "
          f"cache load) {s['sampler_warmup_s']:.2f} s; load average (1 min) {a['load_before'][0]:.2f} before, "
          f"{a['load_after'][0]:.2f} after")  # fmt: skip
    print(f"\nmax |hs_m(sampler) - hs_m(xarray)| = {s['max_abs_diff_hs_m']:.2e} m\n")
    print("### Lazy open of a large NetCDF file\n")
    if "skipped" in lz:
        print(f"skipped: {lz['skipped']}")
    else:
        print(
            "| file [GB] | points | dask-backed | slices read | RSS after open [MB] | RSS after sampling [MB] | peak RSS [MB] | peak / file size | peak / one time slice |"
        )
        print("|---:|---:|:---:|---:|---:|---:|---:|---:|---:|")
        print(
            f"| {lz['file_gb']:.2f} | {lz['points']:,} | {lz['dask_backed']} | {lz['slices_read']} | {lz['rss_open_mb']:.0f} | "
            f"{lz['rss_sampled_mb']:.0f} | {lz['rss_peak_mb']:.0f} | {lz['peak_over_file']:.3f} | {lz['peak_over_slice']:.1f} |"
        )
    return {"sampling": s, "lazy": lz}


def main(argv: list[str] | None = None) -> None:
    bench_main(run, __doc__.splitlines()[0], "a 1 deg grid, fewer points, a small file", argv)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    main()
