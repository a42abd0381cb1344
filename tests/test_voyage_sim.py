"""The voyage simulator (optroute.voyage) against the plan evaluator, a hand-worked calm passage and its own rules.

References, all independent of the simulator's stepping:

* calm water: the ship sails the plan's speed, so it arrives after D / V and burns
  (D / V) · fuel_rate(calm power(V)) from the Ship's own performance model;
* truth = forecast: the plan's arrival and fuel are :meth:`optroute.Plan.from_schedule`'s dense
  evaluation (:func:`optroute.plan.evaluate.evaluate_track`), which shares no stepping code with
  the simulator;
* a storm the forecast places 300 nm north of its true track (built with
  :func:`optroute.scenarios.storm_forecast`): the first plan sailed blind meets a danger band of
  the truth (the band check is :func:`optroute.physics.safety.is_speed_forbidden`).
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.physics.performance import default_model
from optroute.voyage import ForecastSequence, ForecastTimeError, ReplanPolicy, VoyageOutcome
from optroute.weather import scenarios as sc

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
A, B = (30.0, -150.0), (30.0, -140.0)
STEP_H = 0.25


def _calm(hours: float = 60.0):
    return sc.calm(start=T0, duration_h=hours, step_h=3.0, resolution_deg=1.0, bbox=(20, 40, -160, -130))


def _hours(td) -> float:
    return float(td / np.timedelta64(1, "ns")) / 3.6e12


# --------------------------------------------------------------------------- policies and forecasts


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"every_h": 0.0}, "every_h=0.0"),
        ({"every_h": -3}, "every_h=-3"),
        ({"hs_threshold_m": float("nan")}, "hs_threshold_m=nan"),
        ({"direction_threshold_deg": 200.0}, "direction_threshold_deg=200.0"),
        ({"period_threshold_s": "x"}, "period_threshold_s='x'"),
        ({"min_interval_h": -1.0}, "min_interval_h=-1.0"),
        ({"on_forecast": "yes"}, "on_forecast='yes'"),
    ],
)
def test_bad_policies_are_errors_naming_the_value(kwargs, named):
    with pytest.raises(ConfigError, match=named.replace("(", r"\(")):
        ReplanPolicy(**kwargs)


def test_policy_never_has_no_trigger_and_the_default_replans_on_forecasts():
    assert not ReplanPolicy.never().replans
    assert ReplanPolicy().replans and ReplanPolicy().on_forecast


def test_outcome_is_validated():
    with pytest.raises(ConfigError, match="fuel_t=-1"):
        VoyageOutcome(T0, T0, -1.0, 0.0, 0.0, 0.0, None, 0)
    with pytest.raises(ConfigError, match="before the departure"):
        VoyageOutcome(T0, T0 - np.timedelta64(1, "h"), 1.0, 0.0, 0.0, 0.0, None, 0)
    o = VoyageOutcome(T0, T0 + np.timedelta64(10, "h"), 1.0, 1.0, 0.0, 0.0, T0 + np.timedelta64(9, "h"), 0)
    assert o.eta_miss_h == pytest.approx(1.0) and o.eta_met is False and o.duration_h == pytest.approx(10.0)


def test_a_forecast_used_before_its_issue_time_is_an_error_naming_both_times():
    issued = T0 + np.timedelta64(6, "h")
    fs = ForecastSequence([(issued, _calm())])
    with pytest.raises(ForecastTimeError, match="2024-01-10T06:00:00Z.*2024-01-10T00:00:00Z"):
        fs.get(0, T0)
    # the simulator asks for the first plan's forecast at the departure: the same error, before any planning
    with pytest.raises(
        ForecastTimeError, match="issued at 2024-01-10T06:00:00Z cannot be used at 2024-01-10T00:00:00Z"
    ):
        orx.simulate_voyage((A, B), _calm(), SHIP, forecasts=[(issued, _calm())], departure=T0)


def test_forecast_sequence_picks_the_newest_issued():
    a, b = _calm(), _calm()
    fs = ForecastSequence([(T0 + np.timedelta64(6, "h"), b), (T0, a)])
    assert fs.latest(T0 + np.timedelta64(5, "h"))[1] is a
    assert fs.latest(T0 + np.timedelta64(6, "h"))[1] is b
    with pytest.raises(ConfigError, match="share an issue time"):
        ForecastSequence([(T0, a), (T0, b)])


# --------------------------------------------------------------------------- sailing a plan


def test_calm_passage_matches_the_hand_worked_time_and_fuel():
    wx = _calm()
    v = 15.0
    plan = orx.Plan.from_schedule([A, B], [v], departure=T0, ship=SHIP, weather=wx, use_land_mask=False)
    res = orx.simulate_voyage(plan, wx, SHIP, replan=ReplanPolicy.never(), step_h=STEP_H)
    d = float(geo.distance_nm(*A, *B))
    model = default_model(SHIP)
    fuel = d / v * float(model.fuel_rate_tph(model.brake_power_kw(v)))
    assert res.outcome.duration_h == pytest.approx(d / v, abs=1e-6)
    assert res.outcome.fuel_t == pytest.approx(fuel, rel=1e-9)
    assert res.outcome.distance_nm == pytest.approx(d, rel=1e-9)
    assert res.outcome.time_in_band_h == 0.0 and res.outcome.n_replans == 0
    assert res.log.sizes["step"] == int(np.ceil(d / v / STEP_H))


def test_truth_equal_to_the_forecast_reproduces_the_plan():
    """A plan through a moving storm, sailed in the same weather: its arrival to the step, its fuel to 1 %."""
    wx = sc.moving_storm(
        32.0,
        -146.0,
        180.0,
        8.0,
        peak_hs_m=7.0,
        radius_nm=200.0,
        start=T0,
        duration_h=60.0,
        step_h=3.0,
        resolution_deg=0.5,
        bbox=(20, 42, -156, -134),
    )
    mid = geo.intermediate_points(*A, *B, np.linspace(0.0, 1.0, 6))
    wp = np.column_stack(mid)
    plan = orx.Plan.from_schedule(
        wp, [15.0, 14.0, 14.5, 16.0, 15.0], departure=T0, ship=SHIP, weather=wx, use_land_mask=False
    )
    assert plan.verify() == []
    res = orx.simulate_voyage(plan, wx, SHIP, forecasts=[(T0, wx)], replan=ReplanPolicy.never(), step_h=STEP_H)
    o = res.outcome
    assert abs(_hours(o.arrival - plan.arrival)) <= STEP_H
    assert o.fuel_t == pytest.approx(plan.total_fuel_t, rel=0.01)
    assert o.time_in_band_h == 0.0 and o.time_slowed_h == 0.0
    assert np.allclose(res.log["stw_kn"], res.log["commanded_stw_kn"])
    assert res.log["fuel_t"].sum() == pytest.approx(o.fuel_t)


# --------------------------------------------------------------------------- a storm the forecast misplaces


def _storm_case():
    """A 12.5 m storm moving south at 10 kn across the route near 145 W (the truth), forecast 300 nm north.

    The first forecast (issued at departure) carries the whole 300 nm track error; the second,
    issued 3 h later, has converged on the truth (:func:`optroute.scenarios.converging_forecasts`).
    """
    storm = sc.moving_storm_spec(34.0, -145.0, 180.0, 10.0, peak_hs_m=12.5, radius_nm=150.0, duration_h=60.0)
    kw = {"start": T0, "duration_h": 60.0, "step_h": 3.0, "resolution_deg": 0.5, "bbox": (18, 42, -156, -134)}
    truth = sc.storm_dataset([storm], background_hs_m=1.5, **kw)
    forecasts = sc.converging_forecasts(
        [storm], [0.0, 3.0], converged_h=3.0, displacement_nm=300.0, bearing_deg=0.0, background_hs_m=1.5, **kw
    )
    return truth, forecasts


STORM_OPTS = {
    "max_leg_nm": 30.0,
    "samples_per_leg": 5,
    "band_margin": 0.05,
    "band_hs_margin": 0.1,
    "use_land_mask": False,
}


@pytest.fixture(scope="module")
def storm_voyages():
    truth, forecasts = _storm_case()
    eta = T0 + np.timedelta64(42, "h")
    common = {
        "forecasts": forecasts,
        "departure": T0,
        "eta": eta,
        "optimise_options": STORM_OPTS,
        "corridor_width_nm": 400.0,
        "step_h": 0.5,
    }
    replanned = orx.simulate_voyage((A, B), truth, SHIP, replan=ReplanPolicy(), **common)
    # Sailed blind: the same first plan (made at the departure on the first forecast, as simulate_voyage makes it
    # from the ports; Ipopt is deterministic on the same inputs), never re-planned. Planned once, not twice.
    first = replanned.plans[0]
    blind = orx.simulate_voyage(first, truth, SHIP, replan=ReplanPolicy.never(), **common)
    return truth, forecasts, blind, replanned


def test_the_forecast_places_the_storm_300_nm_off_its_true_track(storm_voyages):
    truth, forecasts, _, _ = storm_voyages
    first, last = forecasts[0][1], forecasts[1][1]
    at = {"time": T0 + np.timedelta64(24, "h")}

    def peak(ds):
        hs = ds["hs_m"].sel(at, method="nearest")
        i = np.unravel_index(int(np.argmax(hs.values)), hs.shape)
        return float(hs["lat"][i[0]]), float(hs["lon"][i[1]])

    off = float(geo.distance_nm(*peak(truth), *peak(first)))
    assert off == pytest.approx(300.0, abs=45.0)  # within one 0.5° grid cell
    assert float(np.abs(last["hs_m"] - truth["hs_m"]).max()) == 0.0


def test_sailing_the_first_plan_blind_meets_a_danger_band(storm_voyages):
    truth, _, blind, _ = storm_voyages
    o = blind.outcome
    assert o.n_replans == 0
    assert o.time_in_band_h > 1.0 and o.time_band_met_h >= o.time_in_band_h
    # the first plan verified against its own forecast, but not against the truth
    first = blind.plans[0]
    assert first.verify() == []
    again = orx.Plan.from_schedule(
        first.waypoints, first.stw_kn, departure=T0, times=first.times, ship=SHIP, weather=truth, use_land_mask=False
    )
    assert any(v.kind.startswith("band:") for v in again.verify())
    # the log marks the steps inside a band, and their margins are <= 0 for some band
    inside = blind.log["in_band"].values.astype(bool)
    margins = np.column_stack([blind.log[f"margin_{b}"].values for b in orx.BandRules().enabled_bands])
    assert inside.any() and np.all(margins[inside].min(axis=1) <= 1e-9)


def test_the_replanning_voyage_avoids_the_band_and_keeps_the_eta(storm_voyages):
    _, forecasts, _, replanned = storm_voyages
    o = replanned.outcome
    assert o.n_replans >= 1
    assert "new forecast" in str(replanned.log["replan_reason"].values[1])
    assert replanned.log["replan_forecast_index"].values[-1] == 1
    assert o.time_in_band_h == 0.0
    assert o.eta_met or (o.earliest_arrival is not None and o.arrival <= o.earliest_arrival + np.timedelta64(1, "h"))


def test_the_replan_minimises_fuel_to_the_eta_rather_than_racing(storm_voyages):
    # Fuel per mile rises with the speed, so a least-fuel plan by an ETA that can be met uses the time it has: the
    # re-plan (the storm binds on the corridor; the minimum-time plan, racing south of it at 25-26 kn, arrives
    # 17.5 h early on 139 t) starts from the 3-D DP's plan, which passes the other side by the ETA: both were
    # candidates of the start stage, scored by the referee before the first solve.
    _, _, blind, replanned = storm_voyages
    o, eta = replanned.outcome, T0 + np.timedelta64(42, "h")
    last = replanned.plans[-1]
    assert o.eta_met and o.arrival >= eta - np.timedelta64(1, "h")
    starts = last.solver_stats["starts"]
    assert last.verify() == [] and last.solver_stats["start"] == "3-D DP" and starts["3-D DP"]["chosen"]
    assert last.total_fuel_t <= min(c["score"] for c in starts.values()) * (1 + 1e-9)  # never worse than a start
    assert o.fuel_t < 2.0 * blind.outcome.fuel_t


# --------------------------------------------------------------------------- the command line and the files


def test_cli_simulate_writes_the_log_files_and_the_figure(tmp_path, capsys):
    import json

    import xarray as xr

    from optroute.cli import main

    wx = _calm()
    truth, fc = tmp_path / "truth.nc", tmp_path / "fc.nc"
    wx.to_netcdf(truth)
    wx.to_netcdf(fc)
    code = main([
        "simulate", "--truth", str(truth), "--forecast", f"2024-01-10T00:00={fc}", "--from", "30,-150",
        "--to", "30,-146", "--depart", "2024-01-10T00:00", "--eta", "+20", "--out", str(tmp_path / "v") + "/",
        "--plot", str(tmp_path / "v.png"),
    ])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0, out
    assert "ETA 2024-01-10T20:00:00Z met" in out
    log = xr.open_dataset(tmp_path / "v" / "voyage_log.nc")
    csv_rows = (tmp_path / "v" / "voyage_log.csv").read_text().splitlines()
    gj = json.loads((tmp_path / "v" / "voyage_log.geojson").read_text())
    assert len(csv_rows) == log.sizes["step"] + 1
    assert [f["properties"]["kind"] for f in gj["features"]] == ["track", "plan"]
    assert gj["features"][0]["geometry"]["coordinates"][0] == pytest.approx([-150.0, 30.0])
    assert (tmp_path / "v.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.rglob("*.tmp*"))
    # calm water: the whole passage at the plan's speed, burning what the log's steps add up to
    assert float(log["fuel_t"].sum()) == pytest.approx(float(log.attrs["fuel_t"]))
    assert float(log.attrs["time_in_band_h"]) == 0.0


# --------------------------------------------------------------------------- forecast error (scenarios)


def test_displaced_storm_is_moved_delayed_and_scaled_as_stated():
    truth = sc.moving_storm_spec(30.0, -145.0, 90.0, 10.0, peak_hs_m=10.0, radius_nm=150.0, duration_h=48.0)
    (fc,) = sc.displaced_storms([truth], displacement_nm=300.0, bearing_deg=0.0, delay_h=6.0, intensity_factor=0.8)
    # 300 nm due north is 5 degrees of latitude; the forecast storm is where the truth was 6 h before
    for h in (6.0, 12.0, 30.0):
        lat_t, lon_t = truth.centre(h - 6.0)
        lat_f, lon_f = fc.centre(h)
        assert lat_f - lat_t == pytest.approx(5.0, abs=1e-9)
        assert lon_f == pytest.approx(lon_t, abs=1e-9)
    assert fc.peak_hs_m == pytest.approx(8.0)
    with pytest.raises(ConfigError, match="intensity_factor"):
        sc.displaced_storms([truth], intensity_factor=0.0)


def test_converging_forecasts_shrink_the_error_linearly_to_the_truth():
    storm = sc.moving_storm_spec(30.0, -145.0, 90.0, 10.0, peak_hs_m=10.0, radius_nm=150.0, duration_h=24.0)
    kw = {"start": T0, "duration_h": 24.0, "step_h": 6.0, "resolution_deg": 1.0, "bbox": (20, 42, -156, -134)}
    fcs = sc.converging_forecasts([storm], [0.0, 6.0, 12.0], converged_h=12.0, displacement_nm=240.0, **kw)
    assert [t for t, _ in fcs] == [T0, T0 + np.timedelta64(6, "h"), T0 + np.timedelta64(12, "h")]
    truth = sc.storm_dataset([storm], **kw)
    assert float(np.abs(fcs[2][1]["hs_m"] - truth["hs_m"]).max()) == 0.0
    # the forecast issued half-way carries half the error: 120 nm = 2 degrees north at t = 0
    half = sc.storm_dataset(sc.displaced_storms([storm], displacement_nm=120.0), **kw)
    assert float(np.abs(fcs[1][1]["hs_m"] - half["hs_m"]).max()) == 0.0


def test_a_sea_that_differs_from_the_forecast_beyond_the_threshold_triggers_replans_spaced_by_the_interval():
    """Forecast calm, truth 3 m head seas: the Hs trigger (1 m) fires once min_interval_h has passed since each plan."""
    kw = {"start": T0, "duration_h": 60.0, "step_h": 3.0, "resolution_deg": 1.0, "bbox": (20, 40, -160, -130)}
    truth = sc.uniform(3.0, wave_from_deg=90.0, **kw)
    policy = ReplanPolicy(on_forecast=False, hs_threshold_m=1.0, min_interval_h=5.0)
    res = orx.simulate_voyage(
        (A, (30.0, -146.0)), truth, SHIP, forecasts=[(T0, _calm())], replan=policy, departure=T0,
        eta=T0 + np.timedelta64(20, "h"), optimise_options={"use_land_mask": False}, step_h=0.5,
    )  # fmt: skip
    reasons = [str(r) for r in res.log["replan_reason"].values]
    assert reasons[0] == "initial plan" and len(reasons) >= 3
    assert all(r.startswith("weather met: Hs differs from the plan's forecast by 3 m > 1 m") for r in reasons[1:])
    gaps = np.diff(res.log["replan_time"].values) / np.timedelta64(1, "h")
    assert np.all(gaps >= 5.0) and np.all(gaps < 5.5)  # the first step at or after the interval
    # the same voyage (its first plan, made on the same calm forecast) without the trigger never re-plans
    quiet = orx.simulate_voyage(
        res.plans[0], truth, SHIP, forecasts=[(T0, res.plans[0].context.dataset)], replan=ReplanPolicy(),
        eta=T0 + np.timedelta64(20, "h"), optimise_options={"use_land_mask": False}, step_h=0.5,
    )  # fmt: skip
    assert quiet.outcome.n_replans == 0


def test_every_plan_of_the_storm_voyage_improves_on_its_verified_start(storm_voyages):
    # The re-plan's start (the 3-D DP, 62.12 t) sails inside the synchronous band where the sea is below the threshold;
    # without the third disjunct ("Hs stays below the threshold") the first solve carried 27 such samples into the
    # band's seas, every re-solve from there failed and the plan was the start. Now the first solve's plan stands.
    _, _, _, replanned = storm_voyages
    assert len(replanned.plans) >= 2
    for plan in replanned.plans:
        st = plan.solver_stats
        assert plan.status != "start", st["status_reason"]
        assert plan.total_fuel_t < st["start_score"]


def test_a_re_plan_that_keeps_its_start_says_why(storm_voyages):
    # Every plan of the re-planned voyage records where its verified start lay inside the NLP's bands; a plan that is
    # the start (the NLP found no better one) names the first solve's verdict and, where there were any, those samples.
    _, _, _, replanned = storm_voyages
    for plan in replanned.plans:
        st = plan.solver_stats
        record = st["verified_start_in_nlp_bands"]
        assert record is None or record["samples"] == sum(v for k, v in record.items() if k != "samples")
        if plan.status == "start":
            assert (
                f"its first solve: {st['first_solve']}" in st["status_reason"]
                or "failed verification" in st["status_reason"]
            )
            if record and record["samples"]:
                assert f"inside the NLP's bands at {record['samples']} samples" in st["status_reason"]
