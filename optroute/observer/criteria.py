"""The five criteria of the resonance observer (thyssenkrupp EP 2377756), sample by sample.

One loop, :func:`advance`, turns heave z and roll φ sampled at a fixed
interval into the patent's criteria K1–K5, their normalised values k1–k5 in
[0, 1] and the resonance level RL.  Its whole memory is a state vector of
:data:`N_STATE` numbers, so the batch function and the streaming observer of
:mod:`optroute.observer.level` run the same code (one model, stated once):
the batch call gives it the whole record, the streaming one a sample or a
chunk at a time with the state carried over.  The loop is compiled with
numba when it is installed and runs as Python otherwise.

Per sample, in this order (EP 2377756, description of Fig. 1, A1–A5):

* **pre-filter**: z and φ through a first-order low-pass (time constant
  ``smoothing_s``), the roll rate φ' the backward difference of the
  filtered roll.  The patent samples every 20 ms; differentiating raw
  50 Hz samples would amplify the sensor noise.
* **K1** (A1) [deg]: the roll angle when the heave passes its equilibrium
  going up, minus the roll angle at the next pass going down.  Crossings are
  counted with a dead band (a pass counts only after the heave went beyond
  ±``heave_deadband_m``) and the roll is interpolated linearly to the
  crossing instant.  Held between crossings; normalised by its decaying
  peak |K1| over ``k1_ref_deg``.
* **K2** (A20, A21, A2) [kW]: the roll power P_φ = M_φ(z, φ) · φ', M_φ the
  righting moment [kN·m] from the righting-moment characteristic (a table
  over heave and roll, :class:`optroute.observer.level.RightingMoment`).
  P_φ changes sign four times a roll cycle, so it is normalised by its
  decaying peak |P_φ| over ``k2_ref_kw``.
* **K3** (A3) [kJ]: the roll energy at each upright passage of the roll
  (φ = 0, with a dead band ``roll_deadband_deg``), minus its value
  ``energy_lag`` passages before (1: the previous passage, the patent's
  embodiment; 2, the default: the passage one roll period before, which
  the patent allows too, and which cancels the alternation a wave-frequency
  roll component at 2ω0 gives successive passages in oblique seas).  At φ = 0 the potential energy is zero, so the roll
  energy is the kinetic ½ I φ'² with the virtual inertia I = Δ g GM / ω0²
  (from the natural roll period); the patent obtains it by integrating P_φ,
  which for a characteristic that depends on φ alone returns to zero at
  every upright passage and would carry no information.  Normalised by
  the least relative gain K3 / E_{n−lag} of the last ``energy_passages``
  passages over ``k3_ref_gain``, clipped to [0, 1] (only sustained gains
  count); K3 is held between passages, its normalised value decays.
* **K4** (A4) [kW/s]: the time derivative of the roll power through low-pass
  filters: the power level (|P_φ| through a first-order low-pass of time
  constant ``lookahead_s``) is differentiated and low-passed again with the
  same constant; the patent's filter constants set how far ahead the
  pre-alert looks (near field against the general course).  |P_φ| is used
  because P_φ itself averages zero over a steady roll cycle.  Normalised by
  K4 / ``k4_ref_kw_per_s`` clipped to [0, 1].
* **K5** (A5) [-]: closeness of (z, φ) to mutually dependent state limits,
  the ellipse (z/z_lim)² + (φ/φ_lim)² = 1 of the decaying peaks of |z| and
  |φ|: K5 = √((ẑ/z_lim)² + (φ̂/φ_lim)²), 1 on the limit.  Normalised by
  min(K5, 1).
* **RL** (A_RL): the normalised criteria combined with weights w_i >= 0:
  ``product`` Π k_i^{w_i} (the patent's embodiment), ``sum`` Σ w_i k_i /
  Σ w_i, or ``max`` max{k_i : w_i > 0}; always in [0, 1].  During the
  first ``warmup_s`` after the first sample RL is NaN ("not known yet"):
  the filters and peaks start from zero and would read their own start-up
  as a growing roll.

Every "decaying peak" is x̂_n = max(|x_n|, x̂_{n−1} e^{−Δt/τ}) with τ =
``hold_s`` (one natural roll period by default).
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is optional: the same loop runs in Python without it (slower)
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None

AVAILABLE = numba is not None

COMBINE_CODES = {"product": 0, "sum": 1, "max": 2}
CRITERIA = ("K1", "K2", "K3", "K4", "K5")
CRITERION_UNITS = ("deg", "kW", "kJ", "kW/s", "-")

# parameter vector layout
P_DT, P_AF, P_A4, P_DECAY, P_ZDEAD, P_PDEAD, P_INERTIA = 0, 1, 2, 3, 4, 5, 6
P_K1REF, P_K2REF, P_K3REF, P_K4REF, P_ZLIM, P_PLIM, P_COMBINE, P_W = 7, 8, 9, 10, 11, 12, 13, 14
P_WARM, P_NPASS, P_LAG = 19, 20, 21
N_PARAMS = 22
MAX_PASSAGES = 8

# state vector layout
S_INIT, S_ZF, S_PF, S_RATE, S_ENVP, S_PLEV, S_K4 = 0, 1, 2, 3, 4, 5, 6
S_ZARM, S_HAVEUP, S_PHIUP, S_ENV1, S_K1 = 7, 8, 9, 10, 11
S_PARM, S_NE, S_K3 = 12, 13, 15
S_ENVZ, S_ENVPHI, S_K3RAW, S_COUNT = 16, 17, 18, 19
S_ERING = 20  # ring of the last MAX_PASSAGES passage energies [kJ]
S_GRING = S_ERING + MAX_PASSAGES  # ring of the last relative gains K3 / E_{n-lag}
N_STATE = S_GRING + MAX_PASSAGES


def new_state() -> np.ndarray:
    """The observer's memory before the first sample (all zeros)."""
    return np.zeros(N_STATE)


def _lookup(zax, pax, table, z, p):  # noqa: ANN001, ANN202 - numba-friendly
    """Bilinear interpolation of table[z, φ] on rectilinear axes; NaN outside them."""
    nz = zax.shape[0]
    npp = pax.shape[0]
    if not (zax[0] <= z <= zax[nz - 1]) or not (pax[0] <= p <= pax[npp - 1]):
        return math.nan
    i = 0
    lo, hi = 0, nz - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if zax[mid] <= z:
            lo = mid
        else:
            hi = mid
    i = lo
    lo, hi = 0, npp - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if pax[mid] <= p:
            lo = mid
        else:
            hi = mid
    j = lo
    tz = (z - zax[i]) / (zax[i + 1] - zax[i])
    tp = (p - pax[j]) / (pax[j + 1] - pax[j])
    return (
        (1.0 - tz) * (1.0 - tp) * table[i, j]
        + tz * (1.0 - tp) * table[i + 1, j]
        + (1.0 - tz) * tp * table[i, j + 1]
        + tz * tp * table[i + 1, j + 1]
    )


def _combine(k, prm):  # noqa: ANN001, ANN202
    code = int(prm[P_COMBINE])
    if code == 0:
        out = 1.0
        for c in range(5):
            w = prm[P_W + c]
            if w > 0.0:
                out *= k[c] ** w
        return out
    if code == 1:
        num = 0.0
        den = 0.0
        for c in range(5):
            num += prm[P_W + c] * k[c]
            den += prm[P_W + c]
        return num / den
    out = 0.0
    for c in range(5):
        if prm[P_W + c] > 0.0 and k[c] > out:
            out = k[c]
    return out


def _clip01(x):  # noqa: ANN001, ANN202
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


def advance(z, roll_deg, prm, st, zax, pax, table, raw, norm, rl):  # noqa: ANN001, ANN201, C901
    """Feed samples z [m] and roll [deg] through the observer; returns the first bad index or −1.

    ``st`` (length :data:`N_STATE`) is updated in place; ``raw`` and ``norm``
    (shape (n, 5)) and ``rl`` (n) receive K1–K5, k1–k5 and RL.  A sample
    whose filtered (z, φ) falls outside the righting-moment table stops the
    loop and its index is returned (the caller raises).
    """
    dt = prm[P_DT]
    af = prm[P_AF]
    a4 = prm[P_A4]
    decay = prm[P_DECAY]
    k = np.zeros(5)
    for i in range(z.shape[0]):
        zi = z[i]
        pi = math.radians(roll_deg[i])
        if st[S_INIT] == 0.0:
            st[S_INIT] = 1.0
            st[S_ZF] = zi
            st[S_PF] = pi
        zf_prev = st[S_ZF]
        pf_prev = st[S_PF]
        zf = zf_prev + af * (zi - zf_prev)
        pf = pf_prev + af * (pi - pf_prev)
        rate_prev = st[S_RATE]
        rate = (pf - pf_prev) / dt
        st[S_ZF] = zf
        st[S_PF] = pf
        st[S_RATE] = rate
        m = _lookup(zax, pax, table, zf, pf)
        if math.isnan(m):
            return i
        power = m * rate
        # K2: roll power and its decaying peak
        st[S_ENVP] = max(abs(power), st[S_ENVP] * decay)
        # K4: derivative of the low-passed power level, low-passed again
        plev = st[S_PLEV] + a4 * (abs(power) - st[S_PLEV])
        st[S_K4] = st[S_K4] + a4 * ((plev - st[S_PLEV]) / dt - st[S_K4])
        st[S_PLEV] = plev
        # K1: roll at heave up- and down-crossings (dead band, linear interpolation)
        st[S_ENV1] = st[S_ENV1] * decay
        if st[S_ZARM] < 0.0 and zf_prev < 0.0 <= zf:
            frac = -zf_prev / (zf - zf_prev)
            st[S_PHIUP] = math.degrees(pf_prev + frac * (pf - pf_prev))
            st[S_HAVEUP] = 1.0
            st[S_ZARM] = 0.0
        elif st[S_ZARM] > 0.0 and zf_prev > 0.0 >= zf:
            frac = zf_prev / (zf_prev - zf)
            phi_down = math.degrees(pf_prev + frac * (pf - pf_prev))
            if st[S_HAVEUP] > 0.0:
                st[S_K1] = st[S_PHIUP] - phi_down
                st[S_ENV1] = max(st[S_ENV1], abs(st[S_K1]))
            st[S_ZARM] = 0.0
        if zf > prm[P_ZDEAD]:
            st[S_ZARM] = 1.0
        elif zf < -prm[P_ZDEAD]:
            st[S_ZARM] = -1.0
        # K3: roll energy at upright passages
        st[S_K3] = st[S_K3] * decay
        crossed = (st[S_PARM] < 0.0 and pf_prev < 0.0 <= pf) or (st[S_PARM] > 0.0 and pf_prev > 0.0 >= pf)
        if crossed:
            frac = -pf_prev / (pf - pf_prev)
            rate_c = rate_prev + frac * (rate - rate_prev)
            energy = 0.5 * prm[P_INERTIA] * rate_c * rate_c
            n_e = int(st[S_NE])
            lag = int(prm[P_LAG])
            st[S_ERING + n_e % MAX_PASSAGES] = energy
            st[S_NE] += 1.0
            if n_e >= lag:
                before = st[S_ERING + (n_e - lag) % MAX_PASSAGES]
                st[S_K3RAW] = energy - before
                n_g = n_e - lag
                st[S_GRING + n_g % MAX_PASSAGES] = st[S_K3RAW] / before if before > 0.0 else 0.0
                npass = int(prm[P_NPASS])
                if n_g + 1 >= npass:
                    least = math.inf
                    for back in range(npass):
                        g = st[S_GRING + (n_g - back) % MAX_PASSAGES]
                        if g < least:
                            least = g
                    st[S_K3] = least
            st[S_PARM] = 0.0
        if pf > prm[P_PDEAD]:
            st[S_PARM] = 1.0
        elif pf < -prm[P_PDEAD]:
            st[S_PARM] = -1.0
        # K5: closeness of the (heave, roll) peaks to the limit ellipse
        st[S_ENVZ] = max(abs(zf), st[S_ENVZ] * decay)
        st[S_ENVPHI] = max(abs(math.degrees(pf)), st[S_ENVPHI] * decay)
        k5 = math.sqrt((st[S_ENVZ] / prm[P_ZLIM]) ** 2 + (st[S_ENVPHI] / prm[P_PLIM]) ** 2)
        raw[i, 0] = st[S_K1]
        raw[i, 1] = power
        raw[i, 2] = st[S_K3RAW]
        raw[i, 3] = st[S_K4]
        raw[i, 4] = k5
        k[0] = _clip01(st[S_ENV1] / prm[P_K1REF])
        k[1] = _clip01(st[S_ENVP] / prm[P_K2REF])
        k[2] = _clip01(st[S_K3] / prm[P_K3REF])
        k[3] = _clip01(st[S_K4] / (st[S_PLEV] + 0.05 * prm[P_K2REF]) / prm[P_K4REF])
        k[4] = _clip01(k5)
        for c in range(5):
            norm[i, c] = k[c]
        st[S_COUNT] += 1.0
        rl[i] = _combine(k, prm) if st[S_COUNT] > prm[P_WARM] else math.nan
    return -1


if numba is not None:
    _lookup = numba.njit(cache=True)(_lookup)
    _combine = numba.njit(cache=True)(_combine)
    _clip01 = numba.njit(cache=True)(_clip01)
    advance = numba.njit(cache=True)(advance)
