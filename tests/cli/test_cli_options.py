"""Every CLI option is checked before any work starts, the option named; a fit whose parameters
the chosen signals cannot see says so instead of printing ``+- inf``."""
import pytest

from acausal.cli import main
from acausal.models.bench.virtual import BenchCondition, run_bench


def _fails(argv, capsys, message):
    try:
        code = main(argv)
    except SystemExit as exit_:  # argparse's own refusal
        code = exit_.code
    err = capsys.readouterr().err
    assert code == 2 and message in err, err
    return err


BENCH = {
    "an effect far outside its range": (["--effect", "gear_coulomb_friction=1e9"],
                                        "--effect 'gear_coulomb_friction=1e9': outside the range the diagnosis fits "
                                        "it in, 0-0.2 [N.m]"),
    "no encoder bits": (["--sensor", "encoder_bits=0"], "--sensor encoder_bits=0: a whole number 1-52 expected"),
    "fractional encoder bits": (["--sensor", "encoder_bits=13.7"], "--sensor encoder_bits=13.7: a whole number"),
    "negative noise": (["--sensor", "motor_current_noise=-1"], "--sensor motor_current_noise=-1: a finite number "
                       ">= 0 expected [A]"),
    "zero sample rate": (["--sensor", "rate=0"], "--sensor rate=0: a finite number 10-100000 expected [Hz]"),
    "a filter above Nyquist": (["--sensor", "current_filter_hz=600"], "below half the sample rate (1000 Hz)"),
    "a negative seed": (["--seed", "-1"], "--seed takes a whole number >= 0, got '-1'"),
    "a truth that is no number": (["--truth", "R=abc"], "--truth R=abc: the value after '=' must be a finite number"),
}


@pytest.mark.parametrize("case", list(BENCH))
def test_bench_options_are_checked_before_any_recording(case, tmp_path, capsys):
    extra, message = BENCH[case]
    _fails(["bench", "--out", str(tmp_path / "set"), *extra], capsys, message)
    assert not (tmp_path / "set").exists() or not any((tmp_path / "set").glob("*.csv"))


@pytest.fixture(scope="module")
def bench_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bench")
    run_bench(folder, [BenchCondition(0.008, 1.5, strides=3)], seed=3)
    return folder


@pytest.mark.parametrize("extra, message", [
    (["--weight", "bogus=1"], "a weight is given for 'bogus', which is not a fitted signal"),
    (["--weight", "motor_curent_A=2"], "did you mean 'motor_current_A'?"),
    (["--weight", "motor_current_A=abc"], "--weight motor_current_A=abc: the value after '=' must be a finite"),
    (["--holdout-every", "0"], "--holdout-every takes a whole number >= 1, got '0'"),
    (["--signals", "joint_torque_Nm"], "calibration on joint_torque_Nm: motor.R, motor.J, motor.b cannot be "
                                       "identified"),
], ids=["unknown weight", "misspelt weight", "weight not a number", "hold out none", "signal that sees none"])
@pytest.mark.slow
def test_fit_options_are_checked(extra, message, bench_set, tmp_path, capsys):
    err = _fails(["fit", str(bench_set), "--out", str(tmp_path / "fit"), *extra], capsys, message)
    assert "inf" not in err.replace("infinite", "")


def test_diagnose_refuses_no_effects(bench_set, tmp_path, capsys):
    _fails(["diagnose", str(bench_set), "--out", str(tmp_path / "d"), "--max-effects", "0"], capsys,
           "--max-effects takes a whole number >= 1, got '0'")


@pytest.mark.parametrize("model", ["ankle", "servo_pendulum"])
def test_a_json_that_would_replace_the_report_is_refused(model, tmp_path, capsys):
    """``--json OUT/report.md`` replaced the markdown report while the command said ``report: OUT/report.md``;
    refused before any work (the data folder is not even read), naming the option and a name that works."""
    out = tmp_path / "o"
    argv = ["diagnose", str(tmp_path / "data"), "--out", str(out), "--json", str(out / "report.md")]
    if model != "ankle":
        argv += ["--model", model]
    _fails(argv, capsys, f"--json {out / 'report.md'}: inside --out {out}, where the report writes")
    assert not out.exists()


@pytest.mark.slow
def test_a_run_that_stops_half_way_leaves_no_earlier_report_beside_its_files(bench_set, tmp_path, monkeypatch,
                                                                             capsys):
    """A fit into a folder that holds an earlier run, stopped after its first new file: the earlier report.md (the
    folder's completion mark) is gone, so the folder says it is incomplete instead of looking complete."""
    from acausal.models.bench import fit_report

    out = tmp_path / "fit"
    assert main(["fit", str(bench_set), "--out", str(out)]) == 0
    earlier = (out / "report.md").read_text()
    assert "motor.R" in earlier

    def stops(folder, *args, **kwargs):
        (folder / "calibration.csv").write_text("parameter,value\nmotor.R,0.899\n")
        raise KeyboardInterrupt
    monkeypatch.setattr(fit_report, "fit_outputs", stops)
    with pytest.raises(KeyboardInterrupt):
        main(["fit", str(bench_set), "--out", str(out)])
    assert not (out / "report.md").exists() and (out / "calibration.csv").exists()


def test_export_without_a_compiler_names_the_commands_own_options(tmp_path, monkeypatch, capsys):
    """Without a C compiler the command's remedy is its own options (``--compiler``, ``--no-binary``), not the
    Python call's ``compiler=`` / ``binary=False``; with ``--no-binary`` the source FMU is written."""
    monkeypatch.setenv("CC", "/nonexistent/cc")
    err = _fails(["export", "tests.drive_models:MotorGearLoad", "--fmu", str(tmp_path / "m.fmu")], capsys,
                 "export with --no-binary for a source-only FMU")
    assert "binary=False" not in err and "compiler=" not in err
    assert main(["export", "tests.drive_models:MotorGearLoad", "--fmu", str(tmp_path / "m.fmu"), "--no-binary"]) == 0
    assert (tmp_path / "m.fmu").stat().st_size > 1000
