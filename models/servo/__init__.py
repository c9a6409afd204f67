"""A position servo swinging a pendulum, on real recordings (Dynamixel XL330, Rhoban/bam, Apache-2.0).

* :mod:`.model`: the assembled model (library :class:`~acausal.library.servo.PositionServo` on a
  :class:`~acausal.library.rotational.Pendulum`, replaying a recording's goal, supply voltage and torque enable;
  candidate elements put into the servo's slots);
* :mod:`.recording_format`: the recordings' columns and JSON keys, and what the model takes from them;
* :mod:`.bam_logs`: BAM's own raw JSON logs read directly;
* :mod:`.effects`: the candidate library across the chain (friction, firmware, electrics, sensing) and a user's
  own candidates;
* :mod:`.problem`: the recordings as a calibration and diagnosis problem (splits, candidates, replays);
* :mod:`.support`: what a set of recordings can show before fitting (``acausal check``);
* :mod:`.virtual`: simulated recordings of another servo with effects hidden in it;
* :mod:`.bam`: BAM's published friction-model parameters (M1-M6), replayed on our model with BAM's load measure;
* :mod:`.report`: the report of ``acausal diagnose --model servo_pendulum`` and ``examples/servo_friction.py``.
"""
