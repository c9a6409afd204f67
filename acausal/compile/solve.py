"""Solve BLT blocks symbolically where sympy can, numerically where it cannot.

* one equation, linear in its unknown: explicit assignment ``y = -r(0) / (dr/dy)``;
* one nonlinear equation with a single closed-form sympy solution: that solution;
* a block of several equations is torn (see :func:`_tear`): a linear block usually becomes explicit
  assignments; what cannot be torn is solved by sympy LU (linear, up to :data:`SYMBOLIC_LINEAR_MAX` unknowns),
  a numeric linear solve ``A y = b`` at run time (larger linear), or damped Newton with the exact sympy
  Jacobian of the torn residuals (nonlinear; :func:`acausal.backends.numpy.runtime.newton`).

A coefficient that depends on discrete modes and vanishes for some of their values (:func:`_may_vanish`) is never
a pivot: the unknown is left to the block's numeric solve, which pivots on the values of the present mode. So an
element whose equations determine a variable from one equation in one mode and from another in the other (a
friction element's path parameter, stuck or sliding) compiles to code without inf or NaN in either mode.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sp

from ..errors import ModelError
from .structure import EquationSystem
from ..model.symbols import par_symbol, var_symbol

SYMBOLIC_LINEAR_MAX = 3


@dataclass
class Assign:
    var: str
    expr: sp.Expr


@dataclass
class LinearSolve:
    vars: list
    A: list  # rows of expressions
    b: list
    origins: list  # the components of every equation of the block (the torn ones too), as error messages name them


@dataclass
class NewtonSolve:
    vars: list  # tear variables iterated by Newton
    residuals: list
    jac: list
    origins: list  # the components of every equation of the block (eliminated ones are inside the residuals)
    guesses: list  # start values of the tear variables: Newton starts from them unless its caller gives others
    # per tear variable, (nominal, scale) of an Indeterminate the block may leave free, or None: where the Jacobian
    # is singular, the solution minimising sum((y - nominal)**2 / scale) over them
    # (acausal.backends.numpy.runtime.newton)
    split: list | None = None


def solve_blocks(system: EquationSystem, starts: dict, modes=(), indeterminates=None) -> EquationSystem:
    """``system`` (after BLT) with its ``steps``: every block solved, in evaluation order. ``starts`` (variable
    name -> start value) seeds Newton's method where a block needs it. ``modes``: the names of the discrete
    modes; a coefficient that vanishes for some mode values (``1 - stuck``) is never divided by (see
    :func:`_may_vanish`). ``indeterminates``: variable name -> ``(nominal, scale, origin)``
    (:class:`~acausal.model.components.Indeterminate`); a block with two or more of them may leave them free in some
    mode: they stay its tear variables and it is solved by Newton with their rule (:attr:`NewtonSolve.split`)."""
    steps, solved = [], set()
    ms = frozenset(par_symbol(m) for m in modes)
    indeterminates = indeterminates or {}
    for eqs, unknowns in system.blocks:
        ys = [var_symbol(u) for u in unknowns]
        rs = [system.residuals[e] for e in eqs]
        orig = [system.origins[e] for e in eqs]
        free = {u: indeterminates[u] for u in unknowns if u in indeterminates}
        if len(eqs) == 1:
            steps.extend(_solve_scalar(rs[0], ys[0], unknowns[0], orig, starts, ms))
        elif len(free) >= 2:
            block = _tear(rs, ys, unknowns, orig, starts, ms, free)
            _check_split_inputs(block[0], free, set(system.unknowns) - solved - set(unknowns))
            steps.extend(block)
        else:
            steps.extend(_tear(rs, ys, unknowns, orig, starts, ms))
        solved.update(unknowns)
    return replace(system, steps=steps)


def _check_split_inputs(head, free, later):
    """The rules of a split block's indeterminate variables (``head``, its :class:`NewtonSolve`) use only what is
    known when the block is solved (``later``: the unknowns solved after it); ModelError naming the component
    otherwise."""
    for name, rule in zip(head.vars, head.split):
        late = sorted(s.name for e in (rule or ()) for s in e.free_symbols if s.name in later)
        if late:
            raise ModelError(f"{free[name][2]}: the rule of Indeterminate({name!r}) uses {', '.join(late)}, which "
                             "the model computes only after the block that solves it; write the rule with what the "
                             "block's equations use")


MODE_VALUES = (0, 1)  # the values a mode is checked at (the library's modes are flags)
_MAX_MODE_COMBINATIONS = 64


def _may_vanish(a, modes: frozenset) -> bool:
    """Whether coefficient ``a`` depends on the discrete modes ``modes`` (their symbols) and is zero for some of their
    values (each mode at :data:`MODE_VALUES`; a coefficient with more modes than :data:`_MAX_MODE_COMBINATIONS`
    combinations counts as vanishing). Dividing by it would give inf or NaN in that mode: e.g. a friction element's ``a
    = (1 - stuck) sa`` determines ``sa`` only while sliding, ``tau = stuck sa + ...`` only while stuck."""
    ms = sorted(a.free_symbols & modes, key=lambda s: s.name)
    if not ms:
        return False
    if len(MODE_VALUES) ** len(ms) > _MAX_MODE_COMBINATIONS:
        return True
    from itertools import product
    for values in product(MODE_VALUES, repeat=len(ms)):
        v = a.xreplace(dict(zip(ms, values)))
        if v == 0 or (v.is_number and v.is_zero):
            return True
    return False


def _solve_scalar(r, y, name, orig, starts, modes=frozenset()):
    a = r.diff(y)
    if a != 0 and y not in a.free_symbols and not _may_vanish(a, modes):
        return [Assign(name, -r.xreplace({y: 0}) / a)]
    if sp.count_ops(r) <= 40:
        try:
            sols = sp.solve(r, y, dict=False)
        except (NotImplementedError, ValueError, TypeError):  # sympy finds no closed form: Newton's method below
            sols = []
        real = [s for s in sols if not s.has(sp.I)]
        if len(real) == 1:
            return [Assign(name, _real_roots(real[0]))]
    return [NewtonSolve([name], [r], [[a]], orig, [starts.get(name, 0.0)])]


def _real_roots(expr):
    """``expr`` with every odd root of a base that may be negative taken as the real root:
    ``x**(p/q)`` (q odd) -> ``|x|**(p/q)``, negated where ``x < 0`` for odd ``p`` (a Piecewise, so that it
    differentiates without the derivative of ``sign``). sympy's solution of ``v = a i**3`` is the principal cube
    root ``(v/a)**(1/3)``, which is complex (NaN in numpy) for negative ``v/a``; the real root is the solution of
    the real equation."""
    def odd_root(e):
        return (e.is_Pow and e.exp.is_Rational and not e.exp.is_Integer and e.exp.q % 2 == 1
                and not e.base.is_nonnegative)

    def real(e):
        mag = sp.Abs(e.base) ** e.exp
        return mag if e.exp.p % 2 == 0 else sp.Piecewise((-mag, e.base < 0), (mag, True))
    return expr.replace(odd_root, real)


def _pivot_score(a):
    if a == 1 or a == -1:
        return 0
    if a.is_number:
        return 1
    return 2 + len(a.free_symbols)


def _tear(rs, ys, unknowns, orig, starts, modes=frozenset(), free=None):
    """Tearing: repeatedly eliminate the unknown that some block equation gives linearly with a coefficient free
    of block unknowns (cheapest pivot first: +-1, then numbers, then the fewest symbols; among equal pivots the
    equation with the fewest block unknowns left, so the order of the block's unknowns does not decide),
    substituting it into the other equations. A linear block is solved this way entirely. What remains (the tear
    variables) is solved by sympy LU (linear, small), a numeric linear solve (linear, large) or Newton (nonlinear); the
    eliminated unknowns then follow explicitly.

    ``free`` (name -> ``(nominal, scale, origin)``): indeterminate unknowns; they are never eliminated, and the
    block becomes a :class:`NewtonSolve` whose ``split`` carries their rule in the tear variables (the eliminated
    unknowns substituted), so that the run-time solve can pick the weighted least-norm solution where they are
    free."""
    cur = list(rs)
    eqs = list(range(len(rs)))
    vars_ = list(range(len(ys)))
    yset = set(ys)
    elim = []
    free = free or {}
    rules = {u: [sp.sympify(nominal), sp.sympify(scale)] for u, (nominal, scale, _) in free.items()}
    while vars_:
        best = None
        left = {ys[v] for v in vars_}
        for e in eqs:
            width = len(cur[e].free_symbols & left)  # block unknowns still in the equation
            for v in vars_:
                if unknowns[v] in free:
                    continue
                a = cur[e].diff(ys[v])
                if a == 0 or (a.free_symbols & yset) or _may_vanish(a, modes):
                    continue
                score = (_pivot_score(a), width)
                if best is None or score < best[0]:
                    best = (score, e, v, a)
                    if score == (0, 1):
                        break
            if best is not None and best[0] == (0, 1):
                break
        if best is None:
            break
        _, e, v, a = best
        expr = -cur[e].xreplace({ys[v]: 0}) / a
        elim.append(Assign(unknowns[v], expr))
        eqs.remove(e)
        vars_.remove(v)
        for e2 in eqs:
            cur[e2] = cur[e2].xreplace({ys[v]: expr})
        for rule in rules.values():
            rule[:] = [x.xreplace({ys[v]: expr}) for x in rule]
    if not vars_:
        return list(reversed(elim))
    tear = [unknowns[v] for v in vars_]
    tsyms = [ys[v] for v in vars_]
    res = [cur[e] for e in eqs]
    jac = [[r.diff(y) for y in tsyms] for r in res]
    tset = set(tsyms)
    if free:
        split = [tuple(rules[u]) if u in rules else None for u in tear]
        return [NewtonSolve(tear, res, jac, list(orig), [starts.get(u, 0.0) for u in tear], split)] \
            + list(reversed(elim))
    if all(not (j.free_symbols & tset) for row in jac for j in row):
        zero = {y: 0 for y in tsyms}
        b = [-r.xreplace(zero) for r in res]
        sol = sp.Matrix(jac).LUsolve(sp.Matrix(b)) if len(tear) <= SYMBOLIC_LINEAR_MAX else None
        if sol is not None and not any(_may_vanish(sp.fraction(sp.together(x))[1], modes) for x in sol):
            head = [Assign(u, sol[i]) for i, u in enumerate(tear)]
        else:  # large, or sympy's LU divides by a pivot that is zero in some mode: numpy pivots per sample
            head = [LinearSolve(tear, jac, b, list(orig))]
    else:
        head = [NewtonSolve(tear, res, jac, list(orig), [starts.get(u, 0.0) for u in tear])]
    return head + list(reversed(elim))


def step_vars(st) -> list:
    """The variables a solved step defines."""
    if isinstance(st, Assign):
        return [st.var]
    return list(st.vars)


def step_exprs(st) -> list:
    """The expressions a solved step evaluates (what it depends on)."""
    if isinstance(st, Assign):
        return [st.expr]
    if isinstance(st, LinearSolve):
        return [e for row in st.A for e in row] + list(st.b)
    if isinstance(st, NewtonSolve):
        return (list(st.residuals) + [e for row in st.jac for e in row]
                + [e for rule in (st.split or ()) if rule for e in rule])
    return []
