"""The HTML pages, without a browser: the paper's explorer embeds exactly the numbers of the run's CSVs,
is self-contained, deterministic and under 10 MB; ``Result.to_html`` embeds the accounts, the Sankey flows and the
balance of any run; ``acausal compare --html`` writes its page; without plotly the paper run still completes and
says why there is no page, and ``to_html`` fails naming the package and the install command.

The pages are built from one *small* ``acausal paper`` run (:func:`paper_folder`: 2 x 2 bench and replay conditions
of both presets, the examples that read them, a 3 x 3 design map; about 20 s), made once per test session and shared
with ``tests/docs/test_browser.py`` (under ``pytest -n`` the first worker makes it under a file lock, the other waits).
"""
from __future__ import annotations

import csv
import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from acausal import ModelError, Model, Start, compile_model, connect
from acausal.library.electrical import EMF, ConstantVoltage, Ground, Inductor, Resistor
from acausal.library.rotational import Damper, Fixed, Inertia
from acausal.library.sensors import ElectricalPowerSensor, MechanicalPowerSensor

#: each test here takes seconds (its simulations or its shared fixture): out of the quick lane
pytestmark = pytest.mark.slow

#: the small run's grid: precompressions [m] x stride times [s] (the Table 1 condition, 8 mm and 2 s, included)
SMALL_PS, SMALL_TS = (0.005, 0.008), (1.2, 2.0)


def _make_small_run(out: Path) -> None:
    """A small ``acausal paper`` output folder: the bench and replay at :data:`SMALL_PS` x :data:`SMALL_TS` for both
    presets, the examples that read them (Table 1, Figs. 8-12, 15), the design maps' example on a 3 x 3 grid (its
    refinement replaced by the grid optimum) and ``write_report`` (protocol, power traces, claims, index.html)."""
    from acausal.models.ankle.figures import run_section
    from acausal.models.ankle import paper
    from acausal.models.ankle.protocol import Condition
    from acausal.models.bench import design

    conds = [Condition(P, T, m, p, points_per_stride=101) for m in ("replay", paper.BENCH)
             for p in (paper.HEADLINE, paper.BESIDE) for P in SMALL_PS for T in SMALL_TS]
    results = paper.run_all(conds, progress=False, executor="serial")
    outputs = [run_section(name, str(out), results) for name in ("table1", "fig08_power_chain", "fig09_12_losses",
                                                                  "fig15_efficiency")]
    full_map = design.efficiency_map
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(design, "efficiency_map", lambda *a, **k: full_map(
            *a, **{**k, "ks": [90e3, 130e3, 170e3], "Ps": [0.004, 0.007, 0.010], "executor": "serial"}))
        mp.setattr(design, "refine", lambda m, overrides=None: m.optimum())
        outputs.append(run_section("fig16_17_design", str(out)))
    paper.write_report(out, results, outputs, quick=True)


def paper_folder(tmp_path_factory) -> Path:
    """The small run's folder (:func:`_make_small_run`), made once per session and shared by the xdist workers."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    out, done = root / "small_paper_run", root / "small_paper_run.done"
    try:
        import fcntl
    except ImportError:  # no file locks (Windows): each worker makes its own
        fcntl, out, done = None, base / "small_paper_run", base / "small_paper_run.done"
    with open(root / "small_paper_run.lock", "w") as lock:
        if fcntl:
            fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            _make_small_run(out)
            done.write_text("made\n")
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return paper_folder(tmp_path_factory)


def embedded(page: Path) -> dict:
    """The JSON a page embeds (``<script type="application/json" id="acausal-data">``)."""
    m = re.search(r'<script type="application/json" id="acausal-data">(.*?)</script>', page.read_text(), re.S)
    assert m, f"{page}: no embedded data"
    return json.loads(m.group(1).replace("<\\/", "</"))


def csv_columns(path: Path) -> dict:
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return {name: [r[j] for r in rows[1:]] for j, name in enumerate(rows[0])}


def same_cell(text: str, value) -> bool:
    """A CSV cell and its embedded value: the same number (empty or NaN as None) or the same text."""
    if isinstance(value, str):
        return value == text
    if value is None:
        return text.strip() == "" or math.isnan(float(text))
    return float(text) == value


def test_paper_page_embeds_every_csv_exactly(run):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    data = embedded(run / "index.html")
    tables = data["tables"]
    assert {"protocol", "power_traces", "table1", "claims", "fig09_driver_loss", "fig15_efficiency", "design_maps",
            "design_optima"} <= set(tables), sorted(tables)
    assert data["missing"] == []
    for name, table in tables.items():
        cols = csv_columns(run / table["file"])
        assert table["columns"] == list(cols), name
        for col, cells in cols.items():
            got = table["data"][col]
            assert len(got) == len(cells), (name, col)
            bad = [(c, v) for c, v in zip(cells, got) if not same_cell(c, v)]
            assert not bad, (name, col, bad[:3])


def test_power_traces_agree_with_the_protocols_energies(run):
    """power_traces.csv (written by write_report from the runs) integrates to the energies of protocol.csv."""
    with (run / "protocol.csv").open() as f:
        proto = [r for r in csv.DictReader(f) if r["model"] == "closed_loop"]
    with (run / "power_traces.csv").open() as f:
        traces = list(csv.DictReader(f))
    assert len(proto) == 2 * len(SMALL_PS) * len(SMALL_TS)
    for r in proto:
        mine = [t for t in traces if (t["preset"], t["P_mm"], t["stride_time_s"]) ==
                (r["preset"], r["P_mm"], r["stride_time_s"])]
        assert len(mine) == 101, (r["preset"], r["P_mm"], r["stride_time_s"])
        t = np.array([float(x["time_ms"]) for x in mine]) / 1e3
        assert t[0] == 0.0 and math.isclose(t[-1], float(r["stride_time_s"]))
        for k in ("source", "driver", "motor", "link", "output"):
            p = np.array([float(x[f"P_{k}_W"]) for x in mine])
            E = float(np.sum(np.diff(t) * (p[1:] + p[:-1]) / 2))
            assert E == pytest.approx(float(r[f"E_{k}_J"]), rel=0.02, abs=0.05), (k, r["preset"])


def test_paper_page_is_self_contained_small_and_deterministic(run, tmp_path):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    from acausal.models.reporting.explorer import paper_page
    page = run / "index.html"
    text = page.read_text()
    assert page.stat().st_size < 10e6
    assert text.count("<script") == 3  # plotly.js, the data, the page's script: all inline
    assert not re.search(r'<(?:script|link|img|iframe)[^>]*\s(?:src|href)="(?!data:)', text)
    assert "Plotly.react" in text and 'id="sankey-' in text
    again = paper_page(run, tmp_path / "again.html")
    assert again.read_bytes() == page.read_bytes()
    report = (run / "report.md").read_text()
    assert "[`index.html`](index.html)" in report and "[`power_traces.csv`](power_traces.csv)" in report


def test_paper_run_without_plotly_says_why_there_is_no_page(run, tmp_path, monkeypatch, capsys):
    from acausal.models.reporting.explorer import write_index
    for name in ("protocol.csv", "table1.csv"):
        (tmp_path / name).write_bytes((run / name).read_bytes())
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.offline", None)
    line = write_index(tmp_path)
    assert "plotly is not installed" in line and "acausal[html]" in line
    assert "index.html" in capsys.readouterr().err
    assert not (tmp_path / "index.html").exists()


def test_explorer_names_a_missing_or_broken_csv(tmp_path):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    from acausal import DataError
    from acausal.models.reporting.explorer import paper_page
    with pytest.raises(ModelError, match="not a folder"):
        paper_page(tmp_path / "nowhere")
    with pytest.raises(DataError, match="protocol.csv"):
        paper_page(tmp_path)
    (tmp_path / "protocol.csv").write_text("model,preset\nclosed_loop\n")
    with pytest.raises(DataError, match=r"protocol.csv, line 2: 1 cells for 2 columns"):
        paper_page(tmp_path)


# ---------------------------------------------------------------------------------------------- Result.to_html

class Chain(Model):
    """12 V -> electrical power sensor -> R, L -> motor (EMF) -> mechanical power sensor -> rotor, damper."""

    def build(self):
        self.src, self.gnd = ConstantVoltage(V=12.0), Ground()
        self.P_in = ElectricalPowerSensor()
        self.R, self.L, self.emf = Resistor(R=1.0), Inductor(L=1e-3, i=Start(0.0)), EMF(k=0.05)
        self.P_shaft = MechanicalPowerSensor()
        self.rotor, self.damper, self.fixed = Inertia(J=1e-4), Damper(d=1e-3), Fixed()
        connect(self.src.p, self.P_in.pc, self.P_in.pv)
        connect(self.P_in.nc, self.R.p)
        connect(self.R.n, self.L.p)
        connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p, self.P_in.nv)
        connect(self.emf.flange, self.P_shaft.flange_a)
        connect(self.P_shaft.flange_b, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.damper.flange_a)
        connect(self.damper.flange_b, self.fixed.flange)


@pytest.fixture(scope="module")
def chain_result():
    return compile_model(Chain()).simulate(0.2, n_points=401)


def test_result_page_chain_and_balance(chain_result, tmp_path):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    res = chain_result
    path = res.to_html(tmp_path / "chain.html", t0=0.05, names=["L.i", "rotor.w"], max_points=100)
    data = embedded(path)
    k0 = int(np.argmin(np.abs(res.t - 0.05)))
    s = data["sankey"]
    assert s["kind"] == "chain" and [p["key"] for p in s["points"]] == ["P_in.P", "P_shaft.P"]
    for p in s["points"]:
        assert p["J"] == float(res.energy(p["key"])[-1] - res.energy(p["key"])[k0])
    assert s["losses"][0]["label"] == "loss (R)"
    assert s["losses"][0]["J"] == pytest.approx(res.energy("R.loss_power")[-1] - res.energy("R.loss_power")[k0]
                                                 + res["L.energy"][-1] - res["L.energy"][k0], rel=1e-6)
    b = res.energy_balance(t0=0.05)
    assert data["balance"]["residual"] == b.residual and data["balance"]["delivered"] == b.delivered
    assert data["balance"]["residual_t"][0] == 0.0
    assert data["balance"]["residual_t"][-1] == pytest.approx(b.residual, rel=1e-6, abs=1e-12)
    names = [x["name"] for x in data["series"]]
    assert names[:2] == ["P_in.P", "P_shaft.P"] and {"R.loss_power", "L.i", "rotor.w"} <= set(names)
    units = {x["name"]: x["unit"] for x in data["series"]}
    assert units["L.i"] == "A" and units["rotor.w"] == "rad/s" and units["R.loss_power"] == "W"
    assert len(data["time"]) <= 101 and data["time"][-1] == res.t[-1]
    assert data["accounts"]["losses"] == ["R.loss_power", "damper.loss_power"]


def test_result_page_balance_without_sensors(tmp_path):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    from ..drive_models import MotorGearLoad
    res = compile_model(MotorGearLoad()).simulate(0.2, n_points=201)
    data = embedded(res.to_html(tmp_path / "drive.html"))
    s = data["sankey"]
    assert s["kind"] == "balance"
    ins, outs = res.energy_balance().flows()
    model = [n["label"] for n in s["nodes"]].index("model")
    assert sorted(link["value"] for link in s["links"] if link["target"] == model) == sorted(ins.values())
    assert sorted(link["value"] for link in s["links"] if link["source"] == model) == sorted(outs.values())
    assert any(x["name"] == "src (boundary, delivered)" for x in data["series"])


def test_result_page_bad_input_is_named(chain_result, tmp_path, monkeypatch):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    from acausal.errors import UnknownNameError
    res = chain_result
    with pytest.raises(ModelError, match="is a folder"):
        res.to_html(tmp_path)
    with pytest.raises(ModelError, match="does not exist"):
        res.to_html(tmp_path / "no" / "page.html")
    with pytest.raises(ModelError, match="names must be a list"):
        res.to_html(tmp_path / "p.html", names="L.i")
    with pytest.raises(UnknownNameError, match="nope"):
        res.to_html(tmp_path / "p.html", names=["nope"])
    with pytest.raises(ModelError, match="t1 = 5 s is outside"):
        res.to_html(tmp_path / "p.html", t1=5.0)
    with pytest.raises(ModelError, match="max_points"):
        res.to_html(tmp_path / "p.html", max_points=1)
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.offline", None)
    with pytest.raises(ModelError, match=r"needs plotly, which is not installed.*pip install \"acausal\[html\]\""):
        res.to_html(tmp_path / "p.html")
    assert not (tmp_path / "p.html").exists()


# ---------------------------------------------------------------------------------------------- acausal compare

def test_compare_html_writes_the_page_from_compare_csv(tmp_path, capsys):
    pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")
    from acausal.cli import main
    out = tmp_path / "cmp"
    assert main(["compare", "replay", "--stride-time", "2", "--out", str(out), "--jobs", "1", "--no-progress",
                 "--html"]) == 0
    assert f"page: {out / 'index.html'}" in capsys.readouterr().out
    data = embedded(out / "index.html")
    cols = csv_columns(out / "compare.csv")
    table = data["tables"]["compare"]
    assert table["columns"] == list(cols)
    assert all(same_cell(c, v) for col, cells in cols.items() for c, v in zip(cells, table["data"][col]))


def test_compare_html_without_plotly_fails_before_running(tmp_path, monkeypatch, capsys):
    from acausal.cli import main
    monkeypatch.setitem(sys.modules, "plotly", None)
    monkeypatch.setitem(sys.modules, "plotly.offline", None)
    assert main(["compare", "replay", "--out", str(tmp_path / "c"), "--html"]) == 2
    assert "acausal compare --html: writing an HTML page needs plotly" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
