"""The equation system as it flows through the compiler's stages.

One record, :class:`EquationSystem`, goes from the flattened model (aliases eliminated) through the balance check,
Pantelides' index reduction with dummy derivatives, the BLT ordering and the solving of the blocks. Each stage
takes a system and returns it (the balance check) or a new one with its own results filled in (the others never
change the system they are given):

* :meth:`EquationSystem.from_flat`: the equations, their origins and incidence, the base variables;
* :func:`~acausal.compile.structure.reduce_index`: differentiated equations appended (``eq_pred``), derivatives that
  occur (``var_diff``), ``states``, ``dummies``, ``differentiations``;
* :func:`~acausal.compile.structure.blt_blocks`: ``blocks``;
* :func:`~acausal.compile.solve.solve_blocks`: ``steps``, what the code generator emits.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ...model.symbols import ConstantSymbol, der_name, split_der, time


@dataclass
class EquationSystem:
    residuals: list  # sympy expressions r of the equations 0 = r (originals first, then differentiated ones)
    origins: list  # where each equation comes from: "Resistor 'R1'", "connect(a.p, b.n)", "d/dt of ..."
    eq_vars: list  # incidence: the variable names (base or derivative) occurring in each equation
    base: list  # the base variables, sorted (before index reduction x and der(x) count as one unknown)
    owners: dict  # base variable -> the component it belongs to (for messages)
    state_select: dict  # base variable -> preference to be a state, 0 (never) .. 4 (always)
    eq_pred: list  # equation k is d/dt of equation eq_pred[k]; None for an equation of the model
    variables: list  # every variable name that occurs (base and derivatives), sorted
    var_diff: dict  # variable name -> name of its derivative, when that occurs
    states: list = field(default_factory=list)  # index reduction: the variables integrated in time
    dummies: set = field(default_factory=set)  # index reduction: derivatives made algebraic unknowns
    differentiations: int = 0  # index reduction: most times any equation was differentiated
    blocks: list = field(default_factory=list)  # BLT: (equation indices, unknown names) in evaluation order
    steps: list = field(default_factory=list)  # solving: Assign / LinearSolve / NewtonSolve in evaluation order

    def __post_init__(self):
        self._base_set = frozenset(self.base)

    @classmethod
    def from_flat(cls, flat) -> "EquationSystem":
        """The system of a flattened model (:class:`~acausal.compile.flatten.FlatModel`, aliases eliminated)."""
        base = sorted(flat.variables)
        system = cls([eq.residual for eq in flat.equations], [eq.origin for eq in flat.equations], [], base,
                     {n: v.owner for n, v in flat.variables.items()},
                     {n: v.state_select for n, v in flat.variables.items()}, [None] * len(flat.equations), [], {})
        system.eq_vars = [system.incidence(r) for r in system.residuals]
        variables = set(base).union(*system.eq_vars)
        system.variables = sorted(variables)
        system.var_diff = {v: der_name(v) for v in system.variables if der_name(v) in variables}
        return system

    def incidence(self, expr) -> set:
        """The variable names (base or derivative) occurring in ``expr``: not parameters, modes or time."""
        return {s.name for s in expr.free_symbols
                if not isinstance(s, ConstantSymbol) and s is not time and split_der(s.name)[0] in self._base_set}

    def owner(self, name: str) -> str:
        """The component a variable (or a derivative of one) belongs to."""
        base = split_der(name)[0]
        return self.owners.get(base, base.rsplit(".", 1)[0] if "." in base else "")

    def preference(self, name: str) -> int:
        """How strongly base variable ``name`` wants to be a state (``state_select``; 2 is the default)."""
        return self.state_select.get(name, 2)

    @property
    def index(self) -> int:
        """Differential index estimate: 0 for an ODE, otherwise 1 + the most differentiations needed."""
        has_algebraic = any(split_der(v)[1] == 0 and v not in self.var_diff for v in self.variables)
        if self.differentiations == 0 and not has_algebraic:
            return 0
        return self.differentiations + 1

    @property
    def unknowns(self) -> list:
        """Everything the equations determine at each instant: all variables except the states."""
        s = set(self.states)
        return [v for v in self.variables if v not in s]
