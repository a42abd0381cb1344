"""The corridor NLP's lateral bounds: where its waypoints may move so that every leg stays off land.

The NLP (:mod:`formulations.speed_nlp`) bounds the lateral offset ``y_k`` [nm, port +] of every
waypoint by a box ``[lo_k, hi_k]``; a leg is the great circle between two offset waypoints. This
module chooses the boxes so that **every leg between any two admissible waypoints** is navigable:
off the land mask and out of the weather's no-passage (NaN) cells.

Method (:func:`lateral_bounds`)
-------------------------------
1. **Lattice.** Every leg ``k`` is swept by the great circles from the offset point ``W_k(y)`` to
   ``W_{k+1}(y)`` (same ``y`` at both ends); its points at fractions ``f = j/m_k`` along the leg
   are the lattice *rows*, the offsets ``y`` its *columns*. A leg from ``W_k(a)`` to ``W_{k+1}(b)``
   passes, at fraction ``f``, through the row-``f`` point of offset ``(1 − f) a + f b`` (exactly in
   the developed frame when the two normals are parallel, as they are along one great-circle piece
   of the centreline). With the land mask on, rows and columns are at most one mask cell's shortest
   side / √2 apart (GLOBE: 0.5 nm × cos(latitude) / √2, at least 0.15 nm), so that every mask cell
   holds a lattice point.
2. **Blocked points.** A point is blocked when it is on land (:func:`optroute.geo.land.is_land`), or
   when the weather blocks it: its interpolation stencil holds a NaN of ``hs_m``/``tp_s``/``tm_s``/
   ``wave_from_deg`` at any dataset time bracketing ``times`` (moving no-go areas block their whole
   sweep: conservative, because the bounds are static; with ``static_only`` they are left to the NLP's
   time windows, :mod:`optroute.optimise.timed_no_go`), or it lies outside the dataset's area. Land
   points are then dilated by one mask cell diagonal (in lattice steps), because a leg can cut the
   corner of a land cell between lattice points: the bounds keep about 0.65 nm (GLOBE) off the
   coastline — except within that distance (plus one step) of the two pinned ends, where the
   undilated mask is used so that a port snapped 0.5 nm off the coast stays reachable.
3. **One channel.** Each row's navigable offsets form runs (contiguous intervals). A dynamic
   programme over the rows picks one run per row such that consecutive runs overlap, the first and
   last contain the pinned ends (``y = 0``), and the summed distance of the runs from a reference
   path is least (ties: the wider runs). The reference is the centreline (the search route, for a
   corridor built from :meth:`optroute.Route.corridor`) unless ``reference_port_nm`` is given. An
   island inside the corridor makes the navigable set non-convex; the programme passes it on the
   side nearer the reference over the island's whole length (never switching sides across it), and
   the other side is excluded from the bounds.
4. **Boxes.** With ``[L_i, H_i]`` the chosen run of row ``i`` (leg ``k``, fraction ``f``), a leg
   stays navigable when ``(1 − f) lo_k + f lo_{k+1} ≥ L_i`` and ``(1 − f) hi_k + f hi_{k+1} ≤ H_i``
   for all its rows. The box of station ``k`` is first the intersection of the runs over the two
   legs on either side (each leg then lies in its own rows' common run), with the exact
   ``lo_1 ≥ max L_i / f_i`` (and mirrored) on the two legs whose outer end is pinned at 0. Where
   that intersection is empty (the channel drifts across a long leg), the boxes are the solution of
   the linear programme above maximising the smallest, then the summed, box width.

:func:`avoid_point` is what the verification loop does when a plan still touches land or a
no-passage cell (a feature finer than the lattice): it moves the bounds of that leg's two
waypoints off the offending point, to the side with more room.

Sign conventions as :mod:`optroute.optimise.nlp_inputs`: offsets positive to **port**.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy import ndimage, sparse
from scipy.optimize import linprog

from optroute import geodesy as geo
from optroute.errors import ConfigError, NoSafePassage, OnLandError
from optroute.geo import land
from optroute.physics.passage import navigability_variables
from optroute.search.grid import unit_xyz
from optroute.weather.sample import WeatherSampler

if TYPE_CHECKING:
    from optroute.optimise.nlp_inputs import CorridorFrame

__all__ = ["LAND_STEP_MIN_NM", "ROUTE_AROUND", "avoid_point", "lateral_bounds", "reach_windows", "wave_nan"]

LAND_STEP_MIN_NM = 0.15
"""Finest lattice spacing used for the land mask [nm] (the GSHHG backend is finer than this)."""

ROUTE_AROUND = "widen the corridor, move it, or plan it with plan_voyage so that the search routes around"
"""The advice that ends the message of a corridor closed across its width (:func:`lateral_bounds`)."""

_CHUNK_POINTS = 300_000


# --------------------------------------------------------------------------- lattice


class _Lattice:
    """Rows (points along the legs) × columns (lateral offsets) of one corridor frame."""

    def __init__(self, frame: CorridorFrame, row_step_nm: float, col_step_nm: float) -> None:
        n = frame.n_legs
        d = np.diff(frame.s_nm)
        m = np.maximum(1, np.ceil(d / row_step_nm - 1e-9).astype(np.int64))
        leg = np.repeat(np.arange(n), m)
        self.station_row = np.concatenate([[0], np.cumsum(m)])
        f = (np.arange(leg.size) - self.station_row[leg]) / m[leg]
        self.row_leg = np.concatenate([leg, [n - 1]])
        self.row_f = np.concatenate([f, [1.0]])
        self.row_s_nm = frame.s_nm[self.row_leg] + self.row_f * d[self.row_leg]
        self.row_spacing_min_nm = float(np.min(d / m))
        hw = np.asarray(frame.corridor.half_width_nm, dtype=float)
        self.hw_max = float(np.max(hw))
        j = int(math.ceil(self.hw_max / col_step_nm - 1e-9)) if self.hw_max > 0 else 0
        self.y_nm = np.linspace(-self.hw_max, self.hw_max, 2 * j + 1) if j else np.zeros(1)
        self.centre_col = j
        self.row_hw = (1.0 - self.row_f) * hw[self.row_leg] + self.row_f * hw[self.row_leg + 1]
        kk = np.repeat(np.arange(n + 1), self.y_nm.size)
        yy = np.tile(self.y_nm, n + 1)
        lat, lon = frame.normal_points(kk, yy)
        self._station_xyz = unit_xyz(lat, lon).reshape(n + 1, self.y_nm.size, 3)

    def leg_boxes(self, frame: CorridorFrame, pad_nm: float) -> np.ndarray:
        """Per leg, (lat_min, lat_max, lon_min, lon_max) [deg] holding its sweep padded by ``pad_nm``.

        Longitudes are unwrapped about the leg's first corner (they may leave [-180, 180)). The sweep's
        sides are great-circle arcs between the corners; their bulge (at most (d² + (2 hw)²) / 8R) is
        added to the pad.
        """
        xyz = self._station_xyz[:, [0, self.centre_col, -1]]
        lat = np.degrees(np.arctan2(xyz[..., 2], np.hypot(xyz[..., 0], xyz[..., 1])))
        lon = np.degrees(np.arctan2(xyz[..., 1], xyz[..., 0]))
        corners_lat = np.concatenate([lat[:-1], lat[1:]], axis=1)
        corners_lon = np.concatenate([lon[:-1], lon[1:]], axis=1)
        corners_lon = corners_lon[:, :1] + (corners_lon - corners_lon[:, :1] + 180.0) % 360.0 - 180.0
        d = np.diff(frame.s_nm)
        pad = pad_nm + (d**2 + (2.0 * self.hw_max) ** 2) / (8.0 * 3440.065)
        lat_min, lat_max = corners_lat.min(axis=1) - pad / 60.0, corners_lat.max(axis=1) + pad / 60.0
        coslat = np.maximum(np.cos(np.radians(np.maximum(np.abs(lat_min), np.abs(lat_max)))), 1e-3)
        dlon = pad / (60.0 * coslat)
        return np.column_stack([lat_min, lat_max, corners_lon.min(axis=1) - dlon, corners_lon.max(axis=1) + dlon])

    @property
    def n_rows(self) -> int:
        return int(self.row_leg.size)

    def positions(self, rows: np.ndarray, cols: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lat, lon) [deg] of the lattice points of ``rows`` × ``cols`` (all columns by default), shape (r, c)."""
        k, f = self.row_leg[rows], self.row_f[rows]
        a = self._station_xyz[k] if cols is None else self._station_xyz[k][:, cols]
        b = self._station_xyz[k + 1] if cols is None else self._station_xyz[k + 1][:, cols]
        # normalised linear interpolation of unit vectors: on the great circle, the fraction distorted by
        # O(ω²) (ω the leg's angle: 2e-4 of a 50 nm leg)
        xyz = (1.0 - f)[:, None, None] * a + f[:, None, None] * b
        lat = np.degrees(np.arctan2(xyz[..., 2], np.hypot(xyz[..., 0], xyz[..., 1])))
        lon = np.degrees(np.arctan2(xyz[..., 1], xyz[..., 0]))
        return lat, lon


def _chunks(n_rows: int, n_cols: int) -> list[np.ndarray]:
    per = max(1, _CHUNK_POINTS // max(n_cols, 1))
    return [np.arange(i, min(i + per, n_rows)) for i in range(0, n_rows, per)]


# --------------------------------------------------------------------------- what blocks


def wave_nan(dataset: xr.Dataset) -> np.ndarray:
    """Where the weather marks no passage: a (time, lat, lon) boolean array of the dataset's nodes.

    A node is no passage at a dataset time when any wave variable the referee reads
    (:func:`optroute.physics.passage.navigability_variables`: Hs, the band period, the wave direction)
    is NaN there, the referee's rule (:attr:`optroute.physics.passage.SeaState.navigable`; the sampler
    returns NaN wherever such a node is in its stencil). The variables are combined *before* any
    reduction over time, so a node NaN in Hs at some times and in the period at the others is no
    passage at every time: a fixed obstacle. A dataset without times gives one slice.

    Raises
    ------
    ConfigError
        The dataset has no wave variable.
    """
    names = navigability_variables(dataset.data_vars)
    if "hs_m" not in names:
        raise ConfigError("the weather dataset has no wave variable (hs_m); open it with optroute.open_weather")
    nan = None
    for v in names:
        da = dataset[v].isnull()
        da = (da if "time" in da.dims else da.expand_dims("time")).transpose("time", "lat", "lon")
        nan = da.values if nan is None else nan | da.values
    return np.asarray(nan, dtype=bool)


class _NanCounts:
    """Where the weather marks no passage (:func:`wave_nan`), read once: a bracket of dataset times is then a
    numpy reduction of a few of its slices, not an xarray reduction of every variable per bracket (a 500-leg
    corridor has some 60 brackets). ``static_only``: only the nodes no passage at every dataset time (the
    moving ones go to the NLP's time windows, :mod:`optroute.optimise.timed_no_go`)."""

    def __init__(self, dataset: xr.Dataset, static_only: bool = False) -> None:
        self.t_all = np.asarray(dataset["time"].values).astype("datetime64[ns]") if "time" in dataset.coords else None
        nan = wave_nan(dataset)
        if self.t_all is None or self.t_all.size < 2 or nan.shape[0] < 2:
            self.static, self.varying = nan.any(axis=0), None
        elif static_only:
            self.static, self.varying = nan.all(axis=0), None
        else:
            self.static, self.varying = None, nan

    def bracket(self, times: np.ndarray) -> tuple[int, int]:
        """The dataset times bracketing ``times``: first and last index."""
        if self.t_all is None or self.t_all.size < 2:
            return 0, 0
        tq = np.asarray(times).astype("datetime64[ns]")
        i0 = max(int(np.searchsorted(self.t_all, tq.min(), side="right")) - 1, 0)
        return i0, min(int(np.searchsorted(self.t_all, tq.max(), side="left")), self.t_all.size - 1)

    def bad(self, times: np.ndarray) -> np.ndarray | None:
        """(lat, lon) NaN in any wave variable at any dataset time bracketing ``times``; None: nowhere."""
        bad = self.static
        if self.varying is not None:
            i0, i1 = self.bracket(times)
            grid = self.varying[i0 : i1 + 1].any(axis=0)
            bad = grid if bad is None else bad | grid
        return bad


def _weather_blocker(dataset: xr.Dataset, times: np.ndarray, nans: _NanCounts | None = None):  # noqa: ANN202
    """Functions (lat, lon) → blocked (exact for the sampler's stencil over the dataset times bracketing
    ``times``) and box → clear (no blocked point in a lat/lon box, conservative)."""
    bad = (nans if nans is not None else _NanCounts(dataset)).bad(times)
    lat_axis = np.asarray(dataset["lat"].values, dtype=float)
    lon_axis, periodic = land._weather_lon_axis(dataset)

    def box_clear(lat_min: float, lat_max: float, lon_min: float, lon_max: float) -> bool:
        """Every point of the box is inside the dataset and off every NaN stencil (conservative)."""
        if lat_min < lat_axis[0] or lat_max > lat_axis[-1] or lon_max - lon_min >= 180.0:
            return False
        q0 = lon_axis[0] + np.mod(lon_min - lon_axis[0], 360.0)
        q1 = q0 + (lon_max - lon_min)
        if not periodic and q1 > lon_axis[-1]:
            return False
        if bad is None:
            return True
        i0 = max(int(np.searchsorted(lat_axis, lat_min, side="right")) - 1, 0)
        i1 = int(np.searchsorted(lat_axis, lat_max, side="left"))
        j0 = max(int(np.searchsorted(lon_axis, q0, side="right")) - 1, 0)
        j1 = int(np.searchsorted(lon_axis, q1, side="left"))
        if j1 > lon_axis.size - 1:
            return False  # across a periodic grid's seam: let the points decide
        return not bool(bad[i0 : i1 + 1, j0 : j1 + 1].any())

    def blocked(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
        lon_q = lon_axis[0] + np.mod(lon - lon_axis[0], 360.0)
        lon_q = np.where(lon_q > lon_axis[0] + 360.0 - land._EPS, lon_q - 360.0, lon_q)
        yi0, yi1, y_in = land._axis_stencil(lat_axis, lat)
        xi0, xi1, x_in = land._axis_stencil(lon_axis, lon_q, periodic)
        out = ~(y_in & x_in)
        if bad is not None:
            out |= bad[yi0, xi0] | bad[yi0, xi1] | bad[yi1, xi0] | bad[yi1, xi1]
        return out

    return blocked, box_clear


def _leg_times(times: np.ndarray, leg_windows: np.ndarray | None, n: int) -> list[np.ndarray]:
    """Per leg, the times [UTC] its rows are checked at: ``times``, or those inside its window and the window's ends."""
    if leg_windows is None:
        return [times] * n
    w = np.asarray(leg_windows).astype("datetime64[ns]")
    if w.shape != (n, 2) or np.isnat(w).any() or np.any(w[:, 1] < w[:, 0]):
        raise ConfigError(
            f"leg_windows must be {n} (first, last) UTC times, one per leg, first <= last; got shape {w.shape}: "
            "build them with reach_windows(frame, ...)"
        )
    return [np.unique(np.concatenate([[a, b], times[(times > a) & (times < b)]])) for a, b in w]


def _groups(leg_times: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The distinct time sets of ``leg_times`` and the legs having each."""
    out: dict[bytes, tuple[np.ndarray, list[int]]] = {}
    for k, t in enumerate(leg_times):
        out.setdefault(t.tobytes(), (t, []))[1].append(k)
    return [(t, np.asarray(legs)) for t, legs in out.values()]


class _LegBlockers:
    """:func:`_weather_blocker` of each leg over its own times, built once per distinct bracket of dataset times."""

    def __init__(self, dataset: xr.Dataset, leg_times: list[np.ndarray], static_only: bool = False) -> None:
        nans = _NanCounts(dataset, static_only)
        built: dict[tuple[int, int], tuple] = {}
        self.of_leg: list[tuple] = []
        for t in leg_times:
            key = nans.bracket(t)
            if key not in built:
                built[key] = _weather_blocker(dataset, t, nans)
            self.of_leg.append(built[key])

    def box_clear(self, leg: int, *box: float) -> bool:
        return bool(self.of_leg[leg][1](*box))

    def blocked(self, row_leg: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
        """Blocked points of rows (one leg each, ``row_leg``) × columns."""
        out = np.zeros(lat.shape, dtype=bool)
        for leg in np.unique(row_leg):
            r = row_leg == leg
            out[r] = self.of_leg[int(leg)][0](lat[r], lon[r])
        return out


def _sampler_blocked(sampler: WeatherSampler, times: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Outside the sampler's cover or a non-finite wave value at any of ``times`` (flat points)."""
    when = np.broadcast_to(times[:, None], (times.size, lat.size))
    la = np.broadcast_to(lat[None, :], when.shape)
    lo = np.broadcast_to(lon[None, :], when.shape)
    ok = sampler.covers(when, la, lo).all(axis=0)
    if ok.any():
        names = list(navigability_variables(sampler.variables))
        idx = np.flatnonzero(ok)
        got = sampler.sample(when[:, idx], la[:, idx], lo[:, idx], variables=names)
        ok[idx] = np.all([np.isfinite(got[v]).all(axis=0) for v in names], axis=0)
    return ~ok


def _coarse_to_fine(coarse: np.ndarray, rows: np.ndarray, cols: np.ndarray, n_rows: int, n_cols: int) -> np.ndarray:
    """Blocked on the fine lattice where any corner of the coarse cell holding the point is blocked."""
    ri = np.clip(np.searchsorted(rows, np.arange(n_rows), side="right") - 1, 0, rows.size - 1)
    ci = np.clip(np.searchsorted(cols, np.arange(n_cols), side="right") - 1, 0, cols.size - 1)
    cell = coarse.copy()
    cell[:-1] |= coarse[1:]
    cell[:, :-1] |= cell[:, 1:].copy()
    return cell[ri][:, ci]


def _dilate(blocked: np.ndarray, r_rows: int, r_cols: int) -> np.ndarray:
    out = blocked.view(np.uint8)
    if r_rows > 0:
        out = ndimage.maximum_filter1d(out, 2 * r_rows + 1, axis=0, mode="constant", cval=0)
    if r_cols > 0:
        out = ndimage.maximum_filter1d(out, 2 * r_cols + 1, axis=1, mode="constant", cval=0)
    return out.astype(bool)


# --------------------------------------------------------------------------- the channel


def _where(frame: CorridorFrame, lat_: _Lattice, row: int) -> str:
    k, f = int(lat_.row_leg[row]), float(lat_.row_f[row])
    la, lo = lat_.positions(np.array([row]), np.array([lat_.centre_col]))
    return (
        f"{lat_.row_s_nm[row]:.1f} nm along the corridor, between its waypoints {k} and {k + 1} "
        f"({f:.0%} of that leg; centreline at ({float(la[0, 0]):.4f}, {float(lo[0, 0]):.4f}))"
    )


def _channel(
    ok: np.ndarray, lat_: _Lattice, ref_rows: np.ndarray, frame: CorridorFrame
) -> tuple[np.ndarray, np.ndarray]:
    """The chosen run of every row as (first, last) column index (method step 3)."""
    n_rows, n_cols = ok.shape
    padded = np.zeros((n_rows, n_cols + 2), dtype=np.int8)
    padded[:, 1:-1] = ok
    step = np.diff(padded, axis=1)
    rs, cs = np.nonzero(step == 1)
    _, ce = np.nonzero(step == -1)  # exclusive ends, row-major order like the starts
    first_run = np.searchsorted(rs, np.arange(n_rows + 1))
    y = lat_.y_nm
    lo_y, hi_y = y[cs], y[ce - 1]
    ref = ref_rows[rs]
    dist = np.maximum(lo_y - ref, 0.0) + np.maximum(ref - hi_y, 0.0)
    cost_run = dist + 1e-6 * (2.0 * lat_.hw_max - (hi_y - lo_y))
    c0 = lat_.centre_col
    cost = np.full(rs.size, np.inf)
    back = np.full(rs.size, -1, dtype=np.int64)
    for j in range(first_run[0], first_run[1]):
        if cs[j] <= c0 < ce[j]:
            cost[j] = cost_run[j]
    cs_l, ce_l, cost_l, cr_l = cs.tolist(), ce.tolist(), cost.tolist(), cost_run.tolist()
    fr = first_run.tolist()
    back_l = back.tolist()
    for i in range(1, n_rows):
        p0, p1, a, b = fr[i - 1], fr[i], fr[i], fr[i + 1]
        reached = False
        for j in range(a, b):
            best, arg = math.inf, -1
            for p in range(p0, p1):
                if cs_l[j] < ce_l[p] and cs_l[p] < ce_l[j] and cost_l[p] < best:
                    best, arg = cost_l[p], p
            if arg >= 0:
                cost_l[j], back_l[j] = best + cr_l[j], arg
                reached = True
        if not reached:
            raise NoSafePassage(
                f"the corridor has no navigable passage at {_where(frame, lat_, i)}: land or no-passage weather "
                f"closes all of ±{lat_.row_hw[i]:g} nm there (or the open water there is not connected to the "
                f"water before it); {ROUTE_AROUND}"
            )
    last = [j for j in range(fr[n_rows - 1], fr[n_rows]) if cs_l[j] <= c0 < ce_l[j] and math.isfinite(cost_l[j])]
    if not last:
        raise NoSafePassage(
            f"the corridor's last waypoint is not reachable through navigable water within the corridor "
            f"(the water around it is cut off at {_where(frame, lat_, n_rows - 1)}); widen or move the corridor"
        )
    run = np.empty(n_rows, dtype=np.int64)
    j = last[0]
    for i in range(n_rows - 1, -1, -1):
        run[i] = j
        j = back_l[j]
    return cs[run], ce[run] - 1


# --------------------------------------------------------------------------- boxes


def _boxes_intersection(lo_r: np.ndarray, hi_r: np.ndarray, lat_: _Lattice, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Station boxes as the intersection of the chosen runs over the legs on either side (method step 4)."""
    sr = lat_.station_row
    # a row at fraction f constrains (1 − f) y_k + f y_{k+1}: the row at f = 0 only y_k, the one at f = 1 only y_{k+1}
    start_lo, start_hi = np.maximum.reduceat(lo_r, sr[:-1]), np.minimum.reduceat(hi_r, sr[:-1])  # f in [0, 1)
    end_lo, end_hi = np.maximum.reduceat(lo_r, sr[:-1] + 1), np.minimum.reduceat(hi_r, sr[:-1] + 1)  # f in (0, 1]
    # legs with a pinned outer end (y = 0): y(f) = f·y_1 on the first, (1 − f)·y_{N−1} on the last
    rows0 = np.arange(sr[0] + 1, sr[1] + 1)
    f0 = lat_.row_f[rows0].copy()
    f0[-1] = 1.0  # the station row closing leg 0 is stored as leg 1's f = 0
    first_lo, first_hi = np.max(lo_r[rows0] / f0), np.min(hi_r[rows0] / f0)
    rows_n = np.arange(sr[n - 1], sr[n])
    f1 = 1.0 - lat_.row_f[rows_n]
    last_lo, last_hi = np.max(lo_r[rows_n] / f1), np.min(hi_r[rows_n] / f1)
    lo, hi = np.zeros(n + 1), np.zeros(n + 1)
    for k in range(1, n):
        a_lo = first_lo if k == 1 else end_lo[k - 1]
        a_hi = first_hi if k == 1 else end_hi[k - 1]
        b_lo = last_lo if k == n - 1 else start_lo[k]
        b_hi = last_hi if k == n - 1 else start_hi[k]
        lo[k], hi[k] = max(a_lo, b_lo), min(a_hi, b_hi)
    return lo, hi


def _boxes_lp(
    lo_r: np.ndarray, hi_r: np.ndarray, lat_: _Lattice, hw: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Station boxes from the linear programme of method step 4 (None when infeasible)."""
    n1 = hw.size
    k, f = lat_.row_leg, lat_.row_f
    r = k.size
    rows = np.arange(r)
    # variables: lo (n1), hi (n1), t (smallest interior width)
    nv = 2 * n1 + 1
    a_lo = sparse.csr_matrix(
        (np.concatenate([-(1.0 - f), -f]), (np.concatenate([rows, rows]), np.concatenate([k, k + 1]))), shape=(r, nv)
    )
    a_hi = sparse.csr_matrix(
        (np.concatenate([1.0 - f, f]), (np.concatenate([rows, rows]), np.concatenate([k, k + 1]) + n1)), shape=(r, nv)
    )
    inner = np.arange(1, n1 - 1)
    m = inner.size
    a_w = sparse.csr_matrix(
        (
            np.concatenate([np.ones(m), -np.ones(m), np.ones(m)]),
            (np.tile(np.arange(m), 3), np.concatenate([inner, inner + n1, np.full(m, nv - 1)])),
        ),
        shape=(m, nv),
    )
    a = sparse.vstack([a_lo, a_hi, a_w]).tocsr()
    b = np.concatenate([-lo_r, hi_r, np.zeros(m)])
    c = np.concatenate([np.ones(n1), -np.ones(n1), [-float(n1)]])
    bounds = [(-h, h) for h in hw] + [(-h, h) for h in hw] + [(0.0, None)]
    for i in (0, n1 - 1, n1, 2 * n1 - 1):
        bounds[i] = (0.0, 0.0)
    res = linprog(c, A_ub=a, b_ub=b, bounds=bounds, method="highs")
    if res.status != 0:
        return None
    x = res.x
    return x[:n1], x[n1 : 2 * n1]


# --------------------------------------------------------------------------- public


def land_step_nm(frame: CorridorFrame, mask: land.LandMask) -> float:
    """Lattice spacing [nm] that puts a lattice point in every cell of ``mask`` over the corridor."""
    wp = frame.corridor.waypoints
    hw = float(np.max(frame.corridor.half_width_nm))
    lat_max = min(float(np.max(np.abs(wp[:, 0]))) + hw / 60.0, 89.0)
    return max(LAND_STEP_MIN_NM, float(mask.resolution_nm) * math.cos(math.radians(lat_max)) / math.sqrt(2.0))


def lateral_bounds(
    frame: CorridorFrame,
    *,
    sampler: WeatherSampler,
    dataset: xr.Dataset | None,
    times: np.ndarray,
    use_land_mask: bool | None = None,
    step_nm: float = 2.0,
    reference_port_nm: ArrayLike | None = None,
    leg_windows: np.ndarray | None = None,
    static_only: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Navigable lateral range [nm, port +] of every waypoint, such that every leg stays navigable.

    See the module docstring for the method: a lattice at the land mask's resolution over every
    leg's sweep, one connected channel chosen by a dynamic programme (an island inside the corridor
    is passed on the side nearer ``reference_port_nm``, default the centreline), and boxes such that
    a leg between any two admissible waypoints stays in that channel.

    Parameters
    ----------
    frame : CorridorFrame
        The corridor (its legs are the NLP's legs).
    sampler : WeatherSampler
        The weather (used when ``dataset`` is None).
    dataset : xarray.Dataset or None
        The canonical weather behind ``sampler``: its NaN cells are no passage. Without it, the
        sampler is read on a coarser lattice (every ``step_nm``) and a point is blocked when a
        corner of its coarse cell is.
    times : array_like of datetime64
        The times the ship may pass [UTC].
    use_land_mask : bool, optional
        As :func:`optroute.geo.land.navigable` (default: on unless the weather is synthetic geography).
    step_nm : float
        Lattice spacing [nm] when the land mask is off (the weather's NaN cells are exact at any
        spacing finer than its grid; without ``dataset``, the coarse spacing).
    reference_port_nm : array_like, shape (N+1,), optional
        The path whose side of an island is kept [nm, port +] (e.g. a warm start); default 0.
    leg_windows : array_like of datetime64, shape (N, 2), optional
        The first and last time [UTC] the ship can be on each leg (:func:`reach_windows`): a leg's
        rows are blocked by the weather's no-passage cells over its own window instead of over all
        of ``times`` (a moving no-go area then blocks only where it is while the ship can be there).
        Default: every leg over ``times``.
    static_only : bool
        Block only the weather's cells that are NaN at every time of ``dataset`` (land, fixed no-go
        areas): a moving no-go area is then left to the NLP's time windows
        (:mod:`optroute.optimise.timed_no_go`). Needs ``dataset``.

    Returns
    -------
    y_lo, y_hi : numpy.ndarray, shape (N+1,)
        Bounds [nm, port +]; the two ends are 0 (pinned).

    Raises
    ------
    OnLandError
        The corridor's first or last waypoint (the ends are pinned) is not navigable.
    NoSafePassage
        No navigable channel joins the two ends within the corridor (the message names where it is
        closed), or no box keeps every leg in it.
    """
    n = frame.n_legs
    n1 = n + 1
    wp = frame.corridor.waypoints
    times = np.atleast_1d(np.asarray(times)).astype("datetime64[ns]")
    with_land = land.coastline_applies(dataset, use_land_mask)
    mask = land.land_mask() if with_land else None
    step = land_step_nm(frame, mask) if mask is not None else float(step_nm)
    if mask is None and dataset is not None:
        # the weather's NaN cells are exact at any spacing: a third of its smaller cell side suffices
        dlat = float(np.min(np.abs(np.diff(dataset["lat"].values)))) * 60.0 if dataset["lat"].size > 1 else step
        step = min(step, max(dlat / 3.0, 0.25))
    lat_ = _Lattice(frame, step, step)
    leg_times = _leg_times(times, leg_windows, n)
    if static_only and dataset is None:
        raise ConfigError(
            "static_only=True tells the weather's fixed no-passage cells from the moving ones by the dataset's NaN "
            "over time; pass the canonical dataset (optimise_corridor with an xarray.Dataset, not a WeatherSampler)"
        )
    wx = _LegBlockers(dataset, leg_times, static_only) if dataset is not None else None
    ok = _open_cells(frame, lat_, mask, wx, (sampler, dataset, leg_times), step, float(step_nm))
    c0 = lat_.centre_col
    for which, row, k in (("first", 0, 0), ("last", lat_.n_rows - 1, n)):
        if not ok[row, c0]:
            raise OnLandError(
                f"the corridor's {which} waypoint ({wp[k, 0]:.4f}, {wp[k, 1]:.4f}) is not navigable (land, or NaN "
                "weather at some time of the voyage); move it to open water (search_route snaps ports to the sea)"
            )
    ref = np.zeros(n1) if reference_port_nm is None else np.broadcast_to(np.asarray(reference_port_nm, float), (n1,))
    ref_rows = (1.0 - lat_.row_f) * ref[lat_.row_leg] + lat_.row_f * ref[lat_.row_leg + 1]
    first, last = _channel(ok, lat_, ref_rows, frame)
    if n == 1:
        return np.zeros(n1), np.zeros(n1)
    return _channel_boxes(lat_.y_nm[first], lat_.y_nm[last], lat_, frame)


def _open_cells(
    frame: CorridorFrame,
    lat_: _Lattice,
    mask: Any,
    wx: _LegBlockers | None,
    weather: tuple[WeatherSampler, xr.Dataset | None, Any],
    step: float,
    step_nm: float,
) -> np.ndarray:
    """The lattice's cells (rows, columns) inside the corridor and navigable: not land (dilated by the mask's
    cell diagonal away from the ends) and not the weather's no passage over each row's leg's times. Legs whose
    padded sweep is clear by a box look-up are not sampled. ``weather``: the sampler, the canonical dataset or
    None (then the sampler on a coarse lattice every ``step_nm``), and the legs' times (:func:`_leg_times`)."""
    sampler, dataset, leg_times = weather
    n = frame.n_legs
    n_rows, n_cols = lat_.n_rows, lat_.y_nm.size
    blocked_land = np.zeros((n_rows, n_cols), dtype=bool)
    blocked_wx = np.zeros((n_rows, n_cols), dtype=bool)
    diag = float(mask.resolution_nm) * math.sqrt(2.0) if mask is not None else 0.0
    # legs whose whole (padded) sweep is clear need no lattice: a box look-up on the mask and the weather grid
    boxes = lat_.leg_boxes(frame, diag + 2.0 * step)
    need = np.ones(n, dtype=bool)
    box_land = getattr(mask, "any_land_in_box", None) if mask is not None else None
    if mask is None or box_land is not None:
        for k, (a, b, c, d) in enumerate(boxes):
            land_clear = mask is None or (-180.0 <= c and d < 180.0 and not box_land(a, b, c, d))
            need[k] = not (land_clear and (wx is None or wx.box_clear(k, a, b, c, d)))
    row_need = need[lat_.row_leg]
    row_need[lat_.station_row[1:-1]] |= need[:-1]  # a station row closes the leg before it too
    need_rows = np.flatnonzero(row_need)
    for rows in _chunks(need_rows.size, n_cols):
        rows = need_rows[rows]
        la, lo = lat_.positions(rows)
        if mask is not None:
            blocked_land[rows] = mask.is_land(la, lo)
        if wx is not None:
            blocked_wx[rows] = wx.blocked(lat_.row_leg[rows], la, lo)
    if dataset is None:
        stride = max(1, int(round(step_nm / step)))
        rows_c = np.unique(np.concatenate([np.arange(0, n_rows, stride), [n_rows - 1]]))
        cols_c = np.unique(np.concatenate([np.arange(lat_.centre_col % stride, n_cols, stride), [0, n_cols - 1]]))
        la, lo = lat_.positions(rows_c, cols_c)
        coarse = np.zeros(la.shape, dtype=bool)
        for when, legs in _groups(leg_times):
            r = np.flatnonzero(np.isin(lat_.row_leg[rows_c], legs))
            coarse[r] = _sampler_blocked(sampler, when, la[r].ravel(), lo[r].ravel()).reshape(r.size, -1)
        blocked_wx = coarse if stride == 1 else _coarse_to_fine(coarse, rows_c, cols_c, n_rows, n_cols)
    inside = np.abs(lat_.y_nm)[None, :] <= lat_.row_hw[:, None] + 1e-9
    raw = blocked_land | blocked_wx
    if mask is not None and blocked_land.any():
        r_rows = int(math.ceil(diag / lat_.row_spacing_min_nm - 1e-9))
        r_cols = int(math.ceil(diag / step - 1e-9)) if n_cols > 1 else 0
        dilated = _dilate(blocked_land, r_rows, r_cols)
        near_end = (lat_.row_s_nm <= diag + step) | (lat_.row_s_nm >= frame.s_nm[-1] - diag - step)
        dilated[near_end] = blocked_land[near_end]
        blocked = dilated | blocked_wx
    else:
        blocked = raw
    return inside & ~blocked


def _channel_boxes(
    lo_r: np.ndarray, hi_r: np.ndarray, lat_: _Lattice, frame: CorridorFrame
) -> tuple[np.ndarray, np.ndarray]:
    """Waypoint bounds [nm, port +] from the channel's range per lattice row (``lo_r``, ``hi_r``): the boxes'
    intersection, within the half-widths and pinned at the ends; where it is empty, the LP's boxes; NoSafePassage
    naming the waypoint where none exists."""
    n = frame.n_legs
    hw = np.asarray(frame.corridor.half_width_nm, dtype=float)
    wp = frame.corridor.waypoints
    y_lo, y_hi = _boxes_intersection(lo_r, hi_r, lat_, n)
    y_lo, y_hi = np.maximum(y_lo, -hw), np.minimum(y_hi, hw)
    y_lo[[0, -1]] = y_hi[[0, -1]] = 0.0
    empty = np.flatnonzero(y_lo > y_hi + 1e-9)
    if empty.size:
        lp = _boxes_lp(lo_r, hi_r, lat_, hw)
        if lp is None:
            k = int(empty[0])
            raise NoSafePassage(
                f"no lateral range at corridor waypoint {k} ({wp[k, 0]:.4f}, {wp[k, 1]:.4f}) keeps both its legs in "
                "navigable water: the open water there is narrower than the legs' sweep or bends across them; use "
                "shorter legs (max_leg_nm), widen the corridor, or plan it with plan_voyage"
            )
        y_lo, y_hi = lp
    return y_lo, np.maximum(y_hi, y_lo)


def reach_windows(
    frame: CorridorFrame, departure: np.datetime64, cap_h: float, sog_max_kn: float, *, margin_h: float = 1.0
) -> np.ndarray:
    """The first and last time [UTC] a ship can be on each leg of the corridor, shape (N, 2).

    A ship departing at ``departure`` from the first waypoint, arriving at the last by ``cap_h`` [h after
    departure] and never faster over ground than ``sog_max_kn`` [kn] (the NLP's top speed through water plus
    the strongest current) reaches station ``k`` no earlier than ``d(start, W_k) / sog_max`` and leaves
    station ``k + 1`` no later than ``cap_h - d(W_{k+1}, end) / sog_max``, with ``d`` the WGS84 geodesic
    distance (no track is shorter) to the nearest admissible offset of the station (offsets every
    ``half_width / 16``, less half that spacing: the distance is 1-Lipschitz in the position). The window
    of leg ``k`` is the first of these to the second, widened by ``margin_h`` [h] each side and clipped to
    ``[0, cap_h]``: a superset of the times the ship can be on the leg, so blocking a leg's sweep over its
    window keeps every admissible leg navigable, as the static window did, but a moving no-go area blocks
    only where it is while the ship can be there.
    """
    n = frame.n_legs
    hw = np.asarray(frame.corridor.half_width_nm, dtype=float)
    frac = np.linspace(-1.0, 1.0, 33)
    kk = np.repeat(np.arange(n + 1), frac.size)
    yy = (hw[:, None] * frac[None, :]).ravel()
    lat, lon = frame.normal_points(kk, yy)
    wp = frame.corridor.waypoints
    slack = hw / 32.0 + 1e-6  # half the offset spacing [nm]
    d0 = geo.distance_nm(wp[0, 0], wp[0, 1], lat, lon).reshape(n + 1, -1).min(axis=1) - slack
    d1 = geo.distance_nm(lat, lon, wp[-1, 0], wp[-1, 1]).reshape(n + 1, -1).min(axis=1) - slack
    v = float(sog_max_kn) * (1.0 + 1e-9)
    first = np.maximum(d0[:-1], 0.0) / v - margin_h
    last = float(cap_h) - np.maximum(d1[1:], 0.0) / v + margin_h
    first, last = np.clip(first, 0.0, cap_h), np.clip(last, 0.0, cap_h)
    last = np.maximum(last, first)
    to_ns = np.timedelta64(1, "ns")
    t0 = np.datetime64(departure, "ns")
    hours = np.column_stack([first, last])
    return t0 + np.round(hours * 3600e9).astype(np.int64) * to_ns


def avoid_point(
    y_lo: np.ndarray,
    y_hi: np.ndarray,
    *,
    leg: int,
    fraction: float,
    offset_port_nm: float,
    margin_nm: float = 1.0,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Bounds that keep leg ``leg`` at least ``margin_nm`` to one side of a non-navigable point.

    The point lies at ``fraction`` [-] along the leg and at lateral offset ``offset_port_nm``
    [nm, port +] in the leg's sweep (:func:`lateral_bounds`); the leg's offset there is
    ``(1 − f) y_k + f y_{k+1}``, so raising both lower bounds to ``offset + margin`` (or lowering
    both upper bounds to ``offset − margin``) moves the whole leg off the point. A pinned end
    (``k = 0`` or ``k + 1 = N``) stays at 0 and the other bound is scaled by ``1/f`` (``1/(1 − f)``).
    The side leaving the larger summed width is chosen.

    Returns
    -------
    (y_lo, y_hi) or None
        New bounds (copies), or None when neither side leaves a non-empty range.
    """
    n1 = y_lo.size
    f = float(np.clip(fraction, 0.0, 1.0))
    k0, k1 = leg, leg + 1
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for side in (1.0, -1.0):
        target = offset_port_nm + side * margin_nm
        lo, hi = y_lo.copy(), y_hi.copy()
        feasible = True
        for k, w in ((k0, 1.0 - f), (k1, f)):
            if k in (0, n1 - 1):
                continue
            other_pinned = (k0 == 0 and k == k1) or (k1 == n1 - 1 and k == k0)
            need = target / w if other_pinned and w > 1e-9 else target
            if other_pinned and w <= 1e-9:
                feasible = False
                break
            if side > 0:
                lo[k] = max(lo[k], need)
            else:
                hi[k] = min(hi[k], need)
            feasible &= bool(lo[k] <= hi[k])
        if k0 == 0 and k1 == n1 - 1:
            feasible = False  # a single pinned leg cannot move
        if feasible:
            width = float(np.sum(hi[[k0, k1]] - lo[[k0, k1]]))
            if best is None or width > best[0]:
                best = (width, lo, hi)
    return None if best is None else (best[1], best[2])
