"""Cyclone tracks as forecasters publish them: ATCF b-deck/a-deck lines and IBTrACS CSV.

A :class:`CycloneTrack` holds, per track point, the centre, the time, the maximum wind, the
central pressure and the radii of 34/50/64-kn winds by quadrant (NE, SE, SW, NW), and gives the
force-7 radius R of the typhoon-avoidance patent (the circle to avoid, its safe distance
R + 30 km), interpolated in time along the track (longitude unwrapped, so a track may cross the
antimeridian), and a forecast cone that widens with lead time.

Formats (column layouts from the ATCF documentation, "Best Track/Objective Aid/Wind Radii
Format", and NOAA NCEI's IBTrACS v04 column documentation):

* ATCF (comma separated): ``BASIN, CY, YYYYMMDDHH, TECHNUM/MIN, TECH, TAU, LatN/S, LonE/W, VMAX,
  MSLP, TY, RAD, WINDCODE, RAD1, RAD2, RAD3, RAD4, RADP, RRP, MRD, ...``: latitude and longitude
  in tenths of a degree with a hemisphere letter, VMAX [kn], MSLP [hPa], RAD the wind of the radii
  (34, 50, 64 kn; 0 or 35 for none), WINDCODE ``NEQ`` (radii in the quadrants NE, SE, SW, NW) or
  ``AAA`` (full circle), RAD1–4 [nm], RADP the pressure of the outermost closed isobar [hPa], RRP
  its radius [nm], MRD the radius of maximum wind [nm].  A b-deck holds ``TECH = BEST``, ``TAU = 0``
  (one line per wind threshold); an a-deck holds forecasts (``TECH`` an aid such as ``OFCL`` or
  ``JTWC``, ``TAU`` the lead time [h]): the track read is one aid's forecast from one DTG, valid at
  DTG + TAU.
* IBTrACS CSV: a header row, a units row, then ``SID, SEASON, NUMBER, BASIN, SUBBASIN, NAME,
  ISO_TIME, NATURE, LAT, LON, WMO_WIND, WMO_PRES, ... USA_WIND, USA_PRES, ... USA_R34_NE ...
  USA_R64_NW, USA_POCI, USA_ROCI, USA_RMW, ...`` (blank where missing); winds [kn], pressures
  [hPa], radii [nm].

The force-7 radius R (Beaufort 7, 10 m wind of at least 13.9 m/s = 27.0 kn; WMO No. 306):

* from the 34-kn radii when a point has them: the largest quadrant radius R34 carried outward
  to 13.9 m/s by the modified Rankine vortex V r^x = const (Depperman 1947; Hughes 1952) with
  x = 0.5 (a modelling choice; 0.4–0.6 is the usual range outside the radius of maximum wind):
  R = R34 (V34 / V7)^(1/x).  The largest quadrant makes the circle conservative (the patent
  avoids a circle, not a quadrant shape).
* else from the central pressure with Holland's (1980) profile
  (:func:`optroute.weather.cyclone.cyclone_radius_km`): Δp = environmental pressure (the outermost
  closed isobar when given, else 1010 hPa) − central pressure; R_max from MRD/USA_RMW when given,
  else 40 km (a modelling choice); Holland's B from V_max = sqrt(B Δp / (ρ e)) with the gradient
  V_max = VMAX / 0.8 (the 10 m factor of :mod:`optroute.weather.cyclone`), else B = 1.4.

The cone: the uncertainty of a forecast position grows with its lead time; the circle to avoid is
R + margin + ``cone_km_per_h`` × lead.  ``DEFAULT_CONE_KM_PER_H`` = 3 km/h (72 km a day) is a
modelling choice of the order of recent official 24-h track errors in the western North Pacific
(about 70–90 km); pass the figure of the agency whose forecast is used.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from optroute import geodesy as geo
from optroute import units
from optroute._checks import finite
from optroute._store import atomic_write_bytes
from optroute.errors import ConfigError
from optroute.weather.cyclone import BEAUFORT_7_MS, cyclone_radius_km

__all__ = [
    "DEFAULT_CONE_KM_PER_H",
    "RANKINE_DECAY",
    "CycloneTrack",
    "TrackFormatError",
    "read_atcf",
    "read_ibtracs",
    "read_track",
    "write_atcf",
]

KM_PER_NM = 1.852
KN_PER_MS = 3600.0 / 1852.0
RANKINE_DECAY = 0.5
"""Exponent x of the modified Rankine vortex V r^x = const outside the radius of maximum wind [-]."""
DEFAULT_CONE_KM_PER_H = 3.0
"""Growth of the forecast cone with lead time [km/h] (a modelling choice, see the module docstring)."""
ENV_PRESSURE_HPA = 1010.0
DEFAULT_RMAX_KM = 40.0
DEFAULT_HOLLAND_B = 1.4
_QUADRANTS = ("NE", "SE", "SW", "NW")


class TrackFormatError(ConfigError):
    """A cyclone track file that cannot be read: names the file, the line, the value and a fix."""


@dataclass(frozen=True)
class CycloneTrack:
    """A cyclone's track: one entry per point, strictly increasing in time.

    Attributes
    ----------
    time : ndarray of datetime64[ns]
        Valid time of every point [UTC].
    lat_deg, lon_deg : ndarray
        Centre [deg], longitude in [-180, 180).
    vmax_kn : ndarray
        Maximum sustained 10 m wind [kn], NaN when not given.
    pressure_hpa : ndarray
        Central pressure [hPa], NaN when not given.
    r34_nm, r50_nm, r64_nm : ndarray, shape (n, 4)
        Radii of 34/50/64-kn winds in the quadrants NE, SE, SW, NW [nm], NaN when not given.
    rmax_nm, env_pressure_hpa : ndarray
        Radius of maximum wind [nm] and outermost closed isobar [hPa], NaN when not given.
    lead_h : ndarray
        Forecast lead time [h] (0 for a best track or analysis).
    name : str
    source : str
        The file it was read from, for messages.
    """

    time: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    vmax_kn: np.ndarray
    pressure_hpa: np.ndarray
    r34_nm: np.ndarray
    r50_nm: np.ndarray
    r64_nm: np.ndarray
    rmax_nm: np.ndarray
    env_pressure_hpa: np.ndarray
    lead_h: np.ndarray
    name: str = "cyclone"
    source: str = ""
    _r7: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.atleast_1d(np.asarray(self.time, dtype="datetime64[ns]"))
        n = t.size
        if n == 0 or np.isnat(t).any() or np.any(np.diff(t) <= np.timedelta64(0, "ns")):
            raise ConfigError(f"{self._who}: track times must be non-empty and strictly increasing, got {t}")
        lat = finite("lat_deg", np.broadcast_to(self.lat_deg, (n,)), error=ConfigError).astype(float)
        if np.any(np.abs(lat) > 90.0):
            raise ConfigError(f"{self._who}: latitude outside [-90, 90] in {lat}; give (lat, lon) in degrees")
        lon = units.wrap_180(finite("lon_deg", np.broadcast_to(self.lon_deg, (n,)), error=ConfigError))
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "lat_deg", lat)
        object.__setattr__(self, "lon_deg", np.asarray(lon, dtype=float))
        for name in ("vmax_kn", "pressure_hpa", "rmax_nm", "env_pressure_hpa", "lead_h"):
            v = np.array(np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (n,)))
            if np.any(v[np.isfinite(v)] < 0) or np.isinf(v).any():
                raise ConfigError(f"{self._who}: {name} must be >= 0 or NaN (not given), got {v}")
            object.__setattr__(self, name, v)
        for name in ("r34_nm", "r50_nm", "r64_nm"):
            v = np.array(np.broadcast_to(np.asarray(getattr(self, name), dtype=float), (n, 4)))
            if np.any(v[np.isfinite(v)] < 0) or np.isinf(v).any():
                raise ConfigError(f"{self._who}: {name} must be >= 0 or NaN (not given), got {v}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "_r7", np.array([self._r7_point(k) for k in range(n)]))

    @property
    def _who(self) -> str:
        return f"cyclone track {self.name!r}" + (f" from {self.source}" if self.source else "")

    # ------------------------------------------------------------------ the force-7 circle
    @property
    def r7_km(self) -> np.ndarray:
        """Force-7 radius R at every point [km] (see the module docstring for the two ways)."""
        return self._r7.copy()

    def _r7_point(self, k: int) -> float:
        r34 = self.r34_nm[k]
        if np.isfinite(r34).any() and np.nanmax(r34) > 0:
            v7_kn = BEAUFORT_7_MS * KN_PER_MS
            return float(np.nanmax(r34)) * KM_PER_NM * (34.0 / v7_kn) ** (1.0 / RANKINE_DECAY)
        pc = self.pressure_hpa[k]
        if not np.isfinite(pc):
            raise ConfigError(
                f"{self._who}: the point at {units.format_utc(self.time[k])} has neither 34-kn radii nor a central "
                "pressure, so its force-7 radius is unknown; give one of them (ATCF RAD 34 lines or MSLP)"
            )
        penv = self.env_pressure_hpa[k] if np.isfinite(self.env_pressure_hpa[k]) else ENV_PRESSURE_HPA
        dp = penv - pc
        if dp <= 0:
            return 0.0
        rmax = self.rmax_nm[k] * KM_PER_NM if np.isfinite(self.rmax_nm[k]) and self.rmax_nm[k] > 0 else DEFAULT_RMAX_KM
        b = DEFAULT_HOLLAND_B
        if np.isfinite(self.vmax_kn[k]) and self.vmax_kn[k] > 0:
            vg = self.vmax_kn[k] / KN_PER_MS / 0.8
            b = 1.15 * math.e * vg**2 / (dp * 100.0)
        return cyclone_radius_km(float(dp), float(rmax), float(b), float(self.lat_deg[k]))

    # ------------------------------------------------------------------ interpolation
    def _hours(self, time: ArrayLike) -> np.ndarray:
        t = np.asarray(time, dtype="datetime64[ns]")
        return (t - self.time[0]) / np.timedelta64(1, "h")

    def covers(self, time: ArrayLike) -> np.ndarray:
        """Whether the times lie within the track's span."""
        q = self._hours(time)
        return (q >= 0.0) & (q <= float((self.time[-1] - self.time[0]) / np.timedelta64(1, "h")))

    def at(self, time: ArrayLike) -> dict[str, np.ndarray]:
        """Centre, force-7 radius, lead time and motion at UTC times (linear in time between points).

        Outside the track the end values are held (the caller decides whether that is acceptable:
        :meth:`covers`).

        Returns
        -------
        dict of ndarray
            ``lat``, ``lon`` [deg], ``r7_km``, ``lead_h``, ``u_kn``, ``v_kn`` (the centre's motion
            east/north [kn], zero outside the track).
        """
        q = self._hours(time)
        x = self._hours(self.time)
        lon_u = geo.unwrap_lon_deg(self.lon_deg)
        out = {
            "lat": np.interp(q, x, self.lat_deg),
            "lon": units.wrap_180(np.interp(q, x, lon_u)),
            "r7_km": np.interp(q, x, self._r7),
            "lead_h": np.interp(q, x, self.lead_h),
        }
        if x.size > 1:
            k = np.clip(np.searchsorted(x, q, side="right") - 1, 0, x.size - 2)
            dt = x[k + 1] - x[k]
            mid = np.radians(0.5 * (self.lat_deg[k] + self.lat_deg[k + 1]))
            v = (self.lat_deg[k + 1] - self.lat_deg[k]) * 60.0 / dt
            u = (lon_u[k + 1] - lon_u[k]) * 60.0 * np.cos(mid) / dt
            inside = (q >= x[0]) & (q <= x[-1])
            out["u_kn"], out["v_kn"] = np.where(inside, u, 0.0), np.where(inside, v, 0.0)
        else:
            out["u_kn"], out["v_kn"] = np.zeros(np.shape(q)), np.zeros(np.shape(q))
        return out

    def avoid_radius_km(
        self, time: ArrayLike, margin_km: float = 30.0, cone_km_per_h: float = DEFAULT_CONE_KM_PER_H
    ) -> np.ndarray:
        """Radius of the circle to keep out of: R + margin + cone growth × lead time [km]."""
        s = self.at(time)
        return s["r7_km"] + float(margin_km) + float(cone_km_per_h) * s["lead_h"]


# --------------------------------------------------------------------------- readers


def _fail(path: Any, line: int, what: str, value: Any, fix: str) -> TrackFormatError:
    return TrackFormatError(f"{path}, line {line}: {what} {value!r} cannot be read; {fix}")


def _num(path: Any, line: int, name: str, text: str, *, missing: tuple[str, ...] = ("",)) -> float:
    s = text.strip()
    if s in missing:
        return float("nan")
    try:
        v = float(s)
    except ValueError:
        raise _fail(path, line, name, text, f"{name} must be a number (blank when not given)") from None
    if not math.isfinite(v):
        raise _fail(path, line, name, text, f"{name} must be a finite number")
    return v


def _atcf_latlon(path: Any, line: int, lat_s: str, lon_s: str) -> tuple[float, float]:
    lat_s, lon_s = lat_s.strip().upper(), lon_s.strip().upper()
    if len(lat_s) < 2 or lat_s[-1] not in "NS" or not lat_s[:-1].isdigit():
        raise _fail(path, line, "LatN/S", lat_s, "write the latitude in tenths of a degree with N or S, e.g. 152N")
    if len(lon_s) < 2 or lon_s[-1] not in "EW" or not lon_s[:-1].isdigit():
        raise _fail(path, line, "LonE/W", lon_s, "write the longitude in tenths of a degree with E or W, e.g. 1275E")
    lat = int(lat_s[:-1]) / 10.0 * (1 if lat_s[-1] == "N" else -1)
    lon = int(lon_s[:-1]) / 10.0 * (1 if lon_s[-1] == "E" else -1)
    if abs(lat) > 90 or abs(lon) > 360:
        raise _fail(path, line, "position", f"{lat_s} {lon_s}", "latitude at most 900 and longitude at most 3600")
    return lat, lon


def _atcf_time(path: Any, line: int, text: str) -> np.datetime64:
    s = text.strip()
    if len(s) != 10 or not s.isdigit():
        raise _fail(path, line, "YYYYMMDDHH", text, "give the date-time group as 10 digits, e.g. 2022101300")
    try:
        return np.datetime64(f"{s[:4]}-{s[4:6]}-{s[6:8]}T{s[8:10]}:00", "ns")
    except ValueError:
        raise _fail(path, line, "YYYYMMDDHH", text, "give a real date and hour, e.g. 2022101300") from None


def read_atcf(path: str | Path, *, tech: str | None = None, init: Any = None) -> CycloneTrack:
    """Read an ATCF b-deck (best track) or a-deck (one aid's forecast) file.

    Parameters
    ----------
    path : str or Path
    tech : str, optional
        The technique to read (``BEST`` for a b-deck, an aid such as ``OFCL`` or ``JTWC`` in an
        a-deck); default: ``BEST`` if present, else the only technique in the file.
    init : datetime64 or str, optional
        For forecasts: the date-time group of the forecast to read (default the latest).

    Raises
    ------
    TrackFormatError
        A line that cannot be read (file, line number, value and fix), or no line of ``tech``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="ascii", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise TrackFormatError(f"{p}: cannot read the ATCF file ({exc}); give a readable ASCII b-deck/a-deck") from None
    rows: list[dict[str, Any]] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip():
            continue
        f = [c.strip() for c in raw.split(",")]
        if len(f) < 11:
            raise _fail(p, n, "line", raw[:60], "an ATCF line has at least 11 comma-separated fields (BASIN … TY)")
        row = {"line": n, "dtg": _atcf_time(p, n, f[2]), "tech": f[4].upper()}
        row["tau"] = _num(p, n, "TAU", f[5])
        if not math.isfinite(row["tau"]):
            raise _fail(p, n, "TAU", f[5], "give the forecast hour (0 for a best track)")
        row["lat"], row["lon"] = _atcf_latlon(p, n, f[6], f[7])
        row["vmax"] = _num(p, n, "VMAX", f[8])
        row["mslp"] = _num(p, n, "MSLP", f[9], missing=("", "0"))
        row["rad"] = _num(p, n, "RAD", f[11], missing=("", "0")) if len(f) > 11 else float("nan")
        code = f[12].upper() if len(f) > 12 else ""
        radii = [_num(p, n, f"RAD{i + 1}", f[13 + i]) if len(f) > 13 + i else float("nan") for i in range(4)]
        if math.isfinite(row["rad"]):
            if row["rad"] not in (34.0, 35.0, 50.0, 64.0):
                raise _fail(p, n, "RAD", f[11], "the wind of the radii is 34, 50 or 64 kn (0 for none)")
            if code == "AAA":
                radii = [radii[0]] * 4
            elif code not in ("NEQ", ""):
                raise _fail(p, n, "WINDCODE", f[12], "read are NEQ (quadrants NE, SE, SW, NW) and AAA (full circle)")
        row["radii"] = radii
        row["poci"] = _num(p, n, "RADP", f[17], missing=("", "0")) if len(f) > 17 else float("nan")
        row["rmw"] = _num(p, n, "MRD", f[19], missing=("", "0")) if len(f) > 19 else float("nan")
        row["name"] = f[27] if len(f) > 27 and f[27] else ""
        rows.append(row)
    if not rows:
        raise TrackFormatError(f"{p}: no ATCF lines; give a b-deck or a-deck file")
    techs = sorted({r["tech"] for r in rows})
    want = (tech or ("BEST" if "BEST" in techs else (techs[0] if len(techs) == 1 else ""))).upper()
    if want not in techs:
        raise TrackFormatError(
            f"{p}: technique {tech or ''!r} not chosen or not in the file (it holds {techs}); pass tech="
        )
    rows = [r for r in rows if r["tech"] == want]
    if want != "BEST":
        dtgs = sorted({r["dtg"] for r in rows})
        t_init = dtgs[-1] if init is None else np.datetime64(init, "ns")
        if t_init not in dtgs:
            raise TrackFormatError(f"{p}: no {want} forecast from {init}; the file has {[str(d) for d in dtgs]}")
        rows = [r for r in rows if r["dtg"] == t_init]
    return _rows_to_track(rows, p, want)


def _rows_to_track(rows: list[dict[str, Any]], path: Path, tech: str) -> CycloneTrack:
    points: dict[np.datetime64, dict[str, Any]] = {}
    for r in rows:
        valid = r["dtg"] + np.timedelta64(int(round(r["tau"] * 3600)), "s")
        pt = points.setdefault(valid, {"r": {}, **r})
        if (pt["lat"], pt["lon"]) != (r["lat"], r["lon"]):
            raise _fail(
                path, r["line"], "position", f"{r['lat']} {r['lon']}",
                f"lines of one time must share the centre (line {pt['line']} has {pt['lat']} {pt['lon']})",
            )  # fmt: skip
        if math.isfinite(r["rad"]):
            pt["r"][34.0 if r["rad"] == 35.0 else r["rad"]] = r["radii"]
    times = sorted(points)
    nan4 = [float("nan")] * 4

    def col(key: str) -> np.ndarray:
        return np.array([points[t][key] for t in times], dtype=float)

    return CycloneTrack(
        time=np.array(times, dtype="datetime64[ns]"),
        lat_deg=col("lat"),
        lon_deg=col("lon"),
        vmax_kn=col("vmax"),
        pressure_hpa=col("mslp"),
        r34_nm=np.array([points[t]["r"].get(34.0, nan4) for t in times]),
        r50_nm=np.array([points[t]["r"].get(50.0, nan4) for t in times]),
        r64_nm=np.array([points[t]["r"].get(64.0, nan4) for t in times]),
        rmax_nm=col("rmw"),
        env_pressure_hpa=col("poci"),
        lead_h=col("tau"),
        name=next((points[t]["name"] for t in times if points[t]["name"]), tech),
        source=str(path),
    )


_IBTRACS_NEEDED = ("ISO_TIME", "LAT", "LON")


def read_ibtracs(path: str | Path, *, sid: str | None = None) -> CycloneTrack:
    """Read one storm from an IBTrACS v04 CSV file (header row, units row, then one row per point).

    Winds and pressures are the WMO agency's (``WMO_WIND``, ``WMO_PRES``), else the US agency's
    (``USA_WIND``, ``USA_PRES``); radii ``USA_R34_NE`` … ``USA_R64_NW``, ``USA_RMW``, ``USA_POCI``.

    Parameters
    ----------
    path : str or Path
    sid : str, optional
        The storm (``SID``) to read; default the only one in the file.

    Raises
    ------
    TrackFormatError
    """
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            table = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise TrackFormatError(f"{p}: cannot read the IBTrACS file ({exc}); give an IBTrACS v04 CSV") from None
    if not table:
        raise TrackFormatError(f"{p}: empty file; give an IBTrACS v04 CSV")
    head = [h.strip().upper() for h in table[0]]
    missing = [c for c in _IBTRACS_NEEDED if c not in head]
    if missing:
        raise TrackFormatError(f"{p}, line 1: the header lacks {missing}; give an IBTrACS v04 CSV with its header row")
    ix = {h: i for i, h in enumerate(head)}
    body = [(n, r) for n, r in enumerate(table[1:], start=2) if any(c.strip() for c in r)]
    if body and body[0][1][ix["ISO_TIME"]].strip() in ("", "Year"):  # the units row
        body = body[1:]
    sids = sorted({r[ix["SID"]].strip() for _, r in body}) if "SID" in ix else [""]
    want = sid if sid is not None else (sids[0] if len(sids) == 1 else None)
    if want is None or want not in sids:
        raise TrackFormatError(f"{p}: storm sid={sid!r} not chosen or not in the file (it holds {sids}); pass sid=")

    def get(n: int, r: list[str], *names: str) -> float:
        for name in names:
            if name in ix and ix[name] < len(r) and r[ix[name]].strip():
                return _num(p, n, name, r[ix[name]])
        return float("nan")

    times, lat, lon, vmax, pres, rmw, poci, radii = [], [], [], [], [], [], [], {34: [], 50: [], 64: []}
    name = ""
    for n, r in body:
        if "SID" in ix and r[ix["SID"]].strip() != want:
            continue
        s = r[ix["ISO_TIME"]].strip()
        try:
            times.append(np.datetime64(s.replace(" ", "T"), "ns"))
        except ValueError:
            raise _fail(p, n, "ISO_TIME", s, "write the time as YYYY-MM-DD HH:MM:SS (UTC)") from None
        la, lo = get(n, r, "LAT"), get(n, r, "LON")
        if not (math.isfinite(la) and math.isfinite(lo)) or abs(la) > 90:
            raise _fail(
                p, n, "LAT/LON", f"{r[ix['LAT']]} {r[ix['LON']]}", "give the centre in degrees (lat in [-90, 90])"
            )
        lat.append(la)
        lon.append(lo)
        vmax.append(get(n, r, "WMO_WIND", "USA_WIND"))
        pres.append(get(n, r, "WMO_PRES", "USA_PRES"))
        rmw.append(get(n, r, "USA_RMW"))
        poci.append(get(n, r, "USA_POCI"))
        for w in (34, 50, 64):
            radii[w].append([get(n, r, f"USA_R{w}_{q}") for q in _QUADRANTS])
        name = name or (r[ix["NAME"]].strip() if "NAME" in ix else "")
    if len(times) != len(set(times)):
        dup = next(t for t in times if times.count(t) > 1)
        raise TrackFormatError(f"{p}: storm {want} has two rows at {dup}; keep one row per time")
    order = np.argsort(np.array(times, dtype="datetime64[ns]"))

    def arr(v: list[Any]) -> np.ndarray:
        return np.asarray(v, dtype=float)[order]

    return CycloneTrack(
        time=np.array(times, dtype="datetime64[ns]")[order],
        lat_deg=arr(lat),
        lon_deg=arr(lon),
        vmax_kn=arr(vmax),
        pressure_hpa=arr(pres),
        r34_nm=arr(radii[34]),
        r50_nm=arr(radii[50]),
        r64_nm=arr(radii[64]),
        rmax_nm=arr(rmw),
        env_pressure_hpa=arr(poci),
        lead_h=np.zeros(len(times)),
        name=name or want,
        source=str(p),
    )


def read_track(path: str | Path, **kwargs: Any) -> CycloneTrack:
    """Read an ATCF deck or an IBTrACS CSV, told apart by the first line (IBTrACS starts with ``SID``)."""
    p = Path(path)
    try:
        with p.open(encoding="utf-8", errors="replace") as fh:
            first = fh.readline()
    except OSError as exc:
        raise TrackFormatError(f"{p}: cannot open the cyclone track ({exc}); give an existing file") from None
    if first.strip().upper().startswith("SID"):
        return read_ibtracs(p, **kwargs)
    return read_atcf(p, **kwargs)


def _int0(x: float) -> int:
    """ATCF's 0 for "not given"."""
    return 0 if not np.isfinite(x) else round(float(x))


def write_atcf(track: CycloneTrack, path: str | Path, *, basin: str = "WP", number: int = 1) -> Path:
    """Write a track as ATCF b-deck lines (one 34-kn line per point), atomically.

    The 34-kn radii are written when known; otherwise RAD is 0.  Positions are rounded to tenths
    of a degree, as the format holds them.
    """
    lines = []
    for k in range(track.time.size):
        t = track.time[k].astype("datetime64[h]").astype(object)
        la, lo = float(track.lat_deg[k]), float(track.lon_deg[k])
        lat_s = f"{round(abs(la) * 10):d}{'N' if la >= 0 else 'S'}"
        lon_s = f"{round(abs(lo) * 10):d}{'E' if lo >= 0 else 'W'}"
        v, pc = track.vmax_kn[k], track.pressure_hpa[k]
        r34 = track.r34_nm[k]
        has = np.isfinite(r34).all()
        rad = "34, NEQ, " + ", ".join(f"{r:4.0f}" for r in r34) if has else " 0,    ,    0,    0,    0,    0"
        lines.append(
            f"{basin}, {number:02d}, {t:%Y%m%d%H},   , BEST,   0, {lat_s:>4}, {lon_s:>5}, "
            f"{_int0(v):3d}, {_int0(pc):4d}, "
            f"TY, {rad}, {_int0(track.env_pressure_hpa[k]):4d},    0,  {_int0(track.rmax_nm[k]):2d},"
        )
    out = Path(path)
    atomic_write_bytes(out, ("\n".join(lines) + "\n").encode("ascii"))
    return out
