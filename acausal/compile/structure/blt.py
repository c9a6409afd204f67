"""Block lower triangular ordering: match every equation to the unknown it determines, then order the strongly
connected components of the dependency graph (Tarjan, via networkx) so each block needs only earlier blocks."""
from __future__ import annotations

from dataclasses import replace

import networkx as nx

from ...errors import StructureError
from .balance import _alternating_reach, _fmt, max_matching
from .system import EquationSystem


def blt_blocks(system: EquationSystem) -> EquationSystem:
    """``system`` (after index reduction) with its ``blocks``: ``(equation indices, unknown names)`` in
    evaluation order, each block needing only the states and earlier blocks."""
    eq_vars, unknowns, origins = system.eq_vars, system.unknowns, system.origins
    unk = set(unknowns)
    evars = [{v for v in vs if v in unk} for vs in eq_vars]
    match = max_matching(evars, sorted(unknowns))
    if len(match) != len(eq_vars) or len(match) != len(unknowns):
        unmatched_eqs = [k for k in range(len(eq_vars)) if k not in match]
        got = set(match.values())
        unmatched_vars = [v for v in sorted(unknowns) if v not in got]
        parts = [f"after index reduction {len(eq_vars)} equations for {len(unknowns)} unknowns are structurally "
                 "singular"]
        if unmatched_vars:
            _, vs = _alternating_reach(unmatched_vars, evars, match, from_equations=False)
            parts.append(f"nothing determines {_fmt(sorted(vs))}")
        if unmatched_eqs:
            es, _ = _alternating_reach(unmatched_eqs, evars, match, from_equations=True)
            parts.append(f"redundant or conflicting equations from {_fmt(sorted({origins[k] for k in es}))}")
        raise StructureError("; ".join(parts))
    solved_by = {v: e for e, v in match.items()}
    g = nx.DiGraph()
    g.add_nodes_from(range(len(eq_vars)))
    for e, vs in enumerate(evars):
        for v in vs:
            src = solved_by[v]
            if src != e:
                g.add_edge(src, e)
    cond = nx.condensation(g)
    members = cond.graph["mapping"]
    comp_eqs: dict[int, list[int]] = {}
    for e, c in members.items():
        comp_eqs.setdefault(c, []).append(e)
    order = nx.lexicographical_topological_sort(cond, key=lambda c: min(comp_eqs[c]))
    blocks = []
    for c in order:
        eqs = sorted(comp_eqs[c])
        blocks.append((eqs, [match[e] for e in eqs]))
    return replace(system, blocks=blocks)
