"""NLP legs cut shorter where a danger band can bind (``optimise_corridor(band_leg_nm=...)``).

A leg holds one speed. Where a band binds, the 3-D DP start changes speed every ~20 nm; on 30-50 nm legs the NLP
started from it cannot keep that plan. ``band_leg_nm`` cuts the legs where a band or the exclusion can bind
(:func:`optroute.optimise.rows.binding_legs`) and leaves the others long.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from benchmarks import bench_compare
from optroute import geodesy as geo
from optroute.errors import ConfigError
from optroute.optimise.corridor_problem import PreparedCorridor
from optroute.optimise.rows import cut_where_binding

# an equatorial corridor: 3 deg of longitude (about 180 nm on WGS84) then 1 deg (about 60 nm)
EQUATOR = orx.Corridor(np.array([[0.0, -30.0], [0.0, -27.0], [0.0, -26.0]]), np.array([10.0, 20.0, 30.0]))


def test_a_leg_is_cut_into_the_fewest_equal_pieces_no_longer_than_its_own_length_by_hand() -> None:
    d = EQUATOR.leg_distance_nm  # (180.4, 60.1) nm
    out = EQUATOR.resample([50.0, 100.0])  # ceil(180.4 / 50) = 4 pieces, ceil(60.1 / 100) = 1
    assert out.waypoints.shape[0] == 4 + 1 + 1
    np.testing.assert_allclose(out.leg_distance_nm, [d[0] / 4] * 4 + [d[1]], rtol=1e-9)
    np.testing.assert_allclose(out.waypoints[[0, 4, 5]], EQUATOR.waypoints, atol=1e-12)  # the original waypoints
    np.testing.assert_allclose(out.waypoints[:, 0], 0.0, atol=1e-9)  # on the great circle: the equator
    # half-widths interpolated along track: 10 -> 20 nm over the first leg
    np.testing.assert_allclose(out.half_width_nm, [10.0, 12.5, 15.0, 17.5, 20.0, 30.0], rtol=1e-9)
    # one length for every leg is the same as that length given per leg
    np.testing.assert_array_equal(EQUATOR.resample(50.0).waypoints, EQUATOR.resample([50.0, 50.0]).waypoints)


def test_a_corridor_cut_at_given_distances_keeps_its_waypoints_and_puts_the_cuts_on_its_great_circles() -> None:
    """``Corridor.cut_at`` (the legs a free-arrival minimum time solves on when it starts from the 3-D DP's plan):
    on the equator every cut is at latitude 0 and at its distance from the start by the WGS84 geodesic
    (:func:`optroute.geodesy.distance_nm`, independent of the cut); a cut within 0.05 nm of a waypoint or of an
    earlier cut, or outside the corridor, is left out; half-widths are interpolated along track by hand."""
    d0 = float(EQUATOR.leg_distance_nm[0])
    out = EQUATOR.cut_at([30.0, 90.0, 90.02, d0 + 0.03, d0 + 20.0, -5.0, 1e4])
    assert out.waypoints.shape[0] == 3 + 3
    np.testing.assert_allclose(out.waypoints[[0, 3, 5]], EQUATOR.waypoints, atol=1e-12)
    np.testing.assert_allclose(out.waypoints[:, 0], 0.0, atol=1e-9)
    from_start = geo.distance_nm(0.0, -30.0, out.waypoints[:, 0], out.waypoints[:, 1])
    np.testing.assert_allclose(from_start, [0.0, 30.0, 90.0, d0, d0 + 20.0, EQUATOR.length_nm], atol=1e-6)
    np.testing.assert_allclose(out.half_width_nm[[1, 2, 4]], [10 + 10 * 30 / d0, 10 + 10 * 90 / d0, 20 + 10 * 20 / (
        EQUATOR.length_nm - d0)], rtol=1e-9)  # fmt: skip
    assert EQUATOR.cut_at([0.01, d0, EQUATOR.length_nm]) is EQUATOR  # nothing to cut: the corridor itself
    with pytest.raises(ConfigError, match="s_nm"):
        EQUATOR.cut_at([np.nan])


@pytest.mark.parametrize("bad", [[], [50.0, 0.0], [50.0, np.nan], [[50.0, 50.0]], [50.0, 50.0, 50.0]])
def test_a_length_per_leg_of_another_shape_or_not_positive_is_refused(bad) -> None:
    with pytest.raises(ConfigError, match="max_leg_nm"):
        EQUATOR.resample(np.array(bad))


def test_only_the_binding_legs_longer_than_the_band_length_are_cut_by_hand() -> None:
    binding = np.array([True, False, True, True])
    leg_nm = np.array([50.0, 50.0, 15.0, 30.0])
    steps = cut_where_binding(binding, leg_nm, 20.0)
    pieces = np.ceil(leg_nm / steps - 1e-9).astype(int)  # as Corridor.resample cuts them
    np.testing.assert_array_equal(pieces, [3, 1, 1, 2])
    assert cut_where_binding(binding, np.array([50.0, 50.0, 15.0, 20.0]) * [0.4, 1, 1, 1], 20.0) is None
    assert cut_where_binding(np.zeros(4, dtype=bool), leg_nm, 20.0) is None
    with pytest.raises(ConfigError, match="band_leg_nm"):
        cut_where_binding(binding, leg_nm, 0.0)


@settings(max_examples=40, deadline=None)
@given(
    lengths=st.lists(st.floats(1.0, 200.0), min_size=1, max_size=8),
    flags=st.lists(st.booleans(), min_size=8, max_size=8),
    band_nm=st.floats(5.0, 60.0),
)
def test_cut_legs_are_never_longer_than_asked_and_the_others_are_left_whole(lengths, flags, band_nm) -> None:
    leg_nm = np.array(lengths)
    binding = np.array(flags[: leg_nm.size])
    steps = cut_where_binding(binding, leg_nm, band_nm)
    if steps is None:
        assert not np.any(binding & (leg_nm > band_nm * (1 + 1e-9)))
        return
    pieces = np.maximum(1, np.ceil(leg_nm / steps - 1e-9))
    assert np.all(leg_nm[binding] / pieces[binding] <= band_nm * (1 + 1e-9))
    assert np.all(pieces[~binding] == 1)


def test_a_free_arrival_minimum_time_keeps_its_legs_whole() -> None:
    # its 3-D DP runs only where no local start verifies; cut legs let a poorer local start verify in its place.
    # Least fuel without an ETA (its free-arrival DP always a start where the weather changes) has them cut.
    sc = bench_compare.scenarios(True)[0]

    def legs(objective: str, band_leg_nm: float | None) -> int:
        prepared = PreparedCorridor(sc.corridor, sc.weather, sc.ship, departure=bench_compare.T0, objective=objective,
                                    rules=sc.rules, max_leg_nm=30.0, band_leg_nm=band_leg_nm)  # fmt: skip
        return prepared.frame.n_legs

    assert legs("time", 20.0) == legs("time", None) == legs("fuel", None) < legs("fuel", 20.0)


def test_ensemble_members_share_one_set_of_legs_cut_where_a_band_can_bind_in_any_member() -> None:
    # the storm of tests/test_robust.py on the track in one member, 2.5 deg north of it in the other; the robust NLP
    # stacks its members on one frame, so the legs cut are the union of the members' binding legs
    from optroute.optimise.robust import prepare_members
    from optroute.weather import storms

    t0 = np.datetime64("2024-01-10T00:00", "ns")
    kw = {"start": t0, "duration_h": 12.0, "step_h": 3.0, "resolution_deg": 0.5, "background_hs_m": 1.5}
    members = [
        storms.storm_dataset([storms.moving_storm_spec(30.0 + dlat, -148.5, 90.0, 0.5, peak_hs_m=8.7, radius_nm=40.0,
                                                       duration_h=12.0)], bbox=(25, 35, -152, -145), **kw)
        for dlat in (2.5, 0.0)
    ]  # fmt: skip
    corridor = orx.Corridor.from_waypoints([(30.0, -150.0), (30.0, -147.0)], width_nm=0.0)
    ship = orx.Ship.preset("container_54k_dwt")
    shared = {
        "departure": t0, "latest_eta": t0 + np.timedelta64(372, "m"), "objective": "fuel", "model": None,
        "rules": None, "max_leg_nm": 30.0, "samples_per_leg": 3, "fuel_price_per_t": 600.0, "hourly_cost_per_h": 0.0,
        "exclusion": None, "speed_range_kn": None, "band_margin": 0.005, "band_hs_margin": 0.05,
        "verify_step_nm": 5.0, "use_land_mask": False,
    }  # fmt: skip
    whole, _, _ = prepare_members(corridor, members, ship, shared, 0)
    cut, _, _ = prepare_members(corridor, members, ship, shared, 0, band_leg_nm=10.0)
    binding = [p.binding for p in whole]
    assert binding[1].any() and not np.array_equal(binding[0], binding[1])  # the storm's member binds more legs
    union = binding[0] | binding[1]
    pieces = np.where(union, np.ceil(np.diff(whole[0].frame.s_nm) / 10.0), 1)
    for p in cut:  # every member on the same legs: each binding leg of either member cut to 10 nm
        assert p.frame.n_legs == int(pieces.sum()) > whole[0].frame.n_legs
        np.testing.assert_array_equal(p.frame.s_nm, cut[0].frame.s_nm)


def test_hs_under_read_is_the_largest_shortfall_in_a_bands_seas_by_hand() -> None:
    # two bands, thresholds 10 m and 5 m; samples where the referee's sea reaches 0.8 x threshold count for that band
    from formulations.common import Band
    from optroute.optimise.rescue import hs_under_read

    bands = (
        Band("te_over_tr", 0.8, 1.2, param=10.0, hs_min_m=10.0, name="synchronous"),
        Band("te_over_tr", 0.4, 0.6, param=10.0, hs_min_m=5.0, name="parametric"),
    )
    true = np.array([[9.0, 10.2, 3.0], [4.5, np.nan, 7.9]])
    nlp = np.array([[8.95, 10.13, 2.0], [4.5, 9.0, 7.95]])
    # band a (from 8 m): 0.05 and 0.07 m short -> 0.07 / 10; band b (from 4 m): 0.05, 0.07, 0.0 and -0.05 -> 0.07 / 5
    assert hs_under_read(nlp, true, bands) == pytest.approx(0.07 / 5.0)
    assert hs_under_read(nlp, true, bands[:1]) == pytest.approx(0.07 / 10.0)
    # the 3 m sample reads 1 m under, but below both bands' seas: it does not count; an NLP reading over: 0
    assert hs_under_read(true + 0.1, true, bands) == 0.0


@pytest.mark.parametrize("bad", [0.0, -5.0, np.inf, np.nan, "20 nm"])
@pytest.mark.parametrize("objective", ["time", "fuel"])
def test_a_band_leg_length_that_is_not_a_length_is_refused_naming_it_even_where_it_would_not_apply(bad, objective):
    # a free-arrival minimum time never cuts its legs: the value is checked all the same
    sc = bench_compare.scenarios(True)[0]
    with pytest.raises(ConfigError, match=r"band_leg_nm.*None to keep max_leg_nm|band_leg_nm=.*not a number"):
        PreparedCorridor(sc.corridor, sc.weather, sc.ship, departure=bench_compare.T0, objective=objective,
                         rules=sc.rules, band_leg_nm=bad)  # fmt: skip
