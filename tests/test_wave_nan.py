"""One reader of the weather's no-passage nodes (:func:`optroute.optimise.lateral.wave_nan`), checked against the referee.

The referee calls a point no passage when a wave variable it reads (Hs, the band period, the wave
direction) samples NaN there (:attr:`optroute.physics.passage.SeaState.navigable`); the sampler gives NaN
when a NaN node lies in its stencil (the 2 × 2 cell, the two bracketing times). The lateral bounds
(static obstacles) and the NLP's time windows (moving ones) both read :func:`wave_nan`; here it is compared
with the referee's own samples at every cell centre and time step of a dataset with random NaNs in every
variable, and on the edge case the two readers used to split: a node NaN in Hs at the first times and in
the period at the others is no passage at *every* time, so a fixed obstacle (main called it neither fixed,
per variable, nor moving, the variables combined).
"""

from __future__ import annotations

import numpy as np

import optroute as orx
from optroute.optimise.lateral import _NanCounts, wave_nan
from optroute.optimise.timed_no_go import time_varying_nan
from optroute.physics.passage import SeaState
from optroute.weather.sample import WeatherSampler

T0 = np.datetime64("2024-01-10T00:00", "ns")


def _weather() -> object:
    ds = orx.scenarios.uniform(
        hs_m=2.0, tp_s=9.0, wave_from_deg=270.0, bbox=(0.0, 6.0, 10.0, 16.0), start=T0, duration_h=18.0, step_h=3.0,
        resolution_deg=1.0,
    ).copy(deep=True)  # fmt: skip
    ds["tm_s"] = ds["tp_s"] * 0.7718  # read by nothing while tp_s is there (SeaState.from_sample)
    return ds


def _referee_no_passage(ds) -> np.ndarray:
    """Whether the referee's sample is no passage at every cell centre, at the middle of every time step."""
    t, lat, lon = ds.time.values, ds.lat.values, ds.lon.values
    tt, la, lo = np.broadcast_arrays(
        (t[:-1] + (t[1:] - t[:-1]) // 2)[:, None, None],
        (0.5 * (lat[1:] + lat[:-1]))[None, :, None],
        (0.5 * (lon[1:] + lon[:-1]))[None, None, :],
    )
    sampler = WeatherSampler(ds)
    got = sampler.sample(tt.ravel(), la.ravel(), lo.ravel(), variables=list(sampler.variables))
    return ~SeaState.from_sample(got).navigable.reshape(tt.shape)


def _stencil_any(nan: np.ndarray) -> np.ndarray:
    """Any of the 2 x 2 x 2 nodes around every cell centre and time-step middle."""
    return (
        nan[:-1, :-1, :-1]
        | nan[1:, :-1, :-1]
        | nan[:-1, 1:, :-1]
        | nan[:-1, :-1, 1:]
        | (nan[1:, 1:, :-1] | nan[1:, :-1, 1:] | nan[:-1, 1:, 1:] | nan[1:, 1:, 1:])
    )


def test_wave_nan_is_the_referees_no_passage_everywhere():
    ds = _weather()
    rng = np.random.default_rng(14)
    for v in ("hs_m", "tp_s", "tm_s", "wave_from_deg"):
        ds[v] = ds[v].where(rng.random(ds[v].shape) > 0.04)
    nan = wave_nan(ds)
    assert nan.shape == (ds.sizes["time"], ds.sizes["lat"], ds.sizes["lon"])
    referee = _referee_no_passage(ds)
    assert 0 < referee.sum() < referee.size  # both kinds of cell occur
    np.testing.assert_array_equal(_stencil_any(nan), referee)
    # a NaN of tm_s alone is not no passage (the referee reads tp_s), a NaN of wave_from_deg alone is
    only_tm = ds["tm_s"].isnull().values & ~ds["hs_m"].isnull().values & ~ds["tp_s"].isnull().values
    only_tm &= ~ds["wave_from_deg"].isnull().values
    assert only_tm.any() and not nan[only_tm].any()


def test_a_node_nan_in_one_variable_then_another_is_a_fixed_obstacle():
    ds = _weather()
    i, j = 3, 2
    half = ds.sizes["time"] // 2
    ds["hs_m"][:half, i, j] = np.nan
    ds["tp_s"][half:, i, j] = np.nan
    assert _referee_no_passage(ds)[
        :, i - 1 : i + 1, j - 1 : j + 1
    ].all()  # no passage at every time, as the referee sees it
    nan, varying = time_varying_nan(ds)
    assert nan[:, i, j].all() and not varying[i, j]  # not a moving no-go area: the NLP's time windows leave it
    static = _NanCounts(ds, static_only=True).static
    assert static[i, j] and static.sum() == 1  # so the lateral bounds must keep the legs off it
    assert not _NanCounts(ds, static_only=True).bad(ds.time.values[:2])[i - 1, j]
