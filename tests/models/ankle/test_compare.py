"""``acausal compare`` (models/drivetrains/compare.py): the conditions it runs, the table, the flags on exceeded limits,
the files it writes, and the CLI's arguments and errors."""
import argparse
import csv
import dataclasses
import re
import math
import sys
import types

import pytest

from acausal import ModelError
from acausal.models.drivetrains import compare
from acausal.models.ankle.registry import MODELS


@pytest.fixture(scope="module")
def results():
    return compare.run_models(["replay", "direct_drive", "battery"], stride_times=[2.0], jobs=2)


def parser():
    p = argparse.ArgumentParser(prog="acausal compare")
    compare.configure(p)
    return p


def test_conditions_cover_models_and_grid():
    conds = compare.conditions(["replay", "sea"], stride_times=[1.5, 2.0], precompressions=[0.005, 0.008])
    got = [(c.model, None if math.isnan(c.P) else c.P, c.stride_time) for c in conds]
    assert got == [("replay", 0.005, 1.5), ("replay", 0.005, 2.0), ("replay", 0.008, 1.5), ("replay", 0.008, 2.0),
                   ("sea", None, 1.5), ("sea", None, 2.0)]  # the SEA has no precompression: run once per T


@pytest.mark.parametrize("kw, message", [
    (dict(models=["replay", "maccepa_xl"]), "unknown model 'maccepa_xl'; known models: replay, closed_loop"),
    (dict(models=[]), "no model given; known models"),
    (dict(models=["sea", "sea"]), "named twice"),
    (dict(models=["sea"], stride_times=[0.0]), "stride time must be a positive"),
    (dict(models=["sea"], precompressions=[8.0]), "0-0.018 m"),
    (dict(models=["sea"], preset="nope"), "unknown preset 'nope'"),
    (dict(models=["sea"], overrides={"replay": {"link.k": 1.0}}), "not among the compared models"),
])
def test_bad_input_names_what_is_wrong(kw, message):
    with pytest.raises(ModelError, match=message):
        compare.conditions(**kw)


@pytest.mark.slow
def test_table_has_every_quantity_and_flags_the_direct_drive(results):
    rows = compare.records(results)
    assert [r["model"] for r in rows] == ["replay", "direct_drive", "battery"]
    rep, dd, bat = rows
    for key in ["E_source_J", "E_driver_J", "E_motor_J", "E_link_J", "E_output_J", "eff_driver", "eff_motor",
                "eff_gearing", "eff_output", "eff_total", "peak_source_W", "peak_output_W", "motor_speed_peak_rpm",
                "current_peak_A", "current_rms_A", "voltage_peak_V", "voltage_limit_V", "limits_exceeded"]:
        assert key in rep, key
    for r in rows:
        assert abs(r["balance_residual"]) < 1e-6
        assert r["eff_total"] == pytest.approx(r["E_output_J"] / r["E_source_J"])
        assert r["eff_driver"] * r["eff_motor"] * r["eff_gearing"] * r["eff_output"] == pytest.approx(r["eff_total"])
    assert math.isnan(dd["P_mm"]) and rep["P_mm"] == pytest.approx(8.0)
    # at 2 s/stride the direct drive needs more than 0.9 x 48 V at the motor: flagged, the value kept
    assert "voltage" in dd["limits_exceeded"] and dd["voltage_peak_V"] > dd["voltage_limit_V"] == pytest.approx(43.2)
    assert rep["limits_exceeded"] == "none"
    assert bat["E_returned_J"] > 0.1 and rep["E_returned_J"] < 1e-3
    assert dd["peak_motor_W"] > 2 * rep["peak_motor_W"]


def test_an_exceeded_limit_is_never_hidden(results):
    fast = dataclasses.replace(results[0], peak_motor_speed=3000.0, rms_motor_current=5.0)  # > 2618 rad/s, 3.47 A
    assert compare.exceeded(fast) == ["speed", "current_rms"]
    md = compare.markdown(compare.records([fast]))
    assert md.count("(limit exceeded)") == 2 and "replay at 8 mm, 2 s: speed, current_rms" in md


def test_outputs_are_written_and_read_back(results, tmp_path):
    paths = compare.write_outputs(results, tmp_path)
    with open(paths["csv"]) as f:
        back = list(csv.DictReader(f))
    rows = compare.records(results)
    assert [b["model"] for b in back] == [r["model"] for r in rows]
    for b, r in zip(back, rows):
        assert float(b["E_source_J"]) == pytest.approx(r["E_source_J"], rel=1e-8)
        assert b["limits_exceeded"] == r["limits_exceeded"]
    md = paths["markdown"].read_text()
    assert "| quantity | replay<br>8 mm, 2 s | direct_drive<br>2 s | battery<br>8 mm, 2 s |" in md
    assert "**" in md and "Limits exceeded:" in md and "`battery`:" in md
    assert sorted(p.name for p in paths["sankey"]) == ["sankey_battery.png", "sankey_direct_drive.png",
                                                       "sankey_replay.png"]
    assert all(p.stat().st_size > 10_000 for p in paths["sankey"])


def test_api_table_is_records_or_a_dataframe(results, monkeypatch):
    rows = compare.records(results)
    monkeypatch.setitem(sys.modules, "pandas", None)  # pandas not installed
    assert compare.as_table(rows) is rows
    fake = types.ModuleType("pandas")
    fake.DataFrame = lambda data: ("frame", data)
    monkeypatch.setitem(sys.modules, "pandas", fake)
    assert compare.as_table(rows) == ("frame", rows)


def test_cli_lists_models(capsys):
    args = parser().parse_args(["--list"])
    assert args.run(args) == 0
    out = capsys.readouterr().out
    for name in MODELS:
        assert name in out


@pytest.mark.parametrize("argv, message", [
    (["replay", "nope", "--out", "x"], "unknown model 'nope'; known models: replay"),
    (["replay", "--precompression", "0.008", "--out", "x"], "did you mean 8 mm"),
    (["replay", "--precompression", "25", "--out", "x"], "in mm \\(0-18\\)"),
    (["replay"], "--out DIR is required"),
    ([], "name at least one model"),
    (["battery", "--set", "motor.R", "--out", "x"], "expected \\[MODEL:\\]NAME=VALUE"),
    (["battery", "--set", "motor.R=abc", "--out", "x"], "'abc' is not a number"),
    (["battery", "--set", "motor.RR=0.5", "--out", "x"], "unknown parameter 'motor.RR'.*did you mean 'motor.R'"),
    (["battery", "--set", "replay:motor.R=0.5", "--out", "x"], "model 'replay' is not among the compared"),
    (["battery", "--set", "motor.R=-1", "--out", "x"], "motor.R.*minimum"),
])
def test_cli_errors(argv, message, capsys, tmp_path):
    args = parser().parse_args(argv)
    assert args.run(args) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "x").exists()


def test_cli_end_to_end(tmp_path, capsys):
    out = tmp_path / "cmp"
    args = parser().parse_args(["battery", "--stride-time", "2", "3", "--precompression", "8", "--out", str(out),
                                "--jobs", "1", "--no-progress"])
    assert args.run(args) == 0
    with open(out / "compare.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["model"], float(r["stride_time_s"]), float(r["P_mm"])) for r in rows] == [("battery", 2.0, 8.0),
                                                                                        ("battery", 3.0, 8.0)]
    assert (out / "sankey_battery.png").exists() and "compare.md" in capsys.readouterr().out


@pytest.mark.slow
def test_cli_sets_a_parameter(tmp_path, capsys):
    """``--set NAME=VALUE`` (SI units) reaches the simulation: a larger winding resistance loses more in the motor."""
    rows = {}
    for label, extra in (("datasheet", []), ("hot", ["--set", "motor.R=0.6"])):
        out = tmp_path / label
        args = parser().parse_args(["battery", "--stride-time", "2", "--precompression", "8", "--out", str(out),
                                    "--jobs", "1", "--no-progress", *extra])
        assert args.run(args) == 0
        with open(out / "compare.csv") as f:
            rows[label] = next(csv.DictReader(f))
    loss = {k: float(r["E_driver_J"]) - float(r["E_motor_J"]) for k, r in rows.items()}
    assert loss["hot"] > 1.2 * loss["datasheet"]
    # the table records what it was run with
    assert "- `--set battery:motor.R=0.6`" in (tmp_path / "hot" / "compare.md").read_text()
    assert "No `--set` values" in (tmp_path / "datasheet" / "compare.md").read_text()
