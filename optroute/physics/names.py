"""The names of the danger bands and their rule variants, with nothing heavy to import.

:mod:`optroute.physics.safety` uses them and re-exports them; the ``optroute bands``
parser lists them as choices without loading numpy (``optroute --help`` stays quick).
"""

from __future__ import annotations

BANDS: tuple[str, ...] = ("synchronous_roll", "parametric_roll", "surf_riding", "high_wave_attack")
"""Names of the four bands, in the order tables and plots list them."""

RULE_SETS: tuple[str, ...] = ("boeing", "imo")
"""Rule sets: Boeing's EP 2145155 and IMO MSC.1/Circ.1228."""

PERIOD_FORMS: tuple[str, ...] = ("exact", "imo")
"""The g/2π term of the encounter period: exact, or IMO MSC.1/Circ.1228's 3."""

__all__ = ["BANDS", "PERIOD_FORMS", "RULE_SETS"]
