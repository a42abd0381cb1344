"""The parametric-roll observer (thyssenkrupp EP 2377756) and the motions it observes.

Sources of the expected values:

* the criteria against hand-worked series (a sinusoid growing at a known
  rate, worked in each test's docstring);
* the simulator's growth rate against the Floquet multiplier of the damped
  Mathieu equation, integrated independently with scipy's solve_ivp;
* Grim's effective wave and the waterplane averages against brute-force
  least squares and quadrature;
* the observer's behaviour (no alarm at rest or outside the parametric band,
  RL = 1 at least two roll periods before the roll passes 15° inside it) on
  simulated records.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

from optroute.errors import ConfigError, OptrouteError
from optroute.observer.io import MotionLogError, read_motion_log, read_righting_moment, write_motion_csv
from optroute.observer.level import (
    ObserverInputError,
    ObserverSettings,
    ResonanceObserver,
    RightingMoment,
    observe,
)
from optroute.observer.motions import (
    Encounter,
    RollModel,
    grim_effective_wave_ratio,
    simulate_motions,
    waterplane_average,
    waterplane_slope,
)
from optroute.physics import seaway
from optroute.physics.ship import Ship

ROOT = Path(__file__).resolve().parents[1]
DT = 0.02


@pytest.fixture(scope="module")
def ship():
    return Ship.preset("container_54k_dwt")


def band_speed_kn(ship: Ship, period_s: float, alpha_deg: float = 0.0) -> float:
    """The speed that puts T_E at exactly T_R / 2 (the principal parametric resonance)."""
    target = ship.roll_period_s / 2.0
    return brentq(lambda v: float(seaway.encounter_period_s(period_s, v, alpha_deg)) - target, 0.0, 40.0)


def lambda_eq_l_period_s(ship: Ship) -> float:
    """The wave period whose deep-water wavelength is the ship's length."""
    return math.sqrt(2.0 * math.pi * ship.length_m / seaway.G_MS2)


def hand_settings(**kw) -> ObserverSettings:
    """Plain settings for the hand-worked series: no pre-filter, unit inertia, no warm-up."""
    base = dict(
        sample_interval_s=DT,
        roll_inertia_knms2=1.0,
        smoothing_s=0.0,
        lookahead_s=5.0,
        hold_s=20.0,
        k1_ref_deg=1.0,
        k2_ref_kw=1.0,
        k3_ref_gain=0.25,
        k4_ref_per_s=0.02,
        heave_limit_m=2.0,
        roll_limit_deg=3.0,
        warmup_s=0.0,
    )
    base.update(kw)
    return ObserverSettings(**base)


def linear_moment(c_knm_per_rad: float = 1.0) -> RightingMoment:
    """M = c φ [kN·m], φ in rad, over ±10 m heave and ±90° roll (bilinear is exact for it)."""
    roll = np.array([-90.0, 90.0])
    m = c_knm_per_rad * np.radians(roll)
    return RightingMoment(heave_m=np.array([-10.0, 10.0]), roll_deg=roll, moment_knm=np.vstack([m, m]), source="linear")


# --------------------------------------------------------------------------- the criteria by hand


def test_k1_growing_sinusoid_closed_form():
    """K1 of φ = A0 e^{σt} cos(ωt − ψ) [deg] with heave z = sin(2ωt) [m].

    Heave up-crossings at 2ωt = 2πn, i.e. t_n = nπ/ω; the following
    down-crossing at t_n + π/(2ω).  There
        φ(t_n)          = A0 e^{σ t_n} cos(nπ − ψ)        = (−1)^n A0 e^{σ t_n} cos ψ
        φ(t_n + π/2ω)   = A0 e^{σ(t_n + π/2ω)} cos(nπ + π/2 − ψ) = (−1)^n A0 e^{σ(t_n + π/2ω)} sin ψ
    so K1_n = (−1)^n A0 e^{σ t_n} (cos ψ − e^{σπ/(2ω)} sin ψ).
    With A0 = 1°, σ = 0.01/s, ω = 0.4 rad/s, ψ = π/6: e^{σπ/2ω} = e^{0.03927} =
    1.040051, so K1_n = (−1)^n e^{0.0785398 n} (0.866025 − 0.520026) = (−1)^n 0.346000 e^{0.0785 n}.
    """
    a0, sigma, omega, psi = 1.0, 0.01, 0.4, math.pi / 6
    t = np.arange(0.0, 120.0, DT)
    roll = a0 * np.exp(sigma * t) * np.cos(omega * t - psi)
    heave = np.sin(2.0 * omega * t)
    res = observe(t, heave, roll, settings=hand_settings(), moment=linear_moment())
    k1 = res.criteria[:, 0]
    changes = np.flatnonzero(np.diff(k1) != 0) + 1
    assert changes.size >= 10
    for i in changes:
        n = round((t[i] - math.pi / (2 * omega)) * omega / math.pi)  # the down-crossing just passed
        expected = (-1) ** n * a0 * math.exp(sigma * n * math.pi / omega) * (0.866025404 - 1.040051 * 0.5)
        assert k1[i] == pytest.approx(expected, rel=2e-4, abs=1e-5)
    # the first few by the numbers of the docstring
    assert abs(k1[changes[0]]) == pytest.approx(0.346000 * math.exp(0.0785398), rel=2e-4)


@pytest.mark.parametrize("lag", [1, 2])
def test_k3_growing_sinusoid_closed_form(lag):
    """K3 of φ = A0 e^{σt} sin(ωt) with the roll inertia I [kN·m·s²].

    Upright passages at t_m = mπ/ω, where φ'(t_m) = A0 e^{σ t_m} (σ sin + ω cos)(ωt_m)
    = (−1)^m A0 ω e^{σ t_m}, so the roll energy there is E_m = ½ I A0² ω² e^{2σ t_m}
    and K3_m = E_m − E_{m−lag} = E_m (1 − e^{−2σ lag π/ω}); the relative gain
    K3_m / E_{m−lag} = e^{2σ lag π/ω} − 1.  With I = 1e6 kN·m·s², A0 = 1° =
    0.0174533 rad, ω = 0.4, σ = 0.01, lag 1: E_m = 24.3694 e^{0.157080 m} kJ and the
    gain is e^{0.157080} − 1 = 0.170089.
    """
    inertia, a0, sigma, omega = 1.0e6, 1.0, 0.01, 0.4
    t = np.arange(0.0, 100.0, DT)
    roll = a0 * np.exp(sigma * t) * np.sin(omega * t)
    heave = np.zeros_like(t)
    settings = hand_settings(roll_inertia_knms2=inertia, energy_lag=lag, energy_passages=1, k3_ref_gain=10.0)
    res = observe(t, heave, roll, settings=settings, moment=linear_moment())
    k3 = res.criteria[:, 2]
    changes = np.flatnonzero(np.diff(k3) != 0) + 1
    assert changes.size >= 8
    e0 = 0.5 * inertia * math.radians(a0) ** 2 * omega**2
    assert e0 == pytest.approx(24.3694, rel=1e-5)
    for i in changes:
        m = math.floor(t[i] * omega / math.pi)  # the passage just passed
        e_m = e0 * math.exp(2.0 * sigma * m * math.pi / omega)
        assert k3[i] == pytest.approx(e_m * (1.0 - math.exp(-2.0 * sigma * lag * math.pi / omega)), rel=2e-3)
        gain = math.exp(2.0 * sigma * lag * math.pi / omega) - 1.0
        assert res.normalised[i, 2] == pytest.approx(gain / 10.0, rel=2e-3)
    if lag == 1:
        assert math.exp(2.0 * sigma * math.pi / omega) - 1.0 == pytest.approx(0.170089, rel=1e-5)


def test_k2_is_righting_moment_times_roll_rate():
    """K2 = M_φ(z, φ) · φ' with φ' the backward difference (no pre-filter): c φ_n (φ_n − φ_{n−1}) / Δt."""
    c = 3.0e5
    t = np.arange(0.0, 30.0, DT)
    roll = 2.0 * np.sin(0.5 * t)
    res = observe(t, 0.3 * np.sin(t), roll, settings=hand_settings(), moment=linear_moment(c))
    r = np.radians(roll)
    expected = c * r[1:] * np.diff(r) / DT
    np.testing.assert_allclose(res.criteria[1:, 1], expected, rtol=1e-12, atol=1e-9)
    assert res.criteria[0, 1] == 0.0  # no rate before the second sample


def test_k4_rate_of_an_exponential_roll_power():
    """K4 / power level for φ = e^{σt} [deg], a roll that only grows (no ripple).

    With the linear characteristic M = c φ the power P = c φ φ' = c σ e^{2σt}
    (φ in rad) is one exponential, sampled x_n ∝ r^n, r = e^{2σΔt}.  The
    first-order filter y_n = y_{n−1} + a (x_n − y_{n−1}), a = Δt / (τ + Δt),
    passes it (once its start has died out) as y_n = G x_n with
    G = a r / (r − 1 + a); the backward difference (y_n − y_{n−1}) / Δt =
    y_n (1 − 1/r) / Δt is again ∝ r^n, and the second filter multiplies it
    by G, so K4 / y = G (1 − 1/r) / Δt.  With σ = 0.01/s, τ = 5 s, Δt = 0.02 s:
    r = e^{0.0004}, a = 0.02/5.02, G = 0.9090909…·(1 + O(Δt)), and K4 / y →
    2σ / (1 + 2στ) = 0.02 / 1.1 = 0.0181818 /s as Δt → 0.
    """
    sigma, tau, c = 0.01, 5.0, 1.0e4
    t = np.arange(0.0, 300.0, DT)
    roll = np.exp(sigma * t)
    # the normalised k4 is K4 / (level + 5 % of k2_ref) / k4_ref: with k2_ref tiny and k4_ref 1 it is K4 / level
    settings = hand_settings(lookahead_s=tau, k2_ref_kw=1e-12, k4_ref_per_s=1.0)
    res = observe(t, np.zeros_like(t), roll, settings=settings, moment=linear_moment(c))
    r, a = math.exp(2 * sigma * DT), DT / (tau + DT)
    gain = a * r / (r - 1 + a)
    ratio = res.normalised[t > 250.0, 3]
    np.testing.assert_allclose(ratio, gain * (1 - 1 / r) / DT, rtol=1e-7)
    assert ratio[-1] == pytest.approx(2 * sigma / (1 + 2 * sigma * tau), rel=2e-3)


def test_k5_closeness_to_the_limit_ellipse():
    """K5 = √((ẑ/z_lim)² + (φ̂/φ_lim)²) with ẑ, φ̂ the held peaks: 1.2 m and 2.4° against (2 m, 3°)
    give √(0.36 + 0.64) = 1 at the common peaks (every π/ω); the hold (τ = 20 s) lets them decay by
    at most e^{−π/(ωτ)} in between."""
    t = np.arange(0.0, 120.0, DT)
    res = observe(t, 1.2 * np.sin(0.35 * t), 2.4 * np.sin(0.35 * t), settings=hand_settings(), moment=linear_moment())
    k5 = res.criteria[t > 60.0, 4]
    assert k5.max() == pytest.approx(1.0, abs=1e-4)
    assert k5.min() > math.exp(-math.pi / 0.35 / 20.0) - 1e-9
    assert res.normalised[:, 4].max() <= 1.0


@pytest.mark.parametrize("combine", ["product", "sum", "max"])
def test_rl_combines_the_normalised_criteria(ship, combine):
    """RL from k1–k5 and the weights: Π k^w, Σ w k / Σ w, max over w > 0, recomputed with numpy."""
    w = (0.5, 1.0, 2.0, 0.0, 1.0)
    settings = ObserverSettings.for_ship(ship, combine=combine, weights=w)
    m = simulate_motions(ship, _band_encounter(ship, 4.0), duration_s=200.0, seed=5)
    res = observe(m.time_s, m.heave_m, m.roll_deg, settings=settings, moment=RightingMoment.from_ship(ship))
    k, wa = res.normalised, np.array(w)
    expected = {
        "product": np.prod(k**wa, axis=1),
        "sum": (k * wa).sum(axis=1) / wa.sum(),
        "max": k[:, wa > 0].max(axis=1),
    }[combine]
    warm = res.time_s < settings.warmup_s - 1e-9
    assert np.isnan(res.rl[warm]).all()
    np.testing.assert_allclose(res.rl[~warm], expected[~warm], rtol=1e-12, atol=1e-15)
    assert ((res.rl[~warm] >= 0) & (res.rl[~warm] <= 1)).all()


# --------------------------------------------------------------------------- streaming and batch


def test_streaming_equals_batch(ship):
    settings = ObserverSettings.for_ship(ship)
    moment = RightingMoment.from_ship(ship)
    m = simulate_motions(ship, _band_encounter(ship, 4.0), duration_s=240.0, seed=7)
    batch = observe(m.time_s, m.heave_m, m.roll_deg, settings=settings, moment=moment)
    one = ResonanceObserver(settings, moment)
    stream = np.array([one.update(z, r) for z, r in zip(m.heave_m, m.roll_deg, strict=True)])
    np.testing.assert_array_equal(stream, batch.rl)  # NaN during the warm-up in both
    np.testing.assert_array_equal(one.criteria[0], batch.criteria[-1])
    chunks = ResonanceObserver(settings, moment)
    rng = np.random.default_rng(0)
    cuts = np.sort(rng.choice(np.arange(1, m.time_s.size), 40, replace=False))
    parts = [
        chunks.update_many(z, r)[0] for z, r in zip(np.split(m.heave_m, cuts), np.split(m.roll_deg, cuts), strict=True)
    ]
    np.testing.assert_array_equal(np.concatenate(parts), batch.rl)
    assert one.count == chunks.count == m.time_s.size
    assert np.nanmax(batch.rl) == 1.0  # the record does contain an alarm


# --------------------------------------------------------------------------- the simulator


def _band_encounter(ship: Ship, hs_m: float, alpha_deg: float = 0.0) -> Encounter:
    period = lambda_eq_l_period_s(ship)
    return Encounter(hs_m=hs_m, period_s=period, alpha_deg=alpha_deg, speed_kn=band_speed_kn(ship, period, alpha_deg))


def _floquet_rate(w0: float, zeta: float, h: float, we: float) -> float:
    """Growth rate of φ'' + 2ζω0 φ' + ω0² (1 − h cos ω_e t) φ = 0 from its monodromy matrix."""
    te = 2 * math.pi / we

    def rhs(t, y):
        return [y[1], -2 * zeta * w0 * y[1] - w0**2 * (1 - h * math.cos(we * t)) * y[0]]

    cols = [solve_ivp(rhs, (0, te), y0, rtol=1e-11, atol=1e-13).y[:, -1] for y0 in ([1.0, 0.0], [0.0, 1.0])]
    mono = np.column_stack(cols)
    return math.log(max(abs(np.linalg.eigvals(mono)))) / te


@pytest.mark.parametrize("hs_m", [2.0, 3.0, 4.0])
def test_roll_growth_rate_matches_floquet(ship, hs_m):
    """In the band the roll grows at the Floquet rate of the linear damped Mathieu equation (small angles,
    no quadratic damping, no noise); the rate rises with the wave height."""
    model = RollModel(quadratic_damping_per_rad=0.0, random_moment_deg=0.0, roll_noise_deg=0.0)
    enc = _band_encounter(ship, hs_m)
    m = simulate_motions(ship, enc, duration_s=600.0, model=model, initial_roll_deg=0.05)
    w0, we = 2 * math.pi / m.roll_period_s, 2 * math.pi / m.encounter_period_s
    expected = _floquet_rate(w0, model.damping_ratio, m.gm_ratio, we)
    roll = np.abs(m.true_roll_deg)
    sel = (roll > 0.1) & (roll < 2.0)
    peaks = np.flatnonzero((roll[1:-1] > roll[:-2]) & (roll[1:-1] >= roll[2:]) & sel[1:-1]) + 1
    rate = np.polyfit(m.time_s[peaks], np.log(roll[peaks]), 1)[0]
    assert expected > 0
    assert rate == pytest.approx(expected, rel=0.03)


def test_roll_grows_in_the_band_faster_in_higher_waves_and_decays_outside(ship):
    quiet = RollModel(random_moment_deg=0.0, roll_noise_deg=0.0)
    amp = {}
    for hs in (2.0, 3.0, 4.0):
        m = simulate_motions(ship, _band_encounter(ship, hs), duration_s=150.0, model=quiet, initial_roll_deg=0.5)
        amp[hs] = np.abs(m.true_roll_deg[m.time_s > 130.0]).max()
    assert 0.5 < amp[2.0] < amp[3.0] < amp[4.0]
    period = lambda_eq_l_period_s(ship)
    outside = Encounter(hs_m=4.0, period_s=period, alpha_deg=0.0, speed_kn=5.0)  # T_E / T_R = 0.66
    assert outside.encounter_period_s / ship.roll_period_s > 0.6
    m = simulate_motions(ship, outside, duration_s=300.0, model=quiet, initial_roll_deg=0.5)
    assert np.abs(m.true_roll_deg[m.time_s > 250.0]).max() < 0.05


def test_grim_effective_wave_and_waterplane_averages_by_brute_force():
    """R(u) against a least-squares fit of c0 + c1 cos(2πx/L) to cos(kx) on 2001 points; F(u) and G(u)
    against quad over the parabolic waterplane."""
    x = np.linspace(-0.5, 0.5, 2001)  # x / L
    for lam_over_l in (0.6, 1.0, 1.5, 3.0):
        u = math.pi / lam_over_l
        a = np.column_stack([np.ones_like(x), np.cos(2 * math.pi * x)])
        coef = np.linalg.lstsq(a, np.cos(2 * u * x), rcond=None)[0]
        assert float(grim_effective_wave_ratio(u)) == pytest.approx(coef[1], abs=2e-3)
        f = quad(lambda s, u=u: 0.75 * math.cos(u * s) * (1 - s * s), -1, 1)[0]
        assert float(waterplane_average(u)) == pytest.approx(f, rel=1e-9)
        g = quad(lambda s, u=u: s * math.sin(u * s) * (1 - s * s), -1, 1)[0] / (u * 4 / 15)
        assert float(waterplane_slope(u)[0]) == pytest.approx(g, rel=1e-9)
    assert float(grim_effective_wave_ratio(math.pi)) == 1.0


# --------------------------------------------------------------------------- the observer on simulated cases


@pytest.mark.parametrize(
    ("hs_m", "period_s", "alpha_deg", "speed_kn"),
    [
        (0.0, 10.0, 0.0, 15.0),  # at rest: no waves
        (4.0, None, 0.0, 5.0),  # head seas, T_E / T_R = 0.66
        (4.0, None, 180.0, 10.0),  # following seas, T_E / T_R = 1.0
        (5.0, 10.0, 90.0, 15.0),  # beam seas: forced roll, no GM variation
        (3.0, 9.0, 30.0, 22.0),  # bow seas, T_E / T_R = 0.36
    ],
)
def test_no_alarm_at_rest_or_outside_the_band(ship, hs_m, period_s, alpha_deg, speed_kn):
    period = lambda_eq_l_period_s(ship) if period_s is None else period_s
    enc = Encounter(hs_m=hs_m, period_s=period, alpha_deg=alpha_deg, speed_kn=speed_kn)
    ratio = enc.encounter_period_s / ship.roll_period_s
    m = simulate_motions(ship, enc, duration_s=600.0, seed=11)
    assert not (0.4 <= ratio <= 0.6 and m.gm_ratio > 0.1)  # outside the band (or no GM variation)
    res = observe(
        m.time_s, m.heave_m, m.roll_deg, settings=ObserverSettings.for_ship(ship), moment=RightingMoment.from_ship(ship)
    )
    assert np.nanmax(res.rl) < 0.2


@pytest.mark.parametrize(("hs_m", "alpha_deg", "seed"), [(3.0, 0.0, 1), (4.0, 0.0, 2), (4.0, 0.0, 3), (5.0, 45.0, 4)])
def test_alarm_in_the_band_two_roll_periods_ahead(ship, hs_m, alpha_deg, seed):
    enc = _band_encounter(ship, hs_m, alpha_deg)
    m = simulate_motions(ship, enc, duration_s=600.0, seed=seed)
    res = observe(
        m.time_s, m.heave_m, m.roll_deg, settings=ObserverSettings.for_ship(ship), moment=RightingMoment.from_ship(ship)
    )
    over = np.flatnonzero(np.abs(m.true_roll_deg) > 15.0)
    assert over.size, "the case must develop parametric roll"
    t15 = m.time_s[over[0]]
    t_alarm = res.first_time_s(1.0)
    assert t_alarm < t15
    assert np.abs(m.true_roll_deg[m.time_s <= t_alarm]).max() < 15.0
    assert t15 - t_alarm >= 2.0 * ship.roll_period_s


# --------------------------------------------------------------------------- inputs and files


def test_bad_inputs_raise_optroute_errors(ship):
    settings = ObserverSettings.for_ship(ship)
    moment = RightingMoment.from_ship(ship)
    t = np.arange(0.0, 10.0, DT)
    with pytest.raises(ObserverInputError, match="not evenly spaced"):
        observe(np.r_[t[:100], t[101:]], np.zeros(t.size - 1), np.zeros(t.size - 1), settings=settings, moment=moment)
    with pytest.raises(ObserverInputError, match="sample_interval_s=0.1"):
        observe(np.arange(0.0, 10.0, 0.1), np.zeros(100), np.zeros(100), settings=settings, moment=moment)
    roll = np.zeros(t.size)
    roll[7] = np.nan
    with pytest.raises(ObserverInputError, match="sample 7"):
        observe(t, np.zeros(t.size), roll, settings=settings, moment=moment)
    with pytest.raises(ObserverInputError, match="outside the righting-moment characteristic"):
        observe(t, np.zeros(t.size), np.full(t.size, 70.0), settings=settings, moment=moment)
    obs = ResonanceObserver(settings, moment)
    obs.update_many(np.zeros(50), np.ones(50))
    kept = obs.update_many(np.zeros(5), np.ones(5))
    fresh = ResonanceObserver(settings, moment)
    fresh.update_many(np.zeros(50), np.ones(50))
    with pytest.raises(ObserverInputError, match="sample 52"):
        fresh.update_many(np.zeros(5), [1.0, 1.0, 5000.0, 5000.0, 1.0])
    assert fresh.count == 50  # the bad chunk is refused whole
    np.testing.assert_array_equal(fresh.update_many(np.zeros(5), np.ones(5))[1], kept[1])
    with pytest.raises(ConfigError, match="combine="):
        ObserverSettings.for_ship(ship, combine="mean")
    with pytest.raises(ConfigError, match="weights="):
        ObserverSettings.for_ship(ship, weights=(0, 0, 0, 0, 0))
    with pytest.raises(ConfigError, match="roll_deg axis"):
        RightingMoment(heave_m=[0, 1], roll_deg=[0, 0], moment_knm=np.zeros((2, 2)))
    with pytest.raises(OptrouteError, match="hs_m"):
        Encounter(hs_m=-1.0, period_s=10.0, alpha_deg=0.0, speed_kn=10.0)


def test_csv_and_netcdf_logs_round_trip(tmp_path):
    t = np.arange(0.0, 4.0, DT)
    z, r, p = np.sin(t), 2.0 * np.cos(t), 0.5 * np.sin(2 * t)
    path = write_motion_csv(tmp_path / "m.csv", t, z, r, p)
    log = read_motion_log(path)
    np.testing.assert_allclose(log.roll_deg, r, rtol=1e-9)
    np.testing.assert_allclose(log.time_s, t, rtol=0, atol=1e-12)
    # radians are converted, pitch is optional
    (tmp_path / "rad.csv").write_text("time_s,heave_m,roll_rad\n0,0,0.1\n0.02,0.1,0.2\n")
    log = read_motion_log(tmp_path / "rad.csv")
    np.testing.assert_allclose(log.roll_deg, np.degrees([0.1, 0.2]))
    assert log.pitch_deg is None
    ds = xr.Dataset(
        {
            "heave": ("time", z, {"units": "m"}),
            "roll": ("time", np.radians(r), {"units": "rad"}),
            "pitch": ("time", p, {"units": "degrees"}),
        },
        coords={"time": ("time", t, {"units_note": "seconds"})},
    )
    ds["time"].attrs["units"] = "s"
    ds.to_netcdf(tmp_path / "m.nc", engine="h5netcdf")
    log = read_motion_log(tmp_path / "m.nc")
    np.testing.assert_allclose(log.roll_deg, r, rtol=1e-12)
    ds["roll"].attrs["units"] = "furlongs"
    ds.to_netcdf(tmp_path / "bad.nc", engine="h5netcdf")
    with pytest.raises(MotionLogError, match="'roll' has units='furlongs'"):
        read_motion_log(tmp_path / "bad.nc")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time_s,heave_m\n0,0\n0.02,0\n", "no roll column"),
        ("time_s,heave_m,roll\n0,0,0\n0.02,0,0\n", "column 'roll' names no unit"),
        ("time_s,heave_m,roll_deg\n0,0,0\n0.02,x,0\n", "column 'heave_m' row 3 holds 'x'"),
        ("time_s,heave_m,roll_deg\n0,0,0\n0.02,0\n", "row 3 has 2 fields"),
        ("time_s,heave_m,roll_deg\n0,0,0\n", "a header and >= 2 rows"),
        ("time_s,heave_m,roll_deg,roll_rad\n0,0,0,0\n0.02,0,0,0\n", "keep one"),
    ],
)
def test_bad_csv_logs_name_the_column_and_the_fix(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(MotionLogError, match=message):
        read_motion_log(path)
    with pytest.raises(MotionLogError, match="does not exist"):
        read_motion_log(tmp_path / "none.csv")


def test_righting_moment_table_from_csv(tmp_path):
    rows = ["heave_m,roll_deg,moment_knm"]
    for z in (-1.0, 1.0):
        for phi in (-30.0, 0.0, 30.0):
            rows.append(f"{z},{phi},{1000.0 * phi - 10.0 * z * phi}")
    (tmp_path / "gz.csv").write_text("\n".join([rows[0], *rows[:0:-1]]))  # any row order
    table = read_righting_moment(tmp_path / "gz.csv")
    assert table.moment_knm.shape == (2, 3)
    assert table.moment_knm[1, 2] == pytest.approx(30000.0 - 300.0)
    (tmp_path / "hole.csv").write_text("\n".join(rows[:-1]))
    with pytest.raises(MotionLogError, match="do not fill the grid"):
        read_righting_moment(tmp_path / "hole.csv")


def test_cli_observe(ship, tmp_path, capsys):
    # in-process (optroute.cli.main, as the console script calls it): the process boundary of the same entry point
    # is tested once in tests/test_cli.py (test_console_script, test_help_and_version_in_a_fresh_interpreter)
    from optroute.cli import main

    m = simulate_motions(ship, _band_encounter(ship, 4.0), duration_s=240.0, seed=3)
    log = write_motion_csv(tmp_path / "motions.csv", m.time_s, m.heave_m, m.roll_deg, m.pitch_deg)
    code = main(["observe", str(log), "--plot", str(tmp_path / "obs.png"), "--every", "30"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "RL reaches 1 first at t = " in out
    assert "K3_kJ" in out and "time_s" in out
    assert (tmp_path / "obs.png").stat().st_size > 10_000
    (tmp_path / "bare.csv").write_text("time_s,heave_m,roll\n0,0,0\n0.02,0,0\n")
    code = main(["observe", str(tmp_path / "bare.csv")])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.startswith("optroute: error: ") and err.count("\n") == 1 and "roll_deg" in err


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    cuts=st.lists(st.integers(1, 2999), max_size=12),
    combine=st.sampled_from(["product", "sum", "max"]),
)
def test_any_record_any_chunking_gives_the_batch_rl_in_0_1(seed, cuts, combine):
    """Invariants: RL is NaN exactly in the warm-up and in [0, 1] after it, whatever the motions, and
    feeding the record in any chunks gives the batch RL bit for bit."""
    ship = Ship.preset("general_cargo_25k_dwt")
    rng = np.random.default_rng(seed)
    n = 3000
    t = np.arange(n) * DT
    heave = np.cumsum(rng.normal(0, 0.05, n))
    roll = 20.0 * np.sin(np.cumsum(rng.normal(0, 0.05, n)))
    settings_ = ObserverSettings.for_ship(ship, combine=combine)
    moment = RightingMoment.from_ship(ship, heave_range_m=1e3)
    batch = observe(t, heave, roll, settings=settings_, moment=moment)
    warm = np.arange(n) < round(settings_.warmup_s / DT)
    assert np.isnan(batch.rl[warm]).all()
    assert ((batch.rl[~warm] >= 0.0) & (batch.rl[~warm] <= 1.0)).all()
    obs = ResonanceObserver(settings_, moment)
    parts = np.split(np.arange(n), sorted(set(cuts)))
    rl = np.concatenate([obs.update_many(heave[p], roll[p])[0] for p in parts])
    np.testing.assert_array_equal(rl, batch.rl)
