"""The solved equations of a compiled model as CasADi SX expressions.

The steps of a compile's lowered program (:class:`~acausal.compile.program.Program`: assignments, linear solves, Newton
blocks) are translated one sympy node at a time; shared subexpressions stay shared (the translation is memoised per
node), so the CasADi graph is as compact as the generated Python code. Numeric input signals enter through their
closed forms (:meth:`Signal.table <acausal.model.signals.Signal.table>`: polynomial pieces looked up by CasADi
interpolants with the numbers inside; :meth:`Signal.symbolic <acausal.model.signals.Signal.symbolic>`: an expression). A
Newton block becomes algebraic variables with their residuals (a DAE for IDAS). What has no CasADi form raises
:class:`Unsupported` with the reason, and the caller stays on the scipy path.
"""
from __future__ import annotations

import functools
import hashlib
import operator

import casadi as ca
import numpy as np
import sympy as sp

from ..model.signals import SignalCall
from ..compile.solve import Assign, LinearSolve
from ..model.symbols import der_name, par_symbol, time, var_symbol


class Unsupported(Exception):
    """The model (or one of its inputs) has no CasADi form; ``str(exc)`` says what."""


_UNARY = {sp.sin: ca.sin, sp.cos: ca.cos, sp.tan: ca.tan, sp.asin: ca.asin, sp.acos: ca.acos, sp.atan: ca.atan,
          sp.sinh: ca.sinh, sp.cosh: ca.cosh, sp.tanh: ca.tanh, sp.asinh: ca.asinh, sp.acosh: ca.acosh,
          sp.atanh: ca.atanh, sp.exp: ca.exp, sp.log: ca.log, sp.Abs: ca.fabs, sp.sign: ca.sign,
          sp.floor: ca.floor, sp.ceiling: ca.ceil, sp.erf: ca.erf}
_COMPARE = {sp.StrictLessThan: operator.lt, sp.LessThan: operator.le, sp.StrictGreaterThan: operator.gt,
            sp.GreaterThan: operator.ge, sp.Equality: ca.eq, sp.Unequality: ca.ne}


class Converter:
    """sympy -> CasADi SX for one graph: ``env`` maps sympy symbols to SX values; ``signal(token, order, arg)``
    returns the value of a numeric input. Every node is translated once."""

    def __init__(self, env: dict, signal):
        self.env = env
        self.signal = signal
        self._memo: dict = {}

    def __call__(self, expr):
        try:
            return self._memo[expr]
        except KeyError:
            pass
        except TypeError:  # a plain Python number
            return float(expr)
        out = self._convert(expr)
        self._memo[expr] = out
        return out

    def _convert(self, e):
        if e.is_Number or isinstance(e, sp.NumberSymbol):
            return float(e)
        if e.is_Symbol:
            try:
                return self.env[e]
            except KeyError:
                raise Unsupported(f"no value for symbol {e.name!r}") from None
        if e is sp.true or e is sp.false:
            return 1.0 if e is sp.true else 0.0
        args = e.args
        if e.is_Add:
            return functools.reduce(operator.add, [self(a) for a in args])
        if e.is_Mul:
            return functools.reduce(operator.mul, [self(a) for a in args])
        if e.is_Pow:
            base, ex = args
            b = self(base)
            if ex.is_Number:
                if ex == -1:
                    return 1.0 / b
                if ex == sp.Rational(1, 2):
                    return ca.sqrt(b)
                return ca.constpow(b, float(ex))
            return ca.power(b, self(ex))
        if isinstance(e, SignalCall):
            return self.signal(e.args[0].name, int(e.args[1]), self(e.args[2]))
        if isinstance(e, sp.Piecewise):
            out = float("nan")
            for val, cond in reversed(args):
                out = self(val) if cond is sp.true else ca.if_else(self(cond), self(val), out)
            return out
        f = _UNARY.get(e.func)
        if f is not None and len(args) == 1:
            return f(self(args[0]))
        op = _COMPARE.get(e.func)
        if op is not None:
            return op(self(args[0]), self(args[1]))
        if e.func is sp.And:
            return functools.reduce(ca.logic_and, [self(a) for a in args])
        if e.func is sp.Or:
            return functools.reduce(ca.logic_or, [self(a) for a in args])
        if e.func is sp.Not:
            return ca.logic_not(self(args[0]))
        if e.func is sp.Min:
            return functools.reduce(ca.fmin, [self(a) for a in args])
        if e.func is sp.Max:
            return functools.reduce(ca.fmax, [self(a) for a in args])
        if e.func is sp.atan2:
            return ca.atan2(self(args[0]), self(args[1]))
        if e.func is sp.Mod:
            a, b = self(args[0]), self(args[1])
            return a - b * ca.floor(a / b)
        if e.func is sp.DiracDelta:  # a step's derivative in a Jacobian: zero but at the switch (as codegen)
            return ca.DM(0.0)
        if e.func is sp.Heaviside:
            a = self(args[0])
            return ca.if_else(a > 0, 1.0, ca.if_else(a < 0, 0.0, 0.5))
        raise Unsupported(f"{e.func.__name__}(...) has no CasADi form (in {e})")


# ---------------------------------------------------------------------------------------------- signals
class Signals:
    """The numeric inputs of a model as CasADi expressions: tables become interpolant lookups with their numbers
    inside (so the right-hand side passes only the time to them), symbolic forms become expressions.

    ``layout(cm, u)`` is the key of a run's signals (kinds, table sizes and a digest of their numbers): runs with
    equal keys share one translation. A signal with neither a table nor a symbolic form raises
    :class:`Unsupported`.
    """

    def __init__(self, cm, u):
        self.names = list(cm.input_names)
        self.forms = [_form(n, sig) for n, sig in zip(self.names, u)]
        self._memo: dict = {}

    @staticmethod
    def layout(cm, u) -> tuple:
        return tuple(_form(n, sig)[:2] for n, sig in zip(cm.input_names, u))

    def __call__(self, token, order, arg):
        key = (token, order, arg)
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        k = self.names.index(token)
        form = self.forms[k]
        if form[0] == "symbolic":
            a = sp.Symbol("_arg", real=True)
            out = Converter({a: arg}, None)(sp.diff(form[1], a, order))
        else:
            out = self._table(k, order, arg)
        self._memo[key] = out
        return out

    def _table(self, k, order, arg):
        _, (n, g, outside, top, _), breaks, rows = self.forms[k]
        b0, bn = float(breaks[0]), float(breaks[-1])
        if outside == "periodic":
            span = bn - b0
            tau = arg - span * ca.floor((arg - b0) / span)
        elif outside == "hold":
            tau = ca.fmin(ca.fmax(arg, b0), bn)
        else:
            tau = arg
        lookups = self._lookups(k)
        i = ca.fmin(ca.fmax(ca.floor(lookups[0](tau)), 0), n - 1)
        row = lookups[1](i)
        x = tau - row[0]
        start = 1 + sum(g + 1 - o for o in range(order))
        y = 0.0
        for j in range(g + 1 - order if order <= g else 0):
            y = y * x + row[start + j]
        if outside == "hold" and order > 0:
            y = ca.if_else(ca.logic_and(arg >= b0, arg < bn), y, 0.0)
        return y

    def _lookups(self, k):
        """The piece index (binary search over the breaks) and the row of each piece (break, then the
        coefficients of every derivative order) of table input ``k``, as CasADi interpolants."""
        key = ("lookups", k)
        if key not in self._memo:
            _, (n, *_), breaks, rows = self.forms[k]
            index = ca.interpolant(f"pieces_{k}", "linear", [breaks.tolist()], np.arange(n + 1.0).tolist(),
                                   {"lookup_mode": ["binary"]})
            row = ca.interpolant(f"rows_{k}", "linear", [np.arange(float(n)).tolist()], rows.ravel().tolist(),
                                 {"lookup_mode": ["exact"]})
            self._memo[key] = (index, row)
        return self._memo[key]


def _form(name, sig):
    """``("table", (pieces, degree, outside, highest order, digest), breaks, rows)`` with ``rows`` of shape
    ``(pieces, m)``, or ``("symbolic", expression, None, None)``; cached on the signal (signals do not change)."""
    cache = getattr(sig, "_casadi_form", None)
    if cache is not None:
        return cache
    table = sig.table()
    if table is not None:
        breaks = np.asarray(table.breaks, dtype=float)
        coef = np.asarray(table.coef, dtype=float)
        g, n = coef.shape[0] - 1, coef.shape[1]
        top = g if sig.max_order is None else min(g, sig.max_order)
        per_piece = [breaks[:-1][None, :]] + [table.derivative(o)[: g + 1 - o] for o in range(top + 1)]
        rows = np.ascontiguousarray(np.vstack(per_piece).T)  # (pieces, m)
        digest = hashlib.sha1(breaks.tobytes() + rows.tobytes()).hexdigest()
        form = ("table", (n, g, table.outside, top, digest), breaks, rows)
    else:
        a = sp.Symbol("_arg", real=True)
        expr = sig.symbolic(a)
        if expr is None:
            raise Unsupported(f"input {name!r} is a {type(sig).__name__} ({sig.name!r}) with neither a table nor a "
                              "symbolic form (Signal.table / Signal.symbolic)")
        form = ("symbolic", expr, None, None)
    try:
        sig._casadi_form = form
    except AttributeError:
        pass
    return form


# ---------------------------------------------------------------------------------------------- steps
def translate(cm, exprs, signals: Signals, t, x, p, d, given: dict | None = None, algebraic: list | None = None):
    """CasADi values of the sympy expressions ``exprs`` (in the variables, parameters, modes and time of ``cm``) at
    SX time ``t``, states ``x``, parameters ``p`` and modes ``d``: the steps they need are translated in order.

    A Newton block has no closed form: with ``algebraic`` (a list), its tear variables become new SX symbols and
    ``(names, symbols, residuals)`` is appended, so that the caller integrates them as the algebraic variables of
    a DAE (IDAS); without it the block raises :class:`Unsupported`. ``given`` maps variable symbols to values
    already known (those algebraic variables, when translating more expressions of the same model)."""
    program = cm.program
    env = {time: t}
    for i, n in enumerate(program.states):
        env[var_symbol(n)] = x[i]
    for i, n in enumerate(program.params):
        env[par_symbol(n)] = p[i]
    for i, n in enumerate(program.discretes):
        env[par_symbol(n)] = d[i]
    env.update(given or {})
    conv = Converter(env, signals)
    exprs = [sp.sympify(e) for e in exprs]
    for k in program.slice({s for e in exprs for s in e.free_symbols}):
        st = program.steps[k]
        if isinstance(st, Assign):
            env[var_symbol(st.var)] = conv(st.expr)
        elif isinstance(st, LinearSolve):
            A = ca.vertcat(*[ca.horzcat(*[conv(e) for e in row]) for row in st.A])
            y = ca.solve(A, ca.vertcat(*[conv(e) for e in st.b]))
            for i, v in enumerate(st.vars):
                env[var_symbol(v)] = y[i]
        elif all(var_symbol(v) in env for v in st.vars):
            continue
        elif st.split:
            raise Unsupported(f"the block of {', '.join(map(repr, st.vars))} may leave them undetermined (friction "
                              "elements stuck together): its weighted least-norm solve runs in Python")
        elif algebraic is not None:
            zs = [ca.SX.sym(f"z{len(algebraic)}_{i}") for i in range(len(st.vars))]
            for v, z in zip(st.vars, zs):
                env[var_symbol(v)] = z
            algebraic.append((list(st.vars), zs, [conv(r) for r in st.residuals]))
        else:
            raise Unsupported(f"the nonlinear block of {', '.join(map(repr, st.vars))} is solved by Newton's method "
                              "in Python")
    return [conv(e) for e in exprs]


def variational(cm, f, x, p, wrt, bindings):
    """``(S, dS)``: the sensitivity states ``S`` (``n q`` symbols, CasADi's column order) and their rates
    ``dS/dt = f_x S + f_p B`` for the state rates ``f`` of ``cm`` in the SX states ``x`` and parameters ``p``,
    ``B`` the derivatives of the parameters with respect to ``wrt`` through their ``bindings``
    (:func:`acausal.compile.parameters.binding_totals`)."""
    from ..compile.parameters import binding_totals
    n, q = x.numel(), len(wrt)
    conv = Converter({par_symbol(nm): p[i] for i, nm in enumerate(cm.param_names)}, None)
    B = ca.SX.zeros(len(cm.param_names), q)
    for name, col in binding_totals(cm.param_names, wrt, bindings or {}).items():
        for j, e in col.items():
            B[cm.param_index(name), j] = conv(e)
    S = ca.SX.sym("S", n * q)
    return S, ca.vec(ca.mtimes(ca.jacobian(f, x), ca.reshape(S, n, q)) + ca.mtimes(ca.jacobian(f, p), B))


def state_derivatives(cm):
    """The symbols of the state derivatives of ``cm``, in state order."""
    return [var_symbol(der_name(s)) for s in cm.state_names]
