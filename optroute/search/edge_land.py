"""The coastline between a search's states: which grid cells may hold land, and the packed mask to walk legs on.

:class:`~optroute.search.grid.RouteGrid`'s navigable mask tests the coastline at its nodes, the cells'
centres; an island or a peninsula narrower than a cell can lie between two open-water nodes, under a leg.
:class:`EdgeLand` closes that gap for the grid search.  A cell is *coastal* when any GLOBE land cell lies in
its bounding box of latitude and longitude: its corners', widened by an eighth of a cell (a cell's side, a
great circle, bulges from the straight line between its corners by at most L² tan(latitude) / 8R, 0.5 nm for
a 120 nm cell at 45°, against the pad's 15 nm).  A leg that crosses a coastal cell is walked on the coastline
every :data:`WALK_STEP_NM` (:func:`on_land`, the look-up of :meth:`optroute.geo.land.GlobeLandMask.is_land`)
before it may be costed, and a leg that touches land does not exist.  Legs through open-water cells only cost
nothing more.  With a coastline source that has no packed cells (GSHHG) there is no :class:`EdgeLand`, and
routes keep the node test (:func:`optroute.search.routing.search_route` then names the legs that cross land).
The 3-D DP's lattice legs are walked the same way, on the rows their latitudes span (:func:`legs_on_land`,
:class:`CoastWalk`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from optroute import geodesy as geo
from optroute import units
from optroute._numba import jit
from optroute.geo import land
from optroute.search.grid import RouteGrid, unit_xyz

__all__ = [
    "WALK_STEP_NM",
    "CoastWalk",
    "EdgeLand",
    "edge_on_land",
    "edges_on_land",
    "legs_on_land",
    "no_land_arrays",
    "on_land",
]

_SUB = 1  # samples of a cell's outline per cell side: its corners (an edge's bulge is far below the pad)
_R_NM = geo.EARTH_RADIUS_NM
WALK_STEP_NM = 0.1
"""Largest spacing of the points a leg is walked at [nm]: a fifth of a GLOBE cell (0.5 nm), so that a leg
cutting a land cell's corner over more than 0.1 nm is found."""
STRETCH_NM = 5.0
"""Length of the stretches a leg is cut into [nm]: each is skipped whole where the 8 × 8-cell blocks about it
hold no land, else walked in latitude and longitude linearly between its ends (on a great circle of 5 nm
the error is below 0.001 nm × tan(latitude))."""


@dataclass(frozen=True, eq=False)
class CoastWalk:
    """The GLOBE coastline between two latitudes, packed, to walk legs on (:func:`on_land`).

    Attributes
    ----------
    packed : PackedLand
        The GLOBE mask's rows (:func:`optroute.geo.land.packed_land`).
    blocks : ndarray of bool, shape (row blocks, bytes)
        Its 8 × 8-cell blocks (8 rows, one byte) that hold land.
    step_nm : float
        Largest spacing of the points walked along a leg [nm].
    """

    packed: land.PackedLand
    blocks: np.ndarray
    step_nm: float = WALK_STEP_NM

    @classmethod
    def between(
        cls, lat_min_deg: float, lat_max_deg: float, *, mask: land.LandMask | str | None = None
    ) -> CoastWalk | None:
        """The coastline from ``lat_min_deg`` to ``lat_max_deg`` [deg]; None when the mask has no packed cells."""
        packed = land.packed_land(lat_min_deg, lat_max_deg, mask=mask)
        return None if packed is None else cls(packed, _blocks(packed))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(packed rows, their 8 × 8-cell blocks that hold land, the look-up's parameters)``: the arguments
        ``bits, blocks, par`` of :func:`on_land`."""
        p = self.packed
        par = np.array([self.step_nm, p.row0, p.lat0, p.dlat, p.lon0, p.dlon, p.nlat, p.nlon, *p.lat_range,
                        *p.lon_range, STRETCH_NM], dtype=float)  # fmt: skip
        return np.ascontiguousarray(p.bits), self.blocks, par


@dataclass(frozen=True, eq=False)
class EdgeLand:
    """The coastline a grid search walks its legs on.

    Attributes
    ----------
    coastal : ndarray of bool, shape (ny, nx)
        Cells whose area may hold land.
    walk : CoastWalk
        The GLOBE mask's rows over the grid, packed.
    """

    coastal: np.ndarray
    walk: CoastWalk

    @classmethod
    def build(cls, grid: RouteGrid, *, mask: land.LandMask | str | None = None) -> EdgeLand | None:
        """The coastline over ``grid``; None when the mask has no packed cells."""
        ny, nx = grid.shape
        fi = np.arange(_SUB * ny + 1) / _SUB - 0.5
        fj = np.arange(_SUB * nx + 1) / _SUB - 0.5
        x, y = grid.node_xy_nm(fi[:, None], fj[None, :])
        lat, lon = grid.xy_to_latlon(x, y)
        pad_deg = grid.cell_nm / 8.0 / 60.0
        walk = CoastWalk.between(float(lat.min()) - 2 * pad_deg - 0.1, float(lat.max()) + 2 * pad_deg + 0.1, mask=mask)
        if walk is None:
            return None
        return cls(_coastal_cells(lat, lon, ny, nx, pad_deg, walk.packed, walk.blocks), walk)

    def kernel_arrays(self, nav_pad_shape: tuple[int, int], radius: int) -> tuple:
        """``(coastal cells padded as the search's navigable mask, raveled; the packed rows; their 8 × 8-cell
        blocks that hold land; the look-up's parameters)`` for :func:`on_land`."""
        pad = np.zeros(nav_pad_shape, dtype=bool)
        ny, nx = self.coastal.shape
        pad[radius : radius + ny, radius : radius + nx] = self.coastal
        return (pad.ravel(), *self.walk.arrays())


def legs_on_land(
    lat0_deg: np.ndarray, lon0_deg: np.ndarray, lat1_deg: np.ndarray, lon1_deg: np.ndarray,
    *, mask: land.LandMask | str | None = None,
) -> np.ndarray:  # fmt: skip
    """Whether each great-circle leg touches land, for legs anywhere (the 3-D DP's lattice legs).

    With the GLOBE mask each leg is walked as a grid search's edge is (:func:`on_land`, every
    :data:`WALK_STEP_NM`), on the mask's rows over the legs' latitudes widened by the legs' poleward bulge;
    with a mask that has no packed cells (GSHHG) its points are looked up every
    ``land.DEFAULT_LEG_RESOLUTION_NM`` (:func:`optroute.geo.land.legs_cross_land`).

    Parameters
    ----------
    lat0_deg, lon0_deg, lat1_deg, lon1_deg : array_like
        The legs' ends [deg, north and east positive], broadcast together.
    mask : LandMask or str, optional
        The coastline (:func:`optroute.geo.land.land_mask`).

    Returns
    -------
    ndarray of bool
        True for legs that touch land, in the broadcast shape.
    """
    la0, lo0, la1, lo1 = (np.asarray(v, dtype=float) for v in np.broadcast_arrays(lat0_deg, lon0_deg, lat1_deg,
                                                                                   lon1_deg))  # fmt: skip
    if la0.size == 0:
        return np.zeros(la0.shape, dtype=bool)
    a, b = unit_xyz(la0, lo0).reshape(-1, 3), unit_xyz(la1, lo1).reshape(-1, 3)
    chord = np.linalg.norm(a - b, axis=1)
    length_nm = float(np.max(2.0 * _R_NM * np.arcsin(np.minimum(chord / 2.0, 1.0))))
    top = float(max(np.max(np.abs(la0)), np.max(np.abs(la1))))
    # a great circle of length L rises above its ends' latitude phi by about L^2 tan(phi) / 8R (twice that here)
    bulge_deg = length_nm**2 * np.tan(np.radians(min(top, 89.0))) / (4.0 * _R_NM) / 60.0 + 0.1
    lo = max(float(min(la0.min(), la1.min())) - bulge_deg, -90.0)
    hi = min(float(max(la0.max(), la1.max())) + bulge_deg, 90.0)
    walk = CoastWalk.between(lo, hi, mask=mask)
    if walk is None:
        return land.legs_cross_land(la0, lo0, la1, lo1, mask=mask)
    return _legs_on_land(a, b, *walk.arrays()).reshape(la0.shape)


def no_land_arrays(nav_pad_size: int) -> tuple:
    """:meth:`EdgeLand.kernel_arrays` for a search without the coastline walk (step 0: off)."""
    return np.zeros(nav_pad_size, dtype=bool), np.zeros((1, 1), dtype=np.uint8), np.zeros((1, 1), bool), np.zeros(13)


@jit(inline="always")
def _latlon(x, y, z):  # pragma: no cover - compiled
    return np.degrees(np.arctan2(z, np.sqrt(x * x + y * y))), np.degrees(np.arctan2(y, x))


@jit
def _blocks_hold_land(blocks, n_rows, par, lat_a, lat_b, lon_a, lon_b):  # pragma: no cover - compiled
    """Whether a 8 × 8-cell block touching the box (lat_a..lat_b, lon_a..lon_b) [deg] holds land; True where the
    box leaves the longitude range or the ``n_rows`` loaded rows (the walk then looks, and counts those as land)."""
    if lon_a < par[10] or lon_b >= par[11]:
        return True
    row0, lat0, dlat, lon0, dlon, nlat, nlon = int(par[1]), par[2], par[3], par[4], par[5], int(par[6]), int(par[7])
    i_a = min(max(int((max(lat_a, lat_b) - lat0) / dlat), 0), nlat - 1) - row0
    i_b = min(max(int((min(lat_a, lat_b) - lat0) / dlat), 0), nlat - 1) - row0
    if i_a < 0 or i_b >= n_rows:
        return True
    j_a = min(max(int((lon_a - lon0) / dlon), 0), nlon - 1) >> 3
    j_b = min(max(int((lon_b - lon0) / dlon), 0), nlon - 1) >> 3
    for r in range(i_a >> 3, (i_b >> 3) + 1):
        for c in range(j_a, j_b + 1):
            if blocks[r, c]:
                return True
    return False


@jit
def _cell_is_land(bits, par, lat, lon):  # pragma: no cover - compiled
    """The packed mask's answer at (lat, lon) [deg], as ``GlobeLandMask.is_land``; True outside the loaded rows."""
    lat = min(max(lat, par[8]), par[9])
    lon = min(max(lon, par[10]), par[11])
    i = min(max(int((lat - par[2]) / par[3]), 0), int(par[6]) - 1) - int(par[1])
    j = min(max(int((lon - par[4]) / par[5]), 0), int(par[7]) - 1)
    if i < 0 or i >= bits.shape[0]:
        return True
    return ((bits[i, j >> 3] >> (7 - (j & 7))) & 1) == 1


@jit
def on_land(a, b, bits, blocks, par):  # pragma: no cover - compiled
    """Whether the great circle from unit vector ``a`` to ``b`` touches land.

    The leg is cut into stretches of at most :data:`STRETCH_NM` (their ends on the great circle); a stretch
    whose box of latitude and longitude touches no 8 × 8-cell block with land is clear, the others are
    walked every ``par[0]`` nm at most, linearly in latitude and longitude between their ends, on the packed
    mask (``bits``, ``blocks``, ``par``: :meth:`EdgeLand.kernel_arrays`).  The leg's length is taken on the
    sphere from the two vectors alone (so every caller walks the same points), less 1 % for the ellipsoid.
    """
    ex, ey, ez = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    d_nm = 2.0 * _R_NM * np.arcsin(min(np.sqrt(ex * ex + ey * ey + ez * ez) / 2.0, 1.0)) / 0.99
    n_s = max(int(np.ceil(d_nm / par[12])), 1)
    n_pts = max(int(np.ceil(d_nm / n_s / par[0])) + 1, 2)  # both ends, even of a leg of no length
    lat0, lon0 = _latlon(a[0], a[1], a[2])
    for s in range(1, n_s + 1):
        f = s / n_s
        lat1, lon1 = _latlon(a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f)
        dlon = lon1 - lon0
        if dlon > 180.0:
            dlon -= 360.0
        elif dlon < -180.0:
            dlon += 360.0
        if _blocks_hold_land(blocks, bits.shape[0], par, lat0, lat1, min(lon0, lon0 + dlon), max(lon0, lon0 + dlon)):
            for k in range(n_pts):
                t = k / (n_pts - 1.0)
                lon = lon0 + dlon * t
                lon = lon - 360.0 if lon >= 180.0 else (lon + 360.0 if lon < -180.0 else lon)
                if _cell_is_land(bits, par, lat0 + (lat1 - lat0) * t, lon):
                    return True
        lat0, lon0 = lat1, lon1
    return False


@jit
def _legs_on_land(a, b, bits, blocks, par):  # pragma: no cover - compiled
    """:func:`on_land` for each leg ``a[i] → b[i]`` (unit vectors)."""
    out = np.zeros(a.shape[0], dtype=np.bool_)
    for i in range(a.shape[0]):
        out[i] = on_land(a[i], b[i], bits, blocks, par)
    return out


@jit
def edges_on_land(
    u, v, o, xyz, base_pad, cell_off, cell_n, coastal_pad, bits, blocks, par
):  # pragma: no cover - compiled
    """For each edge ``u → v`` along offset ``o``: whether it crosses a coastal cell and touches land there
    (:func:`on_land`); all False when the walk is off (``par[0] <= 0``)."""
    out = np.zeros(u.size, dtype=np.bool_)
    if par[0] <= 0.0:
        return out
    for e in range(u.size):
        out[e] = edge_on_land(xyz[u[e]], xyz[v[e]], base_pad[u[e]], o[e], cell_off, cell_n, coastal_pad, bits, blocks,
                              par)  # fmt: skip
    return out


@jit
def edge_on_land(a, b, base, q, cell_off, cell_n, coastal_pad, bits, blocks, par):  # pragma: no cover - compiled
    """Whether the edge from unit vector ``a`` (the node at padded index ``base``) to ``b`` along offset ``q``
    crosses a coastal cell and touches land there (:func:`on_land`); the walk must be on (``par[0] > 0``)."""
    for c in range(cell_n[q]):
        if coastal_pad[base + cell_off[q, c]]:
            return on_land(a, b, bits, blocks, par)
    return False


def _blocks(packed) -> np.ndarray:
    """The packed rows' 8 × 8-cell blocks (8 rows, one byte) that hold land, (row blocks, bytes)."""
    bits = packed.bits
    rows = -(-bits.shape[0] // 8) * 8
    nz = np.zeros((rows, bits.shape[1]), dtype=bool)
    nz[: bits.shape[0]] = bits != 0
    return nz.reshape(rows // 8, 8, bits.shape[1]).any(axis=1)


def _coastal_cells(
    lat: np.ndarray, lon: np.ndarray, ny: int, nx: int, pad_deg: float, packed, blocks: np.ndarray
) -> np.ndarray:
    """Cells (ny, nx) whose outline's bounding box, widened by ``pad_deg`` [deg of latitude], holds land (``blocks``:
    :func:`_blocks` of ``packed``)."""
    s = _SUB
    cells = lambda a: np.lib.stride_tricks.sliding_window_view(a, (s + 1, s + 1))[::s, ::s]  # noqa: E731
    la = cells(lat)
    lat_lo, lat_hi = la.min(axis=(2, 3)) - pad_deg, la.max(axis=(2, 3)) + pad_deg
    # longitudes relative to each cell's first corner: a cell across the antimeridian stays one interval
    lo_all = cells(lon)
    ref = lo_all[:, :, :1, :1]
    rel = units.wrap_180(lo_all - ref)
    coslat = np.maximum(np.cos(np.radians(np.maximum(np.abs(lat_lo), np.abs(lat_hi)))), 1e-3)
    lon_pad = pad_deg / coslat
    lon_lo = ref[:, :, 0, 0] + rel.min(axis=(2, 3)) - lon_pad
    lon_hi = ref[:, :, 0, 0] + rel.max(axis=(2, 3)) + lon_pad
    out = np.zeros((ny, nx), dtype=bool)
    cum = _block_sums(blocks)
    # a box over the antimeridian is looked up in two parts
    for shift in (0.0, 360.0, -360.0):
        a, b = np.clip(lon_lo + shift, -180.0, 180.0 - 1e-9), np.clip(lon_hi + shift, -180.0, 180.0 - 1e-9)
        out |= (b > a) & _any_land(packed, cum, lat_lo, lat_hi, a, b)
    return out


def _block_sums(block: np.ndarray) -> np.ndarray:
    """Summed-area table of the blocks (:func:`_blocks`) that hold land."""
    cum = np.zeros((block.shape[0] + 1, block.shape[1] + 1), dtype=np.int64)
    cum[1:, 1:] = block.cumsum(axis=0).cumsum(axis=1)
    return cum


def _any_land(packed, cum, lat_lo, lat_hi, lon_lo, lon_hi) -> np.ndarray:
    """Whether any land cell touches each box [deg] (vectorised), from the block sums ``cum``."""
    bits = packed.bits
    i_a = np.clip(((lat_hi - packed.lat0) / packed.dlat).astype(np.int64) - packed.row0, 0, bits.shape[0] - 1) // 8
    i_b = np.clip(((lat_lo - packed.lat0) / packed.dlat).astype(np.int64) - packed.row0, 0, bits.shape[0] - 1) // 8
    j_a = np.clip(((lon_lo - packed.lon0) / packed.dlon).astype(np.int64), 0, packed.nlon - 1) >> 3
    j_b = np.clip(((lon_hi - packed.lon0) / packed.dlon).astype(np.int64), 0, packed.nlon - 1) >> 3
    r0, r1 = np.minimum(i_a, i_b), np.maximum(i_a, i_b) + 1
    c0, c1 = j_a, j_b + 1
    return (cum[r1, c1] - cum[r0, c1] - cum[r1, c0] + cum[r0, c0]) > 0
