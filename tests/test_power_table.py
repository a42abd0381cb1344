"""The NLP's power table: evaluated only where the ship can be, and its error measured per leg at every solution.

References, independent of the code under test: the whole-grid table (every node evaluated, as before the reach
windows), and the ship's performance model evaluated directly at the NLP's own samples.
"""

from __future__ import annotations

import numpy as np
import pytest

import optroute as orx
from formulations._ratio_table import power_ratio
from formulations.splines import SECTOR_RAMP_DEG, sector_weights
from optroute.optimise.corridor_setup import _hours
from optroute.optimise.lateral import reach_windows
from optroute.optimise.nlp_inputs import build_frame, weather_grid
from optroute.optimise.power_table import baseline_power_model, heading_nodes, speed_nodes
from optroute.physics.performance import KwonModel

SHIP = orx.Ship.preset("container_54k_dwt")
T0 = np.datetime64("2024-01-10T00:00", "ns")
#: The table's resolution in speed: the quasi-interpolant over speed nodes 3.5 kn apart [-] (measured 0.49 % at most,
#: 0.08 % on average, in the turning sea below)
SPEED_TOL = 0.01


@pytest.fixture(scope="module")
def storm() -> object:
    return orx.scenarios.moving_storm(
        31.0, -151.0, 120.0, 14.0, peak_hs_m=9.0, radius_nm=150.0, start=T0, duration_h=72.0, step_h=3.0,
        resolution_deg=0.5, bbox=(24, 36, -156, -140),
    )  # fmt: skip


def test_table_on_reach_windows_equals_the_whole_grid_table_wherever_the_ship_can_be(storm: object) -> None:
    frame = build_frame(orx.Corridor.from_waypoints([(30.0, -152.0), (30.0, -144.0)], width_nm=30.0).resample(40.0))
    model = KwonModel(SHIP)
    base, _ = baseline_power_model(model, v_min_kn=3.0, v_max_kn=24.0, min_load=0.1)
    eta_h = 26.0  # 416 nm at 16 kn; at 24 kn at most, the ship can be on each leg during some 11 h of the 26
    windows_h = _hours(reach_windows(frame, T0, eta_h, 24.0) - T0)
    kw = {
        "departure": T0, "t_end_h": eta_h * 1.02 + 1.0, "dt_h": 1.5, "ds_nm": 15.0, "dy_nm": 7.5, "model": model,
        "base": base, "speeds_kn": speed_nodes(3.0, 24.0), "headings_deg": heading_nodes(False, False),
    }  # fmt: skip
    sampler = orx.WeatherSampler(storm)
    whole, whole_smp = weather_grid(frame, sampler, **kw)
    part, part_smp = weather_grid(frame, sampler, **kw, leg_windows_h=windows_h)
    assert part_smp.power_evaluations < 0.85 * whole_smp.power_evaluations  # the saving this is for
    rng = np.random.default_rng(3)
    k = rng.integers(0, frame.n_legs, 4000)
    t = windows_h[k, 0] + rng.random(k.size) * (windows_h[k, 1] - windows_h[k, 0])
    s = frame.s_nm[k] + rng.random(k.size) * np.diff(frame.s_nm)[k]
    y = rng.uniform(-30.0, 30.0, k.size)
    pts = np.vstack([t, s, y])
    a, b = whole.tensor_spline().evaluate(pts, order=2), part.tensor_spline().evaluate(pts, order=2)
    np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)
    # and outside the windows the grid holds its column's nearest evaluated value: finite, not the whole grid's
    late = np.vstack([np.full(50, whole.t_h[-1]), np.linspace(0.0, 40.0, 50), np.zeros(50)])
    assert np.isfinite(part.tensor_spline().evaluate(late)).all()
    assert not np.allclose(part.tensor_spline().evaluate(late), whole.tensor_spline().evaluate(late))


def test_sample_error_weighs_each_legs_samples_by_their_time_worked_by_hand() -> None:
    # two legs of two samples; the model's power at each sample worked from its own arguments (IMO relative wave
    # angle from heading and wave direction), the NLP's power off it by chosen factors
    from optroute.optimise.power_table import sample_error
    from optroute.physics.passage import SeaState

    model = KwonModel(SHIP)
    base, _ = baseline_power_model(model, v_min_kn=3.0, v_max_kn=24.0, min_load=0.1)
    sea = SeaState.from_sample({"hs_m": np.full((2, 2), 4.0), "tp_s": 9.0, "wave_from_deg": 0.0})  # wind unknown
    heading = np.array([[0.0, 40.0], [180.0, 100.0]])  # α = 0 (head), 320 (bow, folded 40), 180, 260 (beam)
    stw = np.array([14.0, 18.0])
    alpha = (0.0 - heading) % 360.0
    p_model = np.array(
        [
            [float(model.brake_power_kw(stw[i], hs_m=4.0, wave_angle_deg=alpha[i, j])) for j in range(2)]
            for i in range(2)
        ]
    )
    factor = np.array([[1.10, 1.00], [0.95, 0.90]])
    power = p_model * factor
    rate = np.asarray(model.fuel_rate_tph(power), dtype=float)
    w = np.array([[0.5 / 12.0, 0.5 / 16.0], [0.25 / 17.0, 0.75 / 19.0]])  # weight over SOG [h/nm]
    got = sample_error(model, base, sea, heading, stw, power, rate, w)
    model_rate = np.asarray(model.fuel_rate_tph(p_model), dtype=float)
    legs = (rate * w).sum(axis=1) / (model_rate * w).sum(axis=1) - 1.0
    assert got["max_leg_rel_error"] == pytest.approx(legs[np.argmax(np.abs(legs))], rel=1e-12)
    assert got["worst_leg"] == int(np.argmax(np.abs(legs)))
    assert got["mean_abs_leg_rel_error"] == pytest.approx(np.mean(np.abs(legs)), rel=1e-12)
    assert got["max_sample_rel_error"] == pytest.approx(0.10, rel=1e-9)
    assert got["mean_abs_sample_rel_error"] == pytest.approx(0.0625, rel=1e-9)
    assert got["capped_samples"] == 0 and got["samples"] == 4


@pytest.mark.parametrize("edge", [30.0, 60.0, 150.0])
def test_sector_weights_sum_to_one_are_one_hot_off_the_ramps_and_c2_by_finite_differences(edge: float) -> None:
    edges = (30.0, 60.0, 150.0)
    alpha = np.linspace(0.0, 180.0, 18001)
    w = np.array(sector_weights(np.cos(np.radians(alpha)), edges, np))  # (4, n)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, rtol=0, atol=1e-15)
    assert (w >= 0.0).all() and (w <= 1.0).all()
    # off the ramps (SECTOR_RAMP_DEG either side to first order, 1.3 times that with the cosine's curvature),
    # Kwon's own sector has weight 1 exactly
    far = np.min(np.abs(alpha[:, None] - np.array(edges)), axis=1) > 1.3 * SECTOR_RAMP_DEG
    sector = np.searchsorted(edges, alpha, side="left")
    np.testing.assert_array_equal(w[:, far], (sector[far] == np.arange(4)[:, None]).astype(float))
    # C^2 in x = cos(alpha) across the ramp of this edge: the finite-difference first and second derivatives are
    # continuous (no jump between neighbouring points beyond the step's own change) and vanish at the ramp's ends
    q = edges.index(edge)
    h = np.sin(np.radians(edge)) * np.radians(SECTOR_RAMP_DEG)
    x = np.cos(np.radians(edge)) + np.linspace(-1.5 * h, 1.5 * h, 3001)
    eps = x[1] - x[0]
    wq = np.array(sector_weights(x, edges, np))[q]
    d1, d2 = np.gradient(wq, eps), np.diff(wq, 2) / eps**2
    scale1, scale2 = np.max(np.abs(d1)), np.max(np.abs(d2))
    assert scale1 == pytest.approx(1.875 / (2 * h), rel=1e-3)  # S'(1/2) = 15/8 over the ramp's width 2h
    assert np.max(np.abs(np.diff(d1))) < 0.01 * scale1 and np.max(np.abs(np.diff(d2))) < 0.02 * scale2
    ends = np.abs(np.abs(x - np.cos(np.radians(edge))) - h) < 2 * eps
    assert np.max(np.abs(d1[ends])) < 1e-3 * scale1 and np.max(np.abs(d2[ends[1:-1]])) < 0.03 * scale2


def test_table_through_its_spline_is_the_model_away_from_the_sector_ramps() -> None:
    # a sea of one height whose direction turns through every sector in time: Kwon's power at any point, speed and
    # heading is the model's at the wave angle the NLP computes there (the model called directly), except within
    # the sector ramps, to the table's resolution in speed; the old heading-node table was off by up to +-30 % near
    # Kwon's sector edges
    wx = orx.scenarios.uniform(
        5.0, wave_from_deg=0.0, bbox=(24, 36, -156, -140), start=T0, duration_h=60.0, step_h=3.0, resolution_deg=0.5
    )
    turning = 180.0 + 6.0 * (wx["time"] - wx["time"][0]) / np.timedelta64(1, "h")
    wx["wave_from_deg"] = (turning % 360.0).broadcast_like(wx["wave_from_deg"]).transpose(*wx["wave_from_deg"].dims)
    frame = build_frame(orx.Corridor.from_waypoints([(30.0, -152.0), (30.0, -144.0)], width_nm=30.0).resample(40.0))
    model = KwonModel(SHIP)
    base, _ = baseline_power_model(model, v_min_kn=3.0, v_max_kn=24.0, min_load=0.1)
    grid, _ = weather_grid(
        frame, orx.WeatherSampler(wx), departure=T0, t_end_h=50.0, dt_h=1.5, ds_nm=15.0, dy_nm=7.5, model=model,
        base=base, speeds_kn=speed_nodes(3.0, 24.0), headings_deg=heading_nodes(False, False),
    )  # fmt: skip
    assert grid.ratio_axes[5] == 1 and grid.ratio_axes[6] == (30.0, 60.0, 150.0)  # sectors, no heading nodes
    rng = np.random.default_rng(11)
    k = 20000
    pts = np.vstack([rng.uniform(0.0, 45.0, k), rng.uniform(0.0, frame.s_nm[-1], k), rng.uniform(-25.0, 25.0, k)])
    v, psi = rng.uniform(5.0, 20.0, k), rng.uniform(-30.0, 30.0, k)
    col = dict(zip(grid.field_names, grid.tensor_spline().evaluate(pts), strict=True))
    a, c = col["wave_to_along"], col["wave_to_across"]
    cos_alpha = -(a * np.cos(np.radians(psi)) + c * np.sin(np.radians(psi))) / np.hypot(a, c)
    table = power_ratio(col, v, psi, grid.ratio_axes, np, cos_alpha) * base.calm_power_kw(v)
    alpha = np.degrees(np.arccos(np.clip(cos_alpha, -1.0, 1.0)))
    wind = float(np.hypot(wx["wind_u_ms"].values.flat[0], wx["wind_v_ms"].values.flat[0]))
    p = np.asarray(model.brake_power_kw(v, hs_m=5.0, wave_angle_deg=alpha, wind_speed_ms=wind))
    ok = np.isfinite(p) & (p < 1.5 * model.mcr_kw)  # the table caps beyond 1.5 MCR
    far = np.min(np.abs(alpha[:, None] - np.array([30.0, 60.0, 150.0])), axis=1) > 1.3 * SECTOR_RAMP_DEG
    err = table[far & ok] / p[far & ok] - 1.0
    assert (far & ok).sum() > 0.4 * k and {0, 1, 2, 3} <= set(np.searchsorted([30.0, 60.0, 150.0], alpha[far]))
    assert np.max(np.abs(err)) < SPEED_TOL


def test_table_by_regime_is_the_model_evaluated_at_every_node_in_every_sector() -> None:
    # Kwon declares its power a function of the regime (Beaufort number, wave sector) and the speed only, so the
    # table evaluates it once per regime; the reference is the referee's own function called at every node, heading
    # and sector (no regimes): random seas over Beaufort 0-12, every wave direction, winds known and unknown (NaN:
    # Beaufort from Hs), nodes on sector edges included
    from optroute.optimise.power_table import CAP_MCR, tabulate_ratio
    from optroute.physics.passage import SeaState, power_at_heading

    model = KwonModel(SHIP)
    assert model.power_by_regime
    base, _ = baseline_power_model(model, v_min_kn=3.0, v_max_kn=26.5, min_load=0.1)
    rng = np.random.default_rng(7)
    n = 4000
    wu, wv = rng.normal(0.0, 14.0, n), rng.normal(0.0, 14.0, n)
    unknown = rng.random(n) < 0.4
    wu[unknown], wv[unknown] = np.nan, np.nan
    along = rng.uniform(0.0, 360.0, n)
    wave_from = rng.uniform(0.0, 360.0, n)
    wave_from[:40] = (along[:40] + rng.choice([30.0, 60.0, 150.0, 210.0, 300.0], 40)) % 360.0  # on the edges
    sea = SeaState.from_sample(
        {"hs_m": rng.uniform(0.0, 15.0, n), "tp_s": 10.0, "wave_from_deg": wave_from, "wind_u_ms": wu, "wind_v_ms": wv}
    )
    given = speed_nodes(3.0, 26.5)
    tab = tabulate_ratio(model, base, sea, along, given, np.array([-30.0, 0.0, 30.0]))
    speeds = tab.speeds_kn  # Beaufort 12 among the seas: the speed step halved (SPEED_TOL)
    np.testing.assert_allclose(speeds, np.linspace(given[0], given[-1], 2 * given.size - 1), rtol=1e-15, atol=0.0)
    assert tab.ratio.shape == (n, speeds.size, 1, 4)
    sectors = [(0.0, 30.0), (30.0, 60.0), (60.0, 150.0), (150.0, 180.0)]
    capped = 0
    for q, sector in enumerate(sectors):
        for psi in (-30.0, 0.0, 30.0):  # the heading axis dropped: the same field at every heading
            p = power_at_heading(
                model, speeds[None, :], (along - psi)[:, None], sea.hs_m[:, None], sea.wave_from_deg[:, None],
                sea.wind_u_ms[:, None], sea.wind_v_ms[:, None], wave_sector_deg=sector,
            )  # fmt: skip
            over = ~np.isfinite(p) | (p > CAP_MCR * model.mcr_kw)
            capped += int(over.sum()) if psi == -30.0 else 0
            want = np.where(over, CAP_MCR * model.mcr_kw, p) / base.calm_power_kw(speeds)[None, :]
            np.testing.assert_allclose(tab.ratio[:, :, 0, q], want, rtol=1e-9, atol=0.0)
    assert 0 < capped < tab.ratio.size and tab.capped_share == pytest.approx(capped / tab.ratio.size, rel=1e-12)


def test_kwon_power_is_one_function_of_its_regime_to_the_bit() -> None:
    # the claim KwonModel.power_by_regime makes: seas of one regime (Beaufort number, wave sector), however their
    # Hs, wind, wave and wind angles differ, need the same power at every speed; seas of different regimes differ
    model = KwonModel(SHIP)
    rng = np.random.default_rng(5)
    n = 20000
    hs, angle = rng.uniform(0.0, 15.0, n), rng.uniform(0.0, 360.0, n)
    wind = np.where(rng.random(n) < 0.5, np.nan, rng.uniform(0.0, 40.0, n))
    regime = model.power_regime(hs_m=hs, wave_angle_deg=angle, wind_speed_ms=wind)
    speeds = np.array([4.0, 9.0, 14.0, 19.0, 24.0])
    p = model.brake_power_kw(
        speeds[None, :], hs_m=hs[:, None], wave_angle_deg=angle[:, None], wind_speed_ms=wind[:, None],
        wind_angle_deg=rng.uniform(0.0, 360.0, (n, 1)),
    )  # fmt: skip
    keys = np.unique(regime)
    assert keys.size > 40  # most of the 13 x 4 regimes
    first = {}
    for key in keys:
        rows = p[regime == key]
        np.testing.assert_array_equal(rows, np.broadcast_to(rows[0], rows.shape))
        first[int(key)] = rows[0]
    # not a vacuous claim: most regimes need their own power (C_β clipped at 0 gives calm water in a few)
    assert len({tuple(np.nan_to_num(r, posinf=-1.0)) for r in first.values()}) > 0.6 * keys.size


def _spline_miss(model, base, sea, along, given: np.ndarray) -> float:
    """Brute force: the largest relative miss, capped values aside, of the uniform cubic B-spline quasi-interpolant
    through the model's ratio at ``given`` against the model's ratio at and halfway between those speeds, every
    sector (the referee's ``power_at_heading`` at each speed, node by node)."""
    from formulations.splines import spline_weights
    from optroute.optimise.power_table import CAP_MCR
    from optroute.physics.passage import power_at_heading

    fine = np.linspace(given[0], given[-1], 2 * given.size - 1)
    worst = 0.0
    for sector in [(0.0, 30.0), (30.0, 60.0), (60.0, 150.0), (150.0, 180.0)]:

        def ratio(v, sector=sector):
            p = power_at_heading(model, v[None, :], along[:, None], sea.hs_m[:, None], sea.wave_from_deg[:, None],
                                 sea.wind_u_ms[:, None], sea.wind_v_ms[:, None], wave_sector_deg=sector)  # fmt: skip
            over = ~np.isfinite(p) | (p > CAP_MCR * model.mcr_kw)
            return np.where(over, CAP_MCR * model.mcr_kw, p) / base.calm_power_kw(v)[None, :], over

        at_given, _ = ratio(given)
        exact, over = ratio(fine)
        w = spline_weights(fine, float(given[0]), float(given[1] - given[0]), given.size, np)
        fit = sum(w_j[None, :] * at_given[:, [j]] for j, w_j in enumerate(w))
        worst = max(worst, float(np.max(np.abs(fit / exact - 1.0)[~over], initial=0.0)))
    return worst


@pytest.mark.parametrize(("hs_m", "halved"), [(3.0, False), (7.0, True)])
def test_the_speed_step_is_halved_where_the_spline_misses_the_model_by_more_than_the_tolerance(hs_m, halved) -> None:
    """Seas of 3 m and 7 m on 200 nodes: the table's ``speed_error`` is the brute-force miss of the spline through
    the given speed nodes; in 3 m it is within :data:`SPEED_TOL` and the nodes are kept, in 7 m (Beaufort 8:
    the ratio to calm water climbs steeply towards low speeds) it is not and the nodes are twice as dense, each
    value the model's own there."""
    from optroute.optimise.power_table import SPEED_TOL, tabulate_ratio
    from optroute.physics.passage import SeaState

    model = KwonModel(SHIP)
    base, _ = baseline_power_model(model, v_min_kn=3.0, v_max_kn=26.5, min_load=0.1)
    rng = np.random.default_rng(3)
    n = 200
    along = rng.uniform(0.0, 360.0, n)
    sea = SeaState.from_sample({"hs_m": np.full(n, hs_m), "tp_s": 10.0, "wave_from_deg": along + rng.uniform(-20, 20, n),
                                "wind_u_ms": np.nan, "wind_v_ms": np.nan})  # fmt: skip
    given = speed_nodes(3.0, 26.5)
    tab = tabulate_ratio(model, base, sea, along, given, np.zeros(1))
    assert tab.speed_error == pytest.approx(_spline_miss(model, base, sea, along, given), rel=1e-9, abs=1e-12)
    assert (tab.speed_error > SPEED_TOL) == halved
    want = np.linspace(given[0], given[-1], 2 * given.size - 1) if halved else given
    np.testing.assert_allclose(tab.speeds_kn, want, rtol=1e-15, atol=0.0)
    assert tab.ratio.shape[1] == want.size
    unchecked = tabulate_ratio(model, base, sea, along, tab.speeds_kn, np.zeros(1), speed_tol=None)
    np.testing.assert_array_equal(tab.ratio, unchecked.ratio)  # the model's own values at the nodes kept
    assert unchecked.capped_share == tab.capped_share and np.isnan(unchecked.speed_error)
