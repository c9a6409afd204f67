"""Assembled models (imported as ``acausal.models``), by concern:

* :mod:`acausal.models.ankle`: the paper's actuator (:class:`~acausal.models.ankle.actuator.AnkleActuator`),
  its presets, trajectory planning, the bench protocol and the paper's report;
* :mod:`acausal.models.drivetrains`: the alternative drive trains, their registry and ``acausal compare``;
* :mod:`acausal.models.bench`: measured data: recording format, effects, the virtual bench, calibration,
  diagnosis, the design maps and their reports;
* :mod:`acausal.models.reporting`: table and figure helpers every report shares.

Nothing is imported here: each module loads only what it uses.
"""
