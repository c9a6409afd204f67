"""Simulation results: every variable and alias by hierarchical name, powers, energies, CSV, plots."""
from __future__ import annotations

import csv
import dataclasses

import numpy as np
import sympy as sp

from ..errors import ModelError, UnknownNameError
from .gauss import gauss_cumulative, integrate_cumulative, node_samples, nodes_at
from ..backends.numpy.runtime import as_rows
from ..model.signals import SignalCall
from ..model.symbols import der_name, split_der


@dataclasses.dataclass
class DenseOutput:
    """What a run hands its :class:`Result` beyond the states at the output times, for integrals to the
    integrator's accuracy (:meth:`Result.energy`): one backend fills what it has.

    ``steps``: the scipy path's accepted steps, ``(t0, t1, interpolant, modes)`` each (energies on their Gauss
    nodes); ``nodes``: the compiled path's ``() -> (output times, states at the Gauss nodes of every output
    interval)``, integrated when called; ``integrals``: ``name -> integral from the start at the output times``,
    integrated with the states; ``more``: ``names -> such integrals`` by running the same integration again (the
    compiled path); ``exact_time``: no states, every variable an explicit function of time (evaluated, not
    integrated)."""

    steps: list = dataclasses.field(default_factory=list)
    nodes: object = None
    integrals: dict = dataclasses.field(default_factory=dict)
    more: object = None
    exact_time: bool = False


class Result:
    """Output of a simulation.

    ``res["motor.i"]`` gives any state, algebraic variable or eliminated alias (an array over :attr:`t`);
    ``res["R.R"]`` a parameter value; ``res["pos.phi_ref"]`` a numeric input signal and ``res.der(name, k)`` its
    k-th derivative (or a variable's derivative when the model has it). Derived quantities: :meth:`power`,
    :meth:`energy`; export: :meth:`to_csv`, :meth:`plot`.
    """

    def __init__(self, cm, t, X, p, u, D, events, dense: "DenseOutput | None" = None, *, solver: str = "",
                 newton_starts=None):
        self.model = cm
        self.solver = solver  # which integrator ran, and on which path (see CompiledModel.simulate)
        self.trust: list = []  # what the trust checks found (acausal.results.trust): empty when the result passed
        self.dense = DenseOutput() if dense is None else dense  # what the energies integrate on besides the outputs
        self._asked: set = set()  # names already run again for
        self.t = np.asarray(t)
        self.states = X
        self.params = p
        self.inputs = u
        self.modes = D
        self.events = events
        self._states_by_name = dict(zip(cm.state_names, X))
        self._values = None  # every unknown by name, evaluated at the outputs when first asked for (_unknowns)
        if not cm.program.plain:  # a numeric block or an input signal can fail: evaluated now, its error from simulate
            self._evaluate(newton_starts)  # (the Newton blocks from the integrator's algebraic variables, if given)
        self._cache: dict = {}

    @property
    def _unknowns(self) -> dict:
        """Every state and unknown by name (arrays over :attr:`t`), evaluated when first asked for."""
        if self._values is None:
            self._evaluate(None)
        return self._values

    def _evaluate(self, newton_starts) -> None:
        """Every unknown at the outputs, the Newton blocks starting from ``newton_starts`` (values at the outputs
        by variable) where given."""
        cm = self.model
        values = dict(zip(cm.unknown_names, as_rows(cm.funcs["all_values"](self.t, self.states, self.params,
                                                                            self.modes, self.inputs, newton_starts),
                                                     self.t.shape)))
        values.update(self._states_by_name)
        self._values = values

    def evaluated(self) -> bool:
        """Whether every unknown has been evaluated at the outputs (a model of plain assignments waits until one is
        asked for)."""
        return self._values is not None

    def unknowns_at(self, t, X, D, near=None) -> list:
        """Every unknown (in ``unknown_names`` order) at other points of this run's parameters and inputs: times
        ``t``, states ``X`` and modes ``D`` (one column per time, or a constant vector); rows over ``t``.
        ``near``: the indices of outputs the points lie near, one per point; their Newton blocks then start from
        their values there."""
        starts = None if near is None else {name: self._unknowns[name][near]
                                            for name in self.model.program.newton_variables}
        return as_rows(self.model.funcs["all_values"](t, X, self.params, D, self.inputs, starts), np.shape(t))

    # ------------------------------------------------------------------ access
    def names(self, pattern: str | None = None, parameters: bool = False) -> list:
        """The names this result answers (states, unknowns, aliases; parameters too with ``parameters=True``),
        filtered by ``pattern`` (shell-style wildcard or substring); see :meth:`CompiledModel.names
        <acausal.compiled_model.CompiledModel.names>`."""
        return self.model.names(pattern, parameters)

    def __contains__(self, name):
        if not isinstance(name, str):
            return False
        try:
            self[name]
            return True
        except KeyError:
            return False

    def __getitem__(self, name: str) -> np.ndarray:
        if not isinstance(name, str):
            raise ModelError(f"result of {self.model.flat.name}: index it by a variable's name (a str, e.g. "
                             f"res['C.v']), got the {type(name).__name__} {name!r}; res.names() lists them")
        if name in self._states_by_name:
            return self._states_by_name[name]
        if name in self._unknowns:
            return self._unknowns[name]
        if name in self._cache:
            return self._cache[name]
        cm = self.model
        if name in cm.flat.aliases:
            v = cm.eval_expr(cm.flat.aliases[name], self._unknowns, self.params, self._mode_rows(), self.t)
            v = np.broadcast_to(np.asarray(v, dtype=float), self.t.shape)
        elif cm.has_parameter(name):
            v = np.broadcast_to(np.asarray(self.params[cm.param_index(name)], dtype=float), self.t.shape)
        elif name in cm.discrete_names:
            v = self.modes[cm.discrete_names.index(name)] if np.ndim(self.modes) == 2 else \
                np.full(self.t.shape, self.modes[cm.discrete_names.index(name)])
        elif name in cm.input_names:
            v = self.inputs[cm.input_names.index(name)](self.t, 0)
        else:
            base, order = split_der(name)
            if order:
                return self.der(base, order)
            if not name.endswith(".value") and name + ".value" in self._known_names():
                return self[name + ".value"]  # a causal port by its own name: res["ref.y"] is ref.y.value
            raise UnknownNameError(self._missing(name))
        self._cache[name] = v
        return v

    def _missing(self, name):
        import difflib
        close = difflib.get_close_matches(name, self.names(), n=3)
        return f"no variable {name!r} in the result of {self.model.flat.name}" + (
            f"; did you mean {', '.join(map(repr, close))}?" if close else "")

    def _mode_rows(self):
        D = self.modes
        if np.ndim(D) == 2:
            return [D[i] for i in range(D.shape[0])]
        return list(D)

    def der(self, name: str, order: int = 1) -> np.ndarray:
        """Exact time derivative of a numeric input or of a variable whose derivative the model computes;
        otherwise a finite-difference estimate over the output grid."""
        if not isinstance(order, (int, np.integer)) or order < 0:
            raise ModelError(f"der: the order must be a non-negative integer, got {order!r}")
        cm = self.model
        if name in cm.input_names:
            return self.inputs[cm.input_names.index(name)](self.t, order)
        target = der_name(name, order)
        if target in self._unknowns:
            return self._unknowns[target]
        if name in cm.flat.aliases:
            expr = cm.flat.aliases[name]
            c, rest = expr.as_coeff_Mul()
            if isinstance(rest, sp.Symbol) and not cm.has_parameter(rest.name):
                return float(c) * self.der(rest.name, order)
            if all(cm.has_parameter(s.name) for s in expr.free_symbols):
                return np.zeros(self.t.shape)
            syms = [s for s in expr.free_symbols if s.name in self._unknowns]
            if all(der_name(s.name, order) in self._unknowns for s in syms):
                from ..model.symbols import der
                d_expr = der(expr, order)
                return np.broadcast_to(np.asarray(
                    cm.eval_expr(d_expr, self._unknowns, self.params, self._mode_rows(), self.t), dtype=float),
                    self.t.shape)
        if self.dense.exact_time and order == 1 and name in self._unknowns:
            # no states: the variable is an explicit function of time; differentiate it off the grid
            h = 1e-6 * max(1.0, float(np.max(np.abs(self.t))))
            i = self.model.unknown_names.index(name)
            x = np.zeros((0,) + self.t.shape)
            f = self.model.funcs["all_values"]
            hi = np.asarray(f(self.t + h, x, self.params, self.modes, self.inputs)[i], dtype=float)
            lo = np.asarray(f(self.t - h, x, self.params, self.modes, self.inputs)[i], dtype=float)
            return np.broadcast_to((hi - lo) / (2 * h), self.t.shape)
        if order == 1 and not self.dense.exact_time:
            d_expr = cm.rate_expr(name)  # through the assignment that computes it (gear.phi_b = motor.phi / ratio)
            if d_expr is not None and not d_expr.has(SignalCall):
                return np.broadcast_to(np.asarray(
                    cm.eval_expr(d_expr, self._unknowns, self.params, self._mode_rows(), self.t), dtype=float),
                    self.t.shape)
        y = self[name]
        for _ in range(order):
            y = np.gradient(y, self.t)
        return y

    # ------------------------------------------------------------------ derived quantities
    def power(self, port: str) -> np.ndarray:
        """Power flowing *into* the component through a port [W]: ``v*i`` for a pin, ``tau*der(phi)`` for a
        flange, ``Q_flow`` for a heat port."""
        names = self._known_names()
        if f"{port}.v" in names and f"{port}.i" in names:
            return self[f"{port}.v"] * self[f"{port}.i"]
        if f"{port}.phi" in names and f"{port}.tau" in names:
            return self[f"{port}.tau"] * self.der(f"{port}.phi")
        if f"{port}.Q_flow" in names:
            return self[f"{port}.Q_flow"]
        raise UnknownNameError(f"{port!r} is not a pin, flange or heat port of {self.model.flat.name}")

    def _integrand(self, what):
        try:
            return self.power(what)
        except KeyError:
            return self[what]

    def energy(self, what: str) -> np.ndarray:
        """Cumulative time integral [J] of a port's power (``what`` a port), of the power into a component
        through all of its physical ports (``what`` a component such as a damper), or of a power variable, at
        the output times.

        Integrated as accurately as the simulation itself: 5-point Gauss-Legendre on every solver step, with
        the states taken from the integrator's dense output (steps end at events, so mode switches are exact).
        On the compiled path the model's energy accounts (sources, boundary ports, losses, power sensors) are
        integrated by CVODES with the states; anything else with a compiled form is integrated the same way by
        one more run of the same integration the first time it is asked for (with ``dense_output=False``, and for
        what has no compiled form, by the Gauss rule on the output intervals). A model without states is
        integrated the same way on the output grid with exact values at the nodes.
        """
        parts = self._through(what)
        self._check_power(what, "energy", parts)
        if parts != [what]:  # a component with several ports: the power into it through all of them
            self._integrate_with_states(parts)
            return sum(self._cumulative(p) for p in parts)
        return self._cumulative(what).copy()  # the caller's to change; the cached one stays

    def _check_power(self, what, who: str, parts=None) -> None:
        """``what`` must be something with a power: a port, a component, or a variable or parameter in W (or
        without a unit); a ModelError naming it and its unit otherwise. ``parts``: its :meth:`_through`, if known."""
        if not isinstance(what, str):
            raise ModelError(f"{who}: name a power variable, a port or a component (a str), got {what!r}")
        unit = self._unit(what)
        if unit and unit != "W" and (parts or self._through(what)) == [what] and not self._is_power_port(what):
            raise ModelError(f"{who}: {what!r} [{unit}] is not a power (W); {who}() integrates a power variable, "
                             "a port (pin, flange, heat port) or a component")

    def _is_power_port(self, name) -> bool:
        try:
            self.power(name)
            return True
        except KeyError:
            return False

    def energy_balance(self, t0: float | None = None, t1: float | None = None, between: tuple | None = None):
        """The energy balance between output times ``t0`` and ``t1`` (default: the whole result), from the
        model's accounts found by convention (:mod:`acausal.results.energy`): energy the sources and the boundary
        delivered, lost per ``loss_power``, change of every stored ``energy``; ``print`` it for the table,
        ``.residual`` is the relative residual. ``between=(a, b)`` adds the :meth:`efficiency` from ``a`` to
        ``b`` (``.efficiency``, a number; ``.efficiency_path = (a, b)``; printed under the table)."""
        from .energy import balance
        b = balance(self, self.model.accounts, *self._window(t0, t1))
        if between is not None:
            if isinstance(between, str) or not hasattr(between, "__len__") or len(between) != 2:
                raise ModelError(f"energy_balance: between must be a pair (a, b) of names (power variables, ports "
                                 f"or components), got {between!r}")
            a, z = between
            b.efficiency, b.efficiency_path = self.efficiency(a, z, t0, t1), (a, z)
        return b

    def efficiency(self, a: str, b: str, t0: float | None = None, t1: float | None = None) -> float:
        """Energy that passed ``b`` over energy that passed ``a`` between output times ``t0`` and ``t1``.

        ``a`` and ``b`` are anything :meth:`energy` integrates: a power variable (a power sensor's ``P``, a
        supply's ``power``, ``motor.shaft_power``), a one-port component (``v i``), a flange (``tau w``, power
        into its component). Each side is the magnitude of its net energy over the window, so the sign
        convention of the port (into its component) does not matter; over a window where energy flows both
        ways (a drive that brakes), this is the ratio of the net energies. No net energy at ``a`` is a
        :class:`ModelError`.
        """
        k0, k1 = self._window(t0, t1)
        for x in (a, b):
            self._check_power(x, "efficiency")
        self._integrate_with_states(self._through(a) + self._through(b))  # one more run for both, if any
        ea, eb = (self._passed(x, k0, k1) for x in (a, b))
        if ea == 0.0:
            raise ModelError(f"efficiency {a} -> {b}: no net energy passed {a!r} between {self.t[k0]:g} and "
                             f"{self.t[k1]:g} s")
        eta = abs(eb) / abs(ea)
        if eta > 1.0 + 1e-9:
            import warnings
            warnings.warn(f"efficiency {a} -> {b} is {eta:.4g} > 1 between {self.t[k0]:g} and {self.t[k1]:g} s: more "
                          f"energy passed {b!r} ({eb:.4g} J) than {a!r} ({ea:.4g} J); are the ends reversed, or does "
                          "energy reach the far end from a store or another source?", stacklevel=2)
        return eta

    def _through(self, name: str) -> list:
        """What :meth:`_passed` integrates for ``name``: ``name`` itself (a variable, a port, a one-port), or a
        component's physical ports."""
        cm = self.model
        if name not in cm.flat.components:
            return [name]
        known = self._known_names()
        if name in known or {f"{name}.v", f"{name}.i"} <= known or {f"{name}.phi", f"{name}.tau"} <= known \
                or f"{name}.Q_flow" in known:
            return [name]
        ports = [p for p in cm.flat.components if p.startswith(name + ".") and "." not in p[len(name) + 1:]
                 and ({f"{p}.v", f"{p}.i"} <= known or {f"{p}.phi", f"{p}.tau"} <= known or f"{p}.Q_flow" in known)
                 and self._is_port(p)]
        return ports or [name]

    def _is_port(self, path: str) -> bool:
        """Whether the component at ``path`` is a connector (its current, torque or heat flow a connector's
        ``Flow``), not a part inside a composite whose one-port ``v``/``i`` only look like a pin's."""
        flat = self.model.flat
        for flow in ("i", "tau", "Q_flow"):
            info = flat.variables.get(f"{path}.{flow}") or flat.alias_info.get(f"{path}.{flow}")
            if info is not None:
                return getattr(info, "kind", "") == "flow"
        return False

    def _known_names(self) -> set:
        """The names this result answers, as a set (built once)."""
        if "known names" not in self._cache:
            self._cache["known names"] = set(self.names())
        return self._cache["known names"]

    def _passed(self, name: str, k0: int, k1: int) -> float:
        """Net energy [J] through ``name`` between samples ``k0`` and ``k1``: what :meth:`energy` integrates,
        or for a component with several ports the power into it through all of its physical ports."""
        return float(sum(self.energy(p)[k1] - self.energy(p)[k0] for p in self._through(name)))

    def sankey(self, ax=None, t0: float | None = None, t1: float | None = None, title: str | None = None):
        """Sankey diagram between output times ``t0`` and ``t1``: the energy passed on at each power sensor (in
        the order the model built them), each stage's loss named by its components (:mod:`acausal.results.energy`); a
        model with fewer than two power sensors gets its energy balance as one diagram (inflows left, each
        loss and stored energy leaving)."""
        from .energy import draw_sankey
        if ax is not None and not callable(getattr(ax, "add_patch", None)):
            raise ModelError(f"sankey: ax must be a matplotlib Axes (or None for a new figure), got {ax!r}")
        return draw_sankey(self, self.model.accounts, ax, *self._window(t0, t1), title)

    def to_html(self, path, t0: float | None = None, t1: float | None = None, title: str | None = None,
                names=(), max_points: int = 4000):
        """Write a self-contained HTML page of this run to ``path`` (plotly.js inline, data embedded; opens from
        the file system, offline) and return its path: the energy accounts found by convention as an interactive
        Sankey diagram between output times ``t0`` and ``t1`` [s] (as :meth:`sankey`), every account's power and
        the variables ``names`` over time (at most ``max_points`` samples drawn), the energy balance [J] and its
        relative residual over time (:mod:`acausal.results.html`). Needs plotly (``pip install "acausal[html]"``):
        without it a ModelError says so."""
        from .html import result_page
        return result_page(self, path, t0, t1, title, names, max_points)

    def _window(self, t0, t1) -> tuple:
        """Output samples nearest to ``t0`` and ``t1`` (default: the first and the last); a ModelError when a time
        is not a number, lies outside the run (by more than half an output interval) or ``t0`` is not before
        ``t1``."""
        t = self.t
        slack = 0.5 * float(np.max(np.diff(t))) if t.size > 1 else 0.0
        for what, value in (("t0", t0), ("t1", t1)):
            if value is None:
                continue
            if isinstance(value, (str, bytes, bool, np.bool_)) or not np.isscalar(value) or not np.isreal(value) \
                    or not np.isfinite(value):
                raise ModelError(f"window: {what} must be a time in s (a finite number), got {value!r}")
            if not t[0] - slack <= value <= t[-1] + slack:
                raise ModelError(f"window: {what} = {value:g} s is outside the run ({t[0]:g}..{t[-1]:g} s)")
        if t0 is not None and t1 is not None and not t0 < t1:
            raise ModelError(f"window: t0 = {t0:g} s must be before t1 = {t1:g} s")
        k0 = 0 if t0 is None else int(np.argmin(np.abs(t - t0)))
        k1 = t.size - 1 if t1 is None else int(np.argmin(np.abs(t - t1)))
        return k0, k1

    def integral(self, name: str) -> float:
        """Integral of a variable (or a port's power) over the whole result, like :meth:`energy`."""
        return float(self._cumulative(name)[-1])

    def _quadrature_nodes(self, steps_only: bool = False):
        """Gauss-Legendre nodes of every solver step (cut at the output times) and a Result evaluated there;
        built once per Result and shared by all energy integrals. ``steps_only``: the steps uncut (the run's
        totals, :meth:`_run_energy`: a fifth to a sixth of the nodes with many outputs per step)."""
        steps_only = steps_only and bool(self.dense.steps) and self.dense.nodes is None
        key = ("nodes", steps_only)
        if key not in self._cache:
            self._cache[key] = nodes_at(self, None, self._node_samples()) if steps_only else nodes_at(self, self.t)
        return self._cache[key]

    def _node_samples(self):
        """The times, states and modes at the Gauss nodes of the solver's steps, uncut (the run's totals;
        :func:`~acausal.results.gauss.node_samples`), found once per Result."""
        if "node samples" not in self._cache:
            self._cache["node samples"] = node_samples(self, None)
        return self._cache["node samples"]

    def _totals_on_steps(self) -> bool:
        """Whether the run's totals come from the scipy path's steps' own Gauss nodes (:meth:`_run_energy`): not
        where the compiled path integrated the energies with the states, nor without dense output."""
        return bool(self.dense.steps) and self.dense.nodes is None and not self.dense.integrals

    def _run_samples(self) -> "Result":
        """The samples the run's totals come from: the steps' Gauss nodes (a Result there, :meth:`_totals_on_steps`),
        else this result's outputs."""
        return self._quadrature_nodes(steps_only=True)[4] if self._totals_on_steps() else self

    def ends(self, names) -> dict:
        """``name -> (value at the first output, value at the last)``, evaluated at those two times only where the
        outputs have not been evaluated yet (the values of a variable the model computes; others, such as aliases,
        from the outputs)."""
        cm = self.model
        names = list(dict.fromkeys(names))
        if self.evaluated() or not self.t.size:
            return {n: (np.asarray(self[n])[0], np.asarray(self[n])[-1]) for n in names}
        pick = [0, self.t.size - 1]
        D = self.modes if np.ndim(self.modes) == 1 else np.asarray(self.modes)[:, pick]
        index = {n: i for i, n in enumerate(cm.unknown_names)}
        rows = self.unknowns_at(self.t[pick], np.asarray(self.states)[:, pick], D) if \
            any(n in index for n in names) else []
        out = {}
        for n in names:
            v = rows[index[n]] if n in index else self._states_by_name.get(n)
            if v is None:
                v = np.asarray(self[n])[pick]
            out[n] = (float(v[0]), float(v[-1]))
        return out

    def _run_energy(self, what: str) -> np.ndarray:
        """What :meth:`energy` integrates, cumulative at the solver's step boundaries instead of the output times
        (the first the run's start, the last its end): the trust check's balance needs the run's totals only,
        which the steps' own Gauss nodes give without the output times' cuts. Where the energies are not
        integrated on the scipy path's steps (the compiled path's quadratures, no dense output), the
        cumulative energy at the output times."""
        if not self._totals_on_steps():
            return self.energy(what)
        key = ("run cumulative", what)
        if key not in self._cache:
            nodes = self._quadrature_nodes(steps_only=True)
            self._cache[key] = sum(gauss_cumulative(nodes, part) for part in self._through(what))
        return self._cache[key]

    def _integrate_with_states(self, names) -> None:
        """On the compiled path: the integrals of ``names`` not yet integrated with the states, by one more run
        of the same integration with them as quadratures (an output interval may hold a transient that its Gauss
        nodes do not resolve; the integrator's steps do)."""
        names = [n for n in dict.fromkeys(names) if n not in self.dense.integrals and n not in self._asked]
        if self.dense.more is None or not names:
            return
        self._asked.update(names)
        self.dense.integrals.update(self.dense.more(names))

    def _cumulative(self, what):
        """The cumulative integral of ``what`` at the output times (found once per result: the trust check's
        energy balance and the user's share it)."""
        key = ("cumulative", what)
        if key not in self._cache:
            self._cache[key] = self._integrate(what)
        return self._cache[key]

    def _integrate(self, what):
        t = self.t
        self._integrate_with_states([what])
        if what in self.dense.integrals:
            q = self.dense.integrals[what]
            return q - q[0]
        if not self.dense.steps and not self.dense.exact_time and self.dense.nodes is None:
            return integrate_cumulative(self._integrand(what), t)
        nodes = self._quadrature_nodes()
        return gauss_cumulative(nodes, what)[np.searchsorted(nodes[0], t)]

    # ------------------------------------------------------------------ export
    def to_csv(self, path, names=None) -> None:
        """Write ``time`` and the named variables (default: all) as CSV, one row per output time."""
        import os
        names = list(names) if names is not None else self.names()
        cols = [self[n] for n in names]
        if os.path.isdir(path):
            raise ModelError(f"to_csv: {path} is a folder; give a file path (e.g. {os.path.join(path, 'run.csv')})")
        folder = os.path.dirname(os.fspath(path))
        if folder and not os.path.isdir(folder):
            raise ModelError(f"to_csv: the folder {folder} of {path} does not exist")
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["time"] + names)
            for k in range(self.t.size):
                w.writerow([repr(float(self.t[k]))] + [repr(float(c[k])) for c in cols])

    def plot(self, *names, ax=None, label=None, **kwargs):
        """Plot variables over time with matplotlib; returns the axes.

        One y axis per unit: the first unit on ``ax`` (labelled with it), a second one on a twin axis at the right
        (``ax.twin``); a third unit and more share the second axis, with a warning naming them. ``label``: a string
        (one name), a list (one per name) or a dict (name -> label); by default each curve is labelled with its name
        and unit. Other keywords go to matplotlib's ``plot``. Outside a notebook call ``matplotlib.pyplot.show()``
        to see the figure (or save it: ``ax.figure.savefig(path)``)."""
        from .plotting import plot_result
        return plot_result(self, names, ax, label, kwargs)

    def _unit(self, name):
        flat = self.model.flat
        base = split_der(name)[0]
        if base in flat.variables:
            return flat.variables[base].unit
        if base in flat.alias_info:
            return flat.alias_info[base].unit
        if base in flat.parameters:
            return flat.parameters[base].unit
        return ""

    def __repr__(self):
        return f"<Result {self.model.flat.name}: {self.t.size} samples, t = {self.t[0]:g}..{self.t[-1]:g} s>"

