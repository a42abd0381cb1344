"""What each status the ``optroute`` commands print means for the user, in one short sentence.

A plan's :attr:`~optroute.plan.result.Plan.status` says how the optimiser ended (``optimal``,
``feasible``, ``minimum time``); a front's or a study's rows add ``infeasible: …`` and
``solver failure: …`` (:mod:`optroute.studies.tradeoff`, :mod:`optroute.studies.voyage_study`),
and a study's engine ``ok`` / ``failed: …`` (:mod:`optroute.studies.study`).  The first word
(before a ``:`` or ``;``) selects the explanation; Ipopt's own status, when known, says why a
plan is only ``feasible``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

#: Ipopt's status (its ``return_status``) → why it stopped short of a converged optimum.
_IPOPT_STOPS = {
    "Maximum_Iterations_Exceeded": "Ipopt stopped at its iteration limit",
    "Maximum_CpuTime_Exceeded": "Ipopt stopped at its CPU-time limit",
    "Maximum_WallTime_Exceeded": "Ipopt stopped at its wall-time limit",
    "Solved_To_Acceptable_Level": "Ipopt stopped at its looser 'acceptable' tolerance",
}

_GOAL = {"fuel": "least-fuel", "time": "fastest", "cost": "least-cost"}


def status_key(status: str) -> str:
    """The status's first word(s), before a ``:`` or ``;``: ``"infeasible: earliest …"`` → ``"infeasible"``."""
    return re.split(r"[:;]", str(status), maxsplit=1)[0].strip()


def explain_status(status: str, *, ipopt_status: str | None = None, objective: str = "fuel") -> str:
    """A short sentence saying what ``status`` means for the user.

    Parameters
    ----------
    status : str
        A plan's, a front point's or a study case's status as printed.
    ipopt_status : str, optional
        Ipopt's ``return_status`` for the plan (``plan.solver_stats["ipopt_status"]``).
    objective : {"fuel", "time", "cost"}
        What the plan minimises, to say what a ``feasible`` plan is not proven to be.

    Returns
    -------
    str
        The explanation; for a status this module does not know, says so rather than guess.
    """
    text = _explain_key(status, ipopt_status, objective)
    if RESOLVED in str(status):
        text += (
            "; this ETA's first solve, from its neighbour, ended above an earlier ETA's fuel, so it was solved once "
            "more from that ETA's plan (which also arrives in time): this is that solve, the first one's fuel is "
            "own_fuel_t"
        )
    return text


#: What a front point's status says when its first solve rose and it was solved again from an earlier ETA's plan.
RESOLVED = "solved again from the plan of the earlier ETA"


def _explain_key(status: str, ipopt_status: str | None, objective: str) -> str:
    """:func:`explain_status` of the status's key alone."""
    goal = _GOAL.get(objective, f"least-{objective}")
    key = status_key(status)
    if key == "optimal":
        if "the plan of the earlier ETA" in str(status) and RESOLVED not in str(status):
            return (
                "this ETA's own solve burnt more fuel than an earlier ETA's plan, which also arrives in time, "
                "so that verified plan is kept (the own solve's fuel is own_fuel_t): the front never rises"
            )
        return (
            "Ipopt converged to a local optimum for the chosen side of each danger band, and the plan verifies "
            "against every constraint"
        )
    if key == "feasible":
        if "fastest verified plan known" in str(status):
            return (
                "the minimum-time solve failed, so the front starts from the fastest verified plan known "
                "(an upper bound on the earliest arrival, not proven fastest)"
            )
        why = _IPOPT_STOPS.get(
            str(ipopt_status), "Ipopt stopped before converging (an iteration or time limit, or its looser tolerance)"
        )
        return f"{why} at a point that verifies; the plan is safe but not proven {goal}"
    if key == "sides_unsettled":
        return (
            "Ipopt converged and the plan verifies, but the search over the danger-band sides stopped on its "
            f"solve budget (band_solves): safe, not proven {goal} over every side"
        )
    if key == "mended":
        return (
            "Ipopt converged, but between its check points the referee found the engine just outside its range "
            "(the smooth power table cannot follow the model's steps), so the speeds of those legs were moved to "
            f"the limit by the propeller law; the plan verifies: safe, not proven {goal}"
        )
    if key == "start":
        return (
            "the NLP did not improve on its best verified start (a search route, the 3-D DP, the ship's dual "
            f"schedule or the centreline start), so that start is returned: safe, not proven {goal}"
        )
    if key == "minimum time":
        return "the fastest verified passage known, kept because the requested ETA could not be optimised"
    if key == "infeasible":
        return "no verified passage arrives by this ETA (the earliest arrival is given when known)"
    if key == "solver failure":
        return "Ipopt found no verified plan for this ETA (its status follows); nothing is kept for it"
    if key == "ok":
        return "the case ran and is stored"
    if key == "failed":
        return "the case raised an error, stored with its message; run again with the fix to retry it"
    if key in ("missing", ""):
        return "no result is stored for these cases"
    return "a status this version of optroute does not explain"


def status_legend(statuses: Iterable[str], *, objective: str = "fuel", indent: str = "  ") -> list[str]:
    """One ``<status>: <meaning>`` line per distinct status key, in first-seen order."""
    seen: dict[str, str] = {}
    for status in statuses:
        key = status_key(status) or "missing"
        if RESOLVED in str(status):
            key = f"{key}; {RESOLVED}"
        elif key == "optimal" and "earlier ETA" in str(status):
            key = "optimal; the plan of the earlier ETA"
        elif key == "feasible" and "fastest verified plan known" in str(status):
            key = "feasible: fastest verified plan known"
        if key not in seen:
            seen[key] = explain_status(status, objective=objective)
    return [f"{indent}{key}: {text}" for key, text in seen.items()]


__all__ = ["explain_status", "status_key", "status_legend"]
