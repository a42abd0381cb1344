"""Which rows the corridor NLP imposes, on which legs, in which order (issue 13).

:class:`formulations.speed_nlp.SpeedNLP` stacks its constraint rows in blocks (:func:`row_blocks`): time dynamics
(one per leg), engine load (one per sample), danger bands (one per sample and band, band-major), drift and speed over
ground (with a current that can bind them), exclusion circle (one per sample). A band row can bind only where the
band applies (Hs at or above its threshold), an exclusion row only where the circle comes near; elsewhere its bounds
are −∞…+∞ at every solve, yet Ipopt and MUMPS carry it at every iteration. :class:`RowLegs` says which legs carry
the band rows and which the exclusion rows (the caller's knowledge of its weather and circle; default every leg),
and maps per-sample arrays to those rows' order and back. The load, dynamics and current rows stay on every leg.

Nothing here imports :mod:`optroute`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from formulations.common import BELOW_BETA, BELOW_SIDE, Band, FormulationInputError, broadcast_legs

__all__ = [
    "BELOW_MARGIN",
    "RowLegs",
    "leg_kinds",
    "leg_row_numbers",
    "row_blocks",
    "row_bounds",
    "waypoint_time_bounds",
]

BELOW_MARGIN = 1e-6
"""How far below a band's threshold a sample on the side "Hs below the threshold" is kept, relative [-]: so that the
solution lies strictly below it and the band does not apply there (``Hs ≥ hs_min_m`` applies)."""


@dataclass(frozen=True)
class RowLegs:
    """The legs that carry the band rows and the exclusion rows of an NLP of ``n_legs`` legs, ``per_leg`` samples
    each and ``n_bands`` bands.

    A band row of sample ``j`` of leg ``k`` is row ``b·K_b + i·m + j`` of the band block (``i`` the rank of leg ``k``
    among :attr:`band_legs`, ``K_b`` their samples); an exclusion row ``i·m + j`` of the exclusion block.
    """

    band_legs: np.ndarray  # (N,) bool
    exclusion_legs: np.ndarray  # (N,) bool
    per_leg: int
    n_bands: int

    @classmethod
    def of(cls, band_legs: ArrayLike | None, exclusion_legs: ArrayLike | None, n: int, m: int, nb: int) -> RowLegs:
        """Checked masks (None: every leg)."""
        return cls(_mask(band_legs, n, "band_legs"), _mask(exclusion_legs, n, "exclusion_legs"), int(m), int(nb))

    @property
    def band_samples(self) -> np.ndarray:
        """The samples (index k·m + j) that carry band rows."""
        return np.flatnonzero(np.repeat(self.band_legs, self.per_leg))

    @property
    def exclusion_samples(self) -> np.ndarray:
        """The samples (index k·m + j) that carry an exclusion row."""
        return np.flatnonzero(np.repeat(self.exclusion_legs, self.per_leg))

    def select(self, expr: Any, samples: np.ndarray) -> Any:
        """The rows ``samples`` of a (K, c) CasADi expression over every sample (itself when they are all)."""
        return expr if samples.size == self.band_legs.size * self.per_leg else expr[samples.tolist(), :]

    def band_rows_of(self, values: np.ndarray) -> np.ndarray:
        """Per-sample values (N, m, B) in the band rows' order."""
        flat = np.asarray(values).reshape(self.band_legs.size * self.per_leg, self.n_bands)[self.band_samples]
        return np.transpose(flat).ravel()

    def band_samples_of(self, rows: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """The inverse of :meth:`band_rows_of`: band-row values to (N, m, B), ``fill`` on legs without band rows."""
        n, m, nb = self.band_legs.size, self.per_leg, self.n_bands
        out = np.full((n * m, nb), fill, dtype=np.asarray(rows).dtype)
        out[self.band_samples] = np.transpose(np.asarray(rows).reshape(nb, -1))
        return out.reshape(n, m, nb)

    def band_activity(
        self, lam_rows: np.ndarray, g_rows: np.ndarray, sides: np.ndarray, applies: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The band rows' multipliers per sample (N, m, B), 0 where no row is imposed, and where a band row is
        active (an imposed row with a multiplier or at its edge: 0, or −:data:`BELOW_MARGIN` on the side "Hs below
        the threshold"), from the band block's multipliers ``lam_rows`` and values ``g_rows`` at a solution."""
        lam_b = self.band_samples_of(lam_rows)
        res = self.band_samples_of(g_rows, np.inf)
        below = sides == BELOW_SIDE  # "Hs below the threshold": its row's bound is -BELOW_MARGIN
        imposed = applies | below
        edge = np.where(below, -BELOW_MARGIN, 0.0)
        active = imposed & ((np.abs(lam_b) > 1e-8) | (np.abs(res - edge) < 1e-6))
        return np.where(imposed, lam_b, 0.0), active

    def exclusion_samples_of(self, rows: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """Exclusion-row values to (N, m), ``fill`` on legs without exclusion rows."""
        out = np.full(self.band_legs.size * self.per_leg, fill, dtype=np.asarray(rows).dtype)
        out[self.exclusion_samples] = rows
        return out.reshape(self.band_legs.size, self.per_leg)

    def band_edges(
        self,
        bands: tuple[Band, ...],
        sides: np.ndarray,
        applies: np.ndarray,
        *,
        edges: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The band-edge parameter ``beta`` (N·m·B, band-major over every sample) and the band rows' lower and upper
        bounds for ``sides`` (−1: ``ratio ≤ lower``, +1: ``ratio ≥ upper``, :data:`~formulations.common.BELOW_SIDE`:
        ``Hs < hs_min_m``) and ``applies``, both (N, m, B).

        A band is imposed where it applies on the legs that carry its rows; on the others it is not (the caller
        leaves a leg out only where no band can apply). A sample on the :data:`~formulations.common.BELOW_SIDE`
        keeps the sea below the band's threshold by :data:`BELOW_MARGIN` (relative) wherever its leg carries the
        band's rows, and must not be one where the band applies. ``edges``: every sample's lower and upper edge,
        (N, m, B) each (default the bands' own)."""
        n, m, nb = self.band_legs.size, self.per_leg, self.n_bands
        side_arr = np.asarray(sides).astype(np.int8)
        app_arr = np.asarray(applies, dtype=bool)
        if side_arr.shape != (n, m, nb) or app_arr.shape != (n, m, nb):
            raise FormulationInputError(
                f"sides and applies must have shape {(n, m, nb)}, got {side_arr.shape} and {app_arr.shape}"
            )
        if not nb:
            return np.zeros(0), np.zeros(0), np.zeros(0)
        if not np.isin(side_arr, (-1, 1, BELOW_SIDE)).all():
            raise FormulationInputError(
                f"sides must be -1 (ratio <= lower), +1 (ratio >= upper) or {BELOW_SIDE} (Hs below the threshold)"
            )
        below = side_arr == BELOW_SIDE
        if (below & app_arr).any():
            k, j, b = np.argwhere(below & app_arr)[0]
            raise FormulationInputError(
                f"band {bands[b].name or b} applies at leg {k}, sample {j}, whose side is 'Hs below the threshold'; "
                "give it side -1 or +1"
            )
        hs_min = np.array([b.hs_min_m for b in bands])
        if (below & ~(hs_min > 0.0)[None, None, :]).any():
            raise FormulationInputError("the side 'Hs below the threshold' needs a band with hs_min_m > 0")
        if edges is None:
            lower = np.broadcast_to(np.array([b.lower for b in bands], dtype=float), side_arr.shape)
            upper = np.broadcast_to(np.array([b.upper for b in bands], dtype=float), side_arr.shape)
        else:
            lower, upper = edges
        beta3 = np.where(side_arr < 0, lower, upper)
        app_arr = app_arr & self.band_legs[:, None, None]
        bad = app_arr & ~np.isfinite(beta3)
        if bad.any():
            k, j, b = np.argwhere(bad)[0]
            raise FormulationInputError(
                f"band {bands[b].name or b} has no side {int(side_arr[k, j, b])} (its edge is infinite): "
                f"leg {k}, sample {j}"
            )
        beta3 = np.where(below, BELOW_BETA, np.where(np.isfinite(beta3), beta3, 0.0))
        beta = np.transpose(beta3.reshape(n * m, nb)).ravel()
        s_flat, a_flat = self.band_rows_of(side_arr), self.band_rows_of(app_arr)
        lo = np.where(a_flat & (s_flat > 0), 0.0, -np.inf)
        hi = np.where(a_flat & (s_flat < 0), 0.0, np.where(s_flat == BELOW_SIDE, -BELOW_MARGIN, np.inf))
        return beta, lo, hi


def _mask(legs: ArrayLike | None, n: int, name: str) -> np.ndarray:
    if legs is None:
        return np.ones(n, dtype=bool)
    out = np.asarray(legs)
    if out.shape != (n,) or out.dtype != bool:
        raise FormulationInputError(f"{name} must be a bool array of shape ({n},), got {out.dtype} {out.shape}")
    return out.copy()


def leg_kinds(legs: RowLegs, has_excl: bool) -> list[tuple[np.ndarray, bool, bool]]:
    """The legs grouped by the rows they carry: (leg indices, band rows, exclusion rows), non-empty groups only
    (one group of every leg when every leg carries every row)."""
    with_b = legs.band_legs & (legs.n_bands > 0)
    with_e = legs.exclusion_legs & has_excl
    out = []
    for b in (True, False):
        for e in (True, False):
            ks = np.flatnonzero((with_b == b) & (with_e == e))
            if ks.size:
                out.append((ks, b, e))
    return out


def leg_row_numbers(
    rows: dict[str, tuple[int, int]], legs: RowLegs, ks: np.ndarray, with_b: bool, with_e: bool
) -> np.ndarray:
    """The global numbers (n_gl, n_k) of the rows of the legs ``ks``, in a leg's order: dynamics, m loads, per band
    m residuals (``with_b``), m drifts and m SOGs (when ``rows`` has them), m exclusion residuals (``with_e``)."""
    m = legs.per_leg
    idx = [rows["dyn"][0] + ks]
    idx += [rows["load"][0] + ks * m + j for j in range(m)]
    if with_b:
        rank, k_b = np.cumsum(legs.band_legs)[ks] - 1, int(np.sum(legs.band_legs)) * m
        idx += [rows["band"][0] + b * k_b + rank * m + j for b in range(legs.n_bands) for j in range(m)]
    if "drift" in rows:
        idx += [rows["drift"][0] + ks * m + j for j in range(m)]
        idx += [rows["sog"][0] + ks * m + j for j in range(m)]
    if with_e:
        rank = np.cumsum(legs.exclusion_legs)[ks] - 1
        idx += [rows["excl"][0] + rank * m + j for j in range(m)]
    return np.vstack(idx)


def row_blocks(mdl: dict[str, Any], t: Any, *, bands: bool, current: bool, exclusion: bool) -> tuple[list[Any], dict]:
    """The corridor NLP's constraint blocks in their order, and each block's (first, end) row.

    Time dynamics, engine load, band residuals (``bands``), drift and speed over ground (``current``),
    exclusion (``exclusion``) — from :meth:`SpeedNLP.symbolic_model`'s expressions ``mdl`` and the arrival
    times ``t``; shared by the single-weather and the ensemble (member) NLPs.
    """
    parts: list[Any] = []
    rows: dict[str, tuple[int, int]] = {}

    def add(name: str, expr: Any) -> None:
        start = sum(p.shape[0] for p in parts)
        rows[name] = (start, start + expr.shape[0])
        parts.append(expr)

    add("dyn", (t[1:] - t[:-1]) - mdl["dt_leg"])
    add("load", mdl["load"])
    if bands:
        add("band", mdl["band_res"])
    if current:
        add("drift", mdl["h_perp"])
        add("sog", mdl["sog"])
    if exclusion:
        add("excl", mdl["excl_res"])
    return parts, rows


def row_bounds(
    rows: dict[str, tuple[int, int]],
    n_rows: int,
    power: Any,
    *,
    band: tuple[Any, Any] | None,
    sog_min_kn: float | None,
    exclusion: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of :func:`row_blocks`' rows: the dynamics equal 0, the engine load in
    [``power.min_load``, ``power.max_load``], the band residuals in ``band`` (lower, upper; None: no band rows),
    the drift angle within 60° (``|sin| ≤ √0.75``) and SOG ≥ ``sog_min_kn`` [kn] (None: no current rows), the
    exclusion residuals ≥ 0. Rows past the blocks (``n_rows`` beyond the last block: a caller's own rows) are 0."""
    lbg, ubg = np.zeros(n_rows), np.zeros(n_rows)

    def set_rows(name: str, lo: Any, hi: Any) -> None:
        a, b = rows[name]
        lbg[a:b], ubg[a:b] = lo, hi

    set_rows("load", power.min_load, power.max_load)
    if band is not None:
        set_rows("band", *band)
    if sog_min_kn is not None:
        set_rows("drift", -np.sqrt(0.75), np.sqrt(0.75))
        set_rows("sog", sog_min_kn, np.inf)
    if exclusion:
        set_rows("excl", 0.0, np.inf)
    return lbg, ubg


def waypoint_time_bounds(
    n: int, eta_h: float | None, eta_mode: str, time_lo_h: ArrayLike | None, time_hi_h: ArrayLike | None
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds on the ``n + 1`` waypoint times [h since departure]: departure at 0, arrival by (``"le"``) or at
    (``"eq"``) ``eta_h``, and the caller's windows ``time_lo_h`` / ``time_hi_h`` (−inf / inf where none).

    Raises
    ------
    FormulationInputError
        A window holds NaN, or a waypoint's bounds are empty.
    """
    t_lo = np.zeros(n + 1)
    t_hi = np.full(n + 1, np.inf)
    t_hi[0] = 0.0
    if eta_h is not None:
        t_hi[n] = eta_h
        if eta_mode == "eq":
            t_lo[n] = eta_h
    if time_lo_h is not None:
        t_lo = np.maximum(t_lo, broadcast_legs(time_lo_h, n + 1, "time_lo_h", finite=False))
    if time_hi_h is not None:
        t_hi = np.minimum(t_hi, broadcast_legs(time_hi_h, n + 1, "time_hi_h", finite=False))
    if np.any(np.isnan(t_lo) | np.isnan(t_hi)):
        raise FormulationInputError("time_lo_h / time_hi_h hold NaN; give -inf / inf where a waypoint has no bound")
    if np.any(t_lo > t_hi):
        k = int(np.argmax(t_lo > t_hi))
        raise FormulationInputError(
            f"waypoint {k}'s time bounds are empty: {t_lo[k]:.6g} h > {t_hi[k]:.6g} h (time_lo_h / time_hi_h "
            "against departure and the ETA); relax the time windows or give a later ETA"
        )
    return t_lo, t_hi
