"""Calibration of the Eq. (4) model against bench recordings: Table 2 with a calibrated column and Fig. 14 (measured vs
simulated motor current before and after calibration).

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig14_calibration`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig14_calibration

if __name__ == "__main__":
    print(fig14_calibration.main(Path("results"))["markdown"])
