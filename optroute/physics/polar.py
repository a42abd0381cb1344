"""A sailing boat's polar diagram as data: true wind angle × true wind speed → boat speed.

Formats read and written
------------------------
* **table** — the tab-separated ``.pol`` of OpenCPN and qtVlm (``;`` and ``,``
  separated ``.csv`` too): a header ``TWA\\TWS`` followed by the wind speeds
  [kn], then one line per true wind angle [deg] with the boat speeds [kn].
* **expedition** — Expedition's polar text: one line per wind speed, the wind
  speed [kn] followed by pairs ``TWA BSP``; every line must give the same angles.
* **the paper's matrix** ``C[a][b]`` (Życkowski, eq. 9–10): as printed, one row
  per discrete wind speed ``b`` and one column per heading relative to the wind
  ``a`` (``w_r`` columns, 360/w_r degrees apart, column 0 head to wind); 0 means
  "not sailable".  See :func:`Polar.from_matrix`.

Interpolation
-------------
A bicubic Hermite patch on the table's cells (Fritsch–Carlson monotone slopes
along each axis, zero twist): C1-continuous, exact at every table point.  The
angle is folded to ``|TWA|`` in [0, 180] (port and starboard are the same
polar).  Angles below the polar's no-go limit — the smallest table angle whose
speeds are all positive — give 0 (the table must be zero there, or the reader
says which entry is not).  Below the smallest table wind speed the speed falls
to 0 at 0 kn (a zero column is added); above the largest, evaluation raises
unless ``above_max_tws="hold"`` is chosen (the largest column's speeds).
The model's speeds stay within 0 and the largest of the cell's four corners
(the patch's overshoot is cut there), so no speed exceeds the table's largest:
the search's A* bound relies on it.

hrosailing (0.12.0) was evaluated and not used: its table polar interpolates
scattered neighbourhoods (inverse-distance / arithmetic-mean interpolators), not
a patch exact at the table's points and C1; it marks itself as "still in
development, no backwards compatibility for 0.x", declares Python 3.7–3.9
classifiers and pulls matplotlib into a solver's dependencies; and the search
needs the polar inside a numba kernel (:func:`polar_speed_scalar`), which a
Python object cannot give.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from optroute._numba import jit
from optroute._store import atomic_write_bytes
from optroute.errors import ConfigError

AboveMax = Literal["raise", "hold"]
_VMG_STEP_DEG = 0.01


def _pchip_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Fritsch–Carlson monotone slopes of ``y`` over ``x`` along axis 0 (one-sided three-point ends)."""
    n = x.size
    if n < 2:
        return np.zeros_like(y)
    h = np.diff(x).reshape((-1,) + (1,) * (y.ndim - 1))
    delta = np.diff(y, axis=0) / h
    d = np.zeros_like(y)
    if n == 2:
        d[0] = d[1] = delta[0]
        return d
    w1 = 2 * h[1:] + h[:-1]
    w2 = h[1:] + 2 * h[:-1]
    same = np.sign(delta[1:]) * np.sign(delta[:-1]) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        hm = (w1 + w2) / (w1 / delta[:-1] + w2 / delta[1:])
    d[1:-1] = np.where(same, hm, 0.0)
    for end, (h0, h1, d0, d1) in ((0, (h[0], h[1], delta[0], delta[1])), (-1, (h[-1], h[-2], delta[-1], delta[-2]))):
        e = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
        e = np.where(np.sign(e) != np.sign(d0), 0.0, e)
        e = np.where((np.sign(d0) != np.sign(d1)) & (np.abs(e) > 3 * np.abs(d0)), 3 * d0, e)
        d[end] = e
    return d


@jit(inline="always")
def _cell(x, nodes):  # pragma: no cover - compiled
    """Cell index k (nodes[k] <= x <= nodes[k+1]) and local coordinate t in [0, 1]."""
    lo, hi = 0, nodes.size - 2  # bisection (numba's searchsorted on a scalar allocates)
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if nodes[mid] <= x:
            lo = mid
        else:
            hi = mid - 1
    k = lo
    h = nodes[k + 1] - nodes[k]
    return k, (x - nodes[k]) / h, h


@jit(inline="always")
def polar_speed_scalar(abs_twa_deg, tws_kn, twa_nodes, tws_nodes, f, fa, fw, no_go_deg):  # pragma: no cover
    """Boat speed [kn] at one ``|TWA|`` [deg, 0–180] and TWS [kn, within the nodes]; 0 inside the no-go sector.

    The one implementation of the polar's interpolation: :meth:`Polar.speed_kn`
    and the sailing search's kernel both call it.
    """
    if abs_twa_deg < no_go_deg or tws_kn <= 0.0:
        return 0.0
    i, u, ha = _cell(abs_twa_deg, twa_nodes)
    j, v, hw = _cell(tws_kn, tws_nodes)
    u2, u3, v2, v3 = u * u, u * u * u, v * v, v * v * v
    a0, a1 = 2 * u3 - 3 * u2 + 1, -2 * u3 + 3 * u2
    b0, b1 = (u3 - 2 * u2 + u) * ha, (u3 - u2) * ha
    c0, c1 = 2 * v3 - 3 * v2 + 1, -2 * v3 + 3 * v2
    d0, d1 = (v3 - 2 * v2 + v) * hw, (v3 - v2) * hw
    s = (
        a0 * c0 * f[i, j] + a1 * c0 * f[i + 1, j] + a0 * c1 * f[i, j + 1] + a1 * c1 * f[i + 1, j + 1]
        + (b0 * c0 * fa[i, j] + b1 * c0 * fa[i + 1, j] + b0 * c1 * fa[i, j + 1] + b1 * c1 * fa[i + 1, j + 1])
        + (a0 * d0 * fw[i, j] + a1 * d0 * fw[i + 1, j] + a0 * d1 * fw[i, j + 1] + a1 * d1 * fw[i + 1, j + 1])
    )  # fmt: skip
    top = max(max(f[i, j], f[i + 1, j]), max(f[i, j + 1], f[i + 1, j + 1]))
    return 0.0 if s < 0.0 else (top if s > top else s)


@jit
def _speeds(abs_twa, tws, twa_nodes, tws_nodes, f, fa, fw, no_go):  # pragma: no cover - compiled
    out = np.empty(abs_twa.size)
    for k in range(abs_twa.size):
        out[k] = polar_speed_scalar(abs_twa[k], tws[k], twa_nodes, tws_nodes, f, fa, fw, no_go)
    return out


@dataclass(frozen=True, eq=False)
class Polar:
    """Boat speed through water as a function of true wind angle and speed.

    Parameters
    ----------
    twa_deg : array_like, shape (a,)
        True wind angles [deg off the bow, 0 = head to wind], increasing, from
        ≥ 0 to exactly 180.
    tws_kn : array_like, shape (b,)
        True wind speeds [kn], increasing, ≥ 0.
    speed_kn : array_like, shape (a, b)
        Boat speed [kn] at each (angle, wind speed); 0 = not sailable.  Rows
        below the no-go limit must be all zero.
    name : str
        Label (the boat, the file).
    above_max_tws : {"raise", "hold"}
        Wind above the largest ``tws_kn``: raise, or use the largest column.

    Attributes
    ----------
    no_go_deg : float
        Smallest sailable ``|TWA|`` [deg]: the first table angle whose speeds
        are positive at every wind speed above 0.
    """

    twa_deg: np.ndarray = dataclasses.field(repr=False)
    tws_kn: np.ndarray = dataclasses.field(repr=False)
    speed_kn: np.ndarray = dataclasses.field(repr=False)
    name: str = "polar"
    above_max_tws: AboveMax = "raise"
    no_go_deg: float = dataclasses.field(init=False)

    def __post_init__(self) -> None:
        twa = np.array(self.twa_deg, dtype=float).ravel()
        tws = np.array(self.tws_kn, dtype=float).ravel()
        spd = np.array(self.speed_kn, dtype=float)
        where = f"polar {self.name!r}"
        if spd.shape != (twa.size, tws.size):
            raise ConfigError(f"{where}: speed_kn has shape {spd.shape}, expected (len(twa_deg), len(tws_kn)) = "
                              f"{(twa.size, tws.size)}; give one row per angle and one column per wind speed")  # fmt: skip
        for label, arr in (("twa_deg", twa), ("tws_kn", tws), ("speed_kn", spd)):
            if not np.all(np.isfinite(arr)):
                raise ConfigError(f"{where}: {label} has a non-finite entry; fill the table, do not leave gaps")
        if twa.size < 2 or np.any(np.diff(twa) <= 0) or twa[0] < 0 or twa[-1] != 180.0:
            raise ConfigError(f"{where}: twa_deg={twa.tolist()} must increase strictly from >= 0 to exactly 180 "
                              "(a polar covers beating to running; add the 180 deg row)")  # fmt: skip
        if tws.size < 1 or np.any(np.diff(tws) <= 0) or tws[0] < 0:
            raise ConfigError(f"{where}: tws_kn={tws.tolist()} must be >= 0 and strictly increasing")
        if np.any(spd < 0):
            i, j = np.argwhere(spd < 0)[0]
            raise ConfigError(f"{where}: speed {spd[i, j]} kn at TWA {twa[i]} deg, TWS {tws[j]} kn is negative; "
                              "use 0 for not sailable")  # fmt: skip
        if self.above_max_tws not in ("raise", "hold"):
            raise ConfigError(f"{where}: above_max_tws={self.above_max_tws!r}; use 'raise' or 'hold'")
        windy = tws > 0
        positive = np.all(spd[:, windy] > 0, axis=1)
        if not positive.any():
            raise ConfigError(f"{where}: no angle is sailable at every wind speed; check the table's orientation "
                              "(rows are angles, columns wind speeds)")  # fmt: skip
        first = int(np.argmax(positive))
        for i in range(first + 1, twa.size):
            if not positive[i]:
                j = int(np.argmax(~(spd[i, windy] > 0)))
                raise ConfigError(f"{where}: speed 0 at TWA {twa[i]} deg, TWS {tws[windy][j]} kn lies beyond the "
                                  f"no-go limit {twa[first]} deg; a polar is sailable at every angle from the limit "
                                  "to 180 deg: give that entry its speed")  # fmt: skip
        if np.any(spd[:first, windy] != 0):
            i, j = np.argwhere(spd[:first, windy] != 0)[0]
            raise ConfigError(f"{where}: TWA {twa[i]} deg, TWS {tws[windy][j]} kn has speed {spd[i, windy][j]} but "
                              f"other wind speeds are not sailable at that angle (the no-go limit is {twa[first]} "
                              "deg); the limit must be one angle: set that row to 0 or fill it")  # fmt: skip
        for arr in (twa, tws, spd):
            arr.setflags(write=False)
        object.__setattr__(self, "twa_deg", twa)
        object.__setattr__(self, "tws_kn", tws)
        object.__setattr__(self, "speed_kn", spd)
        object.__setattr__(self, "no_go_deg", float(twa[first]))
        # interpolation tables: sailable rows only, a zero column at 0 kn when the table starts above it
        a_nodes = twa[first:]
        w_nodes, f = tws, spd[first:]
        if tws[0] > 0:
            w_nodes = np.concatenate([[0.0], tws])
            f = np.concatenate([np.zeros((f.shape[0], 1)), f], axis=1)
        if a_nodes.size == 1:  # only 180 sailable: a flat patch
            a_nodes, f = np.array([a_nodes[0] - 1.0, a_nodes[0]]), np.vstack([f, f])
        if w_nodes.size == 1:
            w_nodes, f = np.array([w_nodes[0], w_nodes[0] + 1.0]), np.hstack([f, f])
        fa = _pchip_slopes(a_nodes, f)
        fw = _pchip_slopes(w_nodes, f.T).T
        object.__setattr__(self, "_tables", tuple(np.ascontiguousarray(x) for x in (a_nodes, w_nodes, f, fa, fw)))

    # ------------------------------------------------------------------ evaluation
    @property
    def kernel_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """``(twa_nodes, tws_nodes, f, f_twa, f_tws, no_go_deg)`` for :func:`polar_speed_scalar`."""
        return (*self._tables, self.no_go_deg)  # type: ignore[attr-defined]

    @property
    def max_speed_kn(self) -> float:
        """Largest boat speed of the table [kn]: no interpolated speed exceeds it."""
        return float(self.speed_kn.max())

    @property
    def max_tws_kn(self) -> float:
        """Largest tabulated wind speed [kn]."""
        return float(self.tws_kn[-1])

    def checked_tws(self, tws_kn: ArrayLike, source: str = "the wind") -> np.ndarray:
        """Wind speeds [kn] as used by the polar: checked finite, ≥ 0 and, unless ``hold``, within the table."""
        w = np.asarray(tws_kn, dtype=float)
        bad = ~np.isfinite(w) | (w < 0)
        if bad.any():
            raise ConfigError(f"polar {self.name!r}: TWS {w[bad].ravel()[0]} kn from {source} is not a wind speed")
        if self.above_max_tws == "hold":
            return np.minimum(w, self.max_tws_kn)
        if w.size and w.max() > self.max_tws_kn:
            raise ConfigError(f"polar {self.name!r}: TWS {w.max():.2f} kn from {source} is above the polar's largest "
                              f"{self.max_tws_kn:g} kn; extend the polar, or build it with above_max_tws='hold' to "
                              "sail such wind at the largest column's speeds")  # fmt: skip
        return w

    def speed_kn_at(self, twa_deg: ArrayLike, tws_kn: ArrayLike) -> np.ndarray:
        """Boat speed [kn] at true wind angles [deg, either sign, any turn] and speeds [kn]; 0 in the no-go sector."""
        a, w = np.broadcast_arrays(np.asarray(twa_deg, dtype=float), self.checked_tws(tws_kn))
        if not np.all(np.isfinite(a)):
            raise ConfigError(f"polar {self.name!r}: a true wind angle is not finite")
        absa = np.abs(np.mod(a + 180.0, 360.0) - 180.0)
        tw, ww, f, fa, fw, ng = self.kernel_tables
        out = _speeds(absa.ravel().copy(), w.ravel().astype(float).copy(), tw, ww, f, fa, fw, ng)
        return out.reshape(a.shape)

    def vmg_angles_deg(self, tws_kn: float) -> tuple[float, float, float, float]:
        """Optimal upwind and downwind angles at one wind speed.

        Parameters
        ----------
        tws_kn : float
            True wind speed [kn].

        Returns
        -------
        beat_deg, beat_vmg_kn, run_deg, run_vmg_kn : float
            The ``|TWA|`` maximising ``v cos TWA`` (upwind, ≥ the no-go limit)
            and ``-v cos TWA`` (downwind), and those VMGs [kn]; found on a
            0.01° sweep of the interpolated polar.
        """
        n = int(round((180.0 - self.no_go_deg) / _VMG_STEP_DEG))
        ang = np.round(np.linspace(self.no_go_deg, 180.0, n + 1), 9)
        v = self.speed_kn_at(ang, np.full(ang.shape, float(tws_kn)))
        vmg = v * np.cos(np.radians(ang))
        up, down = int(np.argmax(vmg)), int(np.argmin(vmg))
        return float(ang[up]), float(vmg[up]), float(ang[down]), float(-vmg[down])

    # ----------------------------------------------------------------- readers
    @classmethod
    def from_matrix(
        cls,
        c: ArrayLike,
        tws_kn: ArrayLike,
        *,
        name: str = "matrix",
        asymmetric: Literal["raise", "min", "max"] = "raise",
        above_max_tws: AboveMax = "raise",
    ) -> Polar:
        """The paper's matrix ``C`` (Życkowski eq. 9–10) as a polar.

        Parameters
        ----------
        c : array_like, shape (n_tws, w_r)
            As printed: row ``b`` = wind speed ``tws_kn[b]``, column ``a`` =
            heading ``a · 360 / w_r`` degrees off the wind (0 = head to wind),
            boat speed [kn]; ``w_r`` even.
        tws_kn : array_like, shape (n_tws,)
            The wind speed of each row [kn] (the paper's ``b`` are integers of
            an unstated unit).
        asymmetric : {"raise", "min", "max"}
            Columns ``a`` and ``w_r - a`` (port and starboard) that differ:
            raise naming them, or take the smaller / larger.  The printed
            matrix (10) differs in rows 7 and 8, column 225° (0.81 and 0.83
            against 2.05 and 2.16 at 135°).
        """
        m = np.array(c, dtype=float)
        if m.ndim != 2 or m.shape[1] % 2 or m.shape[1] < 4:
            raise ConfigError(f"matrix C of shape {m.shape} must be (wind speeds, w_r headings) with w_r even >= 4")
        wr = m.shape[1]
        half = wr // 2
        stbd = m[:, : half + 1]
        port = np.concatenate([m[:, :1], m[:, : half - 1 : -1]], axis=1)
        diff = stbd != port
        if diff.any():
            if asymmetric == "raise":
                b, a = np.argwhere(diff)[0]
                raise ConfigError(f"matrix C row {b} (TWS {np.ravel(tws_kn)[b]} kn): heading {a * 360 / wr:g} deg "
                                  f"gives {stbd[b, a]} kn but {360 - a * 360 / wr:g} deg gives {port[b, a]} kn; a "
                                  "polar is symmetric: correct the entry or pass asymmetric='min' or 'max'")  # fmt: skip
            if asymmetric not in ("min", "max"):
                raise ConfigError(f"asymmetric={asymmetric!r}; use 'raise', 'min' or 'max'")
            stbd = np.minimum(stbd, port) if asymmetric == "min" else np.maximum(stbd, port)
        twa = np.arange(half + 1) * 360.0 / wr
        return cls(twa, np.ravel(tws_kn), stbd.T, name=name, above_max_tws=above_max_tws)

    def to_matrix(self, wr: int, tws_kn: ArrayLike | None = None) -> np.ndarray:
        """The paper's matrix ``C`` (rows wind speeds, ``wr`` heading columns from head to wind) [kn]."""
        w = self.tws_kn if tws_kn is None else np.ravel(tws_kn)
        heading = np.arange(int(wr)) * 360.0 / int(wr)
        return self.speed_kn_at(heading[None, :], np.asarray(w, dtype=float)[:, None])


def _split(line: str) -> list[str]:
    return [x for x in re.split(r"[\t;,]| +", line.strip()) if x != ""]


def _number(text: str, path: Path, lineno: int) -> float:
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"{path}:{lineno}: {text!r} is not a number; polar entries are plain numbers "
                          "(fill empty cells, use '.' for decimals)") from None  # fmt: skip


def read_polar(path: str | Path, *, fmt: Literal["auto", "table", "expedition"] = "auto",
               above_max_tws: AboveMax = "raise") -> Polar:  # fmt: skip
    """Read a polar file.

    Parameters
    ----------
    path : str or Path
        A ``.pol``/``.csv``/``.txt`` file.
    fmt : {"auto", "table", "expedition"}
        ``"table"``: OpenCPN/qtVlm (header ``TWA\\TWS`` then wind speeds;
        rows ``TWA speeds…``); ``"expedition"``: rows ``TWS TWA BSP TWA BSP…``;
        ``"auto"``: table when the first cell is not a number.
    above_max_tws : {"raise", "hold"}
        See :class:`Polar`.

    Raises
    ------
    ConfigError
        A missing or extra cell, a non-number, rows of different angles
        (Expedition), or a table :class:`Polar` rejects.
    """
    p = Path(path)
    lines = [(k + 1, ln) for k, ln in enumerate(p.read_text().splitlines()) if ln.strip() and not ln.startswith("#")]
    if not lines:
        raise ConfigError(f"{p}: empty polar file")
    first = _split(lines[0][1])
    if fmt == "auto":
        fmt = "expedition" if re.fullmatch(r"[-+0-9.eE]+", first[0]) else "table"
    rows = [(k, _split(ln)) for k, ln in lines]
    if fmt == "table":
        tws = np.array([_number(x, p, lines[0][0]) for x in first[1:]])
        twa, spd = [], []
        for k, cells in rows[1:]:
            if len(cells) != tws.size + 1:
                raise ConfigError(f"{p}:{k}: {len(cells) - 1} speeds for {tws.size} wind speeds in the header; "
                                  "every row needs one speed per wind speed (0 where not sailable)")  # fmt: skip
            twa.append(_number(cells[0], p, k))
            spd.append([_number(x, p, k) for x in cells[1:]])
        return Polar(np.array(twa), tws, np.array(spd), name=p.name, above_max_tws=above_max_tws)
    if fmt != "expedition":
        raise ConfigError(f"fmt={fmt!r}; use 'auto', 'table' or 'expedition'")
    tws, angles, cols = [], None, []
    for k, cells in rows:
        if len(cells) < 3 or len(cells) % 2 == 0:
            raise ConfigError(f"{p}:{k}: an Expedition row is TWS then TWA/BSP pairs; found {len(cells)} cells")
        vals = [_number(x, p, k) for x in cells]
        a = np.array(vals[1::2])
        if angles is None:
            angles = a
        elif a.shape != angles.shape or np.any(a != angles):
            raise ConfigError(f"{p}:{k}: angles {a.tolist()} differ from the first row's {angles.tolist()}; "
                              "resample the rows to common angles")  # fmt: skip
        tws.append(vals[0])
        cols.append(vals[2::2])
    return Polar(angles, np.array(tws), np.array(cols).T, name=p.name, above_max_tws=above_max_tws)


def write_polar(polar: Polar, path: str | Path, *, fmt: Literal["table", "expedition"] = "table",
                delimiter: str = "\t") -> Path:  # fmt: skip
    """Write a polar (atomically: a complete file or none) in a format :func:`read_polar` reads back exactly."""
    p = Path(path)
    num = repr  # shortest text that reads back to the same float
    if fmt == "table":
        out = [delimiter.join(["TWA\\TWS", *(num(float(w)) for w in polar.tws_kn)])]
        out += [delimiter.join([num(float(a)), *(num(float(v)) for v in row)])
                for a, row in zip(polar.twa_deg, polar.speed_kn, strict=True)]  # fmt: skip
    elif fmt == "expedition":
        out = [delimiter.join([num(float(w)), *(f"{num(float(a))}{delimiter}{num(float(v))}"
                                                 for a, v in zip(polar.twa_deg, col, strict=True))])
               for w, col in zip(polar.tws_kn, polar.speed_kn.T, strict=True)]  # fmt: skip
    else:
        raise ConfigError(f"fmt={fmt!r}; use 'table' or 'expedition'")
    atomic_write_bytes(p, ("\n".join(out) + "\n").encode())
    return p
