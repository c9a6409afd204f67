"""Diagnosis of the ankle actuator's Eq. (4) model against bench recordings (``acausal diagnose``).

The baseline is the paper's Eq. (4) model (:meth:`AnkleActuator.eq4
<acausal.models.ankle.actuator.AnkleActuator.eq4>` without effects: DC motor R, L, k, J, b, ideal gear n = 860,
MACCEPA at the nominal precompression, ideal PWM driver behind the non-regenerative rectifier, ideal sensors),
calibrated on R, J and b. The candidates are the effects of :mod:`acausal.models.ankle.effects`, each a change of the
model made with library components. The engine (:mod:`acausal.identify.diagnose`) fits, scores and chooses; this
module says what the experiments, the baseline parameters and the regressors of the residual analysis are for this
actuator:

* signals: motor current, supply current and joint torque (each in units of its sensor noise);
* regressors: sign of the motor speed, motor speed, |transmitted torque| (gear output), motor current squared,
  elapsed time, sign of the driver's output power, joint torque, all from the calibrated model's replay;
* a session (every recording's JSON has ``session_time_s``): recordings in the order they were made, the drift check
  against elapsed session time, and the winding candidate's temperature carried from one recording to the next
  (:mod:`~acausal.models.bench.session`).
"""
from __future__ import annotations

import numpy as np

from acausal.identify import load_recordings
from acausal.identify.calibrate import Free
from acausal.identify.diagnose import Diagnosis, Problem, Thresholds, diagnose, residual_analysis

from .calibration import Split, exact_sensitivity, experiment, free_parameter, replay_inputs, replay_model
from ..ankle.actuator import WINDING_G
from ..ankle.presets import N_TOTAL
from ..ankle.effects import EFFECTS
from .recording_format import ANKLE_FORMAT
from .session import carry_winding, check_session, free_winding_starts, is_session, own_start, replay_params

DIAGNOSIS_SIGNALS = ("motor_current_A", "supply_current_A", "joint_torque_Nm")
BASELINE_PARAMS = ("motor.R", "motor.J", "motor.b")

CANDIDATES = EFFECTS  # an effect record is the diagnosis's candidate

#: speed [rad/s] and power [W] scales of the smooth sign regressors (tanh(x / scale))
_SIGN_SPEED, _SIGN_POWER = 5.0, 1.0


class AnkleProblem(Problem):
    """The ankle actuator's recordings as a diagnosis problem."""

    candidates = CANDIDATES
    #: a resistance that rises from recording to recording is a winding warming over the session
    drift_causes = {"motor.R": ("winding_temperature",)}

    def confirm(self, candidate: str, exps) -> str:
        if candidate == "winding_temperature" and not is_session(self.recordings):
            return ("the recordings do not say when each was made (JSON session_time_s): each got its own start "
                    "temperature, and the warming did not pass the tests that way; record session_time_s to carry "
                    "the temperature from one recording to the next")
        return super().confirm(candidate, exps)

    def __init__(self, recordings, split: Split = Split(), signals=DIAGNOSIS_SIGNALS, baseline=BASELINE_PARAMS,
                 exact: bool = True, strict: bool = False):
        if not isinstance(recordings, (list, tuple)):  # a folder: screened unless strict
            recordings = load_recordings(recordings, ANKLE_FORMAT, strict)
        self.recordings = list(recordings)
        self.left_out = list(getattr(recordings, "left_out", []))  # too damaged to use, with why
        check_session(self.recordings)
        if is_session(self.recordings):  # a session: in the order it was recorded
            self.recordings.sort(key=lambda r: r.meta["session_time_s"])
        self.split = split
        self.signals = list(signals)
        self.baseline = list(baseline)
        self.exact = exact
        self._cache: dict = {}
        self._inputs = None  # the recordings' smoothed motions, made on first use

    def experiments(self, effects: tuple) -> list:
        key = tuple(sorted(effects))
        if key not in self._cache:
            if self._inputs is None:  # smoothed once per recording, shared by every candidate
                self._inputs = [replay_inputs(r, self.split) for r in self.recordings]
            exps = [experiment(r, key, self.split, inputs=u) for r, u in zip(self.recordings, self._inputs)]
            if self.exact:
                cm = replay_model(key)
                for e in exps:
                    e.sensitivity = exact_sensitivity(cm, e)
            if "winding_temperature" in key and is_session(self.recordings):  # warm from the recording before
                carry_winding(exps, replay_model(key))
            elif "winding_temperature" in key:  # no session times: each recording's own start temperature
                free_winding_starts(exps)
            self._cache[key] = exps
        return self._cache[key]

    def base_free(self, start: dict) -> list:
        return [free_parameter(n, start) for n in self.baseline]

    def effect_free(self, effects: tuple, start: dict, drift: bool = False) -> list:
        """With the winding candidate: the temperatures above ambient [K] (0-100 K, from 0) that nobody recorded,
        fitted with the rest. A lone recording that is no session (no ``session_time_s``) starts at an unknown
        temperature (strides to settle the controller, a warm-up before): its start is fitted in every step. When
        the candidate is tried on a drift over several recordings that do not form a session, every recording's
        start (they may be one unrecorded session) and the motor's conductance to ambient ``winding_G`` (from the
        datasheet's 1/7.61 W/K, within a thermal resistance of 1-40 K/W). A session starts cold (its first
        recording at ambient; :mod:`.session`). In the per-sample step the conductance stays at the datasheet's (a
        warming a single recording shows is set by the heating, the slow cooling hardly moves it; fitting both
        there costs half the diagnosis's time again) and several recordings that are no session start at ambient
        (a free start per recording would let the candidate absorb any change from one to the next)."""
        if "winding_temperature" not in effects:
            return []
        session = is_session(self.recordings)
        out = []
        if drift:
            g = float(np.clip(start.get("winding_G", WINDING_G), 1 / 40, 1.0))
            out.append(Free("winding_G", g, 1 / 40, 1.0, 0.1))
        names = [] if session else [own_start(r.name) for r in self.recordings]
        if not drift and len(self.recordings) > 1:
            names = []
        return out + [Free(n, float(np.clip(start.get(n, 0.0), 0.0, 100.0)), 0.0, 100.0, 10.0) for n in names]

    def period(self, exp) -> float:
        return float(exp.info["meta"]["stride_time_s"])

    def unit(self, name: str) -> str:
        found = replay_model(()).flat.parameters.get(name)
        return found.unit if found is not None else super().unit(name)

    def session_order(self, exps):
        """Elapsed session time at each recording's start when every recording says (JSON ``session_time_s``);
        else None (the recordings' order)."""
        if all("session_time_s" in e.info["meta"] for e in exps):
            return "elapsed session time [s]", [float(e.info["meta"]["session_time_s"]) for e in exps]
        return None

    def heldout(self) -> dict:
        return {"signal": self.signals[0], "unit": "A" if self.signals[0].endswith("_A") else "",
                "split": f"one stride in every {self.split.holdout_every} of each recording held out"}

    def regressors(self, exp, values: dict) -> dict:
        cm = replay_model(exp.info["effects"])
        v = cm.simulate(exp.t[-1], t_start=exp.t[0], t_eval=exp.t, params=replay_params(exp, values),
                        inputs=exp.info["inputs"], dense_output=False)
        w = np.asarray(v["motor.w"])
        i = np.asarray(v["motor.i"])
        return {"sign(motor speed)": np.tanh(w / _SIGN_SPEED), "motor speed": w,
                "abs(transmitted torque)": np.abs(np.asarray(v["gear.flange_b.tau"])), "motor current^2": i * i,
                "elapsed time": exp.t - exp.t[0], "sign(driver power)": np.tanh(np.asarray(v["P_driver.P"]) / _SIGN_POWER),
                "joint torque": np.asarray(v["joint_torque"])}


    def effect_reading(self, cid: str, value: float) -> str:
        """What a size of effect ``cid`` means physically, in words (joint side, spring force, ...)."""
        n = N_TOTAL
        if cid == "gear_coulomb_friction":
            return f"{value * 1e3:.3g} mN m at the motor = {value * n:.3g} N m at the gear output (x {n:g})"
        if cid == "gear_load_dependent_loss":
            return f"{100 * (1 - value):.3g} % of the transmitted torque lost in the mesh"
        if cid == "winding_temperature":
            return f"motor heat capacity {1 / value:.3g} J/K" if value > 1e-6 else "no heating"
        if cid == "driver_quiescent_power":
            return f"{value:.3g} W drawn from the supply at all times"
        if cid == "torque_sensor_offset":
            return f"{value:.3g} N m on the joint-torque reading (a sensor effect: no energy)"
        if cid == "precompression_error":
            k = self.recordings[0].meta["spring_stiffness_N_per_m"]
            return f"{value * 1e3:.3g} mm = {k * value:.3g} N of spring force"
        if cid == "gear_backlash":
            return f"{np.degrees(value):.3g} deg of play at the moment arm"
        return ""

    def effect_energy(self, fit, cid: str) -> float:
        """Supply energy per stride [J] the named effect ``cid`` of ``fit`` costs: the extended model's supply
        energy minus the same model's with the effect at its vanishing size, over all recordings' inner strides."""
        c = self.candidates[cid]
        zero = {**fit.values, c.parameter: c.zero}
        energy = strides = 0.0
        for e in fit.exps:
            inner = e.train | e.test
            a, b = e.predict(fit.values), e.predict(zero)
            p = a["supply_voltage_V"] * a["supply_current_A"] - b["supply_voltage_V"] * b["supply_current_A"]
            energy += float(np.trapezoid(p[inner], e.t[inner]))
            strides += float(e.t[inner][-1] - e.t[inner][0]) / self.period(e)
        return energy / strides


#: the seed of the re-recording that measures the replay's own error (:func:`replay_bias`)
REPLAY_CHECK_SEED = 97


def _sensors_of(recordings, scales: dict):
    """The virtual bench's sensors as the recordings show them: the encoders' step (the smallest change of the
    moment-arm angle), the sample rate and the noise levels the diagnosis measured (``scales``)."""
    from .virtual import Sensors
    steps = np.concatenate([np.abs(np.diff(r["moment_arm_angle_rad"])) for r in recordings])
    step = float(steps[steps > 1e-12].min()) if np.any(steps > 1e-12) else Sensors().encoder_step
    dt = float(np.median(np.concatenate([np.diff(r.t) for r in recordings])))
    base = Sensors()
    return Sensors(encoder_bits=int(round(np.log2(2 * np.pi / step))), rate=1.0 / dt,
                   motor_current_noise=scales.get("motor_current_A", base.motor_current_noise),
                   supply_current_noise=scales.get("supply_current_A", base.supply_current_noise),
                   torque_noise=scales.get("joint_torque_Nm", base.torque_noise))


def replay_bias(problem: AnkleProblem, d: Diagnosis, seed: int = REPLAY_CHECK_SEED, progress=None) -> dict:
    """The replay's own error on the named effects' sizes, measured by simulation, and their standard errors
    widened by it. The cluster-robust errors are built from the scatter between strides; the replay also errs the
    same way on every stride (the smoothing of quantised angles into accelerations: a backlash's size comes out
    6 % low, a Coulomb friction's 1 %, on every seed of the virtual bench), which no scatter shows. So the set is
    recorded once more by the virtual bench from the final model (its fitted values as the truth; each
    recording's precompression, stride time, strides and body mass; the recordings' encoder step, sample rate and
    noise), replayed and refitted with the same effects from the same start: the change of each named size is
    the replay's bias there, and its standard error becomes ``sqrt(se^2 + bias^2)``. Returns
    ``{parameter: {"fitted", "bias", "sandwich", "std"}}`` (empty where nothing was named, or for a session's
    warming winding, whose temperatures a re-recording does not carry); ``d.final.cal.std`` holds the widened
    errors and its ``std_method`` says so."""
    from acausal.identify.diagnose import fit_model
    from acausal.identify.recordings import Recording

    from .recording_format import ANKLE_FORMAT as FMT
    from .virtual import BODY_MASS, BenchCondition, record

    if not d.causes or "winding_temperature" in d.causes:
        return {}
    (progress or (lambda msg: None))("re-recording the set from the final model (the replay's own error)")
    fit = d.final
    effects = {cid: float(fit.values[problem.candidates[cid].parameter]) for cid in d.causes}
    truth = {n: float(fit.values[n]) for n in problem.baseline}
    sensors = _sensors_of(problem.recordings, d.scales)
    again = []
    for k, r in enumerate(problem.recordings):
        m = r.meta
        T = float(m["stride_time_s"])
        strides = int(m.get("strides") or max(1, round((r.t[-1] - r.t[0] + np.median(np.diff(r.t))) / T)))
        cond = BenchCondition(float(m["precompression_m"]), T, strides, body_mass=float(m.get("body_mass_kg", BODY_MASS)))
        cols, meta = record(cond, effects, truth, sensors, seed=seed, index=k)
        again.append(Recording(r.name, {c.name: np.asarray(cols[c.name]) for c in FMT.columns}, {**m, **meta}))
    twin = AnkleProblem(again, problem.split, problem.signals, problem.baseline, problem.exact)
    refit = fit_model(twin, tuple(d.causes), dict(fit.values), d.scales)
    out = {}
    for cid in d.causes:
        p = problem.candidates[cid].parameter
        se, bias = float(fit.cal.std.get(p, np.nan)), float(refit.values[p] - fit.values[p])
        out[p] = {"fitted": float(fit.values[p]), "bias": bias, "sandwich": se, "std": float(np.hypot(se, bias))}
        fit.cal.std[p] = out[p]["std"]
    fit.cal.std_method += ("; the named effects' errors widened by the replay's bias, measured on one re-recording "
                           "of the set by the virtual bench from the final model (sqrt(se^2 + bias^2))")
    return out


def run(recordings, split: Split = Split(), thresholds: Thresholds = Thresholds(),
        max_effects: int | None = None, candidates=None, progress=None, strict: bool = False,
        check_replay: bool = True) -> tuple:
    """Diagnose ``recordings`` (list or folder; ``strict``: a folder's samples that cannot be physical refuse it
    instead of being masked); returns ``(Diagnosis, AnkleProblem)``. ``check_replay``: the named effects' standard
    errors include the replay's own error (:func:`replay_bias`, in ``d.replay_bias``)."""
    problem = AnkleProblem(recordings, split, strict=strict)
    d = diagnose(problem, thresholds=thresholds, max_effects=max_effects, candidates=candidates, progress=progress)
    d.replay_bias = replay_bias(problem, d, progress=progress) if check_replay else {}
    return d, problem


__all__ = ["AnkleProblem", "CANDIDATES", "Diagnosis", "Split", "Thresholds", "run", "residual_analysis"]
