"""Structural analysis: balance check, matching, Pantelides index reduction with dummy derivatives, BLT."""
from .balance import check_balance
from .blt import blt_blocks
from .pantelides import IndexReduction, reduce_index

__all__ = ["check_balance", "reduce_index", "IndexReduction", "blt_blocks"]
