"""The resonance level RL of thyssenkrupp EP 2377756: settings, batch and streaming observers.

* :class:`RightingMoment` — the righting-moment characteristic M_φ(z, φ)
  [kN·m] the roll power is computed from: a table from trials (the patent's
  "campo característico") or computed from GM and the hull.
* :class:`ObserverSettings` — sampling interval, filter constants, dead
  bands, the reference values that normalise K1–K4, the state limits of K5
  and how the criteria are combined; :meth:`ObserverSettings.for_ship`
  derives the ship-dependent ones.
* :func:`observe` — the batch function over arrays; :class:`ResonanceObserver`
  — the streaming observer, sample by sample in constant memory.  Both run
  :func:`optroute.observer.criteria.advance` (the criteria are defined
  there), so they give the same RL to the last bit.

Angles in degrees (roll positive to starboard), heave in metres (up), time
in seconds.  The patent (claim 6) determines the normalisation and weights
in trial runs; the defaults here were set on the simulator of
:mod:`optroute.observer.motions` and should be re-determined from the
ship's own records.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from optroute._checks import finite
from optroute.errors import ConfigError, OptrouteError
from optroute.observer import criteria as _c
from optroute.physics.ship import Ship

G_MS2 = 9.80665


class ObserverInputError(OptrouteError, ValueError):
    """Motion samples the observer cannot use (non-finite, unevenly spaced, outside the characteristic)."""


def _axis(name: str, values: Any, unit: str) -> np.ndarray:
    arr = finite(name, values, error=ConfigError, fix=f"give the {name} axis in {unit} as finite numbers")
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.diff(arr) > 0):
        raise ConfigError(
            f"the righting-moment characteristic's {name} axis [{unit}] must hold at least two strictly increasing "
            f"values, got {arr.tolist()!r}"
        )
    return arr


@dataclass(frozen=True)
class RightingMoment:
    """Righting moment M_φ [kN·m] over heave z [m] and roll φ [deg], bilinear between nodes.

    Parameters
    ----------
    heave_m : array_like
        Heave axis [m], strictly increasing, >= 2 values.
    roll_deg : array_like
        Roll axis [deg], strictly increasing, >= 2 values.
    moment_knm : array_like
        M_φ at the nodes, shape (len(heave_m), len(roll_deg)) [kN·m]; positive
        (righting) for positive roll when the ship is stable.
    source : str
        Where the table came from (shown in messages).
    """

    heave_m: np.ndarray
    roll_deg: np.ndarray
    moment_knm: np.ndarray
    source: str = "table"

    def __post_init__(self) -> None:
        object.__setattr__(self, "heave_m", _axis("heave_m", self.heave_m, "m"))
        object.__setattr__(self, "roll_deg", _axis("roll_deg", self.roll_deg, "deg"))
        m = finite("moment_knm", self.moment_knm, error=ConfigError, fix="every node of the table needs a moment")
        want = (self.heave_m.size, self.roll_deg.size)
        if m.shape != want:
            raise ConfigError(
                f"moment_knm of the righting-moment characteristic ({self.source}) has shape {m.shape}; "
                f"it must be (len(heave_m), len(roll_deg)) = {want}"
            )
        object.__setattr__(self, "moment_knm", m)

    @classmethod
    def from_ship(cls, ship: Ship, *, max_roll_deg: float = 60.0, heave_range_m: float = 50.0) -> RightingMoment:
        """Calm-water moment Δ g sin φ (GM + ½ BM tan² φ) [kN·m], the wall-sided formula.

        Independent of heave (a table from trials adds the heave dependence
        the patent's characteristic has).  BM = C_wp² B² / (12 C_b d) with
        C_wp = (1 + 2 C_b) / 3, as in :mod:`optroute.observer.motions`; valid
        up to deck-edge immersion, tabulated every 0.25° to ``max_roll_deg``.
        """
        from optroute.observer.motions import metacentric_radius_m

        phi = np.linspace(-max_roll_deg, max_roll_deg, int(round(2 * max_roll_deg / 0.25)) + 1)
        r = np.radians(phi)
        gz = np.sin(r) * (ship.gm_m + 0.5 * metacentric_radius_m(ship) * np.tan(r) ** 2)
        m = ship.displacement_t * G_MS2 * gz
        return cls(
            heave_m=np.array([-heave_range_m, heave_range_m]),
            roll_deg=phi,
            moment_knm=np.vstack([m, m]),
            source=f"wall-sided GZ of {ship.name} (GM {ship.gm_m} m)",
        )


@dataclass(frozen=True, kw_only=True)
class ObserverSettings:
    """Constants of the resonance observer (the criteria are defined in :mod:`optroute.observer.criteria`).

    Parameters
    ----------
    sample_interval_s : float
        Δt between samples [s] (0.02, the patent's 20 ms), > 0.
    roll_inertia_knms2 : float
        Virtual roll inertia I = Δ g GM / ω0² [kN·m·s²] for the roll energy of K3, > 0.
    smoothing_s : float
        Time constant of the pre-filter of z and φ [s], >= 0.
    lookahead_s : float
        Filter constant of K4 [s], > 0: short looks at the near field, long at the general course.
    hold_s : float
        Decay time of the peaks that normalise K1, K2, K3 and K5 [s], > 0.
    heave_deadband_m, roll_deadband_deg : float
        Dead bands of the heave and roll crossings [m, deg], >= 0.
    k1_ref_deg, k2_ref_kw : float
        Peaks of |K1| [deg] and |K2| [kW] normalised to 1, > 0.
    k3_ref_gain : float
        Relative roll-energy gain per upright passage, K3 / E, normalised to 1 [-], > 0.
    k4_ref_per_s : float
        Relative rise of the roll-power level, K4 / level, normalised to 1 [1/s], > 0.
    energy_passages : int
        k3 takes the least relative gain of this many successive passages (1–8;
        the patent allows comparing with several earlier passages): growth
        must be sustained, not one beat of two roll components.
    energy_lag : int
        K3 compares a passage's energy with the one this many passages
        before (1–4): 1 the previous passage (the patent's embodiment), 2 one
        roll period before (default).
    heave_limit_m, roll_limit_deg : float
        Semi-axes of the (heave, roll) state-limit ellipse of K5 [m, deg], > 0.
    warmup_s : float
        RL is NaN (not known yet) for this long after the first sample [s], >= 0.
    combine : {"product", "sum", "max"}
        How the normalised criteria make RL.
    weights : tuple of 5 floats
        w1–w5 >= 0 (exponents of the product, weights of the sum, on/off for
        the max), not all zero.
    """

    sample_interval_s: float = 0.02
    roll_inertia_knms2: float
    smoothing_s: float = 0.5
    lookahead_s: float
    hold_s: float
    heave_deadband_m: float = 0.05
    roll_deadband_deg: float = 0.1
    k1_ref_deg: float
    k2_ref_kw: float
    k3_ref_gain: float
    k4_ref_per_s: float
    energy_passages: int = 3
    energy_lag: int = 2
    heave_limit_m: float
    roll_limit_deg: float
    warmup_s: float
    combine: str = "product"
    weights: tuple[float, float, float, float, float] = (0.0, 1.0, 1.0, 1.0, 1.0)
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        positive = (
            "sample_interval_s",
            "roll_inertia_knms2",
            "lookahead_s",
            "hold_s",
            "k1_ref_deg",
            "k2_ref_kw",
            "k3_ref_gain",
            "k4_ref_per_s",
            "heave_limit_m",
            "roll_limit_deg",
        )
        for name in positive:
            finite(name, getattr(self, name), minimum=0.0, strict=True, error=ConfigError, fix="see ObserverSettings")
        for name in ("smoothing_s", "heave_deadband_m", "roll_deadband_deg", "warmup_s"):
            finite(name, getattr(self, name), minimum=0.0, error=ConfigError, fix="see ObserverSettings")
        if not (isinstance(self.energy_passages, int) and 1 <= self.energy_passages <= _c.MAX_PASSAGES):
            raise ConfigError(
                f"energy_passages={self.energy_passages!r} must be an integer from 1 to {_c.MAX_PASSAGES}"
            )
        if not (isinstance(self.energy_lag, int) and 1 <= self.energy_lag <= 4):
            raise ConfigError(f"energy_lag={self.energy_lag!r} must be an integer from 1 to 4 (passages back)")
        if self.combine not in _c.COMBINE_CODES:
            raise ConfigError(f"combine={self.combine!r} is not known; use one of {list(_c.COMBINE_CODES)}")
        w = finite("weights", self.weights, minimum=0.0, error=ConfigError, fix="five weights w1-w5 >= 0")
        if w.shape != (5,) or not w.sum() > 0:
            raise ConfigError(f"weights={self.weights!r} must be five numbers >= 0, not all zero (one per K1-K5)")
        object.__setattr__(self, "weights", tuple(float(x) for x in w))

    @classmethod
    def for_ship(
        cls, ship: Ship, *, reference_roll_deg: float = 1.5, growth_per_period: float = 1.25, **overrides: Any
    ) -> ObserverSettings:
        """Settings scaled to ``ship`` around a reference roll amplitude φ_r and growth factor G.

        With Δg GM the initial restoring stiffness [kN·m/rad] and ω0 = 2π/T_R:
        I = Δg GM / ω0²; K1 reference φ_r; K2 reference the peak roll power
        of a steady roll of amplitude φ_r, ½ Δg GM ω0 φ_r²; K3 reference the
        relative energy gain G − 1 one roll period apart (the amplitude
        growing by G a roll period: energy ∝ amplitude²); K4 reference the
        relative rise 2 ln G / T_R [1/s] of the power level (∝ amplitude²);
        state limits (z, φ) = (0.0167 L / 2, 2 φ_r), half the height of the
        IMO Level 1 wave (MSC.1/Circ.1627) and twice φ_r; hold T_R;
        look-ahead T_R / 2; warm-up T_R.  Defaults φ_r = 1.5°, G = 1.25 and
        the weights (0, 1, 1, 1, 1): on the simulator K1 nearly vanishes in
        parametric resonance when the heave lags the wave by about 90° (heave
        resonance near T_E = T_R / 2, as for the container preset), so it
        would veto RL in the product; set ``weights`` to bring it in.  Any
        field can be overridden by keyword.
        """
        finite("reference_roll_deg", reference_roll_deg, minimum=0.0, strict=True, error=ConfigError)
        finite(
            "growth_per_period",
            growth_per_period,
            minimum=1.0,
            strict=True,
            error=ConfigError,
            fix="the roll amplitude's growth factor per roll period that counts as clear growth, e.g. 1.25",
        )
        tr = ship.roll_period_s
        w0 = 2.0 * math.pi / tr
        stiffness = ship.displacement_t * G_MS2 * ship.gm_m  # kN·m / rad
        phr = math.radians(reference_roll_deg)
        base = {
            "roll_inertia_knms2": stiffness / w0**2,
            "lookahead_s": 0.5 * tr,
            "hold_s": tr,
            "k1_ref_deg": float(reference_roll_deg),
            "k2_ref_kw": 0.5 * stiffness * w0 * phr**2,
            "k3_ref_gain": growth_per_period - 1.0,
            "k4_ref_per_s": 2.0 * math.log(growth_per_period) / tr,
            "heave_limit_m": 0.5 * 0.0167 * ship.length_m,
            "roll_limit_deg": 2.0 * reference_roll_deg,
            "warmup_s": tr,
            "source": f"ObserverSettings.for_ship({ship.name!r}, reference_roll_deg={reference_roll_deg})",
        }
        base.update(overrides)
        return cls(**base)

    def replace(self, **changes: Any) -> ObserverSettings:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def parameters(self) -> np.ndarray:
        """The parameter vector of :func:`optroute.observer.criteria.advance`."""
        dt = self.sample_interval_s
        p = np.empty(_c.N_PARAMS)
        p[_c.P_DT] = dt
        p[_c.P_AF] = 1.0 if self.smoothing_s == 0 else dt / (self.smoothing_s + dt)
        p[_c.P_A4] = dt / (self.lookahead_s + dt)
        p[_c.P_DECAY] = math.exp(-dt / self.hold_s)
        p[_c.P_ZDEAD] = self.heave_deadband_m
        p[_c.P_PDEAD] = math.radians(self.roll_deadband_deg)
        p[_c.P_INERTIA] = self.roll_inertia_knms2
        p[_c.P_K1REF] = self.k1_ref_deg
        p[_c.P_K2REF] = self.k2_ref_kw
        p[_c.P_K3REF] = self.k3_ref_gain
        p[_c.P_K4REF] = self.k4_ref_per_s
        p[_c.P_NPASS] = self.energy_passages
        p[_c.P_LAG] = self.energy_lag
        p[_c.P_ZLIM] = self.heave_limit_m
        p[_c.P_PLIM] = self.roll_limit_deg
        p[_c.P_COMBINE] = _c.COMBINE_CODES[self.combine]
        p[_c.P_W : _c.P_W + 5] = self.weights
        p[_c.P_WARM] = round(self.warmup_s / dt)
        return p


@dataclass(frozen=True)
class ObserverResult:
    """RL and the criteria over a record.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s].
    rl : ndarray
        Resonance level RL in [0, 1].
    criteria : ndarray
        K1 [deg], K2 [kW], K3 [kJ], K4 [kW/s], K5 [-], shape (n, 5).
    normalised : ndarray
        k1–k5 in [0, 1], shape (n, 5).
    settings : ObserverSettings
        The settings used.
    """

    time_s: np.ndarray
    rl: np.ndarray
    criteria: np.ndarray
    normalised: np.ndarray
    settings: ObserverSettings

    def first_time_s(self, threshold: float = 1.0) -> float:
        """First time RL >= threshold [s], NaN if never."""
        hit = np.flatnonzero(self.rl >= threshold)
        return float(self.time_s[hit[0]]) if hit.size else math.nan

    def table(self, every_s: float = 10.0) -> str:
        """A compact text table: time, RL and K1–K5 with k1–k5, one row per ``every_s``."""
        finite("every_s", every_s, minimum=0.0, strict=True, error=ConfigError, fix="give the row spacing [s]")
        t0 = float(self.time_s[0])
        rows = np.flatnonzero(np.diff(np.floor((self.time_s - t0) / every_s), prepend=-1.0) > 0)
        head = (
            f"{'time_s':>9} {'RL':>5} | {'K1_deg':>7} {'k1':>4} | {'K2_kW':>9} {'k2':>4} | {'K3_kJ':>9} {'k3':>4}"
            f" | {'K4_kW/s':>9} {'k4':>4} | {'K5':>5} {'k5':>4}"
        )
        lines = [head, "-" * len(head)]
        for i in rows:
            c, k = self.criteria[i], self.normalised[i]
            lines.append(
                f"{self.time_s[i]:9.1f} {self.rl[i]:5.2f} | {c[0]:7.2f} {k[0]:4.2f} | {c[1]:9.3g} {k[1]:4.2f} | "
                f"{c[2]:9.3g} {k[2]:4.2f} | {c[3]:9.3g} {k[3]:4.2f} | {c[4]:5.2f} {k[4]:4.2f}"
            )
        return "\n".join(lines)


def _samples(name: str, values: Any, unit: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise ObserverInputError(f"{name} [{unit}] must be a 1-D series, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i = int(np.argmax(bad))
        raise ObserverInputError(
            f"{name} [{unit}] is {arr[i]!r} at sample {i}; the observer needs every sample: fill or cut the gap first"
        )
    return arr


def _outside(moment: RightingMoment, z: float, phi: float, i: int, t: float | None) -> ObserverInputError:
    when = f"sample {i}" + ("" if t is None else f" (t = {t:g} s)")
    return ObserverInputError(
        f"at {when} the filtered heave {z:.3g} m / roll {phi:.3g}° lies outside the righting-moment "
        f"characteristic ({moment.source}: heave {moment.heave_m[0]:g}..{moment.heave_m[-1]:g} m, roll "
        f"{moment.roll_deg[0]:g}..{moment.roll_deg[-1]:g}°); give a table that covers it"
    )


class ResonanceObserver:
    """The streaming observer: one sample (or a chunk) at a time, constant memory.

    Parameters
    ----------
    settings : ObserverSettings
        Constants; the samples must come every ``settings.sample_interval_s``.
    moment : RightingMoment
        The righting-moment characteristic.

    Notes
    -----
    Memory: a state vector of :data:`optroute.observer.criteria.N_STATE`
    floats plus the last sample's criteria, whatever the record's length.
    """

    def __init__(self, settings: ObserverSettings, moment: RightingMoment) -> None:
        self.settings = settings
        self.moment = moment
        self._prm = settings.parameters()
        self._state = _c.new_state()
        self._zax = moment.heave_m
        self._pax = np.radians(moment.roll_deg)
        self._tab = moment.moment_knm
        self._z1 = np.empty(1)
        self._p1 = np.empty(1)
        self.criteria = np.zeros((1, 5))
        """K1–K5 of the last sample."""
        self.normalised = np.zeros((1, 5))
        """k1–k5 of the last sample."""
        self._rl1 = np.zeros(1)
        self.count = 0
        """Samples seen."""

    @property
    def rl(self) -> float:
        """RL of the last sample (0 before the first)."""
        return float(self._rl1[0])

    def reset(self) -> None:
        """Forget every sample seen."""
        self._state = _c.new_state()
        self.count = 0
        self._rl1[0] = 0.0

    def update(self, heave_m: float, roll_deg: float) -> float:
        """Feed one sample: heave z [m], roll φ [deg]; return RL in [0, 1] (NaN in the warm-up).

        A sample outside the righting-moment characteristic raises
        :class:`ObserverInputError` and leaves the observer as it was.
        """
        self._z1[0] = heave_m
        self._p1[0] = roll_deg
        if not (math.isfinite(self._z1[0]) and math.isfinite(self._p1[0])):
            raise ObserverInputError(
                f"sample {self.count}: heave_m={heave_m!r}, roll_deg={roll_deg!r}; both must be finite numbers"
            )
        before = self._state.copy()
        bad = _c.advance(
            self._z1, self._p1, self._prm, self._state, self._zax, self._pax, self._tab,
            self.criteria, self.normalised, self._rl1,
        )  # fmt: skip
        if bad >= 0:
            err = _outside(self.moment, self._state[_c.S_ZF], math.degrees(self._state[_c.S_PF]), self.count, None)
            self._state = before  # the sample is refused: the observer is as it was before it
            raise err
        self.count += 1
        return float(self._rl1[0])

    def update_many(self, heave_m: Any, roll_deg: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Feed a chunk of samples; return (RL, K1–K5, k1–k5) of each, as :func:`observe`.

        A bad sample raises :class:`ObserverInputError` naming it and refuses the whole
        chunk: the observer is left as it was before the chunk.
        """
        z = _samples("heave_m", heave_m, "m")
        p = _samples("roll_deg", roll_deg, "deg")
        if z.shape != p.shape:
            raise ObserverInputError(f"heave_m has {z.size} samples and roll_deg {p.size}; they must pair up")
        n = z.size
        raw, norm, rl = np.zeros((n, 5)), np.zeros((n, 5)), np.zeros(n)
        before = self._state.copy()
        bad = _c.advance(z, p, self._prm, self._state, self._zax, self._pax, self._tab, raw, norm, rl)
        if bad >= 0:
            err = _outside(
                self.moment, self._state[_c.S_ZF], math.degrees(self._state[_c.S_PF]), self.count + bad, None
            )
            self._state = before  # the chunk is refused whole: the observer is as it was before it
            raise err
        self.count += n
        if n:
            self.criteria[0], self.normalised[0], self._rl1[0] = raw[-1], norm[-1], rl[-1]
        return rl, raw, norm

    def update_until(self, heave_m: Any, roll_deg: Any, threshold: float) -> np.ndarray:
        """Feed samples up to and including the first whose RL reaches ``threshold``; return their RL.

        The samples after the alarm are not fed (the observer is as if the record stopped
        there), so that a caller acting on the alarm can continue with other motions.
        """
        before, count = self._state.copy(), self.count
        crit, norm, last = self.criteria.copy(), self.normalised.copy(), self._rl1.copy()
        rl, _, _ = self.update_many(heave_m, roll_deg)
        hit = np.flatnonzero(rl >= threshold)
        if not hit.size:
            return rl
        self._state, self.count = before, count
        self.criteria[:], self.normalised[:], self._rl1[:] = crit, norm, last
        k = int(hit[0]) + 1
        return self.update_many(np.asarray(heave_m, dtype=float)[:k], np.asarray(roll_deg, dtype=float)[:k])[0]


def check_time(time_s: Any, sample_interval_s: float | None = None, *, source: str = "time_s") -> float:
    """The uniform sampling interval of ``time_s`` [s]; raises ObserverInputError otherwise.

    The steps may differ from their median by at most 1 %; when
    ``sample_interval_s`` is given the median must match it within 1 %.
    """
    t = _samples(source, time_s, "s")
    if t.size < 2:
        raise ObserverInputError(f"{source} has {t.size} sample(s); the observer needs a record of at least two")
    step = np.diff(t)
    if not np.all(step > 0):
        i = int(np.argmax(~(step > 0)))
        raise ObserverInputError(
            f"{source} does not increase at sample {i + 1} ({t[i]!r} s then {t[i + 1]!r} s); sort the record "
            "and drop repeated times"
        )
    dt = float(np.median(step))
    off = np.abs(step - dt) > 0.01 * dt
    if off.any():
        i = int(np.argmax(off))
        raise ObserverInputError(
            f"{source} is not evenly spaced: step {step[i]:g} s at sample {i + 1} against the median {dt:g} s; "
            "resample the record to a uniform interval (the patent samples every 20 ms)"
        )
    if sample_interval_s is not None and abs(dt - sample_interval_s) > 0.01 * sample_interval_s:
        raise ObserverInputError(
            f"{source} is sampled every {dt:g} s but the settings expect {sample_interval_s:g} s; build the settings "
            f"with sample_interval_s={dt:g}"
        )
    return dt


def observe(
    time_s: Any,
    heave_m: Any,
    roll_deg: Any,
    *,
    settings: ObserverSettings,
    moment: RightingMoment,
) -> ObserverResult:
    """RL and K1–K5 of a whole record (the batch function).

    Parameters
    ----------
    time_s : array_like
        Sample times [s], evenly spaced by ``settings.sample_interval_s``.
    heave_m : array_like
        Heave z [m], positive up.
    roll_deg : array_like
        Roll φ [deg], positive to starboard.
    settings : ObserverSettings
        Constants (:meth:`ObserverSettings.for_ship`).
    moment : RightingMoment
        The righting-moment characteristic.

    Returns
    -------
    ObserverResult
        The same values a :class:`ResonanceObserver` fed the samples one by one returns.

    Raises
    ------
    ObserverInputError
        Non-finite samples, uneven times, mismatched lengths or a state outside the characteristic.
    """
    t = _samples("time_s", time_s, "s")
    check_time(t, settings.sample_interval_s)
    obs = ResonanceObserver(settings, moment)
    z = _samples("heave_m", heave_m, "m")
    p = _samples("roll_deg", roll_deg, "deg")
    if not (z.size == p.size == t.size):
        raise ObserverInputError(
            f"time_s, heave_m and roll_deg have {t.size}, {z.size} and {p.size} samples; they must be equal"
        )
    try:
        rl, raw, norm = obs.update_many(z, p)
    except ObserverInputError as exc:
        raise ObserverInputError(f"{exc} (record starting at t = {t[0]:g} s)") from None
    return ObserverResult(time_s=t, rl=rl, criteria=raw, normalised=norm, settings=settings)
