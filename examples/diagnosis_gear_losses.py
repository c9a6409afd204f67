"""The paper's own story, diagnosed: gear mesh losses the Eq. (4) model leaves out, and what calibration does with
them.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.diagnosis_gear_losses`, run on its own
into ``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import diagnosis_gear_losses

if __name__ == "__main__":
    print(diagnosis_gear_losses.main(Path("results"))["markdown"])
