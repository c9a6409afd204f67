"""Which backend integrates a run: the compiled path (CasADi) when it is installed and supports the model and the
run, else a scipy integrator, with the reason (:attr:`Result.solver <acausal.results.result.Result.solver>` says it)."""
from __future__ import annotations

from ..errors import ModelError

COMPILED = "CVODES"  # the compiled path's integrator (method="CVODES" asks for it explicitly)
FALLBACK = "LSODA"  # what method="auto" uses on the scipy path (ROBUST for a model with state events)
ROBUST = "BDF"  # models with events, and a failed compiled run run again (its failure report names the step)


def choose_path(cm, method: str, u, rtol, atol) -> tuple[str, str]:
    """``(method, reason)`` for a run of ``cm`` with inputs ``u`` (:meth:`CompiledModel.input_tuple`) at these
    tolerances. ``method``: ``"auto"`` gives :data:`COMPILED` (reason ``""``) when the compiled path is available
    and supports the run, else the scipy fallback with the reason; ``"CVODES"`` gives :data:`COMPILED` or raises a
    ModelError saying why not; a scipy integrator's name is taken as asked for."""
    if method not in ("auto", COMPILED):
        return method, "asked for"
    from .compiled import available
    if not available():
        why = 'the compiled path needs CasADi (pip install "acausal[fast]")'
    else:
        why = cm.compiled_path.unsupported(u, rtol, atol)
        if why is None:
            return COMPILED, ""
    if method == COMPILED:
        raise ModelError(f"simulate(method={COMPILED!r}): model {cm.flat.name} cannot take the compiled path: {why}")
    return fallback(cm), why


def fallback(cm) -> str:
    """The scipy integrator ``method="auto"`` uses when the compiled path is not taken."""
    return ROBUST if cm.event_zeros else FALLBACK
