"""Fig. 15 of the paper: overall efficiency of the actuator (joint work / source energy per stride) over precompression
x stride time on the bench model (closed loop); conditions where the motor cannot follow at 48 V (the replay of the
plan needs more than 0.9 duty) are hatched.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig15_efficiency`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig15_efficiency

if __name__ == "__main__":
    print(fig15_efficiency.main(Path("results"))["markdown"])
