"""Compile optroute's numba kernels once, into the on-disk cache, before pytest-xdist starts its workers.

Run by ``tests/conftest.py`` (``pytest_configure``, in the xdist controller only, ``-n 2`` or more) as
``python -m tests.warm_kernels`` from the checkout, so that it compiles this checkout's kernels. On a clean clone numba has no cache yet, so every worker would compile
each kernel it meets for itself (tens of CPU-seconds per process) until another process has written it;
compiled here first, the workers and the tests' subprocesses load them from the cache instead. The calls
are tiny problems through the public API, so the kernels compile with the argument types the suite
uses; a kernel missed here is simply compiled by the first test that needs it, as before. Nothing is
asserted: the tests check the results.
"""

from __future__ import annotations

import warnings

import numpy as np


def warm() -> None:
    """Run each kernel family once on a tiny problem.

    Search, the 3-D DP, Kwon's inversion, the sampler, a search around an exclusion (the leg-batch costing), the
    coastline walks of the DP's legs and the batched loop's edges, sailing and its polar, the roll simulation and the parametric-roll observer, and the corridor NLP's weather
    spline and power-table coefficients (``formulations``).
    """
    import optroute as orx
    from formulations._ratio_table import sector_taylor_data
    from formulations.splines import TensorSpline
    from optroute.observer.level import ObserverSettings, RightingMoment, observe
    from optroute.observer.motions import Encounter, parametric_growth_rate_per_s, simulate_motions
    from optroute.physics.performance import KwonModel
    from optroute.physics.polar import Polar
    from optroute.physics.yacht import SailingVessel
    from optroute.search.edge_land import edges_on_land, legs_on_land
    from optroute.search.sailing import SailingGrid, search_sailing_route
    from optroute.weather import WeatherSampler
    from optroute.weather.schema import canonical_dataset

    t0 = np.datetime64("2024-01-10T00:00", "ns")
    ship = orx.Ship.preset("container_54k_dwt")
    wx = orx.scenarios.uniform(
        hs_m=2.5, tp_s=8.0, bbox=(25, 35, -155, -135), start=t0, duration_h=48, resolution_deg=1.0
    )
    KwonModel(ship).brake_power_kw(np.array([18.0]), hs_m=np.array([2.0]), wave_angle_deg=np.array([30.0]))
    for n in (5_000, 200_000):  # the sampler's serial and parallel kernels
        when = np.full(n, t0 + np.timedelta64(5, "h"))
        WeatherSampler(wx, engine="numba").sample(when, np.full(n, 30.0), np.linspace(-150.0, -140.0, n))
    single = wx.astype("float32")  # a file's single-precision fields: the direction kernel's float32 signature
    WeatherSampler(single, engine="numba").sample(np.array([t0]), np.array([30.0]), np.array([-150.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for objective in ("time", "fuel"):
            orx.search_route(
                (30.0, -150.0), (31.0, -145.0), wx, ship, departure=t0, objective=objective, cell_nm=60,
                use_land_mask=False,
            )  # fmt: skip
        far = orx.Exclusion(np.array([t0]), 20.0, -150.0, 10.0)  # a search around it costs legs in batches
        orx.search_route(
            (30.0, -150.0), (31.0, -145.0), wx, ship, departure=t0, objective="time", cell_nm=60, exclusion=far,
            use_land_mask=False,
        )  # fmt: skip
        # the 3-D DP's leg kernels (the pieces checked by the referee's rules in SOG mode)
        orx.search_route(
            (30.0, -150.0), (31.0, -145.0), wx, ship, departure=t0, objective="fuel", eta=t0 + np.timedelta64(20, "h"),
            method="dp", dp_options={"dx_nm": 90.0, "dy_nm": 30.0, "half_width_nm": 30.0}, use_land_mask=False,
        )  # fmt: skip
    # the coastline walks: the 3-D DP's lattice legs (the GLOBE rows of two legs off San Diego) and the batched
    # loop's edges (no edge: the kernel compiles with the argument types the search passes, and returns)
    legs_on_land(np.array([32.5, 33.0]), np.array([-117.5, -118.0]), np.array([33.0, 33.5]), np.array([-118.0, -119.0]))
    none = np.zeros(0, dtype=np.int64)
    edges_on_land(
        none, none, none, np.zeros((1, 3)), none, np.zeros((1, 1), dtype=np.int64), none, np.zeros(1, dtype=bool),
        np.zeros((1, 1), dtype=np.uint8), np.zeros((1, 1), dtype=bool), np.zeros(4),
    )  # fmt: skip
    polar = Polar([0.0, 40.0, 90.0, 180.0], [5.0, 20.0], [[0, 0], [4.0, 6.0], [6.0, 8.0], [5.0, 7.0]], name="warm")
    cell = 1.0 / 60.0
    wind = canonical_dataset(
        np.array([t0]), np.linspace(-0.2, 0.4, 7), np.linspace(-0.3, 0.3, 7),
        {"wind_u_ms": 0.0, "wind_v_ms": -5.0}, attrs={"source": "warm-up", "geography": "synthetic"},
    )  # fmt: skip
    grid = SailingGrid(np.arange(7) * cell, np.arange(-2, 3) * cell)
    search_sailing_route((0.0, 0.0), (6 * cell, 0.0), wind, SailingVessel(polar, name="warm"), departure=t0, grid=grid)
    polar.speed_kn_at(np.array([50.0, 120.0]), np.array([8.0, 12.0]))
    enc = Encounter(hs_m=4.0, period_s=10.0, alpha_deg=0.0, speed_kn=10.0)
    parametric_growth_rate_per_s(ship, enc)
    m = simulate_motions(ship, enc, duration_s=60.0)
    observe(
        m.time_s, m.heave_m, m.roll_deg, settings=ObserverSettings.for_ship(ship), moment=RightingMoment.from_ship(ship)
    )
    rng = np.random.default_rng(0)
    spline = TensorSpline([np.linspace(0.0, 1.0, 3)] * 3, rng.normal(size=(2, 5, 5, 5)))
    for order in (0, 1, 2):
        spline.evaluate(rng.uniform(0.0, 1.0, (3, 4)), order)
    for blocks in (3, 6):
        sector_taylor_data(
            rng.normal(size=(blocks, 2, 3, 3, 4)), np.full(4, 10.0), np.zeros(4), (5.0, 5.0, 3, -10.0, 10.0, 3)
        )


if __name__ == "__main__":
    warm()
