"""Route search: the gnomonic grid, neighbourhoods, time-dependent Dijkstra/A*, and the 3-D DP.

The search machinery is generic over the cost of a leg: the physics layer
passes vectorised callbacks (see :mod:`optroute.search.costs` for the grid
search and :mod:`optroute.search.dp` for the DP); times are hours from
departure and positions (lat, lon) in degrees.

* :class:`RouteGrid` — gnomonic lattice centred on the voyage (Boeing Fig. 18).
* :func:`compass`, :func:`angular_resolution` — Życkowski's 8/16/32
  directions and Boeing's minimum-angular-resolution set (Fig. 13).
* :func:`shortest_path` (``method="astar"`` or ``"dijkstra"``) — time-dependent
  label-setting search (Figs. 14–16, 21–22) → :class:`SearchResult`.
* :func:`solve_dp` — Shao et al.'s stage × lateral × time DP → :class:`DPResult`
  with the fuel-versus-ETA curve.
"""

from optroute.search.costs import LegCost, LegEvaluator, unpack_cost
from optroute.search.dijkstra import SearchResult, edge_mask, grid_edges, shortest_path
from optroute.search.dp import DPPath, DPResult, solve_dp
from optroute.search.grid import RouteGrid, segment_cells
from optroute.search.neighbourhood import Neighbourhood, angular_resolution, compass, max_angular_gap_deg

__all__ = [
    "DPPath",
    "DPResult",
    "LegCost",
    "LegEvaluator",
    "Neighbourhood",
    "RouteGrid",
    "SearchResult",
    "angular_resolution",
    "compass",
    "edge_mask",
    "grid_edges",
    "max_angular_gap_deg",
    "segment_cells",
    "shortest_path",
    "solve_dp",
    "unpack_cost",
]
