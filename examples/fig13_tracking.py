"""Fig. 13 of the paper: moment-arm tracking at 18 mm precompression, 1.2 and 3 s/stride, in closed loop (PID with
velocity and acceleration feed-forward through the PWM driver, limited by the 48 V bus): desired and actual moment-
arm angle (upper) and the power delivered to the joint (lower), next to the replay, where the arm follows the plan
exactly.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig13_tracking`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig13_tracking

if __name__ == "__main__":
    print(fig13_tracking.main(Path("results"))["markdown"])
