"""How many ensemble members each plan would have violated (issue 16 item 3, the studies' report).

:func:`member_violations` sails every plan's track and speeds through water in every member of an ensemble
(:meth:`Plan.verify(weather=member) <optroute.plan.result.Plan.verify>`: the referee of the plan, with the plan's
own ship, rules, corridor, ETA and exclusion) and tabulates, per plan, the members it breaks a constraint in,
which constraints, and its fuel and arrival over the members. A plan planned on the ensemble mean, on one member
or robustly on all of them (``optimise_corridor(..., robust="all")``) are compared on the same footing.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
import xarray as xr

from optroute.errors import ConfigError
from optroute.optimise.robust import cvar, member_datasets
from optroute.plan.result import Plan
from optroute.units import timedelta_to_h

__all__ = ["member_violations"]


def member_violations(
    plans: Mapping[str, Plan],
    ensemble: xr.Dataset,
    *,
    step_nm: float = 5.0,
    cvar_alpha: float = 0.9,
) -> pd.DataFrame:
    """Per plan: the members of ``ensemble`` it would have violated, and its fuel and arrival over them.

    Parameters
    ----------
    plans : mapping of str to Plan
        Label → plan (each verified in its own weather or not: it is re-checked in every member).
    ensemble : xarray.Dataset
        Canonical weather with a ``member`` dimension (:func:`optroute.weather.scenarios.ensemble`).
    step_nm : float
        Longest piece of the referee's dense evaluation [nm] (:meth:`Plan.verify`).
    cvar_alpha : float
        Level in [0, 1) of the fuel's CVaR over the members (:func:`optroute.optimise.robust.cvar`).

    Returns
    -------
    pandas.DataFrame
        Indexed by plan label: ``members`` (M), ``members_violated`` (how many members it breaks a constraint
        in), ``violated_members`` (their indices, comma-separated), ``kinds`` (the kinds of violation met,
        e.g. ``band:surf_riding``, ``power_above_mcr``, ``eta``, comma-separated), ``fuel_mean_t``,
        ``fuel_max_t``, ``fuel_cvar_t`` [t] (true model, every member), ``latest_arrival_h`` [h after
        departure].

    Raises
    ------
    ConfigError
        No plans, a value that is not a Plan, or ``ensemble`` without a ``member`` dimension.
    """
    if not plans:
        raise ConfigError("member_violations: no plans given; pass a mapping of label -> Plan")
    bad = [k for k, p in plans.items() if not isinstance(p, Plan)]
    if bad:
        raise ConfigError(f"member_violations: {bad} are not optroute Plans; pass a mapping of label -> Plan")
    members = member_datasets(ensemble)
    rows = []
    for label, plan in plans.items():
        violated, kinds, fuel, arrival = [], set(), [], []
        for k, m in enumerate(members):
            sailed = plan.in_weather(m, step_nm=step_nm)
            found = sailed.verify(step_nm=step_nm)
            if found:
                violated.append(k)
                kinds.update(v.kind for v in found)
            fuel.append(sailed.total_fuel_t)
            arrival.append(timedelta_to_h(sailed.arrival - sailed.departure))
        f = np.asarray(fuel)
        rows.append(
            {
                "plan": label,
                "members": len(members),
                "members_violated": len(violated),
                "violated_members": ",".join(str(k) for k in violated),
                "kinds": ",".join(sorted(kinds)),
                "fuel_mean_t": float(f.mean()),
                "fuel_max_t": float(f.max()),
                "fuel_cvar_t": cvar(f, cvar_alpha),
                "latest_arrival_h": float(np.max(arrival)),
            }
        )
    return pd.DataFrame(rows).set_index("plan")
