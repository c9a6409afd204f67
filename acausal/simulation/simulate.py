"""Simulation: ``simulate()`` checks a run's settings, builds its :class:`~acausal.simulation.run.Run`, chooses the
backend, integrates and checks the result (:mod:`acausal.results.trust`); the pieces live in :mod:`acausal.simulation`.

Two paths give the same answers (to the tolerances):

* the **compiled path** (:mod:`acausal.simulation.compiled`, optional CasADi): the model's equations as CasADi
expressions,
  integrated by SUNDIALS CVODES (BDF, exact sparse Jacobian) with the step loop in compiled code, numeric inputs
  looked up inside it. It runs models without state events whose state derivatives need no Newton block.
* the **scipy path**: scipy's integrators (``BDF``, ``Radau``, ``LSODA``, ``RK45``...) driven step by step, so that a
  failure is reported with the time, the step size and the variable, and events stop the step exactly at the zero
  crossing (located by Brent's method on the dense output).

``method="auto"`` (the default) takes the compiled path when the model and the run allow it and scipy's ``LSODA``
otherwise (it switches between Adams and BDF by itself and was the fastest of scipy's integrators at the same
accuracy: 5x BDF on the reference drive), ``BDF`` for a model with state events (LSODA's switching stumbles at an
ideal diode's switch: convergence failures and events found twice);
:attr:`Result.solver <acausal.results.result.Result.solver>` says which ran and why. A model with no states
after index reduction is evaluated algebraically at the output times.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import SimulationError
from . import COMPILED, ROBUST, check_tolerances, choose_path, initialize, prepare  # noqa: F401
from .choose import fallback
from .run import Budget
from . import algebraic
from .compiled import driver as compiled_driver
from .scipy import driver as scipy_driver
from .scipy.driver import MAX_STEPS, MAX_STEPS_EXPLICIT, METHODS  # noqa: F401
from ..results.trust import balance_limit, balance_scale, check, check_mode, integration_fault

#: what the trust check's own runs (:func:`acausal.results.trust.energy_balance`'s tighter ones) may spend together at
#: most: integrator steps (a legitimate run 10^4 times tighter takes a few times the steps of the run checked; a
#: chattering switch, 75 times more already at 100 times tighter) and seconds of wall time. Spent, the check says
#: it could not conclude (a warning) instead of running on. The steps decide (the same on every machine: a
#: chattering thermostat spends them in 3 s); the seconds are a safety net for a run whose steps are slow, set far
#: above what the steps take, so that a slower machine does not turn a verdict into a warning
RETRY_STEPS = 1_000_000
RETRY_SECONDS = 60.0

__all__ = ["simulate", "check_tolerances", "initialize", "MAX_STEPS", "MAX_STEPS_EXPLICIT", "METHODS"]


def simulate(cm, t_end: float, *, t_start: float = 0.0, params: dict | None = None, inputs: dict | None = None,
             starts: dict | None = None, method: str = "auto", rtol: float = 1e-6, atol: float = 1e-9,
             t_eval=None, n_points: int = 501, max_step: float = np.inf, first_step: float | None = None,
             max_events: int = 10_000, dense_output: bool = True, trust: str = "raise", max_steps: int | None = None):
    """Simulate a :class:`~acausal.compiled_model.CompiledModel` and return a :class:`~acausal.results.result.Result`.

    ``params``: parameter overrides by name (no recompilation). ``inputs``: replacement :class:`Signal` s for
    numeric inputs by name. ``starts``: start values by variable name (fixed initial conditions).
    ``t_eval``: output times (default ``n_points`` evenly spaced). ``method``: ``"auto"`` (the compiled path when
    the model allows it, else scipy's LSODA), ``"CVODES"`` (the compiled path or a ModelError saying why not) or a
    scipy integrator name. ``dense_output``: keep what :meth:`Result.energy` needs to integrate to solver
    accuracy (every step's interpolant; on the compiled path the states at Gauss nodes); set False for the
    fastest runs (energies then use Simpson's rule on the output grid, and the energy balance is not checked).
    ``trust``: what the trust checks (:mod:`acausal.results.trust`: conditioning of every variable on the states'
    tolerances, the energy balance) do with a result they reject: ``"raise"`` an
    :class:`~acausal.results.trust.UntrustedResult`, ``"warn"``, or ``"off"``; their findings are ``res.trust``.
    ``max_steps``: steps of a scipy integrator at most (default :data:`MAX_STEPS` for an implicit method,
    :data:`MAX_STEPS_EXPLICIT` for an explicit one: a stiff model on RK45 stops with an error saying so instead of
    running for hours); given, ``method="auto"`` takes the scipy path.
    """
    check_mode(trust)
    run = prepare(cm, t_end, t_start=t_start, params=params, inputs=inputs, starts=starts, method=method, rtol=rtol,
                  atol=atol, t_eval=t_eval, n_points=n_points, max_step=max_step, first_step=first_step,
                  max_events=max_events, dense_output=dense_output, max_steps=max_steps)
    return simulate_run(run, trust)


def simulate_run(run, trust: str = "raise"):
    """The Result of the prepared ``run`` (:class:`~.run.Run` of :func:`prepare`): integrated (:func:`integrate`)
    and checked as ``trust`` says (:mod:`acausal.results.trust`, see :func:`simulate`); what :func:`simulate` and
    :func:`acausal.simulation.batch.simulate_many` do with each of their runs."""
    rtol, atol, dense_output = run.rtol, run.atol, run.dense_output
    res, on_scipy = integrate(run)
    scale = None  # the energy the run moves [J], where its energies are integrated again as states
    if trust != "off" and dense_output and integration_fault(res, rtol):
        # the scipy path's energies, integrated on the steps' interpolants, miss what every account holds: the
        # run again with them as states, under the integrator's error control (acausal.simulation.scipy.quadratures)
        scale = balance_scale(res)
        res = scipy_driver.integrate(run, *on_scipy, quadratures=True, energy_atol=_energy_atol(scale, rtol))
    with_quadratures = on_scipy is not None and bool(res.dense.integrals)
    spent = []  # the budget all the check's own runs share, from the first on

    def retry(k):  # the same run, both tolerances divided by k, unchecked (the balance's cause, acausal.results.trust)
        if not spent:
            spent.append(Budget(RETRY_STEPS, RETRY_SECONDS))
        tight = dataclasses.replace(run.tighter(k), budget=spent[0])
        return scipy_driver.integrate(tight, *on_scipy, quadratures=with_quadratures,
                                      energy_atol=_energy_atol(scale, tight.rtol)) if on_scipy else \
            integrate(tight)[0]

    check(res, rtol, atol, trust, dense_output, retry)
    return res


#: the share of the balance's limit (:func:`acausal.results.trust.balance_limit`) the energy integrals carried as
#: states may be off by where they take part in the error control (:data:`.scipy.driver.CORRECTOR_ON_WEIGHTS`):
#: their absolute tolerance is this times the limit times the energy the run moves
ENERGY_ATOL_SHARE = 1e-3


def _energy_atol(scale, rtol) -> float | None:
    """The absolute tolerance [J] of the energy integrals of a run at ``rtol`` that moves ``scale`` joules."""
    return None if scale is None else ENERGY_ATOL_SHARE * balance_limit(rtol) * scale


def integrate(run) -> tuple:
    """``(result, (method, why) or None)``: ``run`` integrated by the backend :func:`choose_path` picks (a model
    without states evaluated algebraically); a failed compiled run is run again on the scipy path, which names
    where it fails. The second item is the scipy integrator that ran and why (None: it was not the scipy path)."""
    if not run.cm.state_names:
        return algebraic.integrate(run), None
    method, why = choose_path(run.cm, run.method, run.u, run.rtol, run.atol)
    if method == COMPILED and run.max_steps is not None:  # method="auto" (check_run refuses it with "CVODES")
        method, why = fallback(run.cm), "max_steps limits a scipy integrator's steps"
    if method == COMPILED:
        try:
            return compiled_driver.integrate(run), None
        except SimulationError as exc:  # the scipy path names the time, the step and the variable
            if run.budget is not None:  # a run under a budget ends here: the scipy path would crawl on
                raise
            method, why = ROBUST, str(exc)
    return scipy_driver.integrate(run, method, why), (method, why)
