"""FMU export (issue 19): exported FMI 2.0 Model Exchange FMUs validated and simulated by fmpy, compared with
``simulate()``. Each FMU is exported (C compiled) once per module."""
import zipfile

import numpy as np
import pytest

from acausal import compile_model
from acausal.export import ExportError, export_fmu
from acausal.export.fmu import find_compiler

from .drive_models import MotorGearLoad

fmpy = pytest.importorskip("fmpy", reason="the FMU tests run the exported FMUs in fmpy (pip install fmpy, in the "
                                          "test extra)")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

try:
    find_compiler()
except ExportError as exc:  # pragma: no cover - machines without a C compiler
    pytest.skip(f"no C compiler to build FMU binaries: {exc}", allow_module_level=True)

TIGHT = dict(rtol=1e-11, atol=1e-13)


def relative_error(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300))


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    cm = compile_model(MotorGearLoad())
    return cm, export_fmu(MotorGearLoad(), tmp_path_factory.mktemp("fmu") / "drive.fmu")


def test_motor_gear_load_validates_and_matches_simulate(drive):
    """fmpy finds nothing wrong with the FMU (XML schema, variable names, model structure, start values, units),
    and its CVODE run matches a tight simulate() to 1e-6 relative in the states and outputs, aliases included."""
    cm, path = drive
    assert validate_fmu(str(path)) == []
    names = ["L.i", "rotor.w", "load.phi", "gear.flange_b.tau", "load.w", "R.v", "src.p.i", "load.flange_b.tau"]
    assert {"src.p.i", "load.flange_b.tau"} <= set(cm.flat.aliases)  # eliminated aliases are outputs too
    res = simulate_fmu(str(path), stop_time=1.0, relative_tolerance=1e-10, output_interval=0.01, output=names)
    ref = cm.simulate(1.0, t_eval=res["time"], **TIGHT)
    for n in names:
        assert relative_error(res[n], ref[n]) < 1e-6, n
