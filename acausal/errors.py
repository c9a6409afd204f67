"""One exception family for the whole tool.

Every message names what is at fault: the component, port, equation, variable, signal, file or column.
Catch :class:`AcausalError` to catch them all.
"""


class AcausalError(Exception):
    """Base class of every error raised by acausal."""


class ModelError(AcausalError):
    """The model as written, or a request to it, is wrong: bad connection, bad parameter, missing port, unknown
    name, an option or argument out of range."""


class UnknownNameError(ModelError, KeyError):
    """A name the model or a result does not have; the message suggests close ones. Also a ``KeyError``, so
    lookups by name behave like a mapping's (``name in result``)."""

    def __str__(self):
        return Exception.__str__(self)  # the message itself, not KeyError's quoted form


class ConnectError(ModelError):
    """Two ports that cannot be connected (different kinds), or a required port left unconnected."""


class StructureError(AcausalError):
    """The equations do not determine the unknowns (over/under-determined, structurally singular)."""


class SignalError(AcausalError):
    """A prescribed signal cannot provide what the model needs (e.g. a derivative order)."""


class SimulationError(AcausalError):
    """Integration or initialisation failed; the message says the time and, when found, the variable."""


class BudgetExceeded(SimulationError):
    """A run stopped because it spent its budget of steps or seconds (:class:`acausal.simulation.run.Budget`: the
    trust check's own tighter runs); the message says which and how much."""


class DataError(AcausalError):
    """Bad input data; the message names the file, row and column."""
