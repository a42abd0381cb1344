"""Ipopt's options for the corridor NLPs and the checked multipliers of a primal-dual warm start (the NLP's leg
functions compiled to C: :mod:`formulations.compiled`).

:data:`IPOPT_DEFAULTS` are the options of every corridor NLP (:class:`formulations.speed_nlp.SpeedNLP`,
:mod:`formulations.robust_nlp`); :data:`PRIMAL_START_OPTIONS` are laid over them for SpeedNLP's solves from a start
point alone, :data:`WARM_START_OPTIONS` for a solve started from another solve's point and multipliers
(:func:`checked_duals`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from formulations.common import FormulationInputError

__all__ = [
    "IPOPT_DEFAULTS",
    "PRIMAL_START_OPTIONS",
    "WARM_START_OPTIONS",
    "checked_duals",
]

IPOPT_DEFAULTS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.tol": 1e-9,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.max_iter": 500,
    "ipopt.linear_solver": "mumps",
    "ipopt.mu_strategy": "adaptive",
    "ipopt.bound_relax_factor": 0.0,
    # no gradient of the Lagrangian in CasADi's Nlpsol (Ipopt returns the bound multipliers lam_x itself, and
    # nothing reads the parameters' lam_p): building it differentiates the whole graph by reverse mode at
    # construction, through the weather splines, which was most of a build's time on a corridor's grid
    "calc_lam_p": False,
    "no_nlp_grad": True,
}
#: Ipopt options of :class:`formulations.speed_nlp.SpeedNLP`'s solves from a start point without multipliers (its
#: ``x0``: in the corridor solver a verified discrete plan): a monotone barrier from ``mu_init`` 1e-4 instead of the
#: adaptive one from Ipopt's 0.1. From a lattice plan the adaptive barrier falls to about 1e-11 within a few
#: iterations and then creeps along the bounds under a regularised (indefinite) Hessian on long corridors; the
#: monotone barrier keeps the iterates central while the lateral offsets and speeds leave the lattice's plan
#: (``python -m benchmarks.bench_nlp --scaling`` measures the whole call).
PRIMAL_START_OPTIONS: dict[str, Any] = {
    "ipopt.mu_strategy": "monotone",
    "ipopt.mu_init": 1e-4,
}
#: Ipopt options of a primal-dual warm start (:meth:`formulations.speed_nlp.SpeedNLP.solve` with ``lam_x0``/``lam_g0``): the given point
#: and multipliers are pushed only 1e-6 into the bounds' interior (Ipopt's defaults, 1e-3 for the warm start and
#: 1e-2 for a cold one, move a converged neighbour's iterate off its active bounds).  The barrier is Ipopt's adaptive
#: one here, not :data:`PRIMAL_START_OPTIONS`' monotone one: Ipopt reads ``mu_init`` only with
#: ``mu_strategy="monotone"`` (Ipopt's options reference), and a monotone barrier started small from a neighbouring
#: ETA's point and multipliers takes more iterations, not fewer, because that point is not on the new problem's
#: central path.
WARM_START_OPTIONS: dict[str, Any] = {
    "ipopt.mu_strategy": "adaptive",
    "ipopt.warm_start_init_point": "yes",
    "ipopt.warm_start_bound_push": 1e-6,
    "ipopt.warm_start_bound_frac": 1e-6,
    "ipopt.warm_start_slack_bound_push": 1e-6,
    "ipopt.warm_start_slack_bound_frac": 1e-6,
    "ipopt.warm_start_mult_bound_push": 1e-6,
}


def checked_duals(lam_x0: ArrayLike | None, lam_g0: ArrayLike | None, nx: int, ng: int) -> dict[str, np.ndarray]:
    """The multipliers of a primal-dual warm start as ``nlpsol`` takes them (``{}`` without them).

    Parameters
    ----------
    lam_x0, lam_g0 : array_like or None
        Multipliers of the ``nx`` variable bounds and of the ``ng`` rows [objective units per unit of the
        variable or row]; both or neither.
    nx, ng : int
        The problem's numbers of variables and rows.
    """
    if lam_x0 is None and lam_g0 is None:
        return {}
    if lam_x0 is None or lam_g0 is None:
        raise FormulationInputError("a primal-dual warm start needs both lam_x0 and lam_g0; give both or neither")
    lam_x = np.asarray(lam_x0, dtype=float).ravel()
    lam_g = np.asarray(lam_g0, dtype=float).ravel()
    if lam_x.size != nx or lam_g.size != ng or not (np.isfinite(lam_x).all() and np.isfinite(lam_g).all()):
        raise FormulationInputError(
            f"lam_x0 ({lam_x.size} values) and lam_g0 ({lam_g.size}) must be finite, of {nx} and {ng} values: the "
            "multipliers of a problem with the same dual_key()"
        )
    return {"lam_x0": lam_x, "lam_g0": lam_g}
