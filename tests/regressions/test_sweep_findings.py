"""The hostile-user sweep (tests/regressions/trust_sweep_findings.md): each finding's reproduction, with the clear outcome
it now gets (an error naming the argument, option, key or file at fault, or a flagged answer). The test names
carry the finding's number."""
from __future__ import annotations

import contextlib
import re
import shutil
import warnings

import numpy as np
import pytest
import sympy as sp

from acausal import ModelError, compile_model

from ..circuit_models import RC
from .test_nothing_silent import _copy as copy_set


@pytest.fixture(scope="module")
def rc():
    sim = compile_model(RC(v_ref=1.0, R=1.0, C=1.0))
    return sim, sim.simulate(1.0)


def test_energy_of_something_that_is_not_a_power_is_refused_and_an_efficiency_above_one_is_flagged(rc):
    sim, res = rc
    for name, unit in (("C.v", "V"), ("R.R", "Ohm"), ("C.energy", "J")):
        with pytest.raises(ModelError, match=rf"energy: '{name}' \[{unit}\] is not a power \(W\)"):
            res.energy(name)
    with pytest.raises(ModelError, match=r"efficiency: 'C.v' \[V\] is not a power"):
        res.energy_balance(between=("src", "C.v"))
    # ports, components and power variables still integrate; the source delivers what R loses and C stores
    e_src, e_loss = res.energy("src")[-1], res.energy("R.loss_power")[-1]
    assert e_src < 0 < e_loss  # power into the source is negative: it delivers
    assert abs(-e_src - e_loss - 0.5 * res["C.v"][-1] ** 2) < 1e-5 * -e_src  # rtol 1e-6 of the run
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        eta = res.energy_balance(between=("R.loss_power", "src")).efficiency
    assert eta > 1 and any("> 1" in str(w.message) and "ends reversed" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a sane efficiency warns about nothing
        assert 0 < res.efficiency("src", "C") < 1


@pytest.mark.parametrize("window, message", [
    ((2.0, 3.0), r"window: t0 = 2 s is outside the run \(0..1 s\)"),
    ((0.8, 0.2), r"window: t0 = 0.8 s must be before t1 = 0.2 s"),
    (("a", 0.05), r"window: t0 must be a time in s \(a finite number\), got 'a'"),
    ((0.0, float("nan")), r"window: t1 must be a time in s"),
])
def test_an_energy_balance_window_outside_the_run_or_reversed_is_refused(rc, window, message):
    _, res = rc
    with pytest.raises(ModelError, match=message):
        res.energy_balance(*window)
    with pytest.raises(ModelError, match=message):
        res.sankey(None, *window)


def test_one_output_point_is_refused(rc):
    sim, _ = rc
    with pytest.raises(ModelError, match=r"n_points must be an integer >= 2 .* got 1; for one time give t_eval"):
        sim.simulate(1.0, n_points=1)
    assert sim.simulate(1.0, t_eval=[1.0]).t.tolist() == [1.0]  # one time, asked for as such


@pytest.mark.parametrize("settings, message", [
    (dict(rtol="1e-6"), r"simulate: rtol must be a number \(or one per state\), got the str '1e-6'"),
    (dict(rtol=float("inf")), r"simulate: rtol must be positive and below 1"),
    (dict(atol=float("inf")), r"simulate: atol must be finite and not negative"),
    (dict(atol=[1e-9, 1e-9]), r"simulate: atol has 2 values for 1 state \['C.v'\]"),
    (dict(rtol=[1e-6, 1e-6, 1e-6]), r"simulate: rtol has 3 values for 1 state"),
    (dict(max_step="0.01"), r"max_step must be a number, got the str '0.01'"),
    (dict(first_step=10.0, method="BDF"), r"first_step = 10 s is longer than the run \(1 s"),
    (dict(max_steps=3, method="CVODES"), r"max_steps limits a scipy integrator's steps; method='CVODES'"),
])
def test_integrator_settings_are_checked_naming_the_setting(rc, settings, message):
    sim, _ = rc
    with pytest.raises(ModelError, match=message):
        sim.simulate(1.0, **settings)
    if set(settings) <= {"rtol", "atol"}:  # the tolerances are sensitivities' settings too
        with pytest.raises(ModelError, match=message.replace("simulate", "sensitivities")):
            sim.sensitivities([0.0, 1.0], ["R.R"], **settings)


def test_one_tolerance_per_state_is_taken(rc):
    sim, _ = rc
    res = sim.simulate(1.0, atol=[1e-9], rtol=[1e-6])
    assert abs(res["C.v"][-1] - (1 - np.exp(-1.0))) < 1e-5


def test_the_result_and_batch_api_name_the_argument_at_fault(rc, tmp_path):
    sim, res = rc
    for key in (0, None, ["C.v"]):
        with pytest.raises(ModelError, match=r"index it by a variable's name \(a str"):
            res[key]
        assert key not in res if not isinstance(key, list) else True
    for between in (("src",), "src", 3):
        with pytest.raises(ModelError, match=r"between must be a pair \(a, b\) of names"):
            res.energy_balance(between=between)
    with pytest.raises(ModelError, match=r"names: pattern must be a str"):
        res.names(3)
    with pytest.raises(ModelError, match=rf"to_csv: {tmp_path} is a folder; give a file path"):
        res.to_csv(tmp_path)
    with pytest.raises(ModelError, match=r"to_csv: the folder /no/such/dir of /no/such/dir/x.csv does not exist"):
        res.to_csv("/no/such/dir/x.csv")
    with pytest.raises(ModelError, match=r"sankey: ax must be a matplotlib Axes"):
        res.sankey(ax=3)
    with pytest.raises(ModelError, match=r"simulate_many: params\[0\] is 1, not a dict of parameter overrides"):
        sim.simulate_many(1.0, [1, 2])
    from acausal.simulation.sweep import sweep
    with pytest.raises(ModelError, match=r"sweep: args must be a list .* got 5"):
        sweep(abs, 5, executor="serial")
    with pytest.raises(ModelError, match=r"sweep: fn must be a function"):
        sweep(3, [1], executor="serial")
    assert sweep(abs, [-1, 2], executor="serial") == [1, 2]


@pytest.mark.parametrize("call, message", [
    (lambda sim: sim.simulate("1.0"), r"t_end must be a number, got the str '1.0'"),
    (lambda sim: sim.simulate(True), r"t_end must be a number, got the bool True"),
    (lambda sim: sim.simulate(1.0, t_start="0.05"), r"t_start must be a number, got the str"),
    (lambda sim: sim.simulate(1.0, dense_output="no"), r"dense_output must be True or False, got 'no'"),
    (lambda sim: sim.simulate_many(1.0, [{}], dense_output="no"), r"dense_output must be True or False"),
    (lambda sim: sim.simulate(1.0, starts={"C.v": "1"}), r"start value of 'C.v' must be a number, got the str"),
    (lambda sim: sim.sensitivities([0.0, 1.0], ["R.R"], substeps=-1), r"substeps must be a positive integer"),
    (lambda sim: sim.device_defaults({"R.RR": 1}), r"unknown parameter 'R.RR' .* did you mean 'R.R'"),
])
def test_loose_acceptance_in_simulate_and_friends_is_gone(rc, call, message):
    sim, _ = rc
    with pytest.raises(ModelError, match=message):
        call(sim)


def test_max_steps_is_honoured_on_auto_by_the_scipy_path(rc):
    sim, _ = rc
    from acausal import SimulationError
    with pytest.raises(SimulationError, match=r"took 3 steps"):
        sim.simulate(1.0, max_steps=3)
    res = sim.simulate(1.0, max_steps=100_000)
    assert "max_steps" in res.solver


def test_an_upper_limit_below_the_lower_one_is_refused_on_every_run():
    from acausal import Model, Parameter, connect
    from acausal.library.blocks import Sine
    from acausal.library.control import PID, Limiter

    class Limited(Model):
        def __init__(self, **limits):
            self.limits = limits
            super().__init__()

        def build(self):
            self.s, self.blk = Sine(amplitude=3.0), Limiter(**self.limits)
            connect(self.s.y, self.blk.u)

    with pytest.raises(ModelError, match=r"Limiter 'blk': the upper limit u_max must not be below the lower limit "
                                         r"u_min \(blk.u_max >= blk.u_min fails with blk.u_max = -1.0, blk.u_min = 1.0\)"):
        compile_model(Limited(u_max=-1.0, u_min=1.0)).simulate(1.0)
    sim = compile_model(Limited(u_max=2.0))
    assert abs(sim.simulate(1.0)["blk.y"].max() - 2.0) < 1e-9  # a sane limiter clips at its limit
    with pytest.raises(ModelError, match=r"blk.u_max = -3.0, blk.u_min = -2.0"):
        sim.simulate(1.0, params={"blk.u_max": -3.0})
    with pytest.raises(ModelError, match=r"the upper output limit y_max must not be below the lower limit y_min"):
        class Loop(Model):
            def build(self):
                self.ref, self.pid = Sine(amplitude=1.0), PID(kp=1.0, y_max=1.0, y_min=2.0)
                self.meas = Sine(amplitude=0.5)
                connect(self.ref.y, self.pid.setpoint)
                connect(self.meas.y, self.pid.measurement)
        compile_model(Loop()).simulate(0.1)
    with pytest.raises(ModelError, match=r"Parameter\(1.0, 'Ohm'\): min 5.0 > max 0.0; no value could meet both"):
        Parameter(1.0, "Ohm", min=5.0, max=0.0)


def test_a_negative_absolute_temperature_is_refused_with_a_celsius_hint():
    from acausal.library.thermal import FixedTemperature, HeatCapacitor
    with pytest.raises(ModelError, match=r"FixedTemperature: parameter 'T' = -10.0 is outside its bounds \[0.0, inf\] "
                                         r"K \(an absolute temperature: 25 degC is 298.15 K\)"):
        FixedTemperature(T=-10.0)
    with pytest.raises(ModelError, match=r"HeatCapacitor: start of 'T' = -300 is outside its bounds \[0.0, inf\] K"):
        HeatCapacitor(C=1.0, T=-300.0)
    assert HeatCapacitor(C=1.0, T=300.0)._starts["T"].value == 300.0


@pytest.mark.parametrize("make, message", [
    (lambda C, Start: C(C=1.0, v=Start("x")), r"Capacitor: start of 'v' = 'x' is a str; give a number \[V\]"),
    (lambda C, Start: C(C=1.0, v=[1, 2]), r"Capacitor: start of 'v' = \[1, 2\] is a list; give a number \[V\]"),
    (lambda C, Start: C(C=1.0, v="0.5"), r"Capacitor: start of 'v' = '0.5' is a str"),
    (lambda C, Start: C(C=1.0, v=Start(0.5, fixed="no")), r"fixed='no'\) for 'v': fixed must be True or False"),
    (lambda C, Start: C(C=sp.I), r"Capacitor: parameter 'C' = I is not a finite real number \[F\]"),
    (lambda C, Start: C(C=sp.zoo), r"parameter 'C' = zoo is not a finite real number"),
])
def test_start_values_and_parameters_of_the_wrong_type_are_refused_where_given(make, message):
    from acausal import Start
    from acausal.library.electrical import Capacitor
    with pytest.raises(ModelError, match=message):
        make(Capacitor, Start)


# ------------------------------------------------------------------------------------------ command line and files
@pytest.fixture(scope="module")
def bench_set(tmp_path_factory):
    from acausal.models.bench.virtual import BenchCondition, run_bench
    folder = tmp_path_factory.mktemp("bench")
    run_bench(folder, [BenchCondition(0.011, 1.2, strides=3), BenchCondition(0.005, 1.2, strides=3)],
              executor="serial")
    return folder


def _copy(src, dst):
    """``src``'s recordings in ``dst``, without the manifest (edited recordings no longer match its checksums)."""
    copy_set(src, dst)
    (dst / "manifest.json").unlink()
    return dst


def _refused(capsys, argv, message):
    """``acausal ARGV`` refuses with exit status 2 and ``message`` (a regex) on stderr; ``usage:...``: refused by
    argparse (SystemExit) before the verb runs."""
    from acausal.cli import main
    with pytest.raises(SystemExit) if message.startswith("usage:") else contextlib.nullcontext():
        assert main(argv) == 2
    err = capsys.readouterr().err
    assert re.search(message.removeprefix("usage:"), err), err
    return err


def test_a_json_that_is_not_utf8_is_named_with_its_byte_and_a_bom_is_read(bench_set, tmp_path, capsys):
    d = _copy(bench_set, tmp_path / "d")
    js = d / "P05.0mm_T1.2s.json"
    js.write_bytes(js.read_bytes() + b"\xff")
    _refused(capsys, ["fit", str(d), "--out", str(tmp_path / "f")],
             rf"{js}: not UTF-8 text \(byte 0xff at offset \d+\)")
    from acausal.identify import load_recordings
    from acausal.models.bench.recording_format import ANKLE_FORMAT
    js.write_bytes(b"\xef\xbb\xbf" + js.read_bytes()[:-1])  # as spreadsheet programs save: a byte-order mark
    csv = d / "P05.0mm_T1.2s.csv"
    csv.write_bytes(b"\xef\xbb\xbf" + csv.read_bytes())
    recs = load_recordings(d, ANKLE_FORMAT)
    assert len(recs) == 2 and "time_s" in recs[0].columns


@pytest.mark.parametrize("key, value, message", [
    ("supply_voltage_V", 4800.0, r"key 'supply_voltage_V' = 4800: outside 0-200 \(.*mV for V\?\)"),
    ("lever_A_m", 100.0, r"key 'lever_A_m' = 100: outside 0.001-1"),
    ("gear_ratio", 0.5, r"key 'gear_ratio' = 0.5: outside 1-10000"),
])
def test_unit_slips_in_the_optional_ankle_keys_are_refused(bench_set, tmp_path, key, value, message):
    import json

    from acausal import DataError
    from acausal.identify import load_recordings
    from acausal.models.bench.recording_format import ANKLE_FORMAT
    d = _copy(bench_set, tmp_path / "d")
    js = d / "P05.0mm_T1.2s.json"
    meta = json.loads(js.read_text())
    meta[key] = value
    js.write_text(json.dumps(meta))
    with pytest.raises(DataError, match=message):
        load_recordings(d, ANKLE_FORMAT)


@pytest.mark.parametrize("argv, message", [
    (["bench", "--quick", "--sensor", "rate=1e12"], r"--sensor rate=1e12: a finite number 10-100000 expected \[Hz\]"),
    (["bench", "--quick", "--sensor", "rate=1"], r"--sensor rate=1: a finite number 10-100000"),
    (["bench", "--quick", "--strides", "0"], r"usage:--strides takes a whole number >= 1, got '0'"),
    (["bench", "--quick", "--strides", "-1"], r"usage:--strides takes a whole number >= 1, got '-1'"),
    (["paper", "--quick", "--jobs", "-1"], r"usage:--jobs takes a whole number >= 1, got '-1'"),
    (["compare", "sea", "--jobs", "0"], r"usage:--jobs takes a whole number >= 1, got '0'"),
    (["compare", "sea", "--set", "motor.R=0.5", "--set", "motor.R=0.6"],
     r"--set motor.R: given twice \('motor.R=0.5' and 'motor.R=0.6'\)"),
    (["bench", "--quick", "--effect", "gear_coulomb_friction=0.01", "--effect", "gear_coulomb_friction=0.02"],
     r"--effect gear_coulomb_friction: given twice"),
    (["bench", "--quick", "--truth", "R=0.8", "--truth", "R=0.9"], r"--truth R: given twice"),
])
def test_options_are_checked_before_any_work_naming_the_option(tmp_path, capsys, argv, message):
    out = tmp_path / "o"
    _refused(capsys, argv + ["--out", str(out)], message)
    assert not out.exists() or not any(out.iterdir())  # nothing written


@pytest.mark.slow
def test_fit_and_diagnose_options_that_would_do_nothing_are_refused(bench_set, tmp_path, capsys):
    f = tmp_path / "f"
    _refused(capsys, ["fit", str(bench_set), "--out", str(f), "--weight", "motor_current_A=0", "--weight",
                      "supply_current_A=0"], r"every fitted signal \(motor_current_A, supply_current_A\) has weight 0")
    for option in ('""', ",,"):
        _refused(capsys, ["diagnose", str(bench_set), "--out", str(f), "--candidates", option.strip('"')],
                 r"--candidates .* names no candidate; leave it out to try them all")
    for extra, named in ((["--split", "kp=400"], "--split"), (["--jobs", "2"], "--jobs"), (["--bam"], "--bam")):
        _refused(capsys, ["diagnose", str(bench_set), "--out", str(f)] + extra,
                 rf"{named}: for --model servo_pendulum only")
    _refused(capsys, ["diagnose", str(bench_set), "--out", str(f), "--json", str(tmp_path)],
             rf"--json {tmp_path}: is a folder; give a file path")
    assert not f.exists()  # refused before any work


def test_a_quantity_given_twice_in_a_servo_json_must_agree(tmp_path):
    import json
    from importlib import resources

    from acausal import DataError
    from acausal.identify import load_recordings
    from acausal.models.servo.recording_format import SERVO_FORMAT
    src = resources.files("acausal.models.servo") / "data/xl330/recordings"
    d = tmp_path / "servo"
    d.mkdir()
    names = sorted(p.name for p in src.iterdir() if p.name.endswith(".json"))[:2]
    for n in names:
        for ext in (".json", ".csv"):
            shutil.copyfile(src / n.replace(".json", ext), d / n.replace(".json", ext))
    assert len(load_recordings(d, SERVO_FORMAT)) == 2  # the shipped files say kp and mass twice, agreeing
    js = d / names[0]
    meta = json.loads(js.read_text())
    meta["controller"]["kp"] = 800
    js.write_text(json.dumps(meta))
    with pytest.raises(DataError, match=r"key 'controller.kp' = 800 contradicts key 'kp' = 100"):
        load_recordings(d, SERVO_FORMAT)
    meta["controller"]["kp"], meta["rig"]["mass_kg"] = 100, 0.9
    js.write_text(json.dumps(meta))
    with pytest.raises(DataError, match=r"key 'rig.mass_kg' = 0.9 contradicts key 'mass_kg' = 0.49"):
        load_recordings(d, SERVO_FORMAT)


def test_loader_messages_name_the_real_problem(bench_set, tmp_path, capsys):
    d = _copy(bench_set, tmp_path / "d")
    (d / "P05.0mm_T1.2s.csv").unlink()
    (d / "P05.0mm_T1.2s.csv").mkdir()
    _refused(capsys, ["fit", str(d), "--out", str(tmp_path / "f")], r"P05.0mm_T1.2s.csv: is a folder, not a "
                                                                    r"recording file")
    base = tmp_path / "base.py"
    base.write_text("x = 1\n")
    _refused(capsys, ["fit", str(base), "--out", str(tmp_path / "f")], rf"recording set {base}: is a file; give "
                                                                       "the folder")


# ------------------------------------------------------------------------------------------------- export
_USER_MODELS = '''
from acausal import Model, connect
from acausal.library.electrical import ConstantVoltage, Ground, Resistor, Capacitor


class RC(Model):
    def build(self):
        self.src, self.R, self.C, self.g = ConstantVoltage(V=1.0), Resistor(R=1.0), Capacitor(C=1.0), Ground()
        connect(self.src.p, self.R.p)
        connect(self.R.n, self.C.p)
        connect(self.C.n, self.src.n, self.g.p)


class NeedsArg(RC):
    def __init__(self, x):
        super().__init__()


class Raises(Model):
    def build(self):
        raise ValueError("boom")
'''


def test_export_names_the_users_file_the_compiler_and_the_setting(tmp_path, capsys):
    import zipfile

    from acausal.cli import main
    models = tmp_path / "mymod.py"
    models.write_text(_USER_MODELS)
    broken = tmp_path / "s.py"
    broken.write_text("this is ( not python\n")
    fmu = str(tmp_path / "e.fmu")
    line = _USER_MODELS.splitlines().index('        raise ValueError("boom")') + 1
    _refused(capsys, ["export", f"{broken}:X", "--fmu", fmu, "--no-binary"],
             rf"model '{broken}:X': {broken} line 1: SyntaxError: '\(' was never closed")
    _refused(capsys, ["export", f"{models}:NeedsArg", "--fmu", fmu, "--no-binary"],
             r"the class must be buildable without arguments; its __init__ needs x")
    _refused(capsys, ["export", f"{models}:Raises", "--fmu", fmu, "--no-binary"],
             rf"building it raised ValueError: boom \({models} line {line}\)")
    _refused(capsys, ["export", f"{models}:RC", "--fmu", fmu, "--no-binary", "--identifier", "my model-1"],
             r"identifier 'my model-1' is not a C identifier .* e.g. 'my_model_1'")
    _refused(capsys, ["export", f"{models}:RC", "--fmu", fmu, "--no-binary", "--preset", "paper_fit"],
             r"--preset paper_fit: presets are for registered models")
    if shutil.which("false"):
        _refused(capsys, ["export", f"{models}:RC", "--fmu", fmu, "--compiler", shutil.which("false")],
                 r"cannot build a one-line C program \(exit status 1\) and says nothing: is it a C compiler\?")
    assert main(["export", f"{models}:RC", "--fmu", fmu, "--no-binary"]) == 0
    xml = zipfile.ZipFile(fmu).read("modelDescription.xml").decode()
    assert 'description="RC (exported by acausal)"' in xml  # not the framework's Model docstring


def test_the_fmu_checks_the_components_assertions_too(tmp_path):
    """An FMU user who sets a limit below the other is refused at fmi2ExitInitializationMode, with the component's
    message in the FMU's log, as simulate() refuses it."""
    from ..export.fmu_support import require_fmu_tools
    require_fmu_tools()
    from fmpy import simulate_fmu

    from acausal import Model, connect
    from acausal.export import export_fmu
    from acausal.library.blocks import Sine
    from acausal.library.control import Limiter

    class Limited(Model):
        """A sine through a limiter."""

        def build(self):
            self.s, self.blk = Sine(amplitude=3.0), Limiter(u_max=2.0)
            connect(self.s.y, self.blk.u)

    path = export_fmu(Limited(), tmp_path / "limited.fmu")
    res = simulate_fmu(str(path), stop_time=1.0, output=["blk.y.value"])
    assert abs(max(res["blk.y.value"]) - 2.0) < 1e-9
    got = []

    def logger(env, name, status, category, message):
        got.append(message.decode() if isinstance(message, bytes) else str(message))

    with pytest.raises(Exception, match="fmi2ExitInitializationMode"):
        simulate_fmu(str(path), stop_time=1.0, start_values={"blk.u_max": -3.0}, logger=logger)
    assert any("Limiter 'blk': the upper limit u_max must not be below the lower limit u_min" in m for m in got), got
