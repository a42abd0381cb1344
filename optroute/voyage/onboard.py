"""The onboard parametric-roll observer in the simulated voyage (thyssenkrupp EP 2377756).

The danger bands *forecast* where parametric roll can occur; the patent's observer *detects* it as
it begins, from the motions sampled on board, early enough for a short speed or heading change.
In :func:`optroute.simulate_voyage` with ``observer=OnboardObserver(...)``:

* each simulator step, the ship's motions in the truth's sea at the step (the wave height and
  period of the bands, the IMO angle of encounter from the heading sailed, the speed through
  water sailed) are simulated for ``window_s`` seconds at 50 Hz by
  :func:`optroute.observer.motions.simulate_motions`, continuing the roll (angle, rate, wave
  phase) of the step before, and fed to one streaming
  :class:`optroute.observer.level.ResonanceObserver` that lives for the whole voyage;
* when the resonance level RL reaches ``threshold``, the step is cut at that instant and the
  patent's short intervention begins: the speed through water nearest the commanded one (slower
  first, as the Boeing speed reduction, then faster within the engine's power) at which small
  roll dies out — the Floquet growth rate of the roll model
  (:func:`optroute.observer.motions.parametric_growth_rate_per_s`) below zero in the sea met —
  held for at least ``hold_h`` and as long as the commanded speed would still be unstable there;
* when the intervention ends the voyage re-plans from there (reason ``"observer: ..."``), if
  ``replan`` is set.

With ``master_sees_parametric_band=False`` (the default) the simulated master's Boeing speed
reduction in the truth leaves the parametric-roll band out: that band is what the observer is
for. The other bands are applied as without the observer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from optroute._checks import finite
from optroute.errors import ConfigError
from optroute.observer.level import ObserverSettings, ResonanceObserver, RightingMoment
from optroute.observer.motions import Encounter, RollModel, parametric_growth_rate_per_s, simulate_motions
from optroute.physics import seaway
from optroute.physics.ship import Ship

__all__ = ["OnboardObserver", "ObserverWatch", "intervention_speed_kn"]


@dataclass(frozen=True, kw_only=True)
class OnboardObserver:
    """How the simulated ship watches for parametric roll and what it does at an alarm.

    Parameters
    ----------
    threshold : float
        RL at which the alarm is raised, in (0, 1].
    window_s : float
        Motions simulated and observed per simulator step [s], > 0 (at most the step's
        duration; the roll state carries over between windows).
    hold_h : float
        Shortest duration of an intervention [h], > 0.
    replan : bool
        Re-plan from where the intervention ends.
    settings : ObserverSettings, optional
        The observer's constants (default :meth:`ObserverSettings.for_ship`).
    roll_model : RollModel, optional
        Damping, GM variation and noise of the simulated motions (default :class:`RollModel`).
    speed_step_kn : float
        Step of the intervention's speed search [kn], > 0.
    master_sees_parametric_band : bool
        False: the master's speed reduction in the truth ignores the parametric-roll band,
        which the observer watches for instead; True: it applies every band, as without the
        observer.
    seed : int
        Seed of the motions' random moment and noise (step k uses ``seed + k``).
    """

    threshold: float = 0.8
    window_s: float = 600.0
    hold_h: float = 1.0
    replan: bool = True
    settings: ObserverSettings | None = None
    roll_model: RollModel | None = None
    speed_step_kn: float = 0.5
    master_sees_parametric_band: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        fix = "see OnboardObserver's parameters"
        finite("threshold", self.threshold, minimum=0.0, strict=True, error=ConfigError, fix=fix)
        if self.threshold > 1.0:
            raise ConfigError(f"threshold={self.threshold!r} must be in (0, 1]: RL never exceeds 1")
        for name in ("window_s", "hold_h", "speed_step_kn"):
            finite(name, getattr(self, name), minimum=0.0, strict=True, error=ConfigError, fix=fix)
        for name, kind in (("settings", ObserverSettings), ("roll_model", RollModel)):
            value = getattr(self, name)
            if value is not None and not isinstance(value, kind):
                raise ConfigError(f"{name} must be a {kind.__name__} or None, got {type(value).__name__}")
        if not isinstance(self.seed, int | np.integer):
            raise ConfigError(f"seed={self.seed!r} must be an integer")


def _encounter(hs_m: float, period_s: float, wave_from_deg: float, heading_deg: float, stw_kn: float) -> Encounter:
    """The regular wave met; a calm sea (no height or no period) is a wave of zero height (no excitation)."""
    if not (math.isfinite(hs_m) and hs_m > 0.0 and math.isfinite(period_s) and period_s > 0.0):
        return Encounter(hs_m=0.0, period_s=10.0, alpha_deg=0.0, speed_kn=max(stw_kn, 0.0))
    alpha = float(seaway.relative_wave_angle_deg(heading_deg, wave_from_deg if math.isfinite(wave_from_deg) else 0.0))
    return Encounter(hs_m=hs_m, period_s=period_s, alpha_deg=alpha, speed_kn=max(stw_kn, 0.0))


def intervention_speed_kn(
    ship: Ship,
    model: RollModel,
    sea: dict[str, float],
    heading_deg: float,
    commanded_kn: float,
    *,
    lowest_kn: float,
    highest_kn: float,
    step_kn: float,
) -> float | None:
    """The speed through water nearest ``commanded_kn`` at which small roll dies out, slower first.

    Parameters
    ----------
    ship, model
        The ship and its roll model.
    sea : dict
        ``hs_m`` [m], ``period_s`` [s] and ``wave_from_deg`` [deg true, from] met.
    heading_deg : float
        Heading [deg true, to].
    commanded_kn : float
        The speed the plan commands [kn].
    lowest_kn, highest_kn : float
        The range the search may use [kn] (the master's slowest speed, the fastest the power
        allows).
    step_kn : float
        Search step [kn].

    Returns
    -------
    float or None
        The speed [kn], or None when none in the range is stable.
    """
    n = int(math.floor(max(commanded_kn - lowest_kn, highest_kn - commanded_kn) / step_kn + 1e-9))
    for k in range(1, n + 1):
        for v in (commanded_kn - k * step_kn, commanded_kn + k * step_kn):
            if lowest_kn - 1e-9 <= v <= highest_kn + 1e-9:
                enc = _encounter(sea["hs_m"], sea["period_s"], sea["wave_from_deg"], heading_deg, v)
                if parametric_growth_rate_per_s(ship, enc, model) < 0.0:
                    return float(v)
    return None


def unstable(ship: Ship, model: RollModel, sea: dict[str, float], heading_deg: float, stw_kn: float) -> bool:
    """Whether small roll builds up at ``stw_kn`` in ``sea`` (Floquet growth rate > 0)."""
    enc = _encounter(sea["hs_m"], sea["period_s"], sea["wave_from_deg"], heading_deg, stw_kn)
    return parametric_growth_rate_per_s(ship, enc, model) > 0.0


@dataclass
class ObserverWatch:
    """The observer's state over a voyage: the streaming observer, the roll carried over, the intervention."""

    config: OnboardObserver
    ship: Ship
    observer: ResonanceObserver = field(init=False)
    roll_model: RollModel = field(init=False)
    roll_deg: float = 0.0
    rate_deg_s: float = 0.0
    clock_s: float = 0.0
    steps: int = 0
    intervention_kn: float | None = None
    until_h: float = 0.0
    alarms: int = 0
    note: str = ""
    pending_reason: str = ""

    def __post_init__(self) -> None:
        settings = self.config.settings or ObserverSettings.for_ship(self.ship)
        self.observer = ResonanceObserver(settings, RightingMoment.from_ship(self.ship))
        self.roll_model = self.config.roll_model or RollModel()

    def watch(self, sea: dict[str, float], heading_deg: float, stw_kn: float, duration_s: float) -> dict[str, Any]:
        """Simulate and observe the motions of one step; the alarm's time in the step [s] if RL reached the threshold.

        Returns a dict with ``rl_max`` (NaN while the observer warms up), ``roll_max_deg`` (true
        roll, without noise) and ``alarm_s`` (None without an alarm).
        """
        span = min(self.config.window_s, duration_s)
        if span < 2.0 * self.observer.settings.sample_interval_s:
            return {"rl_max": math.nan, "roll_max_deg": abs(self.roll_deg), "alarm_s": None}
        enc = _encounter(sea["hs_m"], sea["period_s"], sea["wave_from_deg"], heading_deg, stw_kn)
        dt = self.observer.settings.sample_interval_s
        m = simulate_motions(  # from the state at the last sample seen, which is not fed again
            self.ship,
            enc,
            duration_s=span + dt,
            model=self.roll_model,
            seed=int(self.config.seed) + self.steps,
            initial_roll_deg=self.roll_deg,
            initial_roll_rate_deg_s=self.rate_deg_s,
            start_s=self.clock_s,
            dt_s=dt,
        )
        self.steps += 1
        z, phi, true_phi, t = m.heave_m[1:], m.roll_deg[1:], m.true_roll_deg[1:], m.time_s[1:]
        if self.intervention_kn is None:
            rl = self.observer.update_until(z, phi, self.config.threshold)
        else:  # already acting: the observer watches the roll die out, no new alarm
            rl = self.observer.update_many(z, phi)[0]
        i = rl.size - 1
        alarm = self.intervention_kn is None and bool(rl[i] >= self.config.threshold)
        self.roll_deg = float(true_phi[i])
        self.rate_deg_s = (
            float(m.final_roll_rate_deg_s)
            if i == t.size - 1
            else float((true_phi[i + 1] - m.true_roll_deg[i]) / (2 * dt))
        )
        self.clock_s = float(t[i])
        seen = rl[np.isfinite(rl)]
        return {
            "rl_max": float(seen.max()) if seen.size else math.nan,
            "roll_max_deg": float(np.max(np.abs(true_phi[: i + 1]))),
            "alarm_s": float(t[i] - m.time_s[0]) if alarm else None,
        }
