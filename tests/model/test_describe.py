"""Self-describing declarations: help() and a notebook show a parameter's default, unit, bounds
and doc, and a variable's start, unit and flags, not an object address."""
import pydoc

from acausal import Flow, Parameter, Potential, Variable
from acausal.library.drives import DCMotor


def test_parameter_repr_has_default_unit_bounds_and_doc():
    assert repr(Parameter(0.386, unit="Ohm", min=0.0, doc="winding")) == \
        "Parameter(0.386, unit='Ohm', min=0.0, doc='winding')"
    assert repr(Parameter()) == "Parameter(None, unit='1')"
    assert repr(Parameter(2.0, max=5)) == "Parameter(2.0, unit='1', max=5)"


def test_variable_reprs_name_their_kind_start_and_flags():
    assert repr(Variable(1.5, unit="A", fixed=True)) == "Variable(start=1.5, unit='A', fixed=True)"
    assert repr(Potential(unit="V", doc="pin voltage")) == "Potential(start=0.0, unit='V', doc='pin voltage')"
    assert repr(Flow(unit="A", state_select="never")) == "Flow(start=0.0, unit='A', state_select='never')"


def test_help_of_a_component_shows_its_parameters():
    text = pydoc.render_doc(DCMotor, renderer=pydoc.plaintext)
    assert "R = Parameter(0.386, unit='Ohm', min=0.0" in text
    assert "object at 0x" not in text


# ------------------------------------------------------------------ describe(), equations(), names()
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import sympy as sp  # noqa: E402

from acausal import Model, Start, compile_model, connect, time  # noqa: E402
from acausal.model.describe import Listing  # noqa: E402
from acausal.errors import ModelError  # noqa: E402
from acausal.library.drives import EPOS2, PWMDriver  # noqa: E402
from acausal.library.electrical import EMF, Ground, Inductor, PrescribedVoltage, Resistor, Supply  # noqa: E402
from acausal.library.rotational import Damper, Fixed, Inertia  # noqa: E402


class _Drive(Model):
    def build(self):
        self.src = PrescribedVoltage(v_ref=12.0 * sp.Min(time / 0.1, 1))
        self.R, self.L = Resistor(R=0.386), Inductor(L=6.53e-5, i=Start(0.0))
        self.emf, self.rotor = EMF(k=0.0273), Inertia(J=3.33e-6)
        self.fr, self.house, self.gnd = Damper(d=1e-4), Fixed(), Ground()
        connect(self.src.p, self.R.p); connect(self.R.n, self.L.p); connect(self.L.n, self.emf.p)
        connect(self.emf.n, self.src.n, self.gnd.p); connect(self.emf.flange, self.rotor.flange_a)
        connect(self.rotor.flange_b, self.fr.flange_a); connect(self.fr.flange_b, self.house.flange)


def test_describe_on_class_and_instance_lists_parameters_ports_and_variables():
    text = DCMotor.describe()
    assert isinstance(text, Listing) and repr(text) == str(text)  # shows as text in a notebook
    row = next(ln for ln in text.splitlines() if ln.strip().startswith("R "))
    assert "0.386" in row and "Ohm" in row and "[0, inf]" in row and "maxon EC-4pole 30" in row
    assert "flange" in text and "Flange" in text and "(rotational)" in text and "(electrical)" in text
    assert "copper_loss" in text and "start 0" in text
    mine = DCMotor(R=1.25).describe()
    row = next(ln for ln in mine.splitlines() if ln.strip().startswith("R "))
    assert "1.25" in row and "default of" not in row  # a given value is not a device default
    generic = next(ln for ln in PWMDriver.describe().splitlines() if ln.strip().startswith("P_q "))
    assert generic.split()[2] == "0" and "default of" not in generic  # a neutral default names no device


def test_help_shows_the_parameter_table_and_ports_in_the_class_docstring():
    text = pydoc.render_doc(Resistor, renderer=pydoc.plaintext)
    assert "Parameters (name = default, unit, bounds, doc):" in text
    assert "Ports:" in text and "positive pin" in text
    # the original docstring keeps its own indentation (the table does not shift it)
    assert "\n |  Ideal linear resistor" in text


def test_equations_of_one_component_as_written_and_as_solved():
    sim = compile_model(_Drive())
    text = sim.equations("R")
    assert "Resistor 'R':" in text and "R.v = R.R*R.i" in text
    assert "Inductor" not in text
    whole = sim.equations()
    assert "connect(" in whole and "Inertia 'rotor':" in whole
    solved = sim.equations("R", solved=True)
    assert "after alias elimination" in solved and "aliases (eliminated):" in solved and "R.p.v =" in solved
    with pytest.raises(ModelError, match="unknown component 'Rr'.*'R'"):
        sim.equations("Rr")


def test_names_filter_by_pattern_and_include_parameters():
    sim = compile_model(_Drive())
    res = sim.simulate(0.2)
    assert res.names("*.loss_power") == ["R.loss_power", "fr.loss_power"]
    assert "R.R" not in res.names("R.") and "R.R" in res.names("R.", parameters=True)
    assert res.names("[RL].i") == ["L.i", "R.i"]
    assert all("emf" in n for n in res.names("emf"))
    assert set(res.names()) <= set(res.names(parameters=True))
    assert res["R.R"][0] == 0.386  # what names() lists, the result answers


# ------------------------------------------------------------------ device defaults
class _Bench(Model):
    def __init__(self, driver_cls=PWMDriver, **kw):
        super().__init__(**kw)
        self._cls = driver_cls

    def build(self):
        self.supply = Supply(V=24.0)
        self.driver = self._cls(command="duty")
        self.motor = DCMotor(R=1.0)
        from acausal.library.blocks import SignalSource
        self.cmd = SignalSource(signal=0.5)
        self.load, self.house, self.gnd = Damper(d=1e-3), Fixed(), Ground()
        connect(self.supply.p, self.driver.bus_p); connect(self.supply.n, self.driver.bus_n, self.gnd.p)
        connect(self.cmd.y, self.driver.u)
        connect(self.driver.mot_p, self.motor.p); connect(self.driver.mot_n, self.motor.n)
        connect(self.motor.flange, self.load.flange_a); connect(self.load.flange_b, self.house.flange)


def test_report_lists_parameters_left_at_a_device_default():
    sim = compile_model(_Bench(driver_cls=EPOS2))
    dev = sim.device_defaults()
    assert dev["driver.P_q"] == (12.5, "W", "maxon EPOS2 70/10")
    assert dev["motor.L"][2] == "maxon EC-4pole 30, 48 V winding"
    assert "motor.R" not in dev and "supply.V" not in dev  # given at construction
    assert "supply.R_int" in dev  # left at the bench supply's assumption
    assert "driver.P_q" not in sim.device_defaults(params={"driver.P_q": 3.0})  # a run's override counts
    report = sim.report()
    assert "left at a device's datasheet default" in report
    assert "maxon EPOS2 70/10: driver.P_q = 12.5 W" in report
    assert "load.d" not in "".join(report.splitlines()[-4:])  # a value the user gave is not listed


def test_report_names_unconnected_ports():
    """A port left open is legal (its flow is zero, as in Modelica) but is usually a forgotten connect: the report
    names every one (new-user trial: a motor left unconnected to its load ran at no-load speed, unreported)."""
    from acausal import Model, connect
    from acausal.library.electrical import Capacitor, ConstantVoltage, Ground, Resistor

    class Open(Model):
        def build(self):
            self.src, self.R, self.C, self.g = ConstantVoltage(V=1.0), Resistor(R=1.0), Capacitor(C=1.0), Ground()
            self.R2 = Resistor(R=3.0)
            connect(self.src.p, self.R.p)
            connect(self.R.n, self.C.p, self.R2.p)
            connect(self.C.n, self.src.n, self.g.p)

    line = [ln for ln in compile_model(Open()).report().splitlines() if "unconnected ports" in ln]
    assert line and line[0].endswith("): R2.n")
    closed = compile_model(_Bench(driver_cls=EPOS2)).report()
    assert "R2.n" not in closed


def test_a_generic_pwm_driver_is_lossless_and_the_epos2_has_the_papers_losses():
    generic = compile_model(_Bench()).simulate(0.3)
    assert np.max(np.abs(generic["driver.loss_power"])) == 0.0
    assert np.allclose(generic["driver.bus_power"], generic["driver.motor_power"], rtol=0, atol=1e-9)
    assert "driver." not in " ".join(compile_model(_Bench()).device_defaults())
    epos = compile_model(_Bench(driver_cls=EPOS2)).simulate(0.3)
    im, vb = epos["driver.i_m"], epos["driver.v_bus"]
    assert np.allclose(epos["driver.loss_power"], 12.5 + 0.05 * im**2 + 0.004 * np.abs(im) * vb)
    assert abs(epos.energy_balance().residual) < 1e-6


def test_a_parameter_set_by_a_rule_shows_the_rule_not_required():
    """PID.describe() marked k_aw and y_min "(required)" although the constructor sets them
    (ki/kp, -y_max) when they are not given; y_max, which has no rule, stays required."""
    from acausal.library.control import PID

    text = str(PID.describe())
    assert "(ki/kp)" in text and "(-y_max)" in text
    assert [ln.split()[0] for ln in text.splitlines() if "(required)" in ln] == ["y_max"]


def test_a_causal_port_reads_by_its_own_name_in_a_result():
    """Res["ref.y"] reads the output's value (it needed res["ref.y.value"])."""
    from acausal import Model, compile_model, connect
    from acausal.library.blocks import Gain, Step

    class Chain(Model):
        def build(self):
            self.s, self.g = Step(height=2.0, start_time=0.5), Gain(k=3.0)
            connect(self.s.y, self.g.u)

    res = compile_model(Chain()).simulate(1.0)
    assert res["g.y"][-1] == res["g.y.value"][-1] == 6.0
    with pytest.raises(KeyError, match="no variable 'g.zz'"):
        res["g.zz"]
