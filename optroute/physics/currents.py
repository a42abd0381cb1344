"""Currents: the flat-earth velocity triangle of one leg.

Speed and course over ground from speed and heading through the water, the
heading that holds a course against a cross-current, and the speed through
the water needed for a speed over ground (Bowditch, *The American Practical
Navigator*, "current sailing").  Leeway is not modelled.

Conventions (``shared/design.md``): headings and courses are degrees true,
the direction the ship goes **to**; currents are (u, v) [m/s], the east and
north components of the vector the water flows **to**; speeds in knots.
Every function is vectorised; arrays broadcast together.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from optroute import units
from optroute._checks import finite
from optroute.errors import SeaStateError
from optroute.physics._inputs import OnUnreachable, first_true, on_unreachable_mode, speed_kn

__all__ = ["heading_for_course", "sog_from_stw", "stw_for_sog"]


def _current_kn(current_u_ms: ArrayLike, current_v_ms: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    fix = "pass the current's east/north components [m/s] (missing current means 0)"
    u = finite("current_u_ms", current_u_ms, fix=fix)
    v = finite("current_v_ms", current_v_ms, fix=fix)
    return units.ms_to_kn(u), units.ms_to_kn(v)


def _angle(name: str, value: ArrayLike) -> np.ndarray:
    return finite(name, value, fix="pass degrees true, the direction the ship goes to")


def sog_from_stw(
    stw_kn: ArrayLike,
    heading_deg: ArrayLike,
    current_u_ms: ArrayLike,
    current_v_ms: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """Speed and course over ground from speed and heading through the water.

    Velocity triangle (flat earth, one leg): ground velocity = water velocity
    of the ship + current, V_g = STW (sin h, cos h) + (u, v) in (east, north)
    components (Bowditch, "current sailing").  Leeway is not modelled.

    Parameters
    ----------
    stw_kn : array_like
        Speed through the water [kn], >= 0.
    heading_deg : array_like
        Heading [deg true, the direction the ship goes to].
    current_u_ms, current_v_ms : array_like
        Current, east and north components of the vector the water flows
        to [m/s].

    Returns
    -------
    sog_kn : ndarray
        Speed over ground [kn], >= 0.
    cog_deg : ndarray
        Course over ground [deg true, in [0, 360)]; where the SOG is exactly
        0 the course is undefined and the heading (wrapped) is returned.

    Raises
    ------
    SeaStateError
        A non-finite or negative STW, or a non-finite heading or current.
    """
    stw = speed_kn("stw_kn", stw_kn)
    h = _angle("heading_deg", heading_deg)
    cu, cv = _current_kn(current_u_ms, current_v_ms)
    su, sv = units.speed_to_deg_to_uv(stw, h)
    sog, cog = units.uv_to_speed_to_deg(su + cu, sv + cv)
    cog = np.where(sog > 0.0, cog, units.wrap_360(h) + np.zeros_like(sog))
    return sog, cog


def _along_cross(course_deg: np.ndarray, cu_kn: np.ndarray, cv_kn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Current components along the course and across it (+ to starboard) [kn]."""
    c = np.radians(course_deg)
    along = cu_kn * np.sin(c) + cv_kn * np.cos(c)
    cross = cu_kn * np.cos(c) - cv_kn * np.sin(c)
    return along, cross


def heading_for_course(
    course_deg: ArrayLike,
    stw_kn: ArrayLike,
    current_u_ms: ArrayLike,
    current_v_ms: ArrayLike,
    *,
    on_unreachable: OnUnreachable = "raise",
) -> tuple[np.ndarray, np.ndarray]:
    """Heading that makes good ``course_deg`` at a given STW, and the SOG along it.

    Velocity triangle (flat earth, one leg; Bowditch, "current sailing").
    With the current split into c_along (along the course) and c_cross
    (across it, positive to starboard), the ship crabs by δ = heading −
    course so that its own cross-track velocity cancels the current's:
    STW sin δ = −c_cross, δ = arcsin(−c_cross / STW) (the smaller of the two
    solutions, bow into the current), and SOG = STW cos δ + c_along.

    Parameters
    ----------
    course_deg : array_like
        Course to make good over ground [deg true, direction to].
    stw_kn : array_like
        Speed through the water [kn], > 0.
    current_u_ms, current_v_ms : array_like
        Current, east and north components of the vector the water flows
        to [m/s].
    on_unreachable : {"raise", "nan"}
        Where the course cannot be held (see Raises): raise (default), or
        return NaN heading and SOG there so a vectorised caller can mark it.

    Returns
    -------
    heading_deg : ndarray
        Heading [deg true, in [0, 360)].
    sog_kn : ndarray
        Speed over ground along the course [kn], > 0.

    Raises
    ------
    SeaStateError
        Where the cross-current exceeds the STW (the course cannot be held)
        or the SOG along the course is <= 0 (the current sets the ship back);
        and for a non-finite course or current or an STW <= 0.
    """
    course = _angle("course_deg", course_deg)
    stw = finite("stw_kn", stw_kn, minimum=0.0, strict=True, fix="pass a speed through the water in knots, > 0")
    cu, cv = _current_kn(current_u_ms, current_v_ms)
    course, stw, cu, cv = np.broadcast_arrays(course, stw, cu, cv)
    along, cross = _along_cross(course, cu, cv)
    if on_unreachable_mode(on_unreachable) == "nan":
        delta = np.arcsin(np.clip(-cross / stw, -1.0, 1.0))
        sog = stw * np.cos(delta) + along
        bad = (np.abs(cross) > stw) | (sog <= 0.0)
        return np.where(bad, np.nan, units.wrap_360(course + np.degrees(delta))), np.where(bad, np.nan, sog)
    bad = np.abs(cross) > stw
    if bad.any():
        idx, where = first_true(bad)
        raise SeaStateError(
            f"the cross-current {abs(cross[idx]):.3f} kn exceeds stw_kn={float(stw[idx])!r} on course_deg={float(course[idx])!r}"
            f"{where}: the course cannot be held; use more speed or another course"
        )
    delta = np.arcsin(np.clip(-cross / stw, -1.0, 1.0))  # clip only rounding: |cross| <= stw checked above
    sog = stw * np.cos(delta) + along
    bad = sog <= 0.0
    if bad.any():
        idx, where = first_true(bad)
        raise SeaStateError(
            f"the current sets the ship back: SOG along course_deg={float(course[idx])!r} would be {sog[idx]:.3f} kn "
            f"at stw_kn={float(stw[idx])!r}{where}; use more speed or another course"
        )
    return units.wrap_360(course + np.degrees(delta)), sog


def stw_for_sog(
    course_deg: ArrayLike,
    sog_kn: ArrayLike,
    current_u_ms: ArrayLike,
    current_v_ms: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """Speed through the water and heading that make good ``sog_kn`` along ``course_deg``.

    Velocity triangle (flat earth, one leg; Bowditch, "current sailing"):
    the ship's water velocity is the wanted ground velocity minus the
    current, SOG (sin c, cos c) − (u, v); STW is its length and the heading
    its direction.

    Parameters
    ----------
    course_deg : array_like
        Course to make good over ground [deg true, direction to].
    sog_kn : array_like
        Speed over ground wanted along the course [kn], >= 0.
    current_u_ms, current_v_ms : array_like
        Current, east and north components of the vector the water flows
        to [m/s].

    Returns
    -------
    stw_kn : ndarray
        Speed through the water [kn], >= 0.
    heading_deg : ndarray
        Heading [deg true, in [0, 360)]; where the STW is exactly 0 (the
        current alone gives the wanted ground velocity) the heading is
        undefined and the course (wrapped) is returned.

    Raises
    ------
    SeaStateError
        A non-finite or negative SOG, or a non-finite course or current.
    """
    course = _angle("course_deg", course_deg)
    sog = finite("sog_kn", sog_kn, minimum=0.0, fix="pass a speed over ground in knots, >= 0")
    cu, cv = _current_kn(current_u_ms, current_v_ms)
    gu, gv = units.speed_to_deg_to_uv(sog, course)
    stw, heading = units.uv_to_speed_to_deg(gu - cu, gv - cv)
    heading = np.where(stw > 0.0, heading, units.wrap_360(course) + np.zeros_like(stw))
    return stw, heading
