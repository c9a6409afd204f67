"""The optional accelerators: what ``acausal info`` says is present is what a run takes, and each one's absence
leaves the run on its fallback with the same answer (CasADi's integrators without the native loop, the scipy path
without CasADi)."""
import numpy as np
import pytest

from acausal import compile_model
from acausal.cli.accelerators import default_path, describe, native_loop, survey
from acausal.cli import main

from ..circuit_models import RC

pytestmark = pytest.mark.backend


@pytest.fixture(scope="module")
def rc():
    return compile_model(RC())


def _path_of(solver: str) -> str:
    if "native" in solver:
        return "native loop"
    return "CasADi" if "compiled path" in solver else "scipy"


def test_the_default_path_is_the_one_a_run_takes(rc):
    found = {a.name: a.present for a in survey()}
    res = rc.simulate(1.0)
    expected = "native loop" if found["native loop"] else "CasADi" if found["CasADi"] else "scipy"
    assert _path_of(res.solver) == expected, (res.solver, found)
    said = default_path()
    assert {"native loop": "native loop", "CasADi": "CasADi's integrators", "scipy": "scipy path"}[expected] in said


def test_switched_off_the_native_loop_is_absent_and_runs_take_its_fallback(rc, monkeypatch):
    default = rc.simulate(1.0)
    monkeypatch.setenv("ACAUSAL_NATIVE", "0")
    loop = native_loop()
    assert not loop.present and "ACAUSAL_NATIVE=0" in loop.found
    res = rc.simulate(1.0)
    assert "native" not in res.solver
    np.testing.assert_allclose(res["C.v"], default["C.v"], atol=1e-5)


def test_without_a_c_compiler_the_native_loop_says_why(rc, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    found = {a.name: a for a in survey()}
    assert not found["C compiler"].present and "$CC" in found["C compiler"].found
    assert not found["native loop"].present
    assert "native" not in rc.simulate(1.0).solver


def test_info_names_every_accelerator_and_how_to_get_the_missing(capsys, monkeypatch):
    monkeypatch.setenv("ACAUSAL_NATIVE", "0")
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    for name in ("CasADi", "C compiler", "native loop", "plotly", "Chromium"):
        assert name in out, name
    assert "a default run takes" in out and "shipped data sets:" in out and "xl330" in out
    assert "get it: unset ACAUSAL_NATIVE" in out  # the native loop is off: how to have it back
    assert describe().splitlines()[0] in out


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    from acausal import __version__
    assert f"acausal {__version__}" in capsys.readouterr().out
