"""Working with measured data, for any model: recordings (format, loader, writer), signal smoothing, calibration
by bounded least squares, and residual analysis. What is specific to one actuator (its columns, its virtual
bench, its candidate effects) lives with its model in ``acausal.models``."""
from .recordings import (MANIFEST, Column, Key, Recording, RecordingFormat, load_recording, load_recordings,
                         write_manifest, write_recording)

__all__ = ["MANIFEST", "Column", "Key", "Recording", "RecordingFormat", "load_recording", "load_recordings",
           "write_manifest", "write_recording"]
