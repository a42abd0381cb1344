"""Leg-cost callbacks of the grid search and their evaluation over many edges at once.

The search knows nothing of ships or weather: the physics layer hands it one
of two callbacks, both vectorised over many legs (1-D arrays of one length,
hours counted from departure).

Edge form (one call per batch of edges)::

    edge_cost(lat0_deg, lon0_deg, lat1_deg, lon1_deg, t0_h)
        -> (duration_h, fuel_t, feasible[, extra])

the cost of sailing the geodesic leg from (lat0, lon0) to (lat1, lon1)
leaving at ``t0_h``.

Segment form (Boeing EP 2145155 Figs. 14, 21–22: the leg crosses a sequence of
grid cells and each cell is costed with the weather of the time the ship is
in it)::

    segment_cost(lat_deg, lon_deg, course_deg, length_nm, t_h)
        -> (duration_h, fuel_t, feasible[, extra])

the cost of one straight piece: the part of a leg inside one cell, given by
its midpoint [deg], its course there [deg true, to] and its length [nm] on the
WGS84 ellipsoid, and the time the ship enters it [h].  The search walks every leg
cell by cell (supercover walk of :func:`~optroute.search.grid.segment_cells`),
calls ``segment_cost`` once per piece *position* for all legs of a batch, and
carries the time forward: piece k+1 is entered at the time piece k is left.
A leg is feasible when every piece is; its duration and fuel are the sums.

A segment callback may carry a compiled equivalent of that walk as its
attribute ``leg_batch(lat_deg, lon_deg, course_deg, length_nm, n_pieces, t0_h)
-> (duration_h, fuel_t, feasible)`` over (n, kmax) piece arrays: the search
then costs a whole batch of legs in one call (the physics callbacks of
:mod:`optroute.search.passage_physics` do, see :mod:`optroute.search.passage_kernels`),
and calls the plain callback only to report the legs of the route found.

Moving no-go areas (storms, seas where no speed survives the danger bands)
are expressed by ``feasible = False``; static ones (land, missing weather)
by the grid's navigable mask, which the search applies to every cell a leg
crosses.

In both forms ``duration_h`` [h] must be finite and positive and ``fuel_t``
[t] finite and non-negative wherever ``feasible`` is True; elsewhere they are
ignored (NaN is fine).  ``extra`` is an optional mapping of per-leg (or
per-piece) arrays, for instance the speed chosen or the side of each danger
band; the search does not read it during the search, and re-evaluates the
legs of the route found once, in order, to report it — so callbacks must be
deterministic.  A :class:`LegCost` named tuple may be returned instead of a
plain tuple.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np

from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.search.edge_geometry import edge_piece_arrays
from optroute.search.grid import RouteGrid, segment_cells
from optroute.search.neighbourhood import Neighbourhood


class LegCost(NamedTuple):
    """What a cost callback returns (a plain tuple in this order also works).

    Attributes
    ----------
    duration_h : ndarray
        Time to sail each leg or piece [h].
    fuel_t : ndarray
        Fuel burnt [t].
    feasible : ndarray of bool
        Whether the leg can be sailed at all (safe speed exists, no no-go area).
    extra : mapping of str to ndarray, optional
        Per-leg diagnostics, reported for the legs of the route found.
    """

    duration_h: np.ndarray
    fuel_t: np.ndarray
    feasible: np.ndarray
    extra: Mapping[str, np.ndarray] | None = None


EdgeCostFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], Any]
SegmentCostFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], Any]


def unpack_cost(out: Any, n: int, who: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Check and normalise what a cost callback returned for ``n`` legs.

    Raises
    ------
    ConfigError
        Wrong arity or shape, a non-bool ``feasible``, or a non-finite or
        negative duration or fuel on a feasible leg.
    """
    if not isinstance(out, tuple | list) or len(out) not in (3, 4):
        raise ConfigError(
            f"{who} must return (duration_h, fuel_t, feasible) or (duration_h, fuel_t, feasible, extra); "
            f"got {type(out).__name__}"
        )
    dur, fuel, feas = np.asarray(out[0], dtype=float), np.asarray(out[1], dtype=float), np.asarray(out[2])
    if dur.shape != (n,) or fuel.shape != (n,) or feas.shape != (n,):
        try:
            dur, fuel, feas = (np.broadcast_to(a, (n,)) for a in (dur, fuel, feas))
        except ValueError as exc:
            raise ConfigError(f"{who} returned arrays that do not match the {n} legs it was given: {exc}") from exc
    if feas.dtype != bool:
        raise ConfigError(f"{who} returned feasible of dtype {feas.dtype}; return a bool array")
    with np.errstate(invalid="ignore"):
        good = (dur > 0.0) & (dur < np.inf) & (fuel >= 0.0) & (fuel < np.inf)
    bad = feas & ~good
    if bad.any():
        k = int(np.argmax(bad))
        raise ConfigError(
            f"{who} returned duration_h={dur[k]!r}, fuel_t={fuel[k]!r} on a feasible leg; the duration must be "
            "finite and > 0 and the fuel finite and >= 0"
        )
    extra: dict[str, np.ndarray] = {}
    if len(out) == 4 and out[3] is not None:
        if not isinstance(out[3], Mapping):
            raise ConfigError(f"{who}: the 4th item (extra) must be a mapping of name -> array, got {type(out[3])}")
        extra = {str(k): np.asarray(v) for k, v in out[3].items()}
    return dur, fuel, feas, extra


class LegEvaluator:
    """Evaluates one of the two callback forms for batches of grid edges.

    Parameters
    ----------
    grid : RouteGrid
    neighbourhood : Neighbourhood
    edge_cost, segment_cost : callable
        Exactly one of the two forms described in the module docstring.
    """

    def __init__(
        self,
        grid: RouteGrid,
        neighbourhood: Neighbourhood,
        edge_cost: EdgeCostFn | None = None,
        segment_cost: SegmentCostFn | None = None,
    ) -> None:
        if (edge_cost is None) == (segment_cost is None):
            raise ConfigError("pass exactly one of edge_cost= (whole legs) or segment_cost= (cell by cell)")
        for name, fn in (("edge_cost", edge_cost), ("segment_cost", segment_cost)):
            if fn is not None and not callable(fn):
                raise ConfigError(f"{name} must be callable, got {type(fn).__name__}")
        self.grid = grid
        self.nb = neighbourhood
        self.edge_cost = edge_cost
        self.segment_cost = segment_cost
        self.lat = np.ascontiguousarray(grid.lat_deg.ravel())
        self.lon = np.ascontiguousarray(grid.lon_deg.ravel())
        self.tangent = grid.tangent_points().reshape(-1, 3)
        self.xyz = self.tangent / np.linalg.norm(self.tangent, axis=-1, keepdims=True)
        self.calls = 0
        if segment_cost is not None:
            self._build_pieces()

    def _build_pieces(self) -> None:
        walks = [segment_cells(int(di), int(dj)) for di, dj in self.nb.offsets]
        pieces = [(f0[f1 > f0], f1[f1 > f0], c[f1 > f0]) for c, f0, f1 in walks]
        kmax = max(len(p[0]) for p in pieces)
        m = len(pieces)
        self.piece_f0 = np.zeros((m, kmax))
        self.piece_f1 = np.zeros((m, kmax))
        self.piece_n = np.array([len(p[0]) for p in pieces])
        for o, (f0, f1, _) in enumerate(pieces):
            self.piece_f0[o, : len(f0)] = f0
            self.piece_f1[o, : len(f1)] = f1

    def distance_nm(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """WGS84 geodesic length of edges between flat nodes [nm] (:func:`optroute.geodesy.distance_nm`)."""
        return geo.distance_nm(self.lat[u], self.lon[u], self.lat[v], self.lon[v])

    def evaluate(
        self, u: np.ndarray, v: np.ndarray, o: np.ndarray, t0_h: np.ndarray, detail: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Cost of edges ``u -> v`` (offset index ``o``) left at ``t0_h``.

        Returns
        -------
        duration_h, fuel_t, feasible : ndarray
            One value per edge.
        detail : dict
            With ``detail=True``: the callback's extras per edge (edge form), or
            per piece with ``piece_leg`` (index of the edge), ``piece_lat_deg``,
            ``piece_lon_deg``, ``piece_course_deg``, ``piece_length_nm``,
            ``piece_t_h``, ``piece_duration_h``, ``piece_fuel_t`` (segment form).
        """
        n = len(u)
        self.calls += 1
        if self.edge_cost is not None:
            out = self.edge_cost(self.lat[u], self.lon[u], self.lat[v], self.lon[v], t0_h)
            dur, fuel, feas, extra = unpack_cost(out, n, "edge_cost")
            return dur, fuel, feas, (extra if detail else {})
        return self._evaluate_pieces(u, v, o, t0_h, detail)

    def _evaluate_pieces(
        self, u: np.ndarray, v: np.ndarray, o: np.ndarray, t0_h: np.ndarray, detail: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        n = len(u)
        f0, f1, npc = self.piece_f0[o], self.piece_f1[o], self.piece_n[o]
        t = np.array(t0_h, dtype=float, copy=True)
        fuel = np.zeros(n)
        feas = np.ones(n, dtype=bool)
        rec: list[dict[str, np.ndarray]] = []
        kmax = int(npc.max()) if n else 0
        # the geometry of every piece at once, (n, kmax), from the one source of it
        lat_all, lon_all, course_all, length_all = edge_piece_arrays(self.tangent, u, v, f0, f1, npc)
        batch = getattr(self.segment_cost, "leg_batch", None)
        if batch is not None and not detail:  # a compiled kernel walks every leg of the batch in one call
            pieces = npc.astype(np.int64)
            dur, fuel, feas = batch(lat_all, lon_all, course_all, length_all, pieces, t)
            return dur, fuel, feas, {}
        for k in range(kmax):
            act = np.nonzero(feas & (npc > k))[0]
            if act.size == 0:
                break
            lat, lon, course, length = lat_all[act, k], lon_all[act, k], course_all[act, k], length_all[act, k]
            out = self.segment_cost(lat, lon, course, length, t[act])
            self.calls += 1
            d, fu, ok, extra = unpack_cost(out, act.size, "segment_cost")
            if detail:
                r = {
                    "piece_leg": act,
                    "piece_index": np.full(act.size, k),
                    "piece_lat_deg": lat,
                    "piece_lon_deg": lon,
                    "piece_course_deg": course,
                    "piece_length_nm": length,
                    "piece_t_h": t[act].copy(),
                    "piece_duration_h": np.where(ok, d, np.nan),
                    "piece_fuel_t": np.where(ok, fu, np.nan),
                    "piece_feasible": ok,
                }
                r.update({f"piece_{key}": val for key, val in extra.items()})
                rec.append(r)
            feas[act] = ok
            good = act[ok]
            t[good] += d[ok]
            fuel[good] += fu[ok]
        dur = t - t0_h
        out_detail: dict[str, np.ndarray] = {}
        if detail and rec:
            keys = [k for k in rec[0] if all(k in r for r in rec)]
            cat = {k: np.concatenate([r[k] for r in rec]) for k in keys}
            order = np.lexsort((cat["piece_index"], cat["piece_leg"]))
            out_detail = {k: val[order] for k, val in cat.items()}
        return dur, fuel, feas, out_detail
