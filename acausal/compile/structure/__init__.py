"""Structural analysis: balance check, matching, Pantelides index reduction with dummy derivatives, BLT, all on
one :class:`EquationSystem`."""
from .balance import check_balance
from .blt import blt_blocks
from .pantelides import reduce_index
from .system import EquationSystem

__all__ = ["EquationSystem", "check_balance", "reduce_index", "blt_blocks"]
