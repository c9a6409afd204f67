"""Fuzzing corrupted recordings: `acausal fit` and `acausal diagnose` never return an unflagged result on
a corrupted recording set.

One small clean set is recorded once on the virtual bench (three conditions of three 1.2-s strides, with its
manifest). Hypothesis corrupts a copy the way files get broken in practice: truncated (by rows or mid-row, with and
without the manifest; the JSON too), two columns swapped, a column sign-flipped or in the wrong unit, NaN or empty
cells, duplicated time stamps, a block of rows dropped, a dead or frozen sensor, a wrong stride time or
precompression in the JSON, a key given twice. One recording or all of them. Both commands then run on it through the
command line, and each must either

* stop with a clean error (exit status 2, no traceback) naming the file, recording or column at fault, or
* return a result with at least one ``warning:`` line (the data or the fit is suspect),

except when the corruption touched only columns the command's result does not depend on: then it may be flagged
or not, and if not, its result must be exactly the one on the clean set (not wrong). The clean set itself gives
results without warnings, so a warning is the corruption's doing.

Tolerated by design and not generated: a recording one sample short (the declared span is checked to within
one sample interval: a logger may write both ends), one dropped row (a gap of two sample intervals is close to a
jittery logger's spread; the loader refuses 2.5 or more), and a stride time within 2 % of the true one.
"""
from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from acausal.cli import main
from acausal.identify import MANIFEST
from acausal.models.bench.recording_format import ANKLE_FORMAT
from acausal.models.bench.virtual import BenchCondition, run_bench

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow

CONDS = [BenchCondition(P, 1.2, strides=3) for P in (0.005, 0.011, 0.018)]
NAMES = ["P05.0mm_T1.2s", "P11.0mm_T1.2s", "P18.0mm_T1.2s"]
COLUMNS = [c.name for c in ANKLE_FORMAT.columns]
#: the CSV columns each command's result depends on (the JSON counts for both): the replay's inputs (time, both
#: angles) and the signals it fits. The other columns may be screened (fit checks every recorded signal the model
#: predicts) but do not change the numbers
AFFECTS = {"fit": {"time_s", "ankle_angle_rad", "moment_arm_angle_rad", "motor_current_A", "supply_current_A"}}
AFFECTS["diagnose"] = AFFECTS["fit"] | {"joint_torque_Nm"}
COMMANDS = {"fit": ["fit", "{data}", "--out", "{out}"],
            "diagnose": ["diagnose", "{data}", "--out", "{out}", "--candidates", "driver_quiescent_power",
                         "--max-effects", "1", "--no-progress"]}
SETTINGS = settings(max_examples=5, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def run(command: str, data: Path, out: Path):
    """``acausal COMMAND`` on ``data``: (exit status, stdout, stderr); an exception escaping ``main`` fails the test
    (a traceback is not a clean error)."""
    argv = [a.format(data=data, out=out) for a in COMMANDS[command]]
    so, se = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
        code = main(argv)
    return code, so.getvalue(), se.getvalue()


def result_lines(stdout: str) -> list:
    """The printed result without the report's path (which names the output folder)."""
    return [line for line in stdout.splitlines() if not line.startswith("report:")]


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """The clean set and each command's printed result on it."""
    folder = tmp_path_factory.mktemp("clean")
    run_bench(folder, CONDS, seed=11, executor="serial")
    results = {}
    for command in COMMANDS:
        code, so, se = run(command, folder, tmp_path_factory.mktemp(f"out_{command}"))
        assert code == 0, se
        results[command] = result_lines(so)
    return folder, results


def test_the_clean_set_gives_results_without_warnings(clean):
    folder, results = clean
    for command, lines in results.items():
        assert lines and not [line for line in lines if line.startswith("warning:")], (command, lines)
    assert any(line.startswith("motor.R = ") for line in results["fit"])
    assert results["diagnose"][0] == "cause: none"


# ------------------------------------------------------------------------------------------------ corruptions
def _read(csv: Path):
    lines = csv.read_text().splitlines()
    return lines[0].split(","), [line.split(",") for line in lines[1:]]


def _write(csv: Path, header, rows):
    csv.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")


def _edit_rows(fn):
    """A corruption that rewrites one recording's header and rows; returns the CSV columns it changed."""
    def apply(folder: Path, name: str):
        csv = folder / f"{name}.csv"
        header, rows = _read(csv)
        touched = fn(header, rows)
        _write(csv, header, rows)
        return touched
    return apply


def _edit_json(fn):
    def apply(folder: Path, name: str):
        path = folder / f"{name}.json"
        path.write_text(fn(json.loads(path.read_text())))
        return {"json"}
    return apply


@st.composite
def truncated(draw):
    """The CSV cut at a byte offset that loses at least two rows (maybe mid-row, maybe at a line end)."""
    fraction = draw(st.floats(0.0, 1.0))
    at_line_end = draw(st.booleans())

    def apply(folder: Path, name: str):
        csv = folder / f"{name}.csv"
        text = csv.read_text()
        last_two = text.rstrip("\n").rsplit("\n", 2)[0]  # everything before the last two rows
        cut = int(fraction * len(last_two))
        if at_line_end:
            cut = text.rfind("\n", 0, cut) + 1
        csv.write_text(text[:cut])
        return {"rows"}
    return f"truncate at {fraction:.3f} of the file{' (line end)' if at_line_end else ''}", apply


@st.composite
def truncated_json(draw):
    fraction = draw(st.floats(0.0, 0.999))

    def apply(folder: Path, name: str):
        path = folder / f"{name}.json"
        text = path.read_text().rstrip()
        path.write_text(text[: int(fraction * len(text))])
        return {"json"}
    return f"JSON cut at {fraction:.3f}", apply


@st.composite
def swapped(draw):
    a, b = draw(st.lists(st.sampled_from(COLUMNS), min_size=2, max_size=2, unique=True))

    def fn(header, rows):
        i, j = header.index(a), header.index(b)
        header[i], header[j] = header[j], header[i]
        return {a, b}
    return f"columns {a} and {b} swapped", _edit_rows(fn)


@st.composite
def rescaled(draw):
    """A column sign-flipped or in another unit than its name says (mA, degrees, ...)."""
    col = draw(st.sampled_from(COLUMNS))
    factor = draw(st.sampled_from([-1.0, 1e3, 1e-3, 180 / np.pi, np.pi / 180]))

    def fn(header, rows):
        j = header.index(col)
        for r in rows:
            r[j] = repr(factor * float(r[j]))
        return {col}
    return f"{col} times {factor:g}", _edit_rows(fn)


@st.composite
def not_finite(draw):
    col = draw(st.sampled_from(COLUMNS))
    row = draw(st.integers(0, 3599))
    value = draw(st.sampled_from(["nan", "NaN", "inf", "-inf", ""]))

    def fn(header, rows):
        rows[row][header.index(col)] = value
        return {col}
    return f"{col} in row {row} = {value!r}", _edit_rows(fn)


@st.composite
def duplicated_time(draw):
    row = draw(st.integers(1, 3599))
    copy_row = draw(st.booleans())

    def fn(header, rows):
        if copy_row:
            rows.insert(row, list(rows[row]))
        else:
            rows[row][header.index("time_s")] = rows[row - 1][header.index("time_s")]
        return {"time_s"}
    return f"time stamp of row {row} duplicated ({'whole row' if copy_row else 'time only'})", _edit_rows(fn)


@st.composite
def dropped_rows(draw):
    count = draw(st.integers(2, 1500))
    start = draw(st.integers(0, 3600 - count - 1))

    def fn(header, rows):
        del rows[start:start + count]
        return {"rows"}
    return f"{count} rows dropped from row {start}", _edit_rows(fn)


@st.composite
def dead_sensor(draw):
    """A sensor that reads one value: from the start (dead) or from some row on (frozen)."""
    col = draw(st.sampled_from([c for c in COLUMNS if c != "time_s"]))
    start = draw(st.integers(0, 2700))
    zero = draw(st.booleans())

    def fn(header, rows):
        j = header.index(col)
        value = "0" if zero else rows[start][j]
        for r in rows[start:]:
            r[j] = value
        return {col}
    return f"{col} stuck at {'0' if zero else 'its value'} from row {start}", _edit_rows(fn)


@st.composite
def wrong_setting(draw):
    """A wrong stride time (with its ``strides`` key kept or removed) or precompression in the JSON."""
    key = draw(st.sampled_from(["stride_time_s", "precompression_m"]))
    factor = draw(st.one_of(st.floats(0.5, 0.8), st.floats(1.25, 2.0)) if key == "precompression_m"
                  else st.one_of(st.floats(0.5, 0.95), st.floats(1.05, 2.0)))
    drop_strides = draw(st.booleans())

    def fn(meta):
        meta[key] *= factor
        if drop_strides:
            meta.pop("strides", None)
        return json.dumps(meta, indent=2)
    return f"{key} times {factor:.3f}{', no strides key' if drop_strides else ''}", _edit_json(fn)


@st.composite
def duplicated_key(draw):
    value = draw(st.floats(0.5, 3.0))

    def fn(meta):
        text = json.dumps(meta, indent=2)
        return text.replace('"stride_time_s":', f'"stride_time_s": {value!r},\n  "stride_time_s":', 1)
    return f"stride_time_s given twice ({value:.3g} first)", _edit_json(fn)


CORRUPTIONS = {"truncated": truncated(), "truncated_json": truncated_json(), "swapped": swapped(),
               "rescaled": rescaled(), "not_finite": not_finite(), "duplicated_time": duplicated_time(),
               "dropped_rows": dropped_rows(), "dead_sensor": dead_sensor(), "wrong_setting": wrong_setting(),
               "duplicated_key": duplicated_key()}


@pytest.mark.parametrize("kind", sorted(CORRUPTIONS))
@SETTINGS
@given(data=st.data())
def test_a_corrupted_set_is_never_an_unflagged_result(clean, kind, data):
    folder, results = clean
    what, apply = data.draw(CORRUPTIONS[kind], label="corruption")
    targets = data.draw(st.sampled_from([[n] for n in NAMES] + [NAMES]), label="recordings")
    keep_manifest = kind.startswith("truncated") and data.draw(st.booleans(), label="keep the manifest")
    with tempfile.TemporaryDirectory() as tmp:
        broken = Path(tmp) / "data"
        shutil.copytree(folder, broken)
        if not keep_manifest:
            (broken / MANIFEST).unlink()
        touched = set().union(*(apply(broken, n) for n in targets))
        for command in COMMANDS:
            code, so, se = run(command, broken, Path(tmp) / f"out_{command}")
            case = f"{command} on {what} in {', '.join(targets)}"
            if code == 2:  # a clean error that names the file, recording or column at fault
                assert se.startswith(f"acausal {command}: ") and "Traceback" not in se, (case, se)
                assert any(n in se for n in targets) or MANIFEST in se, (case, se)
            else:
                assert code == 0, (case, code, se)
                warned = [line for line in so.splitlines() if line.startswith("warning:")]
                if touched & (AFFECTS[command] | {"rows", "json"}):
                    assert warned, f"{case}: an unflagged result:\n{so}"
                elif not warned:  # only columns its result does not depend on: the clean result exactly
                    assert result_lines(so) == results[command], (case, so)


# ------------------------------------------------------------------ what the fuzzing found, one reproducer each
def _broken_copy(folder: Path, tmp: Path) -> Path:
    data = tmp / "data"
    shutil.copytree(folder, data)
    (data / MANIFEST).unlink()
    return data


def _set_column(csv: Path, column: str, fn):
    """Replace ``column`` of ``csv`` by ``fn(values)`` (numbers written with repr)."""
    header, rows = _read(csv)
    j = header.index(column)
    for r, v in zip(rows, fn(np.array([float(r[j]) for r in rows]))):
        r[j] = repr(float(v))
    _write(csv, header, rows)


def _drop_rows(csv: Path, rows_slice: slice):
    header, rows = _read(csv)
    del rows[rows_slice]
    _write(csv, header, rows)


def test_fit_flags_a_sign_flipped_current_in_its_python_result(clean, tmp_path):
    """``calibration.fit`` returned R = 0.52 +- 0.02 (truth 0.7) on a sign-flipped supply current with nothing to
    say it was suspect; ``Calibration.warnings`` now names the recording and the likely cause (the clean set has
    none: checked by the command-line test above and here)."""
    from acausal.models.bench import calibration
    folder, _ = clean
    assert calibration.fit(folder, "R,J,b")[0].warnings == []
    data = _broken_copy(folder, tmp_path)
    _set_column(data / "P11.0mm_T1.2s.csv", "supply_current_A", lambda v: -v)
    cal, _ = calibration.fit(data, "R,J,b")
    assert any("P11.0mm_T1.2s, supply_current_A" in w and "reversed sign" in w for w in cal.warnings), cal.warnings


def test_a_sensor_stuck_near_the_start_of_every_recording_is_flagged(clean, tmp_path):
    """Stuck from the second row on in every recording: its readings are not all equal (the first row differs), so
    its noise level was taken as the signal's size and nothing looked wrong (fit R = 0.707 +- 0.0035)."""
    folder, _ = clean
    data = _broken_copy(folder, tmp_path)
    for name in NAMES:
        _set_column(data / f"{name}.csv", "motor_current_A", lambda v: np.r_[v[0], np.full(v.size - 1, v[1])])
    code, so, _ = run("fit", data, tmp_path / "out")
    assert code == 0 and "a dead or disconnected sensor" in so, so


def test_dropped_rows_are_named_by_the_loader_and_the_smoothing(clean, tmp_path):
    """100 dropped rows reached the optimiser as 'Residuals are not finite in the initial point' (a ValueError, no
    file named); 5 dropped rows passed unflagged. The loader now names the line of the gap, and the smoothing says
    what is wrong should a format allow gaps."""
    from acausal import DataError
    from acausal.identify.smoothing import SmoothingSpline
    folder, _ = clean
    data = _broken_copy(folder, tmp_path)
    _drop_rows(data / "P05.0mm_T1.2s.csv", slice(1800, 1805))
    code, _, se = run("fit", data, tmp_path / "out")
    assert code == 2 and "P05.0mm_T1.2s.csv, line 1802, column 'time_s': a gap of 0.006 s" in se, se
    t = np.r_[np.arange(0, 1.8, 1e-3), np.arange(1.9, 3.6, 1e-3)]
    with pytest.raises(DataError, match=r"rec: ankle angle: no unique smooth curve .* gap .* 0.101 s after t = 1.799"):
        SmoothingSpline(t, np.sin(t), 0.015, name="rec: ankle angle")


def test_a_setting_outside_the_models_bounds_names_the_recording(clean, tmp_path):
    """A precompression of 22 mm in one JSON stopped the fit with "parameter 'P_nominal' of (top level) = 0.022 is
    above its maximum", naming no recording."""
    folder, _ = clean
    data = _broken_copy(folder, tmp_path)
    path = data / "P11.0mm_T1.2s.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), "precompression_m": 0.022}))
    for command in COMMANDS:
        code, _, se = run(command, data, tmp_path / f"out_{command}")
        assert code == 2 and "experiment 'P11.0mm_T1.2s': parameter 'P_nominal'" in se, se


def test_a_duplicated_key_and_a_two_row_truncation_are_errors(clean, tmp_path):
    """``json`` kept the last of two ``stride_time_s`` silently; a recording two rows short was within the span
    check's old tolerance of two sample intervals."""
    from acausal import DataError
    from acausal.identify import load_recordings
    folder, _ = clean
    data = _broken_copy(folder, tmp_path)
    path = data / "P05.0mm_T1.2s.json"
    path.write_text(path.read_text().replace('"stride_time_s":', '"stride_time_s": 2.0, "stride_time_s":', 1))
    with pytest.raises(DataError, match=r"P05.0mm_T1.2s.json: key 'stride_time_s' appears twice \(values 2.0 and "
                                        r"1.2\)"):
        load_recordings(data, ANKLE_FORMAT)
    shutil.copy(folder / "P05.0mm_T1.2s.json", path)
    _drop_rows(data / "P05.0mm_T1.2s.csv", slice(-2, None))
    with pytest.raises(DataError, match=r"P05.0mm_T1.2s.csv: the samples cover 3.598 s \(3598 rows\) but its JSON "
                                        r"declares 3.6 s: truncated"):
        load_recordings(data, ANKLE_FORMAT)


def test_a_wrong_stride_time_without_strides_is_named(clean, tmp_path):
    """Without ``strides`` in the JSON nothing checked the stride time against the data: fit and diagnose now see
    that the readings repeat every 1.2 s, not every 1.32 s. Within 2 % nothing is said."""
    folder, _ = clean
    data = _broken_copy(folder, tmp_path)
    path = data / "P18.0mm_T1.2s.json"
    meta = json.loads(path.read_text())
    meta.pop("strides")
    path.write_text(json.dumps({**meta, "stride_time_s": 1.32}))
    for command in COMMANDS:
        code, so, _ = run(command, data, tmp_path / f"out_{command}")
        assert code == 0 and re.search(r"warning: P18.0mm_T1.2s: its readings repeat every 1\.(19|20?)\d* s .*"
                                       r"analysed with a cycle of 1.32 s: a wrong stride time", so), so
    from acausal.models.bench import calibration
    cal, _ = calibration.fit(data, "R,J,b")  # the Python result says it too (its experiments carry the period)
    assert any("P18.0mm_T1.2s" in w and "wrong stride time" in w for w in cal.warnings), cal.warnings
    path.write_text(json.dumps({**meta, "stride_time_s": 1.215}))
    code, so, _ = run("fit", data, tmp_path / "out_fit")
    assert code == 0 and "warning:" not in so, so
