"""Ship motions to observe: heave, roll and pitch at 50 Hz with parametric roll.

A time-domain model small enough to run in milliseconds and rich enough to
show the behaviour the observer (:mod:`optroute.observer.level`) must detect:
roll that builds up when the encounter period is near half the natural roll
period and dies out elsewhere, faster in higher waves.

Model
-----
Roll, one degree of freedom, the damped Mathieu form with the wall-sided
restoring arm (physics.md §10):

    φ'' + 2 ζ ω0 φ' + β φ'|φ'| + ω0² [(1 − h c(t)) sin φ + (BM / 2GM) sin φ tan² φ]
        = ω0² (r_α k a sin α sin(ω_e t) + m(t))

* ω0 = 2π / T_R, T_R from :attr:`optroute.physics.ship.Ship.roll_period_s`
  (IS Code 2008 Part A §2.3.4, or the measured period).
* ``c(t) = cos(ω_e t)`` is +1 with a wave crest amidships, when GM is at
  its lowest; h = ΔGM / GM is the relative GM amplitude.  This is the
  restoring variation of the parametric-roll literature (France et al.
  2003, *An investigation of head-sea parametric rolling and its influence
  on container lashing systems*, Marine Technology 40(1); Spyrou 2005; ITTC
  recommended procedure 7.5-02-07-04.3).
* h grows linearly with the wave height and is largest when the wavelength
  along the hull is the ship's length:
  h = h_L1 · (H / H_L1) · R(u),  H_L1 = 0.0167 L the wave height of the
  IMO second-generation Level 1 parametric-roll check (MSC.1/Circ.1627,
  wave steepness 0.0167 at λ = L), and R Grim's effective wave (Grim 1961):
  the least-squares fit of a·cos(2πx/L) to the wave a·cos(kx) along the
  hull, R(u) = 2u sin u / (π² − u²), u = π L |cos α| / λ (R(π) = 1, R → 0
  for long or beam waves).  h_L1 (``gm_ratio_level1``) is ΔGM/GM in that
  standard wave, a property of the hull's flare: 0.6 by default for
  container ships (above the Level 1 limit R_PR <= 0.49, i.e. a hull
  vulnerable to parametric roll), 0.3 otherwise; give the hull's own value
  from a hydrostatic computation when it is known.
* Damping: linear ζ plus quadratic β [1/rad], the split of Himeno (1981),
  *Prediction of ship roll damping — state of the art*, Univ. Michigan
  report 239 (ζ 0.02–0.1 for merchant ships, physics.md §10).
* Wall-sided restoring arm GZ = sin φ (GM + ½ BM tan² φ) (e.g. Rawson &
  Tupper, *Basic Ship Theory*, ch. 4), with BM = C_wp² B² / (12 C_b d)
  and C_wp = (1 + 2 C_b) / 3 (Schneekluth & Bertram 1998): the hardening
  that bounds the roll at a steady amplitude.
* Direct excitation by the wave slope k a in oblique seas (zero in head and
  following seas), reduced by r_α = |sin(kB/2) / (kB/2)| over the beam, and
  a seeded random moment m(t) (a sum of random-phase sines around ω0)
  that seeds the roll as the irregular part of a real sea would.

Heave and pitch are the steady responses of second-order transfer functions
at ω_e, natural frequency ω_z² = g C_wp / (C_b d (1 + a33)) with the added
mass ratio a33 = 1 and damping ratio 0.5 (radiation damping makes the
heave RAO peak near 1), driven by the wave elevation
(heave) and slope (pitch) averaged over a parabolic waterplane b(x) ∝ 1 −
(2x/L)²: F(u) = 3 (sin u − u cos u) / u³ (derived here; F(0) = 1) and
:func:`waterplane_slope`.  The
wave is regular with height H = Hs (a conservative choice: the parametric
roll literature tests regular waves) and its encounter period from
:func:`optroute.physics.seaway.encounter_period_s` (exact form).

Integration: fixed-step classical Runge–Kutta (RK4) at the sampling
interval (20 ms: at least 100 steps per encounter period of 2 s or more),
chosen over ``scipy.integrate.solve_ivp`` so that the output lands on the
50 Hz grid without interpolation and a run is a deterministic function of
the seed; compiled with numba when it is installed.

Angles: roll φ and pitch θ are returned in degrees (roll positive to
starboard, pitch bow up), heave z in metres (positive up), time in seconds.
Measurement noise (seeded, Gaussian) is added to the returned series.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from optroute._checks import finite
from optroute.errors import ConfigError, SeaStateError
from optroute.physics import seaway
from optroute.physics.ship import Ship

try:  # numba is optional: the same loop runs in Python without it (slower)
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None

G_MS2 = seaway.G_MS2
SAMPLE_INTERVAL_S = 0.02
"""The patent's sampling interval (EP 2377756: every 20 ms) [s]."""

IMO_LEVEL1_STEEPNESS = 0.0167
"""Wave height over ship length of the IMO Level 1 parametric-roll check (MSC.1/Circ.1627)."""

_N_RANDOM = 24  # sines in the random roll moment


def grim_effective_wave_ratio(u: np.ndarray | float) -> np.ndarray:
    """Grim's effective wave: amplitude of the fitted a·cos(2πx/L) over the wave amplitude.

    Parameters
    ----------
    u : array_like
        π L / λ_along [-], λ_along = λ / |cos α| the wavelength along the hull.

    Returns
    -------
    ndarray
        R(u) = 2u sin u / (π² − u²) (least squares over −L/2 <= x <= L/2,
        Grim 1961); R(π) = 1 (λ = L), R(0) = 0; negative where the fitted
        wave has its crest at the ends when the real one has it amidships.
    """
    u = np.asarray(u, dtype=float)
    den = np.pi**2 - u**2
    near = np.abs(den) < 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(near, 1.0, 2.0 * u * np.sin(u) / np.where(near, 1.0, den))
    return r


def waterplane_average(u: np.ndarray | float) -> np.ndarray:
    """Wave elevation averaged over a parabolic waterplane, over the amplitude.

    F(u) = (3/4) ∫_{-1}^{1} cos(u s) (1 − s²) ds = 3 (sin u − u cos u) / u³,
    u = π L |cos α| / λ; F(0) = 1 (long waves lift the whole ship).
    """
    u = np.asarray(u, dtype=float)
    small = np.abs(u) < 1e-3
    us = np.where(small, 1.0, u)
    return np.where(small, 1.0 - u**2 / 10.0, 3.0 * (np.sin(us) - us * np.cos(us)) / us**3)


def waterplane_slope(u: np.ndarray | float) -> np.ndarray:
    """Least-squares wave slope over a parabolic waterplane, over the slope k a.

    G(u) = ∫ s sin(u s)(1 − s²) ds / (u ∫ s² (1 − s²) ds) over s = 2x/L in
    [−1, 1] (32-point Gauss–Legendre), u = π L |cos α| / λ; G(0) = 1.
    """
    u = np.atleast_1d(np.asarray(u, dtype=float))
    s, w = np.polynomial.legendre.leggauss(32)
    us = np.where(np.abs(u) < 1e-6, 1e-6, u)
    num = (w * s * np.sin(us[:, None] * s) * (1.0 - s**2)).sum(axis=1)
    return num / (us * 4.0 / 15.0)


@dataclass(frozen=True, kw_only=True)
class Encounter:
    """A regular wave met by the ship.

    Parameters
    ----------
    hs_m : float
        Significant wave height [m], >= 0; the regular wave's height H = Hs.
    period_s : float
        Wave period T [s], > 0.
    alpha_deg : float
        IMO relative heading α [deg]: 0 head seas, 90 from starboard, 180 following.
    speed_kn : float
        Ship speed through the water [kn], >= 0.
    """

    hs_m: float
    period_s: float
    alpha_deg: float
    speed_kn: float

    def __post_init__(self) -> None:
        finite("hs_m", self.hs_m, minimum=0.0, fix="give the significant wave height in metres")
        finite("period_s", self.period_s, minimum=0.0, strict=True, fix="give the wave period in seconds")
        finite("alpha_deg", self.alpha_deg, fix="give the IMO relative heading in degrees (0 = head seas)")
        finite("speed_kn", self.speed_kn, minimum=0.0, fix="give the speed through the water in knots")

    @property
    def encounter_period_s(self) -> float:
        """T_E [s] by the exact deep-water form (inf when riding with the waves)."""
        return float(seaway.encounter_period_s(self.period_s, self.speed_kn, self.alpha_deg))

    @property
    def wavelength_m(self) -> float:
        """Deep-water wavelength λ = g T² / 2π [m]."""
        return float(seaway.wavelength_m(self.period_s))


@dataclass(frozen=True, kw_only=True)
class RollModel:
    """Hull constants of the roll, heave and pitch model (module docstring).

    Parameters
    ----------
    damping_ratio : float
        Linear roll damping ratio ζ [-], [0, 1) (Himeno 1981; 0.02–0.1).
    quadratic_damping_per_rad : float
        Quadratic roll damping β [1/rad], >= 0.
    gm_ratio_level1 : float or None
        ΔGM/GM in the IMO Level 1 wave (H = 0.0167 L, λ = L) [-], >= 0;
        None: 0.6 for container ships, 0.3 otherwise.
    heave_damping_ratio : float
        Damping ratio of the heave and pitch transfer functions [-], (0, 1].
    heave_added_mass_ratio : float
        Heave added mass over the ship's mass a33 [-], >= 0.
    random_moment_deg : float
        Amplitude of the random roll moment as a static heel [deg], >= 0.
    roll_noise_deg, pitch_noise_deg, heave_noise_m : float
        Standard deviations of the measurement noise [deg, deg, m], >= 0.
    """

    damping_ratio: float = 0.03
    quadratic_damping_per_rad: float = 0.25
    gm_ratio_level1: float | None = None
    heave_damping_ratio: float = 0.5
    heave_added_mass_ratio: float = 1.0
    random_moment_deg: float = 0.01
    roll_noise_deg: float = 0.02
    pitch_noise_deg: float = 0.02
    heave_noise_m: float = 0.01

    def __post_init__(self) -> None:
        fix = "see RollModel's parameters"
        finite("damping_ratio", self.damping_ratio, minimum=0.0, error=ConfigError, fix=fix)
        if not self.damping_ratio < 1.0:
            raise ConfigError(f"damping_ratio={self.damping_ratio!r} must be below 1 (an oscillating roll)")
        for name in (
            "quadratic_damping_per_rad",
            "heave_added_mass_ratio",
            "random_moment_deg",
            "roll_noise_deg",
            "pitch_noise_deg",
            "heave_noise_m",
        ):
            finite(name, getattr(self, name), minimum=0.0, error=ConfigError, fix=fix)
        if self.gm_ratio_level1 is not None:
            finite("gm_ratio_level1", self.gm_ratio_level1, minimum=0.0, error=ConfigError, fix=fix)
        finite("heave_damping_ratio", self.heave_damping_ratio, minimum=0.0, strict=True, error=ConfigError, fix=fix)
        if self.heave_damping_ratio > 1.0:
            raise ConfigError(f"heave_damping_ratio={self.heave_damping_ratio!r} must be in (0, 1]")

    def level1_ratio(self, ship: Ship) -> float:
        """h_L1: the given ΔGM/GM in the Level 1 wave, else 0.6 (container) or 0.3."""
        if self.gm_ratio_level1 is not None:
            return float(self.gm_ratio_level1)
        return 0.6 if ship.ship_type == "container" else 0.3


def metacentric_radius_m(ship: Ship) -> float:
    """BM = C_wp² B² / (12 C_b d) [m], C_wp = (1 + 2 C_b) / 3 (Schneekluth & Bertram 1998)."""
    cwp = (1.0 + 2.0 * ship.block_coefficient) / 3.0
    return cwp**2 * ship.beam_m**2 / (12.0 * ship.block_coefficient * ship.draught_m)


def gm_amplitude_ratio(ship: Ship, encounter: Encounter, model: RollModel | None = None) -> float:
    """h = ΔGM/GM of the encounter: h_L1 (H / 0.0167 L) R(π L |cos α| / λ) [-] (signed)."""
    model = model or RollModel()
    u = math.pi * ship.length_m * abs(math.cos(math.radians(encounter.alpha_deg))) / encounter.wavelength_m
    return (
        model.level1_ratio(ship)
        * encounter.hs_m
        / (IMO_LEVEL1_STEEPNESS * ship.length_m)
        * float(grim_effective_wave_ratio(u))
    )


@dataclass(frozen=True)
class Motions:
    """Sampled ship motions.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s] from ``start_s`` (0 by default), uniform.
    heave_m : ndarray
        Heave z [m], positive up.
    roll_deg : ndarray
        Roll φ [deg], positive to starboard.
    pitch_deg : ndarray
        Pitch θ [deg], positive bow up.
    true_roll_deg : ndarray
        Roll without measurement noise [deg] (for scoring the observer).
    encounter_period_s : float
        T_E [s].
    roll_period_s : float
        Natural roll period T_R [s].
    gm_ratio : float
        h = ΔGM/GM of the encounter [-].
    final_roll_rate_deg_s : float
        Roll rate at the last sample, without noise [deg/s] (to continue the record).
    """

    time_s: np.ndarray
    heave_m: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    true_roll_deg: np.ndarray
    encounter_period_s: float
    roll_period_s: float
    gm_ratio: float
    final_roll_rate_deg_s: float = math.nan


def _rhs(t, phi, rate, p, amp, om, ph):  # noqa: ANN001, ANN202 - numba-friendly scalars
    """Roll acceleration [rad/s²]; p = (ω0, ζ, β, h, ω_e, bm/2gm, slope)."""
    w0, zeta, beta, h, we, half_bm_gm, slope = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    s = math.sin(phi)
    ta = math.tan(phi)
    restoring = (1.0 - h * math.cos(we * t)) * s + half_bm_gm * s * ta * ta
    forcing = slope * math.sin(we * t)
    for j in range(amp.shape[0]):
        forcing += amp[j] * math.sin(om[j] * t + ph[j])
    return -2.0 * zeta * w0 * rate - beta * rate * abs(rate) - w0 * w0 * (restoring - forcing)


def _rk4_roll(n, dt, phi0, rate0, p, amp, om, ph, t0=0.0):  # noqa: ANN001, ANN202
    """Roll angle [rad] at n samples, classical RK4 with step dt from (φ0, φ'0) at time t0; and the rate at the last."""
    out = np.empty(n)
    phi = phi0
    rate = rate0
    rate_out = rate0
    for i in range(n):
        out[i] = phi
        rate_out = rate
        t = t0 + i * dt
        k1p = rate
        k1r = _rhs(t, phi, rate, p, amp, om, ph)
        k2p = rate + 0.5 * dt * k1r
        k2r = _rhs(t + 0.5 * dt, phi + 0.5 * dt * k1p, k2p, p, amp, om, ph)
        k3p = rate + 0.5 * dt * k2r
        k3r = _rhs(t + 0.5 * dt, phi + 0.5 * dt * k2p, k3p, p, amp, om, ph)
        k4p = rate + dt * k3r
        k4r = _rhs(t + dt, phi + dt * k3p, k4p, p, amp, om, ph)
        phi = phi + dt / 6.0 * (k1p + 2.0 * k2p + 2.0 * k3p + k4p)
        rate = rate + dt / 6.0 * (k1r + 2.0 * k2r + 2.0 * k3r + k4r)
        if not abs(phi) < 1.4:  # 80°: beyond the wall-sided model; stop, the caller reports it
            out[i + 1 :] = np.nan
            break
    return out, rate_out


if numba is not None:
    _rhs = numba.njit(cache=True)(_rhs)
    _rk4_roll = numba.njit(cache=True)(_rk4_roll)


def _second_order(omega_n: float, zeta: float, omega: float) -> complex:
    """Steady response of x'' + 2ζω_n x' + ω_n² x = ω_n² f to f = e^{iωt}."""
    return omega_n**2 / complex(omega_n**2 - omega**2, 2.0 * zeta * omega_n * omega)


def simulate_motions(
    ship: Ship,
    encounter: Encounter,
    *,
    duration_s: float,
    model: RollModel | None = None,
    seed: int = 0,
    initial_roll_deg: float = 0.0,
    dt_s: float = SAMPLE_INTERVAL_S,
    start_s: float = 0.0,
    initial_roll_rate_deg_s: float | None = None,
) -> Motions:
    """Heave, roll and pitch of ``ship`` in ``encounter``, sampled every ``dt_s``.

    Parameters
    ----------
    ship : Ship
        The ship (T_R, GM, L, B, d, C_b are used).
    encounter : Encounter
        Wave height, period, IMO relative heading (0 = head seas) and speed.
    duration_s : float
        Length of the record [s], > 0.
    model : RollModel, optional
        Damping, GM variation and noise constants (defaults: :class:`RollModel`).
    seed : int
        Seed of the random moment and the measurement noise.
    initial_roll_deg : float
        Roll at t = 0 [deg] added to the linear steady response to the
        wave slope (zero in head and following seas), which the roll starts
        on so that an oblique sea shows no start-up build-up.
    dt_s : float
        Sampling and integration step [s] (20 ms, EP 2377756).
    start_s : float
        Time of the first sample [s] on the clock of the wave and the random moment, so
        that a record continued from another one (``initial_roll_deg`` and
        ``initial_roll_rate_deg_s`` its last state) keeps the wave's phase.
    initial_roll_rate_deg_s : float, optional
        Roll rate at the first sample [deg/s]; given, the roll starts exactly at
        (``initial_roll_deg``, this rate) instead of on the steady response to the wave slope.

    Returns
    -------
    Motions
        The series (module docstring for the model) and the encounter's T_E,
        T_R and h.

    Raises
    ------
    SeaStateError
        The ship rides with the waves (infinite T_E), or the roll passes 80°
        (beyond the wall-sided restoring arm; the ship would capsize in this
        model).
    """
    model = model or RollModel()
    finite("duration_s", duration_s, minimum=0.0, strict=True, error=ConfigError, fix="give the record length [s]")
    finite("dt_s", dt_s, minimum=0.0, strict=True, error=ConfigError, fix="give the sampling interval [s]")
    te = encounter.encounter_period_s
    if not math.isfinite(te):
        raise SeaStateError(
            f"speed_kn={encounter.speed_kn} at alpha_deg={encounter.alpha_deg} rides with the waves of period "
            f"{encounter.period_s} s (infinite encounter period); change the speed or heading"
        )
    tr = ship.roll_period_s
    w0, we = 2.0 * math.pi / tr, 2.0 * math.pi / te
    lam = encounter.wavelength_m
    k = 2.0 * math.pi / lam
    a = 0.5 * encounter.hs_m
    alpha = math.radians(encounter.alpha_deg)
    h = gm_amplitude_ratio(ship, encounter, model)
    half_kb = 0.5 * k * ship.beam_m * abs(math.sin(alpha))
    r_beam = 1.0 if half_kb < 1e-9 else abs(math.sin(half_kb) / half_kb)
    slope = r_beam * k * a * math.sin(alpha)
    half_bm_gm = 0.5 * metacentric_radius_m(ship) / ship.gm_m
    p = np.array([w0, model.damping_ratio, model.quadratic_damping_per_rad, h, we, half_bm_gm, slope])
    rng = np.random.default_rng(seed)
    om = w0 * rng.uniform(0.6, 1.4, _N_RANDOM)
    ph = rng.uniform(0.0, 2.0 * math.pi, _N_RANDOM)
    amp = np.full(_N_RANDOM, math.radians(model.random_moment_deg) / math.sqrt(_N_RANDOM))
    n = int(round(duration_s / dt_s)) + 1
    # start on the linear steady response to the wave slope, so that beam seas start without a build-up
    finite("start_s", start_s, error=ConfigError, fix="give the time of the first sample [s]")
    if initial_roll_rate_deg_s is None:
        steady = _second_order(w0, model.damping_ratio, we) * slope
        phi0, rate0 = math.radians(initial_roll_deg) + steady.imag, we * steady.real
    else:
        finite("initial_roll_rate_deg_s", initial_roll_rate_deg_s, error=ConfigError, fix="give a roll rate [deg/s]")
        phi0, rate0 = math.radians(initial_roll_deg), math.radians(initial_roll_rate_deg_s)
    roll, last_rate = _rk4_roll(n, float(dt_s), phi0, rate0, p, amp, om, ph, float(start_s))
    if np.isnan(roll).any():
        t_bad = float(np.argmax(np.isnan(roll)) * dt_s)
        raise SeaStateError(
            f"the roll passed 80° at t = {t_bad:.1f} s (Hs {encounter.hs_m} m, T {encounter.period_s} s, "
            f"alpha {encounter.alpha_deg}°, {encounter.speed_kn} kn, h = {h:.2f}): beyond the wall-sided model; "
            "lower the wave height or raise the damping"
        )
    t = float(start_s) + np.arange(n) * dt_s
    u = math.pi * ship.length_m * abs(math.cos(alpha)) / lam
    cb, d = ship.block_coefficient, ship.draught_m
    cwp = (1.0 + 2.0 * cb) / 3.0
    wz = math.sqrt(G_MS2 * cwp / (cb * d * (1.0 + model.heave_added_mass_ratio)))
    hz = _second_order(wz, model.heave_damping_ratio, we) * float(waterplane_average(u)) * a
    heave = np.real(hz * np.exp(1j * we * t))
    pitch_amp = _second_order(wz, model.heave_damping_ratio, we) * k * a * math.cos(alpha)
    pitch = np.degrees(np.real(1j * pitch_amp * float(waterplane_slope(u)[0]) * np.exp(1j * we * t)))
    true_roll = np.degrees(roll)
    return Motions(
        time_s=t,
        heave_m=heave + rng.normal(0.0, model.heave_noise_m, n),
        roll_deg=true_roll + rng.normal(0.0, model.roll_noise_deg, n),
        pitch_deg=pitch + rng.normal(0.0, model.pitch_noise_deg, n),
        true_roll_deg=true_roll,
        encounter_period_s=te,
        roll_period_s=tr,
        gm_ratio=h,
        final_roll_rate_deg_s=math.degrees(last_rate),
    )


def parametric_growth_rate_per_s(ship: Ship, encounter: Encounter, model: RollModel | None = None) -> float:
    """Floquet growth rate of small roll in ``encounter`` [1/s]: > 0 parametric roll builds up, < 0 it dies out.

    The largest Floquet exponent ln|μ| / T_E of the linear damped Mathieu equation
    φ'' + 2ζω0 φ' + ω0² (1 − h cos ω_e t) φ = 0 (the model of :func:`simulate_motions` at small
    angles, without the quadratic damping, the hardening and the direct excitation, which do not
    decide whether the upright ship is stable), μ the eigenvalues of its monodromy matrix over
    one encounter period, integrated by RK4 with 400 steps (Nayfeh & Mook 1979, *Nonlinear
    Oscillations*, ch. 5: the transition curves of the damped Mathieu equation).

    Parameters
    ----------
    ship : Ship
        The ship (T_R and the hull figures of h are used).
    encounter : Encounter
        Wave height, period, IMO relative heading (0 = head seas) and speed.
    model : RollModel, optional
        Damping and GM-variation constants.

    Returns
    -------
    float
        The growth rate [1/s]; riding with the waves (infinite T_E) gives the damping's own
        decay rate −ζω0.
    """
    model = model or RollModel()
    w0 = 2.0 * math.pi / ship.roll_period_s
    zeta = model.damping_ratio
    te = encounter.encounter_period_s
    if not math.isfinite(te):
        return -zeta * w0
    h = gm_amplitude_ratio(ship, encounter, model)
    mono = _monodromy(w0, zeta, h, 2.0 * math.pi / te, 400)
    return float(math.log(max(abs(np.linalg.eigvals(mono)))) / te)


def _monodromy(w0, zeta, h, we, n):  # noqa: ANN001, ANN202 - numba-friendly scalars
    """Monodromy matrix of φ'' + 2ζω0 φ' + ω0² (1 − h cos ω_e t) φ = 0 over 2π/ω_e, RK4 with n steps."""
    dt = 2.0 * math.pi / we / n
    out = np.empty((2, 2))
    for col in range(2):
        x, v = (1.0, 0.0) if col == 0 else (0.0, 1.0)
        for i in range(n):
            t = i * dt
            a1 = -2.0 * zeta * w0 * v - w0 * w0 * (1.0 - h * math.cos(we * t)) * x
            x2, v2 = x + 0.5 * dt * v, v + 0.5 * dt * a1
            c = 1.0 - h * math.cos(we * (t + 0.5 * dt))
            a2 = -2.0 * zeta * w0 * v2 - w0 * w0 * c * x2
            x3, v3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2
            a3 = -2.0 * zeta * w0 * v3 - w0 * w0 * c * x3
            x4, v4 = x + dt * v3, v + dt * a3
            a4 = -2.0 * zeta * w0 * v4 - w0 * w0 * (1.0 - h * math.cos(we * (t + dt))) * x4
            x = x + dt / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        out[0, col] = x
        out[1, col] = v
    return out


if numba is not None:
    _monodromy = numba.njit(cache=True)(_monodromy)
