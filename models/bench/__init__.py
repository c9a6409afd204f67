"""Measured data for the ankle actuator: the recording format, the effects Eq. (4) leaves out, the virtual bench
(:mod:`.virtual`), calibration, diagnosis, the design maps (Figs. 16-17) and the reports they write."""
