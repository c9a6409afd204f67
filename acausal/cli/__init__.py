"""Stage 8, the ``acausal`` command (:mod:`.commands`): its option values, classes named by reference, the machine's
accelerators and the shipped data sets."""
from .commands import build_parser, check_bench_folder, main, shipped_data

__all__ = ["build_parser", "check_bench_folder", "main", "shipped_data"]
