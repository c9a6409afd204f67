"""Error control for the fixed step (:mod:`~acausal.simulation.compiled.fixed_step`) over several grids.

RK4 has no error estimate of its own. A run that replays many recordings of one model, at one parameter set after
another (a calibration), needs one: :class:`SubstepControl` chooses the substeps per output interval for each grid
and checks them by the largest difference between a run and one at twice the substeps (the coarser run's error, to
within 16/15 where the solution is smooth). The comparison is the caller's output of interest (a sensor's reading,
say), so the tolerance is in its units. Importable without CasADi: there, every grid goes to the error-controlled
integrator.
"""
from __future__ import annotations

import numpy as np

#: the most substeps per output interval before a grid goes to an error-controlled integrator (CVODES), by where the
#: fixed step's loop runs (:attr:`FixedStep.backend <acausal.simulation.compiled.fixed_step.FixedStep.backend>`).
#: Measured on 6-s servo replays (XL330, 1 kHz): with the steps in C RK4 with seven sensitivities at 128 substeps
#: costs less than half of CVODES at rtol 1e-5 with load friction and play (230 ms against 525 ms, and nearer the
#: tight solution: the play's replay at 16 substeps is within 2e-8 rad of one at 256, CVODES within 1.5e-4); on
#: CasADi's virtual machine RK4 at 16 substeps costs about a third of CVODES, at 32 as much
MAX_SUBSTEPS = {"C": 128, "CasADi": 32}


def fixed_step_runs(cm) -> bool:
    """Whether ``cm`` can take the fixed step: CasADi is installed and the model has neither event zero functions
    nor a Newton block (:func:`~acausal.simulation.compiled.fixed_step.unsupported` says why not)."""
    try:
        from .fixed_step import unsupported
    except ImportError:
        return False
    return unsupported(cm) is None


class SubstepControl:
    """The substeps of ``cm``'s fixed-step runs on grids ``0..G-1`` (the keys of ``start``, each grid's first
    substep count; None: the error-controlled integrator), held within ``tol`` of a run at twice the substeps.

    * :meth:`refine` doubles each grid's substeps until its run differs from one at twice as many by ``tol`` at most;
      beyond :attr:`most` (:data:`MAX_SUBSTEPS` of the backend) that grid goes to the error-controlled integrator.
      The first call at a parameter set is :meth:`choose`.
    * As the parameters move (a fit's accepted iterates), one grid is checked per new set, the one nearest its limit
      (:meth:`nearest_limit`; its run at twice the substeps is run with the others), and :meth:`accepts` says
      whether it is still within ``tol``; where it is not, :meth:`refine` checks them all again: a model that stiffens
      as a parameter grows gets more substeps where and when it needs them.
    * :meth:`adopt` takes the substeps of another control of a model this one extends (an extension at its zero is
      that model), to be checked on the grid nearest its limit at the next set (:attr:`probe_next`).

    ``run(pairs)`` is the caller's: the compared output (an array) of grid ``j`` at ``k`` substeps for every
    ``(j, k)`` of ``pairs``, run together (through a process pool, say)."""

    def __init__(self, cm, tol: float, start: dict):
        self.tol = tol
        self.start = dict(start)
        self.cm = cm
        self.possible = fixed_step_runs(cm)
        self.chosen: dict | None = None  # grid -> substeps (None: the error-controlled integrator), once checked
        self.errors: dict = {}  # grid -> the last check's difference, in the output's units
        self.probe_next = False  # check the grid nearest its limit at the next set, whatever the call

    @property
    def most(self) -> int:
        """The most substeps a grid takes on the fixed step: :data:`MAX_SUBSTEPS` of the backend its steps run on
        (C where the machine's compiler built the loop, else CasADi's virtual machine)."""
        from .fixed_step import fixed_step
        first = next((k for k in self.start.values() if k is not None), 1)
        return MAX_SUBSTEPS[fixed_step(self.cm, first).backend]

    def adopt(self, other: "SubstepControl") -> None:
        """The substeps and errors of ``other`` (a control of the model this one extends), checked at the next set;
        every grid on the error-controlled integrator where this model cannot take the fixed step."""
        self.chosen, self.errors, self.probe_next = dict(other.chosen), dict(other.errors), True
        if not self.possible:
            self.chosen = {j: None for j in self.chosen}

    def choose(self, run) -> dict:
        """The substeps at the first parameter set: every grid refined from ``start``."""
        if self.chosen is None:
            self.chosen = self.refine(run, self.start)
        return self.chosen

    def refine(self, run, ks: dict) -> dict:
        """Substeps from ``ks`` (grid -> substeps) on, doubled per grid until its run differs from one at twice as
        many by ``tol`` at most (None beyond :attr:`most`)."""
        if not self.possible:
            return {j: None for j in ks}
        out, most = dict(ks), self.most
        todo = [j for j, k in ks.items() if k is not None]
        coarse = dict(zip(todo, run([(j, ks[j]) for j in todo])))
        while todo:
            fine = dict(zip(todo, run([(j, 2 * out[j]) for j in todo])))
            failed = []
            for j in todo:
                self.errors[j] = float(np.max(np.abs(coarse[j] - fine[j])))
                if self.errors[j] > self.tol:
                    out[j] = 2 * out[j] if 2 * out[j] <= most else None
                    if out[j] is not None:
                        failed.append(j)
            todo, coarse = failed, fine
        return out

    def nearest_limit(self, group) -> int | None:
        """The grid of ``group`` on the fixed step whose last check came nearest ``tol`` (unchecked first); None
        when none of them takes the fixed step."""
        rk4 = [j for j in group if self.chosen[j] is not None]
        return max(rk4, key=lambda j: self.errors.get(j, np.inf)) if rk4 else None

    def accepts(self, j: int, coarse, fine) -> bool:
        """Whether grid ``j``'s run at its substeps (``coarse``) is within ``tol`` of the one at twice as many
        (``fine``); the difference is kept as its error."""
        self.probe_next = False
        self.errors[j] = float(np.max(np.abs(np.asarray(coarse) - np.asarray(fine))))
        return self.errors[j] <= self.tol
