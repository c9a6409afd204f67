"""`acausal paper --quick` end to end, from this checkout and from a wheel installed into a fresh environment
(tests/cli/wheel_support.py): the report, every figure with the CSV behind it, the same bytes from both; the wheel's
other verbs (info, check and diagnose on the shipped servo set, export) and a first model; bad command lines
failing loudly."""
import csv
import json
import re
import subprocess
import zipfile
from pathlib import Path

import pytest

from acausal.cli import main
from acausal.models.ankle.figures import SECTIONS

from .paper_hashseed import SEEDS, compare_csvs, quick_runs_under_hash_seeds
from .wheel_support import installed_wheel

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow

FIGURES = ["table1_sankey", "fig07_direct_drive", "fig08_power_chain", "fig09_driver_loss", "fig10_motor_loss",
           "fig11_gearing_loss", "fig12_output_loss", "fig13_tracking", "fig15_efficiency", "table2_presets"]
TABLES = ["table1", "fig07_summary", "table2", "protocol"]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The package as a user gets it: a wheel of a clean copy of the checkout in a fresh environment, its
    commands run from a folder outside the checkout (tests/cli/wheel_support.py)."""
    return installed_wheel(tmp_path_factory.mktemp("wheel"))


@pytest.fixture(scope="module")
def runs(tmp_path_factory, wheel):
    """`acausal paper --quick` in two fresh processes with different hash seeds, side by side (one worker each),
    the second from the installed wheel: the report tests read the first, the hash-seed test compares the two."""
    return quick_runs_under_hash_seeds(tmp_path_factory.mktemp("paper"),
                                       {SEEDS[1]: ([str(wheel.script)], wheel.workdir)})


@pytest.fixture(scope="module")
def out(runs):
    return runs[SEEDS[0]]



def test_paper_csvs_are_byte_identical_across_hash_seeds_and_from_the_wheel(runs):
    """See ``tests/cli/paper_hashseed.py``: the second run is also the installed wheel's."""
    compare_csvs(runs)


def test_the_wheel_writes_the_same_report(runs):
    """The installed wheel's report is the editable install's, line for line but the wall time."""
    a, b = ([line for line in (runs[s] / "report.md").read_text().splitlines() if not _timed(line)] for s in SEEDS)
    assert len(a) > 100 and a == b, next((x, y) for x, y in zip(a, b) if x != y)


def _timed(line: str) -> bool:
    return bool(re.search(r"\d s\b|\bin [\d.]+ ?s\b|wall time|elapsed", line))

def test_report_has_table1_next_to_the_paper(out):
    text = (out / "report.md").read_text()
    assert "## Table 1" in text
    for paper_value in ("64.5", "42.0", "33.0", "15.4", "12.0", "34.9 %", "53.3 %", "18.6 %"):
        assert paper_value in text, paper_value
    assert "## Inferred parameters (`paper_fit`)" in text and "Every other number is a prediction" in text
    assert "`library`" in text  # the a-priori preset beside the headline
    assert "ratio" in text
    # every figure is embedded, every difference > 25 % comes with the assumption behind it
    for stem in FIGURES:
        assert f"]({stem}.png)" in text, stem
    n_flagged = text.count("**(> 25 %)**")
    assert n_flagged == text.count("differs by more than 25 %") > 0
    assert "largest |residual|" in text and "motor could not follow" in text


def test_every_figure_has_its_csv(out):
    for stem in FIGURES:
        png = out / f"{stem}.png"
        assert png.stat().st_size > 10_000, stem
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (out / f"{stem}.csv").stat().st_size > 0, stem
    for name in TABLES:
        assert (out / f"{name}.csv").stat().st_size > 0, name


def test_the_explorer_page_is_written_beside_the_report(out):
    """With plotly installed (the test extra) the run writes its page, linked from the report."""
    pytest.importorskip("plotly", reason="the page needs plotly (the html and test extras)")
    page = out / "index.html"
    assert page.stat().st_size > 1_000_000  # plotly.js inline
    assert "index.html" in (out / "report.md").read_text()
    assert (out / "power_traces.csv").stat().st_size > 0


def test_csvs_parse(out):
    for path in out.glob("*.csv"):
        with path.open() as f:
            rows = list(csv.DictReader(f))
        assert rows, path.name
        assert all(len(r) == len(rows[0]) and None not in r for r in rows), path.name
        numeric = [k for k, v in rows[0].items() if re.fullmatch(r"-?[\d.]+(e[-+]?\d+)?", v or "")]
        assert numeric or path.name in ("claims.csv", "figure_verdicts.csv"), path.name  # verdicts in words
        for r in rows:
            for k in numeric:
                float(r[k])


def test_every_protocol_csv_row_says_its_preset(out):
    """The CSVs of protocol runs, design maps and the Eq. 4 calibration carry a preset column (the calibration's:
    the chain its recordings come from); the gear-loss diagnosis describes its own Eq. 4 truth instead."""
    calibration = ["calibration", "calibration_rmse", "table2_calibrated", "fig14_calibration"]
    for stem in calibration:
        assert (out / f"{stem}.csv").exists(), stem
    for stem in [*FIGURES, *TABLES, *calibration, "claims", "design_maps", "design_optima", "fig09_driver_loss",
                 "fig15_efficiency", "fig17_linkage_friction"]:
        path = out / f"{stem}.csv"
        if not path.exists():
            continue
        with path.open() as f:
            rows = list(csv.DictReader(f))
        assert rows and all(r.get("preset") for r in rows), stem


def test_table1_csv_matches_the_paper_column(out):
    with (out / "table1.csv").open() as f:
        rows = {r["point"]: r for r in csv.DictReader(f)}
    assert [float(rows[k]["paper_energy_J"]) for k in ("source", "driver", "motor", "link", "output")] == \
        [64.5, 42.0, 33.0, 15.4, 12.0]
    for r in rows.values():  # the simulation is in the paper's range without being tuned to it
        assert 0.5 < float(r["ratio_energy"]) < 1.5


def test_protocol_csv_one_row_per_condition(out):
    with (out / "protocol.csv").open() as f:
        rows = list(csv.DictReader(f))
    for preset in ("paper_fit", "library"):
        replay = [r for r in rows if r["model"] == "replay" and r["preset"] == preset]
        assert len(replay) == 9  # quick grid: 3 precompressions x 3 stride times
    # every condition's energy balance closes, the Table 2 presets' included (the scipy path's BDF left 5e-6 on the
    # datasheet preset; the compiled path, the default, 2e-8)
    worst = max(rows, key=lambda r: abs(float(r["balance_residual"])))
    assert abs(float(worst["balance_residual"])) < 1e-6, (worst["model"], worst["preset"], worst["P_mm"])
    assert {r["model"] for r in rows} == {"replay", "closed_loop", "direct_drive", "bench_output_motor"}
    assert all(r["preset"] for r in rows)


def test_examples_registered():
    """Every script in examples/ runs a section of `acausal paper`'s report (which ships in the package, so these
    tests exercise it) or is a declared standalone example with a test of its own (tests/models/servo/test_servo.py)."""
    examples = Path(__file__).resolve().parent.parent.parent / "examples"
    scripts = {p.stem: p.read_text() for p in examples.glob("*.py")}
    assert set(SECTIONS) | {"servo_friction"} == set(scripts)
    for name in SECTIONS:
        assert f"from acausal.models.ankle.figures import {name}\n" in scripts[name], name


def test_an_unknown_report_section_is_named():
    from acausal.models.ankle.figures import section
    with pytest.raises(KeyError, match="no report section 'table9'.*table1"):
        section("table9")


def test_diagnose_on_a_missing_folder_fails_clearly(tmp_path, capsys):
    assert main(["diagnose", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")]) == 2
    assert "nowhere" in capsys.readouterr().err


def test_no_verb_is_an_error(capsys):
    assert main([]) == 2


def test_claims_table_is_written_and_in_the_report(out):
    with (out / "claims.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [(r["preset"], r["id"]) for r in rows] == [(p, f"C{i}") for p in ("paper_fit", "library")
                                                      for i in range(1, 14)]
    assert set(rows[0]) >= {"id", "statement", "paper", "simulated", "holds", "used_in_fit", "note", "preset"}
    assert {r["holds"] for r in rows} <= {"yes", "no", "not checked"}
    held = {r["id"]: r["holds"] for r in rows if r["preset"] == "paper_fit"}
    assert held["C2"] == "not checked"  # the quick grid has 9 of the 36 conditions
    assert held["C1"] in ("yes", "no") and held["C10"] in ("yes", "no")
    fitted = {r["id"] for r in rows if r["used_in_fit"] == "yes"}
    from acausal.models.ankle.fit_record import fitted_claims
    from acausal.models.ankle.presets import paper_fit_record
    assert fitted == fitted_claims(paper_fit_record()) == {"C1", "C2", "C3", "C7", "C8", "C10"}
    assert all(r["used_in_fit"] == "no" for r in rows if r["preset"] == "library")
    text = (out / "report.md").read_text()
    assert "## Claims" in text and f"**{sum(h == 'yes' for h in held.values())} of 13 hold** with" in text


def test_every_link_in_the_report_resolves(out):
    text = (out / "report.md").read_text()
    links = set(re.findall(r"\]\(([^)#]+\.(?:png|csv|md|json))\)", text))
    assert links
    missing = [link for link in links if not (out / link).exists()]
    assert not missing, missing


# ------------------------------------------------------------------------------------- the installed wheel
def _wheel_python(wheel, code: str) -> str:
    proc = subprocess.run([str(wheel.python), "-c", code], cwd=wheel.workdir, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_the_wheel_says_what_it_has(wheel):
    proc = wheel.run("info")
    assert proc.returncode == 0, proc.stderr
    for part in ("optional accelerators:", "CasADi", "C compiler", "native loop", "a default run takes",
                 "shipped data sets:", str(wheel.python.parent.parent)):
        assert part in proc.stdout, part


def test_the_wheel_checks_and_diagnoses_the_shipped_servo_set(wheel):
    """The XL330 recordings ship in the wheel: `acausal check` reads all 16, `acausal diagnose` calibrates on
    them and names the load-dependent friction from the one candidate it is given."""
    data = _wheel_python(wheel, "from acausal.cli import shipped_data; print(shipped_data()['xl330'][0])").strip()
    assert Path(data).is_relative_to(wheel.python.parent.parent)
    proc = wheel.run("check", data, "--model", "servo_pendulum")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "16 recordings" in proc.stdout + proc.stderr
    out = wheel.workdir / "servo"
    proc = wheel.run("diagnose", data, "--model", "servo_pendulum", "--candidates", "load", "--max-effects", "1",
                     "--jobs", "1", "--no-progress", "--out", str(out), "--json", str(out / "verdict.json"))
    assert proc.returncode == 0, proc.stderr[-3000:]
    verdict = json.loads((out / "verdict.json").read_text())
    assert verdict["causes"] == ["load"], verdict["causes"]
    assert (out / "report.md").stat().st_size > 1000


def test_the_wheel_exports_an_fmu(wheel):
    from acausal.backends.ccompiler import which_compiler
    fmu = wheel.workdir / "replay.fmu"
    binary = which_compiler()[0] is not None
    proc = wheel.run("export", "replay", "--fmu", str(fmu), *(() if binary else ("--no-binary",)))
    assert proc.returncode == 0, proc.stderr[-3000:]
    with zipfile.ZipFile(fmu) as z:
        names = z.namelist()
    assert "modelDescription.xml" in names and any(n.startswith("sources/") for n in names), names
    assert any(n.startswith("binaries/") for n in names) == binary, names


def test_a_first_model_from_the_wheel(wheel):
    """The users' guide's first model and its checks (docs/getting-started.md's first two blocks), run by the
    wheel's interpreter outside the checkout."""
    from ..docs.test_docs import python_blocks
    blocks = [src for _, src in python_blocks(Path(__file__).resolve().parent.parent.parent / "docs" / "getting-started.md")]
    out = _wheel_python(wheel, "\n".join(blocks[:2]) + "\nprint('solver:', res.solver)")
    assert "load speed" in out and "solver:" in out, out
