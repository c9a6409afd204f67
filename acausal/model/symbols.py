"""Symbols of the equation system: time, variables, parameters, discrete modes and time derivatives.

Variables and parameters are plain sympy symbols whose names are hierarchical paths ("motor.R.i"). The time
derivative of a variable ``x`` is the symbol named ``der(x)``, of that ``der(der(x))`` and so on; :func:`der`
applies the chain rule to any expression, so ``der(J*w)`` is ``J*der(w)`` when ``J`` is a parameter.

What kind a symbol is (variable, parameter, discrete) is recorded in a :class:`SymbolTable` owned by the flattened
model, never in global state. Before flattening, :func:`der` needs only the names: every symbol that is not time
and not a known parameter/discrete is differentiated as a variable.
"""
from __future__ import annotations

import re

import sympy as sp

from ..errors import ModelError

#: The independent variable, time [s].
time = sp.Symbol("time", real=True)


def Eq(lhs, rhs=0) -> sp.Equality:
    """The equation ``lhs = rhs`` as a component writes it (``sympy.Equality``), left as written: sympy's ``Eq``
    first tries to decide whether the two sides are equal, which costs more than building the expressions (a
    fifth of flattening the paper's actuator). An equation that holds identically or never is reported when the
    model is flattened, naming its component."""
    return sp.Equality(lhs, rhs, evaluate=False)


_DER = re.compile(r"^der\((.*)\)$")


def der_name(name: str, order: int = 1) -> str:
    for _ in range(order):
        name = f"der({name})"
    return name


def split_der(name: str) -> tuple[str, int]:
    """``"der(der(x))" -> ("x", 2)``."""
    order = 0
    m = _DER.match(name)
    while m:
        order += 1
        name = m.group(1)
        m = _DER.match(name)
    return name, order


def var_symbol(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


class ConstantSymbol(sp.Symbol):
    """A symbol that is constant in time: a parameter or a discrete (piecewise-constant) mode.

    Marking the class lets :func:`der` treat it as constant without any table lookup.
    """


def par_symbol(name: str) -> sp.Symbol:
    return ConstantSymbol(name, real=True)


def is_constant_symbol(s) -> bool:
    return isinstance(s, ConstantSymbol)


def strict_expr(value, who: str, wanted: str, error=ModelError):
    """``value`` as a sympy expression (numbers and sympy objects as they are), never by parsing text: sympify
    would run a string as Python code. ``error`` (naming ``who`` and what is ``wanted``) otherwise."""
    if isinstance(value, str):
        raise error(f"{who}: give {wanted}; got the string {value!r} (text is not parsed: it would be executed as "
                    "code)")
    try:
        return sp.sympify(value, strict=True)
    except sp.SympifyError:
        raise error(f"{who}: {value!r} ({type(value).__name__}) is not {wanted}") from None


def der(expr, order: int = 1):
    """Total time derivative of ``expr`` (chain rule over its variables; parameters are constant).

    ``der(x)`` for a variable symbol ``x`` is the symbol ``der(x)``. Prescribed signals (sympy functions of
    ``time``) differentiate through sympy; see :mod:`acausal.model.signals`.
    """
    if not isinstance(expr, sp.Basic):  # (a sympy expression needs no check: its repr cost a tenth of a compile)
        expr = strict_expr(expr, f"der({expr!r})", "a variable or a sympy expression of variables (self.x, not 'x')")
    for _ in range(order):
        expr = _der1(expr)
    return expr


def _der1(expr):
    if isinstance(expr, sp.Symbol):
        if expr == time:
            return sp.Integer(1)
        if is_constant_symbol(expr):
            return sp.Integer(0)
        return var_symbol(der_name(expr.name))
    out = sp.diff(expr, time) if expr.has(time) else sp.Integer(0)
    for s in sorted(expr.free_symbols, key=lambda s: s.name):
        if s == time or is_constant_symbol(s):
            continue
        d = sp.diff(expr, s)
        if d != 0:
            out += d * var_symbol(der_name(s.name))
    return out
