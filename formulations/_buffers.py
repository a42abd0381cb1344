"""CasADi functions evaluated in numpy through their buffers, for the corridor NLP's hot path.

Split out of :mod:`formulations._nlp_model`. CasADi converts every numpy argument and result of a Python call to
its ``DM`` type element by element; on a 500-leg corridor those conversions cost as much as the derivatives
themselves. Everything here reads and writes CasADi's own memory (``Function.buffer``, ``Callback.eval_buffer``):

* :class:`Buffered` — call a CasADi function on numpy arrays (the inputs' and outputs' nonzeros, column-major);
* :class:`MemoCallback` — a derivative function for ``nlpsol`` fed the memoised Taylor data of the weather
  (:func:`formulations._nlp_model.structured_derivatives`);
* :class:`WeatherValues` — the weather fields at the samples from the numpy spline, as a CasADi function;
* :class:`SharedMap` — a function that answers a repeated input (Ipopt asks ``f`` and ``g`` at the same point)
  from its last result.

None of them has derivatives: they serve graphs that nothing differentiates.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

__all__ = ["Buffered", "CoreCallback", "MemoCallback", "SharedMap", "WeatherValues"]


class Buffered:
    """A CasADi function evaluated on numpy arrays through its buffers (``Function.buffer``): the arrays are the
    inputs' and outputs' nonzeros, column-major; nothing is converted to or from ``DM``."""

    def __init__(self, fn: Any) -> None:
        self._fn = fn
        self._buf, self._eval = fn.buffer()
        self._outs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]

    def array_in(self, i: int, mem: Any) -> np.ndarray:
        """Input ``i`` from a buffer CasADi passed (zeros where it passed none)."""
        a = np.frombuffer(mem, dtype=float) if mem is not None else np.zeros(0)
        return a if a.size == self._fn.nnz_in(i) else np.zeros(self._fn.nnz_in(i))

    def array_out(self, i: int, mem: Any) -> np.ndarray:
        """Output ``i``'s buffer to write into (a scratch array where CasADi wants none)."""
        a = np.frombuffer(mem, dtype=float) if mem is not None else np.zeros(0)
        return a if a.size == self._fn.nnz_out(i) else np.zeros(self._fn.nnz_out(i))

    def __call__(self, *args: np.ndarray, out: list[np.ndarray] | None = None) -> list[np.ndarray]:
        ins = [np.ascontiguousarray(a, dtype=float).ravel() for a in args]  # kept alive through the call
        outs = self._outs if out is None else out
        for i, a in enumerate(ins):
            self._buf.set_arg(i, memoryview(a))
        for i, o in enumerate(outs):
            self._buf.set_res(i, memoryview(o))
        self._eval()
        return outs


class CoreCallback(ca.Callback):
    """A CasADi callback with the inputs, outputs and sparsities of a core function (``self._core``) under the
    names ``self._names = (names_in, names_out)``: the shared shape of the NLP's derivative callbacks."""

    _core: Any
    _names: tuple[list[str], list[str]]

    def get_n_in(self) -> int:
        return len(self._names[0])

    def get_n_out(self) -> int:
        return len(self._names[1])

    def get_name_in(self, i: int) -> str:
        return self._names[0][i]

    def get_name_out(self, i: int) -> str:
        return self._names[1][i]

    def get_sparsity_in(self, i: int) -> Any:
        return self._core.sparsity_in(i)

    def get_sparsity_out(self, i: int) -> Any:
        return self._core.sparsity_out(i)


class MemoCallback(CoreCallback):
    """A derivative function for ``nlpsol`` that feeds the memoised Taylor data to a core function."""

    def __init__(
        self,
        name: str,
        core: Any,
        theta: Callable[[Any], Any],
        names_in: list[str],
        names_out: list[str],
        cache: bool = False,
    ) -> None:
        ca.Callback.__init__(self)
        self._core, self._theta, self._names = core, theta, (names_in, names_out)
        self._run = Buffered(core)
        self._cache = cache
        self._last: tuple[bytes, Any] | None = None
        self.construct(name, {})

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, arg: list[Any], res: list[Any]) -> int:
        """Read the inputs from and write the outputs into CasADi's own buffers: no DM conversion of the inputs,
        the Taylor data or the outputs (on a 500-leg corridor they cost as much as the leg functions)."""
        core = self._run
        ins = [core.array_in(i, a) for i, a in enumerate(arg)]
        outs = [core.array_out(i, r) for i, r in enumerate(res)]
        key = b"".join(a.tobytes() for a in ins) if self._cache else b""
        if self._cache and self._last is not None and self._last[0] == key:
            for o, c in zip(outs, self._last[1], strict=True):
                o[:] = c
            return 0
        core(*ins, self._theta(ins[0]), out=outs)
        if self._cache:
            self._last = (key, [o.copy() for o in outs])
        return 0


class WeatherValues(ca.Callback):
    """The weather fields at K points, ``(3, K) [t; s; y] ↦ (n_fields, K)``, as a CasADi function evaluated in
    numpy (:meth:`formulations.weather_grid.WeatherGrid.tensor_spline`): the values of CasADi's
    ``WeatherGrid.interpolant`` without building it. No derivatives: the NLP built with it takes its
    derivatives from :func:`structured_derivatives`."""

    def __init__(self, weather: Any, n_points: int) -> None:
        ca.Callback.__init__(self)
        self._spline = weather.tensor_spline()
        self._k = int(n_points)
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # the last points and their fields
        self.construct("weather_values", {})

    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> Any:
        return ca.Sparsity.dense(3, self._k)

    def get_sparsity_out(self, i: int) -> Any:
        return ca.Sparsity.dense(self._spline.n_fields, self._k)

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, arg: list[Any], res: list[Any]) -> int:
        """Read the points from and write the fields into CasADi's own buffers (column-major): no DM conversion,
        which costs more than the spline itself on a few thousand points."""
        flat = np.frombuffer(arg[0], dtype=float)
        out = np.frombuffer(res[0], dtype=float).reshape(self._k, self._spline.n_fields).T
        if self._last is None or not np.array_equal(self._last[0], flat):  # Ipopt asks f and g at the same point
            self._last = (flat.copy(), self._spline.evaluate(flat.reshape(self._k, 3).T, 0))
        out[:] = self._last[1]
        return 0


class SharedMap(ca.Callback):
    """A function without derivatives that answers a repeated input from its last result (buffers, no DM).

    Ipopt asks the objective and the constraints at the same point, and CasADi evaluates the NLP's graph once for
    each: wrapped around the per-sample physics mapped over the samples (the bulk of both), the second evaluation
    is a copy of the first. Only for a graph nothing differentiates (the NLP built with
    :func:`structured_derivatives` and the weather read in numpy, :class:`WeatherValues`).
    """

    def __init__(self, fn: Any) -> None:
        ca.Callback.__init__(self)
        self._fn = fn
        self._run = Buffered(fn)
        self._last: tuple[bytes, list[np.ndarray]] | None = None
        self.construct(fn.name() + "_shared", {})

    def get_n_in(self) -> int:
        return self._fn.n_in()

    def get_n_out(self) -> int:
        return self._fn.n_out()

    def get_sparsity_in(self, i: int) -> Any:
        return self._fn.sparsity_in(i)

    def get_sparsity_out(self, i: int) -> Any:
        return self._fn.sparsity_out(i)

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, arg: list[Any], res: list[Any]) -> int:
        ins = [self._run.array_in(i, a) for i, a in enumerate(arg)]
        outs = [self._run.array_out(i, r) for i, r in enumerate(res)]
        key = b"".join(a.tobytes() for a in ins)
        if self._last is None or self._last[0] != key:
            self._last = (key, [o.copy() for o in self._run(*ins)])
        for o, c in zip(outs, self._last[1], strict=True):
            o[:] = c
        return 0
