"""Fixed-step integration on the compiled path: the classical fourth-order Runge-Kutta method (RK4) on the output
grid, with its exact parameter sensitivities.

What Modelica tools offer as a fixed-step solver (Dymola's ``Rkfix4``, OpenModelica's ``rungekutta``), for runs
whose grid is given by the data: a replay of a recording whose inputs are sampled at the output times. Each output
interval ``[t_i, t_i+1]`` is crossed in ``substeps`` equal RK4 steps; a sampled (piecewise-linear) input is then
smooth inside every step, so its kinks cost nothing, where an error-controlled integrator must find each of them
by failed steps. Where the machine has a C compiler the steps run in a compiled loop around CasADi's C code of
the rate function (:mod:`acausal.simulation.compiled.native`: one library per model and set of sensitivity parameters,
for every substep count and recording; the same numbers, five to ten times faster: a 6-s servo replay with seven
sensitivities at 16 substeps 14 ms against 71 ms). Without one, CasADi's virtual machine rolls the unrolled
interval over the grid (``mapaccum``) in pieces of at most :data:`CHUNK` intervals: a few functions per model,
step count and set of sensitivity parameters serve every recording, whatever its length.

**Inputs** enter as data, not as tables inside the function: every numeric input that the right-hand side reads
at the current time is a symbol whose values at the RK4 stage times are computed in numpy before the call (the
stage at a step's end is evaluated at the float just before it, so a sampled input's slope at an output time
belongs to the step that ends there). So one compiled function serves every recording of a model, and inputs
without a CasADi form (any :class:`~acausal.model.signals.Signal`) are supported.

**Sensitivities**: the variational equations ``dS/dt = f_x S + f_p B`` are integrated by the same RK4 stages as
the states, which for an explicit Runge-Kutta method gives the exact derivatives of the discrete solution (what a
least-squares fit of the discrete replay needs), not an approximation of the continuous ones.

**Accuracy** is the caller's to check: a fixed step has no error control. Comparing a run with one of twice the
substeps estimates the coarser run's error (to within 16/15 where the solution is smooth); callers choose
``substeps`` by that or against a tight CVODES run.

Unsupported here (:func:`unsupported` says why): event zero functions, Newton blocks, and an input read at another
time than the current one.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ...backends.casadi import Unsupported, state_derivatives, translate, variational

#: the longest roll built (output intervals per CasADi call): building a roll of 1100 steps took 46 ms against
#: 3 ms for 128, whose calls cost the same per step
CHUNK = 128
#: input stage values kept per roll-out (grids with their input objects; :meth:`FixedStep._stages`)
STAGE_CACHE = 32


class StageInputs:
    """Stands in for :class:`~acausal.backends.casadi.Signals` while translating: each input read at the current
    time (``token``, derivative ``order``) becomes a symbol; ``used`` lists them in symbol order."""

    def __init__(self, t):
        self.t = t
        self.used: list = []
        self.symbols: list = []

    def __call__(self, token, order, arg):
        if not (isinstance(arg, ca.SX) and arg.is_symbolic() and ca.is_equal(arg, self.t)):
            raise Unsupported(f"input {token!r} is read at {arg}, not at the current time (fixed-step stages "
                              "evaluate inputs at the time only)")
        key = (token, int(order))
        if key not in self.used:
            self.used.append(key)
            self.symbols.append(ca.SX.sym(f"u{len(self.used) - 1}"))
        return self.symbols[self.used.index(key)]


def _rates(cm):
    """The state rates of ``cm`` with the inputs as symbols, translated once per model (cached on its compiled
    path): ``dict(t, x, p, d, f, u, inputs)``, or the reason there is none."""
    cache = cm.compiled_path.__dict__
    if "_fixed_step_rates" not in cache:
        if cm.event_zeros:
            cache["_fixed_step_rates"] = "the model has event zero functions (a fixed step cannot locate them)"
        elif not cm.state_names:
            cache["_fixed_step_rates"] = "the model has no states"
        else:
            t, x = ca.SX.sym("t"), ca.SX.sym("x", len(cm.state_names))
            p, d = ca.SX.sym("p", len(cm.param_names)), ca.SX.sym("d", len(cm.discrete_names))
            stage = StageInputs(t)
            try:
                f = ca.vertcat(*translate(cm, state_derivatives(cm), stage, t, x, p, d))  # a Newton block raises
            except Unsupported as exc:
                cache["_fixed_step_rates"] = str(exc)
            else:
                cache["_fixed_step_rates"] = dict(t=t, x=x, p=p, d=d, f=f, inputs=tuple(stage.used),
                                                  u=ca.vertcat(*stage.symbols) if stage.symbols else ca.SX(0, 1))
    return cache["_fixed_step_rates"]


def _rate(cm, rates, wrt, bindings, native: bool) -> tuple:
    """``(rate, native loop or None)``: the CasADi function ``(t, y, pd, u) -> dy/dt`` of the states and their
    sensitivities to ``wrt``, and its compiled RK4 loop (:mod:`acausal.simulation.compiled.native`; looked for only when
    ``native``); cached on the compiled path, shared by every substep count."""
    cache = cm.compiled_path.__dict__.setdefault("_fixed_step_rate", {})
    key = (tuple(wrt), frozenset((bindings or {}).items()))
    if key not in cache:
        t, x, f = rates["t"], rates["x"], rates["f"]
        y, rhs = x, f
        if wrt:
            S, dS = variational(cm, f, x, rates["p"], wrt, bindings)
            y, rhs = ca.vertcat(x, S), ca.vertcat(f, dS)
        pd = ca.vertcat(rates["p"], rates["d"])
        if len(cache) > 64:
            cache.clear()
        cache[key] = [ca.Function("rate", [t, y, pd, rates["u"]], [ca.cse(rhs)]), None, False]
    entry = cache[key]
    if native and not entry[2]:
        from .native import rk4_driver
        entry[1], entry[2] = rk4_driver(entry[0]), True
    return entry[0], entry[1]


def unsupported(cm) -> str | None:
    """Why ``cm`` cannot take the fixed step (None: it can)."""
    rates = _rates(cm)
    return rates if isinstance(rates, str) else None


class FixedStep:
    """The RK4 roll-out of one compiled model, ``substeps`` steps per output interval, with the sensitivities to
    the parameters ``wrt`` (through their ``bindings``; none: the states alone). ``native``: take the steps in
    compiled C (:mod:`acausal.simulation.compiled.native`, the same numbers five to ten times faster) where a C compiler
    is found; ``backend`` says which runs (``"C"`` or ``"CasADi"``)."""

    def __init__(self, cm, substeps: int, wrt=(), bindings=None, native: bool = True):
        rates = _rates(cm)
        if isinstance(rates, str):
            raise Unsupported(rates)
        self.cm, self.substeps, self.wrt = cm, int(substeps), tuple(wrt)
        self.inputs = rates["inputs"]
        self.rate, native_loop = _rate(cm, rates, self.wrt, bindings, native)
        self.n, self.q = len(cm.state_names), len(self.wrt)
        self.native = native_loop if native else None
        self.backend = "C" if self.native is not None else "CasADi"
        self._step = None
        self._rolls: dict = {}
        self._stage_cache: dict = {}

    @property
    def step(self) -> ca.Function:
        """One output interval in CasADi: ``substeps`` RK4 steps unrolled (built on first use; the native loop
        takes the same steps)."""
        if self._step is None:
            F, m, k = self.rate, len(self.inputs), self.substeps
            # one output interval: y at its start, (t_i, h_i), the inputs at its 2k+1 stage times (column j at
            # t_i + j h_i / 2k), the parameters and modes
            ys, th, us = ca.SX.sym("y", F.size1_in(1)), ca.SX.sym("th", 2), ca.SX.sym("us", m, 2 * k + 1)
            ps = ca.SX.sym("pd", F.size1_in(2))
            h = th[1] / k
            yj = ys
            for j in range(k):
                t0 = th[0] + j * h
                a, mid, b = us[:, 2 * j], us[:, 2 * j + 1], us[:, 2 * j + 2]
                k1 = F(t0, yj, ps, a)
                k2 = F(t0 + h / 2, yj + h / 2 * k1, ps, mid)
                k3 = F(t0 + h / 2, yj + h / 2 * k2, ps, mid)
                k4 = F(t0 + h, yj + h * k3, ps, b)
                yj = yj + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            self._step = ca.Function("rk4_step", [ys, ca.vertcat(th, ca.vec(us)), ps], [yj])
        return self._step

    def _roll(self, steps: int):
        """The step rolled ``steps`` times (a power of two up to :data:`CHUNK`; CasADi builds a roll in time that
        grows faster than its length, so a recording is crossed in pieces: a few cached rolls serve every
        length)."""
        if steps not in self._rolls:
            self._rolls[steps] = self.step.mapaccum("rk4_roll", steps)
        return self._rolls[steps]

    @staticmethod
    def pieces(steps: int) -> list:
        """The roll lengths that cross ``steps`` intervals: whole :data:`CHUNK` s, then the rest's binary digits."""
        whole, rest = divmod(int(steps), CHUNK)
        return [CHUNK] * whole + [1 << b for b in range(CHUNK.bit_length() - 1, -1, -1) if rest >> b & 1]

    def stage_values(self, grid, u) -> np.ndarray:
        """The inputs at every stage time of every interval of ``grid``: shape ``(2 + m (2k+1), intervals)``
        (the interval's start and length first, then the inputs stage by stage, CasADi's column order)."""
        cm, k = self.cm, self.substeps
        t0, h = grid[:-1], np.diff(grid)
        frac = np.arange(2 * k + 1) / (2 * k)
        T = t0[:, None] + h[:, None] * frac[None, :]
        T[:, -1] = np.nextafter(grid[1:], grid[:-1])  # the end stage inside its own interval
        cols = [t0[None, :], h[None, :]]
        if self.inputs:
            vals = np.empty((len(t0), 2 * k + 1, len(self.inputs)))
            for i, (token, order) in enumerate(self.inputs):
                sig = u[cm.input_names.index(token)]
                vals[:, :, i] = np.asarray(sig.evaluate(T.ravel(), order), dtype=float).reshape(T.shape)
            cols.append(vals.reshape(len(t0), -1).T)
        return np.vstack(cols)

    def _stages(self, grid, u) -> np.ndarray:
        """:meth:`stage_values`, kept for the last few grids and input objects (a fit replays each recording
        with the same input objects many times; a new object is a new input, whatever it holds)."""
        key = grid.tobytes()
        hit = self._stage_cache.get(key)
        if hit is not None and len(hit[0]) == len(u) and all(a is b for a, b in zip(hit[0], u)):
            return hit[1]
        if len(self._stage_cache) >= STAGE_CACHE:
            self._stage_cache.pop(next(iter(self._stage_cache)))
        self._stage_cache[key] = (tuple(u), self.stage_values(grid, u))
        return self._stage_cache[key][1]

    def run(self, t_start: float, x0, t_out, p, d, u) -> tuple:
        """``(X, S)``: states ``(n, N)`` and sensitivities ``(n, q, N)`` at the output times ``t_out``
        (non-decreasing, not before ``t_start``; the steps run between the distinct ones), from states ``x0`` at
        ``t_start`` (sensitivities zero there)."""
        t_out = np.asarray(t_out, dtype=float)
        n, q, N = self.n, self.q, t_out.size
        if N and (t_out[0] < t_start or np.any(np.diff(t_out) < 0)):
            raise ValueError("fixed step: output times must not decrease nor start before t_start")
        X = np.repeat(np.asarray(x0, dtype=float)[:, None], N, axis=1)
        S = np.zeros((n, q, N))
        later = t_out > t_start
        if later.any():
            times, back = np.unique(t_out[later], return_inverse=True)
            grid = np.concatenate(([t_start], times))
            y0 = np.concatenate([np.asarray(x0, dtype=float), np.zeros(n * q)])
            stages, pd = self._stages(grid, u), np.concatenate([p, d])
            if self.native is not None:
                Y = self.native(y0, stages, pd, self.substeps)
            else:
                parts, at = [], 0
                for size in self.pieces(grid.size - 1):
                    parts.append(np.asarray(self._roll(size)(y0, stages[:, at:at + size], pd), dtype=float))
                    y0, at = parts[-1][:, -1], at + size
                Y = np.hstack(parts)
            Y = Y[:, back]
            X[:, later] = Y[:n]
            if q:
                S[:, :, later] = Y[n:].reshape(q, n, -1).transpose(1, 0, 2)  # CasADi stacks S by columns
        return X, S


def fixed_step(cm, substeps: int, wrt=(), bindings=None) -> FixedStep:
    """The :class:`FixedStep` of ``cm`` (cached on its compiled path by substeps, ``wrt`` and bindings); raises
    :class:`~acausal.backends.casadi.Unsupported` with the reason where the model has none."""
    cache = cm.compiled_path.__dict__.setdefault("_fixed_step", {})
    key = (int(substeps), tuple(wrt), frozenset((bindings or {}).items()))
    if key not in cache:
        if len(cache) > 64:
            cache.clear()
        cache[key] = FixedStep(cm, substeps, wrt, bindings)
    return cache[key]
