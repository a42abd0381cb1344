"""Sailing a plan: a voyage simulator that re-plans on each new forecast (issue 16).

:func:`simulate_voyage` sails a ship through a "truth" weather with the true performance model
and the danger bands, in time steps, receiving forecasts as they are issued and re-planning
with :func:`optroute.plan_voyage` under a :class:`ReplanPolicy` (Boeing EP 2145155: re-plan
"periodically, or when a new forecast arrives"; Życkowski: when the weather met differs from the
forecast used). It returns a :class:`VoyageResult`: the voyage log (an ``xarray.Dataset``) and the
:class:`VoyageOutcome`. With an :class:`OnboardObserver` the simulated ship also runs the
parametric-roll observer of thyssenkrupp EP 2377756 on its simulated motions and acts on its
alarms (:mod:`optroute.voyage.onboard`).
"""

from optroute.voyage.onboard import OnboardObserver
from optroute.voyage.policy import ForecastSequence, ForecastTimeError, ReplanPolicy, VoyageOutcome
from optroute.voyage.simulate import VoyageError, VoyageResult, simulate_voyage

__all__ = [
    "ForecastSequence",
    "ForecastTimeError",
    "OnboardObserver",
    "ReplanPolicy",
    "VoyageError",
    "VoyageOutcome",
    "VoyageResult",
    "simulate_voyage",
]
