"""Speed of the servo replays that the real-data diagnosis repeats, against a hand-written reference
measured in the same run.

One XL330 recording (6 s, ~1100 samples, closed loop on the logged goal, supply voltage and torque enable) with
load-dependent friction:

* the compiled model's replay vs a hand-written ``solve_ivp`` (LSODA, same tolerances) of the same equations;
  the two must agree to 1e-4 rad (a functional check of the assembled components);
* the replay with exact sensitivities to the seven parameters the diagnosis fits, as a multiple of one replay;
* the same with the diagnosis's fixed step (RK4 on the recording's samples, 16 substeps: what this recording needs
  with load friction at the tolerance the diagnosis checks), against CVODES with sensitivities.

Ratios go to ``extra_info`` and the README; the only assertions on time are loose regression guards on ratios.
"""
import math
import time
from importlib import resources

import numpy as np
from scipy.integrate import solve_ivp

from acausal.identify import load_recordings
from acausal.models.servo.problem import ATOL, RTOL, replay, replay_job
from acausal.models.servo.recording_format import SERVO_FORMAT, replay_columns, rig_params, start

PARAMS = {"servo.kt": 0.38, "servo.R": 3.4, "servo.armature": 0.0019, "pendulum.phi0": 0.03, "servo.tau_c": 0.009,
          "servo.d": 0.004, "servo.friction.k_l": 0.25}
TERMS = ("coulomb", "load")
W_C = 0.01  # GearFriction's default speed scale of the smooth Coulomb law


def _recording():
    folder = resources.files("acausal.models.servo").joinpath("data/xl330/recordings")
    return [r for r in load_recordings(str(folder), SERVO_FORMAT) if r.meta["kp"] == 400
            and r.meta["trajectory_name"] == "sin_sin"][0]


def _handwritten(rec, columns, rig, x0):
    """The same physics written by hand (the reference)."""
    from acausal.models.servo.recording_format import inputs_from
    u = inputs_from(rec.t, columns)
    goal, volts, enable = u["goal.signal"], u["supply.v_ref"], u["enable.signal"]
    kt, R, Ja, phi0 = PARAMS["servo.kt"], PARAMS["servo.R"], PARAMS["servo.armature"], PARAMS["pendulum.phi0"]
    tau_c, d, k_l = PARAMS["servo.tau_c"], PARAMS["servo.d"], PARAMS["servo.friction.k_l"]
    m, l, kp, eg = rig["pendulum.m"], rig["pendulum.l"], rig["servo.kp"], rig["servo.error_gain"]
    J = Ja + m * l * l
    mgl = m * 9.80665 * l

    def f(t, x):
        q, w = x
        e = enable(t)
        duty = e * min(max(kp * eg * (goal(t) - q), -1.0), 1.0)
        tau_m = kt * e * (duty * volts(t) - kt * w) / R
        tau_f = (tau_c + k_l * abs(tau_m)) * math.tanh(w / W_C) + d * w
        return [w, (tau_m - tau_f - mgl * math.sin(q + phi0)) / J]

    sol = solve_ivp(f, (rec.t[0], rec.t[-1]), [x0["pendulum.phi"], x0["pendulum.w"]], method="LSODA",
                    t_eval=rec.t, rtol=RTOL, atol=ATOL)
    return sol.y[0]


def _best(fn, rounds=3):
    best, out = np.inf, None
    for _ in range(rounds):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def test_servo_replay_vs_handwritten(benchmark):
    rec = _recording()
    columns, rig, x0 = replay_columns(rec), rig_params(rec.meta), start(rec)
    job = replay_job((TERMS, ()), rec, PARAMS, substeps=None)
    replay(job)  # compile once (cached per process), as the diagnosis does
    pos, _ = benchmark.pedantic(lambda: replay(job), rounds=3, iterations=1)
    t_ref, ref = _best(lambda: _handwritten(rec, columns, rig, x0))
    assert np.max(np.abs(pos - ref)) < 1e-4
    t_sens, (pos_s, S) = _best(lambda: replay(replay_job((TERMS, ()), rec, PARAMS, tuple(PARAMS), None)), rounds=1)
    # the same replay with its sensitivities (CasADi's CVODES; the replay alone runs on the native loop where it is
    # built): the same positions within the replays' integration error (against a replay at rtol 1e-9 on this
    # recording: 6.1e-5 rad on the native loop, 3.3e-5 on CasADi's CVODES, 1e-5 with the sensitivities)
    assert S.shape == (len(PARAMS), rec.t.size) and np.max(np.abs(pos_s - pos)) < 1e-4
    fixed = replay_job((TERMS, ()), rec, PARAMS, tuple(PARAMS), 16)
    replay(fixed)  # builds the roll-out once
    t_rk4, (pos_r, S_r) = _best(lambda: replay(fixed), rounds=2)
    assert np.max(np.abs(pos_r - ref)) < 1e-4 and np.max(np.abs(S_r - S)) < 0.05 * np.max(np.abs(S))
    if not benchmark.disabled and benchmark.stats is not None:
        t = benchmark.stats.stats.min
        benchmark.extra_info.update(replay_s=t, handwritten_s=t_ref, ratio=t / t_ref, sensitivities_s=t_sens,
                                    sensitivities_per_replay=t_sens / t, rk4_sensitivities_s=t_rk4,
                                    rk4_vs_cvodes=t_rk4 / t_sens)
        print(f"\nservo replay {t:.3f} s, hand-written {t_ref:.3f} s (ratio {t / t_ref:.2f}); with sensitivities "
              f"to {len(PARAMS)} parameters {t_sens:.3f} s ({t_sens / t:.1f} replays); RK4 x 16 with them "
              f"{t_rk4:.3f} s ({t_rk4 / t_sens:.2f} of CVODES)")
        assert t / t_ref < 10.0  # regression guard only
