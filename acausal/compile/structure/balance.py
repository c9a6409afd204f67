"""Balance check: as many equations as unknowns, and a complete matching between them.

Before index reduction every variable ``x`` and its derivatives ``der(x)`` count as one unknown. A mismatch is
reported with the culprits found by the Dulmage-Mendelsohn decomposition of a maximum matching: the equations
(and their components) of the over-determined part, or the variables (and their components) that no equation
determines.
"""
from __future__ import annotations

import networkx as nx

from ...errors import StructureError
from ...model.symbols import split_der
from .system import EquationSystem


def max_matching(eq_vars: list[set], unknowns: list[str]) -> dict:
    """Maximum bipartite matching (Hopcroft-Karp); returns {eq index: unknown name}.

    The graph's nodes are integers (equation ``k`` is ``k``, unknown ``i`` is ``len(eq_vars) + i``): networkx
    keeps them in sets, and integers, unlike strings, hash the same in every process, so the same system always
    gets the same matching (and so the same blocks, tearing and generated code)."""
    n_eq = len(eq_vars)
    var_node = {u: n_eq + i for i, u in enumerate(unknowns)}
    g = nx.Graph()
    g.add_nodes_from(range(n_eq), bipartite=0)
    g.add_nodes_from(var_node.values(), bipartite=1)
    for k, vs in enumerate(eq_vars):
        for v in sorted(vs):
            if v in var_node:
                g.add_edge(k, var_node[v])
    m = nx.bipartite.hopcroft_karp_matching(g, top_nodes=range(n_eq))
    return {k: unknowns[m[k] - n_eq] for k in range(n_eq) if k in m}


def _alternating_reach(start_nodes, eq_vars, match_e2v, from_equations: bool):
    """Nodes reachable by alternating paths from unmatched equations (or unmatched variables)."""
    match_v2e = {v: e for e, v in match_e2v.items()}
    var_eqs: dict[str, list[int]] = {}
    for k, vs in enumerate(eq_vars):
        for v in vs:
            var_eqs.setdefault(v, []).append(k)
    eqs, vars_ = set(), set()
    stack = list(start_nodes)
    while stack:
        node = stack.pop()
        if from_equations:
            if node in eqs:
                continue
            eqs.add(node)
            for v in eq_vars[node]:
                if v not in vars_:
                    vars_.add(v)
                    if v in match_v2e:
                        stack.append(match_v2e[v])
        else:
            if node in vars_:
                continue
            vars_.add(node)
            for e in var_eqs.get(node, []):
                if e not in eqs:
                    eqs.add(e)
                    if e in match_e2v:
                        stack.append(match_e2v[e])
    return eqs, vars_


def check_balance(system: EquationSystem) -> EquationSystem:
    """Return ``system`` if it is balanced and matchable; otherwise raise :class:`StructureError` naming the
    culprits: the components of the over-determined equations, or the unknowns (and their components) no
    equation determines, quoting an equation left without any unknown (e.g. two sources fixing one voltage).
    Every variable counts together with its derivatives."""
    eq_vars, origins, variables, residuals = system.eq_vars, system.origins, system.base, system.residuals
    base_eq_vars = [{split_der(v)[0] for v in vs} for vs in eq_vars]
    n_eq, n_var = len(eq_vars), len(variables)
    match = max_matching(base_eq_vars, variables)
    if len(match) == n_eq == n_var:
        return system
    unmatched_eqs = [k for k in range(n_eq) if k not in match]
    matched_vars = set(match.values())
    unmatched_vars = [v for v in variables if v not in matched_vars]
    lines = [f"the model has {n_eq} equations for {n_var} unknowns"]
    if unmatched_vars:
        _, vs = _alternating_reach(unmatched_vars, base_eq_vars, match, from_equations=False)
        vs = sorted(vs)
        comps = sorted({system.owner(v) for v in vs})
        lines.append(f"under-determined: no equation is left for {_fmt(unmatched_vars)}; the unknowns "
                     f"{_fmt(vs)} of {_fmt(comps)} lack {len(unmatched_vars)} equation(s)")
    if unmatched_eqs:
        es, vs = _alternating_reach(unmatched_eqs, base_eq_vars, match, from_equations=True)
        comps = sorted({origins[k] for k in es})
        line = f"over-determined: {len(unmatched_eqs)} equation(s) too many among those of {_fmt(comps)}"
        # an equation left without unknowns after alias elimination constrains nothing: it is quoted instead,
        # since it names the parameters in conflict
        if vs:
            line += f" (they all constrain {_fmt(sorted(vs))})"
        empty = [k for k in unmatched_eqs if not base_eq_vars[k]]
        if empty:
            line += "; " + "; ".join(
                f"the equation from {origins[k]} has no unknown left (it reads 0 = {residuals[k]})" for k in empty)
        lines.append(line)
    if n_eq == n_var:
        lines[0] += ", but they are structurally singular"
    raise StructureError("; ".join(lines))


def local_balance(component) -> tuple:
    """``(equations, unknowns)`` of a component without sub-components, counted as Modelica's local balance rule
    counts them: its own variables, and the potentials of its physical ports and the values of its outputs (its
    ports' flows are determined by the connections, its inputs' values by what drives them). A component whose
    two counts differ makes every model it is used in over- or under-determined."""
    from ...model.components import Connector, Potential, Variable
    from ...model.connectors import RealInput

    own = sum(1 for d in component.declarations().values() if isinstance(d, Variable))
    for port in component._children.values():
        if isinstance(port, Connector) and not isinstance(port, RealInput):
            own += sum(1 for d in port.declarations().values() if isinstance(d, Potential))
    return len(component.equations()), own


def unbalanced(model) -> list:
    """The components of ``model`` (without sub-components of their own) whose local balance
    (:func:`local_balance`) fails: ``(path, class name, equations, unknowns)``."""
    from ...model.components import Connector

    out = []

    def visit(parent):
        for child in parent._children.values():
            if isinstance(child, Connector):
                continue
            if any(not isinstance(g, Connector) for g in child._children.values()):
                visit(child)
                continue
            n_eq, n_var = local_balance(child)
            if n_eq != n_var:
                out.append((child._path, type(child).__name__, n_eq, n_var))
    visit(model)
    return out


def unbalanced_note(model) -> str:
    """What :func:`unbalanced` finds, as the head of a structure error ('' when every component balances)."""
    found = unbalanced(model)
    if not found:
        return ""
    parts = [f"{cls} {path!r} has {n_eq} equation(s) for {n_var} unknown(s) of its own "
             f"({'too many' if n_eq > n_var else 'too few'})" for path, cls, n_eq, n_var in found]
    return ("; ".join(parts) + " (its variables, its ports' potentials and its outputs' values; the flows come "
            "from its connections): the likely culprit; ")


def _fmt(items, limit=12):
    items = list(items)
    s = ", ".join(repr(i) if not str(i).startswith(("connect", "unconnected")) and " " not in str(i) else str(i)
                  for i in items[:limit])
    return s + (f" and {len(items) - limit} more" if len(items) > limit else "")
