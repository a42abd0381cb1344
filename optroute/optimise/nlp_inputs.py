"""Domain → formulation: the arrays the corridor NLP (:mod:`formulations.speed_nlp`) takes.

* :func:`build_frame` — the corridor's flat frame. The frame is the corridor
  *developed* into the plane: the centreline legs keep their great-circle
  lengths and the turns at the waypoints their true angles, and lateral
  offsets are measured along the true normals. Along-track distances are
  therefore exact, and a leg between offset waypoints differs from its
  great-circle length by O((y/R)²) (y the offset, R the Earth radius:
  4·10⁻⁴ relative at 100 nm). A gnomonic projection centred on the corridor
  midpoint (:func:`optroute.geodesy.gnomonic_forward`) keeps great circles
  straight but stretches lengths by 1/cos²c radially at an angular distance
  c from its centre — 0.8 % at 300 nm, 22 % at 1 500 nm — and the NLP's leg
  times and fuel are proportional to those lengths, so it is not used. The
  error actually incurred is measured on every plan
  (:meth:`CorridorFrame.distance_error`) and reported.
* :func:`lateral_bounds` (from :mod:`optroute.optimise.lateral`) — the navigable lateral range at every
  waypoint from the land mask and the weather's NaN cells, such that every leg stays navigable.
* :func:`weather_grid` — the weather on the corridor's (time, along-track,
  across-track) grid, vectors rotated into components along and across the
  centreline.
  With a performance model it also tabulates the ship's power on that grid
  (:mod:`optroute.optimise.power_table`): the NLP's power is the model's own.
* :func:`formulation_bands` — :class:`~optroute.physics.safety.BandRules` as
  formulation :class:`~formulations.common.Band` objects.
* :func:`moving_exclusion` — an :class:`~optroute.plan.result.Exclusion` in the frame.

Sign conventions: the formulation's lateral offset is positive to **port**
(left of the direction of travel); :class:`~optroute.search.route.Corridor` offsets
are positive to starboard. Everything here takes and returns port-positive
offsets and converts at the Corridor boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy import ndimage

from formulations.common import G_OVER_2PI_KN_S, Band, CorridorGeometry, MovingExclusion, PowerModel
from formulations.weather_grid import WeatherGrid
from optroute import geodesy as geo
from optroute import units
from optroute.errors import NoSafePassage, WeatherCoverageError
from optroute.geo.tracks import Exclusion, gc_points, project_to_polyline
from optroute.optimise.lateral import lateral_bounds
from optroute.optimise.power_table import SPEED_TOL, tabulate_ratio
from optroute.physics import seaway
from optroute.physics.passage import SeaState
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import IMO_HIGH_WAVE_TE_OVER_T, IMO_SURF_RIDING_KN_PER_SQRT_M, BandRules
from optroute.physics.ship import Ship
from optroute.search.route import Corridor
from optroute.units import NS_PER_H as _NS_PER_H
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler

__all__ = [
    "CorridorFrame",
    "GridSamples",
    "build_frame",
    "formulation_bands",
    "lateral_bounds",
    "exclusion_frame_error_nm",
    "moving_exclusion",
    "weather_grid",
]


# --------------------------------------------------------------------------- frame


@dataclass(frozen=True)
class CorridorFrame:
    """A corridor developed into a flat frame (see the module docstring).

    Attributes
    ----------
    corridor : Corridor
        The (resampled) centreline and half-widths; its legs are the NLP's legs.
    centre_xy_nm : numpy.ndarray, shape (N+1, 2)
        Centreline waypoints in the flat frame [nm].
    s_nm : numpy.ndarray, shape (N+1,)
        Along-track position of the waypoints [nm] (great-circle lengths).
    tangent_xy : numpy.ndarray, shape (N, 2)
        Unit direction of every centreline leg in the flat frame.
    """

    corridor: Corridor
    centre_xy_nm: np.ndarray
    s_nm: np.ndarray
    tangent_xy: np.ndarray

    @property
    def n_legs(self) -> int:
        """Number of legs N."""
        return self.corridor.n_legs

    def geometry(self, y_lo_nm: np.ndarray | None = None, y_hi_nm: np.ndarray | None = None) -> CorridorGeometry:
        """The formulation's :class:`~formulations.common.CorridorGeometry` with the given lateral bounds."""
        return CorridorGeometry(
            centre_xy_nm=self.centre_xy_nm,
            s_nm=self.s_nm,
            half_width_nm=np.asarray(self.corridor.half_width_nm, dtype=float),
            y_lo_nm=y_lo_nm,
            y_hi_nm=y_hi_nm,
        )

    def waypoints(self, offset_port_nm: ArrayLike) -> np.ndarray:
        """Waypoints (N+1, 2) [deg] at lateral offsets [nm, port +] along the bisecting normals."""
        off = -np.asarray(offset_port_nm, dtype=float)
        hw = np.asarray(self.corridor.half_width_nm)
        off = np.clip(off, -hw, hw)  # bounds hold to rounding; Corridor rejects anything beyond
        lat, lon = self.corridor.offset_points(off)
        return np.column_stack([lat, lon])

    def normal_points(self, k: np.ndarray, y_port_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points at lateral offsets [nm, port +] across waypoint(s) ``k`` along the bisecting normal [deg]."""
        wp = self.corridor.waypoints
        course = self.corridor.normal_course_deg()[k]  # to starboard
        return geo.destination(wp[k, 0], wp[k, 1], course, -np.asarray(y_port_nm, dtype=float))

    def points(self, s_nm: ArrayLike, y_port_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions at corridor coordinates, and the direction of the centreline there.

        Parameters
        ----------
        s_nm : array_like
            Along-track position [nm] (clipped to the corridor).
        y_port_nm : array_like
            Lateral offset [nm], positive to port, along the great circle normal to the centreline.

        Returns
        -------
        lat, lon : ndarray
            [deg].
        along_deg : ndarray
            Direction parallel to the centreline at the point [deg true]: perpendicular to the normal
            arc through it, pointing forward.
        """
        s, y = np.broadcast_arrays(np.asarray(s_nm, dtype=float), np.asarray(y_port_nm, dtype=float))
        ss = np.clip(s, self.s_nm[0], self.s_nm[-1])
        k = np.clip(np.searchsorted(self.s_nm, ss, side="right") - 1, 0, self.n_legs - 1)
        d = np.diff(self.s_nm)
        f = (ss - self.s_nm[k]) / d[k]
        wp = self.corridor.waypoints
        blat, blon, course = gc_points(wp[k, 0], wp[k, 1], wp[k + 1, 0], wp[k + 1, 1], f)
        lat, lon = geo.destination(blat, blon, course - 90.0, y)  # port = course − 90
        toward = geo.initial_course_deg(lat, lon, blat, blon)
        along = np.where(y > 0, toward - 90.0, toward + 90.0)
        along = np.where(np.abs(y) < 1e-9, course, units.wrap_360(along))
        return lat, lon, along

    def to_xy(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> np.ndarray:
        """Flat-frame position [nm] (…, 2) of points: foot on the centreline plus the signed offset along its normal.

        The foot is taken on the nearest leg's geodesic *extended* past its ends (the one the offset is
        measured from), so that a point beyond the corridor's ends (a cyclone centre past the destination)
        keeps its distance from them: held at the end, its along-track distance past it was lost (a centre
        90 nm past the destination was put 90 nm nearer the last leg, and the NLP found the cyclone voyage
        of ``tests/test_voyage_cyclone.py`` infeasible once rows sat where the referee checks).
        """
        s, xt, _, k = project_to_polyline(self.corridor.waypoints, lat_deg, lon_deg, clamp=False)
        tau = self.tangent_xy[k]
        normal = np.stack([-tau[..., 1], tau[..., 0]], axis=-1)  # port
        base = self.centre_xy_nm[k] + (s - self.s_nm[k])[..., None] * tau
        return base + (-xt)[..., None] * normal

    def distance_error(self, offset_port_nm: ArrayLike) -> float:
        """Largest relative difference of the flat leg lengths from the great-circle lengths at given offsets."""
        y = np.asarray(offset_port_nm, dtype=float)
        geom = self.geometry()
        p = geom.centre_xy_nm + y[:, None] * np.asarray(geom.normal_xy)
        flat = np.linalg.norm(np.diff(p, axis=0), axis=1)
        wp = self.waypoints(y)
        true = geo.distance_nm(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
        return float(np.max(np.abs(flat / true - 1.0)))


def build_frame(corridor: Corridor) -> CorridorFrame:
    """Develop a corridor into the plane: true leg lengths and true turning angles (module docstring)."""
    wp = corridor.waypoints
    d = corridor.leg_distance_nm
    c_out = geo.initial_course_deg(wp[:-1, 0], wp[:-1, 1], wp[1:, 0], wp[1:, 1])
    c_end = units.wrap_360(geo.initial_course_deg(wp[1:, 0], wp[1:, 1], wp[:-1, 0], wp[:-1, 1]) + 180.0)
    turn = units.wrap_180(c_out[1:] - c_end[:-1])
    phi = np.radians(c_out[0] + np.concatenate([[0.0], np.cumsum(turn)]))
    tangent = np.column_stack([np.sin(phi), np.cos(phi)])
    centre = np.vstack([[0.0, 0.0], np.cumsum(tangent * d[:, None], axis=0)])
    return CorridorFrame(corridor, centre, np.concatenate([[0.0], np.cumsum(d)]), tangent)


# --------------------------------------------------------------------------- weather grid


@dataclass(frozen=True)
class GridSamples:
    """The raw samples behind a :class:`~formulations.weather_grid.WeatherGrid`, for reports.

    Attributes
    ----------
    hs_m : numpy.ndarray
        Hs [m] at the grid's navigable nodes (1-D).
    filled : int
        Nodes whose NaN (no passage) values were filled from the nearest navigable node.
    static : bool
        The fields do not change in time over the window (the grid keeps one time slice).
    has_current : bool
        A non-zero current is present.
    power_capped_share : float
        Share of the power table capped (:data:`optroute.optimise.power_table.CAP_MCR`); 0 without a table.
    power_evaluations : int
        Performance-model evaluations of the power table (0 without one).
    power_speed_error : float
        The table's largest relative error in the speed at its first speed nodes (its ``speed_error``,
        :func:`~optroute.optimise.power_table.tabulate_ratio`); NaN without a table.
    """

    hs_m: np.ndarray
    filled: int
    static: bool
    has_current: bool
    power_capped_share: float = 0.0
    power_evaluations: int = 0
    power_speed_error: float = float("nan")


def _fill_nearest(arr: np.ndarray, bad: np.ndarray) -> np.ndarray:
    if not bad.any():
        return arr
    idx = ndimage.distance_transform_edt(bad, return_distances=False, return_indices=True)
    return arr[tuple(idx)]


def _uniform_axis(lo: float, hi: float, step: float, *, odd: bool = False, max_n: int = 10_000) -> np.ndarray:
    n = max(2, min(int(math.ceil((hi - lo) / step - 1e-9)) + 1, max_n))
    if odd and n % 2 == 0:
        n += 1
    return np.linspace(lo, hi, n)


def reachable_nodes(
    t_axis_h: np.ndarray, s_axis_nm: np.ndarray, s_legs_nm: np.ndarray, leg_windows_h: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The time nodes of each along-track node that a reachable sample's spline can read: first and last index.

    The grid's cubic B-spline quasi-interpolant reads the nodes within two steps of a point in every axis
    (:func:`formulations.common.spline_weights`), so the value at a sample of leg ``k`` at time ``t`` depends on
    the nodes ``(t_i, s_j)`` with ``|t_i − t| < 2 Δt`` and ``|s_j − s| < 2 Δs`` only. For along-track node ``j``
    these are the time nodes within ``2 Δt`` of the union of the windows of the legs that overlap
    ``[s_j − 2 Δs, s_j + 2 Δs]``.

    Parameters
    ----------
    t_axis_h : numpy.ndarray, shape (nt,)
        The grid's uniform time axis [h after departure].
    s_axis_nm : numpy.ndarray, shape (ns,)
        The grid's uniform along-track axis [nm].
    s_legs_nm : numpy.ndarray, shape (N+1,)
        Along-track position of the corridor's waypoints [nm].
    leg_windows_h : numpy.ndarray, shape (N, 2)
        First and last time a ship can be on each leg [h after departure]
        (:func:`optroute.optimise.lateral.reach_windows`).

    Returns
    -------
    lo, hi : numpy.ndarray of int, shape (ns,)
        The first and last time index each along-track node needs (``lo ≤ hi``).
    """
    dt = float(t_axis_h[1] - t_axis_h[0]) if t_axis_h.size > 1 else 1.0
    ds = float(s_axis_nm[1] - s_axis_nm[0]) if s_axis_nm.size > 1 else max(float(s_legs_nm[-1]), 1.0)
    w = np.asarray(leg_windows_h, dtype=float)
    # legs overlapping [s_j − 2Δs, s_j + 2Δs]: from the first leg ending after its start to the last leg starting
    # before its end (legs in order along the track)
    k0 = np.searchsorted(s_legs_nm[1:], s_axis_nm - 2.0 * ds, side="right")
    k1 = np.searchsorted(s_legs_nm[:-1], s_axis_nm + 2.0 * ds, side="left") - 1
    k0 = np.clip(k0, 0, w.shape[0] - 1)
    k1 = np.clip(k1, k0, w.shape[0] - 1)
    # windows are monotone along the track (reach_windows), so the union over k0..k1 spans first[k0]..last[k1]
    first = np.minimum.accumulate(w[::-1, 0])[::-1][k0]
    last = np.maximum.accumulate(w[:, 1])[k1]
    lo = np.searchsorted(t_axis_h, first - 2.0 * dt, side="right") - 1
    hi = np.searchsorted(t_axis_h, last + 2.0 * dt, side="left")
    lo = np.clip(lo, 0, t_axis_h.size - 1)
    hi = np.clip(hi, lo, t_axis_h.size - 1)
    return lo.astype(np.int64), hi.astype(np.int64)


class _TimeHold:
    """The grid nodes kept under reach windows (:func:`reachable_nodes`; all without) and the hold of the others.

    ``take`` picks the kept nodes of a (nt, ns, …) array, (K, …) in C order; ``spread`` puts (K, …) values back on
    the whole grid, each other node holding its along-track column's nearest kept node in time.
    """

    def __init__(
        self, t_axis: np.ndarray, s_axis: np.ndarray, s_legs: np.ndarray, leg_windows_h: np.ndarray | None
    ) -> None:
        nt, ns = t_axis.size, s_axis.size
        if leg_windows_h is None:
            lo, hi = np.zeros(ns, dtype=np.int64), np.full(ns, nt - 1, dtype=np.int64)
        else:
            lo, hi = reachable_nodes(t_axis, s_axis, s_legs, leg_windows_h)
        i = np.arange(nt)[:, None]
        self.kept = (i >= lo[None, :]) & (i <= hi[None, :])  # (nt, ns)
        # the compact position of node (clip(i, lo_j, hi_j), j): kept nodes are numbered in C order
        number = np.cumsum(self.kept.ravel()).reshape(nt, ns) - 1
        self.source = number[np.clip(i, lo[None, :], hi[None, :]), np.arange(ns)[None, :]]  # (nt, ns)

    def take(self, a: np.ndarray) -> np.ndarray:
        return np.asarray(a)[self.kept]

    def spread(self, compact: np.ndarray) -> np.ndarray:
        return np.asarray(compact)[self.source]


def weather_grid(
    frame: CorridorFrame,
    sampler: WeatherSampler,
    *,
    departure: np.datetime64,
    t_end_h: float,
    dt_h: float,
    ds_nm: float,
    dy_nm: float,
    model: PerformanceModel | None = None,
    base: PowerModel | None = None,
    speeds_kn: np.ndarray | None = None,
    headings_deg: np.ndarray | None = None,
    leg_windows_h: np.ndarray | None = None,
    speed_tol: float | None = SPEED_TOL,
) -> tuple[WeatherGrid, GridSamples]:
    """The weather on the corridor's (time, along-track, across-track) grid, and the ship's power table on it.

    With ``model``, ``base``, ``speeds_kn`` and ``headings_deg`` the grid also carries the ratio of
    the model's brake power to the baseline ``base`` at every node, speed and heading relative to the
    centreline (:func:`optroute.optimise.power_table.tabulate_ratio`, evaluated in the node's sea
    as sampled here: the NLP's power is the model's own).

    Nodes: times ``0, dt, …`` up to ``t_end_h`` [h since departure]; along-track every ``ds_nm`` or
    closer; across-track over ± the largest half-width every ``dy_nm`` or closer (a single node at 0
    for a fixed path). Each node's position is the centreline point at ``s`` moved ``y`` along the
    normal great circle (:meth:`CorridorFrame.points`); :class:`~optroute.weather.WeatherSampler`
    interpolates the dataset there at the node's time.

    Vectors are rotated into components along the centreline direction at the node and to port of
    it (the formulation's convention): waves from the direction they propagate **to**
    (``wave_from_deg + 180``), currents (the vector they flow to) in knots. Along a centreline that
    turns at a waypoint the components jump there and the NLP's smooth interpolant spreads the jump
    over about two along-track cells; the verification of the plan catches what that costs.

    NaN (land, ice, no-go cells) never becomes zeros: such nodes are filled from the nearest
    navigable node only so that the interpolant is defined, and :func:`lateral_bounds` keeps the
    waypoints off them; the dense verification of the plan re-checks every leg.

    With ``leg_windows_h`` (N, 2) [h after departure], the first and last time a ship can be on each
    leg (:func:`optroute.optimise.lateral.reach_windows`), the weather is sampled and the power
    tabulated only at the nodes a reachable sample's spline reads (:func:`reachable_nodes`); every
    other node holds the value of its along-track column's nearest such node in time. The NLP's
    values at reachable samples are then the same as on the whole grid, for a fraction of the model
    evaluations (the reachable band of an ETA at 18 kn with a 24 kn top speed is about a quarter of
    the time span at every along-track node); an iterate outside the windows sees held weather.

    ``speeds_kn`` are the table's speed nodes, halved in step where their spline misses the model by
    more than ``speed_tol`` (:func:`~optroute.optimise.power_table.tabulate_ratio`; None: kept as given).

    Raises
    ------
    WeatherCoverageError
        A node lies outside the weather's area (or, under ``time_policy="raise"``, its time span).
    NoSafePassage
        The weather is NaN at every node.
    """
    nodes = _grid_nodes(frame, sampler, departure, (t_end_h, dt_h, ds_nm, dy_nm), leg_windows_h)
    hold, y_axis, shape = nodes.hold, nodes.y_axis, nodes.shape
    names = [
        v
        for v in ("hs_m", "tp_s", "tm_s", "wave_from_deg", "wind_u_ms", "wind_v_ms", "current_u_ms", "current_v_ms")
        if v in sampler.variables
    ]
    got = {k: hold.spread(v) for k, v in sampler.sample(nodes.tt, nodes.la, nodes.lo, variables=names).items()}
    fields, bad, has_current = _corridor_fields(got, nodes.along, shape)
    hs = fields[0]
    table: dict[str, object] = {}
    capped, evaluations, speed_error = 0.0, 0, float("nan")
    if model is not None and base is not None and speeds_kn is not None and headings_deg is not None:
        table, capped, evaluations, speed_error = _power_table(
            got, fields, bad, nodes, model, base, speeds_kn, headings_deg, speed_tol
        )
    t_axis = nodes.t_axis
    varying = fields + ([np.asarray(table["power_ratio"])] if table else [])
    static = t_axis.size > 1 and all(np.ptp(f, axis=0).max() <= 1e-12 * max(1.0, np.abs(f).max()) for f in varying)
    if static:
        t_axis = np.zeros(1)
        fields = [f[:1] for f in fields]
        if table:
            table["power_ratio"] = np.asarray(table["power_ratio"])[:1]
    grid = WeatherGrid(
        t_h=t_axis,
        s_nm=nodes.s_axis,
        y_nm=y_axis,
        hs_m=np.maximum(fields[0], 0.0),
        period_s=fields[1],
        wave_to_along=fields[2],
        wave_to_across=fields[3],
        current_along_kn=fields[4] if has_current else None,
        current_across_kn=fields[5] if has_current else None,
        method="smooth",
        **table,  # type: ignore[arg-type]
    )
    good = ~bad & hold.kept[..., None]
    samples = GridSamples(
        hs_m=hs[good],
        filled=int((bad & hold.kept[..., None]).sum()),
        static=static or shape[0] == 1,
        has_current=has_current,
        power_capped_share=float(capped),
        power_evaluations=int(evaluations),
        power_speed_error=float(speed_error),
    )
    return grid, samples


class _Nodes(NamedTuple):
    """The grid's axes (time [h since departure], along-track [nm], across-track [nm]), the centreline direction
    at each (along, across) node [deg true], the (time, along, across) shape, the time hold and the times [UTC]
    and positions [deg] sampled (the held nodes' only: :class:`_TimeHold`)."""

    t_axis: np.ndarray
    s_axis: np.ndarray
    y_axis: np.ndarray
    along: np.ndarray
    shape: tuple[int, int, int]
    hold: _TimeHold
    tt: np.ndarray
    la: np.ndarray
    lo: np.ndarray


def _grid_nodes(
    frame: CorridorFrame,
    sampler: WeatherSampler,
    departure: np.datetime64,
    spacing: tuple[float, float, float, float],
    leg_windows_h: np.ndarray | None,
) -> _Nodes:
    """:func:`weather_grid`'s nodes (``spacing``: t_end_h, dt_h, ds_nm, dy_nm); WeatherCoverageError naming the
    first node outside the weather."""
    t_end_h, dt_h, ds_nm, dy_nm = spacing
    length = float(frame.s_nm[-1])
    t_axis = _uniform_axis(0.0, max(float(t_end_h), dt_h), dt_h, max_n=2000)
    s_axis = _uniform_axis(0.0, length, ds_nm, max_n=4000)
    y_max = float(np.max(frame.corridor.half_width_nm))
    y_axis = np.zeros(1) if y_max <= 0 else _uniform_axis(-y_max, y_max, dy_nm, odd=True, max_n=41)
    ss, yy = np.meshgrid(s_axis, y_axis, indexing="ij")
    lat, lon, along = frame.points(ss, yy)
    when = departure + _h_to_td(t_axis)
    shape = (t_axis.size, s_axis.size, y_axis.size)
    hold = _TimeHold(t_axis, s_axis, frame.s_nm, leg_windows_h)
    tt = hold.take(np.broadcast_to(when[:, None, None], shape))
    la = hold.take(np.broadcast_to(lat[None], shape))
    lo = hold.take(np.broadcast_to(lon[None], shape))
    covered = sampler.covers(tt, la, lo)
    if not covered.all():
        i = np.argwhere(~covered)[0]
        ext = sampler.extent
        raise WeatherCoverageError(
            f"the corridor's weather grid node at ({la[tuple(i)]:.3f}, {lo[tuple(i)]:.3f}) at {units.format_utc(tt[tuple(i)])} lies outside "
            f"the weather (lat {ext['lat']}, lon {ext['lon']}, time {units.format_utc(ext['time'][0])} to {units.format_utc(ext['time'][1])}); extend the "
            "forecast in space or time, or narrow the corridor"
        )
    return _Nodes(t_axis, s_axis, y_axis, along, shape, hold, tt, la, lo)


def _corridor_fields(
    got: dict[str, np.ndarray], along: np.ndarray, shape: tuple[int, int, int]
) -> tuple[list[np.ndarray], np.ndarray, bool]:
    """The formulation's fields from the sampled weather ``got``: Hs [m], period [s], the wave's unit direction
    of travel along and to port of the centreline (``along`` [deg true] at each node) and, where there is a
    current, its components [kn]; NaN nodes filled from the nearest navigable one. Returns ``(fields, NaN
    nodes, has_current)``; NoSafePassage where every node is NaN."""
    period_name = "tp_s" if "tp_s" in got else "tm_s"
    hs, period, wfrom = got["hs_m"], got[period_name], got["wave_from_deg"]
    bad = ~(np.isfinite(hs) & np.isfinite(period) & np.isfinite(wfrom))
    if bad.all():
        raise NoSafePassage("the weather is NaN (no passage) at every node of the corridor's grid; check the corridor")
    zero = np.zeros(shape)
    cu, cv = got.get("current_u_ms", zero), got.get("current_v_ms", zero)
    bad |= ~(np.isfinite(cu) & np.isfinite(cv))
    hs, period, cu, cv = (_fill_nearest(np.where(bad, np.nan, a), bad) for a in (hs, period, cu, cv))
    c = np.radians(along)[None]
    wto = np.radians(wfrom + 180.0)
    w_al, w_ac = np.cos(wto - c), np.sin(c - wto)
    w_al, w_ac = (_fill_nearest(np.where(bad, np.nan, a), bad) for a in (w_al, w_ac))
    cu_kn, cv_kn = units.ms_to_kn(cu), units.ms_to_kn(cv)
    c_al = cu_kn * np.sin(c) + cv_kn * np.cos(c)
    c_ac = -cu_kn * np.cos(c) + cv_kn * np.sin(c)
    has_current = bool(np.max(np.hypot(cu_kn, cv_kn)) > 1e-9)
    return [hs, period, w_al, w_ac] + ([c_al, c_ac] if has_current else []), bad, has_current


def _power_table(
    got: dict[str, np.ndarray],
    fields: list[np.ndarray],
    bad: np.ndarray,
    nodes: _Nodes,
    model: PerformanceModel,
    base: PowerModel,
    speeds_kn: np.ndarray,
    headings_deg: np.ndarray,
    speed_tol: float | None,
) -> tuple[dict[str, object], float, int, float]:
    """The ship's power ratio at every node, speed [kn] and heading [deg from the centreline]
    (:func:`~optroute.optimise.power_table.tabulate_ratio`) in the node's own sea (``fields``' Hs and period, the
    sampled direction and wind with NaN nodes filled as they are): the WeatherGrid's table entries, the share
    capped, the model evaluations and the speed axis's error (the table's speed nodes are ``speeds_kn`` or twice as
    dense, :func:`~optroute.optimise.power_table.tabulate_ratio`)."""
    hold, shape, y_axis = nodes.hold, nodes.shape, nodes.y_axis
    period_name = "tp_s" if "tp_s" in got else "tm_s"
    wfrom_f = _fill_nearest(np.where(bad, np.nan, got["wave_from_deg"]), bad)
    sample = {"hs_m": fields[0], period_name: fields[1], "wave_from_deg": wfrom_f}
    for name in ("wind_u_ms", "wind_v_ms"):
        if name in got:
            sample[name] = _fill_nearest(np.where(bad, np.nan, got[name]), bad)
    sea = SeaState.from_sample({k: np.ravel(hold.take(v)) for k, v in sample.items()})
    along_all = np.ravel(hold.take(np.broadcast_to(nodes.along[None], shape)))
    tab = tabulate_ratio(model, base, sea, along_all, speeds_kn, headings_deg, speed_tol)
    # one field per sector where the model declares its sectors, else the plain (nt, ns, ny, nv, nd) table
    ratio, capped = (tab.ratio if tab.sector_edges_deg else tab.ratio[..., 0]), tab.capped_share
    table = {
        "power_ratio": hold.spread(ratio.reshape(-1, y_axis.size, *ratio.shape[1:])),
        "ratio_speed_kn": np.asarray(tab.speeds_kn, dtype=float),
        "ratio_heading_deg": tab.headings_deg,
        "ratio_sector_edges_deg": tab.sector_edges_deg,
    }
    return table, float(capped), int(ratio.size), float(tab.speed_error)


# --------------------------------------------------------------------------- bands and exclusion


def formulation_bands(
    ship: Ship, rules: BandRules, *, widen: float = 0.0, hs_margin: float = 0.0
) -> tuple[tuple[Band, ...], tuple[str, ...], float]:
    """Danger-band rules as formulation bands, and the ``g/2π`` [kn/s] the formulation must use.

    Mapping (formulation ratios: χ the angle between heading and wave **propagation**, 0 = following,
    so IMO's α = 180° − χ and ``V cos χ = V cos(180° − α)``, the speed along the waves of
    :mod:`optroute.physics.safety`; ``A = g/2π``):

    ====================  =============================================  ===============================
    band                  Boeing EP 2145155                              IMO MSC.1/Circ.1228
    ====================  =============================================  ===============================
    synchronous_roll      ``te_over_tr`` (1 − m, 1 + m), T_R            same
    parametric_roll       ``te_over_tr`` (0.5(1 − m), 0.5(1 + m)), T_R  same
    surf_riding           ``v_over_c`` (1 − m, 1 + m)                    ``v_over_ref`` (1, ∞), 1.8 √L
    high_wave_attack      ``v_over_cg`` (1 − m, 1 + m)                   ``v_over_c`` (1 − 1/1.8, 1 − 1/3)
    ====================  =============================================  ===============================

    All apply where ``Hs ≥ hs_threshold_fraction · L``. The IMO high-wave zone
    ``1.8 ≤ c_E/(c_E − u) ≤ 3`` is ``u/c_E ∈ [1 − 1/1.8, 1 − 1/3]``. Two IMO conditions the formulation
    cannot express make it conservative: surf-riding only for 135° < α < 225° (elsewhere
    ``V cos χ ≤ 1.8 √L`` is imposed too, binding only above 1.8 √L / cos 45° = 2.55 √L kn) and the
    high-wave zone only where λ > 0.8 L. With ``period_form="imo"`` the formulation's ``A`` is IMO's 3
    kn/s (T_E and IMO's c_E), and the Boeing speed bands, which use the exact phase speed, have their
    edges scaled by A_exact/3.

    Parameters
    ----------
    ship : Ship
        Length [m] and roll period T_R [s].
    rules : BandRules
        The rule set; disabled bands are left out.
    widen : float
        Safety back-off [-]: every edge moves outwards by this fraction (``lower·(1 − widen)``,
        ``upper·(1 + widen)``), because the bands are closed and the NLP ends on their edges.
    hs_margin : float
        Applicability back-off [-]: the bands apply from ``(1 − hs_margin)`` times the rules'
        threshold, because the NLP sees a smoothed sea at a few samples per leg and a band
        switching on between them must not be missed.

    Returns
    -------
    bands : tuple of Band
    names : tuple of str
        The :data:`optroute.physics.safety.BANDS` name of each.
    g_over_2pi_kn_s : float
    """
    length, t_r = float(ship.length_m), float(ship.roll_period_s)
    hs_min = rules.hs_threshold_fraction * length * (1.0 - hs_margin)
    imo_form = rules.period_form == "imo"
    a = seaway.IMO_G_OVER_2PI_KN_S if imo_form else G_OVER_2PI_KN_S
    speed_scale = G_OVER_2PI_KN_S / a  # exact-c ratio edges in units of the formulation's c

    def band(kind: str, lo: float, hi: float, name: str, param: float = float("nan")) -> Band:
        lo_w = lo * (1.0 - widen) if np.isfinite(lo) else lo
        hi_w = hi * (1.0 + widen) if np.isfinite(hi) else hi
        return Band(kind, lo_w, hi_w, param=param, hs_min_m=hs_min, name=name)

    out: list[Band] = []
    names: list[str] = []
    for name in rules.enabled_bands:
        lo, hi = rules.ratio_band(name)
        if name in ("synchronous_roll", "parametric_roll"):
            out.append(band("te_over_tr", lo, hi, name, t_r))
        elif rules.rule_set == "boeing":
            kind = "v_over_c" if name == "surf_riding" else "v_over_cg"
            out.append(band(kind, lo * speed_scale, hi * speed_scale, name))
        elif name == "surf_riding":
            out.append(band("v_over_ref", 1.0, float("inf"), name, IMO_SURF_RIDING_KN_PER_SQRT_M * math.sqrt(length)))
        else:
            lo_r, hi_r = IMO_HIGH_WAVE_TE_OVER_T
            out.append(band("v_over_c", 1.0 - 1.0 / lo_r, 1.0 - 1.0 / hi_r, name))
        names.append(name)
    return tuple(out), tuple(names), float(a)


def moving_exclusion(
    exclusion: Exclusion, frame: CorridorFrame, departure: np.datetime64, *, extra_radius_nm: float = 0.0
) -> MovingExclusion:
    """An :class:`~optroute.plan.result.Exclusion` as the formulation's moving circle in the corridor frame.

    The centre is mapped by its foot on the centreline and its offset along the normal
    (:meth:`CorridorFrame.to_xy`); far from the corridor the developed frame stretches distances
    by O((y/R)²), which ``extra_radius_nm`` and the plan's verification cover.
    """
    t_h = (exclusion.time - departure).astype(np.int64) / _NS_PER_H
    xy = frame.to_xy(exclusion.lat_deg, exclusion.lon_deg)
    return MovingExclusion(t_h=t_h, centre_xy_nm=xy, radius_nm=exclusion.radius_nm + float(extra_radius_nm))


def dataset_spacing(dataset: xr.Dataset | None) -> tuple[float | None, float | None]:
    """Grid spacing of a canonical dataset: (time step [h], latitude step [nm]); None where unknown."""
    if dataset is None:
        return None, None
    dt = ds = None
    if "time" in dataset.coords and dataset["time"].size > 1:
        t = dataset["time"].values.astype("datetime64[ns]")
        dt = float(np.min(np.diff(t)).astype(np.int64)) / _NS_PER_H
    if "lat" in dataset.coords and dataset["lat"].size > 1:
        ds = float(np.min(np.abs(np.diff(dataset["lat"].values)))) * 60.0
    return dt, ds


def exclusion_frame_error_nm(
    exclusion: Exclusion, frame: CorridorFrame, *, n_along: int = 64, n_across: int = 9, reach_nm: float = 20.0
) -> float:
    """Largest error of the flat frame's distance to the exclusion's centre near its circle [nm].

    The NLP keeps out of the circle in its flat frame (:func:`moving_exclusion`); the referee measures WGS84
    geodesics. At corridor points (``n_along`` × ``n_across`` over its length and width,
    :meth:`CorridorFrame.points`) whose geodesic distance from the centre at one of the track's times is within
    ``reach_nm`` of the radius, the flat distance ``|to_xy(p) − to_xy(c)|`` is compared with the geodesic one;
    the largest difference is the back-off (``extra_radius_nm``) under which a plan on the flat circle's edge
    stays outside the true one. 0 where no corridor point comes near the circle.
    """
    s = np.linspace(frame.s_nm[0], frame.s_nm[-1], n_along)
    hw = float(np.max(frame.corridor.half_width_nm))
    y = np.linspace(-hw, hw, n_across)
    ss, yy = np.meshgrid(s, y, indexing="ij")
    lat, lon, _ = frame.points(ss.ravel(), yy.ravel())
    pxy = frame.to_xy(lat, lon)
    cxy = frame.to_xy(exclusion.lat_deg, exclusion.lon_deg)
    rad = np.broadcast_to(np.asarray(exclusion.radius_nm, dtype=float), np.shape(exclusion.lat_deg))
    true = geo.distance_nm(lat[None, :], lon[None, :], np.asarray(exclusion.lat_deg)[:, None],
                           np.asarray(exclusion.lon_deg)[:, None])  # fmt: skip
    flat = np.linalg.norm(pxy[None, :, :] - cxy[:, None, :], axis=-1)
    near = np.abs(true - rad[:, None]) <= reach_nm
    return float(np.max(np.abs(flat - true)[near])) if np.any(near) else 0.0
