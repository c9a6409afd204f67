"""Alias elimination: ``a = b``, ``a = -b`` and ``a = constant`` are removed before structural analysis.

Every eliminated variable stays answerable by name: :attr:`FlatModel.aliases` maps it to ``±representative`` or
to its constant (an expression of parameters). Equations that become ``0 = 0`` are dropped; one that becomes
``0 = c`` with ``c != 0`` is an inconsistency and is reported with its origin. The representative of an alias
class is chosen deterministically: a variable with a fixed start first, then the strongest ``state_select``,
then a component variable over a connector variable, then the shorter path, then the name.
"""
from __future__ import annotations

import sympy as sp

from ..errors import ModelError, StructureError
from .flatten import FlatModel
from ..model.signals import SignalCall
from ..model.symbols import der, is_constant_symbol, split_der, var_symbol


def _var_term(term, varnames):
    """``c * x`` with x a base (non-derivative) variable -> (c, name), else None."""
    c, rest = term.as_coeff_Mul()
    if isinstance(rest, sp.Symbol) and rest.name in varnames and split_der(rest.name)[1] == 0 and c != 0:
        return c, rest.name
    return None


def _is_constant(expr, varnames):
    """Constant in time: only parameters (no variables, derivatives, signals or time)."""
    if expr.has(SignalCall):
        return False
    return all(is_constant_symbol(s) for s in expr.free_symbols)


def _pattern(res, varnames):
    t = _var_term(res, varnames)
    if t is not None:
        return ("const", t[1], sp.Integer(0))
    if isinstance(res, sp.Add):
        args = res.args
        if len(args) == 2:
            t0, t1 = _var_term(args[0], varnames), _var_term(args[1], varnames)
            if t0 and t1 and abs(t0[0]) == abs(t1[0]) and t0[1] != t1[1]:
                return ("alias", t0[1], t1[1], -t1[0] / t0[0])
        var_terms = [(a, _var_term(a, varnames)) for a in args]
        vt = [(a, t) for a, t in var_terms if t is not None]
        if len(vt) == 1:
            a, (c, name) = vt[0]
            rest = res - a
            if _is_constant(rest, varnames):
                return ("const", name, -rest / c)
    return None


def eliminate_aliases(flat: FlatModel) -> None:
    variables = flat.variables
    info = {n: v for n, v in variables.items()}

    def pref(n):
        v = info[n]
        return (not v.fixed, -v.state_select, v.kind != "variable", n.count("."), len(n), n)

    root: dict[str, tuple[str, int]] = {}  # name -> (parent, sign)
    const: dict[str, sp.Expr] = {}  # root name -> constant value of the class

    def find(n):
        sign = 1
        path = []
        while n in root:
            p, s = root[n]
            path.append((n, sign))
            sign *= s
            n = p
        for m, sm in path:  # compress
            root[m] = (n, sign * sm)
        return n, sign

    changed = True
    while changed:
        changed = False
        varnames = set(variables)
        kept = []
        subs = {}
        for eq in flat.equations:
            pat = _pattern(eq.residual, varnames)
            if pat is None:
                kept.append(eq)
                continue
            if pat[0] == "alias":
                _, a, b, sign = pat
                ra, sa = find(a)
                rb, sb = find(b)
                if ra == rb or (ra in const and rb in const):
                    kept.append(eq)  # redundant or conflicting: leave it to the structural check
                    continue
                # a = sign * b  ->  sa*Ra = sign*sb*Rb
                s = int(sign * sa * sb)
                if pref(rb) <= pref(ra):
                    _merge(root, const, info, ra, rb, s, eq.origin)
                else:
                    _merge(root, const, info, rb, ra, s, eq.origin)
            else:
                _, a, value = pat
                ra, sa = find(a)
                if ra in const:
                    kept.append(eq)
                    continue
                v = info[ra]
                cval = value * sa
                if v.fixed and cval.is_number and abs(float(cval) - v.start) > 1e-12 * (1 + abs(v.start)):
                    raise ModelError(f"variable {ra!r} has a fixed start {v.start} but {eq.origin} makes it "
                                     f"constant {cval}")
                const[ra] = cval
            changed = True
        if not changed:
            break
        # substitution: every eliminated name -> sign * root (or constant)
        for n in list(variables):
            if n in root or n in const:
                r, s = find(n)
                subs[n] = s * const[r] if r in const else s * var_symbol(r)
                if r in const and info[n].fixed:  # kept, and checked at initialisation, also when the
                    flat.fixed_constants[n] = info[n].start  # constant is an expression of parameters
        flat.equations = _substitute(kept, subs, variables)
        for n, expr in subs.items():
            flat.aliases[n] = expr
        for n in subs:
            eliminated = variables.pop(n, None)
            if eliminated is not None:  # its unit and doc stay known (results, reports)
                flat.alias_info[n] = eliminated
        root_names = [n for n in list(root)]
        for n in root_names:
            root.pop(n)
        const.clear()
    # aliases may point at names that were later eliminated themselves: resolve to kept variables
    _resolve_aliases(flat)


def _merge(root, const, info, child, parent, sign, origin):
    """Class ``child`` joins ``parent``: child = sign * parent."""
    vc, vp = info[child], info[parent]
    if child in const:
        const[parent] = const.pop(child) * sign
    if vc.fixed:
        want = vc.start * sign
        if vp.fixed and abs(vp.start - want) > 1e-12 * (1 + abs(want)):
            raise ModelError(f"conflicting fixed start values: {child!r} = {vc.start} and {parent!r} = "
                             f"{vp.start}, but {origin} makes {child} = {'-' if sign < 0 else ''}{parent}")
        vp.start, vp.fixed, vp.start_given = want, True, True
    elif vc.start_given and not vp.start_given:
        vp.start, vp.start_given = vc.start * sign, True
    vp.state_select = max(vp.state_select, vc.state_select)
    root[child] = (parent, sign)


def _substitute(eqs, subs, variables):
    # derivatives of eliminated variables follow their representative
    full = {}
    der_present = set()
    for eq in eqs:
        for s in eq.residual.free_symbols:
            base, order = split_der(s.name)
            if order and base in subs:
                der_present.add((s.name, base, order))
    for name, value in subs.items():
        full[var_symbol(name)] = value
    for dname, base, order in der_present:
        full[var_symbol(dname)] = der(subs[base], order)
    out = []
    for eq in eqs:
        r = eq.residual.xreplace(full) if full else eq.residual
        if r == 0:
            continue
        if r.is_number:
            raise StructureError(f"inconsistent equation from {eq.origin}: after eliminating aliases it reads "
                                 f"0 = {-r}")
        eq.residual = r
        out.append(eq)
    return out


def _resolve_aliases(flat: FlatModel):
    for _ in range(len(flat.aliases) + 1):
        changed = False
        for n, expr in flat.aliases.items():
            syms = {s: flat.aliases[s.name] for s in expr.free_symbols if s.name in flat.aliases}
            if syms:
                flat.aliases[n] = expr.xreplace(syms)
                changed = True
        if not changed:
            return
