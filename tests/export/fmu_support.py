"""What the FMU tests need on the machine: fmpy to run the FMUs and a C compiler to build them (else the module is
skipped, saying which is missing)."""
import pytest

from acausal.export import ExportError
from acausal.export.fmu import find_compiler


def require_fmu_tools():
    """Skip the calling test module unless fmpy and a C compiler are there."""
    pytest.importorskip("fmpy", reason="the FMU tests run the exported FMUs in fmpy (pip install fmpy, in the test "
                                       "extra)")
    try:
        find_compiler()
    except ExportError as exc:  # pragma: no cover - machines without a C compiler
        pytest.skip(f"no C compiler to build FMU binaries: {exc}", allow_module_level=True)
