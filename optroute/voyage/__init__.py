"""Sailing a plan: a voyage simulator that re-plans on each new forecast (issue 16).

:func:`simulate_voyage` sails a ship through a "truth" weather with the true performance model
and the danger bands, in time steps, receiving forecasts as they are issued and re-planning
with :func:`optroute.plan_voyage` under a :class:`ReplanPolicy` (Boeing EP 2145155: re-plan
"periodically, or when a new forecast arrives"; Życkowski: when the weather met differs from the
forecast used). It returns a :class:`VoyageResult`: the voyage log (an ``xarray.Dataset``) and the
:class:`VoyageOutcome`. With an :class:`OnboardObserver` the simulated ship also runs the
parametric-roll observer of thyssenkrupp EP 2377756 on its simulated motions and acts on its
alarms (:mod:`optroute.voyage.onboard`). With a :class:`CycloneWatch` every plan keeps out of the
cyclone's R + margin of the track known then, and the outcome reports the closest approach to the
true centre (:mod:`optroute.voyage.cyclone`). :func:`simulate_sailing` sails a yacht by its polar
and re-plans with the sailing search when the wind met departs from the forecast
(:mod:`optroute.voyage.sailing_sim`).
"""

from optroute.voyage.cyclone import CycloneWatch
from optroute.voyage.onboard import OnboardObserver
from optroute.voyage.policy import ForecastSequence, ForecastTimeError, ReplanPolicy, VoyageOutcome
from optroute.voyage.sailing_sim import SailingOutcome, SailingVoyage, simulate_sailing
from optroute.voyage.simulate import VoyageError, VoyageResult, simulate_voyage

__all__ = [
    "CycloneWatch",
    "SailingOutcome",
    "SailingVoyage",
    "simulate_sailing",
    "ForecastSequence",
    "ForecastTimeError",
    "OnboardObserver",
    "ReplanPolicy",
    "VoyageError",
    "VoyageOutcome",
    "VoyageResult",
    "simulate_voyage",
]
