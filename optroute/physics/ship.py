"""The ship: particulars, presets, calm-water power, engine fuel and roll period.

`Ship` is a frozen dataclass validated on construction: a non-physical value
raises :class:`~optroute.errors.ShipSpecError` naming the field, the value
and the allowed range, and so do propulsion particulars no ship has (an
admiralty coefficient, power per tonne or share of MCR at the design speed
out of range), with the likely unit slip named ("36.5 kW looks like MW").  Everything weather-dependent (added resistance,
involuntary speed loss) lives in :mod:`optroute.physics.performance`; this module is
the ship in calm water.

Sources
-------
* Admiralty law P = Δ^(2/3) V³ / C_adm: e.g. Molland, Turnock & Hudson
  (2017), *Ship Resistance and Propulsion*, 2nd ed., §16.1.
* Service point at 85 % MCR with a 15 % sea margin: MAN Energy Solutions
  (2018), *Basic Principles of Ship Propulsion*, §"Engine layout".
* SFOC(load) = SFC_base (0.455 L² − 0.710 L + 1.280), SFC_base 175 g/kWh
  for slow-speed diesels built after 2001: IMO *Fourth IMO GHG Study 2020*,
  Annex (physics.md §8).
* Natural roll period T_R = 2 C B / √GM, C = 0.373 + 0.023 B/d − 0.043
  L_wl/100: IMO *International Code on Intact Stability* (2008), Part A
  §2.3.4 (physics.md §4).
* Sea-water density 1.025 t/m³ (ITTC 7.5-02-01-03, 15 °C).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

from optroute._checks import finite
from optroute.errors import ConfigError, ShipSpecError

SEAWATER_DENSITY_T_M3 = 1.025

SHIP_TYPES = ("container", "bulk_carrier", "tanker", "general_cargo")
LOADINGS = ("normal", "loaded", "ballast")

# field -> (low, high, inclusive_low): the physical range accepted on construction.
_RANGES: dict[str, tuple[float, float, bool]] = {
    "length_m": (0.0, 500.0, False),
    "beam_m": (0.0, 80.0, False),
    "draught_m": (0.0, 30.0, False),
    "gm_m": (0.0, 15.0, False),
    "block_coefficient": (0.35, 0.95, True),
    "displacement_t": (0.0, 1.0e6, False),
    "design_speed_kn": (0.0, 45.0, False),
    "mcr_kw": (0.0, 2.0e5, False),
    "min_load_fraction": (0.0, 0.9, True),
    "sfoc_base_gpkwh": (100.0, 350.0, True),
    "service_load_fraction": (0.3, 1.0, True),
    "sea_margin": (0.0, 1.0, True),
}

# Δ / (ρ Cb L B T) must lie in this band: catches unit slips (kg for t, feet for m).
_DISPLACEMENT_CONSISTENCY = (0.80, 1.25)

# Plausibility of the propulsion particulars at the design speed; sources and reasoning in the docstring
# of Ship._check_plausible.  Deliberately wide: no real merchant ship may be refused, while a unit slip
# (MW or W for kW, m/s or km/h for kn) moves a figure by a factor of 2 to 1000.
_ADMIRALTY_RANGE = (150.0, 2500.0)  # C_adm = Δ^(2/3) V³ / P [t^(2/3) kn³ / kW]
_POWER_PER_DISPLACEMENT_RANGE = (0.01, 5.0)  # calm-water P / Δ at the design speed [kW/t]
_DESIGN_LOAD_RANGE = (0.2, 1.0)  # calm-water P / MCR at the design speed [-]


def _range_text(fname: str) -> str:
    """The allowed range of a field, for messages: ``(0, 15]`` or ``[0.35, 0.95]``."""
    if fname not in _RANGES:
        return ""
    lo, hi, incl = _RANGES[fname]
    return f"{'[' if incl else '('}{lo:g}, {hi:g}]"


def _plausibility_problems(displacement_t: float, speed_kn: float, p_design_kw: float, mcr_kw: float) -> list[str]:
    """What is out of range among C_adm, P/Δ and P/MCR at the design speed (see ``_ADMIRALTY_RANGE``)."""
    out = []
    c_adm = displacement_t ** (2.0 / 3.0) * speed_kn**3 / p_design_kw
    lo, hi = _ADMIRALTY_RANGE
    if not lo <= c_adm <= hi:
        out.append(
            f"admiralty coefficient Δ^(2/3)·V³/P = {c_adm:.4g} t^(2/3)·kn³/kW at {speed_kn:g} kn and "
            f"{p_design_kw:.4g} kW in calm water, outside {lo:g}–{hi:g}"
        )
    lo, hi = _POWER_PER_DISPLACEMENT_RANGE
    per_t = p_design_kw / displacement_t
    if not lo <= per_t <= hi:
        out.append(f"calm-water power per displacement {per_t:.3g} kW/t at {speed_kn:g} kn, outside {lo:g}–{hi:g}")
    lo, hi = _DESIGN_LOAD_RANGE
    load = p_design_kw / mcr_kw
    if not lo <= load <= hi:
        out.append(f"the design speed needs {load:.3g} of MCR in calm water, outside {lo:g}–{hi:g}")
    return out


def sfoc_ratio(load_fraction: ArrayLike) -> np.ndarray:
    """IMO Fourth GHG Study SFOC curve relative to SFC_base.

    Parameters
    ----------
    load_fraction : array_like
        Engine load, brake power over MCR [-].

    Returns
    -------
    ndarray
        SFOC(L) / SFC_base = 0.455 L² − 0.710 L + 1.280 [-]; 1.039 at 50 %,
        minimum 1.003 at 78 %, 1.025 at 100 %.
    """
    load = np.asarray(load_fraction, dtype=float)
    return 0.455 * load**2 - 0.710 * load + 1.280


def is_code_roll_period_s(beam_m: float, draught_m: float, waterline_length_m: float, gm_m: float) -> float:
    """Natural roll period by the IS Code (2008) Part A §2.3.4 formula.

    Parameters
    ----------
    beam_m : float
        Moulded beam B [m].
    draught_m : float
        Mean moulded draught d [m].
    waterline_length_m : float
        Waterline length L_wl [m].
    gm_m : float
        Metacentric height corrected for free surface GM [m], > 0.

    Returns
    -------
    float
        T_R = 2 C B / √GM [s], C = 0.373 + 0.023 B/d − 0.043 L_wl/100.
    """
    if not gm_m > 0:
        raise ShipSpecError(f"gm_m={gm_m!r} m gives no roll period; GM must be > 0 m")
    c = 0.373 + 0.023 * beam_m / draught_m - 0.043 * waterline_length_m / 100.0
    return 2.0 * c * beam_m / math.sqrt(gm_m)


@dataclass(frozen=True, kw_only=True)
class Ship:
    """A merchant ship in calm water.

    Parameters
    ----------
    name : str
        Identifier shown in outputs.
    length_m : float
        Length between perpendiculars L_pp [m], (0, 500].
    beam_m : float
        Moulded beam B [m], (0, 80].
    draught_m : float
        Mean draught d for the loading condition [m], (0, 30].
    gm_m : float
        Metacentric height corrected for free surface [m], (0, 15].
    block_coefficient : float
        C_b at that draught [-], [0.35, 0.95].
    displacement_t : float
        Displacement Δ [t]; must agree with 1.025 C_b L B d within −20/+25 %.
    design_speed_kn : float
        Service speed in calm water at the service point [kn].
    mcr_kw : float
        Maximum continuous rating of the main engine [kW].
    ship_type : {"container", "bulk_carrier", "tanker", "general_cargo"}
        Selects Kwon's form coefficient and the IMO fw regression.
    loading : {"normal", "loaded", "ballast"}
        Loading condition (Kwon's tables).
    dwt_t : float, optional
        Deadweight [t] (for the IMO fw capacity).
    min_load_fraction : float
        Lowest sustained engine load as a fraction of MCR [-] (0.10: modern
        electronically controlled two-strokes slow-steam down to about
        10 % MCR; older engines need 25–40 %).
    sfoc_base_gpkwh : float
        SFC_base of the IMO GHG SFOC curve [g/kWh] (175 for slow-speed diesels
        after 2001).
    service_load_fraction : float
        Engine load at the service point, as a fraction of MCR [-] (0.85).
    sea_margin : float
        Sea margin included at the service point [-] (0.15): the calm-water
        power at ``design_speed_kn`` is ``service_load_fraction · MCR / (1 +
        sea_margin)``, which calibrates the admiralty coefficient.
    speed_power_table : sequence of (stw_kn, power_kw), optional
        Calm-water brake power against speed through water (sea trial or
        towing-tank curve), strictly increasing in both; interpolated with a
        monotone cubic (PCHIP) and extended beyond its ends by the cube law
        through the end points.  Replaces the admiralty law when given.
    waterline_length_m : float, optional
        L_wl for the IS Code roll formula [m]; defaults to ``length_m``.
    measured_roll_period_s : float, optional
        Natural roll period from a roll test or the loading computer [s];
        replaces the IS Code estimate when given.
    """

    name: str
    length_m: float
    beam_m: float
    draught_m: float
    gm_m: float
    block_coefficient: float
    displacement_t: float
    design_speed_kn: float
    mcr_kw: float
    ship_type: str = "container"
    loading: str = "normal"
    dwt_t: float | None = None
    min_load_fraction: float = 0.10
    sfoc_base_gpkwh: float = 175.0
    service_load_fraction: float = 0.85
    sea_margin: float = 0.15
    speed_power_table: tuple[tuple[float, float], ...] | None = None
    waterline_length_m: float | None = None
    measured_roll_period_s: float | None = None
    description: str = field(default="", compare=False)

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ShipSpecError(f"Ship name={self.name!r} must be a non-empty string")
        for fname, (lo, hi, incl) in _RANGES.items():
            self._check_range(fname, getattr(self, fname), lo, hi, incl)
        if self.ship_type not in SHIP_TYPES:
            raise ShipSpecError(
                f"Ship {self.name!r}: ship_type={self.ship_type!r} is not known; use one of {SHIP_TYPES}"
            )
        if self.loading not in LOADINGS:
            raise ShipSpecError(f"Ship {self.name!r}: loading={self.loading!r} is not known; use one of {LOADINGS}")
        if self.dwt_t is not None:
            self._check_range("dwt_t", self.dwt_t, 0.0, self.displacement_t, False)
        if self.waterline_length_m is not None:
            self._check_range(
                "waterline_length_m", self.waterline_length_m, 0.5 * self.length_m, 1.2 * self.length_m, True
            )
        if self.measured_roll_period_s is not None:
            self._check_range("measured_roll_period_s", self.measured_roll_period_s, 2.0, 80.0, True)
        implied = SEAWATER_DENSITY_T_M3 * self.block_coefficient * self.length_m * self.beam_m * self.draught_m
        ratio = self.displacement_t / implied
        lo, hi = _DISPLACEMENT_CONSISTENCY
        if not lo <= ratio <= hi:
            raise ShipSpecError(
                f"Ship {self.name!r}: displacement_t={self.displacement_t!r} t disagrees with "
                f"1.025·Cb·L·B·d = {implied:.0f} t (ratio {ratio:.2f}, allowed {lo}–{hi}); "
                "check the units (tonnes, metres) and the block coefficient"
            )
        if self.speed_power_table is not None:
            object.__setattr__(self, "speed_power_table", self._validated_table(self.speed_power_table))
        if self.min_load_fraction >= self.service_load_fraction:
            raise ShipSpecError(
                f"Ship {self.name!r}: min_load_fraction={self.min_load_fraction} must be below "
                f"service_load_fraction={self.service_load_fraction}"
            )
        p_design = float(self.calm_power_kw(self.design_speed_kn))
        if p_design > self.mcr_kw:
            raise ShipSpecError(
                f"Ship {self.name!r}: design_speed_kn={self.design_speed_kn} kn needs {p_design:.0f} kW in calm "
                f"water, above mcr_kw={self.mcr_kw:.0f} kW (the MCR reaches {self.max_calm_speed_kn:.2f} kn); "
                "lower the design speed or fix the speed-power table / MCR"
            )
        self._check_plausible(p_design)

    def _check_plausible(self, p_design: float) -> None:
        """Refuse propulsion particulars no ship has, naming the likely unit slip.

        Three figures at the design speed V, with P the calm-water brake power there:

        * the admiralty coefficient C_adm = Δ^(2/3) V³ / P [t^(2/3) kn³/kW], the constant of the
          admiralty law by which power is carried between similar ships (Barrass 2004, *Ship Design
          and Performance for Masters and Mates*; Molland, Turnock & Hudson 2017, *Ship Resistance
          and Propulsion*, §16.1).  Merchant hulls in this metric form give a few hundred — the
          presets 529 (general cargo), 757 and 845 (container ships) — and the accepted range
          150–2 500 is a factor of about 3 around them;
        * the power per tonne of displacement P / Δ [kW/t]: about 0.06 for a 350 000 t tanker
          needing some 20 MW at 15 kn, 0.4 for the 24–25 kn container presets, a few kW/t for fast
          ferries; accepted 0.01–5;
        * P / MCR: the service point sits at 85–90 % MCR with a 15 % sea margin (MAN Energy
          Solutions 2018, *Basic Principles of Ship Propulsion*, "Engine layout"), i.e. 0.74–0.78
          of MCR in calm water; accepted 0.2–1 (an engine five times the power its design speed
          needs is not a design; above 1 the design speed is out of the engine's reach, checked
          before).

        When a figure is out of range, the MCR rescaled by 1000 (MW or W typed as kW; a speed-power
        table with it) and the design speed converted from m/s or km/h are tried; a conversion that
        brings all three into range is named in the message ("36.5 kW looks like MW; did you mean
        36 500 kW?").
        """
        problems = _plausibility_problems(self.displacement_t, self.design_speed_kn, p_design, self.mcr_kw)
        if not problems:
            return
        table = self.speed_power_table is not None
        guesses = []
        for factor, unit in ((1000.0, "MW"), (0.001, "W")):
            p = p_design * factor  # the admiralty law's power is set by the MCR; a table slips with the MCR
            if not _plausibility_problems(self.displacement_t, self.design_speed_kn, p, self.mcr_kw * factor):
                what = "mcr_kw and the speed-power table's powers" if table else "mcr_kw"
                better = f"{self.mcr_kw * factor:,.0f}".replace(",", " ")
                guesses.append(f"{what}: {self.mcr_kw:g} kW looks like {unit}; did you mean {better} kW")
        for factor, unit in ((1.0 / 0.514444, "m/s"), (1.0 / 1.852, "km/h")):
            v = self.design_speed_kn * factor
            p = float(self.calm_power_kw(v)) if table else p_design  # the admiralty law is calibrated at V
            if v <= _RANGES["design_speed_kn"][1] and not _plausibility_problems(
                self.displacement_t, v, p, self.mcr_kw
            ):
                guesses.append(f"design_speed_kn: {self.design_speed_kn:g} looks like {unit}; did you mean {v:.1f} kn")
        hint = ("; " + "; or ".join(guesses) + "?") if guesses else "; check the units (kW, knots, tonnes)"
        raise ShipSpecError(f"Ship {self.name!r}: implausible propulsion particulars: {'; '.join(problems)}{hint}")

    def _check_range(self, fname: str, value: Any, lo: float, hi: float, inclusive_low: bool) -> None:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ShipSpecError(f"Ship {self.name!r}: {fname}={value!r} is not a number") from None
        ok = math.isfinite(v) and (v >= lo if inclusive_low else v > lo) and v <= hi
        if not ok:
            bracket = "[" if inclusive_low else "("
            raise ShipSpecError(
                f"Ship {self.name!r}: {fname}={value!r} is outside the allowed range {bracket}{lo:g}, {hi:g}]"
            )

    def _validated_table(self, table: Any) -> tuple[tuple[float, float], ...]:
        try:
            arr = np.asarray(table, dtype=float)
        except (TypeError, ValueError):
            raise ShipSpecError(
                f"Ship {self.name!r}: speed_power_table must be pairs of numbers (stw_kn, power_kw)"
            ) from None
        if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
            raise ShipSpecError(
                f"Ship {self.name!r}: speed_power_table has shape {arr.shape}; give at least 3 (stw_kn, power_kw) pairs"
            )
        if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise ShipSpecError(
                f"Ship {self.name!r}: speed_power_table holds a non-positive or non-finite value: {arr.tolist()}"
            )
        if np.any(np.diff(arr[:, 0]) <= 0) or np.any(np.diff(arr[:, 1]) <= 0):
            raise ShipSpecError(
                f"Ship {self.name!r}: speed_power_table must be strictly increasing in speed and power: {arr.tolist()}"
            )
        return tuple((float(v), float(p)) for v, p in arr)

    # ------------------------------------------------------------------ derived
    @property
    def volume_m3(self) -> float:
        """Displacement volume ∇ = Δ / 1.025 [m³]."""
        return self.displacement_t / SEAWATER_DENSITY_T_M3

    @property
    def roll_period_s(self) -> float:
        """Natural roll period T_R [s]: measured if given, else the IS Code estimate."""
        if self.measured_roll_period_s is not None:
            return float(self.measured_roll_period_s)
        lwl = self.waterline_length_m if self.waterline_length_m is not None else self.length_m
        return is_code_roll_period_s(self.beam_m, self.draught_m, lwl, self.gm_m)

    @property
    def admiralty_coefficient(self) -> float:
        """C_adm = Δ^(2/3) V³ / P at the design point [t^(2/3) kn³ / kW]."""
        p = self.service_load_fraction * self.mcr_kw / (1.0 + self.sea_margin)
        return self.displacement_t ** (2.0 / 3.0) * self.design_speed_kn**3 / p

    @property
    def min_power_kw(self) -> float:
        """Lowest sustained brake power, ``min_load_fraction · mcr_kw`` [kW]."""
        return self.min_load_fraction * self.mcr_kw

    @cached_property
    def _table_interp(self) -> PchipInterpolator | None:
        if self.speed_power_table is None:
            return None
        arr = np.asarray(self.speed_power_table)
        return PchipInterpolator(arr[:, 0], arr[:, 1], extrapolate=False)

    def calm_power_kw(self, stw_kn: ArrayLike) -> np.ndarray:
        """Brake power in calm water for a speed through water.

        Parameters
        ----------
        stw_kn : array_like
            Speed through water [kn], >= 0.

        Returns
        -------
        ndarray
            Brake power [kW]: the speed-power table (PCHIP, cube law beyond
            its ends) if given, else the admiralty law Δ^(2/3) V³ / C_adm.
        """
        v = finite("stw_kn", stw_kn, minimum=0.0)
        if self.speed_power_table is None:
            return self.displacement_t ** (2.0 / 3.0) * v**3 / self.admiralty_coefficient
        table = np.asarray(self.speed_power_table)
        (v0, p0), (v1, p1) = table[0], table[-1]
        inside = np.clip(v, v0, v1)
        p = self._table_interp(inside)
        p = np.where(v < v0, p0 * (v / v0) ** 3, p)
        return np.where(v > v1, p1 * (v / v1) ** 3, p)

    def calm_speed_kn(self, power_kw: float) -> float:
        """Calm-water speed through water reached with a brake power [kW] → [kn]."""
        if not power_kw > 0:
            raise ShipSpecError(f"power_kw={power_kw!r} must be > 0 to give a speed")
        if self.speed_power_table is None:
            return float((power_kw * self.admiralty_coefficient / self.displacement_t ** (2.0 / 3.0)) ** (1.0 / 3.0))
        hi = 1.0
        while float(self.calm_power_kw(hi)) < power_kw:
            hi *= 2.0
        return float(brentq(lambda v: float(self.calm_power_kw(v)) - power_kw, 0.0, hi, xtol=1e-10))

    @property
    def max_calm_speed_kn(self) -> float:
        """Speed through water at MCR in calm water [kn]."""
        return self.calm_speed_kn(self.mcr_kw)

    def sfoc_gpkwh(self, power_kw: ArrayLike) -> np.ndarray:
        """Specific fuel oil consumption at a brake power (IMO GHG curve).

        Parameters
        ----------
        power_kw : array_like
            Brake power [kW], >= 0.

        Returns
        -------
        ndarray
            SFOC [g/kWh] = SFC_base · (0.455 L² − 0.710 L + 1.280), L = P / MCR.
        """
        p = finite("power_kw", power_kw, minimum=0.0)
        return self.sfoc_base_gpkwh * sfoc_ratio(p / self.mcr_kw)

    def fuel_rate_tph(self, power_kw: ArrayLike) -> np.ndarray:
        """Main-engine fuel consumption [t/h] at a brake power [kW]: SFOC · P / 10⁶."""
        p = finite("power_kw", power_kw, minimum=0.0)
        return self.sfoc_gpkwh(p) * p * 1e-6

    # ------------------------------------------------------------------ construction
    def replace(self, **changes: Any) -> Ship:
        """A copy with some fields changed, validated again."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], *, source: str = "mapping") -> Ship:
        """Build a ship from a mapping (a parsed TOML file, say), naming the source in errors.

        Parameters
        ----------
        data : mapping
            Field name → value; ``speed_power_table`` as a list of [stw_kn, power_kw].
        source : str
            Where the mapping came from, for messages (a file path).
        """
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ShipSpecError(f"{source}: unknown ship field(s) {unknown}; valid fields are {sorted(names)}")
        required = [f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING]
        missing = [n for n in required if n not in data]
        if missing:
            raise ShipSpecError(f"{source}: missing required ship field(s) {missing}")
        kwargs = dict(data)
        if kwargs.get("speed_power_table") is not None:
            kwargs["speed_power_table"] = tuple(tuple(row) for row in kwargs["speed_power_table"])
        try:
            return cls(**kwargs)
        except ShipSpecError as exc:
            raise ShipSpecError(f"{source}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> Ship:
        """Read a ship from a TOML file.

        Schema: the ship's fields as top-level keys, in the units their names carry (SI except
        ``_kn`` knots, ``_kw`` kilowatts, ``_t`` tonnes, ``_gpkwh`` g/kWh)::

            # my_ship.toml: a 4 500 TEU Panamax container ship
            name = "my_panamax"              # optional: default the file's stem
            length_m = 250.0                 # L_pp (0, 500]
            beam_m = 32.2                    # (0, 80]
            draught_m = 12.5                 # (0, 30]
            gm_m = 1.5                       # (0, 15]
            block_coefficient = 0.65         # [0.35, 0.95]
            displacement_t = 67040.0         # within -20/+25 % of 1.025 Cb L B d
            design_speed_kn = 24.0           # calm-water service speed (0, 45]
            mcr_kw = 36500.0                 # (0, 200 000]
            # optional, with their defaults:
            ship_type = "container"          # container | bulk_carrier | tanker | general_cargo
            loading = "normal"               # normal | loaded | ballast
            # dwt_t = 54000.0
            # min_load_fraction = 0.10
            # sfoc_base_gpkwh = 175.0
            # service_load_fraction = 0.85
            # sea_margin = 0.15
            # speed_power_table = [[12.0, 5200.0], [18.0, 16500.0], [24.0, 36000.0]]  # [stw_kn, power_kw]
            # waterline_length_m = 255.0
            # measured_roll_period_s = 22.0
            # description = "..."

        Required: ``length_m``, ``beam_m``, ``draught_m``, ``gm_m``, ``block_coefficient``,
        ``displacement_t``, ``design_speed_kn``, ``mcr_kw``; the ranges are those of
        :class:`Ship`, checked on construction.

        Parameters
        ----------
        path : str or PathLike
            The TOML file.

        Returns
        -------
        Ship

        Raises
        ------
        ShipSpecError
            The file is missing or not valid TOML, a required field is missing, a field is
            unknown, or a value is non-physical; the message names the file and the field.
        """
        import tomllib

        source = os.fspath(path)
        try:
            with open(source, "rb") as fh:
                data = tomllib.load(fh)
        except FileNotFoundError:
            raise ShipSpecError(
                f"ship file {source!r} does not exist; give the path of a ship TOML file or a preset name "
                f"({', '.join(sorted(_PRESETS))})"
            ) from None
        except IsADirectoryError:
            raise ShipSpecError(f"ship file {source!r} is a directory; give the path of a ship TOML file") from None
        except tomllib.TOMLDecodeError as exc:
            raise ShipSpecError(f"{source}: not valid TOML ({exc}); fix the syntax (see Ship.from_toml)") from None
        required = [f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING and f.name != "name"]
        missing = [n for n in required if n not in data]
        if missing:
            hints = ", ".join(f"{n} {_range_text(n)}" for n in missing)
            raise ShipSpecError(f"{source}: missing required ship field(s) {hints}; add them to the file")
        data = {"name": Path(source).stem, **data}
        return cls.from_mapping(data, source=source)

    @classmethod
    def presets(cls) -> tuple[str, ...]:
        """Names of the built-in ships."""
        return tuple(_PRESETS)

    @classmethod
    def preset(cls, name: str) -> Ship:
        """A built-in ship by name (see :func:`Ship.presets`)."""
        try:
            factory = _PRESETS[name]
        except KeyError:
            raise ConfigError(f"unknown ship preset {name!r}; valid presets are {sorted(_PRESETS)}") from None
        return factory()


def container_54k_dwt() -> Ship:
    """The 54 000 DWT container ship of Shao et al.'s (3-D DP) case studies.

    Shao et al. (Tabla 4) name only "buque portacontenedores 54.000 TPM"; the
    particulars are those of a typical Panamax container ship of 4 000–4 500
    TEU and 50–55 kt DWT (physics.md §8, a type, not one ship): L_pp 250 m,
    B 32.2 m (Panamax beam), d 12.5 m, C_b 0.65, Δ = 1.025 C_b L B d ≈ 67 040 t,
    GM 1.5 m, 24 kn service speed at 85 % MCR with a 15 % sea margin,
    MCR 36 500 kW (a 10-cylinder K90-class engine; the type's range is
    35–41 MW).
    """
    return Ship(
        name="container_54k_dwt",
        length_m=250.0,
        beam_m=32.2,
        draught_m=12.5,
        gm_m=1.5,
        block_coefficient=0.65,
        displacement_t=67_040.0,
        design_speed_kn=24.0,
        mcr_kw=36_500.0,
        ship_type="container",
        loading="normal",
        dwt_t=54_000.0,
        description="Panamax container ship, 54 000 DWT (Shao et al. 3-D DP case studies); typical particulars, physics.md §8",
    )


def container_8000teu() -> Ship:
    """A 25 kn transpacific container ship like the worked example of Boeing EP 2145155.

    Boeing EP 2145155 (Figs. 23–26) routes "a typical container
    ship at twenty-five knots" from San Diego to Tokyo without particulars.
    The numbers are typical of the 8 000–8 600 TEU post-Panamax class built
    2003–2010 (a type, not one ship): L_pp 320 m, B 42.8 m, d 14.0 m,
    C_b 0.62, Δ ≈ 122 000 t, DWT ≈ 100 000 t, GM 1.6 m, a 12-cylinder
    K98-class engine of 68 640 kW, 25 kn at 85 % MCR with a 15 % sea margin.
    """
    return Ship(
        name="container_8000teu",
        length_m=320.0,
        beam_m=42.8,
        draught_m=14.0,
        gm_m=1.6,
        block_coefficient=0.62,
        displacement_t=121_860.0,
        design_speed_kn=25.0,
        mcr_kw=68_640.0,
        ship_type="container",
        loading="normal",
        dwt_t=100_000.0,
        description="8 000 TEU post-Panamax container ship, 25 kn (Boeing EP 2145155 worked example); typical particulars",
    )


def general_cargo_25k_dwt() -> Ship:
    """A 20–30 kt general cargo ship like the Chinese typhoon-avoidance patent's test ship.

    The typhoon-avoidance patent ([0141]) tests "a fully loaded ship of 20 000–30 000 t" at a mean
    11 kn.  The hull is the one of physics.md §4's third checked roll-period
    row (B 25.4 m, d 9.5 m, L_wl 175 m, GM 1.02 m → T_R 18.07 s), with
    L_pp 170 m, C_b 0.75 (Δ ≈ 31 540 t, DWT 25 000 t), a 14 kn service speed
    and a 7 000 kW slow-speed engine (typical of the handysize class).
    """
    return Ship(
        name="general_cargo_25k_dwt",
        length_m=170.0,
        beam_m=25.4,
        draught_m=9.5,
        gm_m=1.02,
        block_coefficient=0.75,
        displacement_t=31_540.0,
        design_speed_kn=14.0,
        mcr_kw=7_000.0,
        ship_type="general_cargo",
        loading="loaded",
        dwt_t=25_000.0,
        waterline_length_m=175.0,
        min_load_fraction=0.15,
        description="25 000 DWT general cargo ship (typhoon-avoidance patent's test ship); typical particulars",
    )


_PRESETS = {
    "container_54k_dwt": container_54k_dwt,
    "container_8000teu": container_8000teu,
    "general_cargo_25k_dwt": general_cargo_25k_dwt,
}
