"""What the ``optroute`` subcommands share: the parser class, input parsing and the progress bar.

Inputs are parsed here, each bad value raising an :class:`~optroute.errors.OptrouteError`
subclass that names it and says how to fix it (the command line turns those into exit
code 2 and one line on stderr):

* positions ``LAT,LON`` in decimal degrees (``32.71,-117.17``) or with hemisphere letters
  (``32.71N,117.17W``);
* times in ISO 8601, taken as UTC (``2024-01-10T06:00``; a trailing ``Z`` is accepted),
  an ETA also as ``+HOURS`` after the departure (``+264``);
* a ship as a preset name or a TOML file (:meth:`optroute.physics.ship.Ship.from_toml`);
* weather as a built-in scenario name or a file
  (:func:`optroute.weather.catalogue.load_weather`);
* a corridor from a GeoJSON or CSV file (:func:`read_waypoints`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import xarray as xr

from optroute import units
from optroute.errors import ConfigError, OnLandError

# --------------------------------------------------------------------------- positions and times

_COORD = re.compile(r"^\s*([+-]?\d+(?:\.\d*)?|[+-]?\.\d+)\s*([NSEWnsew]?)\s*$")


#: ``--search`` choices → :func:`optroute.search_route` ``method``.
SEARCH_METHODS = {"grid": "astar", "dp": "dp"}


def parse_position(text: str, what: str) -> tuple[float, float]:
    """``"LAT,LON"`` → (lat, lon) [deg], lon wrapped to [-180, 180).

    Accepts decimal degrees with signs (north and east positive) or hemisphere letters
    (``35.65N,139.77E``).

    Raises
    ------
    ConfigError
        Not two numbers, a letter on the wrong axis, or a latitude outside [-90, 90].
    """
    parts = str(text).split(",")
    if len(parts) != 2:
        raise ConfigError(
            f"{what} {text!r} is not a position; write LAT,LON in degrees, e.g. 32.71,-117.17 or 32.71N,117.17W"
        )
    values = []
    for part, axis, letters in ((parts[0], "latitude", "NS"), (parts[1], "longitude", "EW")):
        m = _COORD.match(part)
        if m is None:
            raise ConfigError(
                f"{what} {text!r}: {part.strip()!r} is not a {axis} in degrees; write LAT,LON, e.g. 32.71,-117.17"
            )
        value, letter = float(m.group(1)), m.group(2).upper()
        if letter:
            if letter not in letters:
                raise ConfigError(
                    f"{what} {text!r}: {letter!r} is not a hemisphere of {axis} ({'/'.join(letters)}); write LAT,LON"
                )
            if value < 0:
                raise ConfigError(f"{what} {text!r}: give either a sign or a hemisphere letter, not both")
            value = -value if letter in "SW" else value
        values.append(value)
    lat, lon = values
    if not -90.0 <= lat <= 90.0:
        raise ConfigError(f"{what} {text!r}: latitude {lat:g} is outside [-90, 90]; write LAT,LON (latitude first)")
    return lat, float(units.wrap_180(lon))


#: ``YYYY-MM-DD`` with an optional ``THH``, ``THH:MM``, ``THH:MM:SS`` or ``THH:MM:SS.fff``.
_ISO_TIME = re.compile(r"^\d{4}-\d{2}-\d{2}(?:[T ]\d{2}(?::\d{2}(?::\d{2}(?:\.\d+)?)?)?)?$")
#: The span ``datetime64[ns]`` holds (numpy wraps around silently outside it).
_NS_FIRST, _NS_LAST = np.datetime64("1678-01-01", "s"), np.datetime64("2262-04-11", "s")
_NEGATIVE_NUMBER = re.compile(r"^-\s*(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?$")


def parse_time(text: str, what: str) -> np.datetime64:
    """An ISO 8601 time (``YYYY-MM-DD[THH[:MM[:SS]]]``, a trailing ``Z`` accepted) as UTC ``datetime64[ns]``.

    Raises
    ------
    ConfigError
        Not in that form, with a time-zone offset, not a calendar time, or outside the years
        1678-2262 that ``datetime64[ns]`` holds (numpy would wrap such a time round silently).
    """
    raw = str(text).strip()
    if raw.endswith(("Z", "z")):
        raw = raw[:-1]
    if re.search(r"[+-]\d\d:?\d\d$", raw) and "T" in raw:
        raise ConfigError(f"{what} {text!r} has a time-zone offset; give the time in UTC, e.g. 2024-01-10T06:00")
    example = "give an ISO 8601 UTC time, e.g. 2024-01-10T06:00"
    if not _ISO_TIME.match(raw):
        raise ConfigError(f"{what} {text!r} is not a time; {example}")
    try:
        t = np.datetime64(raw.replace(" ", "T"), "s")
    except ValueError:
        raise ConfigError(f"{what} {text!r} is not a calendar time; {example}") from None
    if not _NS_FIRST <= t < _NS_LAST:
        raise ConfigError(f"{what} {text!r} is outside the years 1678-2262 that optroute's times hold; {example}")
    return np.datetime64(t, "ns")


def parse_eta(text: str, departure: np.datetime64, what: str = "--eta") -> np.datetime64:
    """``ISO`` or ``+HOURS`` after ``departure`` → UTC time; must be after the departure.

    Raises
    ------
    ConfigError
        Not a time, a negative or zero offset (``-5``, ``+0``), or not after the departure (the
        message names the value, the departure and the fix).
    """
    raw = str(text).strip()
    dep = units.format_utc(departure)
    later = "give +HOURS after the departure (e.g. +264) or an ISO time after it"
    if _NEGATIVE_NUMBER.match(raw):
        raise ConfigError(
            f"{what} {text!r} would be {raw[1:].strip()} h before the departure {dep}, but an ETA comes after it; "
            f"{later}"
        )
    if raw.startswith("+"):
        try:
            hours = float(raw[1:])
        except ValueError:
            raise ConfigError(f"{what} {text!r}: {raw[1:]!r} is not a number of hours; e.g. +264") from None
        if not math.isfinite(hours):
            raise ConfigError(f"{what} {text!r} is not a finite number of hours; e.g. +264")
        if hours <= 0:
            raise ConfigError(f"{what} {text!r} ({hours:g} h) is not after the departure {dep}; {later}")
        if hours > units.timedelta_to_h(np.datetime64(_NS_LAST, "ns") - departure):
            raise ConfigError(
                f"{what} {text!r} falls after 2262, beyond the times optroute holds; give fewer hours, e.g. +264"
            )
        eta = departure + units.h_to_timedelta(hours)
    else:
        eta = parse_time(raw, what)
    if eta <= departure:
        raise ConfigError(f"{what} {text!r} ({units.format_utc(eta)}) is not after the departure {dep}; {later}")
    return np.datetime64(eta, "ns")


def parse_etas(text: str, departure: np.datetime64, what: str = "--etas") -> list[np.datetime64]:
    """A comma-separated list of ETAs (ISO or +HOURS), or ``+A:+B:STEP`` hours after departure."""
    raw = str(text).strip()
    if raw.count(":") == 2 and raw[:1] in "+-" and "T" not in raw:
        try:
            a, b, step = (float(x.strip().lstrip("+")) for x in raw.split(":"))
        except ValueError:
            raise ConfigError(f"{what} {text!r}: write +FIRST:+LAST:STEP in hours, e.g. +240:+300:10") from None
        if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(step) and step > 0 and 0 < a <= b):
            raise ConfigError(
                f"{what} {text!r}: need 0 < FIRST <= LAST and STEP > 0, in hours after the departure, e.g. +240:+300:10"
            )
        hours = np.arange(a, b + 1e-9 * max(1.0, abs(b)), step)
        return [parse_eta(f"+{float(h)!r}", departure, what) for h in hours]
    items = [x for x in raw.split(",") if x.strip()]
    if not items:
        raise ConfigError(f"{what} {text!r} holds no ETA; give ISO times or +HOURS separated by commas")
    return [parse_eta(x, departure, what) for x in items]


def check_cost_options(args: argparse.Namespace) -> None:
    """Check ``--fuel-price`` [currency/t], ``--hourly-cost`` [currency/h], ``--max-leg-nm`` and ``--band-leg-nm`` [nm].

    The fuel price must be > 0: the cost objective values an hour at hourly cost / fuel price tonnes of fuel,
    so a price of 0 leaves it undefined.  An hourly cost of 0 is valid (least fuel alone).

    Raises
    ------
    ConfigError
        A value that is not finite, a fuel price <= 0, an hourly cost < 0 or a leg length <= 0; the message
        names the option and its value.
    """
    price, hourly = args.fuel_price, args.hourly_cost
    if not (math.isfinite(price) and price > 0):
        raise ConfigError(
            f"--fuel-price {price!r} must be a finite price > 0 [currency/t]: the cost objective values an hour "
            "at hourly cost / fuel price tonnes; give the bunker price, e.g. --fuel-price 600, or use "
            "--objective time for the least passage time"
        )
    if not (math.isfinite(hourly) and hourly >= 0):
        raise ConfigError(
            f"--hourly-cost {hourly!r} must be a finite number >= 0 [currency/h]; give 0 for least fuel alone"
        )
    if not (math.isfinite(args.max_leg_nm) and args.max_leg_nm > 0):
        raise ConfigError(f"--max-leg-nm {args.max_leg_nm!r} must be a finite length > 0 [nm]")
    band = getattr(args, "band_leg_nm", None)
    if band is not None and not (math.isfinite(band) and band > 0):
        raise ConfigError(
            f"--band-leg-nm {band!r} must be a finite length > 0 [nm]: leave it out for 20 nm where a band can bind, "
            "or give --max-leg-nm's length to keep one leg length everywhere"
        )


# --------------------------------------------------------------------------- ships and weather


def load_ship(spec: str) -> Any:
    """A :class:`~optroute.physics.ship.Ship` from a preset name or a TOML file path.

    Raises
    ------
    ConfigError
        Neither a preset nor a ``.toml`` path; the message lists the presets.
    ShipSpecError
        The TOML file is missing or invalid (:meth:`Ship.from_toml`).
    """
    from optroute.physics.ship import Ship

    if spec in Ship.presets():
        return Ship.preset(spec)
    if spec.lower().endswith(".toml") or os.sep in spec or Path(spec).exists():
        return Ship.from_toml(spec)
    raise ConfigError(
        f"--ship {spec!r} is neither a ship preset nor a .toml file; valid presets are "
        f"{', '.join(Ship.presets())}, or give the path of a ship TOML file (see Ship.from_toml)"
    )


def load_weather(spec: str) -> xr.Dataset:
    """Weather by built-in scenario name or file (:func:`optroute.weather.catalogue.load_weather`)."""
    from optroute.weather.catalogue import load_weather as _load

    return _load(spec)


def split_list(text: str, what: str) -> list[str]:
    """``"a,b,c"`` → ``["a", "b", "c"]``, at least one item."""
    items = [x.strip() for x in str(text).split(",") if x.strip()]
    if not items:
        raise ConfigError(f"{what} {text!r} is empty; give one or more names or files separated by commas")
    return items


# --------------------------------------------------------------------------- corridor files


def _points_from_geojson(obj: Any, source: str) -> list[tuple[float, float]]:
    def line_points(geom: Any) -> list[list[Any]] | None:
        if not isinstance(geom, dict):
            return None
        if geom.get("type") == "LineString":
            return list(geom.get("coordinates") or [])
        if geom.get("type") == "MultiLineString":
            joined: list[list[Any]] = []
            for part in geom.get("coordinates") or []:
                for p in part:
                    # a line split at the antimeridian (RFC 7946 §3.1.9) repeats the crossing as
                    # +180 and -180 at the same latitude: one point, kept once
                    if (
                        joined
                        and abs(abs(float(p[0])) - 180.0) < 1e-9
                        and abs(abs(float(joined[-1][0])) - 180.0) < 1e-9
                        and float(p[1]) == float(joined[-1][1])
                    ):
                        continue
                    joined.append(p)
            return joined
        return None

    if not isinstance(obj, dict) or "type" not in obj:
        raise ConfigError(
            f"corridor file {source!r} is JSON but not GeoJSON (no 'type'); give a LineString, a Feature or a FeatureCollection"
        )
    coords: list[list[Any]] | None = None
    kind = obj["type"]
    if kind in ("LineString", "MultiLineString"):
        coords = line_points(obj)
    elif kind == "Feature":
        coords = line_points(obj.get("geometry"))
    elif kind == "FeatureCollection":
        feats = [f for f in obj.get("features") or [] if isinstance(f, dict)]
        for f in feats:
            coords = line_points(f.get("geometry"))
            if coords is not None:
                break
        if coords is None:  # no line: the Point features in file order
            pts = [
                f["geometry"].get("coordinates")
                for f in feats
                if isinstance(f.get("geometry"), dict) and f["geometry"].get("type") == "Point"
            ]
            coords = pts if pts else None
    if coords is None:
        raise ConfigError(
            f"corridor file {source!r} holds no LineString, MultiLineString or Point features (GeoJSON type {kind!r}); "
            "give the route as a LineString of [lon, lat] positions"
        )
    out = []
    for k, p in enumerate(coords):
        try:
            lon, lat = float(p[0]), float(p[1])
        except (TypeError, ValueError, IndexError):
            raise ConfigError(f"corridor file {source!r}: position {k} is {p!r}, not [lon, lat] numbers") from None
        out.append((lat, lon))
    return out


_LAT_NAMES = ("lat", "latitude", "lat_deg", "latitude_deg")
_LON_NAMES = ("lon", "long", "longitude", "lon_deg", "longitude_deg")


def _points_from_csv(path: Path, source: str) -> list[tuple[float, float]]:
    import pandas as pd

    try:
        df = pd.read_csv(path, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ConfigError(
            f"corridor file {source!r} cannot be read as CSV ({exc}); give a header lat,lon and one waypoint a row"
        ) from None
    cols = {str(c).strip().lower(): c for c in df.columns}
    lat_col = next((cols[n] for n in _LAT_NAMES if n in cols), None)
    lon_col = next((cols[n] for n in _LON_NAMES if n in cols), None)
    if lat_col is None or lon_col is None:
        raise ConfigError(
            f"corridor file {source!r} has columns {list(map(str, df.columns))}; it needs a latitude column "
            f"({'/'.join(_LAT_NAMES)}) and a longitude column ({'/'.join(_LON_NAMES)}), in degrees"
        )
    out = []
    for k, (la, lo) in enumerate(zip(df[lat_col].tolist(), df[lon_col].tolist(), strict=True)):
        try:
            lat, lon = float(la), float(lo)
        except (TypeError, ValueError):
            raise ConfigError(
                f"corridor file {source!r}: row {k + 1} has lat={la!r}, lon={lo!r}, not numbers in degrees"
            ) from None
        out.append((lat, lon))
    return out


def read_waypoints(path: str | os.PathLike[str], weather: xr.Dataset | None = None) -> np.ndarray:
    """Corridor centreline from a GeoJSON or CSV file, as an (n, 2) array of (lat, lon) [deg].

    GeoJSON (``.geojson``/``.json``): a ``LineString`` or ``MultiLineString`` geometry, a
    ``Feature`` holding one, or a ``FeatureCollection`` whose first line feature is taken (an
    optroute plan file works; a line split at the antimeridian is joined again) or, with no
    line, its ``Point`` features in file order. Positions are [lon, lat] (RFC 7946).
    CSV: a header with a latitude and a longitude column (``lat``/``latitude``,
    ``lon``/``longitude``), one waypoint a row.

    Raises
    ------
    ConfigError
        The file is missing or unreadable, has fewer than two points, a non-finite or
        out-of-range coordinate.
    OnLandError
        A point lies on land (real coastline, unless ``weather`` declares a synthetic geography).
    """
    from optroute.geo import land

    p = Path(path)
    source = os.fspath(path)
    if not p.is_file():
        raise ConfigError(f"corridor file {source!r} does not exist; give a GeoJSON or CSV file of waypoints")
    suffix = p.suffix.lower()
    if suffix in (".geojson", ".json"):
        try:
            obj = json.loads(p.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ConfigError(f"corridor file {source!r} is not valid JSON ({exc})") from None
        pts = _points_from_geojson(obj, source)
    elif suffix in (".csv", ".txt"):
        pts = _points_from_csv(p, source)
    else:
        raise ConfigError(f"corridor file {source!r} has suffix {suffix!r}; give a .geojson/.json or a .csv file")
    if len(pts) < 2:
        raise ConfigError(
            f"corridor file {source!r} has {len(pts)} point(s); a corridor needs at least two waypoints (start and end)"
        )
    wp = np.asarray(pts, dtype=float)
    bad = ~np.isfinite(wp).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ConfigError(f"corridor file {source!r}: point {k} ({pts[k][0]}, {pts[k][1]}) is not finite; fix the file")
    out_lat = np.abs(wp[:, 0]) > 90.0
    if out_lat.any():
        k = int(np.argmax(out_lat))
        raise ConfigError(
            f"corridor file {source!r}: point {k} has latitude {wp[k, 0]:g} outside [-90, 90]; "
            "GeoJSON positions are [lon, lat], CSV columns lat,lon"
        )
    wp[:, 1] = units.wrap_180(wp[:, 1])
    if land.coastline_applies(weather, None):
        on_land = np.asarray(land.is_land(wp[:, 0], wp[:, 1]))
        if on_land.any():
            idx = np.flatnonzero(on_land)
            where = ", ".join(f"{int(k)} ({wp[k, 0]:.4f}, {wp[k, 1]:.4f})" for k in idx[:5])
            more = f" and {idx.size - 5} more" if idx.size > 5 else ""
            raise OnLandError(
                f"corridor file {source!r}: point(s) {where}{more} (lat, lon) lie on land; move them to sea "
                "(start and end at a pilot station, not in the port)"
            )
    return wp


# --------------------------------------------------------------------------- outputs


def output_paths(out: str, default_stem: str, *, create: bool = True) -> dict[str, Path]:
    """``--out PREFIX|DIR`` → ``{"geojson": …, "csv": …, "nc": …, "png": …}``.

    A path that is an existing folder or ends in a separator is a folder (created when
    ``create``, with its parents) and the files are ``<DIR>/<default_stem>.<ext>``; anything
    else is a prefix (``voyage/run1`` → ``voyage/run1.geojson`` …) whose folder must exist. A
    prefix given with one of the suffixes has it removed. Call with ``create=False`` to check
    ``--out`` before the work and create nothing.
    """
    raw = str(out)
    p = Path(raw)
    if raw.endswith((os.sep, "/")) or p.is_dir():
        if p.exists() and not p.is_dir():
            raise ConfigError(f"--out {raw!r} is a file, not a folder; give a folder or a prefix without '/'")
        if create:
            try:
                p.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ConfigError(f"--out {raw!r}: cannot create the folder ({exc.strerror or exc})") from None
        stem = p / default_stem
    else:
        if p.suffix.lower() in (".geojson", ".csv", ".nc", ".png"):
            p = p.with_suffix("")
        folder = p.parent if str(p.parent) else Path(".")
        if not folder.is_dir():
            raise ConfigError(
                f"--out {raw!r}: folder {str(folder)!r} does not exist; create it, or give a folder ending in '/'"
            )
        stem = p
    return {ext: stem.with_name(f"{stem.name}.{ext}") for ext in ("geojson", "csv", "nc", "png")}


# --------------------------------------------------------------------------- progress


class Progress:
    """A progress bar on stderr (tqdm) fed by optroute's callbacks; silent when disabled.

    Call it as ``progress(stage: str, fraction: float)`` (the optimiser) or
    ``progress(done: int, total: int)`` (studies, fronts).
    """

    def __init__(self, enabled: bool, desc: str, stream: TextIO | None = None, *, unit: str = "case") -> None:
        self.enabled = enabled
        self.desc = desc
        self.unit = unit
        self._bar: Any = None
        self._stream = stream if stream is not None else sys.stderr

    def _ensure(self, total: float, unit: str) -> Any:
        if self._bar is None:
            from tqdm import tqdm

            fmt = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}]"
            if unit == "%":
                fmt = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]"
            self._bar = tqdm(
                total=total,
                desc=self.desc,
                unit=unit,
                file=self._stream,
                leave=False,
                bar_format=fmt,
                dynamic_ncols=True,
            )
        return self._bar

    def __call__(self, *args: Any) -> None:
        if not self.enabled or len(args) != 2:
            return
        a, b = args
        if isinstance(a, str):
            bar = self._ensure(100.0, "%")
            bar.set_description_str(f"{self.desc} ({a})", refresh=False)
            bar.n = max(0.0, min(100.0, 100.0 * float(b)))
        else:
            total = max(int(b), 1)
            bar = self._ensure(total, self.unit)
            if bar.total != total:
                bar.total = total
            bar.n = int(a)
        bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def progress_enabled(args: argparse.Namespace) -> bool:
    """``--progress``/``--no-progress``, default: when stderr is a terminal."""
    choice = getattr(args, "progress", None)
    if choice is None:
        return bool(getattr(sys.stderr, "isatty", lambda: False)())
    return bool(choice)


def fmt_duration(hours: float) -> str:
    """``"11 d 02 h 30 min (266.50 h)"``."""
    if not math.isfinite(hours):
        return "n/a"
    total_min = int(round(hours * 60.0))
    d, rem = divmod(total_min, 24 * 60)
    h, m = divmod(rem, 60)
    text = f"{d} d {h:02d} h {m:02d} min" if d else f"{h} h {m:02d} min"
    return f"{text} ({hours:.2f} h)"
