"""The search's floors of the cost rate at a point (:mod:`optroute.physics.pointwise`), by which the speed choice
skips speeds that cannot win.

References: Kwon's (2008) direction coefficient swept over the wave angle every 0.01°; the referee's own point
evaluation (:func:`optroute.physics.pointwise.evaluate_speed`: the heading against the current, Kwon's calm speed,
the bands, the power limits) at random seas, courses, currents and speeds, whose (fuel + λ) / SOG no floor may
exceed and whose speeds no infinite floor may strike while allowed.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optroute as orx
from optroute import units
from optroute.physics.performance import CalmWaterModel, KwonModel
from optroute.physics.pointwise import (
    P_VMAX_KN,
    cached_point_params,
    cost_rate_floor,
    cost_rate_floor_in_sea,
    evaluate_speed,
    kwon_direction_coefficient,
    kwon_direction_range,
    loss_range_at,
)
from optroute.physics.safety import BandRules

_PARAMS = {
    (name, kwon): cached_point_params(ship, KwonModel(ship) if kwon else CalmWaterModel(ship), BandRules())
    for name in orx.Ship.presets()
    for ship in [orx.Ship.preset(name)]
    for kwon in (True, False)
}


@pytest.mark.parametrize("seed", range(4))
def test_kwons_direction_range_is_the_least_and_greatest_of_a_fine_sweep_of_wave_angles(seed):
    """Against the coefficient evaluated every 0.01° (and at the ends) over random intervals of angles, BN 0-12."""
    rng = np.random.default_rng(seed)
    for _ in range(40):
        lo = rng.uniform(-400.0, 400.0)
        hi = lo + rng.choice([rng.uniform(0.1, 5.0), rng.uniform(5.0, 200.0)])
        bn = float(rng.integers(0, 13))
        sweep = [kwon_direction_coefficient(a, bn) for a in np.r_[np.arange(lo, hi, 0.01), hi]]
        least, most = kwon_direction_range(bn, lo, hi)
        assert least == pytest.approx(min(sweep), abs=1e-12) and most == pytest.approx(max(sweep), abs=1e-12)


_finite = dict(allow_nan=False, allow_infinity=False)


@settings(max_examples=400)
@given(
    ship=st.sampled_from(sorted(_PARAMS)),
    hs_m=st.floats(0.0, 14.0, **_finite),
    period_s=st.floats(3.0, 16.0, **_finite),
    wave_from_deg=st.floats(0.0, 360.0, **_finite),
    wind=st.one_of(
        st.tuples(st.floats(-30.0, 30.0, **_finite), st.floats(-30.0, 30.0, **_finite)), st.just((math.nan, math.nan))
    ),  # fmt: skip
    current_ms=st.tuples(st.floats(-2.0, 2.0, **_finite), st.floats(-2.0, 2.0, **_finite)),
    course_deg=st.floats(0.0, 360.0, **_finite),
    speed_share=st.floats(0.05, 1.02, **_finite),
    lam=st.sampled_from([0.0, 0.5, 3.6, 40.0]),
)
def test_the_floor_in_a_sea_never_exceeds_the_referees_rate_and_is_infinite_only_where_no_power_makes_the_speed(
    ship, hs_m, period_s, wave_from_deg, wind, current_ms, course_deg, speed_share, lam
):
    p = _PARAMS[ship]
    stw = 4.0 + speed_share * (float(p[P_VMAX_KN]) - 4.0)
    cur_kn = math.hypot(*current_ms) / units.MS_PER_KN
    loss = loss_range_at(p, course_deg, hs_m, wave_from_deg, *wind, cur_kn, 4.0)
    floor = cost_rate_floor_in_sea(p, stw, lam, cur_kn, *loss)
    _, sog, _, fuel, allowed = evaluate_speed(p, course_deg, hs_m, period_s, wave_from_deg, *wind, *current_ms, stw)
    assert floor >= cost_rate_floor(p, stw, lam, cur_kn)  # never weaker than the calm-water floor
    if allowed and sog > 0.0:
        assert floor <= (fuel + lam) / sog * (1.0 + 1e-12)


def test_in_head_seas_without_current_the_floor_is_within_2_percent_of_the_rate():
    """Not trivial: Beaufort 7 head seas on the 8 000 TEU ship at 14 kn, where the calm-water floor is far below."""
    p = _PARAMS[("container_8000teu", True)]
    wind = (0.0, -15.0)  # 15 m/s from the north: Beaufort 7; waves from the north, course north
    loss = loss_range_at(p, 0.0, 4.0, 0.0, *wind, 0.0, 5.0)
    assert loss[0] == loss[1] > 0.0
    _, sog, _, fuel, allowed = evaluate_speed(p, 0.0, 4.0, 9.0, 0.0, *wind, 0.0, 0.0, 14.0)
    assert allowed
    rate = (fuel + 1.0) / sog
    floor = cost_rate_floor_in_sea(p, 14.0, 1.0, 0.0, *loss)
    assert 0.98 * rate <= floor <= rate
    assert cost_rate_floor(p, 14.0, 1.0, 0.0) < 0.9 * rate
