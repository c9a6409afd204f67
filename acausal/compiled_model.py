"""The compiled model, the façade over every stage: ``compile_model`` runs the compiler's stages
(:mod:`acausal.compile.pipeline`) and hands back a :class:`CompiledModel`, which prints its numeric functions
(:mod:`acausal.backends`), simulates (:mod:`acausal.simulation`) and returns results (:mod:`acausal.results`).

The result, :class:`CompiledModel`, is compiled once and simulated many times with other parameter values,
start values or input signals. ``report()`` tells what the compiler did: states, index, blocks.
"""
from __future__ import annotations

import difflib
from collections.abc import Mapping

import numpy as np
import sympy as sp

from .backends.numpy.printer import CodeGenerator, Functions
from .compile.parameters import bound_message, check_parameter
from .compile.pipeline import run_stages
from .errors import ModelError, SignalError, UnknownNameError
from .model.signals import ParametricSignal, Signal, SignalCall
from .model.symbols import time, var_symbol


def compile_model(model) -> "CompiledModel":
    """Compile a model instance (see :class:`acausal.Model`) into fast numeric functions (the stages:
    :func:`acausal.compile.pipeline.run_stages`)."""
    c = run_stages(model)
    return CompiledModel(c.flat, c.system, c.program, c.seconds, c.accounts)


_ONCE: dict = {}  # the process's compiled models by build key (compile_once)


def compile_once(key, build) -> "CompiledModel":
    """The model ``build()`` makes, compiled once per process: later calls with an equal ``key`` return the same
    :class:`CompiledModel` without building or compiling again. ``key`` is a hashable description of everything
    the build depends on, led by what the model is (``("servo_pendulum", terms, effects)``), so that two builds
    share a compiled model only when they make the same one. Each worker of a process pool compiles its own."""
    try:
        hash(key)
    except TypeError:
        raise TypeError(f"compile_once: the key {key!r} is not hashable (use tuples, not lists)") from None
    if key not in _ONCE:
        _ONCE[key] = compile_model(build())
    return _ONCE[key]


class CompiledModel:
    """A compiled model: numeric functions plus everything needed to name, initialise and simulate.

    ``flat`` is the flattened model (aliases eliminated), ``reduction`` the solved equation system
    (:class:`~acausal.compile.structure.EquationSystem`: equations after index reduction with their origins, states,
    dummy derivatives, BLT ``blocks`` and solved ``steps``, also reachable as :attr:`blocks` and :attr:`steps`),
    ``program`` what every backend prints (:class:`~acausal.compile.program.Program`: parameters, steps, events,
    aliases, signal reads), ``generator`` its numpy code generator and ``funcs`` the generated functions.
    ``accounts`` are the model's energy accounts found by convention (:class:`~acausal.compile.accounts.Accounts`:
    losses, stored energies, sources, boundary, power sensors), which :meth:`Result.energy_balance
    <acausal.results.result.Result.energy_balance>` and :meth:`Result.sankey <acausal.results.result.Result.sankey>`
    use. The numeric functions are printed when first used (a run on the fixed step never uses them), so
    :attr:`compile_seconds` does not include them.
    """

    def __init__(self, flat, system, program, compile_seconds, accounts=None):
        self.flat = flat
        self.program = program
        #: input name -> the highest derivative order the equations and zero functions read of it
        self.signal_orders = dict(program.signal_orders)
        self.accounts = accounts
        self.reduction = system
        self.blocks = system.blocks
        self.steps = list(program.steps)
        self.generator = gen = CodeGenerator(program)
        self.funcs = Functions(gen)  # each printed when first asked for
        self.event_zeros = program.zeros
        self.compile_seconds = compile_seconds
        self.state_names = list(program.states)
        self.unknown_names = list(program.unknowns)
        self.param_names = list(program.params)
        self.discrete_names = list(program.discretes)
        self.input_names = list(program.inputs)
        self._param_index = {n: i for i, n in enumerate(self.param_names)}
        self._discrete_index = {n: i for i, n in enumerate(self.discrete_names)}
        self._variables = frozenset(self.state_names) | frozenset(self.unknown_names)
        self._param_plan = program.parameters
        self._defaults = None  # the default parameter vector, once param_vector has built it
        self.derived: dict = {}  # what the stages after compilation work out from the model once, by their own keys
        # parameters bound to an expression of others: not overridable (they would disagree with the others)
        self._bound = program.bindings
        self._expr_cache: dict = {}  # sympy expression -> (numeric function, symbol names), see eval_expr
        self._compiled_path = None

    @property
    def compiled_path(self):
        """The model's compiled simulation path (:class:`acausal.simulation.compiled.path.CompiledPath`, built on first
        use; it needs CasADi)."""
        if self._compiled_path is None:
            from .simulation.compiled.path import CompiledPath
            self._compiled_path = CompiledPath(self)
        return self._compiled_path

    def simulation_path(self, inputs: dict | None = None) -> str:
        """Which path :meth:`simulate` takes by default for a run with ``inputs`` (the model's own when None), and
        why: ``"compiled (native loop: CVODES in C)"``, ``"compiled (CasADi CVODES)"`` or ``"scipy LSODA:
        <reason>"``. The native loop is asked as a default run asks it (building the model's library for it, once
        per machine, where it is not built yet)."""
        from .simulation import choose_path
        u = self.input_tuple(inputs)
        if not self.state_names:
            from .simulation.algebraic import SOLVER
            return SOLVER
        method, why = choose_path(self, "auto", u, 1e-6, 1e-9)
        if why:
            return f"scipy {method}: {why}"
        from .compile.accounts import account_integrals
        from .simulation.compiled import native_loop
        name = self.compiled_path.integrator_name(u)
        runner, _ = native_loop.runner_for(self, u, account_integrals(self.accounts) if self.accounts else [])
        return f"compiled (native loop: {name} in C)" if runner is not None else f"compiled (CasADi {name})"

    # ------------------------------------------------------------------ names and values
    @property
    def source(self) -> str:
        """The generated Python source."""
        return self.generator.source

    def names(self, pattern: str | None = None, parameters: bool = False) -> list:
        """Every variable name the results answer (states, algebraic unknowns and aliases), sorted; with
        ``parameters=True`` the parameters too. ``pattern`` keeps the names that match it as a shell-style
        wildcard (``"motor.*"``, ``"*.loss_power"``; see :mod:`fnmatch`) or, without wildcards, that contain it."""
        names = set(self.state_names) | set(self.unknown_names) | set(self.flat.aliases)
        if parameters:
            names |= set(self.param_names)
        from .compile.introspect import filtered
        return filtered(sorted(names), pattern)

    def equations(self, component: str | None = None, solved: bool = False):
        """The model's equations, one per line under the component (or connection) they come from; ``print``
        it (a :class:`~acausal.model.describe.Listing`, a ``str``).

        ``component``: a component's path (``"motor"``), for its equations and those of everything inside it
        with the connections made inside it; None for the whole model. By default the equations are shown as
        the components wrote them, in hierarchical names; ``solved=True`` shows them after alias elimination
        (what structural analysis works on: connected potentials and flows merged, ``0 = residual``) with the
        component's eliminated aliases. A path that is no component is a :class:`ModelError` with suggestions.
        """
        from .compile.introspect import equations_listing
        return equations_listing(self, component, solved)

    def rate_expr(self, name: str):
        """d/dt of variable or alias ``name`` as a sympy expression in quantities the model computes (states,
        unknowns, state derivatives, parameters, modes, inputs and their derivatives), or None when it has no
        such closed form. A derivative the model does not compute is taken through the explicit assignment that
        computes the variable (``gear.phi_b = motor.phi / ratio`` gives ``der(motor.phi) / ratio``), repeatedly;
        a variable from a numeric block or an assignment with a non-smooth function (Min, Max, Abs, Piecewise)
        has none. Energies of flanges use it (``tau der(phi)``), so they are integrated, not differenced."""
        from .compile.introspect import rate_expr
        return rate_expr(self, name)

    def parametric_inputs(self) -> dict:
        """Inputs rebuilt from the run's parameters (:class:`~acausal.model.signals.ParametricSignal`, e.g. a planned
        trajectory): input name -> the parameter names it is built from. Setting any of them in a run's
        ``params`` rebuilds (replans) that input; no other parameter changes an input."""
        return {n: tuple(dict.fromkeys(info.signal.parameters.values()))
                for n, info in sorted(self.flat.inputs.items()) if isinstance(info.signal, ParametricSignal)}

    def device_defaults(self, params: dict | None = None) -> dict:
        """Parameters left at a library default that belongs to one device (a datasheet number or an
        assumption about one device, :class:`~acausal.model.components.Parameter` ``device``), unless ``params``
        (a run's overrides) sets them: name -> (value, unit, device)."""
        given = set(params or ())
        for name in given:
            self.param_index(name)  # a misspelt override raises, with suggestions
        return {n: (float(p.value), p.unit, p.device) for n, p in sorted(self.flat.parameters.items())
                if p.device and n not in given and not isinstance(p.value, sp.Basic)}

    def unknown_name_error(self, name: str, kind: str, candidates) -> UnknownNameError:
        """The error for a name the model does not have (a :class:`ModelError` and a ``KeyError``): ``kind``
        says what was looked for ("parameter", "variable", ...), and up to three close ``candidates`` are
        suggested."""
        close = difflib.get_close_matches(str(name), list(candidates), n=3)
        hint = f"; did you mean {', '.join(map(repr, close))}?" if close else ""
        return UnknownNameError(f"unknown {kind} {name!r} in model {self.flat.name}{hint}")

    def has_parameter(self, name: str) -> bool:
        """Whether ``name`` is a parameter of the model (an entry of :attr:`param_names`)."""
        return name in self._param_index

    def param_index(self, name: str) -> int:
        """Position of parameter ``name`` in :attr:`param_names` (and so in :meth:`param_vector`); an unknown
        name raises :class:`ModelError` with suggestions."""
        try:
            return self._param_index[name]
        except KeyError:
            raise self.unknown_name_error(name, "parameter", self.param_names) from None

    def event_assignments(self, index: int, rising: bool) -> list:
        """What event ``index`` (of :attr:`event_zeros`) assigns when its zero function crosses upwards
        (``rising``) or downwards: a list of ``(mode name, sympy expression)``, the expression in variables,
        parameters, modes and time (evaluate it with :meth:`eval_expr`)."""
        ev = self.program.events[index]
        return list(ev.rising if rising else ev.falling)

    def event_reinits(self, index: int) -> list:
        """The states event ``index`` restarts when its zero function rises (:class:`~acausal.model.components.Event`
        ``reinit``): a list of ``(state name, sympy expression)``."""
        return list(self.program.events[index].reinit)

    def eval_expr(self, expr, values=None, p=None, d=None, t=None):
        """Numeric value of ``expr``, a sympy expression of variables, parameters, discrete modes and time.

        Each symbol takes its value from ``values`` (a mapping name -> number or array, e.g. the value rows of
        a result) when it is there, else from the parameter vector ``p`` (in :attr:`param_names` order), else
        from the modes ``d`` (in :attr:`discrete_names` order); ``time`` is ``t`` [s]. Arrays broadcast. The
        expression is turned into a numeric function once and cached on the model, so evaluating the same
        expression again costs only the call. A symbol with no value raises :class:`ModelError` naming it.
        """
        fn, names = self._expr_function(expr)
        if fn is None:
            return names
        args = []
        for n in names:
            if n is None:
                if t is None:
                    raise ModelError(f"eval_expr: {expr} depends on time, but no time t was given")
                args.append(t)
            elif values is not None and n in values:
                args.append(values[n])
            elif p is not None and n in self._param_index:
                args.append(p[self._param_index[n]])
            elif d is not None and n in self._discrete_index:
                args.append(d[self._discrete_index[n]])
            else:
                raise ModelError(f"eval_expr: no value for {n!r} in {expr} (not in values, and no parameter "
                                 "vector p or modes d that has it)")
        return fn(*args)

    def _expr_function(self, expr):
        """``(function, symbol names)`` for :meth:`eval_expr` (``None`` standing for time), built on first
        use; ``(None, value)`` for a number."""
        if not isinstance(expr, sp.Basic):
            expr = sp.sympify(expr)
        try:
            return self._expr_cache[expr]
        except KeyError:
            pass
        if expr.has(SignalCall):
            raise ModelError(f"eval_expr: {expr} calls an input signal; evaluate signals through the model's "
                             "generated functions")
        syms = sorted(expr.free_symbols, key=lambda s: s.name)
        if not syms:
            entry = (None, float(expr))
        else:
            plain = [sp.Symbol(f"a{i}") for i in range(len(syms))]
            fn = sp.lambdify(plain, expr.xreplace(dict(zip(syms, plain))), "numpy")
            entry = (fn, [None if s is time else s.name for s in syms])
        self._expr_cache[expr] = entry
        return entry

    def param_vector(self, params: dict | None = None) -> np.ndarray:
        """Numeric parameter vector (in :attr:`param_names` order) with ``params`` overriding defaults.

        A parameter bound to an expression of others (``Resistor(R=2 * self.R0)``) is evaluated from their
        values in this run; overriding it is a :class:`ModelError` naming what it is bound to (it would disagree
        with them); the expressions are compiled once per model. Every value is checked against its parameter's
        bounds (:class:`ModelError` naming the parameter and its owner).
        A value may be an array (a batch of parameter sets): the vector then has dtype object entries that
        broadcast in the generated code; use :meth:`param_batch` for the usual case.
        """
        params = _mapping(params, "params")
        if not params and self._defaults is not None:
            return self._defaults.copy()
        for k in params:
            if k not in self._param_index:
                raise self.unknown_name_error(k, "parameter", self.param_names)
            if k in self._bound:
                raise ModelError(self.bound_message(k))
        values: dict = {}
        batch = False
        for name, info, binding, default in self._param_plan:
            if name in params:
                v = params[name]
            elif binding is not None:
                v = self.eval_expr(binding, values)
            else:
                v = default
            batch = check_parameter(info, v) or batch
            values[name] = v
        for cond, message, origin in self.flat.assertions:
            if not np.all(self.eval_expr(cond, values)):
                used = ", ".join(f"{s.name} = {values[s.name]}" for s in sorted(cond.free_symbols, key=str))
                raise ModelError(f"{origin}: {message} ({cond} fails with {used})")
        if batch:
            out = np.empty(len(self.param_names), dtype=object)
            for i, n in enumerate(self.param_names):
                out[i] = values[n]
            return out
        vector = np.array([values[n] for n in self.param_names], dtype=float)
        if not params:  # the defaults, checked: the same for every run that overrides nothing
            self._defaults = vector.copy()
        return vector

    @property
    def bindings(self) -> dict:
        """Bound parameters (``Resistor(R=2 * self.R0)``): name -> sympy expression of the others (a copy)."""
        return dict(self._bound)

    @property
    def parameter_plan(self) -> tuple:
        """``(name, info, binding or None, default)`` per parameter, a bound one after those it is bound to."""
        return tuple(self._param_plan)

    def bound_message(self, name: str) -> str:
        """Why a bound parameter cannot be overridden alone (the error :meth:`param_vector` raises; an exported
        FMU says the same)."""
        return bound_message(self.flat, name, self._bound[name])

    def param_batch(self, sets: list) -> np.ndarray:
        """Parameter array of shape ``(n_params, B, 1)`` for ``B`` parameter sets: generated functions evaluated
        with it over ``N`` time samples return arrays of shape ``(B, N)``."""
        cols = [self.param_vector(s) for s in sets]
        if not cols:
            raise ModelError("param_batch: no parameter sets given")
        return np.stack(cols, axis=1)[:, :, None]

    def input_tuple(self, inputs: dict | None = None, p=None) -> tuple:
        """The numeric inputs of a run, in :attr:`input_names` order: ``inputs`` (name -> :class:`Signal`) replace
        the model's own; a :class:`~acausal.model.signals.ParametricSignal` is bound to the run's parameter vector
        ``p`` (default values when None)."""
        inputs = _mapping(inputs, "inputs")
        for k, v in inputs.items():
            if k not in self.flat.inputs:
                raise self.unknown_name_error(k, "numeric input", self.input_names)
            if not isinstance(v, Signal):
                raise ModelError(f"input {k!r}: a replacement must be a Signal, got {type(v).__name__}")
        chosen = [inputs.get(n, self.flat.inputs[n].signal) for n in self.input_names]
        if any(isinstance(v, ParametricSignal) for v in chosen):
            values = dict(zip(self.param_names, self.param_vector() if p is None else p))
            chosen = [v.bind(values) if isinstance(v, ParametricSignal) else v for v in chosen]
        for n, v in zip(self.input_names, chosen):  # replacements and bound signals (the model's own are checked
            need = self.signal_orders.get(n, 0)  # when it compiles)
            if v.max_order is not None and v.max_order < need:
                raise SignalError(f"input {n!r}: the model needs derivatives up to order {need}, the signal "
                                  f"{v.name!r} ({type(v).__name__}) provides up to {v.max_order}")
        return tuple(chosen)

    def discrete_start(self) -> np.ndarray:
        return np.array([self.flat.discretes[n].start for n in self.discrete_names], dtype=float)

    # ------------------------------------------------------------------ running
    def simulate(self, t_end: float, **kwargs):
        """Simulate from ``t_start`` (default 0) to ``t_end``; see :func:`acausal.simulation.simulate.simulate`."""
        from .simulation.simulate import simulate
        return simulate(self, t_end, **kwargs)

    def simulate_many(self, t_end: float, params, **kwargs) -> list:
        """One result per parameter set in ``params`` (list of dicts), in one call where the compiled path allows
        it (the native loop on several threads, or CVODES mapped over the sets); see
        :func:`acausal.simulation.batch.simulate_many`."""
        from .simulation.batch import simulate_many
        return simulate_many(self, t_end, params, **kwargs)

    def evaluate(self, t, x=None, params=None, inputs=None, discrete=None, names=None):
        """Every unknown at times ``t`` for given states ``x`` (shape ``(n_states, len(t))``), vectorised.

        For a model without states (everything prescribed) this is the whole solution, no integrator needed.
        ``params`` may be a dict or a parameter array from :meth:`param_vector` / :meth:`param_batch` (values then
        have shape ``(B, len(t))``). ``names``: return just these variables, aliases included.
        """
        t = np.asarray(t, dtype=float)
        p = params if isinstance(params, np.ndarray) else self.param_vector(params)
        u = self.input_tuple(inputs, p)
        d = self.time_modes(t, p, self.discrete_start()) if discrete is None else discrete
        if x is None:
            if self.state_names:
                raise ModelError(f"model {self.flat.name} has states {self.state_names}; pass x or simulate")
            x = np.zeros((0,) + t.shape)
        elif np.ndim(x) < 1 or len(x) != len(self.state_names):
            raise ModelError(f"evaluate: x must have one row per state of {self.flat.name} "
                             f"({len(self.state_names)}: {self.state_names}), got shape {np.shape(x)}")
        if names is None:
            vals = self.funcs["all_values"](t, x, p, d, u)
            shape = np.broadcast_shapes(t.shape, *[np.shape(v) for v in vals])
            return {n: np.broadcast_to(np.asarray(v, dtype=float), shape) for n, v in zip(self.unknown_names, vals)}
        # just the named: one generated function through the steps they need (a design map's power sensors)
        names, exprs = list(names), []
        for n in names:
            if n in self._variables:
                exprs.append(var_symbol(n))
            elif n in self.flat.aliases:
                exprs.append(self.flat.aliases[n])
            else:
                raise self.unknown_name_error(n, "variable", self.names())
        vals = self.generator.expressions_function(exprs)(t, x, p, d, u)
        shape = np.broadcast_shapes(t.shape, *[np.shape(v) for v in vals])
        return {n: np.broadcast_to(np.asarray(v, dtype=float), shape) for n, v in zip(names, vals)}

    def time_modes(self, t, p, d) -> np.ndarray:
        """The modes ``d`` with every time event's mode (:func:`acausal.compile.time_events.time_events`: 1 from its
        threshold on) set for the time(s) ``t`` under parameters ``p``: one column per time for an array ``t``."""
        if not self.flat.time_events:
            return d
        t = np.asarray(t, dtype=float)
        out = np.repeat(np.asarray(d, dtype=float)[:, None], t.size, axis=1) if t.ndim else \
            np.asarray(d, dtype=float).copy()
        for name, c in self.flat.time_events.items():
            flag = (t >= float(self.eval_expr(c, None, p))).astype(float)
            out[self._discrete_index[name]] = flag.ravel() if t.ndim else flag
        return out

    def sensitivities(self, t, wrt, names=None, params=None, inputs=None, rtol: float = 1e-8, atol: float = 1e-10,
                      *, t_start: float = 0.0, starts: dict | None = None, method: str = "auto",
                      substeps: int = 4):
        """Values and exact parameter sensitivities ``d name / d wrt[j]`` at times ``t``: ``(values, sens)`` with
        ``values[name]`` of shape ``(len(t),)`` and ``sens[name]`` of shape ``(len(wrt), len(t))``.

        ``names`` may include aliases (default: every state and unknown). A model with states is integrated with
        its sensitivities from ``t_start`` (start values independent of the parameters); ``rtol``/``atol`` and
        ``method`` are the integrator's (``"RK4"``: fixed steps on ``t``, ``substeps`` per interval). See
        :func:`acausal.simulation.sensitivity.sensitivities`.
        """
        from .simulation.sensitivity import sensitivities
        return sensitivities(self, t, wrt, names=names, params=params, inputs=inputs, rtol=rtol, atol=atol,
                             t_start=t_start, starts=starts, method=method, substeps=substeps)

    # ------------------------------------------------------------------ report
    def report(self) -> str:
        """What the compiler did (states, index, dummy derivatives, blocks), the simulation path, the inputs
        rebuilt from parameters and the parameters left at a device's default
        (:func:`acausal.compile.introspect.report`)."""
        from .compile.introspect import report
        return report(self)

    def __repr__(self):
        return f"<CompiledModel {self.flat.name}: {len(self.state_names)} states, {len(self.unknown_names)} unknowns>"


def _mapping(value, what: str) -> dict:
    """``value`` (a mapping by name, or None) as a new dict; anything else is a ModelError naming ``what``."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ModelError(f"{what} must be a dict by name, got {type(value).__name__}")
    return dict(value)
