"""The servo on a pendulum: components (pendulum, friction laws, servo), the recording adapter, the closed-loop
replay against BAM's published numbers, a hidden-effect diagnosis on another servo, and the shipped example."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from acausal import DataError, ModelError, Model, compile_model, connect
from acausal.results.energy import balance
from acausal.identify import load_recordings
from acausal.identify.recordings import write_recording
from acausal.library.friction import (CoulombViscousFriction, DirectionalFriction, GearFriction,
                                      LoadDependentFriction, StribeckFriction)
from acausal.library.rotational import Inertia, Pendulum, TorqueSource


# ------------------------------------------------------------------------------------------------ components
class FreePendulum(Model):
    def build(self):
        self.p = Pendulum(m=0.49, l=0.1, m_arm=0.05, phi0=0.0)


def test_pendulum_small_angle_period_and_energy():
    """Small swings: T = 2 pi sqrt(J / ((m + m_arm/2) g l)) with J = (m + m_arm/3) l^2; energy constant."""
    cm = compile_model(FreePendulum())
    res = cm.simulate(3.0, starts={"p.phi": 0.01, "p.w": 0.0}, rtol=1e-10, atol=1e-12, n_points=30001)
    phi = np.asarray(res["p.phi"])
    t = np.asarray(res.t)
    up = np.flatnonzero((phi[:-1] < 0) & (phi[1:] >= 0))
    crossings = t[up] - phi[up] * (t[up + 1] - t[up]) / (phi[up + 1] - phi[up])
    period = np.mean(np.diff(crossings))
    m, ma, l, g = 0.49, 0.05, 0.1, 9.80665
    expected = 2 * math.pi * math.sqrt((m + ma / 3) * l**2 / ((m + ma / 2) * g * l))
    assert period == pytest.approx(expected, rel=2e-5)  # sin(0.01) ~ 0.01: the amplitude error is 6e-6
    e = np.asarray(res["p.energy"])
    assert np.ptp(e) < 1e-6 * e[0]  # conservative: only the integrator drifts


class Pushed(Model):
    """An inertia pushed by a constant torque through a friction law to the ground."""

    def __init__(self, law, torque, **kw):
        self._law, self._torque = law, torque  # (class, parameters) of the law
        super().__init__(**kw)

    def build(self):
        self.src = TorqueSource(tau=self._torque)
        self.friction = self._law[0](**self._law[1])
        self.J = Inertia(J=1e-3)
        connect(self.src.flange, self.friction.flange_a)
        connect(self.friction.flange_b, self.J.flange_a)


def _push(law, torque, t_end=0.2):
    cm = compile_model(Pushed(law, torque))
    return cm.simulate(t_end, rtol=1e-9, atol=1e-12, n_points=201, method="LSODA")


@pytest.mark.parametrize("law, torque, sticks, slip_budget", [
    ((CoulombViscousFriction, dict(tau_c=0.05)), 0.04, True, None),
    ((CoulombViscousFriction, dict(tau_c=0.05)), 0.08, False, 0.05),
    ((StribeckFriction, dict(tau_c=0.05, tau_s=0.04, w_s=0.5)), 0.08, True, None),  # below breakaway 0.09
    ((StribeckFriction, dict(tau_c=0.05, tau_s=0.04, w_s=0.5)), 0.10, False, 0.05),  # slides; budget -> tau_c
    ((LoadDependentFriction, dict(tau_c=0.05, k_l=0.6)), 0.10, True, None),  # budget 0.05 + 0.06 > 0.10
    ((LoadDependentFriction, dict(tau_c=0.05, k_l=0.4)), 0.10, False, 0.09),  # budget 0.09 < 0.10
])
def test_friction_laws_stick_and_slip(law, torque, sticks, slip_budget):
    """Analytic stick/slip: below its budget the shaft creeps slower than about w_c (stiction of the smooth law);
    above it, it accelerates at (torque - budget) / J once the speed is well above w_s and w_c."""
    res = _push(law, torque)
    w = np.asarray(res["J.w"])
    a = np.asarray(res["J.a"])
    if sticks:
        assert np.max(np.abs(w)) < 3 * 0.01
    else:
        assert a[-1] == pytest.approx((torque - slip_budget) / 1e-3, rel=1e-3)
    assert np.min(np.asarray(res["friction.loss_power"])) >= -1e-15


def test_directional_friction_more_while_backdriven():
    """A shaft spinning forward against a braking torque at flange_a is back-driven (power flows b -> a): the
    budget is tau_c + (k_l + k_b) |tau|; while driven it is tau_c + k_l |tau|."""
    for torque, k_sum in ((-0.1, 0.5), (0.1, 0.2)):
        cm = compile_model(Pushed((DirectionalFriction, dict(tau_c=0.02, k_l=0.2, k_b=0.3)), torque))
        res = cm.simulate(0.005, starts={"J.w": 50.0}, rtol=1e-10, atol=1e-12, n_points=3, method="LSODA")
        budget = float(np.asarray(res["friction.budget"])[-1])
        assert budget == pytest.approx(0.02 + k_sum * 0.1, rel=1e-6)


def test_friction_terms_are_checked():
    with pytest.raises(ModelError, match="terms"):
        GearFriction(terms=("coulomb", "quadratic"))


@pytest.mark.slow
def test_servo_pendulum_energy_balance_with_friction():
    """Supply energy = winding + friction losses + change of the pendulum's and the rotor's energy (rel. 1e-6),
    over a replay of a real recording with every friction term switched on."""
    from acausal.models.servo.model import compiled
    from acausal.models.servo.recording_format import inputs, rig_params, start
    rec = _xl330()[5]
    cm = compiled(("coulomb", "stribeck", "load", "backdrive"))
    params = {**rig_params(rec.meta), "servo.friction.tau_s": 0.01, "servo.friction.k_l": 0.2,
              "servo.friction.k_b": 0.1}
    res = cm.simulate(rec.t[-1], t_start=rec.t[0], params=params, inputs=inputs(rec), starts=start(rec),
                      rtol=1e-10, atol=1e-12, n_points=20001, method="LSODA")
    b = balance(res, cm.accounts)
    assert b.delivered > 0.5
    assert abs(b.residual) < 1e-6, b.table()
    assert set(b.losses) >= {"servo.winding.loss_power", "servo.friction.loss_power"}


# ------------------------------------------------------------------------------------------------ adapter
def _xl330():
    import importlib.resources as r
    from acausal.models.servo.recording_format import SERVO_FORMAT
    return load_recordings(str(r.files("acausal.models.servo").joinpath("data/xl330/recordings")), SERVO_FORMAT)


def _copy_one(tmp_path, edit_json=None, drop_column=None):
    src = _xl330()[0].path
    dst = tmp_path / src.name
    text = src.read_text()
    if drop_column:
        lines = text.splitlines()
        header = lines[0].split(",")
        k = header.index(drop_column)
        text = "\n".join(",".join(f for j, f in enumerate(line.split(",")) if j != k) for line in lines) + "\n"
    dst.write_text(text)
    meta = json.loads(src.with_suffix(".json").read_text())
    if edit_json:
        edit_json(meta)
    dst.with_suffix(".json").write_text(json.dumps(meta))
    return dst


def test_adapter_notes_unknown_keys_and_null_arm_mass():
    rec = _xl330()[0]
    assert rec.meta["kp"] == 100 and rec.meta["controller.error_gain_per_rad"] == pytest.approx(0.0028774, rel=1e-4)
    assert "arm_mass_kg" not in rec.meta
    assert any("'arm_mass_kg' is null" in n for n in rec.notes)
    assert any("'source_repo'" in n and "ignored" in n for n in rec.notes)


def test_adapter_missing_column_is_named(tmp_path):
    from acausal.models.servo.recording_format import SERVO_FORMAT
    path = _copy_one(tmp_path, drop_column="goal_position_rad")
    with pytest.raises(DataError, match=r"required column 'goal_position_rad'.*missing") as e:
        load_recordings(tmp_path, SERVO_FORMAT)
    assert path.name in str(e.value)


def test_adapter_missing_nested_key_is_named(tmp_path):
    from acausal.models.servo.recording_format import SERVO_FORMAT
    path = _copy_one(tmp_path, edit_json=lambda m: m["controller"].pop("error_gain_per_rad"))
    with pytest.raises(DataError, match=r"required key 'controller.error_gain_per_rad'") as e:
        load_recordings(tmp_path, SERVO_FORMAT)
    assert path.with_suffix(".json").name in str(e.value)


def test_split_holds_out_the_middle_gain_and_checks_values():
    from acausal.models.servo.problem import Split
    recs = _xl330()
    mask, text = Split().held_out(recs)
    assert {r.meta["kp"] for r, m in zip(recs, mask) if m} == {400}
    assert "kp = 400" in text and mask.sum() == 4
    mask, text = Split("trajectory", "sin_sin").held_out(recs)
    assert all(r.meta["trajectory_name"] == "sin_sin" for r, m in zip(recs, mask) if m) and mask.sum() == 4
    with pytest.raises(DataError, match="no recording has kp = 300"):
        Split("kp", 300).held_out(recs)


# ------------------------------------------------------------------------------------------------ replay
def test_bam_m1_replayed_here_agrees_with_bams_simulator():
    """BAM's published m1 set on the 16 logs: 0.0819 rad with BAM's simulator (the data set's README); this
    model (continuous, smooth Coulomb law) must land within 5 % of it."""
    from acausal.models.servo import bam
    rec = bam.published()
    per = bam.replay_set(_xl330(), "main m1", rec["sets"]["main m1"])
    assert np.mean(list(per.values())) == pytest.approx(rec["bam_replay_mae_rad"]["main m1"], rel=0.05)


# ------------------------------------------------------------------------------------------------ hidden effect
#: another servo: stronger motor, higher supply, its own error gain; its gearbox has load-dependent friction
OTHER = {"servo.kt": 0.9, "servo.R": 6.0, "servo.armature": 0.004, "pendulum.phi0": 0.01, "servo.tau_c": 0.02,
         "servo.d": 0.01, "servo.friction.k_l": 0.3}
OTHER_GAIN, OTHER_SUPPLY, STEP = 0.004, 12.0, 2 * math.pi / 4096


def _other_servo_recordings(folder, seed=3, trajectories=("sin_sin", "up_and_down")):
    """Simulated recordings of OTHER (4 gains x 2 trajectories, 3 s, ~200 Hz with jitter) with quantised
    positions, supply-voltage noise in 0.1 V steps, and the JSON keys a real log has (plus unknown ones)."""
    from acausal.models.servo.model import compiled
    from acausal.models.servo.recording_format import SERVO_FORMAT, inputs_from
    rng = np.random.default_rng(seed)
    cm = compiled(("coulomb", "load"))
    for kp in (150, 300, 600, 1200):
        for traj in trajectories:
            t = np.cumsum(rng.uniform(0.0045, 0.0060, 560))
            t = t[t <= 3.0]
            goal = (np.sin(t) * np.pi / 2 + 0.5 * np.sin(5 * t) * np.sin(2 * t) if traj == "sin_sin"
                    else np.where(t < 1.5, np.pi / 2 * (3 * (t / 1.5) ** 2 - 2 * (t / 1.5) ** 3), np.pi / 2))
            volts = np.round((OTHER_SUPPLY + rng.normal(0, 0.05, t.size)) * 10) / 10
            columns = {"goal_position_rad": goal, "input_voltage_V": volts, "torque_enable": np.ones_like(t)}
            params = {"servo.kp": kp, "servo.error_gain": OTHER_GAIN, "pendulum.m": 0.6, "pendulum.l": 0.12,
                      "pendulum.m_arm": 0.0, **OTHER}
            res = cm.simulate(t[-1], t_start=t[0], t_eval=t, params=params, inputs=inputs_from(t, columns),
                              starts={"pendulum.phi": 0.0, "pendulum.w": 0.0}, method="LSODA", rtol=1e-8, atol=1e-10)
            pos = np.round(np.asarray(res["pendulum.phi"]) / STEP) * STEP
            meta = {"kp": kp, "controller": {"error_gain_per_rad": OTHER_GAIN, "vendor_note": "simulated"},
                    "mass_kg": 0.6, "arm_length_m": 0.12, "arm_mass_kg": None, "trajectory_name": traj,
                    "actuator": "a simulated servo", "rig": {"type": "pendulum"}}
            write_recording(folder, f"other_kp{kp}_{traj}", {"time_s": t, "position_rad": pos, **columns}, meta,
                            SERVO_FORMAT)


@pytest.mark.slow
def test_hidden_load_friction_is_named_on_another_servo(tmp_path):
    """The CLI, unchanged, on recordings of a different servo (own gain, supply, rig) with load-dependent friction
    hidden in the truth: it names `load`, recovers k_l, and its held-out MAE beats the baseline's."""
    from acausal.cli import main
    data = tmp_path / "other"
    _other_servo_recordings(data)
    out = tmp_path / "out"
    assert main(["diagnose", str(data), "--model", "servo_pendulum", "--out", str(out), "--json",
                 str(out / "v.json"), "--candidates", "stribeck,load", "--max-effects", "1", "--no-progress"]) == 0
    v = json.loads((out / "v.json").read_text())
    assert v["cause"] == "load"
    assert v["extended"]["params"]["servo.friction.k_l"] == pytest.approx(OTHER["servo.friction.k_l"], rel=0.1)
    ho = v["heldout"]
    assert ho["signal"] == "position_rad" and ho["metric"] == "mae" and ho["unit"] == "rad"
    assert "kp = 600" in ho["split"]
    assert ho["extended"] < 0.5 * ho["baseline"]
    assert ho["extended"] < 3 * STEP  # back to the quantisation level
    assert (out / "report.md").exists()


# ------------------------------------------------------------------------------------------------ example
@pytest.mark.slow
def test_servo_example_writes_its_report(tmp_path):
    """The shipped example's code path (diagnosis, BAM replays, report) on four short simulated recordings of the
    other servo (the full XL330 run takes minutes: ``python examples/servo_friction.py``): it names the load law
    and writes every section of the report and its figures."""
    import importlib.util
    from acausal.models.servo.recording_format import SERVO_FORMAT
    script = Path(__file__).resolve().parent.parent.parent.parent / "examples" / "servo_friction.py"
    spec = importlib.util.spec_from_file_location("servo_friction", script)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    _other_servo_recordings(tmp_path / "data", trajectories=("sin_sin",))
    recs = load_recordings(tmp_path / "data", SERVO_FORMAT)
    res = mod.main(tmp_path, recordings=recs, candidates=["load"], max_effects=1, jobs=2)
    assert res["causes"] == ["load"]
    assert res["heldout"]["extended"] < 0.5 * res["heldout"]["baseline"]
    text = (tmp_path / "servo_friction" / "report.md").read_text()
    for part in ("Verdict: `load`", "What the calibrated baseline gets wrong", "Per phase", "BAM main m1",
                 "What these data cannot show"):
        assert part in text
    for fig in res["figures"]:
        assert fig.exists()
    assert json.loads((tmp_path / "servo_friction" / "diagnosis.json").read_text())["heldout"]["metric"] == "mae"


def test_the_evidence_table_says_why_a_candidate_was_not_refitted():
    """A candidate left out of the refits by the ranking is not called weak: the table says which limit left it
    out, and marks its scores as the linearised step's."""
    from acausal.identify.verdict import CandidateScore
    from acausal.models.servo.problem import ServoProblem

    def _not_refitted(score, problem):  # what the servo report's evidence table writes
        return score.refit_note(problem.max_refits)

    def score(why, failed=""):
        return CandidateScore("gain_error", "servo.gain_error.s", 0.1, float("nan"), {}, 0.076, 0.076, float("nan"),
                              -10.0, {}, screened=True, why_screened=why, failed=failed)

    assert _not_refitted(score("ranked"), ServoProblem) == "not refitted (beyond the 4 most promising)"
    assert _not_refitted(score("weak"), ServoProblem) == "not refitted (fingerprint too weak)"
    assert _not_refitted(score("failed", "R left its range"), ServoProblem) == "refit failed: R left its range"
