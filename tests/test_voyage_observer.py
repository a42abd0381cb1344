"""The parametric-roll observer of thyssenkrupp EP 2377756 wired into the voyage simulator.

References, independent of the simulator:

* the encounter: the deep-water encounter period of head seas, T_E = 2π / (ω + ω² V / g), and the
  wave of length L (λ = L, T = √(2π L / g)), where parametric roll is strongest;
* the danger: the roll model left alone at the plan's speed (``simulate_motions`` for half an
  hour) passes 15°, while the Boeing band (Hs >= 0.04 L = 10 m) does not apply at Hs 4 m — the
  plan and the master's rules see nothing;
* stability of the intervention's speed: the Floquet exponent of the damped Mathieu equation
  computed here with scipy's ``solve_ivp`` (not the simulator's own monodromy).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import optroute as orx
from optroute.errors import ConfigError
from optroute.observer.level import ObserverSettings, ResonanceObserver, RightingMoment
from optroute.observer.motions import Encounter, RollModel, gm_amplitude_ratio, simulate_motions
from optroute.voyage import OnboardObserver, ReplanPolicy
from optroute.weather import scenarios as sc

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
A, B = (30.0, -150.0), (30.0, -148.5)  # 78 nm due east
LAMBDA_EQ_L_PERIOD_S = math.sqrt(2.0 * math.pi * SHIP.length_m / 9.80665)
PLAN_KN = 18.0  # T_E / T_R = 0.504 in head seas of that period (hand-worked below)


def _head_seas(benign_after_h: float | None = None):
    ds = sc.uniform(
        hs_m=4.0,
        tp_s=LAMBDA_EQ_L_PERIOD_S,
        wave_from_deg=90.0,
        start=T0,
        duration_h=24.0,
        step_h=1.0,
        resolution_deg=1.0,
        bbox=(20, 40, -160, -130),
    )
    if benign_after_h is not None:  # short waves from then on: λ = 40 m, no GM variation to speak of
        late = ds.time >= T0 + np.timedelta64(int(benign_after_h * 3600), "s")
        ds["tp_s"] = ds.tp_s.where(~late, 5.0)
    return ds


def _plan(weather):
    return orx.Plan.from_schedule(np.array([A, B]), np.array([PLAN_KN]), departure=T0, ship=SHIP, weather=weather)


def _floquet_rate_scipy(speed_kn: float) -> float:
    """Largest Floquet exponent [1/s] of φ'' + 2ζω0 φ' + ω0² (1 − h cos ω_e t) φ = 0 in the head seas."""
    enc = Encounter(hs_m=4.0, period_s=LAMBDA_EQ_L_PERIOD_S, alpha_deg=0.0, speed_kn=speed_kn)
    model = RollModel()
    w0, zeta, h = 2 * math.pi / SHIP.roll_period_s, model.damping_ratio, gm_amplitude_ratio(SHIP, enc, model)
    omega = 2 * math.pi / LAMBDA_EQ_L_PERIOD_S
    we = omega + omega**2 * speed_kn * 1852 / 3600 / 9.80665  # head seas, deep water
    te = 2 * math.pi / we

    def rhs(t, y):
        return [y[1], -2 * zeta * w0 * y[1] - w0**2 * (1 - h * math.cos(we * t)) * y[0]]

    cols = [solve_ivp(rhs, (0, te), y0, rtol=1e-10, atol=1e-12).y[:, -1] for y0 in ([1.0, 0.0], [0.0, 1.0])]
    return math.log(max(abs(np.linalg.eigvals(np.column_stack(cols))))) / te


@pytest.fixture(scope="module")
def head_seas_voyage():
    truth = _head_seas()
    return orx.simulate_voyage(
        _plan(truth),
        truth,
        SHIP,
        replan=ReplanPolicy.never(),
        observer=OnboardObserver(window_s=300.0, replan=False),
        step_h=0.5,
    )


def test_the_case_is_a_parametric_resonance_that_the_bands_do_not_see():
    omega = 2 * math.pi / LAMBDA_EQ_L_PERIOD_S
    te = 2 * math.pi / (omega + omega**2 * PLAN_KN * 1852 / 3600 / 9.80665)
    assert te / SHIP.roll_period_s == pytest.approx(0.5, abs=0.01)
    assert 4.0 < 0.04 * SHIP.length_m  # below the Boeing bands' Hs threshold: the plan verifies
    assert not _plan(_head_seas()).verify()
    enc = Encounter(hs_m=4.0, period_s=LAMBDA_EQ_L_PERIOD_S, alpha_deg=0.0, speed_kn=PLAN_KN)
    left_alone = simulate_motions(SHIP, enc, duration_s=1800.0)
    assert np.abs(left_alone.true_roll_deg).max() > 15.0


def test_the_observer_raises_the_alarm_before_15_deg_and_the_ship_slows_to_a_stable_speed(head_seas_voyage):
    r = head_seas_voyage
    log = r.log
    assert r.outcome.n_observer_alarms == 1
    first = int(np.flatnonzero(log.observer_alarm.values)[0])
    assert first == 0  # in the first step: the sea is resonant from the departure
    assert log.rl_max.values[first] >= 0.8
    assert log.roll_max_deg.values[first] < 15.0
    assert r.outcome.max_roll_deg < 15.0
    after = log.intervention.values.astype(bool)
    assert after[first + 1 :].all()  # the sea never changes: the intervention holds to the end
    slow = float(log.stw_kn.values[first + 1])
    assert slow < PLAN_KN
    assert _floquet_rate_scipy(slow) < 0.0 < _floquet_rate_scipy(slow + 0.5)  # the nearest stable speed below
    assert (log.commanded_stw_kn.values == PLAN_KN).all()  # the log keeps the plan's speed beside the one sailed
    assert np.nanmax(log.rl_max.values[first + 2 :]) < 0.2  # the roll has died out


def test_outside_the_band_the_observer_stays_quiet_and_the_voyage_is_unchanged():
    truth = _head_seas(benign_after_h=0.0)
    plan = _plan(truth)
    common = {"replan": ReplanPolicy.never(), "step_h": 0.5}
    watched = orx.simulate_voyage(plan, truth, SHIP, observer=OnboardObserver(window_s=120.0), **common)
    plain = orx.simulate_voyage(plan, truth, SHIP, **common)
    assert watched.outcome.n_observer_alarms == 0
    assert np.nanmax(watched.log.rl_max.values) < 0.2
    assert watched.outcome.fuel_t == pytest.approx(plain.outcome.fuel_t, rel=1e-12)
    assert watched.outcome.arrival == plain.outcome.arrival
    assert "rl_max" not in plain.log and math.isnan(plain.outcome.max_roll_deg)


def test_when_the_sea_changes_the_intervention_ends_and_the_voyage_replans_from_there():
    truth = _head_seas(benign_after_h=2.0)
    r = orx.simulate_voyage(
        _plan(truth),
        truth,
        SHIP,
        forecasts=[(T0, truth)],
        replan=ReplanPolicy.never(),
        observer=OnboardObserver(window_s=120.0, hold_h=1.0),
        step_h=0.5,
        optimise_options={"max_leg_nm": 40.0},
        corridor_width_nm=20.0,
    )
    log = r.log
    acting = np.flatnonzero(log.intervention.values)
    assert r.outcome.n_observer_alarms == 1 and acting.size
    ends = log.step_time.values[acting[-1]] + np.timedelta64(int(log.duration_h.values[acting[-1]] * 3.6e12), "ns")
    assert ends >= T0 + np.timedelta64(2, "h")  # held until the resonant sea was gone
    reasons = list(log.replan_reason.values)
    assert reasons[0] == "initial plan" and reasons[1].startswith("observer: RL reached 0.8")
    assert r.outcome.n_replans == 1
    assert log.replan_time.values[1] == ends  # re-planned where the intervention ended


def test_update_until_feeds_exactly_the_samples_up_to_the_first_alarm():
    enc = Encounter(hs_m=4.0, period_s=LAMBDA_EQ_L_PERIOD_S, alpha_deg=0.0, speed_kn=PLAN_KN)
    m = simulate_motions(SHIP, enc, duration_s=600.0)
    settings, moment = ObserverSettings.for_ship(SHIP), RightingMoment.from_ship(SHIP)
    full = ResonanceObserver(settings, moment).update_many(m.heave_m, m.roll_deg)[0]
    first = int(np.flatnonzero(full >= 0.8)[0])
    obs = ResonanceObserver(settings, moment)
    cut = obs.update_until(m.heave_m, m.roll_deg, 0.8)
    np.testing.assert_array_equal(cut, full[: first + 1])
    assert obs.count == first + 1
    rest = obs.update_many(m.heave_m[first + 1 :], m.roll_deg[first + 1 :])[0]
    np.testing.assert_array_equal(rest, full[first + 1 :])  # the state is exactly the streaming one


def test_the_simulator_continued_in_pieces_equals_one_record():
    enc = Encounter(hs_m=4.0, period_s=LAMBDA_EQ_L_PERIOD_S, alpha_deg=0.0, speed_kn=PLAN_KN)
    quiet = RollModel(random_moment_deg=0.0, roll_noise_deg=0.0, pitch_noise_deg=0.0, heave_noise_m=0.0)
    whole = simulate_motions(SHIP, enc, duration_s=200.0, model=quiet, initial_roll_deg=0.5)
    k = 4000  # the sample at 80 s
    rest = simulate_motions(
        SHIP,
        enc,
        duration_s=120.0,
        model=quiet,
        start_s=float(whole.time_s[k]),
        initial_roll_deg=float(whole.true_roll_deg[k]),
        initial_roll_rate_deg_s=float((whole.true_roll_deg[k + 1] - whole.true_roll_deg[k - 1]) / 0.04),
    )
    np.testing.assert_allclose(
        rest.true_roll_deg, whole.true_roll_deg[k:], atol=2e-3 * np.abs(whole.true_roll_deg).max()
    )
    np.testing.assert_allclose(rest.heave_m, whole.heave_m[k:], atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"threshold": 1.5}, "threshold=1.5"),
        ({"threshold": 0.0}, "threshold must be > 0.0, got 0.0"),
        ({"window_s": -1.0}, "window_s must be > 0.0, got -1.0"),
        ({"hold_h": float("nan")}, "hold_h must be finite, got nan"),
        ({"settings": "x"}, "settings must be"),
    ],
)
def test_bad_observer_settings_are_errors_naming_the_value(kwargs, named):
    with pytest.raises(ConfigError, match=named):
        OnboardObserver(**kwargs)


def test_an_observer_of_the_wrong_type_is_an_error():
    truth = _head_seas()
    with pytest.raises(ConfigError, match="observer must be an OnboardObserver"):
        orx.simulate_voyage(_plan(truth), truth, SHIP, observer="yes")


def test_cli_simulate_with_the_observer_reports_its_alarms(tmp_path, capsys):
    from optroute.cli import main

    wx = sc.calm(start=T0, duration_h=24.0, step_h=3.0, resolution_deg=1.0, bbox=(20, 40, -160, -130))
    truth = tmp_path / "truth.nc"
    wx.to_netcdf(truth)
    code = main([
        "simulate", "--truth", str(truth), "--forecast", f"2024-01-10T00:00={truth}", "--from", "30,-150",
        "--to", "30,-149", "--depart", "2024-01-10T00:00", "--observer", "0.8", "--out", str(tmp_path / "v") + "/",
    ])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert "parametric-roll observer: 0 alarm(s) at RL >= 0.8" in out
