"""The compiler's stages in their order: flatten -> aliases -> time events -> balance -> index reduction -> BLT ->
solve -> lowered program, and the energy accounts. :func:`acausal.compile_model` wraps what they give in a
:class:`~acausal.compiled_model.CompiledModel`."""
from __future__ import annotations

import time as _time
from dataclasses import dataclass

from ..errors import StructureError
from .accounts import Accounts, accounts
from .alias import eliminate_aliases
from .checks import check_signal_orders, check_symbols, resolve
from .flatten import flatten
from .program import Program, build_program
from .solve import solve_blocks
from .structure import EquationSystem, blt_blocks, check_balance, reduce_index
from .structure.balance import unbalanced_note
from .time_events import time_events


@dataclass(frozen=True)
class Compiled:
    """What the stages made of a model: the flattened model (aliases eliminated), the solved equation system, the
    lowered program every backend prints, the seconds it took and the energy accounts."""

    flat: object
    system: EquationSystem
    program: Program
    seconds: float
    accounts: Accounts


def run_stages(model) -> Compiled:
    """Every stage on a model instance, in order; each raises what it finds wrong, naming the culprit."""
    t0 = _time.perf_counter()
    flat = flatten(model)
    eliminate_aliases(flat)
    time_events(flat)
    system = EquationSystem.from_flat(flat)
    check_symbols(flat, system)
    try:
        system = check_balance(system)
    except StructureError as err:  # a component that does not balance its own unknowns is named first
        raise StructureError(unbalanced_note(model) + str(err)) from None
    system = reduce_index(system)
    orders = check_signal_orders(flat, system)
    starts = {n: v.start for n, v in flat.variables.items()}
    free = {n: (resolve(nominal, flat), resolve(scale, flat), origin)
            for n, (nominal, scale, origin) in flat.indeterminates.items() if n not in flat.aliases}
    system = solve_blocks(blt_blocks(system), starts, modes=sorted(flat.discretes), indeterminates=free)
    program = build_program(flat, system, orders)
    return Compiled(flat, system, program, _time.perf_counter() - t0, accounts(model))
