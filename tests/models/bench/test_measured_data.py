"""The recording format's loader (every error names file and column/key), the virtual bench
(deterministic), calibration recovering known parameters, the design map and its executors."""
import json
import shutil

import numpy as np
import pytest

from acausal import DataError
from acausal.identify import load_recording, load_recordings
from acausal.models.bench import calibration, design
from acausal.models.bench import virtual as bench
from acausal.models.bench.recording_format import ANKLE_FORMAT

SLOW = [bench.BenchCondition(P, T, strides=4) for P in (0.005, 0.011, 0.018) for T in (2.5, 3.0)]


@pytest.fixture(scope="module")
def clean_set(tmp_path_factory):
    """Six recordings whose truth has exactly the model's structure (seeded sensor noise, 14-bit encoders)."""
    out = tmp_path_factory.mktemp("clean")
    bench.run_bench(out, SLOW, seed=7)
    return out


@pytest.fixture
def one(tmp_path, clean_set):
    """A copy of one recording to break."""
    for ext in ("csv", "json"):
        shutil.copy(clean_set / f"P05.0mm_T3.0s.{ext}", tmp_path / f"rec.{ext}")
    return tmp_path / "rec.csv"


def _rewrite_csv(path, fn):
    lines = path.read_text().splitlines()
    path.write_text("\n".join(fn(lines)) + "\n")


def _edit_json(path, fn):
    meta = json.loads(path.with_suffix(".json").read_text())
    fn(meta)
    path.with_suffix(".json").write_text(json.dumps(meta))


def _error(path, strict=False):
    with pytest.raises(DataError) as e:
        load_recording(path, ANKLE_FORMAT, strict=strict)
    return str(e.value)


# ---------------------------------------------------------------------------------------------- loader errors
@pytest.mark.slow
def test_round_trip(one):
    rec = load_recording(one, ANKLE_FORMAT)
    assert len(rec) == 12000 and rec.meta["stride_time_s"] == 3.0 and rec.meta["strides"] == 4
    assert np.all(np.diff(rec.t) > 0)


def test_missing_column(one):
    _rewrite_csv(one, lambda ls: [",".join(x.split(",")[:-1]) for x in ls])
    msg = _error(one)
    assert "rec.csv" in msg and "'motor_current_A'" in msg and "missing" in msg


def test_misspelled_column(one):
    _rewrite_csv(one, lambda ls: [ls[0].replace("joint_torque_Nm", "joint_torqe_Nm")] + ls[1:])
    msg = _error(one)
    assert "rec.csv" in msg and "'joint_torque_Nm'" in msg and "'joint_torqe_Nm'" in msg


def test_unknown_unit(one):
    _rewrite_csv(one, lambda ls: [ls[0].replace("time_s", "time_ms")] + ls[1:])
    msg = _error(one)
    assert "rec.csv" in msg and "'time_ms'" in msg and "unit 'ms'" in msg


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_non_finite_value(one, bad):
    def put(ls):
        f = ls[10].split(",")
        f[4] = bad
        ls[10] = ",".join(f)
        return ls
    _rewrite_csv(one, put)
    msg = _error(one, strict=True)
    assert "rec.csv" in msg and "line 11" in msg and "'joint_torque_Nm'" in msg
    rec = load_recording(one, ANKLE_FORMAT)  # screened: the cell masked and named, its value repaired
    [m] = rec.masked
    assert (m.line, m.column, m.kind) == (11, "joint_torque_Nm", "not a number")
    assert rec.masks["joint_torque_Nm"].sum() == 1 and np.isfinite(rec["joint_torque_Nm"]).all()


def test_not_a_number(one):
    def put(ls):
        f = ls[5].split(",")
        f[7] = "1.2A"
        ls[5] = ",".join(f)
        return ls
    _rewrite_csv(one, put)
    msg = _error(one)
    assert "rec.csv" in msg and "line 6" in msg and "'motor_current_A'" in msg and "'1.2A'" in msg


@pytest.mark.parametrize("kind,word", [("dup", "duplicated"), ("back", "goes back")])
def test_time_not_increasing(one, kind, word):
    def put(ls):
        f = ls[20].split(",")
        g = ls[19].split(",")
        f[0] = g[0] if kind == "dup" else str(float(g[0]) - 0.5)
        ls[20] = ",".join(f)
        return ls
    _rewrite_csv(one, put)
    msg = _error(one, strict=True)
    assert "rec.csv" in msg and "line 21" in msg and "'time_s'" in msg and word in msg
    rec = load_recording(one, ANKLE_FORMAT)  # screened: the row left out and named
    [m] = rec.masked
    assert (m.line, m.column, m.kind) == (21, "time_s", "time") and len(rec) == 11999
    assert ("repeats" if kind == "dup" else "goes back") in m.why and np.all(np.diff(rec.t) > 0)


def test_json_missing_key(one):
    _edit_json(one, lambda m: m.pop("spring_stiffness_N_per_m"))
    msg = _error(one)
    assert "rec.json" in msg and "'spring_stiffness_N_per_m'" in msg and "missing" in msg


@pytest.mark.parametrize("value", [0, -0.002])
def test_json_non_positive(one, value):
    _edit_json(one, lambda m: m.update(precompression_m=value))
    msg = _error(one)
    assert "rec.json" in msg and "'precompression_m'" in msg and "positive" in msg


def test_json_unknown_and_wrong_type(one):
    _edit_json(one, lambda m: m.update(stride_time=2.0))
    msg = _error(one)
    assert "rec.json" in msg and "'stride_time'" in msg and "'stride_time_s'" in msg
    _edit_json(one, lambda m: (m.pop("stride_time"), m.update(body_mass_kg="60")))
    msg = _error(one)
    assert "rec.json" in msg and "'body_mass_kg'" in msg and "number" in msg


def test_unpaired_files(one):
    one.with_suffix(".json").rename(one.parent / "other.json")
    with pytest.raises(DataError) as e:
        load_recordings(one.parent, ANKLE_FORMAT)
    msg = str(e.value)
    assert ("rec.csv" in msg and "rec.json" in msg) or ("other.json" in msg and "other.csv" in msg)


# ---------------------------------------------------------------------------------------------- bench
def test_bench_is_deterministic_and_quantised(tmp_path, clean_set):
    bench.run_bench(tmp_path, SLOW[:1], seed=7)
    assert (tmp_path / "P05.0mm_T2.5s.csv").read_bytes() == (clean_set / "P05.0mm_T2.5s.csv").read_bytes()
    rec = load_recording(tmp_path / "P05.0mm_T2.5s.csv", ANKLE_FORMAT)
    step = 2 * np.pi / 2**14
    phi = rec["moment_arm_angle_rad"]
    assert np.allclose(phi / step, np.round(phi / step), atol=1e-6)  # 14-bit encoder readings
    assert np.allclose(np.diff(rec.t), 1e-3)  # 1 kHz
    assert "simulated" in rec.meta["description"]


def test_bench_command_line_body_mass_and_bad_input(tmp_path, capsys):
    """``acausal bench --body-mass`` records a heavier user (more torque, more current); bad input exits 2 naming
    the option or effect at fault."""
    from acausal.cli import main
    assert main(["bench", "--out", str(tmp_path / "x"), "--body-mass", "-5"]) == 2
    assert "--body-mass" in capsys.readouterr().err
    assert main(["bench", "--out", str(tmp_path / "x"), "--effect", "gear_rust=1"]) == 2
    assert "gear_rust" in capsys.readouterr().err
    light, heavy = (bench.record(bench.BenchCondition(0.011, 2.5, strides=1, body_mass=m), seed=1) for m in (60, 100))
    assert heavy[1]["body_mass_kg"] == 100.0 and light[1]["body_mass_kg"] == 60.0
    rms = [np.sqrt(np.mean(cols["motor_current_A"] ** 2)) for cols, _ in (light, heavy)]
    assert rms[1] > 1.3 * rms[0]


@pytest.mark.slow
def test_bench_records_the_component_chain_of_a_preset(tmp_path, capsys):
    """``chain``: the truth is the whole chain with a preset's values (driver, gear and linkage losses), not Eq. 4:
    its driver's constant draw alone takes more from the supply than the Eq. 4 truth's ideal driver gives away."""
    from acausal import ModelError
    from acausal.cli import main
    from acausal.models.ankle.presets import preset
    cond = bench.BenchCondition(0.008, 2.0, strides=1)
    eq4, chain = (bench.record(cond, seed=1, chain=c)[0] for c in (None, "paper_fit"))
    power = [np.mean(c["supply_current_A"] * c["supply_voltage_V"]) for c in (eq4, chain)]
    assert power[1] - power[0] > preset("paper_fit")["driver.P_q"]
    bench.run_bench(tmp_path / "rec", [cond], seed=1, chain="paper_fit", executor="serial")
    assert "preset `paper_fit`" in (tmp_path / "rec" / "README.md").read_text()
    with pytest.raises(DataError, match="winding_temperature"):  # hidden effects are parts of the Eq. 4 truth
        bench.run_bench(tmp_path / "a", [cond], effects={"winding_temperature": 1e-3}, chain="paper_fit")
    with pytest.raises(ModelError, match="paper_fit"):  # an unknown preset lists the known ones
        bench.run_bench(tmp_path / "b", [cond], chain="paper_fitt")
    assert not (tmp_path / "b").exists()
    assert main(["bench", "--out", str(tmp_path / "c"), "--chain", "paper_fit", "--session", "5"]) == 2
    assert "--session" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------- calibration
@pytest.mark.slow
def test_calibration_recovers_truth(clean_set):
    cal, exps = calibration.fit(clean_set, "R,J,b")
    truth = bench.TRUTH
    for name in ("motor.R", "motor.J", "motor.b"):
        assert abs(cal.values[name] / truth[name] - 1) < 0.05, (name, cal.values[name])
        assert cal.std[name] < 0.05 * truth[name]
    floor = bench.Sensors().noise_floor()
    for s in calibration.DEFAULT_SIGNALS:
        assert cal.rmse(s, "test") < 1.10 * floor[s], (s, cal.rmse(s, "test"), floor[s])
    # and the datasheet start was measurably worse
    before = calibration.rmse_before_after(exps, cal)
    assert before["datasheet"]["motor_current_A"] > 2 * before["calibrated"]["motor_current_A"]


@pytest.mark.slow
def test_calibration_bad_parameter_and_bounds(clean_set):
    with pytest.raises(DataError, match="unknown parameter 'Rx'"):
        calibration.fit(clean_set, "Rx")
    with pytest.raises(DataError, match="outside its bounds"):
        calibration.fit(clean_set, "R", start={"motor.R": 100.0})


# ---------------------------------------------------------------------------------------------- design
@pytest.mark.slow
def test_design_energy_balance_and_bounds():
    """The design map's chain (paper_fit: gear, driver and linkage losses): per stride, source energy = output +
    every loss of the model's accounts (stored energies are periodic); and it agrees with the protocol's run at the
    Table 1 point to within the lab supply's internal-resistance loss."""
    r = design.evaluate_designs(np.array([130e3, 80e3]), np.array([0.007, 0.012]), 2.0)
    assert np.all((r["efficiency"] > 0) & (r["efficiency"] < 1))
    sim = design.chain_model()
    given, values = design.design_params("paper_fit", {"link.k": 130e3, "P_nominal": 0.007, "stride_time": 2.0})
    d = design.plan_designs(np.array([130e3]), np.array([0.007]), 2.0, values, n=4000)
    th = design.PeriodicSplineBatch(d.t, d.theta[:, None], 2.0)
    ph = design.PeriodicSplineBatch(d.t, d.phi.T, 2.0)
    acc = sim.accounts
    names = ["P_source.P", "P_output.P", *acc.losses]
    v = sim.evaluate(d.t, params=given, names=names, inputs={"ankle.phi_ref": th, "arm_target.signal": ph})
    E = {n: float(np.mean(v[n]) * 2.0) for n in names}
    assert E["link.loss_power"] > 0.05 * E["P_output.P"] and E["planetary.loss_power"] > 0
    balance = E["P_source.P"] - E["P_output.P"] - sum(E[n] for n in acc.losses)
    assert abs(balance) < 1e-6 * E["P_source.P"]
    from acausal.models.ankle.protocol import Condition, run_condition
    full = run_condition(Condition(0.008, 2.0, preset="paper_fit"))
    one = design.evaluate_designs(np.array([132e3]), np.array([0.008]), 2.0)
    assert one["E_output_J"][0] == pytest.approx(full.energy["output"], rel=1e-3)
    assert one["E_source_J"][0] == pytest.approx(full.energy["source"], rel=0.02)


@pytest.mark.slow
def test_design_map_dask_equals_in_process():
    distributed = pytest.importorskip("distributed")
    ks, Ps = np.array([60e3, 130e3, 200e3]), np.array([0.004, 0.008, 0.014])
    serial = design.efficiency_map(2.0, ks=ks, Ps=Ps, executor="serial")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc, \
            distributed.Client(lc) as client:
        remote = design.efficiency_map(2.0, ks=ks, Ps=Ps, executor=client.get_executor(), tasks=3)
    # the workers compile the model themselves, under another PYTHONHASHSEED: sympy's term order (and so the
    # order of floating-point operations in the generated code) may differ in the last bit, nothing more
    for key in serial.values:
        np.testing.assert_allclose(serial.values[key], remote.values[key], rtol=1e-12, atol=1e-300)
    assert np.isfinite(serial.values["efficiency"]).all()


def test_a_header_with_quoted_names_is_read(one):
    """Spreadsheets quote the names of a CSV's header ("time_s",...): they said "'time_s' is missing"."""
    plain = load_recording(one, ANKLE_FORMAT)
    _rewrite_csv(one, lambda ls: [",".join(f'"{h}"' for h in ls[0].split(","))] + ls[1:])
    quoted = load_recording(one, ANKLE_FORMAT)
    assert quoted.t.tobytes() == plain.t.tobytes() and len(quoted) == len(plain)
