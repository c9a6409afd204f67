"""Prescribed signals of time that know their derivatives.

Index reduction may need the 1st, 2nd or 3rd time derivative of a prescribed input (a position source driving an
inertia through a gear needs the 2nd). A source's signal is therefore either

* a sympy expression of :data:`acausal.time` (differentiated exactly by sympy and compiled into the model), or
* a :class:`Signal`: a numeric function that evaluates itself and its derivatives up to :attr:`Signal.max_order`,
  vectorised over time. It is *not* compiled in: it is called at run time, so a replay can swap it per run
  (``sim.simulate(inputs={"pos.phi_ref": other})``) without recompiling.

Inside equations a numeric signal appears as ``SignalCall(token, order, time)``, a sympy function whose derivative
is the same call with ``order + 1``.

A signal may also describe itself in a closed form that code outside Python can evaluate (the compiled simulation
path, an exported model): :meth:`Signal.table` as a :class:`PiecewisePolynomial` (splines, sampled data,
constants) or :meth:`Signal.symbolic` as a sympy expression of its argument (expressions, Fourier series).
A signal with neither is evaluated in Python only.
"""
from __future__ import annotations

import abc
import bisect
from dataclasses import dataclass

import numpy as np
import sympy as sp
from scipy.interpolate import PPoly, make_interp_spline

from ..errors import SignalError
from .symbols import ConstantSymbol, strict_expr, time


@dataclass(frozen=True)
class PiecewisePolynomial:
    """A signal as polynomial pieces: on ``breaks[i] <= tau < breaks[i+1]`` the value is
    ``sum_k coef[k, i] * (tau - breaks[i]) ** (degree - k)`` (highest power first, as
    :class:`scipy.interpolate.PPoly`). ``outside`` says what happens beyond the breaks: ``"periodic"`` (``tau`` is
    time wrapped into ``[breaks[0], breaks[-1])``), ``"hold"`` (the end values held, derivatives zero) or
    ``"extend"`` (the end pieces continue)."""

    breaks: np.ndarray  # (pieces + 1,) strictly increasing [s]
    coef: np.ndarray  # (degree + 1, pieces)
    outside: str

    def derivative(self, order: int) -> np.ndarray:
        """The coefficient table of the ``order``-th derivative (same layout; zeros beyond the degree)."""
        c = np.asarray(self.coef, dtype=float)
        for _ in range(order):
            m = c.shape[0] - 1
            c = c[:-1] * np.arange(m, 0, -1)[:, None] if m > 0 else np.zeros((1, c.shape[1]))
        return c


class Signal(abc.ABC):
    """A function of time with derivatives, vectorised over time.

    Subclasses implement :meth:`evaluate`; ``max_order`` is the highest derivative they can provide (``None`` means
    any). ``name`` is used in error messages.
    """

    max_order: int | None = None
    name: str = "signal"

    @abc.abstractmethod
    def evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        """The ``order``-th derivative at times ``t`` (an array), same shape as ``t``."""

    def __call__(self, t, order: int = 0):
        if order < 0:
            raise SignalError(f"signal {self.name!r}: negative derivative order {order}")
        if self.max_order is not None and order > self.max_order:
            raise SignalError(
                f"signal {self.name!r} ({type(self).__name__}) provides derivatives up to order "
                f"{self.max_order}, but order {order} was asked for")
        return self.evaluate(np.asarray(t, dtype=float), order)

    def table(self) -> PiecewisePolynomial | None:
        """The signal as polynomial pieces, or None when it has no such form (the default)."""
        return None

    def symbolic(self, arg) -> sp.Expr | None:
        """The signal as a sympy expression of ``arg`` (its time argument), or None (the default)."""
        return None


class Constant(Signal):
    """A constant value (all derivatives zero)."""

    def __init__(self, value: float, name: str = "constant"):
        self.value = float(value)
        self.name = name

    def evaluate(self, t, order):
        return np.full_like(t, self.value if order == 0 else 0.0, dtype=float)

    def symbolic(self, arg):
        return sp.Float(self.value)


class ExpressionSignal(Signal):
    """A sympy expression of :data:`acausal.time`, evaluated numerically with exact derivatives."""

    def __init__(self, expr, name: str = "expression"):
        self.expr = strict_expr(expr, f"signal {name!r}", "a number or a sympy expression of acausal.time",
                                SignalError)
        extra = self.expr.free_symbols - {time}
        if extra:
            raise SignalError(f"signal {name!r}: expression {self.expr} depends on {sorted(map(str, extra))}, "
                              "not only on time")
        self.name = name
        self._fns = {}

    def evaluate(self, t, order):
        f = self._fns.get(order)
        if f is None:
            f = sp.lambdify(time, sp.diff(self.expr, time, order), "numpy")
            self._fns[order] = f
        return np.broadcast_to(np.asarray(f(t), dtype=float), np.shape(t)).copy()

    def symbolic(self, arg):
        return self.expr.xreplace({time: arg})


class PeriodicSpline(Signal):
    """Periodic interpolating B-spline (default quintic: derivatives 1-4 continuous, 5th piecewise constant).

    ``t`` are the sample times of one period (without the repeated end point), ``period`` the period length.
    Derivatives up to ``degree`` are available. Evaluation uses the piecewise-polynomial form with a fast path
    for scalar times (the integrator calls it once per right-hand side).
    """

    def __init__(self, t, y, period: float, degree: int = 5, name: str = "periodic spline"):
        t = np.asarray(t, dtype=float)
        y = np.asarray(y, dtype=float)
        if t.ndim != 1 or t.shape != y.shape:
            raise SignalError(f"signal {name!r}: t and y must be 1-D arrays of equal length")
        if np.any(np.diff(t) <= 0):
            raise SignalError(f"signal {name!r}: sample times must be strictly increasing")
        if not (t[-1] - t[0] < period):
            raise SignalError(f"signal {name!r}: samples span {t[-1] - t[0]} >= period {period}; "
                              "leave out the repeated end point")
        if not np.all(np.isfinite(y)):
            raise SignalError(f"signal {name!r}: non-finite sample at index {int(np.flatnonzero(~np.isfinite(y))[0])}")
        self.period = float(period)
        self.t0 = float(t[0])
        tt = np.append(t, t[0] + period)
        yy = np.append(y, y[0])
        self._spl = make_interp_spline(tt, yy, k=degree, bc_type="periodic")
        pp = PPoly.from_spline(self._spl)
        keep = (pp.x[:-1] >= tt[0]) & (pp.x[1:] <= tt[-1]) & (np.diff(pp.x) > 0)
        self._breaks = np.append(pp.x[:-1][keep], tt[-1])
        self._bl = self._breaks.tolist()
        self._table = PiecewisePolynomial(self._breaks, pp.c[:, keep], "periodic")  # highest power first
        self._coef = [self._table.derivative(order) for order in range(degree + 1)]  # each derivative's
        self._coef_lists = [cc.T.tolist() for cc in self._coef]
        self.max_order = degree
        self.name = name

    def table(self):
        return self._table

    def evaluate(self, t, order):
        if np.ndim(t) == 0:
            return np.float64(self._scalar(float(t), order))
        tau = self.t0 + np.mod(t - self.t0, self.period)
        i = np.clip(np.searchsorted(self._breaks, tau, side="right") - 1, 0, len(self._breaks) - 2)
        x = tau - self._breaks[i]
        c = self._coef[order][:, i]
        y = c[0]
        for row in c[1:]:
            y = y * x + row
        return y

    def _scalar(self, t, order):
        tau = self.t0 + (t - self.t0) % self.period
        i = bisect.bisect_right(self._bl, tau) - 1
        i = min(max(i, 0), len(self._bl) - 2)
        x = tau - self._bl[i]
        y = 0.0
        for a in self._coef_lists[order][i]:
            y = y * x + a
        return y


class SampledSignal(Signal):
    """A measured signal: linear interpolation between samples ``(t[k], y[k])``, held constant outside them.

    The first derivative is the slope of each interval (piecewise constant); higher derivatives are not defined
    (``max_order = 1``). Meant for logged inputs that a model replays (a goal position, a supply voltage, a 0/1
    enable): interpolation does not invent content between samples. Evaluation has a fast path for scalar times
    (the integrator calls it once per right-hand side).
    """

    max_order = 1

    def __init__(self, t, y, name: str = "sampled signal"):
        t = np.asarray(t, dtype=float)
        y = np.asarray(y, dtype=float)
        if t.ndim != 1 or t.shape != y.shape or t.size < 2:
            raise SignalError(f"signal {name!r}: t and y must be 1-D arrays of equal length >= 2")
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0))
            raise SignalError(f"signal {name!r}: sample times must increase strictly (sample {k + 1}: "
                              f"{t[k + 1]!r} after {t[k]!r})")
        if not np.all(np.isfinite(y)):
            raise SignalError(f"signal {name!r}: non-finite sample at index {int(np.flatnonzero(~np.isfinite(y))[0])}")
        self.name = name
        self.t, self.y = t, y
        self.slope = np.append(np.diff(y) / np.diff(t), 0.0)
        self._tl, self._yl, self._sl = t.tolist(), y.tolist(), self.slope.tolist()

    def table(self):
        return PiecewisePolynomial(self.t.copy(), np.vstack([self.slope[:-1], self.y[:-1]]), "hold")

    def evaluate(self, t, order):
        if np.ndim(t) == 0:
            return np.float64(self._scalar(float(t), order))
        if order == 0:
            return np.interp(t, self.t, self.y)
        i = np.searchsorted(self.t, t, side="right") - 1
        inside = (i >= 0) & (i < self.t.size - 1)
        return np.where(inside, self.slope[np.clip(i, 0, self.t.size - 1)], 0.0)

    def _scalar(self, t, order):
        i = bisect.bisect_right(self._tl, t) - 1
        if i < 0:
            return self._yl[0] if order == 0 else 0.0
        if i >= len(self._tl) - 1:
            return self._yl[-1] if order == 0 else 0.0
        return self._yl[i] + self._sl[i] * (t - self._tl[i]) if order == 0 else self._sl[i]


class ParametricSignal(Signal):
    """A signal that depends on run-time parameters: ``make(**values)`` builds it from the values of
    ``parameters`` (``{keyword: parameter}``, a parameter given by its sympy symbol inside ``build`` or by its
    hierarchical name). The compiled model binds it per run with that run's parameter values (defaults included,
    dependent parameters evaluated), so a parameter that shapes an input acts wherever it is set. Bound signals
    are cached by value. ``max_order``: the highest derivative the built signals provide.

    Parameter sensitivities treat the bound signal as fixed (its dependence on the parameters is not
    differentiated)."""

    def __init__(self, make, parameters: dict, name: str = "parametric signal", max_order: int | None = None):
        self.make = make
        self.parameters = {k: getattr(v, "name", v) for k, v in parameters.items()}
        self.name = name
        self.max_order = max_order
        self._bound: dict = {}

    def bind(self, values: dict) -> Signal:
        """The signal for ``values`` (parameter name -> number); every parameter it depends on must be there."""
        try:
            args = {k: values[v] for k, v in self.parameters.items()}
        except KeyError as exc:
            raise SignalError(f"signal {self.name!r} depends on parameter {exc.args[0]!r}, which the model "
                              "does not have") from None
        if any(np.ndim(a) for a in args.values()):
            raise SignalError(f"signal {self.name!r} depends on {', '.join(self.parameters.values())}: with a "
                              "batch of values for them, give the input explicitly per member")
        key = tuple(sorted((k, float(a)) for k, a in args.items()))
        if key not in self._bound:
            if len(self._bound) > 64:
                self._bound.clear()
            self._bound[key] = self.make(**{k: float(a) for k, a in args.items()})
        return self._bound[key]

    def evaluate(self, t, order):
        raise SignalError(f"signal {self.name!r} depends on run-time parameters; it is evaluated once bound "
                          "to a run's values (CompiledModel.input_tuple)")

    def __getstate__(self):
        return {**self.__dict__, "_bound": {}}


class FourierSeries(Signal):
    """``y(t) = a0 + sum_k a_k cos(k w t) + b_k sin(k w t)``, ``w = 2 pi / period``; any derivative order."""

    def __init__(self, a0: float, a, b, period: float, name: str = "Fourier series"):
        self.a0 = float(a0)
        self.a = np.asarray(a, dtype=float)
        self.b = np.asarray(b, dtype=float)
        if self.a.shape != self.b.shape:
            raise SignalError(f"signal {name!r}: cosine and sine coefficient arrays differ in length")
        self.period = float(period)
        self.name = name

    @classmethod
    def fit(cls, t, y, period: float, harmonics: int, name: str = "Fourier series") -> "FourierSeries":
        """Least-squares fit of ``harmonics`` harmonics to samples ``y(t)`` over one period."""
        t = np.asarray(t, dtype=float)
        w = 2 * np.pi / period
        k = np.arange(1, harmonics + 1)
        A = np.hstack([np.ones((t.size, 1)), np.cos(np.outer(t, k) * w), np.sin(np.outer(t, k) * w)])
        c, *_ = np.linalg.lstsq(A, np.asarray(y, dtype=float), rcond=None)
        return cls(c[0], c[1:harmonics + 1], c[harmonics + 1:], period, name=name)

    def evaluate(self, t, order):
        w = 2 * np.pi / self.period
        k = np.arange(1, self.a.size + 1)
        arg = np.multiply.outer(t, k * w)
        # d^n/dt^n cos(x) = cos(x + n pi/2), likewise sin
        scale = (k * w) ** order
        y = (np.cos(arg + order * np.pi / 2) * (self.a * scale) + np.sin(arg + order * np.pi / 2) * (self.b * scale)).sum(-1)
        return y + (self.a0 if order == 0 else 0.0)

    def symbolic(self, arg):
        w = 2 * sp.pi / sp.Float(self.period)
        return sp.Float(self.a0) + sum(sp.Float(a) * sp.cos((k + 1) * w * arg) + sp.Float(b) * sp.sin((k + 1) * w * arg)
                                       for k, (a, b) in enumerate(zip(self.a.tolist(), self.b.tolist())))


class SignalCall(sp.Function):
    """``SignalCall(token, order, time)``: the ``order``-th derivative of the numeric signal ``token``."""

    nargs = 3

    def fdiff(self, argindex=1):
        if argindex != 3:
            raise sp.ArgumentIndexError(self, argindex)
        token, order, t = self.args
        return SignalCall(token, order + 1, t)

    def _eval_is_real(self):
        return True


def as_signal_expr(value, token: str):
    """Turn a source's signal value into a sympy expression for its equations.

    Numbers and sympy expressions of time are used as they are; a :class:`Signal` becomes a :class:`SignalCall`.
    """
    if isinstance(value, Signal):
        return SignalCall(ConstantSymbol(token, real=True), sp.Integer(0), time)
    return strict_expr(value, f"input {token!r}", "a number, a sympy expression of acausal.time or a Signal",
                       SignalError)
