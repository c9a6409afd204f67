"""Nothing silently wrong: atomic writes, a manifest that catches torn or mixed recording
sets, recordings checked against their declared length, outputs that cannot overwrite inputs, clear messages for
bad CSV separators and CLI path errors, upper-case extensions, and the bench's winding starting at ambient."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from acausal import DataError, ModelError
from acausal.cli import main
from acausal.results.files import atomic_write_text
from acausal.identify import MANIFEST, load_recordings
from acausal.models.bench.recording_format import ANKLE_FORMAT
from acausal.models.bench.virtual import BenchCondition, run_bench

CONDS = [BenchCondition(0.011, 1.2, strides=2), BenchCondition(0.005, 1.2, strides=2)]


@pytest.fixture(scope="module")
def bench_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bench")
    run_bench(folder, CONDS, executor="serial")
    return folder


def _copy(src, dst):
    dst.mkdir(parents=True, exist_ok=True)
    for p in src.iterdir():
        (dst / p.name).write_bytes(p.read_bytes())
    return dst


def test_a_bench_set_loads_with_its_manifest(bench_set):
    man = json.loads((bench_set / MANIFEST).read_text())
    assert man["complete"] and set(man["recordings"]) == {"P11.0mm_T1.2s", "P05.0mm_T1.2s"}
    assert len(load_recordings(bench_set, ANKLE_FORMAT)) == 2


def test_a_truncated_recording_is_caught_by_the_manifest(bench_set, tmp_path):
    """The reported case: a rewrite interrupted after part of a CSV, beside the old JSON."""
    data = _copy(bench_set, tmp_path / "data")
    csv = data / "P11.0mm_T1.2s.csv"
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(lines[: int(0.76 * len(lines))]) + "\n")
    with pytest.raises(DataError, match=r"P11.0mm_T1.2s.csv: its content differs from what .*manifest.json "
                                        r"recorded \(\d+ rows, the manifest says \d+\)"):
        load_recordings(data, ANKLE_FORMAT)


def test_a_truncated_recording_without_manifest_is_caught_by_its_length(bench_set, tmp_path):
    data = _copy(bench_set, tmp_path / "data")
    (data / MANIFEST).unlink()
    csv = data / "P05.0mm_T1.2s.csv"
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(lines[: len(lines) // 2]) + "\n")
    with pytest.raises(DataError, match=r"P05.0mm_T1.2s.csv: the samples cover .* s .* but its JSON declares 2.4 s: "
                                        r"truncated"):
        load_recordings(data, ANKLE_FORMAT)


def test_an_interrupted_bench_run_and_a_mixed_folder_are_errors(bench_set, tmp_path):
    data = _copy(bench_set, tmp_path / "data")
    man = json.loads((data / MANIFEST).read_text())
    (data / MANIFEST).write_text(json.dumps({**man, "complete": False}))
    with pytest.raises(DataError, match="did not finish"):
        load_recordings(data, ANKLE_FORMAT)
    (data / MANIFEST).write_text(json.dumps(man))
    for ext in (".csv", ".json"):
        (data / f"P18.0mm_T1.2s{ext}").write_bytes((data / f"P05.0mm_T1.2s{ext}").read_bytes())
    with pytest.raises(DataError, match="P18.0mm_T1.2s.csv: not listed in .*mixes recordings of different runs"):
        load_recordings(data, ANKLE_FORMAT)


def test_an_interrupted_write_leaves_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "r.csv"
    atomic_write_text(path, "old\n")

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_text(path, "new content that never lands\n")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["r.csv"]  # no temporary file left behind


def test_outputs_never_inside_the_input_data(bench_set, tmp_path, capsys):
    data = _copy(bench_set, tmp_path / "data")
    before = {p.name: p.read_bytes() for p in data.iterdir()}
    assert main(["diagnose", str(data), "--out", str(tmp_path / "o"), "--json",
                 str(data / "P11.0mm_T1.2s.json")]) == 2
    assert "--json" in capsys.readouterr().err
    assert main(["fit", str(data), "--out", str(data)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "inside the input data folder" in err
    assert {p.name: p.read_bytes() for p in data.iterdir()} == before  # nothing was touched


def test_bench_into_a_non_empty_folder_needs_force(tmp_path, capsys):
    out = tmp_path / "old_run"
    out.mkdir()
    (out / "P08.0mm_T2.0s.csv").write_text("time_s\n0\n")
    assert main(["bench", "--out", str(out), "--quick"]) == 2
    err = capsys.readouterr().err
    assert "not empty" in err and "--force" in err
    from acausal.cli import check_bench_folder
    check_bench_folder(out, force=True)
    assert not list(out.iterdir())


def test_semicolon_separated_csv_is_named(bench_set, tmp_path):
    data = _copy(bench_set, tmp_path / "data")
    csv = data / "P11.0mm_T1.2s.csv"
    csv.write_text(csv.read_text().replace(",", ";"))
    (data / MANIFEST).unlink()
    with pytest.raises(DataError, match=r"P11.0mm_T1.2s.csv, line 1: the columns are separated by semicolons"):
        load_recordings(data, ANKLE_FORMAT)


def test_upper_case_extensions_load(bench_set, tmp_path):
    data = _copy(bench_set, tmp_path / "data")
    (data / MANIFEST).unlink()
    for ext in ("csv", "json"):
        (data / f"P05.0mm_T1.2s.{ext}").rename(data / f"P05.0mm_T1.2s.{ext.upper()}")
    assert sorted(r.name for r in load_recordings(data, ANKLE_FORMAT)) == ["P05.0mm_T1.2s", "P11.0mm_T1.2s"]


def test_cli_path_errors_are_clean_messages(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    assert main(["bench", "--out", str(blocker / "sub"), "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("acausal bench:") and "Traceback" not in err


def test_bench_winding_starts_at_ambient():
    """With the winding-temperature effect at zero heating the truth is the baseline: the winding starts at the
    motor's reference (ambient) temperature, not 5 K below it."""
    from acausal import compile_model
    from acausal.library.drives import DCMotor
    from acausal.models.ankle.actuator import AnkleActuator
    cm = compile_model(AnkleActuator.eq4(mode="replay", effects=("winding_temperature",)))
    res = cm.simulate(0.5, params={"winding_heating": 1e-9}, n_points=3)
    assert np.allclose(np.asarray(res["winding.T"]), DCMotor.T_ref.default)
    R = float(cm.param_vector({"winding_heating": 1e-9})[cm.param_index("motor.R")])
    assert np.allclose(np.asarray(res["motor.R_T"]), R)  # the winding resistance is the baseline's


def _rc():
    from acausal import Model, compile_model, connect
    from acausal.library.electrical import Capacitor, ConstantVoltage, Ground, Resistor

    class RC(Model):
        def build(self):
            self.src, self.R, self.C, self.g = ConstantVoltage(V=1.0), Resistor(R=1.0), Capacitor(C=1.0), Ground()
            connect(self.src.p, self.R.p)
            connect(self.R.n, self.C.p)
            connect(self.C.n, self.src.n, self.g.p)
    return compile_model(RC())


@pytest.mark.parametrize("param", ["C.C", "R.R"])
def test_degenerate_parameters_are_named_not_leaked(param):
    """C = 0 or R = 0 lie inside the declared bounds but make the system singular: a SimulationError naming the
    parameter, never the integrator's private exception."""
    from acausal import SimulationError
    with pytest.raises(SimulationError, match=rf"t = 0 s: .*{param} = 0 makes the system singular"):
        _rc().simulate(1.0, params={param: 0.0})


def test_a_string_input_is_refused_not_executed(tmp_path):
    from acausal import Model, SignalError, compile_model, connect
    from acausal.library.rotational import Inertia, Position
    marker = tmp_path / "executed"

    class Prescribed(Model):
        def build(self):
            self.pos = Position(phi_ref=f"__import__('pathlib').Path({str(marker)!r}).touch()")
            self.J = Inertia(J=1.0)
            connect(self.pos.flange, self.J.flange_a)
    with pytest.raises(SignalError, match="got the string .*not parsed"):
        compile_model(Prescribed())
    assert not marker.exists()


@pytest.fixture(scope="module")
def diagnosis_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diag")
    run_bench(folder, [BenchCondition(P, T, strides=3) for P in (0.005, 0.011) for T in (1.2, 2.0)], seed=4,
              executor="serial")
    return folder


@pytest.mark.slow
def test_clean_data_gives_no_warning(diagnosis_set):
    from acausal.models.bench import diagnosis
    d, _ = diagnosis.run(diagnosis_set, candidates=["driver_quiescent_power"], max_effects=1)
    assert d.cause == "none" and d.warnings == []


@pytest.mark.slow
def test_swapped_columns_are_flagged_not_a_silent_none(diagnosis_set, tmp_path):
    """The reported case: one recording with its two angle columns swapped gave `Verdict: none` with residuals
    tens of times the noise. Now the recording is named and the misfit is reported."""
    from acausal.models.bench import diagnosis
    data = _copy(diagnosis_set, tmp_path / "data")
    (data / MANIFEST).unlink()
    csv = data / "P11.0mm_T2.0s.csv"
    lines = csv.read_text().splitlines()
    header = lines[0].split(",")
    a, b = header.index("ankle_angle_rad"), header.index("moment_arm_angle_rad")
    header[a], header[b] = header[b], header[a]
    csv.write_text("\n".join([",".join(header)] + lines[1:]) + "\n")
    d, _ = diagnosis.run(data, candidates=["driver_quiescent_power"], max_effects=1)
    text = " ".join(d.warnings)
    assert "P11.0mm_T2.0s" in text and "times the set's median" in text
    assert "noise level" in text
    assert d.to_dict()["warnings"] == d.warnings


@pytest.mark.slow
def test_compare_csv_is_byte_identical_across_hash_seeds(tmp_path):
    """Two fresh processes with different PYTHONHASHSEED values write the same bytes (no iteration order of a
    set or dict of symbols leaks into the generated code or the results)."""
    import subprocess
    import sys
    out = {}
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        folder = tmp_path / f"seed{seed}"
        proc = subprocess.run([sys.executable, "-m", "acausal.cli", "compare", "replay", "sea", "closed_loop",
                               "--stride-time", "1.2", "--out", str(folder)], env=env, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        out[seed] = (folder / "compare.csv").read_bytes()
    assert out["1"] == out["2"]


@pytest.mark.parametrize("t_end", [float("inf"), float("nan"), -float("inf")])
def test_an_infinite_or_undefined_end_time_is_refused(t_end):
    """An infinite or NaN time span is a ModelError naming the setting (it has no output grid and never ends)."""
    from acausal import compile_model

    from ..drive_models import MotorGearLoad
    cm = compile_model(MotorGearLoad())
    with pytest.raises(ModelError, match="t_end must be a finite time"):
        cm.simulate(t_end)
    with pytest.raises(ModelError, match="t_start must be a finite time"):
        cm.simulate(1.0, t_start=-float("inf"))


# ------------------------------------------------------------------ real roots in symbolic solves
def test_an_odd_power_law_is_solved_with_the_real_root_on_both_signs():
    """``v = a i**3`` driven by 8 sin(2 pi t): sympy's principal cube root would be NaN for v < 0; the compiled
    solution is the real root on both paths. (The capacitor starts charged: at exactly v = 0 the law's
    conductance di/dv is infinite, a true singularity of this element.)"""
    import sympy as sp
    from sympy import Eq

    from acausal import Model, Parameter, Start, compile_model, connect, time
    from acausal.library.electrical import Capacitor, Ground, PrescribedVoltage
    from acausal.model.partials import OnePort

    class Cubic(OnePort):
        a = Parameter(2.0, unit="V/A3")

        def equations(self):
            return [*super().equations(), Eq(self.v, self.a * self.i**3)]

    class Drive(Model):
        def build(self):
            self.src = PrescribedVoltage(v_ref=8 * sp.sin(2 * sp.pi * time))
            self.c, self.C, self.g = Cubic(), Capacitor(C=1.0, v=Start(1.0)), Ground()
            connect(self.src.p, self.c.p)
            connect(self.c.n, self.C.p)
            connect(self.C.n, self.src.n, self.g.p)

    sim = compile_model(Drive())
    for method in ("auto", "BDF"):
        res = sim.simulate(1.0, method=method, rtol=1e-9, atol=1e-12, n_points=101)
        i, v = res["c.i"], res["c.v"]
        assert np.all(np.isfinite(i)) and (i < -0.1).any() and (i > 0.1).any()
        assert np.allclose(2.0 * i**3, v, rtol=1e-9, atol=1e-12)
        assert np.all(np.sign(i) == np.sign(v))



def test_sweep_findings_a_value_without_its_name_empty_outputs_and_non_finite_sensitivity_times():
    """The hostile-user sweep (tests/regressions/trust_sweep_findings.md, 1, 2 and 5): Resistor(0.386) became a doc text and kept
    R = 1 ohm; sensitivities at an infinite time hung and at a NaN returned 0; t_eval=[] was a raw IndexError."""
    import numpy as np
    from acausal import ModelError, compile_model
    from acausal.library.electrical import Resistor
    from ..circuit_models import RC

    with pytest.raises(ModelError, match=r"Resistor\(0.386, \.\.\.\): the first positional argument is the doc "
                                         r"text; give parameters by name"):
        Resistor(0.386)
    sim = compile_model(RC(v_ref=1.0, R=1.0, C=1.0))
    for bad, k in (([0, 0.5, float("inf")], 2), ([0, 0.5, float("nan"), 1.0], 2)):
        with pytest.raises(ModelError, match=rf"sensitivities: t\[{k}\] is (inf|nan); output times must be finite"):
            sim.sensitivities(bad, ["R.R"])
    with pytest.raises(ModelError, match=r"simulate: t_eval is empty"):
        sim.simulate(1.0, t_eval=np.array([]))
