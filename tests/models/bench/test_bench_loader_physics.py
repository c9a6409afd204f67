"""The bench loader checks physics (a value outside what the ankle actuator's bench can
read is a unit slip or a broken sensor) and a data file that is not CSV text is named as such."""
import gzip

import numpy as np
import pytest

from acausal import DataError
from acausal.identify import load_recordings, write_recording
from acausal.models.bench.recording_format import ANKLE_FORMAT

META = {"precompression_m": 0.008, "stride_time_s": 2.0, "spring_stiffness_N_per_m": 130e3, "body_mass_kg": 65.0}


def _write(folder, edit=None, meta=None):
    """One plausible recording (2 s at 1 kHz; its values need not be a simulation, only in range), edited."""
    t = np.arange(2000) / 1000.0
    cols = {"time_s": t, "ankle_angle_rad": 0.2 * np.sin(np.pi * t), "moment_arm_angle_rad": 0.3 * np.sin(np.pi * t),
            "moment_arm_setpoint_rad": 0.3 * np.sin(np.pi * t), "joint_torque_Nm": 50 * np.sin(np.pi * t),
            "supply_voltage_V": np.full(t.size, 48.0), "supply_current_A": np.full(t.size, 0.3),
            "motor_current_A": 2 * np.sin(np.pi * t)}
    if edit:
        edit(cols)
    write_recording(folder, "P08.0mm_T2.0s", cols, {**META, **(meta or {})}, ANKLE_FORMAT)
    return folder


def _set(name, k, value):
    def edit(cols):
        cols[name] = cols[name].copy()
        cols[name][k] = value
    return edit


@pytest.mark.parametrize("edit, meta, message", [
    (lambda c: c.update(time_s=1000 * c["time_s"]), None, r"column 'time_s': the samples are 1 s apart .*\(ms"),
    (lambda c: c.update(ankle_angle_rad=np.degrees(c["ankle_angle_rad"])), None, r"degrees in a column of radians"),
    (lambda c: c.update(supply_voltage_V=1000 * c["supply_voltage_V"]), None, r"'supply_voltage_V': 48000 V"),
    (None, {"precompression_m": 8.0}, r"key 'precompression_m' = 8: outside 0-0.1"),
    (None, {"spring_stiffness_N_per_m": 130.0}, r"key 'spring_stiffness_N_per_m' = 130: .*N/mm for N/m"),
    (None, {"body_mass_kg": 65000.0}, r"key 'body_mass_kg' = 65000"),
])
def test_an_implausible_bench_recording_is_refused_naming_the_culprit(tmp_path, edit, meta, message):
    with pytest.raises(DataError, match=message):
        load_recordings(_write(tmp_path, edit, meta), ANKLE_FORMAT)


def test_one_impossible_current_reading_is_masked_and_strict_refuses_it(tmp_path):
    folder = _write(tmp_path, _set("motor_current_A", 9, 1e300))
    [rec] = load_recordings(folder, ANKLE_FORMAT)
    assert [(m.line, m.column, m.kind) for m in rec.masked] == [(11, "motor_current_A", "out of range")]
    with pytest.raises(DataError, match=r"line 11, column 'motor_current_A': 1e\+300 A, outside -200 to 200"):
        load_recordings(folder, ANKLE_FORMAT, strict=True)


def test_a_plausible_recording_loads(tmp_path):
    assert len(load_recordings(_write(tmp_path), ANKLE_FORMAT)) == 1


def test_a_compressed_or_binary_file_named_csv_is_named(tmp_path):
    folder = _write(tmp_path)
    csv = folder / "P08.0mm_T2.0s.csv"
    csv.write_bytes(gzip.compress(csv.read_bytes()))
    with pytest.raises(DataError, match=r"P08.0mm_T2.0s.csv: gzip-compressed: decompress it first"):
        load_recordings(folder, ANKLE_FORMAT)
    csv.write_bytes(b"time_s,\xff\xfe\x00binary")
    with pytest.raises(DataError, match=r"not UTF-8 text \(byte 0xff at offset 7\)"):
        load_recordings(folder, ANKLE_FORMAT)


def test_an_underscore_in_a_number_is_named_with_line_and_column(tmp_path):
    folder = _write(tmp_path)
    csv = folder / "P08.0mm_T2.0s.csv"
    lines = csv.read_text().splitlines()
    fields = lines[3].split(",")
    fields[5] = "4_8"
    lines[3] = ",".join(fields)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"line 4, column 'supply_voltage_V': '4_8' is not a number"):
        load_recordings(folder, ANKLE_FORMAT)
