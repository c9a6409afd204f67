"""Fig. 7 of the paper: power at the driver input (source power) over one stride, 8 mm precompression, 3 s/stride, the
MACCEPA actuator against the paper's "direct drive": the bench's output motor, which imposes the gait angle on the
joint while the actuator pushes it (``bench_output_motor``: its drive train is not published, so it is guessed as
the actuator's own motor, driver and 860:1 gears; claim C9 reads it). Beside them the forward direct drive
(``direct_drive``: the same drive train delivering the gait's torque and power to the joint without the spring), the
design alternative. Peak power and energy per stride of each.

A section of ``acausal paper``'s report: :mod:`acausal.models.ankle.figures.fig07_direct_drive`, run on its own into
``results/``.
"""
from pathlib import Path

from acausal.models.ankle.figures import fig07_direct_drive

if __name__ == "__main__":
    print(fig07_direct_drive.main(Path("results"))["markdown"])
