"""Figs. 9-12 of the paper: the loss of each stage over precompression x stride time, each as a percentage of the
energy at the previous measurement point (driver: of the source; motor: of the driver output; gearing: of the motor
power k i w; output: of the moment arm), on the bench model as the paper measured them (the actuator under its
position controller: where the motor cannot follow, the arm lags). Conditions where the replay of the plan needs
more than the driver's duty limit (the motor cannot follow at 48 V) are hatched.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig09_12_losses`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig09_12_losses

if __name__ == "__main__":
    print(fig09_12_losses.main(Path("results"))["markdown"])
