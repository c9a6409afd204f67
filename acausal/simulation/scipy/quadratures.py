"""Energy integrals carried as extra states of a scipy integration (quadratures under its error control).

On the scipy path :meth:`Result.energy <acausal.results.result.Result.energy>` integrates a power on the steps'
interpolants. A power that amplifies the states' error (a switch's current through a tiny on-resistance, ``(v_src - v_C)
/ R_on``) is then off by far more than the states are, and the energy balance fails although every account holds at
each instant. Carried as states, ``q' = P(t, x)``, the integrals are under the integrator's error control, as the
compiled path's CVODES quadratures are (on LSODA inside its error control, see
:data:`acausal.simulation.scipy.driver.CORRECTOR_ON_WEIGHTS`). The integrands are
:func:`acausal.compile.accounts.integrand_expr`.
"""
from __future__ import annotations


class Quadratures:
    """The model's energy-account integrands as a right-hand side ``P(t, x, p, d, u)``: ``names`` (those of
    :func:`~acausal.compile.accounts.account_integrals` with an integrand the model computes)."""

    def __init__(self, cm):
        from ...compile.accounts import account_integrals, integrand_expr

        self.cm = cm
        names = account_integrals(cm.accounts) if cm.accounts is not None else []
        exprs = {n: integrand_expr(cm, n) for n in names}
        self.names = [n for n, e in exprs.items() if e is not None]
        self.exprs = [exprs[n] for n in self.names]
        unknowns = set(cm.unknown_names)
        self.needed = sorted({str(s) for e in self.exprs for s in e.free_symbols if str(s) in unknowns})
        self._values = cm.generator.values_function(self.needed) if self.needed else None

    def rhs(self, t, x, p, d, u) -> list:
        """The integrands at time ``t`` and states ``x`` (floats)."""
        values = dict(zip(self.needed, self._values(t, x, p, d, u))) if self._values is not None else {}
        for name, v in zip(self.cm.state_names, x):
            values.setdefault(name, v)
        return [float(self.cm.eval_expr(e, values, p, d, t)) for e in self.exprs]
