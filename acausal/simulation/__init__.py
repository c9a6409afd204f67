"""Stage 5, the simulation: one home for a run, a checked, frozen :class:`~.run.Run` (model, parameter vector,
inputs, modes, consistent start, tolerances, output grid), the choice of the backend that integrates it
(:func:`~.choose.choose_path`, shared by ``simulate``, ``simulate_many``, ``sensitivities`` and
``CompiledModel.simulation_path``), and one driver per backend: :mod:`.scipy` (scipy's integrators, stepped with
state events), :mod:`.compiled` (CasADi CVODES/IDAS, or SUNDIALS from C in the native loop) and :mod:`.algebraic`
(a model without states). :func:`acausal.simulation.simulate.simulate` reads: validate -> Run -> choose ->
integrate -> trust check."""
from .choose import COMPILED, FALLBACK, ROBUST, choose_path
from .initial import initialize
from .run import Run, Segment, check_finite_times, check_run, check_tolerances, prepare

__all__ = ["COMPILED", "FALLBACK", "ROBUST", "Run", "Segment", "check_finite_times", "check_run", "check_tolerances",
           "choose_path", "initialize", "prepare"]
