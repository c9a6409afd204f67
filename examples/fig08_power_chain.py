"""Fig. 8 of the paper: power at the five measurement points over one stride, 8 mm precompression, 2 s/stride.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig08_power_chain`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig08_power_chain

if __name__ == "__main__":
    print(fig08_power_chain.main(Path("results"))["markdown"])
