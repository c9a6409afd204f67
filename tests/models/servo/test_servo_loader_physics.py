"""The servo loader checks physics, not only format. Each case edits one shipped XL330 recording
the way a careless user's export would, and the load must fail at once with the file and the column, line or key
at fault (before any replay: a 1-sample log used to fail 56 s later naming neither)."""
import importlib.resources as res
import json
import shutil

import numpy as np
import pytest

from acausal import DataError
from acausal.identify import load_recordings
from acausal.models.servo.problem import Split
from acausal.models.servo.recording_format import SERVO_FORMAT

NAME = "xl330_m0490_l100_kp100_lift_and_drop_2026-01-15_10h28m17"


def _one(tmp_path, rows=None, meta=None):
    """A copy of one shipped recording with its CSV rows edited by ``rows(header, data) -> data`` and its JSON by
    ``meta(dict)``."""
    src = res.files("acausal.models.servo").joinpath("data/xl330/recordings")
    shutil.copy(str(src.joinpath(NAME + ".json")), tmp_path / f"{NAME}.json")
    shutil.copy(str(src.joinpath(NAME + ".csv")), tmp_path / f"{NAME}.csv")
    if rows is not None:
        lines = (tmp_path / f"{NAME}.csv").read_text().splitlines()
        header = lines[0].split(",")
        data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
        data = rows(header, data)
        body = "\n".join(",".join(repr(float(v)) for v in row) for row in data)
        (tmp_path / f"{NAME}.csv").write_text(lines[0] + "\n" + body + "\n")
    if meta is not None:
        m = json.loads((tmp_path / f"{NAME}.json").read_text())
        meta(m)
        (tmp_path / f"{NAME}.json").write_text(json.dumps(m))
    return tmp_path


def _col(header, data, name, f):
    data = data.copy()
    j = header.index(name)
    data[:, j] = f(data[:, j])
    return data


def _set(key, value):
    def edit(m):
        m[key] = value
    return edit


def _drop(key):
    def edit(m):
        del m[key]
    return edit


def _row(name, k, value):
    def edit(header, data):
        data = data.copy()
        data[k, header.index(name)] = value
        return data
    return edit


CASES = {
    "time in ms": (dict(rows=lambda h, d: _col(h, d, "time_s", lambda t: 1000 * t), meta=_drop("duration_s")),
                   r"column 'time_s': the samples are [\d.]+ s apart .* another unit \(ms"),
    "time in ms against its JSON": (dict(rows=lambda h, d: _col(h, d, "time_s", lambda t: 1000 * t)),
                                    r"the samples cover 600\d\.?\d* s \(1510 rows\) but its JSON declares 5\.998 s: "
                                    r"longer than declared, by a factor 1\d\d\d: time in another unit"),
    "time stretched against its JSON": (dict(rows=lambda h, d: _col(h, d, "time_s", lambda t: 1.5 * t)),
                                        r"the samples cover 9\.00\d s \(1510 rows\) but its JSON declares 5\.998 s: "
                                        r"longer than declared$"),
    "torque enable 5": (dict(rows=_row("torque_enable", 40, 5.0)), r"line 42, column 'torque_enable': 5;"),
    "torque enable -1": (dict(rows=_row("torque_enable", 3, -1.0)), r"line 5, column 'torque_enable': -1;"),
    "negative supply": (dict(rows=lambda h, d: _col(h, d, "input_voltage_V", lambda v: -v)),
                        r"line 2, column 'input_voltage_V': -7\.3 V"),
    "degrees in position_rad": (dict(rows=lambda h, d: _col(h, d, "position_rad", np.degrees)),
                                r"column 'position_rad': .* degrees or encoder counts"),
    "mass in grams": (dict(meta=_set("mass_kg", 490)), r"key 'mass_kg' = 490: outside 0-50"),
    "arm length in mm": (dict(meta=_set("arm_length_m", 100)), r"key 'arm_length_m' = 100"),
    "negative arm mass": (dict(meta=_set("arm_mass_kg", -0.05)), r"key 'arm_mass_kg' = -0\.05"),
    "a 1-sample log": (dict(rows=lambda h, d: d[:1]), r"only 1 rows; a replay is fitted on 20 at least"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_an_implausible_recording_is_refused_naming_the_culprit(case, tmp_path):
    edits, message = CASES[case]
    folder = _one(tmp_path, **edits)
    with pytest.raises(DataError, match=message) as err:
        load_recordings(folder, SERVO_FORMAT)
    assert NAME in str(err.value)


def test_one_supply_reading_at_0_V_is_masked_and_strict_refuses_it(tmp_path):
    """One sample among 7.3 V ones is a glitch: masked and named; ``strict`` refuses it as the check always did."""
    folder = _one(tmp_path, rows=_row("input_voltage_V", 10, 0.0))
    [rec] = load_recordings(folder, SERVO_FORMAT)
    [m] = rec.masked
    assert (m.line, m.column, m.kind) == (12, "input_voltage_V", "out of range") and rec["input_voltage_V"][10] > 7
    with pytest.raises(DataError, match=r"line 12, column 'input_voltage_V': 0 V"):
        load_recordings(folder, SERVO_FORMAT, strict=True)


def test_the_shipped_recording_passes_and_the_checks_can_fail(tmp_path):
    assert len(load_recordings(_one(tmp_path), SERVO_FORMAT)) == 1


@pytest.mark.parametrize("n", [2, 3])
def test_a_split_of_few_recordings_holds_one_out(n, tmp_path):
    """One gain, one trajectory, 2 or 3 recordings: 'every fourth' held out nothing."""
    recs = load_recordings(_one(tmp_path), SERVO_FORMAT) * n
    for r in recs:
        r.meta = {**r.meta, "trajectory_name": "same"}
    mask, text = Split().held_out(recs)
    assert mask.tolist() == [False] * (n - 1) + [True] and f"the last of {n} recordings" in text


def test_position_and_goal_swapped_are_named(tmp_path):
    """A servo follows its goal: a log whose position leads the goal (the two columns swapped) is refused; the
    shipped logs' positions lag their goals by 43-196 ms where the goal moves smoothly."""
    from acausal.models.servo.recording_format import lag

    name = "xl330_m0490_l100_kp400_sin_sin_2026-01-15_10h29m14"
    src = res.files("acausal.models.servo").joinpath("data/xl330/recordings")
    shutil.copy(str(src.joinpath(name + ".json")), tmp_path / f"{name}.json")
    lines = src.joinpath(name + ".csv").read_text().splitlines()
    header = lines[0].split(",")
    i, j = header.index("position_rad"), header.index("goal_position_rad")
    header[i], header[j] = header[j], header[i]
    (tmp_path / f"{name}.csv").write_text(",".join(header) + "\n" + "\n".join(lines[1:]) + "\n")
    with pytest.raises(DataError, match=rf"{name}.*the position leads the goal by 0\.10\d s.*swapped"):
        load_recordings(tmp_path, SERVO_FORMAT)
    recs = load_recordings(str(src), SERVO_FORMAT)
    delays = [lag(r.t, r["goal_position_rad"], r["position_rad"], r["torque_enable"]) for r in recs]
    moving = [d for d in delays if d != 0]  # the step goals (up_and_down, lift_and_drop) peak at no lag
    assert len(moving) == 8 and 0.04 < min(moving) and max(moving) < 0.2
