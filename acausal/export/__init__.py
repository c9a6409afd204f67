"""Exporting compiled models for other tools: :func:`export_fmu` writes an FMI 2.0 Model Exchange FMU whose binary
is compiled from C code printed from the model's solved equations (see ``docs/fmu-export.md``)."""
from .ccode import ExportError
from .fmu import export_fmu

__all__ = ["export_fmu", "ExportError"]
