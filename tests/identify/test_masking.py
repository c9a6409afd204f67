"""Sample screening: what no sensor or motion can produce is masked and named (file line, column, kind), the rest
of the recording kept; too much of it leaves the recording out with the reason; a recording that is wrong as a
whole is still refused naming file and column; ``strict`` refuses any of it."""
from __future__ import annotations

import numpy as np
import pytest

from acausal import DataError
from acausal.identify import Column, Key, RecordingFormat, load_recording, load_recordings
from acausal.identify.masking import LeftOut
from acausal.identify.plausibility import column_range

#: a user's own format: an angle with declared limits, a supply with its range, a logger whose dropouts zero both
#: the supply and the temperature channel (an extra column)
FMT = RecordingFormat(
    name="test rig",
    columns=(Column("time_s", "s"), Column("angle_rad", "rad", bounds=(-10.0, 10.0), max_rate=50.0, max_accel=3000.0),
             Column("supply_V", "V", bounds=(1.0, 60.0)), Column("goal_rad", "rad")),
    keys=(Key("mass_kg", "kg"),),
    max_gap=None,
    checks=(lambda cols, meta: column_range(cols, "supply_V", (1.0, 60.0), "V", "a dead supply, or mV"),),
    dropout=("supply_V", "temp_C"),
)
N = 600


def _write(folder, name="rec", edit=None, rows=None):
    """A 3-s recording at about 200 Hz with jitter (seeded): a swinging angle quantised to 4096 steps per turn."""
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.004, 0.006, N))
    q = 2 * np.pi / 4096
    cols = {"time_s": t, "angle_rad": np.round(0.8 * np.sin(3 * t) / q) * q,
            "supply_V": np.round((7.3 + 0.02 * rng.standard_normal(N)) * 10) / 10, "goal_rad": 0.8 * np.sin(3 * t),
            "temp_C": np.full(N, 29.0)}
    lines = [",".join(cols)] + [",".join(repr(float(cols[c][k])) for c in cols) for k in range(N)]
    if edit:
        edit(lines)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.csv").write_text("\n".join(lines) + "\n")
    (folder / f"{name}.json").write_text('{"mass_kg": 0.5}')
    return folder / f"{name}.csv"


def _set(lines, line, **values):
    """Set cells of file line ``line`` (header = 1)."""
    header = lines[0].split(",")
    cells = lines[line - 1].split(",")
    for k, v in values.items():
        cells[header.index(k)] = v
    lines[line - 1] = ",".join(cells)


def test_a_clean_recording_has_nothing_masked(tmp_path):
    rec = load_recording(_write(tmp_path), FMT)
    assert rec.masked == [] and rec.masks == {} and len(rec) == N


def test_a_dropout_row_is_masked_whole_and_its_inputs_held(tmp_path):
    clean = load_recording(_write(tmp_path / "a"), FMT)
    rec = load_recording(_write(tmp_path / "b", edit=lambda ls: _set(ls, 200, supply_V="0", temp_C="0",
                                                                      angle_rad="0", goal_rad="0")), FMT)
    [m] = rec.masked
    assert (m.line, m.kind, m.column) == (200, "dropout", "")
    assert "supply_V, temp_C read 0 together" in m.sentence() and "line 200" in m.sentence()
    k = 198  # data row of file line 200
    for c in ("angle_rad", "supply_V", "goal_rad"):
        assert rec.masks[c][k] and rec.masks[c].sum() == 1
        assert rec[c][k] == clean[c][k - 1]  # held from the sample before
    assert rec.masked_rows(["angle_rad"]).sum() == 1


def test_an_encoder_read_error_is_masked_alone(tmp_path):
    rec = load_recording(_write(tmp_path, edit=lambda ls: _set(ls, 300, angle_rad=repr(-np.pi))), FMT)
    [m] = rec.masked
    assert (m.line, m.column, m.kind) == (300, "angle_rad", "jump") and "-3.14159 rad" in m.why
    assert rec.masks == {"angle_rad": rec.masks["angle_rad"]} and rec.masks["angle_rad"].sum() == 1


@pytest.mark.parametrize("kind, word", [("repeat", "repeats"), ("back", "goes back"), ("ahead", "jumps ahead")])
def test_a_row_out_of_time_order_is_left_out(tmp_path, kind, word):
    def edit(ls):
        prev = float(ls[100 - 2].split(",")[0])
        if kind == "repeat":
            ls.insert(100 - 1, ls[100 - 2])  # file line 100 repeats line 99
        else:
            _set(ls, 100, time_s=repr(prev - 0.5 if kind == "back" else prev + 50.0))
    rec = load_recording(_write(tmp_path, edit=edit), FMT)
    [m] = rec.masked
    assert (m.line, m.column, m.kind) == (100, "time_s", "time") and word in m.why
    assert np.all(np.diff(rec.t) > 0) and len(rec) == (N if kind == "repeat" else N - 1)
    assert "the row is left out" in m.sentence()


def test_empty_nan_and_out_of_range_cells_are_masked(tmp_path):
    def edit(ls):
        _set(ls, 50, goal_rad="")
        _set(ls, 60, angle_rad="nan")
        _set(ls, 70, supply_V="0.2")
    rec = load_recording(_write(tmp_path, edit=edit), FMT)
    got = {(m.line, m.column, m.kind) for m in rec.masked}
    assert got == {(50, "goal_rad", "not a number"), (60, "angle_rad", "not a number"),
                   (70, "supply_V", "out of range")}
    assert all(np.isfinite(rec[c]).all() for c in ("goal_rad", "angle_rad", "supply_V"))


def test_strict_refuses_naming_file_line_and_column(tmp_path):
    path = _write(tmp_path, edit=lambda ls: _set(ls, 300, angle_rad=repr(-np.pi)))
    with pytest.raises(DataError, match=r"rec\.csv, line 300, column 'angle_rad': .* \(--strict"):
        load_recording(path, FMT, strict=True)
    path = _write(tmp_path, edit=lambda ls: _set(ls, 70, supply_V="0.2"))
    with pytest.raises(DataError, match=r"rec\.csv .*line 70, column 'supply_V': 0.2 V, outside 1 to 60"):
        load_recording(path, FMT, strict=True)


def test_a_recording_wrong_as_a_whole_is_still_refused(tmp_path):
    """A supply at 0 V throughout (dead, or logged in another unit) is no glitch: the format's check refuses it,
    naming file and column, and so does a time column that is not ordered at all."""
    path = _write(tmp_path, edit=lambda ls: [_set(ls, k, supply_V="0.0073") for k in range(2, N + 2)])
    with pytest.raises(DataError, match=r"rec\.csv .*column 'supply_V': 0.0073 V, outside 1 to 60"):
        load_recordings(tmp_path, FMT)
    rng = np.random.default_rng(1)

    def shuffle(ls):
        body = ls[1:]
        rng.shuffle(body)
        ls[1:] = body
    _write(tmp_path, edit=shuffle)
    with pytest.raises(DataError, match=r"rec\.csv, line \d+, column 'time_s': time (is duplicated|goes back)"):
        load_recordings(tmp_path, FMT)


def test_too_much_masked_leaves_the_recording_out_with_the_reason(tmp_path):
    """A sensor that steps by 2 rad and stays (re-zeroed) is no glitch: the recording is left out, named with the
    reason, and the set goes on with the others; a set with nothing left is refused."""
    _write(tmp_path, "good")
    _write(tmp_path, "stepped", edit=lambda ls: [_set(ls, k, angle_rad=repr(float(ls[k - 1].split(",")[1]) + 2.0))
                                                 for k in range(300, N + 2)])
    rs = load_recordings(tmp_path, FMT)
    assert [r.name for r in rs] == ["good"]
    [left] = rs.left_out
    assert isinstance(left, LeftOut) and left.recording == "stepped" and "'angle_rad' jumps" in left.why
    dropouts = lambda ls: [_set(ls, k, supply_V="0", temp_C="0") for k in range(10, 400, 10)]  # noqa: E731
    (tmp_path / "good.csv").unlink()
    (tmp_path / "good.json").unlink()
    _write(tmp_path, "lossy", edit=dropouts)
    with pytest.raises(DataError, match=r"every recording was left out"):
        load_recordings(tmp_path, FMT)


def test_the_shipped_servo_logs_and_the_virtual_bench_have_nothing_masked(tmp_path):
    """No false alarm on real recordings (the XL330 logs, irregular host polling) nor on the virtual bench
    (1 kHz, 14-bit encoders, sensor noise)."""
    from acausal.models.bench.recording_format import ANKLE_FORMAT
    from acausal.models.bench.virtual import BenchCondition, run_bench
    from acausal.models.servo.recording_format import SERVO_FORMAT, shipped_recordings
    rs = load_recordings(shipped_recordings(), SERVO_FORMAT)
    assert len(rs) == 16 and rs.masked == [] and rs.left_out == []
    run_bench(tmp_path, [BenchCondition(0.011, 1.2, strides=2)], seed=5)
    rs = load_recordings(tmp_path, ANKLE_FORMAT)
    assert rs.masked == [] and rs.left_out == []


# ------------------------------------------------------------------------------------------------ gaps
SPLIT = RecordingFormat(name="test rig, restartable", columns=FMT.columns, keys=FMT.keys, max_gap=2.5,
                        checks=FMT.checks, dropout=FMT.dropout, split_at_gaps=True)


def test_a_gap_splits_the_recording_where_the_format_can_restart_and_the_cut_is_named(tmp_path):
    path = _write(tmp_path, edit=lambda ls: ls.__delitem__(slice(300, 312)))  # file lines 301-312 gone
    rs = load_recordings(tmp_path, SPLIT)
    assert [r.name for r in rs] == ["rec part 1", "rec part 2"] and [r.part for r in rs] == [1, 2]
    assert len(rs[0]) + len(rs[1]) == N - 12 and rs[1].t[0] > rs[0].t[-1]
    (cut,) = rs.masked
    assert (cut.recording, cut.line, cut.kind) == ("rec part 2", 301, "gap") and "split here" in cut.why
    assert rs[1].lines[0] == 301 and rs[0].lines[-1] == 300
    with pytest.raises(DataError, match=r"rec.csv, line 301, column 'time_s': a gap of .* load_recordings splits"):
        load_recording(path, SPLIT)  # one file on its own: refused, naming the line
    with pytest.raises(DataError, match=r"line 301, column 'time_s': a gap of"):
        load_recordings(tmp_path, SPLIT, strict=True)


def test_a_part_too_short_between_gaps_is_left_out_with_the_reason_and_a_format_that_cannot_restart_refuses(tmp_path):
    def two_gaps(ls):
        del ls[310:320]
        del ls[300:305]  # five rows kept between the gaps: too short to replay
    _write(tmp_path, edit=two_gaps)
    rs = load_recordings(tmp_path, SPLIT)
    assert [r.name for r in rs] == ["rec part 1", "rec part 3"]
    (short,) = rs.left_out
    assert short.recording == "rec part 2" and "5 rows between gaps" in short.why
    refusing = RecordingFormat(name="smoothed", columns=FMT.columns, keys=FMT.keys, max_gap=2.5, checks=FMT.checks)
    with pytest.raises(DataError, match=r"line 306, column 'time_s': a gap of .*rows are missing"):  # the widest
        load_recordings(tmp_path, refusing)
