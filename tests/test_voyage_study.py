"""orx.study (ships × weather × ETAs on Dask) and the parallel front, against calm-water physics by hand.

The cluster tests share one 2-worker LocalCluster on the loopback interface (module fixture), reached
through ``scheduler_address`` as an existing cluster would be.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import optroute as orx
import optroute.studies.voyage_study as vs
from optroute.studies.cluster import SCHEDULER_HTTP_ADDRESS
from optroute.studies.study import SchedulerUnreachable
from optroute.studies.tradeoff import tradeoff

SHIP = orx.Ship.preset("container_54k_dwt")
SMALL = SHIP.replace(name="small_feeder", mcr_kw=20000.0)
T0 = np.datetime64("2024-01-10T00:00", "ns")
CORRIDOR = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -20.0]], width_nm=0.0)
KW = {"max_leg_nm": 150.0, "use_land_mask": False}


def _sea(hs_m: float) -> xr.Dataset:
    return orx.scenarios.uniform(
        hs_m=hs_m, tp_s=7.0, bbox=(-10, 10, -40, 0), start=T0, duration_h=240, resolution_deg=1.0
    )


WEATHER = {"calm": _sea(0.0), "moderate": _sea(2.5)}
ETAS = [20.0, 30.0, 40.0]  # 20 h is faster than either ship's top speed over the 600 nm


def _by_hand_calm(ship: orx.Ship, eta_h: float) -> float:
    v = CORRIDOR.length_nm / eta_h
    return eta_h * float(ship.fuel_rate_tph(ship.calm_power_kw(v)))


def _study(store: Path, **kw) -> xr.Dataset:
    return orx.study([SHIP, SMALL], WEATHER, ETAS, corridor=CORRIDOR, departure=T0, store=store, **KW, **kw)


@pytest.fixture(scope="module")
def serial(tmp_path_factory) -> xr.Dataset:
    return _study(tmp_path_factory.mktemp("serial"), n_workers=0)


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        worker_dashboard_address=None,
        scheduler_kwargs={"dashboard_address": SCHEDULER_HTTP_ADDRESS},  # as a study's cluster
    ) as c:
        yield c


def test_synchronous_study_matches_calm_water_by_hand_and_reports_unreachable_etas(serial):
    assert dict(serial.sizes) == {"ship": 2, "scenario": 2, "eta_h": 3}
    assert list(serial.ship.values) == ["container_54k_dwt", "small_feeder"]
    assert (serial.status == "ok").all()  # the engine: every case ran
    for ship in (SHIP, SMALL):
        case = serial.sel(ship=ship.name, scenario="calm")
        assert str(case.plan_status.sel(eta_h=20.0).values).startswith("infeasible: earliest arrival")
        assert np.isnan(case.fuel_t.sel(eta_h=20.0))
        for h in (30.0, 40.0):
            assert str(case.plan_status.sel(eta_h=h).values) == "optimal"
            assert float(case.fuel_t.sel(eta_h=h)) == pytest.approx(_by_hand_calm(ship, h), rel=1e-5)
    # waves cost fuel, and a later ETA never costs more
    ok = serial.fuel_t.sel(eta_h=[30.0, 40.0])
    assert (ok.sel(scenario="moderate") > ok.sel(scenario="calm")).all()
    assert (ok.sel(eta_h=40.0) < ok.sel(eta_h=30.0)).all()
    assert serial.eta.sel(eta_h=30.0).values == T0 + np.timedelta64(30, "h")


def test_two_worker_cluster_study_equals_the_synchronous_one_exactly(serial, cluster, tmp_path):
    # one ship's 6 cases (both weathers, every ETA, the unreachable one included) spread over the two workers
    par = orx.study(
        [SHIP], WEATHER, ETAS, corridor=CORRIDOR, departure=T0, store=tmp_path / "par",
        scheduler_address=cluster.scheduler_address, **KW,
    )  # fmt: skip
    ref = serial.sel(ship=[SHIP.name])
    for name in ("fuel_t", "duration_h", "mean_power_kw", "max_power_kw"):
        # the same solves; 1-ulp differences between processes were seen once, hence rounding-level tolerance
        np.testing.assert_allclose(par[name].values, ref[name].values, rtol=1e-12)
    # the ETA multiplier is Ipopt's dual, converged to its 1e-9 tolerance, not to the last bit: a worker's
    # BLAS threading sums in another order (4.6e-12 relative was seen in CI)
    np.testing.assert_allclose(par.eta_shadow_price_t_per_h.values, ref.eta_shadow_price_t_per_h.values, rtol=1e-9)
    np.testing.assert_array_equal(par.plan_status.values, ref.plan_status.values)


def test_front_is_bit_identical_serial_run_to_run_and_on_two_workers(cluster):
    """Determinism: the chains are cut by ETA alone and Ipopt's BLAS runs one thread everywhere."""
    wx = WEATHER["moderate"]
    kw = {"departure": T0, "n": 5, "chains": 2, **KW}
    ser = tradeoff(CORRIDOR, wx, SHIP, **kw)
    again = tradeoff(CORRIDOR, wx, SHIP, **kw)  # the prepared corridor is this process's, kept from the first
    par = tradeoff(CORRIDOR, wx, SHIP, scheduler_address=cluster.scheduler_address, **kw)
    assert np.isfinite(ser.fuel_t.values).all() and ser.attrs["risen_points"] == 0  # a plan at every ETA
    for other in (again, par):
        assert set(other.data_vars) == set(ser.data_vars)
        for name in ser.data_vars:
            if name == "runtime_s":  # the clock's, not the solver's
                continue
            a, b = ser[name].values, other[name].values
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name  # ==, not approximately
        np.testing.assert_array_equal(other.eta.values, ser.eta.values)
        assert other.attrs == ser.attrs


def _forget_front_inputs() -> None:
    """Run on a worker: drop the front inputs it holds (module-level, so the worker's own module is cleared)."""
    import optroute.studies.front_points as fp

    fp.SPECS.clear()


def test_a_second_front_on_the_same_workers_ships_nothing_and_a_worker_that_lost_the_inputs_gets_them_again(
    cluster,
):
    """The front's inputs (its weather) travel to each worker once, keyed by their fingerprint."""
    import distributed

    import optroute.studies.front_points as fp
    from optroute.studies.front_runners import DaskRunner

    wx = WEATHER["moderate"]
    token = fp.front_token(CORRIDOR, wx, SHIP, T0, "fuel", KW)
    spec = fp.FrontSpec(CORRIDOR, wx, SHIP, T0, "fuel", dict(KW), token=token)
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        client.run(_forget_front_inputs)
        first = DaskRunner(client, spec)
        assert first.installed == 2 and all(client.run(fp.has_spec, token).values())
        assert DaskRunner(client, spec).installed == 0  # held by both: nothing shipped
        client.run(_forget_front_inputs)  # both workers lose the inputs under a running front
        fast, _ = first.ends(spec, None, need_slow=False)
    ref = fp.solve_point(spec, None, "minimum_time", None)
    assert fast.ok and fast.totals.keys() == ref.totals.keys()
    got, want = (np.array(list(p.totals.values())) for p in (fast, ref))
    assert np.array_equal(got, want, equal_nan=True)  # installed again, solved as in this process, to the bit
    assert first.installed == 4


def test_a_risen_points_re_solve_runs_on_a_worker_as_in_this_process(cluster):
    """A point that rose is solved again from the earlier ETA's plan (its floor): on a worker as in this process, to
    the bit, started from that plan, and no higher than it."""
    import distributed

    import optroute.studies.front_points as fp
    from optroute.studies.front_runners import DaskRunner, SerialRunner

    wx = WEATHER["moderate"]
    spec = fp.FrontSpec(
        CORRIDOR, wx, SHIP, T0, "fuel", dict(KW), token=fp.front_token(CORRIDOR, wx, SHIP, T0, "fuel", KW)
    )
    earlier = fp.solve_point(spec, 35.0, "eta", None)
    (ref,) = SerialRunner().resolve(spec, 40.0, [earlier], end_adjacent=True)
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        (got,) = DaskRunner(client, spec).resolve(spec, 40.0, [earlier], end_adjacent=True)
    assert ref.ok and ref.warm_start == got.warm_start == "warm plan"
    assert ref.fuel_t <= earlier.fuel_t * (1.0 + 1e-9)
    a, b = (np.array(list(p.totals.values())) for p in (ref, got))
    assert np.array_equal(a, b, equal_nan=True) and np.array_equal(ref.legs["stw_kn"], got.legs["stw_kn"])


def test_a_study_prepares_one_corridor_per_ship_and_weather_and_its_cases_do_not_depend_on_their_order(
    serial, tmp_path, monkeypatch
):
    """The cases of one ship and weather share the process's prepared corridor: one preparation each, and a case
    gives the same bits whichever cases ran before it on that corridor (here: the ETAs in reverse order)."""
    import optroute.studies.front_points as fp

    made = []
    real = fp._prepare
    monkeypatch.setattr(fp, "_prepare", lambda spec: made.append(spec.token) or real(spec))
    fp.PREPARED_CORRIDORS.clear()
    rev = orx.study(
        [SHIP, SMALL], WEATHER, ETAS[::-1], corridor=CORRIDOR, departure=T0, store=tmp_path / "r", n_workers=0, **KW
    )
    assert len(made) == len(set(made)) == 4  # 2 ships x 2 weathers, each prepared once for its 3 ETAs
    for name in ("fuel_t", "duration_h", "eta_shadow_price_t_per_h", "plan_status"):
        a, b = serial[name].values, rev[name].sel(eta_h=ETAS).values
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name  # ==, not approximately


def test_interrupted_study_resumes_with_every_case_once(serial, tmp_path, monkeypatch):
    real = vs.solve_point
    calls = {"n": 0}

    def interrupted(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt  # Ctrl-C half-way through one ship's 6 cases
        return real(*args, **kwargs)

    def one_ship(store: Path, **kw) -> xr.Dataset:
        return orx.study([SHIP], WEATHER, ETAS, corridor=CORRIDOR, departure=T0, store=store, n_workers=0, **KW, **kw)

    monkeypatch.setattr(vs, "solve_point", interrupted)
    store = tmp_path / "store"
    with pytest.raises(KeyboardInterrupt):
        one_ship(store)
    stored = sorted(p.name for p in (store / "cases").glob("*.nc"))
    assert len(stored) == 3
    calls["n"] = -1000  # no more interruptions
    done = []
    ds = one_ship(store, progress=lambda d, t: done.append((d, t)))
    assert calls["n"] == -1000 + 3  # only the 3 cases not stored were computed
    assert done[0] == (3, 6) and done[-1] == (6, 6)
    assert len(list((store / "cases").glob("*.nc"))) == 6
    assert (ds.status == "ok").all()
    ref = serial.fuel_t.sel(ship=[SHIP.name]).values
    np.testing.assert_allclose(ds.fuel_t.values, ref, rtol=1e-12)  # same solves, to rounding


def test_unreachable_scheduler_fails_fast_naming_the_address(tmp_path):
    with pytest.raises(SchedulerUnreachable, match="127.0.0.1:9"):
        _study(tmp_path / "s", scheduler_address="tcp://127.0.0.1:9", timeout_s=2)


def test_axes_from_names_ensemble_members_and_bad_input():
    ships = vs._ship_axis(["container_54k_dwt", SMALL])
    assert list(ships) == ["container_54k_dwt", "small_feeder"]
    ens = orx.scenarios.ensemble(
        lambda storms: orx.scenarios.north_pacific_storms(storms=storms, resolution_deg=3.0, duration_h=24.0), 2
    )
    weathers = vs._weather_axis({"np": ens, "calm": "calm"})
    assert list(weathers) == ["np[member=0]", "np[member=1]", "calm"]
    assert "member" not in weathers["np[member=1]"].dims and weathers["calm"] == "calm"
    with pytest.raises(orx.ConfigError, match="shao_case_1"):
        vs._weather_axis(["atlantis"])
    with pytest.raises(orx.ConfigError, match="twice"):
        vs._ship_axis([SHIP, SHIP])
    with pytest.raises(orx.ConfigError, match="corridor="):
        orx.study(SHIP, "calm", [30.0], store="unused")
    with pytest.raises(orx.ConfigError, match="objective"):
        orx.study(SHIP, "calm", [30.0], corridor=CORRIDOR, store="unused", objective="time")


# --------------------------------------------------------------------------- a store cannot return another input's results

LONG = orx.Corridor.from_waypoints([[0.0, -30.0], [0.0, -10.0]], width_nm=0.0)  # 1 200 nm, twice CORRIDOR


def _one(store: Path, corridor: orx.Corridor, weather, eta_h: float, **kw) -> xr.Dataset:
    return orx.study(SHIP, weather, [eta_h], corridor=corridor, departure=T0, store=store, n_workers=0, **KW, **kw)


def test_same_store_with_another_corridor_is_refused_naming_it_or_recomputed(tmp_path):
    store = tmp_path / "s"
    wx = {"sea": _sea(1.0)}
    short = _one(store, CORRIDOR, wx, 60.0)
    assert float(short.distance_nm.squeeze()) == pytest.approx(CORRIDOR.length_nm, rel=1e-9)
    with pytest.raises(
        orx.studies.study.StudyError,
        match=r"route: corridor of 60\d\.\d nm.* in the store, now corridor of 120\d\.\d nm",
    ):
        _one(store, LONG, wx, 60.0)
    with pytest.warns(UserWarning, match="inputs changed"):
        long = _one(store, LONG, wx, 60.0, on_changed_inputs="recompute")
    assert float(long.distance_nm.squeeze()) == pytest.approx(LONG.length_nm, rel=1e-9)
    assert str(long.plan_status.squeeze().values) == "optimal"


def test_forecast_file_overwritten_in_place_is_refused_or_recomputed(tmp_path):
    path = tmp_path / "forecast.nc"
    _sea(1.0).to_netcdf(path)
    store = tmp_path / "s"
    calm = _one(store, CORRIDOR, [str(path)], 40.0)
    _sea(7.0).to_netcdf(path)  # same name, shape and coordinates; other waves
    with pytest.raises(orx.studies.study.StudyError, match=r"weather: weather file .*forecast\.nc.*in the store, now"):
        _one(store, CORRIDOR, [str(path)], 40.0)
    with pytest.warns(UserWarning, match="inputs changed"):
        rough = _one(store, CORRIDOR, [str(path)], 40.0, on_changed_inputs="recompute")
    fresh = _one(tmp_path / "fresh", CORRIDOR, [str(path)], 40.0)
    assert float(rough.fuel_t.squeeze()) == pytest.approx(float(fresh.fuel_t.squeeze()), rel=1e-9)
    assert float(rough.fuel_t.squeeze()) > 1.05 * float(calm.fuel_t.squeeze())  # Hs 7 m costs fuel at 15 kn
