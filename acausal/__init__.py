"""acausal: Modelica-style acausal component modelling in Python.

Write components as classes with ports, parameters and sympy equations; connect them; ``compile_model`` once
(flatten, alias elimination, Pantelides index reduction with dummy derivatives, BLT, sympy solving, generated
numeric code); ``simulate`` many times with other parameters; read any variable by its hierarchical name.
"""

from . import _moved
from .compiled_model import CompiledModel, compile_model, compile_once
from .model.components import (Component, Connector, Discrete, Event, Flow, Indeterminate, Input, Model, Parameter,
                               Potential, Start, Variable, connect)
from .model.connectors import Flange, HeatPort, Pin, RealInput, RealOutput
from .export import export_fmu
from .errors import AcausalError, ConnectError, DataError, ModelError, SignalError, SimulationError, StructureError
from .results.result import Result
from .model.signals import (Constant, ExpressionSignal, FourierSeries, ParametricSignal, PeriodicSpline,
                            SampledSignal, Signal)
from .model.symbols import Eq, der, time  # equations are written as Eq(lhs, rhs)
from .results.trust import UncheckedResultWarning, UntrustedResult, UntrustedResultWarning

__version__ = "0.1.0"

_moved.install()  # the module paths of the release before the stage folders, for one more release

__all__ = [
    "Model", "Component", "Connector", "Parameter", "Variable", "Potential", "Flow", "Discrete", "Input", "Start",
    "Event", "Indeterminate", "connect", "der", "time", "Eq", "compile_model", "compile_once", "CompiledModel", "Result", "export_fmu",
    "Pin", "Flange", "HeatPort", "RealInput", "RealOutput",
    "Signal", "Constant", "ExpressionSignal", "ParametricSignal", "PeriodicSpline", "SampledSignal", "FourierSeries",
    "AcausalError", "ModelError", "ConnectError", "StructureError", "SignalError", "SimulationError", "DataError",
    "UntrustedResult", "UntrustedResultWarning", "UncheckedResultWarning",
]
