"""One ship model inside the corridor NLP: the performance model tabulated on the corridor's weather grid.

Design
------
The plan is scored by the referee (:mod:`optroute.plan.evaluate`): the ship's
:class:`~optroute.physics.performance.PerformanceModel` (Kwon 2008 by default) evaluated through
:func:`optroute.physics.passage.power_at_heading` at dense points along the track, in the weather
interpolated there. The NLP must optimise that same model, not a global fit of it (the separable fit
this module replaces was 16–67 % off on the benchmark corridors and needed up to six per-leg
corrections). So the model itself is evaluated, with the same function, at every node of the NLP's
own (time, along-track, across-track) weather grid (:func:`optroute.optimise.nlp_inputs.weather_grid`),
for a handful of speeds through water and of headings relative to the centreline, and handed to
the formulation as the ratio to a calm-water baseline::

    R(t, s, y, V, ψ) = P_model(V; sea at the node, heading = centreline direction − ψ) / P_calm(V)

(:class:`formulations.weather_grid.WeatherGrid`, ``power_ratio``). The NLP evaluates it through the same
cubic B-spline quasi-interpolant as the weather, in (t, s, y) and in V and ψ (with the structured
derivatives of :mod:`formulations._nlp_model`, exact Hessian), so it sees a smooth version of the
true model that is exact wherever the model is linear along an axis, and within the local range of
the tabulated values everywhere. Why these choices:

* **A ratio, not the power.** ``P_calm`` carries the steep V³ growth exactly; what is left varies
  slowly with the speed (Kwon's C_U is a quadratic in the Froude number), so a few speed nodes
  suffice, and a ratio linear in the sea state (as a linear added-power model) is reproduced exactly
  by the B-spline, which reproduces linear fields.
* **Heading nodes, not wave-angle nodes.** The model's arguments that depend on the heading — the
  relative wave angle, the wind angle — are all computed by :func:`power_at_heading` from the node's
  sea and a heading, so any model (one that reads the wind angle too) is tabulated correctly; the NLP
  knows its heading relative to the centreline (the leg's course and the crab angle against the
  current). On a fixed path without current a single heading node (ψ = 0) is exact.
* **One field per wave-angle sector where the model steps.** Kwon's direction coefficient (Kwon 2008) is
  constant inside each sector of the wave angle α (head 0–30°, bow 30–60°, beam 60–150°, following
  150–180°) and steps at the edges, which move with each node's wave direction: a smooth table over
  heading nodes spreads each step over ±2 nodes (±30°) and mixed head-sea power into bow-sea legs (+30 %
  on the worst leg of the storm crossing's DP track). A model that declares its edges
  (``wave_sector_edges_deg``) is tabulated once per sector, as if the waves came from inside that sector
  (:func:`power_at_heading`'s ``wave_sector_deg`` clamps α into it): each field is smooth in time, space,
  speed and heading. The NLP blends them by C² weights of the cosine of the wave angle it computes
  (:func:`formulations.splines.sector_weights`, ramps of ±10° about each edge: narrower ones are steeper and
  cost Ipopt many more iterations), so the table is exact in direction outside the ramps. Kwon reads the heading only through α, so each sector field is the same
  at every heading node (checked at every node between the first and last heading node) and the
  heading axis is dropped: 4 fields per speed instead of 5 heading nodes.
* **The same grid and spline as the weather.** One spline, one set of Taylor data per sample: the
  table costs model evaluations at set-up (nodes × speeds × headings) and spline outputs per sample,
  not a new mechanism. The quasi-interpolant, not an interpolating spline: Kwon's method steps with
  the Beaufort number and the direction sector, and an interpolating spline rings across a step
  (wiggles that are local optima for Ipopt); the quasi-interpolant is variation-diminishing.
* **Once per regime where the model says so.** A model whose power depends on the sea only through its
  regime (``power_by_regime``: Kwon's integer Beaufort number and direction sector, the wind angle not at all)
  is evaluated once per regime present and the values handed to every node of it (:func:`_model_power`): the
  same numbers as at every node, for a few dozen evaluations per speed instead of some 10⁵ (checked against the
  referee's :func:`power_at_heading` at every node in tests/test_power_table.py).
* **A cap where the model has no power.** Where the model cannot make the speed (Kwon beyond Fn 0.3:
  ``inf``) or needs more than :data:`CAP_MCR` times the MCR, the ratio is capped there: every such
  speed is above the MCR in the table as in the model, and the table stays finite and smooth.

The table's error is then a grid-resolution choice with a measured bound: every NLP plan's
``solver_stats["tabulation"]`` holds the NLP's fuel at its solution against the referee's fuel of
the same track and schedule, and, per leg and per sample, the NLP's power and fuel against the
model's evaluated at the NLP's own samples in the referee's weather (:func:`sample_error`; bound
:data:`LEG_BOUND` per leg). :data:`TABULATION_BOUND` is the bound stated for the default grids
(the NLP's weather grid at half the data's spacing, speed nodes every :data:`SPEED_STEP_KN` at
most, halved where their spline misses the model by more than :data:`SPEED_TOL`, Kwon's sector
fields) and checked in the tests at both NLP solutions of the storm crossing of
``benchmarks/bench_nlp.py`` section 4. What is left is the Beaufort number's integer steps in Hs
(Kwon's BN from Hs), which the quasi-interpolant spreads over ±2 nodes in (t, s, y) (±15 nm along
track, ±7.5 nm across, ±1.5 h): a smooth approximant of a step cannot be exact next to it. The referee,
not the table, scores every plan, so the error costs optimality (a local optimum in another basin),
never feasibility or the reported fuel; it also makes the NLP's minimum-load rows slightly optimistic
at the referee's points, which :func:`optroute.optimise.starts.repaired_plan` mends by speed after the
solve (status ``"mended"``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from formulations.common import PowerModel
from formulations.splines import spline_weights
from optroute.physics.passage import SeaState, model_sea, power_at_heading, sector_angle
from optroute.physics.performance import PerformanceModel

__all__ = [
    "CAP_MCR",
    "LEG_BOUND",
    "PowerTable",
    "RatioTable",
    "TABULATION_BOUND",
    "baseline_power_model",
    "heading_nodes",
    "sample_error",
    "speed_nodes",
    "tabulate_ratio",
]

#: Stated bound of ``|NLP fuel / referee fuel − 1|`` at an NLP solution on the default grids [-]: the largest
#: measured, +1.9 % on the storm crossing from the 3-D DP's start (tests/test_one_model.py), with room to spare.
#: Not a bound on every sea: ``python -m benchmarks.bench_harness`` reports the solutions of its random storm and
#: cyclone cases above it (4 of 137 solutions, the largest 6.0 %).
TABULATION_BOUND = 0.03
#: Stated bound of ``|NLP leg fuel / model leg fuel − 1|`` at the NLP's own samples at an NLP solution on the default
#: grids [-] (:func:`sample_error`, ``solver_stats["tabulation"]["max_leg_rel_error"]``): the largest measured,
#: +6.8 % on the storm crossing from the 3-D DP's start (tests/test_one_model.py), with room to spare; what is
#: left there is Kwon's Beaufort steps in Hs and the sector ramps. Not a bound on any track (+15.8 % on the DP's
#: own track, a start; +30 % there with the heading-node table).
LEG_BOUND = 0.15
#: Largest tabulated power as a multiple of the MCR [-] (where the model gives more, or none).
CAP_MCR = 1.5
#: Spacing of the speed nodes [kn] (at most; at least 4 nodes), halved where the sea needs it (:data:`SPEED_TOL`).
SPEED_STEP_KN = 3.5
#: Largest relative error [-] of the table's spline in the speed against the model, at the speed nodes and halfway
#: between them, above which the speed step is halved (:func:`tabulate_ratio`). In heavy weather the ratio to calm
#: water climbs steeply towards low speeds (Kwon's loss against a cubic baseline): a spline through nodes 3.5 kn
#: apart missed a third of the fuel at a discrete start in a cyclone (harness seed 5: 33.6 %; 7.8 % at 1.75 kn).
SPEED_TOL = 0.02
#: Heading nodes relative to the centreline [deg] on a corridor with lateral freedom or a current.
HEADINGS_DEG = (-30.0, -15.0, 0.0, 15.0, 30.0)


@dataclass(frozen=True)
class PowerTable:
    """Where the NLP's power table was evaluated, and the SFOC curve's fit to the model's fuel rate.

    Attributes
    ----------
    speeds_kn : numpy.ndarray
        Speed nodes [kn].
    headings_deg : numpy.ndarray
        Heading nodes relative to the centreline [deg, to port +].
    capped_share : float
        Share of the tabulated values capped at :data:`CAP_MCR` (no finite power, or more) [-].
    evaluations : int
        Values tabulated (nodes × speeds × headings × sectors).
    sfoc_max_rel_error : float
        Largest relative error of the quadratic SFOC curve against the model's fuel rate per kW [-]
        (0 to rounding for the IMO curve of the built-in ships).
    speed_error : float
        Largest relative error of the spline in the speed through the first speed nodes (every
        :data:`SPEED_STEP_KN` at most) against the model, at and halfway between them [-]; above
        :data:`SPEED_TOL` the table was made on nodes twice as dense (:func:`tabulate_ratio`).
    """

    speeds_kn: np.ndarray
    headings_deg: np.ndarray
    capped_share: float
    evaluations: int
    sfoc_max_rel_error: float
    speed_error: float = float("nan")


def speed_nodes(v_min_kn: float, v_max_kn: float) -> np.ndarray:
    """Uniform speed nodes over the NLP's speed range [kn], at most :data:`SPEED_STEP_KN` apart (at least 4)."""
    n = max(4, int(np.ceil((v_max_kn - v_min_kn) / SPEED_STEP_KN - 1e-9)) + 1)
    return np.linspace(float(v_min_kn), float(v_max_kn), n)


def heading_nodes(fixed_path: bool, has_current: bool) -> np.ndarray:
    """Heading nodes [deg]: only the centreline direction on a fixed path without current, else :data:`HEADINGS_DEG`."""
    return np.zeros(1) if fixed_path and not has_current else np.asarray(HEADINGS_DEG, dtype=float)


def baseline_power_model(
    model: PerformanceModel, *, v_min_kn: float, v_max_kn: float, min_load: float, max_load: float = 1.0
) -> tuple[PowerModel, float]:
    """The calm-water baseline ``P_calm = c V³`` and the SFOC curve of the NLP, and the SFOC curve's error.

    ``c`` is the least-squares cube (relative errors) through the model's calm-water power over the
    speed range: any positive baseline is exact once divided out of the table; a cube close to the
    calm curve keeps the ratio's speed dependence gentle. The SFOC curve ``SFOC/base = a2 L² + a1 L + a0``
    (Fourth IMO GHG Study form) is fitted to the model's fuel rate per kW over the load range and its
    largest relative error is returned (rounding only for the IMO curve of the built-in ships).
    """
    mcr = float(model.mcr_kw)
    v = np.linspace(v_min_kn, v_max_kn, 25)
    p0 = np.asarray(
        model.brake_power_kw(v, hs_m=0.0, wave_angle_deg=0.0, wind_speed_ms=0.0, wind_angle_deg=0.0), dtype=float
    )
    ok = np.isfinite(p0) & (p0 > 0)
    c3 = float(np.sum(v[ok] ** 3 / p0[ok]) / np.sum(v[ok] ** 6 / p0[ok] ** 2))
    loads = np.linspace(max(min_load, 0.05), 1.0, 20)
    pk = loads * mcr
    s = np.asarray(model.fuel_rate_tph(pk), dtype=float) / (pk * 1e-6)  # g/kWh
    basis = np.column_stack([loads**2, loads, np.ones_like(loads)])
    quad = np.linalg.lstsq(basis, s, rcond=None)[0]
    quad = np.where(np.abs(quad) <= 1e-12 * np.max(np.abs(quad)), 0.0, quad)  # a constant SFOC stays constant
    base = float(np.mean(s))
    err = float(np.max(np.abs((basis @ quad) / s - 1.0)))
    power = PowerModel(
        calm_coef=[c3],
        calm_exp=[3.0],
        mcr_kw=mcr,
        min_load=float(min_load),
        max_load=float(max_load),
        sfc_base_gpkwh=base,
        sfc_quad=quad / base,
    )
    return power, err


class RatioTable(NamedTuple):
    """The tabulated ratio and the axes it was tabulated on (:func:`tabulate_ratio`)."""

    ratio: np.ndarray  # (N, nv, nd, nq)
    headings_deg: np.ndarray  # (nd,) [deg, to port +]
    sector_edges_deg: tuple[float, ...]  # nq − 1 edges of the folded wave angle [deg]; () for one field
    capped_share: float  # share of values capped at CAP_MCR · MCR [-]
    speeds_kn: np.ndarray  # (nv,) the speed nodes tabulated [kn]: the given ones, or twice as dense (SPEED_TOL)
    speed_error: float  # the given nodes' spline against the model at those nodes and halfway between them [-]


def _sectors(edges: tuple[float, ...]) -> list[tuple[float, float] | None]:
    """The wave-angle sectors ``(lo, hi)`` [deg] between 0, the edges and 180; ``[None]`` (no clamp) without edges."""
    if not edges:
        return [None]
    bounds = (0.0, *edges, 180.0)
    return list(zip(bounds[:-1], bounds[1:], strict=True))


def tabulate_ratio(
    model: PerformanceModel,
    base: PowerModel,
    sea: SeaState,
    along_deg: np.ndarray,
    speeds_kn: np.ndarray,
    headings_deg: np.ndarray,
    speed_tol: float | None = SPEED_TOL,
) -> RatioTable:
    """``R = P_model / P_calm`` at every node for every speed, heading node and wave-angle sector (module docstring).

    The speed axis is checked: the table is evaluated at the given speed nodes and halfway between them, and where
    the cubic spline through the given nodes (the NLP's, :func:`formulations.splines.spline_weights`) misses the
    model by more than ``speed_tol`` (relative, values capped at :data:`CAP_MCR` aside) at any of them, the table
    keeps every speed evaluated: nodes twice as dense. Its ``speed_error`` is that largest miss of the given nodes.

    A model that declares where it steps in the wave angle (``wave_sector_edges_deg``, Kwon's 30°, 60° and
    150°) is tabulated once per sector, as if the waves came from inside that sector
    (:func:`optroute.physics.passage.power_at_heading`'s ``wave_sector_deg``); the NLP blends the sector
    fields by the wave angle it computes (:func:`formulations.splines.sector_weights`). Each field is then
    smooth in the heading; where it does not depend on the heading at all (the model reads the heading only
    through the wave angle: Kwon), the heading axis is dropped (one node, 0°), checked at every node between
    the first and last heading node.

    Parameters
    ----------
    model : PerformanceModel
        The ship's model (the referee's).
    base : PowerModel
        The NLP's calm-water baseline (:func:`baseline_power_model`).
    sea : SeaState
        The sea at the nodes, shape (N,) (navigable values: the grid's filled ones).
    along_deg : numpy.ndarray, shape (N,)
        The centreline direction at each node [deg true].
    speeds_kn, headings_deg : numpy.ndarray
        The nodes (nv,) [kn], evenly spaced, and (nd,) [deg, to port +: heading = centreline direction − ψ].
    speed_tol : float or None
        Largest relative error of the spline in the speed kept without halving its step [-]; None: no check.

    Returns
    -------
    RatioTable
        ``ratio`` (N, nv, nd', nq), the heading nodes kept (nd'), the sector edges (nq − 1), the capped share,
        the speed nodes (nv) and the spline's error in the speed.
    """
    edges = tuple(float(e) for e in getattr(model, "wave_sector_edges_deg", ()) or ())
    sectors = _sectors(edges)
    heads = np.asarray(headings_deg, dtype=float)
    given = np.asarray(speeds_kn, dtype=float)
    check = speed_tol is not None and given.size > 1
    speeds = np.sort(np.concatenate([given, 0.5 * (given[1:] + given[:-1])])) if check else given
    fields = None
    if edges and heads.size > 1:
        probe = _fields(model, base, sea, along_deg, speeds, heads[[0, -1]], sectors)
        if all(_same(a, b) for a, b in zip(probe[0], probe[1], strict=True)):
            fields, heads = probe[:1], np.zeros(1)
    if fields is None:
        fields = _fields(model, base, sea, along_deg, speeds, heads, sectors)
    return _speed_checked(fields, np.size(along_deg), heads, edges, speeds, check, speed_tol)


class _Field(NamedTuple):
    """The ratio at one heading node and sector (:func:`_fields`): its distinct rows and each node's row."""

    ratio: np.ndarray  # (R, nv) [-], capped at CAP_MCR · MCR / P_calm
    capped: np.ndarray  # (R, nv) bool: the model gives no finite power there, or more than the cap
    row: np.ndarray | None  # (N,) each node's row; None: R = N, in node order

    def rows(self) -> np.ndarray:
        """The ratio at the N nodes (N, nv)."""
        return self.ratio if self.row is None else self.ratio[self.row]

    def capped_count(self, speeds: slice) -> int:
        """Capped values at the N nodes and the speeds ``speeds``."""
        per_row = np.count_nonzero(self.capped[:, speeds], axis=1)
        counts = np.ones(self.ratio.shape[0], dtype=np.int64) if self.row is None else np.bincount(
            self.row, minlength=self.ratio.shape[0])  # fmt: skip
        return int(per_row @ counts)


def _same(a: _Field, b: _Field) -> bool:
    """Whether two fields give every node the same ratio (compared once per pair of rows met)."""
    if a.row is None or b.row is None:
        return np.array_equal(a.rows(), b.rows())
    pair = np.unique(a.row.astype(np.int64) * b.ratio.shape[0] + b.row)
    ra, rb = np.divmod(pair, b.ratio.shape[0])
    return np.array_equal(a.ratio[ra], b.ratio[rb])


def _speed_checked(
    fields: list[list[_Field]], n: int, heads: np.ndarray, edges: tuple, speeds: np.ndarray, check: bool,
    tol: float | None,
) -> RatioTable:  # fmt: skip
    """The table (N, nv, nd, nq) of ``fields`` (per heading node and sector) on every other speed of ``speeds`` (the
    given nodes) where their spline is within ``tol`` of every value but the capped ones, else on all of them
    (without ``check``: as it is, error NaN).  The spline is checked on each field's distinct rows."""
    error = float("nan")
    keep = slice(None)
    if check:
        coarse = speeds[::2]
        w = np.array(spline_weights(speeds, float(coarse[0]), float(coarse[1] - coarse[0]), coarse.size, np))
        error = 0.0
        for f in (f for per_heading in fields for f in per_heading):
            miss = np.abs(np.einsum("cv,nc->nv", w, f.ratio[:, ::2]) / f.ratio - 1.0)[~f.capped]
            error = max(error, float(miss.max()) if miss.size else 0.0)
        if error <= tol:
            keep, speeds = slice(None, None, 2), coarse
    nv = speeds.size
    ratio = np.empty((n, nv, len(fields), len(fields[0])))
    capped = 0
    for k, per_heading in enumerate(fields):
        for q, f in enumerate(per_heading):
            ratio[:, :, k, q] = f.rows()[:, keep]
            capped += f.capped_count(keep)
    return RatioTable(ratio, heads, edges, capped / ratio.size if ratio.size else 0.0, speeds, error)


def _fields(
    model: PerformanceModel,
    base: PowerModel,
    sea: SeaState,
    along_deg: np.ndarray,
    speeds_kn: np.ndarray,
    headings_deg: np.ndarray,
    sectors: list[tuple[float, float] | None],
) -> list[list[_Field]]:
    """The ratio per heading node and sector (:class:`_Field`) at the N nodes and nv speeds, capped at
    :data:`CAP_MCR` · MCR: one row per regime present (:func:`_model_power`), or per node."""
    v = np.asarray(speeds_kn, dtype=float)[None, :]
    p_calm = base.calm_power_kw(v)
    cap = CAP_MCR * base.mcr_kw
    col = lambda a: np.asarray(a, dtype=float)[:, None]  # noqa: E731
    out: list[list[_Field]] = []
    for psi in np.asarray(headings_deg, dtype=float):
        at = model_sea(
            col(np.asarray(along_deg) - psi), col(sea.hs_m), col(sea.wave_from_deg), col(sea.wind_u_ms),
            col(sea.wind_v_ms),
        )  # fmt: skip
        out.append([])
        for sector in sectors:
            at_q = {**at, "wave_angle_deg": sector_angle(at["wave_angle_deg"], sector)}
            p, node_row = _model_power(model, v, at_q, np.size(along_deg))
            over = ~np.isfinite(p) | (p > cap)
            out[-1].append(_Field(np.where(over, cap, p) / p_calm, over, node_row))
    return out


def _model_power(
    model: PerformanceModel, v_kn: np.ndarray, at: dict[str, np.ndarray], n: int
) -> tuple[np.ndarray, np.ndarray | None]:
    """``model.brake_power_kw`` at the speeds ``v_kn`` (1, nv) [kn] in the N seas ``at`` (:func:`model_sea`):
    ``(power (R, nv), each sea's row (N,))``, or ``(power (N, nv), None)``.

    A model whose power depends on the sea only through its regime (``power_by_regime``: Kwon's Beaufort number
    and sector, :attr:`optroute.physics.performance.KwonModel.power_by_regime`) is evaluated once per regime, at
    the first sea of that regime, and its row handed to every sea of it: the same numbers as evaluating it at
    every node (a few dozen regimes against some 10⁵ nodes). Any other model is evaluated at every node.
    """
    if not getattr(model, "power_by_regime", False):
        return np.broadcast_to(np.asarray(model.brake_power_kw(v_kn, **at), dtype=float), (n, v_kn.size)), None
    seas = {name: np.broadcast_to(a, (n, 1)) for name, a in at.items()}
    regime = model.power_regime(
        hs_m=seas["hs_m"][:, 0], wave_angle_deg=seas["wave_angle_deg"][:, 0], wind_speed_ms=seas["wind_speed_ms"][:, 0]
    )
    _, first, inverse = np.unique(np.ravel(regime), return_index=True, return_inverse=True)
    p = model.brake_power_kw(v_kn, **{name: a[first] for name, a in seas.items()})
    return np.broadcast_to(np.asarray(p, dtype=float), (first.size, v_kn.size)), np.ravel(inverse)


def sample_error(
    model: PerformanceModel,
    base: PowerModel,
    sea: SeaState,
    heading_deg: np.ndarray,
    stw_kn: np.ndarray,
    power_kw: np.ndarray,
    rate_tph: np.ndarray,
    hours_per_nm: np.ndarray,
) -> dict[str, float | int]:
    """The NLP's power against the model's at each of its own samples, and its fuel per leg against the model's.

    At an NLP solution both are at hand: the NLP's brake power at every sample (the table through its spline,
    :func:`formulations._ratio_table.power_ratio`) and the sample's time, position, speed and heading, where the
    model is evaluated by :func:`optroute.physics.passage.power_at_heading` in the referee's weather (the
    sampler's interpolation of the data) — the same function the table and the referee use. Where the model
    has no power or more than :data:`CAP_MCR` · MCR it is capped as in the table. What differs from the
    referee's leg fuel is then only where the referee samples (every few nm, leg ends included) against the
    NLP's few samples per leg; what differs here is the table and its smoothing of the weather.

    Parameters
    ----------
    model : PerformanceModel
        The ship's model (the referee's).
    base : PowerModel
        The NLP's baseline (its MCR sets the cap).
    sea : SeaState
        The referee's sea at the samples, shape (N, m).
    heading_deg : numpy.ndarray, shape (N, m)
        The ship's heading at each sample [deg true, the direction it heads to].
    stw_kn : numpy.ndarray, shape (N,)
        Speed through water of each leg [kn].
    power_kw, rate_tph : numpy.ndarray, shape (N, m)
        The NLP's brake power [kW] and fuel rate [t/h] at each sample.
    hours_per_nm : numpy.ndarray, shape (N, m)
        The sample's share of its leg's time per nm of the leg [h/nm] (layout weight over SOG): the leg's fuel
        is ``L_k Σ_j rate_j · hours_per_nm_j``, and ``L_k`` cancels in the ratio.

    Returns
    -------
    dict
        ``max_leg_rel_error`` (signed, the largest in magnitude of NLP leg fuel / model leg fuel − 1) and its
        ``worst_leg``, ``mean_abs_leg_rel_error``, ``max_sample_rel_error`` (signed, of the power) and
        ``mean_abs_sample_rel_error`` [-], ``capped_samples`` and ``samples``.
    """
    p = power_at_heading(
        model, np.asarray(stw_kn, dtype=float)[:, None], heading_deg, sea.hs_m, sea.wave_from_deg, sea.wind_u_ms,
        sea.wind_v_ms,
    )  # fmt: skip
    p = np.broadcast_to(np.asarray(p, dtype=float), np.shape(power_kw))
    cap = CAP_MCR * base.mcr_kw
    over = ~np.isfinite(p) | (p > cap)
    p = np.where(over, cap, p)
    e_sample = np.asarray(power_kw, dtype=float) / p - 1.0
    w = np.asarray(hours_per_nm, dtype=float)
    fuel_model = np.sum(np.asarray(model.fuel_rate_tph(p), dtype=float) * w, axis=1)
    e_leg = np.sum(np.asarray(rate_tph, dtype=float) * w, axis=1) / fuel_model - 1.0
    k = int(np.argmax(np.abs(e_leg)))
    j = np.unravel_index(int(np.argmax(np.abs(e_sample))), e_sample.shape)
    return {
        "max_leg_rel_error": float(e_leg[k]),
        "worst_leg": k,
        "mean_abs_leg_rel_error": float(np.mean(np.abs(e_leg))),
        "max_sample_rel_error": float(e_sample[j]),
        "mean_abs_sample_rel_error": float(np.mean(np.abs(e_sample))),
        "capped_samples": int(over.sum()),
        "samples": int(e_sample.size),
    }
