"""Optional support flanges (MSL ``useSupport``): the partials own the support and its reaction, so the torques
on a massless component's flanges and support sum to zero, for the library's components and for a component
written on the partials with nothing but its torque law."""
import numpy as np
import pytest
import sympy as sp
from sympy import Eq

from acausal import Model, ModelError, Parameter, compile_model, connect, time
from acausal.library.blocks import SignalSource
from acausal.library.control import CascadeServo
from acausal.library.drives import DCMotor, PWMDriver
from acausal.library.electrical import EMF, ConstantVoltage, Ground, Resistor
from acausal.library.rotational import (BearingFriction, Damper, Fixed, Gearbox, IdealGear, Inertia, LossyGear,
                                        Position, SelfLockingGear, Spring, TorqueSource)
from acausal.model.partials import PartialElementaryOneFlangeAndSupport2, PartialGear


class BeltDrive(PartialGear):
    """A user's component: a lossless belt stage, only its torque law."""

    def equations(self):
        return [*super().equations(), Eq(self.flange_b.tau, -self.ratio * self.flange_a.tau)]


class RampTorque(PartialElementaryOneFlangeAndSupport2):
    """A user's source: a torque growing linearly in time, only its law."""

    slope = Parameter(1.0, unit="N.m/s", doc="torque rate")

    def equations(self):
        return [*super().equations(), Eq(self.flange.tau, -self.slope * time)]


def _series(*elements):
    """Connect two-flange elements in a row, each one's flange_b to the next one's flange_a."""
    for left, right in zip(elements, elements[1:]):
        connect(left.flange_b, right.flange_a)


class _Housed(Model):
    """``source -> [J_a] -> stage -> [J_b] -- damper`` with every support on a spring-mounted housing inertia, so
    the reactions move the housing and a wrong one would show in its angle."""

    def __init__(self, source, stage, **kw):
        super().__init__(**kw)
        self._source, self._stage = source, stage

    def build(self):
        self.source, self.stage = self._source(), self._stage()
        self.j_a, self.j_b, self.damper = Inertia(J=1e-3), Inertia(J=1e-2), Damper(d=0.05)
        self.housing, self.mount, self.fixed = Inertia(J=0.5), Spring(c=100.0), Fixed()
        connect(self.source.flange, self.j_a.flange_a)
        _series(self.j_a, self.stage, self.j_b, self.damper)
        _series(self.housing, self.mount)
        connect(self.source.support, self.stage.support, self.housing.flange_a)
        connect(self.mount.flange_b, self.fixed.flange, self.damper.flange_b)


SOURCES = {"TorqueSource": lambda: TorqueSource(tau=0.5 * sp.sin(3 * time), use_support=True),
           "RampTorque": lambda: RampTorque(slope=0.2, use_support=True)}
STAGES = {"IdealGear": lambda: IdealGear(ratio=5.0, use_support=True),
          "LossyGear": lambda: LossyGear(ratio=5.0, eta=0.8, law="smooth", use_support=True),
          "BearingFriction": lambda: BearingFriction(tau_c=0.01, d=0.002, use_support=True),
          "BeltDrive": lambda: BeltDrive(ratio=5.0, use_support=True)}


@pytest.mark.slow
@pytest.mark.parametrize("source", sorted(SOURCES))
@pytest.mark.parametrize("stage", sorted(STAGES))
def test_support_reactions_balance(source, stage):
    res = compile_model(_Housed(SOURCES[source], STAGES[stage])).simulate(2.0, n_points=41, rtol=1e-9, atol=1e-12)
    src = res["source.flange.tau"] + res["source.support.tau"]
    gear = res["stage.flange_a.tau"] + res["stage.flange_b.tau"] + res["stage.support.tau"]
    assert np.max(np.abs(res["source.support.tau"])) > 0.1      # the housing does take torque
    assert np.max(np.abs(res["housing.phi"])) > 1e-4            # and moves
    np.testing.assert_allclose(src, 0.0, atol=1e-12)
    np.testing.assert_allclose(gear, 0.0, atol=1e-12)
    if stage != "BearingFriction":  # gear kinematics relative to the moving housing
        phi_s = res["housing.phi"]
        np.testing.assert_allclose(res["stage.flange_a.phi"] - phi_s, 5.0 * (res["stage.flange_b.phi"] - phi_s),
                                   atol=1e-9)
        np.testing.assert_allclose(res["stage.phi_a"], res["stage.flange_a.phi"] - phi_s, atol=1e-12)


def test_gear_and_position_on_a_fixed_support_take_the_load_torque():
    """Position -> self-locking gear -> load: the housing takes what the gear and the source hand it."""

    class M(Model):
        def build(self):
            self.pos = Position(phi_ref=2 * sp.sin(3 * time), use_support=True)
            self.gear, self.hold = SelfLockingGear(ratio=3.0, use_support=True), SignalSource(signal=0.0)
            self.load, self.damper, self.fixed = Inertia(J=0.1), Damper(d=0.05), Fixed()
            connect(self.pos.flange, self.gear.flange_a)
            _series(self.gear, self.load, self.damper)
            connect(self.hold.y, self.gear.hold)
            connect(self.pos.support, self.gear.support, self.fixed.flange, self.damper.flange_b)

    res = compile_model(M()).simulate(2.0, n_points=41)
    np.testing.assert_allclose(res["pos.flange.tau"] + res["pos.support.tau"], 0.0, atol=1e-12)
    np.testing.assert_allclose(res["gear.flange_a.tau"] + res["gear.flange_b.tau"] + res["gear.support.tau"], 0.0,
                               atol=1e-12)
    # the fixed flange carries the load's damper torque and the reactions of gear and source
    np.testing.assert_allclose(res["fixed.flange.tau"],
                               -(res["pos.support.tau"] + res["gear.support.tau"] + res["damper.flange_b.tau"]),
                               atol=1e-9)


CONVERTERS = {"EMF": lambda: EMF(k=0.5, use_support=True),
              "DCMotor": lambda: DCMotor(use_support=True, tau_c=0.005)}


@pytest.mark.parametrize("converter", sorted(CONVERTERS))
def test_converter_housing_takes_the_reaction(converter):
    """A voltage source drives a converter's shaft into a damped inertia, its housing fixed. The massless EMF
    balances shaft and housing torques at every instant; the motor's rotor inertia takes ``J dw/dt``, nothing at
    constant speed, and its housing takes the air-gap and friction torques."""

    class M(Model):
        def build(self):
            self.src, self.R, self.gnd = ConstantVoltage(V=12.0), Resistor(R=1.0), Ground()
            self.conv = CONVERTERS[converter]()
            self.load, self.damper, self.fixed = Inertia(J=1e-4), Damper(d=1e-3), Fixed()
            connect(self.src.p, self.R.p)
            connect(self.R.n, self.conv.p)
            connect(self.src.n, self.conv.n, self.gnd.p)
            connect(self.conv.flange, self.load.flange_a)
            _series(self.load, self.damper)
            connect(self.conv.support, self.damper.flange_b, self.fixed.flange)

    res = compile_model(M()).simulate(5.0, n_points=51, rtol=1e-9, atol=1e-12)
    shaft, housing = res["conv.flange.tau"], res["conv.support.tau"]
    assert shaft[-1] < -0.01  # the load brakes the shaft
    if converter == "EMF":
        np.testing.assert_allclose(shaft + housing, 0.0, atol=1e-12)
        np.testing.assert_allclose(housing, 0.5 * res["conv.i"], rtol=1e-12)
    else:
        np.testing.assert_allclose(housing, res["conv.tau_e"] - res["conv.tau_f"], rtol=1e-12)
        assert shaft[-1] + housing[-1] == pytest.approx(0.0, abs=1e-9)


def test_without_support_the_housing_is_fixed():
    gear = BeltDrive(ratio=2.0)
    assert not gear.use_support and "support" not in gear.children and gear.phi_support == 0
    housed = BeltDrive(ratio=2.0, use_support=True)
    assert "support" in housed.children


@pytest.mark.parametrize("make", [lambda: IdealGear(use_support="yes"), lambda: BeltDrive(use_support=1.5),
                                  lambda: LossyGear(use_support=None), lambda: DCMotor(use_support="no"),
                                  lambda: EMF(use_support=2)],
                         ids=["IdealGear", "BeltDrive", "LossyGear", "DCMotor", "EMF"])
def test_bad_use_support_names_component_and_option(make, request):
    with pytest.raises(ModelError, match=rf"{request.node.callspec.id}: option use_support must be True or False"):
        make()


@pytest.mark.parametrize("make, component, option", [
    (lambda: LossyGear(law="fast"), "LossyGear", "law"),
    (lambda: Gearbox(law="exact"), "Gearbox", "law"),
    (lambda: PWMDriver(command="current"), "PWMDriver", "command"),
    (lambda: PWMDriver(saturate="no"), "PWMDriver", "saturate"),
    (lambda: DCMotor(use_heat_port="yes"), "DCMotor", "use_heat_port"),
    (lambda: CascadeServo(use_voltage_limit_input=None), "CascadeServo", "use_voltage_limit_input"),
], ids=lambda x: x if isinstance(x, str) else "")
def test_bad_option_names_component_and_option(make, component, option):
    with pytest.raises(ModelError, match=rf"^{component}: option {option} must be .*, got "):
        make()


def test_option_message_lists_the_choices():
    with pytest.raises(ModelError) as info:
        LossyGear(law="fast")
    assert str(info.value) == "LossyGear: option law must be 'events' or 'smooth', got 'fast'"
