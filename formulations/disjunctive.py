"""Disjunctive danger bands: side selection, side-flip improvement and exact small-case modes.

A band is the disjunction "ratio ≤ lower OR ratio ≥ upper", imposed wherever it applies
(``Hs ≥`` a threshold). A continuous solver handles one side at a time (a smooth one-sided
constraint); the combinatorial choice of sides is made here. physics.md §9: Ipopt converges to
the side it starts on and reports success at a local optimum, so exact answers need
enumeration of the disjuncts (or Bonmin with big-M); every answer is re-checked.

Everything here is solver-agnostic. A *side array* has any shape (``(N, B)`` for legs × bands on
a fixed path, ``(N, m, B)`` for the NLP's samples) with entries −1 (``ratio ≤ lower``) or +1
(``ratio ≥ upper``), or :data:`~formulations.common.BELOW_SIDE` (``Hs < hs_min_m``, where the band does not
apply; the NLP's samples only); an *applies* array of the same shape says where a band is imposed. The inner
solver is a callback ``solve(sides, applies) -> InnerOutcome``. Adapters:

* :func:`convex_band_solver` wraps :func:`formulations.speed_convex.solve_speed_convex` on a
  fixed path, where every band side is a speed bound on its leg;
* :func:`nlp_band_solver` wraps :class:`formulations.speed_nlp.SpeedNLP` (sides per leg, sample
  and band; :func:`nlp_groups` makes all samples of a leg and band flip together).

Modes:

(a) :func:`select_sides`: the side a value (e.g. the search's speed) is on — the nearer edge
    when inside the band;
(b) :func:`improve_sides`: the outer loop — solve, re-check where each band applies at the
    solution (applicability only ever grows, a conservative rule that makes the loop finite),
    then try flipping the sides of groups whose band constraint is active (most binding first),
    keep the first improvement, repeat until none improves (a 1-flip local search). A third
    disjunct, "Hs stays below the band's threshold" (:data:`formulations.common.BELOW_SIDE`), holds
    where a start lies inside a band's ratio interval in seas below the threshold, so that the
    solve cannot carry it into the band's seas unseen; a binding one is released as a move;
(c) :func:`enumerate_sides`: all ``2^G`` side combinations of the flippable groups (exact
    for a fixed applicability; ``G ≤ 16``), and :func:`bonmin_fixed_path`, the fixed-path problem
    as a convex MINLP with big-M constraints solved by Bonmin's branch and bound.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from formulations.common import BELOW_SIDE, FormulationInputError, PowerLawFuel, as_float_array, broadcast_legs

__all__ = [
    "BonminResult",
    "DisjunctiveResult",
    "InnerOutcome",
    "bonmin_fixed_path",
    "convex_band_solver",
    "enumerate_sides",
    "fixed_path_speed_bounds",
    "improve_sides",
    "nlp_band_solver",
    "nlp_groups",
    "select_sides",
    "strictly_inside",
]


def select_sides(value: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
    """Side of each band a value is on: −1 (``value ≤ lower``) or +1 (``value ≥ upper``).

    Inside the band (``lower < value < upper``) the nearer edge wins (ties: lower). A band with an
    infinite edge has only the other side.

    Parameters
    ----------
    value : array_like
        Ratio (or speed) at the warm start; broadcast against ``lower`` and ``upper``.
    lower, upper : array_like
        Band edges.

    Returns
    -------
    numpy.ndarray of int8
        −1 or +1, shape of the broadcast.
    """
    v, lo, hi = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (value, lower, upper)))
    side = np.where((v - lo) <= (hi - v), -1, 1)
    side = np.where(~np.isfinite(lo), 1, np.where(~np.isfinite(hi), -1, side))
    return side.astype(np.int8)


def strictly_inside(value: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
    """Whether each value lies strictly inside its band (``lower < value < upper``): on neither side of it.

    The complement of the sides :func:`select_sides` names without choosing; an edge value is on a side.
    Shapes broadcast as in :func:`select_sides`.
    """
    v = np.asarray(value, dtype=float)
    return (v > np.asarray(lower, dtype=float)) & (v < np.asarray(upper, dtype=float))


def held_across_crossings(sides: ArrayLike, applies: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Sides and applicability (..., N, m, B) with each band's speed side held across the sea's rise through its
    threshold (any leading axes, e.g. the robust NLP's members, are independent problems).

    Along a leg (its ``m`` samples in order, one speed through water) a sample on the side "Hs below the threshold"
    (:data:`~formulations.common.BELOW_SIDE`) next to a sample where the band applies on side −1 or +1 has the
    threshold crossing between them: past it the band applies and the ratio, which moves with the sea between
    the two samples, has to be on that side already — the referee finds the stretch in the band otherwise
    (EP 2145155's guidance holds wherever ``Hs`` reaches the threshold, not only at the samples). Such a sample
    takes its neighbour's side, imposed (applies True), so that the one disjunct holds at both ends of the
    stretch. A stricter set, never a looser one; a sample between two neighbours on opposite sides keeps its
    own (no single side holds across both crossings; the referee judges).
    """
    s = np.asarray(sides).astype(np.int8)
    a = np.asarray(applies, dtype=bool)
    if s.ndim < 3 or s.shape != a.shape:
        raise FormulationInputError(
            f"sides and applies must both have shape (..., N, m, B), got {s.shape} and {a.shape}"
        )
    held = a & (s != BELOW_SIDE)
    prev = np.zeros_like(s)
    nxt = np.zeros_like(s)
    prev[..., 1:, :] = np.where(held[..., :-1, :], s[..., :-1, :], 0)
    nxt[..., :-1, :] = np.where(held[..., 1:, :], s[..., 1:, :], 0)
    take = np.where(prev != 0, prev, nxt)
    move = (s == BELOW_SIDE) & ~a & (take != 0) & ((prev == 0) | (nxt == 0) | (prev == nxt))
    return np.where(move, take, s).astype(np.int8), a | move


@dataclass(frozen=True)
class InnerOutcome:
    """What an inner solve reports to the outer loop.

    Attributes
    ----------
    feasible : bool
        The solver found a point satisfying all constraints (its own verdict plus any re-check).
    objective : float
        Objective at that point (``inf`` when not feasible).
    active : numpy.ndarray of bool
        Shape of the side array: the side constraint is imposed and binding.
    weight : numpy.ndarray
        Same shape: how binding (a multiplier magnitude), used to order flips.
    applies : numpy.ndarray of bool or None
        Applicability re-evaluated at the solution (None: unchanged).
    side_at_solution : numpy.ndarray of int8 or None
        The side an entry takes when it newly applies or is released: the side it is on at the solution, except
        where the solution lies inside the band and the inner solver gives the side of the point its next solve
        starts from (:func:`nlp_band_solver`, where that point is clear of the band).
    inside : numpy.ndarray of bool or None
        Entries that apply at the solution and lie strictly inside their band.
    status : str
        The inner solver's status, verbatim.
    payload : object
        The inner solver's full result.
    infeasibility : float
        How far from feasible (0 when feasible; used by the repair step, smaller is better).
    gain : numpy.ndarray, callable or None
        Same shape: an estimate of the objective change of flipping each entry's group from this solution
        (equal over a group; the NLP's Lagrangian estimate, ``optroute.optimise.side_gains.flip_gains``), whose sum
        over a move's groups bounds the change from below where the inner problem is a convex fixed-path
        one; :func:`improve_sides` does not try a move it estimates not to improve. None: every move is tried.
        A callable ``() -> array or None`` is called once, when the estimate is first needed
        (:meth:`flip_gain`): only the solutions the search keeps are estimated, not every trial it rejects.
    release_gain : numpy.ndarray, callable or None
        Same shape and form: an estimate of the objective change of releasing each group's samples held below the
        band's threshold (:data:`~formulations.common.BELOW_SIDE`) to their ``side_at_solution``
        (``optroute.optimise.side_gains.release_gains``); :func:`improve_sides` does not try a release it
        estimates not to improve (:meth:`release_estimate`). None: every release is tried.
    """

    feasible: bool
    objective: float
    active: np.ndarray
    weight: np.ndarray
    applies: np.ndarray | None = None
    side_at_solution: np.ndarray | None = None
    inside: np.ndarray | None = None
    status: str = ""
    payload: Any = field(default=None, repr=False)
    infeasibility: float = 0.0
    gain: np.ndarray | Callable[[], np.ndarray | None] | None = None
    release_gain: np.ndarray | Callable[[], np.ndarray | None] | None = None
    _made: dict[str, np.ndarray | None] = field(default_factory=dict, init=False, repr=False, compare=False)

    def flip_gain(self) -> np.ndarray | None:
        """``gain`` as an array (or None), a callable one evaluated on the first call only."""
        return self._resolved("gain")

    def release_estimate(self) -> np.ndarray | None:
        """``release_gain`` as an array (or None), a callable one evaluated on the first call only."""
        return self._resolved("release_gain")

    def _resolved(self, name: str) -> np.ndarray | None:
        value = getattr(self, name)
        if not callable(value):
            return value
        if name not in self._made:
            self._made[name] = value()
        return self._made[name]


SolveFn = Callable[[np.ndarray, np.ndarray], InnerOutcome]


@dataclass(frozen=True)
class DisjunctiveResult:
    """Result of :func:`improve_sides` or :func:`enumerate_sides`.

    Attributes
    ----------
    sides, applies : numpy.ndarray
        The side choice and applicability of the best solution.
    outcome : InnerOutcome
        The inner solve at that choice.
    objective : float
        Its objective (``inf`` if no feasible choice was found).
    feasible : bool
        Whether a feasible choice was found (and no applicable band is violated at it).
    n_solves : int
        Inner solves performed.
    history : list of float
        Objective after every accepted change.
    solve_time_s : float
        Wall-clock time [s].
    finished : bool
        The search stopped by its own rule (no flip improves, no flip repairs, applicability stable), not on
        its budget of solves: only then is the side choice a local optimum of the flip neighbourhood.
        :func:`enumerate_sides` always finishes.
    """

    sides: np.ndarray
    applies: np.ndarray
    outcome: InnerOutcome
    objective: float
    feasible: bool
    n_solves: int
    history: list[float]
    solve_time_s: float
    finished: bool = True


def _groups_of(sides: np.ndarray, groups: ArrayLike | None) -> np.ndarray:
    if groups is None:
        return np.arange(sides.size).reshape(sides.shape)
    g = np.asarray(groups)
    if g.shape != sides.shape:
        raise FormulationInputError(f"groups must have the shape of sides {sides.shape}, got {g.shape}")
    return g


class _Counter:
    def __init__(self, solve: SolveFn, budget: int) -> None:
        self.solve, self.budget, self.count = solve, budget, 0
        self.cut = False  # the budget stopped an applicability re-check

    def __call__(self, sides: np.ndarray, applies: np.ndarray) -> InnerOutcome:
        self.count += 1
        return self.solve(sides.copy(), applies.copy())

    @property
    def exhausted(self) -> bool:
        return self.count >= self.budget


def _settle(
    solve: _Counter, sides: np.ndarray, applies: np.ndarray, max_rounds: int
) -> tuple[np.ndarray, np.ndarray, InnerOutcome]:
    """Solve, then re-check applicability at the solution until it is stable (it only grows).

    Where the budget stops the re-checks while applicability still grows, ``solve.cut`` is set. Where a re-check's
    solve fails after a solve whose solution is clear of every band where it applies at that solution
    (:func:`_valid`), that solution and its sides are kept: the re-check's rows (the newly applying samples, and
    the samples :func:`held_across_crossings` holds beside them, which that solution may break) would only
    constrain the later moves, and a failed solve is no better than a valid point — the caller's own check
    judges it between the samples.
    """
    out = solve(sides, applies)
    for _ in range(max_rounds):
        if out.applies is None or not out.feasible:
            break
        new = out.applies & ~applies
        if not new.any():
            break
        before = (sides, applies, out)
        sides = sides.copy()
        if out.side_at_solution is not None:
            sides[new] = out.side_at_solution[new]
        applies = applies | out.applies
        if solve.exhausted:
            solve.cut = True
            break
        out = solve(sides, applies)
        if not out.feasible and _valid(before[2]):
            return before
    return sides, applies, out


def _promising(
    moves: list[tuple[int, ...]], grp: np.ndarray, cur: InnerOutcome, rel_tol: float
) -> list[tuple[int, ...]]:
    """The moves, in their order, whose estimated change (the sum of their groups' ``gain``) is an improvement
    beyond ``rel_tol``; every move where the solve gave no estimate. The estimate screens, it does not order: a
    first-order (tangent) bound promises far more than a large move gives (on a band case of ``bench_bands``
    about −6 t for flips that changed the fuel by −1 to +2.3 t), so the multipliers' order stands."""
    gain = cur.flip_gain() if moves else None
    if gain is None:
        return moves
    per = {int(g): float(np.max(gain[grp == g])) for g in np.unique(grp)}
    floor = -rel_tol * max(1.0, abs(cur.objective))
    return [move for move in moves if sum(per[g] for g in move) < floor]


def _releases(cur: InnerOutcome, sides: np.ndarray, applies: np.ndarray, grp: np.ndarray, rel_tol: float) -> list[int]:
    """Groups with a binding row "Hs below the threshold" (:data:`~formulations.common.BELOW_SIDE`), most binding
    first: releasing one lets its samples into the band's seas on the side the solution is on there. Where the
    solve estimates each release's change (``InnerOutcome.release_gain``), only those estimated to improve beyond
    ``rel_tol``, as :func:`_promising` screens the flips."""
    if cur.side_at_solution is None:
        return []
    held = cur.active & (sides == BELOW_SIDE) & ~applies
    estimate = cur.release_estimate() if held.any() else None
    if estimate is not None:
        held &= estimate < -rel_tol * max(1.0, abs(cur.objective))
    labels = np.unique(grp[held])
    strength = np.array([np.max(np.where(held & (grp == g), cur.weight, -np.inf)) for g in labels])
    return [int(g) for g in labels[np.argsort(-strength, kind="stable")]]


def _valid(out: InnerOutcome) -> bool:
    return bool(out.feasible and np.isfinite(out.objective) and (out.inside is None or not out.inside.any()))


def _flip(sides: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = sides.copy()
    out[mask] = -out[mask]
    return out


def improve_sides(
    solve: SolveFn,
    sides: ArrayLike,
    applies: ArrayLike,
    *,
    flippable: ArrayLike | None = None,
    groups: ArrayLike | None = None,
    pairs: bool = True,
    rel_tol: float = 1e-9,
    max_solves: int = 500,
    max_applicability_rounds: int = 10,
) -> DisjunctiveResult:
    """Outer loop: applicability re-check plus flip local search over band sides.

    1. Solve with the given sides; re-check where the bands apply at the solution and re-solve
       while that set grows (entries that newly apply take the side ``side_at_solution`` the solve reports:
       :func:`nlp_band_solver` gives the side of the point the re-solve starts from where that point is clear of
       the band).
    2. If infeasible, repair greedily: flip the group that most reduces the reported
       infeasibility, until feasible or no flip helps.
    3. Local search: flip one group whose band constraint is active (most binding first) and
       keep the first improvement; when no single flip improves and ``pairs`` is set, try flipping
       two groups together, at least one of them active (a 2-flip neighbourhood, which reaches
       the swaps a tight ETA needs: one leg to its fast side, another to its slow side); stop
       when nothing improves. Where the inner solve estimates each flip's change (``InnerOutcome.gain``)
       only the moves estimated to improve are tried, the most promising first. Before the flips, each
       group whose row "Hs below the threshold" binds (:data:`~formulations.common.BELOW_SIDE`, where the
       start lay inside the band's ratio interval in seas below its threshold) is released: those samples
       take the side the solution is on and the band applies there, so the ship may enter the band's seas.

    Parameters
    ----------
    solve : callable
        ``solve(sides, applies) -> InnerOutcome`` with the sides fixed.
    sides : array_like of int
        Initial sides (−1/+1), e.g. from :func:`select_sides` at the search's solution.
    applies : array_like of bool
        Initial applicability.
    flippable : array_like of bool, optional
        Entries whose band has both sides (default: all).
    groups : array_like of int, optional
        Entries with the same label flip together (e.g. all samples of one leg and band).
    pairs : bool
        Use the 2-flip neighbourhood when no single flip improves.
    rel_tol : float
        A flip is kept when it lowers the objective by more than ``rel_tol · max(1, |objective|)``.
    max_solves : int
        Budget of inner solves.
    max_applicability_rounds : int
        Re-solves per settle step when applicability grows.

    Returns
    -------
    DisjunctiveResult
        The best valid solution found; ``feasible`` is False when none was.
    """
    started = time.perf_counter()
    s0 = np.asarray(sides).astype(np.int8)
    a0 = np.asarray(applies, dtype=bool)
    if s0.shape != a0.shape:
        raise FormulationInputError(f"sides {s0.shape} and applies {a0.shape} must have the same shape")
    flip_ok = np.ones(s0.shape, dtype=bool) if flippable is None else np.asarray(flippable, dtype=bool)
    grp = _groups_of(s0, groups)
    counter = _Counter(solve, max_solves)
    cur_s, cur_a, cur = _settle(counter, s0, a0, max_applicability_rounds)
    history: list[float] = []

    def settle(trial: np.ndarray) -> tuple[np.ndarray, np.ndarray, InnerOutcome]:
        return _settle(counter, trial, cur_a, max_applicability_rounds)

    finished = False  # True once the search stops by its own rule, not on the budget
    while not _valid(cur):  # greedy repair on the infeasibility
        if counter.exhausted:
            break
        best = None
        for g in np.unique(grp[flip_ok & cur_a]):
            if counter.exhausted:
                break
            ts, ta, to = settle(_flip(cur_s, (grp == g) & flip_ok & cur_a))
            key = (0, to.objective) if _valid(to) else (1, to.infeasibility)
            if best is None or key < best[0]:
                best = (key, ts, ta, to)
        if best is None or (best[0][0] == 1 and not best[0][1] < cur.infeasibility):
            finished = not counter.exhausted  # no flip repairs (all tried), unless the budget cut the trials
            break
        _, cur_s, cur_a, cur = best
    if _valid(cur):
        history.append(cur.objective)
        while True:  # ends when no move improves; a move tried costs a solve, so the budget ends it too
            cand = cur.active & flip_ok & cur_a
            labels = np.unique(grp[cand])
            strength = np.array([np.max(np.where(cand & (grp == g), cur.weight, -np.inf)) for g in labels])
            labels = labels[np.argsort(-strength, kind="stable")]
            moves: list[tuple[int, ...]] = [(int(g),) for g in labels]
            if pairs:
                others = [int(h) for h in np.unique(grp[flip_ok & cur_a]) if h not in labels]
                moves += [(int(g), int(h)) for g, h in itertools.combinations(labels, 2)]
                moves += [(int(g), h) for g in labels for h in others]
            moves = _promising(moves, grp, cur, rel_tol)
            releases = _releases(cur, cur_s, cur_a, grp, rel_tol)
            improved, tried = False, 0
            for move in [("release", g) for g in releases] + moves:
                if counter.exhausted:
                    break
                if move[0] == "release":  # a binding "Hs below the threshold" row becomes the side it is on
                    mask = (grp == move[1]) & (cur_s == BELOW_SIDE) & ~cur_a
                    released = cur_s.copy()
                    released[mask] = cur.side_at_solution[mask]
                    ts, ta, to = _settle(counter, released, cur_a | mask, max_applicability_rounds)
                else:
                    mask = np.isin(grp, move) & flip_ok & cur_a
                    ts, ta, to = settle(_flip(cur_s, mask))
                tried += 1
                if _valid(to) and to.objective < cur.objective - rel_tol * max(1.0, abs(cur.objective)):
                    cur_s, cur_a, cur = ts, ta, to
                    history.append(cur.objective)
                    improved = True
                    break
            if not improved:
                finished = tried == len(moves) + len(releases)  # every move tried and none improves: a local optimum
                break
    ok = _valid(cur)
    return DisjunctiveResult(
        sides=cur_s,
        applies=cur_a,
        outcome=cur,
        objective=float(cur.objective) if ok else float("inf"),
        feasible=ok,
        n_solves=counter.count,
        history=history,
        solve_time_s=time.perf_counter() - started,
        finished=finished and not counter.cut,
    )


def enumerate_sides(
    solve: SolveFn,
    sides: ArrayLike,
    applies: ArrayLike,
    *,
    flippable: ArrayLike | None = None,
    groups: ArrayLike | None = None,
    max_groups: int = 16,
) -> DisjunctiveResult:
    """Exact mode: solve every side combination of the applicable, flippable groups.

    Exact for the given applicability when each inner solve is globally optimal (e.g. the convex
    fixed-path problem). ``2^G`` solves for ``G`` groups.

    Raises
    ------
    FormulationInputError
        When there are more than ``max_groups`` groups to enumerate.
    """
    started = time.perf_counter()
    s0 = np.asarray(sides).astype(np.int8)
    a0 = np.asarray(applies, dtype=bool)
    flip_ok = np.ones(s0.shape, dtype=bool) if flippable is None else np.asarray(flippable, dtype=bool)
    grp = _groups_of(s0, groups)
    labels = np.unique(grp[flip_ok & a0])
    if labels.size > max_groups:
        raise FormulationInputError(
            f"{labels.size} groups to enumerate (2^{labels.size} solves); the limit is max_groups={max_groups}"
        )
    best: tuple[np.ndarray, InnerOutcome] | None = None
    first: InnerOutcome | None = None
    count = 0
    for combo in itertools.product((-1, 1), repeat=labels.size):
        trial = s0.copy()
        for g, side in zip(labels, combo, strict=True):
            mask = (grp == g) & flip_ok & a0
            trial[mask] = side
        out = solve(trial.copy(), a0.copy())
        count += 1
        first = first or out
        if _valid(out) and (best is None or out.objective < best[1].objective):
            best = (trial, out)
    if best is None:  # no combination is feasible; report the first solve (there is always one)
        out0 = first if first is not None else solve(s0.copy(), a0.copy())
        return DisjunctiveResult(s0, a0, out0, float("inf"), False, count, [], time.perf_counter() - started)
    return DisjunctiveResult(
        best[0], a0, best[1], float(best[1].objective), True, count, [best[1].objective], time.perf_counter() - started
    )


# ---------------------------------------------------------------------------
# Fixed path: bands as forbidden speed intervals, the convex solver inside
# ---------------------------------------------------------------------------


def _intervals(forbidden_kn: ArrayLike, n: int) -> np.ndarray:
    f = as_float_array(forbidden_kn, "forbidden_kn", finite=False)
    if f.ndim == 2:
        f = f[:, None, :]
    if f.ndim != 3 or f.shape[0] != n or f.shape[2] != 2:
        raise FormulationInputError(f"forbidden_kn must have shape ({n}, 2) or ({n}, B, 2), got {f.shape}")
    return f


def fixed_path_speed_bounds(
    sides: np.ndarray, applies: np.ndarray, forbidden_kn: np.ndarray, v_min_kn: np.ndarray, v_max_kn: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Speed bounds per leg [kn] from base bounds and band sides: side −1 caps at ``a``, +1 floors at ``b``."""
    a, b = forbidden_kn[..., 0], forbidden_kn[..., 1]
    cap = np.where(applies & (sides < 0), a, np.inf)
    floor = np.where(applies & (sides > 0), b, -np.inf)
    return np.maximum(v_min_kn, floor.max(axis=1)), np.minimum(v_max_kn, cap.min(axis=1))


def convex_band_solver(
    distance_nm: ArrayLike,
    fuel: PowerLawFuel,
    forbidden_kn: ArrayLike,
    *,
    eta_h: float | None,
    v_min_kn: ArrayLike = 0.0,
    v_max_kn: ArrayLike = np.inf,
    bound_tol: float = 1e-6,
    **convex_kwargs: Any,
) -> SolveFn:
    """Inner solver for a fixed path: every band side is a speed bound, solved by Clarabel.

    Parameters
    ----------
    distance_nm : array_like, shape (N,)
        Leg lengths [nm].
    fuel : PowerLawFuel
        Per-leg fuel-rate model.
    forbidden_kn : array_like, shape (N, 2) or (N, B, 2)
        Forbidden speed interval ``[a, b]`` [kn] of each band on each leg (for a fixed heading and
        sea state every band is such an interval, physics.md §3); NaN rows never apply.
    eta_h : float or None
        Passage time allowed [h].
    v_min_kn, v_max_kn : float or array_like, shape (N,)
        Base speed bounds [kn] (MCR, minimum load, maximum speed).
    bound_tol : float
        Relative distance to a side's speed bound below which that side counts as active.
    **convex_kwargs
        Passed to :func:`formulations.speed_convex.solve_speed_convex`.

    Returns
    -------
    callable
        ``solve(sides, applies) -> InnerOutcome`` with sides of shape (N, B); ``ratio`` is the speed.
        A side choice whose bounds cross (``lo > hi``) is infeasible without a solve.
    """
    from formulations.speed_convex import solve_speed_convex

    d = as_float_array(distance_nm, "distance_nm", ndim=1)
    n = d.size
    f = _intervals(forbidden_kn, n)
    vmin = broadcast_legs(v_min_kn, n, "v_min_kn")
    vmax = broadcast_legs(v_max_kn, n, "v_max_kn", finite=False)
    lower, upper = f[..., 0], f[..., 1]

    def solve(sides: np.ndarray, applies: np.ndarray) -> InnerOutcome:
        s = np.asarray(sides).reshape(lower.shape)
        a = np.asarray(applies, dtype=bool).reshape(lower.shape) & np.isfinite(lower) & np.isfinite(upper)
        lo, hi = fixed_path_speed_bounds(s, a, f, vmin, vmax)
        zero = np.zeros(s.shape)
        # infeasibility [h]: crossed speed bounds, then the shortfall of the fastest passage
        crossed = float(np.sum(np.maximum(0.0, d / hi - d / np.maximum(lo, 1e-9))))
        shortfall = max(0.0, float(np.sum(d / hi)) - eta_h) if eta_h is not None else 0.0
        if crossed > 0.0:
            return InnerOutcome(
                False, float("inf"), zero.astype(bool), zero, status="crossed_bounds", infeasibility=crossed + shortfall
            )
        res = solve_speed_convex(d, fuel, eta_h=eta_h, v_min_kn=lo, v_max_kn=hi, **convex_kwargs)
        if not res.success:
            return InnerOutcome(
                False,
                float("inf"),
                zero.astype(bool),
                zero,
                status=res.status,
                payload=res,
                infeasibility=shortfall if shortfall > 0 else float("inf"),
            )
        v = res.speed_kn[:, None]
        near_cap = a & (s < 0) & (np.abs(v - lower) <= bound_tol * lower)
        near_floor = a & (s > 0) & (np.abs(v - upper) <= bound_tol * upper)
        weight = np.where(near_cap, res.time_lower_dual[:, None], 0.0) + np.where(
            near_floor, res.time_upper_dual[:, None], 0.0
        )
        inside = a & (v > lower * (1 + bound_tol)) & (v < upper * (1 - bound_tol))
        return InnerOutcome(
            feasible=True,
            objective=res.objective,
            active=near_cap | near_floor,
            weight=np.abs(weight),
            applies=None,
            side_at_solution=select_sides(v, lower, upper),
            inside=inside,
            status=res.status,
            payload=res,
        )

    return solve


# ---------------------------------------------------------------------------
# Corridor NLP inside
# ---------------------------------------------------------------------------


def nlp_groups(shape: tuple[int, int, int]) -> np.ndarray:
    """Group labels (leg, band) for an (N, m, B) side array: all samples of a leg flip together."""
    n, m, nb = shape
    return np.broadcast_to((np.arange(n)[:, None] * nb + np.arange(nb)[None, :])[:, None, :], shape).copy()


def nlp_band_solver(
    nlp: Any,
    *,
    violation_tol: float = 1e-6,
    later: Callable[[], Any] | None = None,
    gains: Callable[[Any], np.ndarray | None] | None = None,
    release_gains: Callable[[Any, np.ndarray], np.ndarray | None] | None = None,
    **solve_kwargs: Any,
) -> SolveFn:
    """Inner solver wrapping :meth:`formulations.speed_nlp.SpeedNLP.solve` (duck-typed).

    Every solve is warm-started from the best valid solution so far (initially from the warm
    start in ``solve_kwargs``). An outcome is feasible when Ipopt reports success and the largest
    constraint violation is at most ``violation_tol``; applicability, the side each sample is on
    and band violations are re-evaluated at the solution from the NLP's own sample states.

    Parameters
    ----------
    nlp : SpeedNLP
        The built problem.
    violation_tol : float
        Largest accepted constraint violation (scaled rows).
    later : callable, optional
        ``later() -> SpeedNLP``: the instance for every solve after the first (side flips,
        applicability re-checks), e.g. the same problem with an iteration cap so that hopeless
        flips fail fast; called when needed. Default: ``nlp`` throughout.
    gains : callable, optional
        ``gains(result) -> array (N, m, B) or None``: the estimated change of flipping each group from a
        feasible solve (``InnerOutcome.gain``). Default: none (every move is tried).
    release_gains : callable, optional
        ``release_gains(result, side_at_solution) -> array (N, m, B) or None``: the estimated change of releasing
        each group held below a band's threshold (``InnerOutcome.release_gain``). Default: none (every release is
        tried). Both estimates are made only for the solutions the search keeps.
    **solve_kwargs
        ETA, objective, prices and the initial warm start, passed to ``nlp.solve`` (multipliers
        ``lam_x0``/``lam_g0``, if given, to its first solve only).

    Returns
    -------
    callable
        ``solve(sides, applies) -> InnerOutcome`` with arrays of shape (N, m, B).
    """
    lower, upper = nlp.sample_edges()
    kwargs = dict(solve_kwargs)
    best: dict[str, float] = {"objective": float("inf")}
    calls = [0]

    def _side_to_take(st: Any, feasible: bool) -> np.ndarray:
        """The side of each sample at the solution; where the solution entered a band that did not apply at the
        start of the solve (its sea rose above the threshold there), the side of the point the next solve starts
        from, where that point lies outside the band: that point then meets the new row, instead of starting a
        re-solve from a point that breaks it (on a following-seas case of ``bench_bands`` every such re-solve
        ended Infeasible_Problem_Detected and the call returned its start)."""
        side = select_sides(st.ratio, lower, upper)
        if not (feasible and st.inside.any()) or not {"stw0_kn", "time0_h"} <= kwargs.keys():
            return side
        y0 = kwargs.get("offset0_nm")
        at = nlp.evaluate(np.zeros(nlp.n_legs + 1) if y0 is None else y0, kwargs["stw0_kn"], kwargs["time0_h"])
        clear = ~strictly_inside(at.ratio, lower, upper)
        return np.where(st.inside & clear, select_sides(at.ratio, lower, upper), side).astype(np.int8)

    def solve(sides: np.ndarray, applies: np.ndarray) -> InnerOutcome:
        which = nlp if calls[0] == 0 or later is None else later()
        calls[0] += 1
        res = which.solve(sides=sides, applies=applies, **kwargs)
        # a primal-dual warm start's multipliers belong to the first solve's start; later ones start from a solution
        kwargs.pop("lam_x0", None)
        kwargs.pop("lam_g0", None)
        feasible = bool(res.success and res.max_violation <= violation_tol)
        st = res.samples
        take = _side_to_take(st, feasible)
        out = InnerOutcome(
            feasible=feasible,
            objective=float(res.objective) if feasible else float("inf"),
            active=res.band_active,
            weight=np.abs(res.band_multiplier),
            applies=st.applies,
            side_at_solution=take,
            inside=st.inside,
            status=res.status,
            payload=res,
            infeasibility=0.0 if feasible else float(res.max_violation),
            gain=(lambda: gains(res)) if gains is not None and feasible else None,
            release_gain=(lambda: release_gains(res, take)) if release_gains is not None and feasible else None,
        )
        if feasible and not st.inside.any() and res.objective < best["objective"]:
            best["objective"] = float(res.objective)
            kwargs.update(offset0_nm=res.offset_nm, stw0_kn=res.stw_kn, time0_h=res.time_h)
        return out

    return solve


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence C-level writes to stdout (Bonmin's node log ignores its print options)."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), fd)
        try:
            yield
        finally:
            os.dup2(saved, fd)
            os.close(saved)


@dataclass(frozen=True)
class BonminResult:
    """Result of :func:`bonmin_fixed_path` (status verbatim from Bonmin via CasADi)."""

    status: str
    success: bool
    time_h: np.ndarray
    speed_kn: np.ndarray
    sides: np.ndarray
    objective: float
    solve_time_s: float


def bonmin_fixed_path(
    distance_nm: ArrayLike,
    fuel: PowerLawFuel,
    forbidden_kn: ArrayLike,
    *,
    eta_h: float,
    v_min_kn: ArrayLike = 1.0,
    v_max_kn: ArrayLike = 30.0,
) -> BonminResult:
    """Exact fixed-path band problem as a convex MINLP solved by Bonmin (B-BB), big-M in leg time.

    With a binary ``z_ib`` per leg and applicable band, side −1 (``v ≤ a``) is ``t_i ≥ d_i/a − M z``
    and side +1 (``v ≥ b``) is ``t_i ≤ d_i/b + M (1 − z)`` with ``M = d_i/v_min − d_i/v_max``.
    The continuous relaxation is convex (the fuel of :class:`PowerLawFuel` is convex in ``t``), so
    Bonmin's branch and bound returns the global optimum (physics.md §9).

    Parameters
    ----------
    distance_nm, fuel, forbidden_kn
        As for :func:`convex_band_solver`.
    eta_h : float
        Passage time allowed [h] (``Σ t ≤ eta_h``).
    v_min_kn, v_max_kn : float or array_like
        Base speed bounds [kn], ``v_min > 0`` (it bounds the big-M).

    Returns
    -------
    BonminResult
        ``sides`` as +1/−1 per (leg, band) (0 where no band).
    """
    import casadi as ca

    d = as_float_array(distance_nm, "distance_nm", ndim=1)
    n = d.size
    f = _intervals(forbidden_kn, n)
    vmin = broadcast_legs(v_min_kn, n, "v_min_kn")
    vmax = broadcast_legs(v_max_kn, n, "v_max_kn")
    if (vmin <= 0).any():
        raise FormulationInputError("bonmin_fixed_path needs v_min_kn > 0 (it bounds the big-M)")
    coef, p = fuel.for_legs(n), fuel.exponent
    started = time.perf_counter()
    opti = ca.Opti()
    t = opti.variable(n)
    opti.subject_to(opti.bounded(d / vmax, t, d / vmin))
    opti.subject_to(ca.sum1(t) <= eta_h)
    big_m = d / vmin - d / vmax
    zs: dict[tuple[int, int], Any] = {}
    for i, j in zip(*np.nonzero(np.isfinite(f[..., 0]) & np.isfinite(f[..., 1])), strict=True):
        z = opti.variable()
        opti.set_domain(z, "integer")
        opti.subject_to(opti.bounded(0, z, 1))
        a, b = f[i, j]
        opti.subject_to(t[i] >= d[i] / a - big_m[i] * z)
        opti.subject_to(t[i] <= d[i] / b + big_m[i] * (1 - z))
        zs[(int(i), int(j))] = z
    obj = 0
    for jj, pj in enumerate(p):
        obj += ca.sum1(ca.DM(coef[:, jj] * d**pj) * t ** (1.0 - pj))
    opti.minimize(obj)
    opti.set_initial(t, d / np.clip(d.sum() / eta_h, vmin, vmax))
    quiet = {f"bonmin.{k}": 0 for k in ("bb_log_level", "nlp_log_level", "fp_log_level", "lp_log_level")}
    opti.solver("bonmin", {"print_time": False, "bonmin.algorithm": "B-BB", **quiet})
    with _quiet_stdout():
        try:
            sol = opti.solve()
            stats, tv = sol.stats(), np.asarray(sol.value(t), dtype=float).reshape(n)
            zv = {k: float(sol.value(z)) for k, z in zs.items()}
            objective = float(sol.value(obj))
        except RuntimeError:
            stats, tv, zv, objective = opti.stats(), np.full(n, np.nan), {}, float("nan")
    sides = np.zeros(f.shape[:2], dtype=np.int8)
    for (i, j), val in zv.items():
        sides[i, j] = 1 if val > 0.5 else -1
    status = str(stats.get("return_status", "unknown"))
    return BonminResult(
        status=status,
        success=bool(stats.get("success", False)),
        time_h=tv,
        speed_kn=d / tv,
        sides=sides,
        objective=objective,
        solve_time_s=time.perf_counter() - started,
    )
