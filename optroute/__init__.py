"""optroute: ship voyage optimisation through forecast weather.

A discrete route search fixes a corridor through the forecast; a CasADi/Ipopt
NLP then optimises the speed and heading along it for time, fuel or cost,
subject to the ETA, the engine's MCR and the wave-encounter danger bands of
IMO MSC.1/Circ.1228 and Boeing's EP 2145155.

See ``README.md`` for the command line and ``shared/design.md`` for the
public contract.
"""

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
from optroute.optimise import optimise_corridor, plan_voyage
from optroute.performance import CalmWaterModel, KwonModel, PerformanceModel, PowerTableModel
from optroute.plan import Exclusion, Plan, PlanContext, Violation
from optroute.route import Corridor, Route
from optroute.routing import search_route
from optroute.safety import BandRules, ForbiddenInterval, band_margins, forbidden_speed_intervals
from optroute.ship import Ship
from optroute.study import StudyError, load_study, run_study
from optroute.tradeoff import TradeoffFront, tradeoff
from optroute.voyage_study import study
from optroute.weather import WeatherSampler, load_weather, open_weather, scenarios

__version__ = "0.1.0"

__all__ = [
    "Exclusion",
    "Plan",
    "PlanContext",
    "Violation",
    "optimise_corridor",
    "plan_voyage",
    "BandRules",
    "CalmWaterModel",
    "Corridor",
    "ForbiddenInterval",
    "KwonModel",
    "PerformanceModel",
    "PowerTableModel",
    "Route",
    "Ship",
    "StudyError",
    "TradeoffFront",
    "WeatherSampler",
    "load_weather",
    "open_weather",
    "run_study",
    "scenarios",
    "search_route",
    "study",
    "tradeoff",
    "band_margins",
    "forbidden_speed_intervals",
    "load_study",
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
]
