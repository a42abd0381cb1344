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
* :func:`fit_power_model` — a least-squares fit of the NLP's closed power form
  to any :class:`~optroute.physics.performance.PerformanceModel`.
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

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy import ndimage
from scipy.optimize import least_squares, nnls

from formulations.common import G_OVER_2PI_KN_S, Band, CorridorGeometry, MovingExclusion, PowerModel, WeatherGrid
from optroute import geodesy as geo
from optroute import units
from optroute.errors import NoSafePassage, WeatherCoverageError
from optroute.geo.tracks import Exclusion, gc_points, project_to_polyline
from optroute.optimise.lateral import lateral_bounds
from optroute.physics import seaway
from optroute.physics.performance import PerformanceModel
from optroute.physics.safety import IMO_HIGH_WAVE_TE_OVER_T, IMO_SURF_RIDING_KN_PER_SQRT_M, BandRules
from optroute.physics.ship import Ship
from optroute.search.route import Corridor
from optroute.units import NS_PER_H as _NS_PER_H
from optroute.units import h_to_timedelta as _h_to_td
from optroute.weather.sample import WeatherSampler

__all__ = [
    "CorridorFrame",
    "PowerFit",
    "build_frame",
    "fit_power_model",
    "formulation_bands",
    "lateral_bounds",
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
        """Flat-frame position [nm] (…, 2) of points: foot on the centreline plus the signed offset along its normal."""
        s, xt, _, k = project_to_polyline(self.corridor.waypoints, lat_deg, lon_deg)
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
    """The raw samples behind a :class:`~formulations.common.WeatherGrid`, for the power fit and reports.

    Attributes
    ----------
    hs_m, wind_ms : numpy.ndarray
        Hs [m] and 10 m wind speed [m/s] at the grid's navigable nodes (1-D).
    filled : int
        Nodes whose NaN (no passage) values were filled from the nearest navigable node.
    static : bool
        The fields do not change in time over the window (the grid keeps one time slice).
    has_current : bool
        A non-zero current is present.
    """

    hs_m: np.ndarray
    wind_ms: np.ndarray
    filled: int
    static: bool
    has_current: bool


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


def weather_grid(
    frame: CorridorFrame,
    sampler: WeatherSampler,
    *,
    departure: np.datetime64,
    t_end_h: float,
    dt_h: float,
    ds_nm: float,
    dy_nm: float,
) -> tuple[WeatherGrid, GridSamples]:
    """The weather on the corridor's (time, along-track, across-track) grid.

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

    Raises
    ------
    WeatherCoverageError
        A node lies outside the weather's area (or, under ``time_policy="raise"``, its time span).
    NoSafePassage
        The weather is NaN at every node.
    """
    length = float(frame.s_nm[-1])
    t_axis = _uniform_axis(0.0, max(float(t_end_h), dt_h), dt_h, max_n=2000)
    s_axis = _uniform_axis(0.0, length, ds_nm, max_n=4000)
    y_max = float(np.max(frame.corridor.half_width_nm))
    y_axis = np.zeros(1) if y_max <= 0 else _uniform_axis(-y_max, y_max, dy_nm, odd=True, max_n=41)
    ss, yy = np.meshgrid(s_axis, y_axis, indexing="ij")
    lat, lon, along = frame.points(ss, yy)
    when = departure + _h_to_td(t_axis)
    shape = (t_axis.size, s_axis.size, y_axis.size)
    tt = np.broadcast_to(when[:, None, None], shape)
    la = np.broadcast_to(lat[None], shape)
    lo = np.broadcast_to(lon[None], shape)
    covered = sampler.covers(tt, la, lo)
    if not covered.all():
        i = np.argwhere(~covered)[0]
        ext = sampler.extent
        raise WeatherCoverageError(
            f"the corridor's weather grid node at ({la[tuple(i)]:.3f}, {lo[tuple(i)]:.3f}) at {units.format_utc(tt[tuple(i)])} lies outside "
            f"the weather (lat {ext['lat']}, lon {ext['lon']}, time {units.format_utc(ext['time'][0])} to {units.format_utc(ext['time'][1])}); extend the "
            "forecast in space or time, or narrow the corridor"
        )
    names = [
        v
        for v in ("hs_m", "tp_s", "tm_s", "wave_from_deg", "wind_u_ms", "wind_v_ms", "current_u_ms", "current_v_ms")
        if v in sampler.variables
    ]
    got = sampler.sample(tt, la, lo, variables=names)
    period_name = "tp_s" if "tp_s" in got else "tm_s"
    hs, period, wfrom = got["hs_m"], got[period_name], got["wave_from_deg"]
    bad = ~(np.isfinite(hs) & np.isfinite(period) & np.isfinite(wfrom))
    if bad.all():
        raise NoSafePassage("the weather is NaN (no passage) at every node of the corridor's grid; check the corridor")
    zero = np.zeros(shape)
    cu, cv = got.get("current_u_ms", zero), got.get("current_v_ms", zero)
    wu, wv = got.get("wind_u_ms", zero), got.get("wind_v_ms", zero)
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
    fields = [hs, period, w_al, w_ac] + ([c_al, c_ac] if has_current else [])
    static = t_axis.size > 1 and all(np.ptp(f, axis=0).max() <= 1e-12 * max(1.0, np.abs(f).max()) for f in fields)
    if static:
        t_axis = np.zeros(1)
        fields = [f[:1] for f in fields]
    grid = WeatherGrid(
        t_h=t_axis,
        s_nm=s_axis,
        y_nm=y_axis,
        hs_m=np.maximum(fields[0], 0.0),
        period_s=fields[1],
        wave_to_along=fields[2],
        wave_to_across=fields[3],
        current_along_kn=fields[4] if has_current else None,
        current_across_kn=fields[5] if has_current else None,
        method="smooth",
    )
    good = ~bad
    wind = np.hypot(np.where(np.isfinite(wu), wu, 0.0), np.where(np.isfinite(wv), wv, 0.0))
    samples = GridSamples(
        hs_m=hs[good],
        wind_ms=wind[good],
        filled=int(bad.sum()),
        static=static or shape[0] == 1,
        has_current=has_current,
    )
    return grid, samples


# --------------------------------------------------------------------------- power fit


@dataclass(frozen=True)
class PowerFit:
    """The NLP's power model fitted to a performance model, with the fit's errors.

    Attributes
    ----------
    power : PowerModel
        ``P = P_calm(V) (1 + W(Hs) D(cos α) S(V))`` [kW] and the SFOC curve (see
        :mod:`formulations.speed_nlp`).
    max_rel_error, rms_rel_error : float
        Largest and root-mean-square relative error of the fitted brake power against the model's
        over the fit points [-].
    sfoc_max_rel_error : float
        Largest relative error of the fitted fuel rate per kW [-].
    n_points : int
        Fit points (speed × sea state × wave angle).
    speed_range_kn, hs_range_m : (float, float)
        Ranges covered.
    """

    power: PowerModel
    max_rel_error: float
    rms_rel_error: float
    sfoc_max_rel_error: float
    n_points: int
    speed_range_kn: tuple[float, float]
    hs_range_m: tuple[float, float]


def _lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.lstsq(a, b, rcond=None)[0]


def fit_power_model(
    model: PerformanceModel,
    *,
    hs_m: ArrayLike,
    wind_ms: ArrayLike,
    v_min_kn: float,
    v_max_kn: float,
    min_load: float,
    max_load: float = 1.0,
    n_speeds: int = 12,
    n_seas: int = 12,
    angles_deg: ArrayLike = tuple(range(0, 181, 15)),
) -> PowerFit:
    """Fit the NLP's power form to a performance model by least squares on relative errors.

    The form (:mod:`formulations.speed_nlp`)::

        P = P_calm(V) · (1 + W(Hs) · D(cos α) · S(V)),
        P_calm(V) = Σ c_j V^{n_j},  W = Σ h_m Hs^{q_m},  D = b0 + b1 cos α + b2 cos² α,  S = Σ u_r V^r

    with ``V`` the speed through water [kn], ``α`` the IMO encounter angle (0 = head sea).

    1. ``P_calm`` on the model's calm-water power at 25 speeds over ``[v_min, v_max]``: a pure cube
       law when it reproduces the model to 1e-9 (the admiralty law), else non-negative least squares
       on ``n = 1…5`` (non-negative terms keep the fuel convex in the leg time).
    2. ``W D S`` on ``P/P_calm − 1`` at ``n_speeds`` speeds × ``n_seas`` sea states × the angles,
       weighted by ``P_calm/P`` (so that the residual is the relative power error), by alternating
       least squares over the three factors (each step is linear). The sea states are the voyage's
       own (Hs, wind) pairs at Hs quantiles, because the model may take the Beaufort number from
       the wind (Kwon); ``q = 1, 2, 3`` (fewer when the voyage has fewer distinct Hs), ``S``
       quadratic. Points where the model has no finite power or needs more than 1.5 MCR are left out.
    3. The SFOC curve ``SFOC/base = a2 L² + a1 L + a0`` on ``fuel_rate_tph(P)/P`` over the load range.

    Kwon's method is piecewise constant in the Beaufort number and the wave sector, which a smooth
    form cannot follow exactly: the maximum relative error is reported, and the optimiser verifies
    every plan with the true model and re-solves with a reduced MCR where the fit underestimates.

    Parameters
    ----------
    model : PerformanceModel
        The true model (``brake_power_kw``, ``fuel_rate_tph``, ``mcr_kw``).
    hs_m, wind_ms : array_like
        The voyage's sea states: Hs [m] and 10 m wind speed [m/s], paired.
    v_min_kn, v_max_kn : float
        Speed range [kn].
    min_load, max_load : float
        Engine load limits [-] for the PowerModel.
    n_speeds, n_seas : int
        Fit resolution.
    angles_deg : array_like
        IMO encounter angles [deg] of the fit.

    Returns
    -------
    PowerFit
    """
    mcr = float(model.mcr_kw)
    v_all = np.linspace(v_min_kn, v_max_kn, 25)
    p0 = np.asarray(
        model.brake_power_kw(v_all, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=0.0, wind_angle_deg=0.0), dtype=float
    )
    ok0 = np.isfinite(p0) & (p0 > 0)
    v0, p0 = v_all[ok0], p0[ok0]
    c3 = float(np.sum(v0**3 / p0) / np.sum(v0**6 / p0**2))
    if np.max(np.abs(c3 * v0**3 / p0 - 1.0)) <= 1e-9:
        calm_coef, calm_exp = np.array([c3]), np.array([3.0])
    else:
        exps = np.arange(1.0, 6.0)
        scale = v_max_kn**exps
        coef, _ = nnls((v0[:, None] ** exps[None, :] / scale) / p0[:, None], np.ones(v0.size))
        keep = coef > 0
        calm_coef, calm_exp = (coef / scale)[keep], exps[keep]

    def calm(v: np.ndarray) -> np.ndarray:
        return np.sum(calm_coef * np.asarray(v)[..., None] ** calm_exp, axis=-1)

    # sea states: (Hs, wind) pairs at Hs quantiles
    hs = np.asarray(hs_m, dtype=float).ravel()
    wind = np.broadcast_to(np.asarray(wind_ms, dtype=float), hs.shape).ravel()
    keep = np.isfinite(hs) & np.isfinite(wind)
    hs, wind = hs[keep], wind[keep]
    order = np.argsort(hs, kind="stable")
    picks = np.unique(np.round(np.linspace(0, hs.size - 1, n_seas)).astype(int)) if hs.size else np.zeros(0, int)
    pairs = np.unique(np.column_stack([hs[order][picks], wind[order][picks]]), axis=0) if hs.size else np.zeros((0, 2))
    levels = np.unique(np.round(pairs[:, 0], 9)) if pairs.size else np.zeros(0)
    n_levels = int(np.sum(levels > 0))
    q = np.array([1.0, 2.0, 3.0][: max(0, min(3, n_levels))])
    v = np.linspace(v_min_kn, v_max_kn, n_speeds)
    alpha = np.asarray(angles_deg, dtype=float)
    hs_g = pairs[:, 0][:, None, None] if pairs.size else np.zeros((0, 1, 1))
    wind_g = pairs[:, 1][:, None, None] if pairs.size else np.zeros((0, 1, 1))
    a_g = alpha[None, :, None]
    v_g = v[None, None, :]
    hs_coef, speed_coef, angle_coef = np.zeros(0), np.array([1.0]), np.array([1.0, 0.0, 0.0])
    err_max = err_rms = 0.0
    n_pts = 0
    if pairs.size:
        p = np.asarray(
            model.brake_power_kw(v_g, hs_m=hs_g, wave_angle_deg=a_g, wind_speed_ms=wind_g, wind_angle_deg=a_g),
            dtype=float,
        )
        p = np.broadcast_to(p, (pairs.shape[0], alpha.size, v.size))
        pc = np.broadcast_to(calm(v)[None, None, :], p.shape)
        use = np.isfinite(p) & (p > 0) & (p <= 1.5 * mcr)
        hs_b = np.broadcast_to(hs_g, p.shape)[use]
        ca = np.broadcast_to(np.cos(np.radians(a_g)), p.shape)[use]
        vb = np.broadcast_to(v_g, p.shape)[use]
        wgt = pc[use] / p[use]
        target = (p[use] / pc[use] - 1.0) * wgt
        n_pts = int(use.sum())
        if q.size and n_pts:
            bw = hs_b[:, None] ** q[None, :]
            bd = np.column_stack([np.ones_like(ca), ca, ca**2])
            bs = np.column_stack([np.ones_like(vb), vb, vb**2])
            h, b, u = np.zeros(q.size), np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
            prev = np.inf
            for _ in range(100):
                dd, sv = bd @ b, bs @ u
                h = _lstsq(bw * (wgt * dd * sv)[:, None], target)
                ww = bw @ h
                b = _lstsq(bd * (wgt * ww * sv)[:, None], target)
                dd = bd @ b
                u = _lstsq(bs * (wgt * ww * dd)[:, None], target)
                res = float(np.sum((wgt * ww * dd * (bs @ u) - target) ** 2))
                if prev - res <= 1e-14 * max(prev, 1e-300):
                    break
                prev = res
            # joint Levenberg–Marquardt polish: ALS crawls along the factors' scale ambiguity
            nq = q.size

            def resid(x: np.ndarray) -> np.ndarray:
                return wgt * (bw @ x[:nq]) * (bd @ x[nq : nq + 3]) * (bs @ x[nq + 3 :]) - target

            polished = least_squares(
                resid, np.concatenate([h, b, u]), method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000
            )
            if float(np.sum(polished.fun**2)) <= float(np.sum(resid(np.concatenate([h, b, u])) ** 2)):
                h, b, u = polished.x[:nq], polished.x[nq : nq + 3], polished.x[nq + 3 :]
            scale_b = float(np.max(np.abs(b))) or 1.0  # normalise D to max |coef| 1, move the scale into W
            scale_u = float(u[0]) if abs(u[0]) > 1e-12 else 1.0  # S(0) = 1: move the scale into W
            b, u, h = b / scale_b, u / scale_u, h * scale_b * scale_u
            scale_b = 1.0
            hs_coef, angle_coef, speed_coef = h * scale_b, b / scale_b, u
        w_fit = hs_b[:, None] ** q[None, :] @ hs_coef if hs_coef.size else np.zeros(n_pts)
        d_fit = angle_coef[0] + angle_coef[1] * ca + angle_coef[2] * ca**2
        s_fit = sum(ur * vb**r for r, ur in enumerate(speed_coef))
        fit = pc[use] * (1.0 + w_fit * d_fit * s_fit)
        rel = fit / p[use] - 1.0
        calm_rel = calm(v0) / p0 - 1.0
        allrel = np.concatenate([rel, calm_rel])
        err_max = float(np.max(np.abs(allrel))) if allrel.size else 0.0
        err_rms = float(np.sqrt(np.mean(allrel**2))) if allrel.size else 0.0
    else:
        calm_rel = calm(v0) / p0 - 1.0
        err_max = float(np.max(np.abs(calm_rel)))
        err_rms = float(np.sqrt(np.mean(calm_rel**2)))
    # SFOC
    loads = np.linspace(max(min_load, 0.05), 1.0, 20)
    pk = loads * mcr
    s = np.asarray(model.fuel_rate_tph(pk), dtype=float) / (pk * 1e-6)  # g/kWh
    quad = _lstsq(np.column_stack([loads**2, loads, np.ones_like(loads)]), s)
    quad = np.where(np.abs(quad) <= 1e-12 * np.max(np.abs(quad)), 0.0, quad)  # a constant SFOC stays constant
    base = float(np.mean(s))
    sfoc_err = float(np.max(np.abs((np.column_stack([loads**2, loads, np.ones_like(loads)]) @ quad) / s - 1.0)))
    power = PowerModel(
        calm_coef=calm_coef,
        calm_exp=calm_exp,
        mcr_kw=mcr,
        min_load=float(min_load),
        max_load=float(max_load),
        hs_coef=hs_coef if q.size else (),
        hs_exp=q if hs_coef.size else (),
        angle_coef=angle_coef,
        speed_coef=speed_coef,
        sfc_base_gpkwh=base,
        sfc_quad=quad / base,
    )
    hs_range = (float(pairs[:, 0].min()), float(pairs[:, 0].max())) if pairs.size else (0.0, 0.0)
    return PowerFit(power, err_max, err_rms, sfoc_err, n_pts + v0.size, (float(v_min_kn), float(v_max_kn)), hs_range)


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
