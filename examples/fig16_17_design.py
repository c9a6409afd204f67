"""Efficiency-optimal spring design (paper section 4.4): overall efficiency per stride (joint energy / source energy)
over spring stiffness x precompression at 1.2 s (Fig. 16) and 2.0 s (Fig. 17) per stride, with the original design
criterion (minimum peak moment-arm power at 1.2 s; paper: 130 N/mm, 7 mm) next to the efficiency optimum and a
continuous refinement of it.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig16_17_design`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig16_17_design

if __name__ == "__main__":
    print(fig16_17_design.main(Path("results"))["markdown"])
