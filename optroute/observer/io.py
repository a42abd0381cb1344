"""Motion logs in and out: CSV and NetCDF with time, heave, roll and pitch, units named.

CSV: one header line; the columns are named with their unit as a suffix:
``time_s``, ``heave_m``, ``roll_deg`` or ``roll_rad``, ``pitch_deg`` or
``pitch_rad`` (pitch optional: the observer does not use it, the figure
shows it).  NetCDF: variables ``time``, ``heave``, ``roll`` and ``pitch``
(optional) along one dimension, each with a ``units`` attribute (``s``,
``m``, ``deg``/``degree``/``degrees`` or ``rad``/``radian``/``radians``); a
``time`` of datetime64 is taken as seconds since its first value.

Every problem raises :class:`MotionLogError` naming the file, the column and
the fix; nothing is filled in or skipped.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from optroute.errors import OptrouteError


class MotionLogError(OptrouteError, ValueError):
    """A motion log is missing, unreadable, lacks a column or names no unit."""


_ANGLE_UNITS = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "rad": math.degrees(1.0), "radian": math.degrees(1.0)}
_ANGLE_UNITS["radians"] = _ANGLE_UNITS["rad"]
_NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".h5")


@dataclass(frozen=True)
class MotionLog:
    """A motion record in the observer's units.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s].
    heave_m : ndarray
        Heave z [m], positive up.
    roll_deg : ndarray
        Roll φ [deg].
    pitch_deg : ndarray or None
        Pitch θ [deg], None when the log has none.
    source : str
        The file it came from.
    """

    time_s: np.ndarray
    heave_m: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray | None
    source: str


def _column(path: Path, name: str, values: list[str]) -> np.ndarray:
    out = np.empty(len(values))
    for i, text in enumerate(values):
        try:
            out[i] = float(text)
        except ValueError:
            raise MotionLogError(
                f"{path}: column {name!r} row {i + 2} holds {text!r}, not a number; fix or cut that row"
            ) from None
        if not math.isfinite(out[i]):
            raise MotionLogError(
                f"{path}: column {name!r} row {i + 2} is {text!r}; the observer needs every sample, fill or cut the gap"
            )
    return out


def _pick(path: Path, header: list[str], quantity: str, units: dict[str, float], required: bool) -> str | None:
    """The header name of ``quantity`` (e.g. roll → roll_deg), or None if optional and absent."""
    names = [f"{quantity}_{u}" for u in units]
    found = [h for h in header if h in names]
    if len(found) > 1:
        raise MotionLogError(f"{path}: columns {found} all give the {quantity}; keep one")
    if found:
        return found[0]
    bare = [h for h in header if h.lower().split("[")[0].strip() == quantity]
    if bare:
        raise MotionLogError(
            f"{path}: column {bare[0]!r} names no unit; rename it to one of {names} (the unit as a suffix)"
        )
    if required:
        raise MotionLogError(
            f"{path}: no {quantity} column; the header {header} needs one of {names} "
            "(columns: time_s, heave_m, roll_deg or roll_rad, optionally pitch_deg or pitch_rad)"
        )
    return None


def _read_csv(path: Path) -> MotionLog:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    rows = [r for r in rows if r and not (len(r) == 1 and not r[0].strip())]
    if len(rows) < 3:
        raise MotionLogError(f"{path}: {max(len(rows) - 1, 0)} data row(s); a motion log needs a header and >= 2 rows")
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise MotionLogError(f"{path}: row {i + 2} has {len(r)} fields but the header {len(header)}; fix the row")
    cols = {h: [r[j].strip() for r in body] for j, h in enumerate(header)}
    t_name = _pick(path, header, "time", {"s": 1.0}, True)
    z_name = _pick(path, header, "heave", {"m": 1.0}, True)
    r_name = _pick(path, header, "roll", _ANGLE_UNITS, True)
    p_name = _pick(path, header, "pitch", _ANGLE_UNITS, False)
    roll = _column(path, r_name, cols[r_name]) * _ANGLE_UNITS[r_name.split("_", 1)[1]]
    pitch = None
    if p_name is not None:
        pitch = _column(path, p_name, cols[p_name]) * _ANGLE_UNITS[p_name.split("_", 1)[1]]
    return MotionLog(
        time_s=_column(path, t_name, cols[t_name]),
        heave_m=_column(path, z_name, cols[z_name]),
        roll_deg=roll,
        pitch_deg=pitch,
        source=str(path),
    )


def _nc_var(path: Path, ds: Any, name: str, units: dict[str, float], required: bool) -> np.ndarray | None:
    if name not in ds.variables:
        if required:
            raise MotionLogError(
                f"{path}: no variable {name!r}; the file needs 'time', 'heave' and 'roll' (and optionally 'pitch') "
                f"with a units attribute each (has {sorted(ds.variables)})"
            )
        return None
    var = ds[name]
    if name == "time" and np.issubdtype(var.dtype, np.datetime64):
        t = var.values.astype("datetime64[ns]").astype(np.int64)
        return (t - t[0]) / 1e9
    unit = str(var.attrs.get("units", "")).strip()
    if unit not in units:
        raise MotionLogError(
            f"{path}: variable {name!r} has units={unit!r}; set its units attribute to one of {sorted(units)}"
        )
    values = np.asarray(var.values, dtype=float).ravel() * units[unit]
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.argmax(bad))
        raise MotionLogError(f"{path}: variable {name!r} is {values[i]!r} at index {i}; fill or cut the gap")
    return values


def _read_netcdf(path: Path) -> MotionLog:
    import xarray as xr

    try:
        ds = xr.open_dataset(path, decode_times=True)
    except Exception as exc:  # noqa: BLE001 - any backend failure is an unreadable file for the user
        raise MotionLogError(f"{path}: not a readable NetCDF file ({type(exc).__name__}: {exc})") from exc
    with ds:
        t = _nc_var(path, ds, "time", {"s": 1.0, "seconds": 1.0}, True)
        z = _nc_var(path, ds, "heave", {"m": 1.0, "metre": 1.0, "meter": 1.0}, True)
        r = _nc_var(path, ds, "roll", _ANGLE_UNITS, True)
        p = _nc_var(path, ds, "pitch", _ANGLE_UNITS, False)
    sizes = {"time": t.size, "heave": z.size, "roll": r.size} | ({} if p is None else {"pitch": p.size})
    if len(set(sizes.values())) != 1:
        raise MotionLogError(f"{path}: the variables have different lengths {sizes}; they must share one time axis")
    return MotionLog(time_s=t, heave_m=z, roll_deg=r, pitch_deg=p, source=str(path))


def read_motion_log(path: str | Path) -> MotionLog:
    """Read a motion log (CSV, or NetCDF by its suffix .nc/.nc4/.netcdf/.h5).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    MotionLog
        Time [s], heave [m], roll [deg] and pitch [deg] (or None).

    Raises
    ------
    MotionLogError
        Missing file, missing column or variable, a column without its unit,
        a non-numeric or missing value.
    """
    p = Path(path)
    if not p.is_file():
        raise MotionLogError(f"motion log {str(p)!r} does not exist; give the path of a CSV or NetCDF file")
    if p.suffix.lower() in _NETCDF_SUFFIXES:
        return _read_netcdf(p)
    return _read_csv(p)


def write_motion_csv(path: str | Path, time_s: Any, heave_m: Any, roll_deg: Any, pitch_deg: Any = None) -> Path:
    """Write a motion log as CSV (``time_s,heave_m,roll_deg[,pitch_deg]``), atomically.

    Returns the path written.
    """
    from optroute._store import atomic_write_bytes

    cols = [np.asarray(time_s, float), np.asarray(heave_m, float), np.asarray(roll_deg, float)]
    names = ["time_s", "heave_m", "roll_deg"]
    if pitch_deg is not None:
        cols.append(np.asarray(pitch_deg, float))
        names.append("pitch_deg")
    lines = [",".join(names)]
    lines += [",".join(f"{v:.10g}" for v in row) for row in zip(*cols, strict=True)]
    out = Path(path)
    atomic_write_bytes(out, ("\n".join(lines) + "\n").encode())
    return out


def read_righting_moment(path: str | Path) -> Any:
    """A righting-moment characteristic from a CSV table (``heave_m,roll_deg,moment_knm``).

    One row per node of a full grid over heave [m] and roll [deg] (any row
    order), e.g. from trials (EP 2377756) or a hydrostatics program; the
    moment M_φ in kN·m, positive (righting) for positive roll when stable.

    Returns
    -------
    optroute.observer.level.RightingMoment

    Raises
    ------
    MotionLogError
        Missing file or column, a non-number, or nodes that do not fill the grid.
    """
    from optroute.observer.level import RightingMoment

    p = Path(path)
    if not p.is_file():
        raise MotionLogError(f"righting-moment table {str(p)!r} does not exist; give a CSV heave_m,roll_deg,moment_knm")
    with open(p, newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(fh) if r]
    header = [h.strip() for h in rows[0]] if rows else []
    need = ("heave_m", "roll_deg", "moment_knm")
    missing = [c for c in need if c not in header]
    if missing:
        raise MotionLogError(f"{p}: columns {missing} missing; the header {header} must name {list(need)}")
    body = rows[1:]
    cols = {c: _column(p, c, [r[header.index(c)].strip() for r in body]) for c in need}
    zs, ps = np.unique(cols["heave_m"]), np.unique(cols["roll_deg"])
    if zs.size * ps.size != len(body):
        raise MotionLogError(
            f"{p}: {len(body)} rows do not fill the grid of {zs.size} heave × {ps.size} roll values "
            "(each pair once); add the missing nodes or remove repeated ones"
        )
    grid = np.full((zs.size, ps.size), np.nan)
    grid[np.searchsorted(zs, cols["heave_m"]), np.searchsorted(ps, cols["roll_deg"])] = cols["moment_knm"]
    if np.isnan(grid).any():
        raise MotionLogError(f"{p}: some (heave, roll) pairs repeat and others are missing; give each pair once")
    return RightingMoment(heave_m=zs, roll_deg=ps, moment_knm=grid, source=str(p))
