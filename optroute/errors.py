"""The one family of exceptions optroute raises.

Every message says what was wrong, with the offending value and where it
came from, and what would fix it (cvxpy style).  Subclasses that describe
bad *values* also derive from :class:`ValueError` so that generic callers
can catch them the usual way.
"""

from __future__ import annotations

from typing import Any


class OptrouteError(Exception):
    """Base class of every error optroute raises on purpose."""


class ShipSpecError(OptrouteError, ValueError):
    """A ship's particulars are missing, inconsistent or non-physical."""


class SeaStateError(OptrouteError, ValueError):
    """A sea-state or speed input is NaN, negative or otherwise unusable."""


class ConfigError(OptrouteError, ValueError):
    """An option or a name (preset, scenario, rule set) is not known or not valid."""


class WeatherSchemaError(OptrouteError, ValueError):
    """A weather dataset lacks a variable, has unknown units or broken coordinates."""


class WeatherCoverageError(OptrouteError):
    """A voyage point or time lies outside the weather dataset's extent."""


class OnLandError(OptrouteError, ValueError):
    """A point lies on land and no navigable point is within the snapping limit."""


class NoSafePassage(OptrouteError):
    """No route exists through navigable, survivable water."""


class InfeasibleETA(OptrouteError):
    """The requested arrival time cannot be met.

    Parameters
    ----------
    message : str
        What was asked and why it cannot be met.
    earliest_arrival : numpy.datetime64 or None
        The earliest feasible arrival found [UTC], when known.
    latest_arrival : numpy.datetime64 or None
        For an ETA to be met exactly (``eta_mode="eq"``) later than every plan found arrives: the arrival of the
        centreline sailed at the engine's minimum load, the slowest schedule it allows [UTC], when known.
    """

    def __init__(self, message: str, earliest_arrival: Any = None, latest_arrival: Any = None) -> None:
        super().__init__(message)
        self.earliest_arrival = earliest_arrival
        self.latest_arrival = latest_arrival


class SolverFailure(OptrouteError):
    """A numerical solver did not return a usable solution.

    Parameters
    ----------
    message : str
        What failed.
    status : str
        The solver's own status string, verbatim.
    best_plan : object or None
        The best feasible plan known (for instance the search's), if any.
    """

    def __init__(self, message: str, status: str = "", best_plan: Any = None) -> None:
        super().__init__(message)
        self.status = status
        self.best_plan = best_plan
