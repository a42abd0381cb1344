"""Sailing route search (Życkowski): a latitude/longitude lattice, 8/16/32 headings, time and manoeuvres.

The sailing area is the lattice ``P(i, j) = (φ_i, λ_j)`` of the paper's eq. (1);
a leg goes from ``P(i, j)`` to ``P(i + p, j + q)`` with the offsets of
:func:`optroute.search.neighbourhood.compass` (8, 16 or 32 headings,
``p, q ∈ −3..3``), along the great circle, at the boat speed the polar gives
for the leg's heading in the wind at its departure node and time
(:class:`optroute.physics.yacht.SailingVessel`); a heading inside the no-go
sector has speed 0 and is not an edge.

Objectives (all exact for this model when the passage time of a leg never
decreases as its departure is delayed — FIFO, always true in steady wind):

* ``"time"`` — earliest arrival; among equally fast routes, fewest manoeuvres.
* ``"manoeuvres"`` — fewest manoeuvres (tacks + gybes), then earliest arrival.
* ``"weighted"`` — least ``passage_h + manoeuvre_penalty_h · ω``: a search on
  node × tack × ω for ω up to the fastest route's count, which bounds the
  optimum's (its weighted value is an upper bound and T never falls below
  the fastest time), so the answer is the exact minimum over the (ω, T) front.

Counting manoeuvres exactly needs the tack of the previous leg in the label:
states are node × tack (none at the start, starboard, port); the route lists
every manoeuvre with its time, position and kind (tack or gybe).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from optroute import geodesy as geo
from optroute import units
from optroute.errors import ConfigError, NoSafePassage, WeatherCoverageError, WeatherSchemaError
from optroute.geo import land
from optroute.physics.yacht import TACK_NAMES, SailingVessel, check_vessel, manoeuvre_kind, wind_kn_from
from optroute.search import sailing_kernel as sk
from optroute.search.neighbourhood import Neighbourhood, compass
from optroute.units import as_utc_time
from optroute.weather.sample import WeatherSampler

SailObjective = Literal["time", "manoeuvres", "weighted"]
_WIND = (("wind_u_ms",), ("wind_v_ms",))


@dataclass(frozen=True, eq=False)
class SailingGrid:
    """The lattice ``P(φ_i, λ_j)``: ``lat_deg`` (m rows) × ``lon_deg`` (n columns), both increasing [deg]."""

    lat_deg: np.ndarray = field(repr=False)
    lon_deg: np.ndarray = field(repr=False)

    def __post_init__(self) -> None:
        for name in ("lat_deg", "lon_deg"):
            a = np.array(getattr(self, name), dtype=float).ravel()
            if a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
                raise ConfigError(f"SailingGrid {name} must hold >= 2 finite, strictly increasing values")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if self.lat_deg[0] < -89.0 or self.lat_deg[-1] > 89.0:
            raise ConfigError("SailingGrid latitudes must lie within ±89 deg")

    @classmethod
    def box(cls, lat_min: float, lat_max: float, lon_min: float, lon_max: float, m: int, n: int) -> SailingGrid:
        """``m × n`` evenly spaced points over a box [deg] (the paper's ``Create(OB, m, n)``)."""
        if int(m) < 2 or int(n) < 2:
            raise ConfigError(f"a lattice needs m, n >= 2, got m={m}, n={n}")
        return cls(np.linspace(lat_min, lat_max, int(m)), np.linspace(lon_min, lon_max, int(n)))

    @classmethod
    def around(cls, start: tuple[float, float], end: tuple[float, float], cell_nm: float,
               margin_nm: float) -> SailingGrid:  # fmt: skip
        """A lattice of ``cell_nm`` spacing [nm] around start and end with ``margin_nm`` [nm]; start is a node."""
        if not (np.isfinite(cell_nm) and cell_nm > 0 and np.isfinite(margin_nm) and margin_nm >= 0):
            raise ConfigError(f"cell_nm={cell_nm} must be > 0 and margin_nm={margin_nm} >= 0 [nm]")
        lat0, lon0 = float(start[0]), float(start[1])
        dlat = cell_nm / 60.0
        dlon = cell_nm / (60.0 * np.cos(np.radians(0.5 * (start[0] + end[0]))))
        lo_lat, hi_lat = min(start[0], end[0]) - margin_nm / 60.0, max(start[0], end[0]) + margin_nm / 60.0
        mlon = margin_nm / 60.0 / np.cos(np.radians(0.5 * (start[0] + end[0])))
        lo_lon, hi_lon = min(start[1], end[1]) - mlon, max(start[1], end[1]) + mlon
        ki = np.arange(np.floor((lo_lat - lat0) / dlat), np.ceil((hi_lat - lat0) / dlat) + 1)
        kj = np.arange(np.floor((lo_lon - lon0) / dlon), np.ceil((hi_lon - lon0) / dlon) + 1)
        return cls(lat0 + ki * dlat, lon0 + kj * dlon)

    @property
    def shape(self) -> tuple[int, int]:
        """``(m, n)``."""
        return self.lat_deg.size, self.lon_deg.size

    @property
    def n_nodes(self) -> int:
        """``|V| = m · n``."""
        return self.lat_deg.size * self.lon_deg.size

    def node_latlon(self, k: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        """(lat, lon) [deg] of flat node indices ``k = i · n + j``."""
        i, j = np.divmod(np.asarray(k), self.lon_deg.size)
        return self.lat_deg[i], self.lon_deg[j]

    def nearest(self, lat: float, lon: float) -> int:
        """Flat index of the node nearest (in lat, lon) to a position."""
        i = int(np.argmin(np.abs(self.lat_deg - lat)))
        j = int(np.argmin(np.abs(self.lon_deg - lon)))
        return i * self.lon_deg.size + j

    def edges(self, nb: Neighbourhood) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``target[k, d]`` (−1 off the lattice), great-circle ``length_nm`` and initial ``course_deg`` per edge."""
        m, n = self.shape
        ii, jj = np.meshgrid(np.arange(m), np.arange(n), indexing="ij")
        ii, jj = ii.ravel(), jj.ravel()
        ti = ii[:, None] + nb.offsets[None, :, 0]
        tj = jj[:, None] + nb.offsets[None, :, 1]
        ok = (ti >= 0) & (ti < m) & (tj >= 0) & (tj < n)
        target = np.where(ok, ti * n + tj, -1)
        la0, lo0 = self.lat_deg[ii][:, None], self.lon_deg[jj][:, None]
        la1, lo1 = self.lat_deg[np.clip(ti, 0, m - 1)], self.lon_deg[np.clip(tj, 0, n - 1)]
        length = np.where(ok, geo.distance_nm(la0, lo0, la1, lo1), np.inf)
        course = np.where(ok, geo.initial_course_deg(la0, lo0, la1, lo1), 0.0)
        return target.astype(np.int64), length, course

    def n_edges(self, nb: Neighbourhood) -> int:
        """Number of directed edges ``|E|`` inside the lattice."""
        return int((self.edges(nb)[0] >= 0).sum())


@dataclass(frozen=True, eq=False)
class SailingGraph:
    """The lattice's edges for one heading set, without the legs that touch land (the paper's ``G(V, E)``).

    Build it once (:meth:`build`) and pass it as ``grid=`` to search many
    departures or winds on the same graph.

    Attributes
    ----------
    grid : SailingGrid
    directions : int
        8, 16 or 32.
    target : ndarray of int, shape (nodes, directions)
        Node each heading reaches, −1 where the edge leaves the lattice or touches land.
    length_nm, course_deg : ndarray, shape (nodes, directions)
        Great-circle length [nm] and initial course [deg true] of each edge.
    sea : ndarray of bool, shape (nodes,)
        Nodes at sea (all of them without the land mask).
    land_resolution_nm : float or None
        Spacing of the land checks along each edge [nm]; None: no land mask.
    """

    grid: SailingGrid
    directions: int
    target: np.ndarray = field(repr=False)
    length_nm: np.ndarray = field(repr=False)
    course_deg: np.ndarray = field(repr=False)
    sea: np.ndarray = field(repr=False)
    land_resolution_nm: float | None = None
    _geometry: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    """Per-graph geometry computed on first use and kept (the graph is immutable): sea nodes, distances to a node."""

    @classmethod
    def build(cls, grid: SailingGrid, directions: int = 16, *, use_land_mask: bool = True,
              land_resolution_nm: float = 0.25) -> SailingGraph:  # fmt: skip
        """The graph of ``grid`` with Życkowski's ``directions``; with the coastline (GLOBE 30") unless told not."""
        nb = compass(directions)
        target, length, course = grid.edges(nb)
        sea = np.ones(grid.n_nodes, dtype=bool)
        if use_land_mask:
            la, lo = grid.node_latlon(np.arange(grid.n_nodes))
            sea = ~land.is_land(la, lo)
            k, d = np.nonzero(target >= 0)
            t = target[k, d]
            ok = sea[k] & sea[t]
            ok[ok] = ~land.legs_cross_land(la[k[ok]], lo[k[ok]], la[t[ok]], lo[t[ok]], land_resolution_nm,
                                           use_land_mask=True)  # fmt: skip
            target = target.copy()
            target[k[~ok], d[~ok]] = -1
        for a in (target, length, course, sea):
            a.setflags(write=False)
        res = float(land_resolution_nm) if use_land_mask else None
        return cls(grid, int(directions), target, length, course, sea, res)

    @property
    def n_vertices(self) -> int:
        """Nodes at sea ``|V|``."""
        return int(self.sea.sum())

    @property
    def n_edges(self) -> int:
        """Directed edges ``|E|`` (each way counted)."""
        return int((self.target >= 0).sum())

    def nearest_sea(self, lat: float, lon: float) -> int:
        """Flat index of the sea node nearest (WGS84 geodesic) to a position.

        The spherical distance brackets the geodesic one (:data:`optroute.geodesy.SPHERE_TO_WGS84_MIN` and
        ``_MAX``), so only the nodes the sphere cannot rule out are measured on the ellipsoid: the same node.
        """
        if "sea" not in self._geometry:
            nodes = np.flatnonzero(self.sea)
            self._geometry["sea"] = (nodes, *self.grid.node_latlon(nodes))
        nodes, la, lo = self._geometry["sea"]
        d_sphere = geo.sphere_distance_nm(lat, lon, la, lo)
        near = np.flatnonzero(d_sphere * geo.SPHERE_TO_WGS84_MIN <= d_sphere.min() * geo.SPHERE_TO_WGS84_MAX)
        k = near[int(np.argmin(geo.distance_nm(lat, lon, la[near], lo[near])))]
        return int(nodes[k])

    def distance_to_nm(self, node: int) -> np.ndarray:
        """WGS84 geodesic distance [nm] from every node to ``node``, kept for the next search to that node."""
        key = ("to", int(node))
        if key not in self._geometry:
            la, lo = self.grid.node_latlon(np.arange(self.grid.n_nodes))
            d = geo.distance_nm(la, lo, *self.grid.node_latlon(node))
            d.setflags(write=False)
            self._geometry[key] = d
        return self._geometry[key]


@dataclass(frozen=True)
class Manoeuvre:
    """A tack or gybe: at ``time`` [UTC] at (``lat_deg``, ``lon_deg``), from one tack to the other."""

    time: np.datetime64
    t_h: float
    lat_deg: float
    lon_deg: float
    kind: str
    from_tack: str
    to_tack: str


@dataclass(frozen=True, eq=False)
class SailingRoute:
    """A sailing route through the lattice and how it was found.

    Attributes
    ----------
    lat_deg, lon_deg : ndarray, shape (k + 1,)
        Route nodes [deg].
    time : ndarray of datetime64, shape (k + 1,)
        Time at each node [UTC]; ``t_h`` the same in hours from departure.
    course_deg, twa_deg, speed_kn, length_nm : ndarray, shape (k,)
        Each leg's heading [deg true], signed true wind angle [deg, + = starboard],
        boat speed [kn], length [nm].
    motoring : ndarray of bool, shape (k,)
    manoeuvres : tuple of Manoeuvre
    heading_changes : int
        Legs whose lattice direction differs from the previous leg's (the paper's ω).
    objective : str
    front : tuple of (int, float)
        For ``"weighted"``: (ω, least passage time [h] with exactly ω manoeuvres)
        found below the stopping bound; else empty.
    status : str
        ``"optimal"``: the search settled the destination (exact under FIFO).
    stats : dict
        ``vertices``, ``edges`` (directed), ``directions``, ``build_s``,
        ``search_s``, ``runtime_s``, ``pops``, ``relaxations``.
    """

    lat_deg: np.ndarray = field(repr=False)
    lon_deg: np.ndarray = field(repr=False)
    time: np.ndarray = field(repr=False)
    t_h: np.ndarray = field(repr=False)
    course_deg: np.ndarray = field(repr=False)
    twa_deg: np.ndarray = field(repr=False)
    speed_kn: np.ndarray = field(repr=False)
    length_nm: np.ndarray = field(repr=False)
    motoring: np.ndarray = field(repr=False)
    manoeuvres: tuple[Manoeuvre, ...]
    heading_changes: int
    objective: str
    status: str
    front: tuple[tuple[int, float], ...] = ()
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def passage_h(self) -> float:
        """Passage time [h]."""
        return float(self.t_h[-1] - self.t_h[0])

    @property
    def distance_nm(self) -> float:
        """Sailed distance [nm]."""
        return float(self.length_nm.sum())

    @property
    def n_manoeuvres(self) -> int:
        """Tacks plus gybes (ω)."""
        return len(self.manoeuvres)

    def verify(self, weather: xr.Dataset, vessel: SailingVessel) -> dict[str, Any]:
        """Re-sail the route through the weather with the vessel's own model (the referee).

        Each leg's wind is sampled by :class:`WeatherSampler` at its departure
        node and time, its speed from :meth:`SailingVessel.leg_speed_kn`.

        Returns
        -------
        dict
            ``ok``; ``max_time_error_h`` (recomputed against reported node times);
            ``no_go_legs`` (indices of sailed legs with speed 0 or ``|TWA|`` below
            the no-go limit); ``manoeuvres`` recounted; ``land_legs`` (legs that
            touch the GLOBE coastline, checked every 0.1 nm, unless the weather's
            geography is synthetic).
        """
        sampler = sailing_sampler(weather)
        wx = sampler.sample(self.time[:-1], self.lat_deg[:-1], self.lon_deg[:-1], variables=["wind_u_ms", "wind_v_ms"])
        tws, frm = wind_kn_from(wx["wind_u_ms"], wx["wind_v_ms"])
        spd, twa, mot = vessel.leg_speed_kn(self.course_deg, frm, tws, source=sampler.source)
        t = self.t_h[0] + np.concatenate([[0.0], np.cumsum(self.length_nm / np.where(spd > 0, spd, np.nan))])
        bad = np.flatnonzero(~mot & ((spd <= 0) | (np.abs(twa) < vessel.polar.no_go_deg)))
        err = float(np.nanmax(np.abs(t - self.t_h))) if np.all(np.isfinite(t)) else float("inf")
        count = len(manoeuvres_along(twa, mot, self.time, self.t_h, self.lat_deg, self.lon_deg))
        on_land = np.zeros(self.course_deg.size, dtype=bool)
        if land.coastline_applies(weather, None):
            la, lo = self.lat_deg, self.lon_deg
            on_land = land.legs_cross_land(la[:-1], lo[:-1], la[1:], lo[1:], 0.1, use_land_mask=True)
        ok = err < 1e-6 and bad.size == 0 and count == self.n_manoeuvres and not on_land.any()
        return {"ok": ok, "max_time_error_h": err, "no_go_legs": bad.tolist(), "manoeuvres": count,
                "land_legs": np.flatnonzero(on_land).tolist()}  # fmt: skip


def sailing_sampler(weather: xr.Dataset) -> WeatherSampler:
    if not isinstance(weather, xr.Dataset):
        raise ConfigError(f"weather must be a canonical xarray.Dataset with wind_u_ms/wind_v_ms, "
                          f"got {type(weather).__name__}")  # fmt: skip
    for v in ("wind_u_ms", "wind_v_ms"):
        if v not in weather.data_vars:
            raise WeatherSchemaError(f"weather {weather.attrs.get('source', 'dataset')!r} has no {v}: a sailing "
                                     "route needs the wind; give a dataset with 10 m wind (ERA5 u10/v10)")  # fmt: skip
    steady = weather.sizes.get("time", 0) == 1  # a single step is a steady wind
    return WeatherSampler(weather, required=_WIND, time_policy="hold" if steady else None)


def manoeuvres_along(twa, mot, time, t_h, lat, lon) -> list[Manoeuvre]:
    """Tack changes along the legs (a leg dead downwind or under engine keeps the tack)."""
    out, cur, cur_twa = [], 0, 0.0
    for k, (a, m) in enumerate(zip(twa, mot, strict=True)):
        run = abs(abs(a) - 180.0) <= 1e-9 or a == 0.0
        if m or run:
            continue
        side = 1 if a > 0 else 2
        if cur and side != cur:
            out.append(Manoeuvre(time[k], float(t_h[k]), float(lat[k]), float(lon[k]), manoeuvre_kind(cur_twa, a),
                                 TACK_NAMES[cur], TACK_NAMES[side]))  # fmt: skip
        cur, cur_twa = side, float(a)
    return out


@dataclass(frozen=True, eq=False)
class GraphWind:
    """A forecast's wind at a graph's sea nodes, every step (the paper's ``State(t)`` for all ``t``).

    Build it once per forecast and graph with :meth:`sample` and pass it as
    ``weather`` to search many departures; :meth:`SailingRoute.verify` still
    takes the dataset.

    Attributes
    ----------
    graph : SailingGraph
    times : ndarray of datetime64, shape (k,)
        The forecast steps [UTC].
    u_ms, v_ms : ndarray, shape (k, nodes)
        Wind components [m/s, the vector it blows to] at every node (0 at land
        nodes, which have no edges and are never read).
    hold : bool
        Whether the last step's wind holds after it (``time_policy="hold"`` or a single step).
    source : str
    """

    graph: SailingGraph
    times: np.ndarray = field(repr=False)
    u_ms: np.ndarray = field(repr=False)
    v_ms: np.ndarray = field(repr=False)
    hold: bool = False
    source: str = "weather"

    @classmethod
    def sample(cls, graph: SailingGraph, weather: xr.Dataset) -> GraphWind:
        """Interpolate the weather's wind (:class:`WeatherSampler`) at the graph's sea nodes at every step."""
        sampler = sailing_sampler(weather)
        steps = weather["time"].values.astype("datetime64[ns]")
        nodes = np.flatnonzero(graph.sea)
        la, lo = graph.grid.node_latlon(nodes)
        wx = sampler.sample(np.repeat(steps, la.size), np.tile(la, steps.size), np.tile(lo, steps.size),
                            variables=["wind_u_ms", "wind_v_ms"])  # fmt: skip
        u = np.zeros((steps.size, graph.grid.n_nodes))
        v = np.zeros_like(u)
        u[:, nodes] = wx["wind_u_ms"].reshape(steps.size, la.size)
        v[:, nodes] = wx["wind_v_ms"].reshape(steps.size, la.size)
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
            k = int(np.flatnonzero(~np.isfinite(u + v))[0]) % graph.grid.n_nodes
            la_k, lo_k = graph.grid.node_latlon(k)
            raise WeatherCoverageError(f"the wind is missing (NaN) at node ({la_k:.4f}, {lo_k:.4f}) in "
                                       f"{sampler.source}; fill the wind there or keep the lattice off it")  # fmt: skip
        for a in (steps, u, v):
            a.setflags(write=False)
        return cls(graph, steps, u, v, sampler.time_policy == "hold", sampler.source)

    def from_departure(self, t0: np.datetime64) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, v, step times [h after departure]) from the step at or before departure on."""
        first = int(np.searchsorted(self.times, t0, side="right")) - 1
        if first < 0:
            raise WeatherCoverageError(f"departure {units.format_utc(t0)} is before the weather's first time "
                                       f"{units.format_utc(self.times[0])}; depart later or give earlier weather")  # fmt: skip
        slice_h = (self.times[first:] - t0) / np.timedelta64(1, "h")
        return np.ascontiguousarray(self.u_ms[first:]), np.ascontiguousarray(self.v_ms[first:]), slice_h


def _check_wind(vessel: SailingVessel, u: np.ndarray, v: np.ndarray, source: str) -> float:
    top = float(units.ms_to_kn(np.sqrt(np.max(u * u + v * v))))
    if vessel.polar.above_max_tws == "raise" and top > vessel.polar.max_tws_kn:
        vessel.polar.checked_tws(top, source=f"{source} (somewhere on the lattice)")
    return float(vessel.polar.max_tws_kn) if vessel.polar.above_max_tws == "hold" else float("inf")


def _path(res, grid: SailingGrid, target: np.ndarray, state: int, layers: int, t0: np.datetime64, t0_h: float):
    t_arr, om, pred, twa_in, spd_in, mot_in = res[:6]
    states = []
    s = state
    while s >= 0:
        states.append(s)
        s = int(pred[s])
    states = np.array(states[::-1])
    nodes = states // (3 * layers)
    lat, lon = grid.node_latlon(nodes)
    t_h = t_arr[states] - t0_h
    time = t0 + units.h_to_timedelta(t_h)
    dirs = np.array([int(np.flatnonzero(target[a] == b)[0]) for a, b in zip(nodes[:-1], nodes[1:], strict=True)])
    legs = {"twa": twa_in[states[1:]], "speed": spd_in[states[1:]], "mot": mot_in[states[1:]], "dirs": dirs}
    return nodes, lat, lon, time, t_h, legs


def search_sailing_route(
    start: tuple[float, float],
    end: tuple[float, float],
    weather: xr.Dataset | GraphWind,
    vessel: SailingVessel,
    *,
    departure: Any,
    directions: int | None = None,
    grid: SailingGrid | SailingGraph | None = None,
    cell_nm: float = 1.0,
    margin_nm: float = 5.0,
    objective: SailObjective = "time",
    manoeuvre_penalty_h: float | None = None,
    use_land_mask: bool | None = None,
) -> SailingRoute:
    """Search a sailing route through the wind.

    Parameters
    ----------
    start, end : (float, float)
        (lat, lon) [deg]; each is sailed from/to the nearest lattice node.
    weather : xarray.Dataset or GraphWind
        Canonical weather with ``wind_u_ms``/``wind_v_ms`` [m/s]; waves are not
        needed.  ``time_policy="hold"`` in its attrs holds the last step's wind
        beyond its end; a single time step is a steady wind.  Or that wind
        already sampled on the graph (:meth:`GraphWind.sample`), whose graph
        is then the search's.
    vessel : SailingVessel
    departure : datetime64 or str
        Departure [UTC].
    directions : {8, 16, 32}, optional
        Życkowski's heading sets; default 16, or the graph's.
    grid : SailingGrid or SailingGraph, optional
        The lattice (default :meth:`SailingGrid.around` with ``cell_nm`` and
        ``margin_nm`` [nm]) or a graph built once with :meth:`SailingGraph.build`.
    use_land_mask : bool, optional
        Remove the edges that touch land (GLOBE 30" coastline, checked every
        0.25 nm); default: yes, unless the weather's ``attrs["geography"]`` is
        ``"synthetic"``.  Ignored when ``grid`` is a graph.
    objective : {"time", "manoeuvres", "weighted"}
    manoeuvre_penalty_h : float
        For ``"weighted"``: hours one manoeuvre is worth [h], ≥ 0.

    Raises
    ------
    NoSafePassage
        No sailable route reaches the end (the message says why it may be).
    WeatherCoverageError
        Departure before the weather, a node outside it, or the passage needs
        wind past the weather's last time.
    ConfigError
        Bad arguments, wind above the polar's range.
    """
    t_start = _time.perf_counter()
    vessel = check_vessel(vessel)
    if objective not in ("time", "manoeuvres", "weighted"):
        raise ConfigError(f"objective={objective!r}; use 'time', 'manoeuvres' or 'weighted'")
    pen = 0.0
    if objective == "weighted":
        if manoeuvre_penalty_h is None or not np.isfinite(manoeuvre_penalty_h) or manoeuvre_penalty_h < 0:
            raise ConfigError(f"objective='weighted' needs manoeuvre_penalty_h >= 0 [h per manoeuvre], "
                              f"got {manoeuvre_penalty_h!r}")  # fmt: skip
        pen = float(manoeuvre_penalty_h)
    t0 = as_utc_time(departure, "departure")
    graph = _graph(start, end, weather, directions, grid, cell_nm, margin_nm, use_land_mask)
    grid, directions = graph.grid, graph.directions
    target, length, course = graph.target, graph.length_nm, graph.course_deg
    gw = weather if isinstance(weather, GraphWind) else GraphWind.sample(graph, weather)
    if gw.graph is not graph:
        raise ConfigError("the GraphWind was sampled for another graph; pass grid=wind.graph or the dataset")
    u, v, slice_h = gw.from_departure(t0)
    cap = _check_wind(vessel, u, v, gw.source)
    hold = gw.hold
    src, dst = graph.nearest_sea(*start), graph.nearest_sea(*end)
    if src == dst:
        raise ConfigError(f"start {start} and end {end} fall on the same lattice node; use a finer grid")
    tables = (*vessel.polar.kernel_tables, cap)
    lo, motor = vessel.motor_kernel
    build_s = _time.perf_counter() - t_start

    h_node = _bound_h(graph, dst, max(vessel.polar.max_speed_kn, motor))

    def run(mode: int, layers: int = 1, stop_h: float = np.inf):
        return sk.sail_search(target, length, course, np.ascontiguousarray(u), np.ascontiguousarray(v), slice_h,
                              hold, tables, lo, motor, src, dst, 0.0, mode, layers, stop_h, h_node)  # fmt: skip

    res = run(sk.MODE_FEWEST if objective == "manoeuvres" else sk.MODE_TIME)
    found, stats = int(res[6]), res[7]
    if stats[2] or found < 0:  # a label past the forecast's end was not expanded: it might have led somewhere better
        _no_route(stats[2], weather, vessel)
    layers, front, state = 1, (), found
    if objective == "weighted":
        res, layers, front, state = _weighted(run, res, found, dst, pen)
        stats = stats + res[7]
        if res[7][2]:
            _no_route(res[7][2], weather, vessel)
    nodes, lat, lon, time, t_h, legs = _path(res, grid, target, state, layers, t0, 0.0)
    mot = legs["mot"]
    man = manoeuvres_along(legs["twa"], mot, time, t_h, lat, lon)
    dirs = legs["dirs"]
    run_s = _time.perf_counter() - t_start
    st = {"vertices": graph.n_vertices, "edges": graph.n_edges, "directions": int(directions),
          "build_s": build_s, "search_s": run_s - build_s, "runtime_s": run_s, "pops": int(stats[0]),
          "relaxations": int(stats[1]), "start_node": (float(lat[0]), float(lon[0])),
          "end_node": (float(lat[-1]), float(lon[-1]))}  # fmt: skip
    return SailingRoute(
        lat_deg=lat, lon_deg=lon, time=time, t_h=t_h,
        course_deg=course[nodes[:-1], dirs], twa_deg=legs["twa"], speed_kn=legs["speed"],
        length_nm=length[nodes[:-1], dirs], motoring=mot, manoeuvres=tuple(man),
        heading_changes=int(np.count_nonzero(np.diff(dirs))), objective=objective, status="optimal",
        front=front, stats=st,
    )  # fmt: skip


def _weighted(run, res, found: int, dst: int, pen: float):
    """The node x tack x ω search for ω up to the fastest route's count; the front and the weighted optimum."""
    w = int(res[1][found])
    layers = w + 1
    res = run(sk.MODE_LAYERED, layers, float(res[0][found]) + pen * w)
    best = []
    for om_ in range(layers):
        ts = [(res[0][(dst * 3 + tk) * layers + om_], (dst * 3 + tk) * layers + om_) for tk in range(3)]
        t_best, s_best = min(ts)
        if np.isfinite(t_best):
            best.append((om_, float(t_best), int(s_best)))
    front = tuple((o, t) for o, t, _ in best)
    state = min(best, key=lambda x: (x[1] + pen * x[0], x[0]))[2]
    return res, layers, front, state


def _bound_h(graph: SailingGraph, dst: int, v_max_kn: float) -> np.ndarray:
    """A* bound [h]: great-circle distance to the end over the fastest speed, a hair below (rounding)."""
    return graph.distance_to_nm(dst) / v_max_kn * (1.0 - 1e-9)


def _graph(start, end, weather, directions, grid, cell_nm, margin_nm, use_land_mask) -> SailingGraph:
    if isinstance(weather, GraphWind):
        grid = weather.graph if grid is None else grid
        if grid is not weather.graph:
            raise ConfigError("the GraphWind was sampled for another graph; pass grid=wind.graph or the dataset")
    if isinstance(grid, SailingGraph):
        if directions is not None and int(directions) != grid.directions:
            raise ConfigError(f"directions={directions} but the graph was built with {grid.directions}; "
                              "build a graph for those directions or leave directions out")  # fmt: skip
        return grid
    if grid is not None and not isinstance(grid, SailingGrid):
        raise ConfigError(f"grid must be a SailingGrid or SailingGraph, got {type(grid).__name__}")
    grid = grid or SailingGrid.around(start, end, cell_nm, margin_nm)
    use = land.coastline_applies(weather, use_land_mask)
    return SailingGraph.build(grid, 16 if directions is None else int(directions), use_land_mask=use)


def _no_route(cut: float, weather: xr.Dataset, vessel: SailingVessel) -> None:
    if cut:
        last = weather.times[-1] if isinstance(weather, GraphWind) else weather["time"].values[-1]
        raise WeatherCoverageError(f"the search needed the wind after the weather's last time "
                                   f"{units.format_utc(last)} (a route still under way then may be the best); "
                                   "give weather that lasts longer, "
                                   "or time_policy='hold' in its attrs to hold the last wind")  # fmt: skip
    raise NoSafePassage(f"no sailable route reaches the end with {vessel.name}'s polar (no-go below "
                        f"{vessel.polar.no_go_deg:g} deg, calm wind sails nowhere): give motoring_below_kn and "
                        "motor_speed_kn, more directions, or a larger margin_nm")  # fmt: skip
