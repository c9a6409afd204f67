"""What a set of servo recordings can show, before anything is fitted (``acausal check DATA --model
servo_pendulum``).

Every candidate of :mod:`~.effects` shows only where the recordings exercise it: a goal rate limit only where the
goal moves faster than the limit, a duty limit or a supply sag only where the duty nears its limit, play only
where the arm's gravity torque changes sign, a deadband or a punch only where the servo holds still, a gain off
its declared value only where the duty saturates (elsewhere it is the same motion as other kt and R). This module
measures each of these from the logs themselves (the duty is the firmware law on the logged goal and position).
"""
from __future__ import annotations

import numpy as np

from acausal.identify.recordings import screening_summary, screening_warnings

from . import bam_logs
from .recording_format import POSITION

#: goal speed [rad/s] below which the servo counts as holding
HOLD_SPEED = 0.05
#: duty magnitude counted as saturated
SATURATED = 0.98


def survey(recordings, strict: bool = False) -> dict:
    """Facts of a set of recordings (list or folder, screened unless ``strict``) that decide which effects it can
    show; what the screening masked and left out among them."""
    if not isinstance(recordings, (list, tuple)):
        recordings = bam_logs.load(recordings, strict=strict)
    n = sum(r.t.size for r in recordings)
    dts = np.concatenate([np.diff(r.t) for r in recordings])
    steps = np.concatenate([np.abs(np.diff(r[POSITION])) for r in recordings])
    steps = steps[steps > 1e-12]
    goal_speed, duty, enable, bias_sign_changes, volts = [], [], [], 0, []
    off_segments, off_time = 0, 0.0
    for r in recordings:
        g, q, en = r["goal_position_rad"], r[POSITION], r["torque_enable"] > 0.5
        goal_speed.append(np.abs(np.gradient(g, r.t)))
        duty.append(np.clip(r.meta["kp"] * r.meta["controller.error_gain_per_rad"] * (g - q), -1, 1) * en)
        enable.append(en)
        s = np.sign(np.sin(q))
        bias_sign_changes += int(np.sum(s[1:] * s[:-1] < 0))
        volts.append(r["input_voltage_V"])
        starts = np.flatnonzero(en[:-1] & ~en[1:])
        off_segments += starts.size
        off_time += float(np.sum(np.diff(r.t)[~en[:-1]]))
    goal_speed, duty, enable = np.concatenate(goal_speed), np.concatenate(duty), np.concatenate(enable)
    volts = np.concatenate(volts)
    on = enable
    holding = on & (goal_speed < HOLD_SPEED)
    return {
        "recordings": len(recordings), "samples": int(n),
        "duration_s": float(sum(r.t[-1] - r.t[0] for r in recordings)),
        "sample_time_s": float(np.median(dts)), "encoder_step_rad": float(steps.min()) if steps.size else None,
        "gains": sorted({float(r.meta["kp"]) for r in recordings}),
        "trajectories": sorted({str(r.meta.get("trajectory_name", "")) for r in recordings}),
        "rigs": sorted({(float(r.meta["mass_kg"]), float(r.meta["arm_length_m"])) for r in recordings}),
        "torque_off_segments": off_segments, "torque_off_s": off_time,
        "goal_speed_max": float(np.percentile(goal_speed, 99.5)),
        "saturated_fraction": float(np.mean(np.abs(duty[on]) >= SATURATED)) if on.any() else 0.0,
        "duty_p99": float(np.percentile(np.abs(duty[on]), 99)) if on.any() else 0.0,
        "holding_fraction": float(np.mean(holding)), "gravity_sign_changes": bias_sign_changes,
        "supply_V": (float(volts.min()), float(np.median(volts)), float(volts.max())),
        "screening": screening_summary(recordings),
    }


def verdicts(s: dict) -> list:
    """``(candidate or topic, "yes" / "no" / "weak", why)`` for the facts ``s`` of :func:`survey`."""
    out = []
    split = ("yes", f"{len(s['gains'])} gains: every recording at the middle one held out") if len(s["gains"]) > 1 \
        else ("yes", f"{len(s['trajectories'])} trajectories: one held out") if len(s["trajectories"]) > 1 \
        else ("weak", "one gain and one trajectory: every fourth recording held out")
    if s["recordings"] < 3:
        split = ("no", "fewer than 3 recordings: nothing to hold out and fit on")
    out.append(("held-out split", *split))
    sat = s["saturated_fraction"]
    out.append(("duty_limit, supply_sag", "yes" if sat > 0.02 else "weak" if s["duty_p99"] > 0.5 else "no",
                f"the duty is saturated in {100 * sat:.1f} % of the torque-on samples (99th percentile "
                f"{s['duty_p99']:.2f})"))
    out.append(("gain_error", "yes" if sat > 0.02 else "no",
                "told apart from kt and R only where the duty saturates" + ("" if sat > 0.02 else
                                                                             ": it does not here")))
    out.append(("goal_rate_limit", "yes", f"a limit below {s['goal_speed_max']:.2g} rad/s (the goal's fastest "
                                          "moves) shows; a higher one cannot be seen"))
    hold = s["holding_fraction"]
    out.append(("error_deadband, punch, stribeck", "yes" if hold > 0.05 else "weak",
                f"the goal is still in {100 * hold:.0f} % of the samples"))
    out.append(("backlash", "yes" if s["gravity_sign_changes"] > 2 * s["recordings"] else "weak",
                f"the arm's gravity torque changes sign {s['gravity_sign_changes']} times"))
    off = s["torque_off_segments"]
    out.append(("friction without the motor", "yes" if off else "no",
                f"{off} torque-off segments ({s['torque_off_s']:.1f} s): the arm falls against friction alone"
                if off else "no torque-off segment: friction and the motor's losses are seen together"))
    rigs = s["rigs"]
    out.append(("load vs inertia", "yes" if len(rigs) > 1 else "no",
                f"{len(rigs)} rigs (mass, arm)" + ("" if len(rigs) > 1 else ": a load-dependent friction and a "
                                                  "wrong inertia or gravity scale together")))
    return out


def report(s: dict) -> str:
    """The survey and what it supports, as text."""
    lo, med, hi = s["supply_V"]
    lines = [f"{s['recordings']} recordings, {s['duration_s']:.1f} s, {s['samples']} samples "
             f"(median step {1e3 * s['sample_time_s']:.2f} ms); encoder step {s['encoder_step_rad']:.4g} rad; "
             f"supply {lo:.1f}-{hi:.1f} V (median {med:.1f})",
             f"gains {', '.join(f'{g:g}' for g in s['gains'])}; trajectories "
             f"{', '.join(t or '(unnamed)' for t in s['trajectories'])}", "", "what the set can show:"]
    lines += [f"  {what:32s} {ok:5s} {why}" for what, ok, why in verdicts(s)]
    screened = s.get("screening", {})
    if screened.get("masked") or screened.get("left_out"):
        lines += ["", "screened (the raw files are untouched; --strict refuses instead):"]
        lines += [f"  {w}" for w in screening_warnings(screened, shown=10)]
    return "\n".join(lines)
