"""The results of the corridor NLP (:class:`formulations.speed_nlp.SpeedNLP`): per-sample conditions and a solve.

Split out of :mod:`formulations.speed_nlp` to keep modules short; both names are re-exported there.
Units: hours [h], nautical miles [nm], knots [kn], metres [m], seconds [s], kilowatts [kW], tonnes [t].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["NLPResult", "SampleState", "max_violation"]


@dataclass(frozen=True)
class SampleState:
    """Conditions and derived quantities at every sample, arrays of shape (n_legs, m) (bands: (n_legs, m, n_bands)).

    Attributes
    ----------
    time_h, s_nm, y_nm : numpy.ndarray
        Time since departure [h] and corridor coordinates [nm] of the sample.
    x_nm, y_flat_nm : numpy.ndarray
        Position in the flat frame [nm].
    hs_m, period_s : numpy.ndarray
        Significant wave height [m] and wave period [s] interpolated there.
    sog_kn, power_kw, load, fuel_rate_tph : numpy.ndarray
        Speed over ground [kn], brake power [kW], engine load P/MCR [-], fuel rate [t/h].
    cos_chi : numpy.ndarray
        cos of the angle between heading and wave propagation [-] (1 = following sea).
    dev_deg : numpy.ndarray
        Heading minus the centreline direction [deg, to port +] (the power table's heading axis).
    ratio : numpy.ndarray, shape (n_legs, m, n_bands)
        Band ratios (see :class:`formulations.common.Band`).
    applies : numpy.ndarray of bool, shape (n_legs, m, n_bands)
        ``hs_m ≥ band.hs_min_m`` at this sample.
    inside : numpy.ndarray of bool, shape (n_legs, m, n_bands)
        ``applies`` and ``lower + ε < ratio < upper − ε`` (ε = 1e-6 · max(1, |lower|), the solver tolerance).
    exclusion_margin_nm : numpy.ndarray
        Distance to the moving exclusion circle's edge [nm] (> 0 outside; +inf without one).
    outside_grid : numpy.ndarray of bool
        The sample lies outside the weather grid (the interpolant extrapolates).
    """

    time_h: np.ndarray
    s_nm: np.ndarray
    y_nm: np.ndarray
    x_nm: np.ndarray
    y_flat_nm: np.ndarray
    hs_m: np.ndarray
    period_s: np.ndarray
    sog_kn: np.ndarray
    power_kw: np.ndarray
    load: np.ndarray
    fuel_rate_tph: np.ndarray
    cos_chi: np.ndarray
    dev_deg: np.ndarray
    ratio: np.ndarray
    applies: np.ndarray
    inside: np.ndarray
    exclusion_margin_nm: np.ndarray
    outside_grid: np.ndarray


@dataclass(frozen=True)
class NLPResult:
    """Solution of :meth:`SpeedNLP.solve`.

    Attributes
    ----------
    status : str
        Ipopt's ``return_status``, verbatim (``"Solve_Succeeded"``, ``"Infeasible_Problem_Detected"``...).
    success : bool
        CasADi's ``stats()["success"]``.
    iterations : int
        Ipopt iterations.
    solve_time_s : float
        Wall-clock time of the Ipopt call [s].
    objective : float
        Optimal objective: fuel [t], time [h] or cost [currency].
    offset_nm : numpy.ndarray, shape (N+1,)
        Lateral offsets ``y_k`` [nm].
    position_xy_nm : numpy.ndarray, shape (N+1, 2)
        Waypoints in the flat frame [nm].
    stw_kn : numpy.ndarray, shape (N,)
        Speed through water per leg [kn].
    time_h : numpy.ndarray, shape (N+1,)
        Arrival time at every waypoint [h since departure].
    distance_nm, duration_h, fuel_t : numpy.ndarray, shape (N,)
        Leg length [nm], duration [h], fuel [t].
    total_fuel_t, duration_total_h : float
        Voyage fuel [t] and passage time [h].
    eta_multiplier : float
        ``-d(objective*)/d(T_eta)``, Ipopt's multiplier of the ETA bound; for ``"fuel"``
        the fuel saved per extra hour of passage [t/h]. 0 without an active ETA.
    band_multiplier : numpy.ndarray, shape (N, m, B)
        Multipliers of the band constraints (0 where not imposed) [objective units per unit ratio·scale].
    band_active : numpy.ndarray of bool, shape (N, m, B)
        Band constraint imposed and binding (|multiplier| > 1e-8 or the row within 1e-6 of its bound: the ratio at
        its edge, or on the side "Hs below the threshold" the sea at it).
    sides, applies : numpy.ndarray, shape (N, m, B)
        The side (−1 / +1, or :data:`formulations.common.BELOW_SIDE`) and applicability used in this solve.
    samples : SampleState
        Per-sample conditions at the solution (re-evaluated, for the outer loop and reports).
    max_violation : float
        Largest constraint violation at the returned point (scaled units of each row).
    """

    status: str
    success: bool
    iterations: int
    solve_time_s: float
    objective: float
    offset_nm: np.ndarray
    position_xy_nm: np.ndarray
    stw_kn: np.ndarray
    time_h: np.ndarray
    distance_nm: np.ndarray
    duration_h: np.ndarray
    fuel_t: np.ndarray
    total_fuel_t: float
    duration_total_h: float
    eta_multiplier: float
    band_multiplier: np.ndarray
    band_active: np.ndarray
    sides: np.ndarray
    applies: np.ndarray
    samples: SampleState
    max_violation: float
    x_opt: np.ndarray = field(repr=False)
    lam_x: np.ndarray = field(repr=False)
    lam_g: np.ndarray = field(repr=False)


def max_violation(
    x: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, g: np.ndarray, lbg: np.ndarray, ubg: np.ndarray
) -> float:
    """The largest violation of a solution: of the variables ``x`` outside ``[lbx, ubx]`` and of the rows ``g``
    outside ``[lbg, ubg]`` (each in its own unit; 0 when every bound holds)."""
    return max(
        float(np.max(np.concatenate([[0.0], lbg - g, g - ubg]))),
        float(np.max(np.concatenate([[0.0], lbx - x, x - ubx]))),
    )
