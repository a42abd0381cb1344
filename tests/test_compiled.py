"""The NLP's leg functions compiled to C through a disk cache (formulations.compiled), and ``jit``'s modes.

The reference is CasADi's own virtual machine: a compiled function must give its numbers bit for bit.
"""

from __future__ import annotations

import shutil

import casadi as ca
import numpy as np
import pytest

from formulations.compiled import CACHE_ENV, compiled_function, compiler
from optroute.errors import ConfigError
from optroute.optimise.corridor_setup import JIT_AUTO_LEGS, check_jit
from tests.test_formulations_nlp import _rich_problem

needs_cc = pytest.mark.skipif(shutil.which(compiler()[0]) is None, reason="no C compiler on this machine")


def _sx_function() -> ca.Function:
    x = ca.SX.sym("x", 3)
    return ca.Function("probe", [x], [ca.vertcat(ca.sin(x[0]) * x[1] ** 2 + ca.sqrt(x[2]), x[0] * x[1] * x[2] + 1e-3)])


@needs_cc
def test_a_function_is_compiled_once_then_loaded_from_the_cache_with_the_interpreters_numbers(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    fun = _sx_function()
    first, how1 = compiled_function(fun)
    second, how2 = compiled_function(_sx_function())
    assert (how1, how2) == ("compiled", "cached")
    assert [p.suffix for p in (tmp_path / "cache").iterdir()] == [".so"]  # no source or partial library left
    assert list(work.iterdir()) == []  # nothing written where the user works
    rng = np.random.default_rng(3)
    for x in rng.uniform(0.1, 5.0, (20, 3)):
        expected = np.asarray(fun(x)).ravel()
        np.testing.assert_array_equal(np.asarray(first(x)).ravel(), expected)
        np.testing.assert_array_equal(np.asarray(second(x)).ravel(), expected)


@needs_cc
def test_a_build_removes_the_libraries_not_used_for_stale_days_and_a_load_marks_its_library_used(tmp_path, monkeypatch):
    import os
    import time

    from formulations.compiled import STALE_DAYS

    cache = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(cache))
    cache.mkdir()
    stale, recent = cache / "leg_hess-0123.so", cache / "leg_jac-4567.so"
    for path, age_days in ((stale, STALE_DAYS + 1.0), (recent, STALE_DAYS - 1.0)):
        path.write_bytes(b"not a library")
        then = time.time() - age_days * 86400.0
        os.utime(path, (then, then))
    _, how = compiled_function(_sx_function())
    assert how == "compiled"
    assert not stale.exists() and recent.exists()  # the one past STALE_DAYS removed, the younger kept
    (built,) = [p for p in cache.glob("probe-*.so")]
    then = time.time() - (STALE_DAYS + 1.0) * 86400.0
    os.utime(built, (then, then))
    _, how = compiled_function(_sx_function())
    assert how == "cached" and built.stat().st_mtime > time.time() - 3600.0  # loading marked it used


def test_without_a_compiler_or_a_writable_cache_the_function_stays_interpreted_and_says_why(tmp_path, monkeypatch):
    fun = _sx_function()
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    same, how = compiled_function(fun)
    assert same is fun and "no C compiler" in how and "CC" in how
    if shutil.which("gcc") is None:
        return
    monkeypatch.setenv("CC", "gcc")
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(CACHE_ENV, str(blocker))
    same, how = compiled_function(fun)
    assert same is fun and CACHE_ENV in how


@needs_cc
def test_the_nlps_compiled_derivatives_equal_the_interpreted_ones_bit_for_bit(tmp_path, monkeypatch):
    # the real leg functions of a corridor with curvature, time-varying waves, current, wind, two bands and a moving
    # exclusion: Ipopt's gradient, Jacobian and Lagrangian Hessian at random points, compiled against interpreted
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    plain, _ = _rich_problem(exact_hessian=True)
    fast, _ = _rich_problem(exact_hessian=True, jit=True)
    assert len(list(tmp_path.glob("*.so"))) == 3  # leg_grad, leg_jac, leg_hess
    n = plain.n_legs
    rng = np.random.default_rng(11)
    p = np.concatenate([[1.0, 0.2], np.full(plain.n_legs * plain.samples_per_leg * 2, 0.8), np.ones(n)])
    names = ("nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
    for _ in range(3):
        x = np.concatenate([rng.uniform(-20, 20, n + 1), rng.uniform(8, 20, n), np.sort(rng.uniform(0, 40, n + 1))])
        lam = rng.normal(size=plain._ng)
        for name in names:
            args = (x, p, 1.0, lam) if name == "nlp_hess_l" else (x, p)
            want, got = (_outputs(nlp._solver.get_function(name)(*args)) for nlp in (plain, fast))
            for w, g in zip(want, got, strict=True):
                np.testing.assert_array_equal(g, w, err_msg=name)


def _outputs(out: object) -> list[np.ndarray]:
    return [np.asarray(ca.DM(a).full()) for a in (out if isinstance(out, tuple) else (out,))]


def test_jit_modes(monkeypatch):
    with pytest.raises(ConfigError, match="jit='yes' is not known"):
        check_jit("yes", 10)
    assert check_jit(False, 10_000) is False
    found = shutil.which(compiler()[0]) is not None
    assert check_jit("auto", JIT_AUTO_LEGS - 1) is False
    assert check_jit("auto", JIT_AUTO_LEGS) is found
    monkeypatch.setenv("CC", "no-such-compiler-here")
    assert check_jit("auto", 10 * JIT_AUTO_LEGS) is False  # "auto" without a compiler: interpreted, no error
    with pytest.raises(ConfigError, match="'no-such-compiler-here' is not on the PATH.*jit='auto' or False"):
        check_jit(True, 10)


@needs_cc
def test_jit_true_refuses_a_cache_folder_it_cannot_write(tmp_path, monkeypatch):
    # an explicit jit=True that would silently stay interpreted is refused; "auto" stays interpreted, no error
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(CACHE_ENV, str(blocker))
    with pytest.raises(ConfigError, match=f"{CACHE_ENV}=.*a-file.*cannot be written.*jit='auto' or False"):
        check_jit(True, 10)
    assert check_jit("auto", 10 * JIT_AUTO_LEGS) is True
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "fresh"))
    assert check_jit(True, 10) is True


@needs_cc
def test_a_compiled_corridor_call_plans_the_same_to_the_last_bit_and_says_how_it_compiled(tmp_path, monkeypatch):
    # a storm crossing a free corridor, through optimise_corridor: jit=True against jit=False, its record in
    # solver_stats, and a second call served by the cache
    import optroute as orx

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    t0 = np.datetime64("2024-01-10T00:00", "ns")
    wx = orx.scenarios.moving_storm(0.0, -30.0, 90.0, 6.0, peak_hs_m=7.0, start=t0, duration_h=120.0,
                                    bbox=(-10, 10, -40, 0))  # fmt: skip
    corridor = orx.Corridor.from_waypoints([[0.0, -35.0], [2.0, -15.0]], width_nm=20.0)
    kw = {"departure": t0, "eta": t0 + np.timedelta64(90, "h"), "max_leg_nm": 60.0, "use_land_mask": False}
    ship = orx.Ship.preset("container_54k_dwt")
    plans = {j: orx.optimise_corridor(corridor, wx, ship, jit=j, **kw) for j in (False, True, "auto")}
    assert plans[False].solver_stats["jit"] == "off"
    assert plans["auto"].solver_stats["jit"] == "off"  # 20 legs: below JIT_AUTO_LEGS
    how = plans[True].solver_stats["jit"]
    assert how and all(h.startswith("leg_") and h.endswith((": compiled", ": cached")) for h in how)
    again = orx.optimise_corridor(corridor, wx, ship, jit=True, **kw)
    assert again.solver_stats["jit"] and all(h.endswith(": cached") for h in again.solver_stats["jit"])
    for plan in (plans[True], again):
        assert plan.status == plans[False].status
        assert plan.total_fuel_t == plans[False].total_fuel_t
        np.testing.assert_array_equal(plan.stw_kn, plans[False].stw_kn)
        np.testing.assert_array_equal(plan.waypoints, plans[False].waypoints)
        assert plan.solver_stats["iterations"] == plans[False].solver_stats["iterations"]
