"""A position servo swinging a pendulum, on real recordings (Dynamixel XL330, Rhoban/bam, Apache-2.0).

* :mod:`.model`: the assembled model (library :class:`~acausal.library.servo.PositionServo` on a
  :class:`~acausal.library.rotational.Pendulum`, replaying a recording's goal, supply voltage and torque enable);
* :mod:`.recording_format`: the recordings' columns and JSON keys, and what the model takes from them;
* :mod:`.problem`: the recordings as a calibration and diagnosis problem (splits, candidates: friction laws);
* :mod:`.bam`: BAM's published friction-model parameters, replayed on our model;
* :mod:`.report`: the report of ``acausal diagnose --model servo_pendulum`` and ``examples/servo_friction.py``.
"""
