"""Self-describing declarations (issue 22, item 1): help() and a notebook show a parameter's default, unit, bounds
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
