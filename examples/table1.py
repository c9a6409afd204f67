"""Table 1 of the paper: energy per stride at the five measurement points, 8 mm precompression, 2 s/stride, simulation
next to the paper, and a Sankey diagram of the loss chain.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.table1`, run on its own into ``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import table1

if __name__ == "__main__":
    print(table1.main(Path("results"))["markdown"])
