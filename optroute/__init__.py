"""optroute: ship voyage optimisation through forecast weather.

A discrete route search fixes a corridor through the forecast; a CasADi/Ipopt
NLP then optimises the speed and heading along it for time, fuel or cost,
subject to the ETA, the engine's MCR and the wave-encounter danger bands of
IMO MSC.1/Circ.1228 and Boeing's EP 2145155.

The package follows the pipeline (``docs/design.md`` draws the layers, which
import-linter enforces): :mod:`optroute.physics` → :mod:`optroute.weather` →
:mod:`optroute.geo` → :mod:`optroute.search` → :mod:`optroute.plot` /
:mod:`optroute.plan` → :mod:`optroute.optimise` → :mod:`optroute.voyage` → :mod:`optroute.studies` →
:mod:`optroute.cli`.

The public names below are loaded on first use (PEP 562), so ``import optroute``
and ``optroute --help`` do not wait for CasADi, CVXPY, matplotlib or Dask.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from optroute import _numba
from optroute._version import __version__
from optroute.errors import (
    ConfigError,
    InfeasibleETA,
    NoSafePassage,
    OnLandError,
    OptrouteError,
    SeaStateError,
    ShipSpecError,
    SolverFailure,
    WeatherCoverageError,
    WeatherSchemaError,
)

# Before any kernel module is imported: numba refuses to import a cache=True kernel when it can write
# no cache folder (issue 14, failure 8); this points it at one of the user's own (optroute._numba).
_numba.ensure_cache_dir()

#: Public name → the module that defines it (imported when the name is first used).
_LAZY: dict[str, str] = {
    "optimise_corridor": "optroute.optimise.api",
    "plan_voyage": "optroute.optimise.api",
    "refine_sailing_route": "optroute.optimise.sailing",
    "CalmWaterModel": "optroute.physics.performance",
    "KwonModel": "optroute.physics.performance",
    "PerformanceModel": "optroute.physics.performance",
    "PowerTableModel": "optroute.physics.performance",
    "Exclusion": "optroute.plan.result",
    "Plan": "optroute.plan.result",
    "PlanContext": "optroute.plan.result",
    "Violation": "optroute.plan.result",
    "Corridor": "optroute.search.route",
    "Route": "optroute.search.route",
    "search_route": "optroute.search.routing",
    "BandRules": "optroute.physics.safety",
    "ForbiddenInterval": "optroute.physics.safety",
    "band_margins": "optroute.physics.safety",
    "forbidden_speed_intervals": "optroute.physics.safety",
    "Ship": "optroute.physics.ship",
    "Polar": "optroute.physics.polar",
    "read_polar": "optroute.physics.polar",
    "write_polar": "optroute.physics.polar",
    "SailingVessel": "optroute.physics.yacht",
    "SailingGrid": "optroute.search.sailing",
    "SailingRoute": "optroute.search.sailing",
    "StudyError": "optroute.studies.study",
    "SchedulerUnreachable": "optroute.studies.study",
    "load_study": "optroute.studies.study",
    "run_study": "optroute.studies.study",
    "TradeoffFront": "optroute.studies.tradeoff",
    "tradeoff": "optroute.studies.tradeoff",
    "study": "optroute.studies.voyage_study",
    "member_violations": "optroute.studies.ensemble_check",
    "apf_avoidance": "optroute.voyage.apf",
    "read_track": "optroute.weather.cyclone_tracks",
    "ReplanPolicy": "optroute.voyage",
    "OnboardObserver": "optroute.voyage",
    "VoyageOutcome": "optroute.voyage",
    "simulate_voyage": "optroute.voyage",
    "WeatherSampler": "optroute.weather",
    "load_weather": "optroute.weather",
    "open_weather": "optroute.weather",
    "open_forecasts": "optroute.weather",
    "scenarios": "optroute.weather",
}

if TYPE_CHECKING:  # what the lazy names resolve to, for type checkers and IDEs
    from optroute.optimise.api import optimise_corridor, plan_voyage
    from optroute.optimise.sailing import refine_sailing_route
    from optroute.physics.performance import CalmWaterModel, KwonModel, PerformanceModel, PowerTableModel
    from optroute.physics.polar import Polar, read_polar, write_polar
    from optroute.physics.safety import BandRules, ForbiddenInterval, band_margins, forbidden_speed_intervals
    from optroute.physics.ship import Ship
    from optroute.physics.yacht import SailingVessel
    from optroute.plan.result import Exclusion, Plan, PlanContext, Violation
    from optroute.search.route import Corridor, Route
    from optroute.search.routing import search_route
    from optroute.search.sailing import SailingGrid, SailingRoute
    from optroute.studies.ensemble_check import member_violations
    from optroute.studies.study import SchedulerUnreachable, StudyError, load_study, run_study
    from optroute.studies.tradeoff import TradeoffFront, tradeoff
    from optroute.studies.voyage_study import study
    from optroute.voyage import OnboardObserver, ReplanPolicy, VoyageOutcome, simulate_voyage
    from optroute.voyage.apf import apf_avoidance
    from optroute.weather import WeatherSampler, load_weather, open_forecasts, open_weather, scenarios
    from optroute.weather.cyclone_tracks import read_track


def __getattr__(name: str) -> Any:
    """Load a public name on first use (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'optroute' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "ConfigError",
    "InfeasibleETA",
    "NoSafePassage",
    "OnLandError",
    "OptrouteError",
    "SeaStateError",
    "ShipSpecError",
    "SolverFailure",
    "WeatherCoverageError",
    "WeatherSchemaError",
    "__version__",
    "optimise_corridor",
    "plan_voyage",
    "refine_sailing_route",
    "CalmWaterModel",
    "KwonModel",
    "PerformanceModel",
    "PowerTableModel",
    "Exclusion",
    "Plan",
    "PlanContext",
    "Violation",
    "Corridor",
    "Route",
    "search_route",
    "BandRules",
    "ForbiddenInterval",
    "band_margins",
    "forbidden_speed_intervals",
    "Ship",
    "Polar",
    "read_polar",
    "write_polar",
    "SailingVessel",
    "SailingGrid",
    "SailingRoute",
    "StudyError",
    "SchedulerUnreachable",
    "load_study",
    "run_study",
    "TradeoffFront",
    "tradeoff",
    "study",
    "member_violations",
    "OnboardObserver",
    "ReplanPolicy",
    "VoyageOutcome",
    "simulate_voyage",
    "apf_avoidance",
    "read_track",
    "WeatherSampler",
    "load_weather",
    "open_forecasts",
    "open_weather",
    "scenarios",
]
