"""Real servo logs as they come: the shipped XL330 set with a logging dropout, an encoder read error (exactly -pi)
and a repeated time stamp gives the verdict and held-out error of the set with those rows deleted, and the report
and the verdict's JSON name the three masked samples; ``--strict`` refuses the set naming the first."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from acausal.cli import main
from acausal.models.servo.recording_format import shipped_recordings

pytestmark = pytest.mark.slow

#: (recording number in name order, file line, what happens to it)
GLITCHES = [(0, 394, "dropout"), (3, 300, "read error"), (7, 501, "repeated")]


def _edit(path, fn):
    lines = path.read_text().splitlines()
    fn(lines)
    path.write_text("\n".join(lines) + "\n")


def _glitched(folder):
    """The shipped set with the three glitches written in (the raw rows otherwise untouched)."""
    shutil.copytree(shipped_recordings(), folder)
    csvs = sorted(folder.glob("*.csv"))

    def dropout(ls, k=394):  # every reading of the row 0, as a logger that lost the read writes it
        header, cells = ls[0].split(","), ls[k - 1].split(",")
        for c in ("position_rad", "speed_rad_s", "duty_frac", "input_voltage_V", "temperature_C", "present_pwm_raw"):
            cells[header.index(c)] = "0"
        ls[k - 1] = ",".join(cells)

    def read_error(ls, k=300):
        header, cells = ls[0].split(","), ls[k - 1].split(",")
        cells[header.index("position_rad")] = repr(-np.pi)
        ls[k - 1] = ",".join(cells)

    _edit(csvs[0], dropout)
    _edit(csvs[3], read_error)
    _edit(csvs[7], lambda ls: ls.insert(500, ls[499]))  # file line 501 repeats line 500
    return csvs


def _deleted(folder):
    """The shipped set with the dropout's and the read error's rows deleted (the repeat never written)."""
    shutil.copytree(shipped_recordings(), folder)
    csvs = sorted(folder.glob("*.csv"))
    for k, line in ((0, 394), (3, 300)):
        _edit(csvs[k], lambda ls, line=line: ls.pop(line - 1))
    return csvs


def _diagnose(data, out, *extra):
    code = main(["diagnose", str(data), "--model", "servo_pendulum", "--out", str(out), "--json", str(out / "v.json"),
                 "--jobs", "2", "--no-progress", *extra])
    return code, (json.loads((out / "v.json").read_text()) if code == 0 else None)


def test_glitches_are_masked_named_and_change_nothing(tmp_path, capsys):
    csvs = _glitched(tmp_path / "glitched")
    _deleted(tmp_path / "deleted")
    code, v = _diagnose(tmp_path / "glitched", tmp_path / "out_glitched")
    assert code == 0
    printed = capsys.readouterr().out
    code, ref = _diagnose(tmp_path / "deleted", tmp_path / "out_deleted")
    assert code == 0
    assert v["causes"] == ref["causes"] == ["load"]
    assert v["heldout"]["extended"] == pytest.approx(ref["heldout"]["extended"], rel=0.01)
    assert v["heldout"]["baseline"] == pytest.approx(ref["heldout"]["baseline"], rel=0.01)
    masked = v["screening"]["masked"]
    got = {(m["recording"], m["line"], m["kind"]) for m in masked}
    assert got == {(csvs[0].stem, 394, "dropout"), (csvs[3].stem, 300, "jump"), (csvs[7].stem, 501, "time")}
    assert ref["screening"] == {"masked": [], "left_out": []}
    report = (tmp_path / "out_glitched" / "report.md").read_text()
    assert "**Screened samples**" in report
    for stem, line, _ in got:
        assert f"| {stem} | {line} |" in report
    assert sum("sample(s) masked" in w for w in v["warnings"]) == 3
    assert sum(line.startswith("warning:") and "sample(s) masked" in line for line in printed.splitlines()) == 3
    code = main(["diagnose", str(tmp_path / "glitched"), "--model", "servo_pendulum", "--out",
                 str(tmp_path / "strict"), "--strict", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and f"{csvs[0].name}" in err and "line 394" in err, err


def test_a_log_with_rows_missing_is_split_at_the_gap_and_changes_nothing(tmp_path, capsys):
    """A host that stalled for 90 ms in a training recording (16 rows missing mid-swing): the log is split there,
    the part after the gap replayed from its reading, moving; the verdict and the held-out error are those of the
    intact set (within 1 %), and the report and the JSON name the cut."""
    shutil.copytree(shipped_recordings(), tmp_path / "gap")
    csvs = sorted((tmp_path / "gap").glob("*.csv"))
    _edit(csvs[5], lambda ls: ls.__delitem__(slice(599, 615)))
    code, v = _diagnose(tmp_path / "gap", tmp_path / "out_gap")
    assert code == 0
    code, ref = _diagnose(shipped_recordings(), tmp_path / "out_intact")
    assert code == 0
    assert v["causes"] == ref["causes"] == ["load"]
    assert v["heldout"]["extended"] == pytest.approx(ref["heldout"]["extended"], rel=0.01)
    (cut,) = v["screening"]["masked"]
    assert (cut["recording"], cut["line"], cut["kind"]) == (f"{csvs[5].stem} part 2", 600, "gap")
    assert any("split there" in w for w in v["warnings"])
    assert f"| {csvs[5].stem} part 2 | 600 | time_s |" in (tmp_path / "out_gap" / "report.md").read_text()
