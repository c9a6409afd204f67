"""One actuator that owns its parameters: parameters travel through the model (body mass, precompression replan the
trajectory), energy accounts are found by convention, and models/ stays a shallow house that loads only what it
uses."""
import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from acausal import Model, ModelError, ParametricSignal, Start, compile_model, connect
from acausal.library.electrical import Capacitor, Ground, PrescribedVoltage, Resistor
from acausal.models.ankle.actuator import AnkleActuator

from ...circuit_models import RC

from acausal.models.ankle.planning import planned_arm_angle
from acausal.models.ankle.protocol import Condition, compiled, run_condition

MODELS_DIR = Path(__file__).resolve().parent.parent.parent.parent / "models"


@pytest.fixture(scope="module")
def replay():
    return compiled("replay").sim


@pytest.mark.slow
def test_body_mass_acts_through_the_planned_trajectory(replay):
    """The joint torque is the gait moment times body mass: the trajectory is replanned from the run's value (the
    lossless linkage of the library preset, so the torque is exact)."""
    T = 2.0
    runs = {m: replay.simulate(T, params={"stride_time": T, "body_mass": m, "link.r_f": 0.0}, n_points=401,
                               rtol=1e-8, atol=1e-10)
            for m in (60.0, 90.0)}
    for m, res in runs.items():
        moment = m * np.interp(res.t / T % 1.0, *_unit_moment())
        assert np.max(np.abs(res["joint_torque"] - moment)) < 0.02 * np.max(np.abs(moment)), m
    e60, e90 = (abs(r.energy("P_output.P")[-1]) for r in runs.values())
    assert e90 > 1.3 * e60  # more joint work for the heavier user (the angle is the same, the torque is not)


def _unit_moment():
    from acausal.library.gait import unit_cycle
    s = np.linspace(0, 1, 2001)
    return s, unit_cycle().torque(s)


@pytest.mark.slow
def test_a_run_parameter_replans_exactly_as_an_explicit_input(replay):
    """Setting P_nominal, link.k and body_mass gives the same run as handing the planned trajectory over."""
    params = {"stride_time": 1.5, "P_nominal": 0.011, "link.k": 150e3, "body_mass": 75.0}
    own = replay.simulate(3.0, params=params, n_points=301)
    given = replay.simulate(3.0, params=params, n_points=301,
                            inputs={"arm_ref.profile": planned_arm_angle(0.011, 150e3, 0.1, 0.06, 75.0)})
    np.testing.assert_array_equal(own["motor.i"], given["motor.i"])
    default = replay.simulate(3.0, params={"stride_time": 1.5}, n_points=301)
    assert np.max(np.abs(default["motor.i"] - own["motor.i"])) > 0.1


def test_parametric_signal_errors_name_the_parameter():
    sig = ParametricSignal(lambda c: c, {"c": "link.c"}, name="plan")
    with pytest.raises(Exception, match="link.c"):
        sig.bind({"link.k": 1.0})
    with pytest.raises(Exception, match="batch"):
        sig.bind({"link.c": np.array([1.0, 2.0])})


def test_accounts_of_the_paper_actuator_are_found_by_convention(replay):
    acc = replay.accounts
    assert acc.sensors == ("P_source.P", "P_driver.P", "P_motor.P", "P_link.P", "P_output.P")
    assert acc.losses == ("supply.loss_power", "rect.loss_power", "driver.loss_power", "motor.loss_power",
                          "rotor_friction.loss_power", "planetary.loss_power", "helical.loss_power",
                          "link.loss_power")
    assert acc.stored == ("rect.bus_energy", "motor.energy", "rotor.energy", "planetary.energy", "helical.energy",
                          "link.energy")
    assert acc.sources == ("supply.source_power",)
    assert "rect.diode.loss_power" not in acc.losses  # inside an accounted component: counted by it
    r = run_condition(Condition(0.008, 2.0))
    assert r.stages == {"driver": ["supply.loss_power", "rect.loss_power", "driver.loss_power"],
                        "motor": ["motor.loss_power"],  # the air gap's k i w is the motor point (paper Eq. 6)
                        "gearing": ["rotor_friction.loss_power", "planetary.loss_power", "helical.loss_power"],
                        "output": ["link.loss_power"]}


def test_energy_balance_of_any_model():
    """A user's model with no accounts listed: the source's boundary work = resistor loss + capacitor energy."""
    res = compile_model(RC()).simulate(1.3, rtol=1e-9, atol=1e-12)
    b = res.energy_balance()
    assert set(b.boundary) >= {"src"} and list(b.losses) == ["R.loss_power"] and list(b.stored) == ["C.energy"]
    assert abs(b.residual) < 1e-6
    assert b.boundary["src"] == pytest.approx(b.losses["R.loss_power"] + b.stored["C.energy"], rel=1e-6)
    assert "relative residual" in str(b)


class _SensedRC(Model):
    """Source -[P_in]- R -[P_cap]- C: two power sensors in chain order."""

    def build(self):
        import sympy as sp
        from acausal import time
        from acausal.library.sensors import ElectricalPowerSensor
        self.src = PrescribedVoltage(v_ref=10 * sp.sin(2 * sp.pi * time))
        self.P_in = ElectricalPowerSensor()
        self.R = Resistor(R=2.0)
        self.P_cap = ElectricalPowerSensor()
        self.C = Capacitor(C=0.05, v=Start(0.0))
        self.gnd = Ground()
        connect(self.src.p, self.P_in.pc, self.P_in.pv)
        connect(self.P_in.nc, self.R.p)
        connect(self.R.n, self.P_cap.pc, self.P_cap.pv)
        connect(self.P_cap.nc, self.C.p)
        connect(self.C.n, self.src.n, self.gnd.p, self.P_in.nv, self.P_cap.nv)


def test_sankey_and_stages_of_any_model_with_power_sensors():
    import matplotlib
    matplotlib.use("Agg")
    res = compile_model(_SensedRC()).simulate(0.25, rtol=1e-9, atol=1e-12)
    acc = res.model.accounts
    assert acc.sensors == ("P_in.P", "P_cap.P") and acc.stages["P_cap.P"] == ["R.loss_power"]
    ax = res.sankey()
    texts = " ".join(t.get_text() for t in ax.texts)
    assert "R" in texts and "P_in" in texts
    e_in, e_cap = res.energy("P_in.P")[-1], res.energy("P_cap.P")[-1]
    assert e_in - e_cap == pytest.approx(res.energy("R.loss_power")[-1], rel=1e-6)


def test_sankey_of_a_model_without_power_sensors_draws_its_balance():
    """No measurement points: the balance itself as one diagram, every account drawn (small ones as "other")."""
    import matplotlib
    matplotlib.use("Agg")
    res = compile_model(RC()).simulate(0.2, rtol=1e-9, atol=1e-12)  # the capacitor is still charging
    b = res.energy_balance()
    ins, outs = b.flows()
    assert ins == {"src (boundary)": pytest.approx(b.boundary["src"])}
    assert set(outs) == {"R loss", "C (stored)"}
    assert sum(ins.values()) == pytest.approx(sum(outs.values()), rel=1e-6)
    texts = " ".join(t.get_text() for t in res.sankey().texts)
    assert "src (boundary)" in texts and "R loss" in texts and "C (stored)" in texts


def test_efficiency_between_two_named_ports():
    """Capacitor charged through R from 0 V by a constant source: half the delivered energy is stored."""
    res = compile_model(RC(v_ref=10.0)).simulate(3.0, rtol=1e-10, atol=1e-12)  # 30 time constants
    assert res.efficiency("src", "C") == pytest.approx(0.5, rel=1e-6)  # port signs do not matter
    assert res.efficiency("src", "R.loss_power") == pytest.approx(0.5, rel=1e-6)
    b = res.energy_balance(between=("src", "C"))
    assert b.efficiency == pytest.approx(0.5, rel=1e-6) and b.efficiency_path == ("src", "C")
    assert "efficiency src -> C: 0.5" in str(b)
    t1 = res.t[np.argmin(np.abs(res.t - 0.1))]  # the output time nearest to one time constant
    assert res.efficiency("src", "C", t1=0.1) == pytest.approx((1 - np.exp(-t1 / 0.1)) / 2, rel=1e-6)
    with pytest.raises(ModelError, match="no net energy passed 'C'"):
        res.efficiency("C", "src", t0=3.0)


@pytest.mark.parametrize("switched", [False, True])
def test_efficiency_follows_the_integrator_not_the_output_grid(switched):
    """Outputs 1 s apart and the whole charging transient (RC = 0.1 s) inside one output interval: the energies
    of ports that are not among the model's accounts are integrated on the integrator's steps (on the compiled path
    by one more run with them as quadratures), so half the delivered energy is stored, to the run's tolerance,
    with and without state events (a source switched on at 0.5 s: a time event)."""
    import sympy as sp
    from acausal import time
    v_ref = sp.Piecewise((10.0, time >= 0.5), (0.0, True)) if switched else 10.0
    sim = compile_model(RC(v_ref=v_ref))
    for method in ("auto", "BDF"):
        res = sim.simulate(3.0, n_points=4, method=method)
        assert res.efficiency("src", "C") == pytest.approx(0.5, rel=1e-5), (method, res.solver)
        assert -res.energy("src")[-1] == pytest.approx(100 * 0.05, rel=1e-5)  # C V^2 = 5 J delivered
    if _compiled():
        assert "compiled path" in sim.simulate(3.0, n_points=4).solver


def _compiled() -> bool:
    from acausal.simulation.compiled import available
    return available()


def test_options_are_checked_with_model_errors():
    with pytest.raises(ModelError, match="option supply"):
        AnkleActuator(supply="solar")
    with pytest.raises(ModelError, match="option mode"):
        AnkleActuator(mode="open_loop")
    with pytest.raises(ModelError, match="recorded"):
        AnkleActuator(mode="closed_loop", motion="recorded")
    with pytest.raises(ModelError, match="gears='ideal'"):
        AnkleActuator(effects=("gear_load_dependent_loss",))


def _loaded(code: str) -> list:
    out = subprocess.run([sys.executable, "-c", code + "; import sys; print(' '.join(sorted(m for m in sys.modules "
                          "if m.startswith(('acausal.models', 'acausal.library')))))"],
                         capture_output=True, text=True, check=True)
    return out.stdout.split()


@pytest.mark.slow
def test_reports_and_the_command_line_load_no_model():
    for code in ("import acausal.models.bench.diagnosis_report", "import acausal.models.reporting.tables",
                 "from acausal.cli import build_parser; build_parser()"):
        loaded = _loaded(code)
        models = [m for m in loaded if m.endswith(("actuator", "direct_drive", "sea", "parallel_elastic",
                                                    "switch_off", "calibration", "virtual", "paper"))]
        assert not models, (code, models)


def _imports(path: Path) -> set:
    """Modules of models/ that ``path`` imports (absolute or relative), by dotted name under acausal.models."""
    pkg = path.relative_to(MODELS_DIR).with_suffix("").parts
    here = pkg[:-1] if pkg[-1] != "__init__" else pkg[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(here[:len(here) - node.level + 1]) if node.level > 1 else list(here)
                parts = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.startswith("acausal.models"):
                parts = node.module.split(".")[2:]
            else:
                continue
            for alias in node.names:
                for cand in (parts + [alias.name], parts):
                    if (MODELS_DIR.joinpath(*cand).with_suffix(".py")).exists():
                        out.add(".".join(cand))
                        break
    return out


def test_models_is_a_shallow_house():
    top = [p.name for p in MODELS_DIR.iterdir() if p.name != "__pycache__"]
    assert len(top) <= 6, top
    mods = {".".join(p.relative_to(MODELS_DIR).with_suffix("").parts): p for p in MODELS_DIR.rglob("*.py")
            if p.name != "__init__.py"}
    graph = {m: _imports(p) & set(mods) for m, p in mods.items()}
    depth: dict = {}

    def floor(m, seen=()):
        if m in seen:
            raise AssertionError(f"import cycle through {m}")
        if m not in depth:
            depth[m] = 1 + max((floor(d, seen + (m,)) for d in graph[m]), default=0)
        return depth[m]
    # the paper report's sections (ankle.figures, run by `acausal paper`) are the top floor: one above the models
    # they plot, imported by nothing else in models/
    sections = {m for m in mods if m.startswith("ankle.figures.")}
    deepest = max(set(mods) - sections, key=floor)
    assert floor(deepest) <= 5, (deepest, depth)
    assert max(floor(m) for m in sections) <= 6, {m: depth[m] for m in sections}
    assert not [m for m in set(mods) - sections if graph[m] & sections], "a model imports a report section"


def test_every_package_ships():
    """Each folder with an __init__.py is a package of the distribution (a wheel would miss it otherwise)."""
    import tomllib
    root = MODELS_DIR.parent
    conf = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    dirs = {str(Path(d)) for d in conf["package-dir"].values()}
    assert set(conf["packages"]) == set(conf["package-dir"])
    for top in ("acausal", "library", "models"):
        for init in (root / top).rglob("__init__.py"):
            assert str(init.parent.relative_to(root)) in dirs, init.parent


@pytest.mark.slow
def test_frictional_linkage_option_loses_energy_between_arm_and_joint():
    """``linkage="frictional"``: the link's loss is found by convention, the balance closes, the output stage
    loses energy, and the joint torque falls short of the gait moment by the friction (reported)."""
    model = AnkleActuator(linkage="frictional")
    sim = compile_model(model)
    assert "link.loss_power" in sim.accounts.losses
    T = 2.0
    res = sim.simulate(2 * T, params={"stride_time": T, "link.r_f": 1e-3}, n_points=401, rtol=1e-9, atol=1e-11)
    b = res.energy_balance(t0=T)
    assert abs(b.residual) < 1e-6 and b.losses["link.loss_power"] > 0.5
    link, out = (res.energy(n)[-1] - res.energy(n)[200] for n in ("P_link.P", "P_output.P"))
    assert link - out == pytest.approx(b.losses["link.loss_power"] + b.stored["link.energy"], rel=1e-6)
    assert 0.05 < 1 - out / link < 0.3  # r_f = 1 mm: about 11 % at 8 mm (the paper: about 20 % on average)
    with pytest.raises(ModelError, match="option linkage"):
        AnkleActuator(linkage="greased")
