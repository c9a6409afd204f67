"""Table 2 of the paper under both readings: the 8 mm, 2 s/stride replay with each of the paper's Eq. 4 parameter sets
(models/ankle/presets.py) next to the full component model (``library``).

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.table2`, run on its own into ``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import table2

if __name__ == "__main__":
    print(table2.main(Path("results"))["markdown"])
