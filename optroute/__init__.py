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

__version__ = "0.1.0"

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
]
