"""Pantelides index reduction and dummy-derivative state selection.

Pantelides (1988): equations whose highest-derivative unknowns cannot be matched are differentiated (and with
them the variables on the augmenting path get a new derivative) until every equation is matched to a
highest-derivative unknown. Mattsson & Soederlind (1993), dummy derivatives: going down the levels of
differentiated equations, for each level pick as many variables as there are differentiated equations such that
their block is structurally nonsingular; the derivatives of the picked variables become algebraic ("dummy")
unknowns. What remains differentiated and not dummy are the states.

Which variables are picked follows ``state_select`` (variables marked "avoid" become dummies first, "prefer" last)
and then their names, so the same model always gives the same states.
"""
from __future__ import annotations

from dataclasses import replace

from ...errors import StructureError
from ...model.symbols import der, der_name, split_der
from .system import EquationSystem


def reduce_index(system: EquationSystem) -> EquationSystem:
    """Run Pantelides and the dummy-derivative selection on ``system`` (the equations of the model, see
    :meth:`EquationSystem.from_flat`); returns a new system with the differentiated equations appended and
    ``eq_pred``, ``variables``, ``var_diff``, ``states``, ``dummies`` and ``differentiations`` filled in.
    Preferences for states come from ``system.state_select``."""
    residuals = list(system.residuals)
    origins = list(system.origins)
    eq_vars = list(system.eq_vars)
    variables = set(system.variables)
    var_diff = dict(system.var_diff)
    eq_pred: list = list(system.eq_pred)
    eq_diff: list = [None] * len(residuals)
    assign: dict = {}  # variable -> equation

    def highest(v):
        return v not in var_diff

    n_orig = len(residuals)
    for k0 in range(n_orig):
        k = k0
        for _guard in range(50):
            colored_e, colored_v = set(), set()
            if _augment(k, eq_vars, assign, highest, colored_e, colored_v):
                break
            if not eq_vars[k]:
                raise StructureError(
                    f"structurally singular: equation from {origins[k]} ({residuals[k]} = 0) has no unknown "
                    "left to determine")
            for v in sorted(colored_v):
                d = der_name(v)
                var_diff[v] = d
                variables.add(d)
            for e in sorted(colored_e):
                dr = der(residuals[e])
                residuals.append(dr)
                origins.append(f"d/dt of {origins[e]}")
                eq_pred.append(e)
                eq_diff.append(None)
                eq_diff[e] = len(residuals) - 1
                vs = system.incidence(dr)
                eq_vars.append(vs)
                variables |= vs
                for v in vs:
                    if der_name(v) in variables:
                        var_diff[v] = der_name(v)
            for v in sorted(colored_v):
                if v in assign:
                    assign[var_diff[v]] = eq_diff[assign[v]]
            k = eq_diff[k]
        else:
            raise StructureError(f"index reduction did not converge for the equation from {origins[k0]}: "
                                 "the model is structurally singular (an equation with no unknown that any "
                                 "number of differentiations could determine)")
    # recompute var_diff over everything that now occurs
    for v in list(variables):
        if der_name(v) in variables:
            var_diff[v] = der_name(v)
    var_pred = {d: v for v, d in var_diff.items()}
    dummies = _dummy_derivatives(eq_pred, eq_diff, eq_vars, variables, var_diff, var_pred, system.preference,
                                 origins)
    states = sorted(v for v, d in var_diff.items() if d not in dummies)
    depth = 0
    for k in range(len(residuals)):
        n, e = 0, k
        while eq_pred[e] is not None:
            n, e = n + 1, eq_pred[e]
        depth = max(depth, n)
    return replace(system, residuals=residuals, origins=origins, eq_pred=eq_pred, eq_vars=eq_vars,
                   variables=sorted(variables), var_diff=var_diff, states=states, dummies=dummies,
                   differentiations=depth)


def _augment(i, eq_vars, assign, highest, colored_e, colored_v) -> bool:
    colored_e.add(i)
    cands = sorted(v for v in eq_vars[i] if highest(v))
    for v in cands:
        if v not in assign:
            assign[v] = i
            return True
    for v in cands:
        if v not in colored_v:
            colored_v.add(v)
            if _augment(assign[v], eq_vars, assign, highest, colored_e, colored_v):
                assign[v] = i
                return True
    return False


def _dummy_derivatives(eq_pred, eq_diff, eq_vars, variables, var_diff, var_pred, state_select, origins) -> set:
    dummies = set()
    G = [e for e in range(len(eq_pred)) if eq_pred[e] is not None and eq_diff[e] is None]
    Z = [v for v in variables if v not in var_diff and v in var_pred]
    while G:
        Gp = sorted({eq_pred[e] for e in G})
        Zp = sorted({var_pred[z] for z in Z})
        chosen = _select_columns(Gp, Zp, eq_vars, state_select, origins)
        for v in chosen:
            dummies.add(var_diff[v])
        G = [e for e in Gp if eq_pred[e] is not None]
        Z = [v for v in chosen if v in var_pred]
    return dummies


def _select_columns(rows, cands, eq_vars, state_select, origins):
    """Pick len(rows) candidates with a structurally nonsingular block, least-preferred states first.

    Greedy over the candidates in preference order: a candidate is kept when it enlarges the maximum matching.
    Transversal matroids make this greedy choice optimal for the order.
    """
    def key(v):
        base, order = split_der(v)
        return (state_select(base), -order, v)

    order = sorted(cands, key=key)
    chosen: list = []
    assign: dict = {}  # var -> row
    row_set = set(rows)
    for v in order:
        if len(chosen) == len(rows):
            break
        rows_of_v = [r for r in rows if v in eq_vars[r]]
        if not rows_of_v:
            continue
        # try to find an augmenting path starting at v
        if _aug_from_var(v, rows_of_v, eq_vars, assign, set(), row_set, set(chosen)):
            chosen.append(v)
    if len(chosen) < len(rows):
        missing = [origins[r] for r in rows if r not in assign.values()]
        raise StructureError("dummy derivative selection failed: the differentiated equations of "
                             f"{sorted(set(missing))} have no nonsingular choice of dummy derivatives among "
                             f"{cands}")
    return chosen


def _aug_from_var(v, rows_of_v, eq_vars, assign, seen_rows, row_set, chosen):
    row_owner = {r: w for w, r in assign.items()}
    for r in rows_of_v:
        if r in seen_rows:
            continue
        seen_rows.add(r)
        if r not in row_owner:
            assign[v] = r
            return True
        w = row_owner[r]
        w_rows = [rr for rr in row_set if w in eq_vars[rr]]
        if _aug_from_var(w, w_rows, eq_vars, assign, seen_rows, row_set, chosen):
            assign[v] = r
            return True
    return False


