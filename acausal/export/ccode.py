"""C code of a compiled model for an FMI 2.0 Model Exchange FMU, printed from the same lowered program
(:class:`~acausal.compile.program.Program`) as the Python code generator (:mod:`acausal.backends.numpy.printer`) and the
CasADi translation; shared subexpressions by their one rule (:func:`acausal.compile.program.lower`).

Every real variable of the FMU lives in one array ``r`` at the index of its value reference (:class:`Layout`):
parameters, states, unknowns (state derivatives included), aliases and discrete modes. The generated functions are

* ``model_bound_parameters``: parameters bound to an expression of others, in dependency order;
* ``model_check_parameter``: one parameter's value against its bounds (finite, ``min``, ``max``);
* ``model_check_assertions``: the conditions on parameters (:meth:`Component.assertions
  <acausal.model.components.Component.assertions>`), each failure logged with its component and message;
* ``model_evaluate``: every unknown (assignments, linear blocks by Gaussian elimination, Newton blocks by
  ``solve_newton`` in the runtime), every alias and every event zero function, from time, states, parameters and
  modes. A Newton block is solved by the rules of simulate(): the damped iteration of
  :func:`acausal.backends.numpy.runtime.newton` (its exact Jacobian, its line search, iteration limit, step test
  and accepted residual), from the block's last converged solution (as IDAS carries the block's variables on the
  compiled path), and from its start values where that fails (as the scipy path starts every evaluation);
* ``model_event``: the assignments of an event (rising or falling), evaluated before any is made.

Numeric input signals are compiled in: a signal with polynomial pieces (:meth:`Signal.table
<acausal.model.signals.Signal.table>`: splines, sampled data) becomes a constant table looked up by binary search; one
with a closed form (:meth:`Signal.symbolic <acausal.model.signals.Signal.symbolic>`) becomes its expression,
differentiated by sympy to the orders the equations use. Common subexpressions are shared (sympy ``cse``), each emitted
just before its first use.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter

from ..backends.numpy import runtime
from ..errors import ModelError
from ..model.declarations import BOUND_RTOL
from ..simulation.events import CASCADE_ITER, KNEE, ROUNDOFF, SETTLE_ITER
from ..simulation.simulate import simulate
from ..model.signals import ParametricSignal, SignalCall
from ..compile.solve import Assign, LinearSolve, NewtonSolve
from ..compile.program import lower
from ..model.symbols import der_name, time


class ExportError(ModelError):
    """A model (or the machine) cannot produce an FMU; the message says what is missing and what to do."""


#: the FMU's event limit: an Integer parameter of this name (value reference NR, after every Real), whose start is
#: simulate()'s default max_events; more events than that stop the FMU as they stop simulate()
MAX_EVENTS_NAME = "max_events"
MAX_EVENTS = inspect.signature(simulate).parameters["max_events"].default

#: the Newton iteration's rules, from runtime.newton (its tolerance and iteration limit, its line search, the
#: residual it accepts after its last iteration)
_NEWTON = inspect.signature(runtime.newton).parameters
NEWTON_TOL, NEWTON_MAXITER = float(_NEWTON["tol"].default), int(_NEWTON["maxiter"].default)
NEWTON_ACCEPT = runtime.ACCEPTED_RESIDUAL
NEWTON_MAX = 16  # tear variables of one block at most in the C runtime (its arrays are fixed in size)


@dataclass
class Layout:
    """Value references of an exported model: ``r[vr]`` in the C code, one block per kind in this order."""

    params: list
    states: list
    unknowns: list
    aliases: list
    discretes: list
    index: dict = field(default_factory=dict)  # name -> value reference

    def __post_init__(self):
        for k, n in enumerate(self.params + self.states + self.unknowns + self.aliases + self.discretes):
            self.index[n] = k

    @property
    def offsets(self) -> dict:
        np_, nx, nv, na = len(self.params), len(self.states), len(self.unknowns), len(self.aliases)
        return {"X": np_, "V": np_ + nx, "A": np_ + nx + nv, "D": np_ + nx + nv + na,
                "R": np_ + nx + nv + na + len(self.discretes)}


@dataclass
class Tabulated:
    """A numeric input compiled into the FMU: ``kind`` ``"table"`` (pieces, degree, outside) or ``"symbolic"``;
    ``parameters``: for an input rebuilt from parameters (a :class:`~acausal.model.signals.ParametricSignal`), those
    parameters' names and the values it was built with at export."""

    name: str
    owner: str
    signal: str  # class and name of the signal exported
    kind: str
    pieces: int = 0
    degree: int = 0
    outside: str = ""
    parameters: dict = field(default_factory=dict)


def layout_of(cm) -> Layout:
    program = cm.program
    return Layout(list(program.params), list(program.states), list(program.unknowns), sorted(program.aliases),
                  list(program.discretes))


_OUTSIDE = {"periodic": 0, "hold": 1, "extend": 2}


class _Printer(C99CodePrinter):
    """C99 with every model symbol printed as its C location and numeric signals as table lookups."""

    def __init__(self, names: dict, tables: dict):
        super().__init__({"precision": 17})
        self._names = names
        self._tables = tables  # input name -> C function name (table inputs)

    def _print_Symbol(self, expr):
        try:
            return self._names[expr.name]
        except KeyError:
            raise ExportError(f"C code: no value for the symbol {expr.name!r}") from None

    _print_Dummy = _print_Symbol

    def _print_SignalCall(self, expr):
        token, order, arg = expr.args[0].name, int(expr.args[1]), expr.args[2]
        fn = self._tables.get(token)
        if fn is None:
            raise ExportError(f"C code: the input {token!r} has no table form")
        return f"{fn}({self._print(arg)}, {order})"

    def _print_Piecewise(self, expr):
        out = "NAN"
        for value, cond in reversed(expr.args):
            out = self._print(value) if cond is sp.true else \
                f"(({self._print(cond)}) ? ({self._print(value)}) : ({out}))"
        return out

    def _print_BooleanTrue(self, expr):
        return "1"

    def _print_BooleanFalse(self, expr):
        return "0"

    def _print_Heaviside(self, expr):
        a = self._print(expr.args[0])
        return f"(({a}) > 0 ? 1.0 : (({a}) < 0 ? 0.0 : 0.5))"

    def _print_Mod(self, expr):
        a, b = (self._print(x) for x in expr.args)
        return f"(({a}) - ({b}) * floor(({a}) / ({b})))"

    def _print_not_supported(self, expr):
        raise ExportError(f"C code: {type(expr).__name__} has no C form (in {expr})")


class _Emitter:
    """Statements of one C function: ``assign`` (a C location = a sympy expression) and ``code`` (verbatim),
    rendered with shared subexpressions (cse) emitted just before their first use."""

    def __init__(self, printer: _Printer, names: dict, prefix: str):
        self.items: list = []
        self.printer, self.names, self.prefix = printer, names, prefix

    def assign(self, target: str, expr):
        self.items.append(("assign", target, sp.sympify(expr)))

    def code(self, text: str):
        self.items.append(("code", text, None))

    def render(self, indent: str = "    ") -> str:
        lines = []
        for kind, target, payload in lower(self.items, self.prefix):
            if kind == "temp":
                self.names[target.name] = target.name
                lines.append(f"{indent}const double {target.name} = {self.printer.doprint(payload)};")
            elif kind == "assign":
                lines.append(f"{indent}{target} = {self.printer.doprint(payload)};")
            else:
                lines.append(f"{indent}{target}")
        return "\n".join(lines)


def _c_string(text: str) -> str:
    """A C string literal of ``text`` (UTF-8 bytes beyond ASCII as octal escapes; ``?`` escaped so that no
    trigraph forms under -std=c99)."""
    out = str(text).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "")
    out = out.replace("?", "\\?")
    return '"' + "".join(ch if 32 <= ord(ch) < 127 else f"\\{ord(ch) & 0xff:03o}"
                         for ch in out.encode("utf-8").decode("latin-1")) + '"'


def _c_comment(text: str) -> str:
    """``text`` as a C comment (a ``*/`` inside it cannot end the comment early)."""
    return "/* " + str(text).replace("*/", "* /").replace("\n", " ") + " */"


def _c_double(v: float) -> str:
    v = float(v)
    if np.isnan(v):
        return "NAN"
    if np.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    return repr(v)


def _array(ctype: str, name: str, values, fmt=str) -> str:
    values = list(values)
    body = ", ".join(fmt(v) for v in values) if values else "0"
    return f"static const {ctype} {name}[{max(1, len(values))}] = {{{body}}};"


# ---------------------------------------------------------------------------------------------- inputs
def input_forms(cm, params: dict | None, inputs: dict | None) -> tuple:
    """The run's numeric inputs as ``(signals, tabulated)``: the bound signal per input name (a
    :class:`~acausal.model.signals.ParametricSignal` built with the export's parameter values) and the
    :class:`Tabulated` description of each. An input with neither a table nor a symbolic form, or a table of
    too few derivatives, is an :class:`ExportError` naming it."""
    p = cm.param_vector(params)
    values = dict(zip(cm.param_names, p))
    signals = dict(zip(cm.input_names, cm.input_tuple(inputs, p)))
    described = {}
    for name, sig in signals.items():
        info = cm.flat.inputs[name]
        own = info.signal
        label = f"{type(sig).__name__} {sig.name!r}"
        built = {}
        if isinstance(own, ParametricSignal) and (inputs or {}).get(name) is None:
            built = {v: float(values[v]) for v in dict.fromkeys(own.parameters.values())}
        need = cm.signal_orders.get(name, 0)
        table = sig.table()
        if table is not None:
            coef = np.asarray(table.coef, dtype=float)
            degree = coef.shape[0] - 1
            if table.outside not in _OUTSIDE:
                raise ExportError(f"input {name!r} of {info.owner}: its table's outside rule {table.outside!r} is "
                                  f"not one of {sorted(_OUTSIDE)}")
            described[name] = Tabulated(name, info.owner, label, "table", coef.shape[1], degree, table.outside,
                                        built)
        elif sig.symbolic(sp.Symbol("_arg", real=True)) is not None:
            described[name] = Tabulated(name, info.owner, label, "symbolic", parameters=built)
        else:
            raise ExportError(
                f"input {name!r} of {info.owner} is a {label} with neither a table nor a symbolic form "
                "(Signal.table() or Signal.symbolic()), so it cannot be compiled into the FMU: give the signal a "
                "table() (polynomial pieces), or export with inputs={name!r: PeriodicSpline(...) or "
                "SampledSignal(...)} sampled from it")
        top = sig.max_order
        if top is not None and need > top:
            raise ExportError(f"input {name!r} of {info.owner}: the model needs its derivative of order {need}, "
                              f"the signal {label} provides up to {top}")
    return signals, described


def _inline_symbolic(expr, signals: dict, described: dict):
    """``expr`` with every call of a symbolic input replaced by its (differentiated) expression."""
    if not expr.has(SignalCall):
        return expr
    rep = {}
    a = sp.Symbol("_arg", real=True)
    for call in expr.atoms(SignalCall):
        token, order, arg = call.args[0].name, int(call.args[1]), call.args[2]
        if described[token].kind == "symbolic":
            form = signals[token].symbolic(a)
            rep[call] = sp.diff(form, a, order).xreplace({a: arg})
    return expr.xreplace(rep) if rep else expr


# ---------------------------------------------------------------------------------------------- the model's C
def generate(cm, identifier: str, guid: str, params: dict | None = None, inputs: dict | None = None) -> tuple:
    """``(head, tail, layout, tabulated inputs, start values)`` of compiled model ``cm``: ``head`` the model's
    constants and tables (before the runtime), ``tail`` its functions (after it); :func:`source` joins them with
    the FMI declarations and the runtime (``templates/``)."""
    lay = layout_of(cm)
    if MAX_EVENTS_NAME in lay.index:
        raise ExportError(f"the model's variable {MAX_EVENTS_NAME!r} has the name of the FMU's event limit (the "
                          f"Integer parameter {MAX_EVENTS_NAME!r}, simulate()'s max_events): rename it to export "
                          "the model")
    off = lay.offsets
    bindings = cm.bindings
    signals, described = input_forms(cm, params, inputs)
    names = {n: f"r[{k}]" for n, k in lay.index.items()}
    names[time.name] = "t"
    tables = {n: f"input_{k}" for k, n in enumerate(cm.input_names) if described[n].kind == "table"}
    printer = _Printer(names, tables)
    out = [_c_comment(f"model {cm.flat.name}: generated by acausal from its solved equations"),
           f"#define MODEL_IDENTIFIER {_c_string(identifier)}", f"#define MODEL_GUID {_c_string(guid)}",
           f"#define NP {len(lay.params)}", f"#define NX {len(lay.states)}", f"#define NV {len(lay.unknowns)}",
           f"#define NA {len(lay.aliases)}", f"#define ND {len(lay.discretes)}", f"#define NZ {len(cm.program.events)}",
           *(f"#define OFF_{k} {v}" for k, v in off.items()), "#define NR OFF_R"]

    # start values: parameters (bound ones evaluated), raw state starts, modes; computed values start at 0
    p = cm.param_vector(params)
    start = np.zeros(off["R"])
    start[:len(lay.params)] = p
    for i, n in enumerate(lay.states):
        info = cm.flat.variables.get(n)
        start[off["X"] + i] = info.start if info is not None else 0.0
    start[off["D"]:] = cm.discrete_start()
    fixed = [bool(cm.flat.variables[n].fixed) if n in cm.flat.variables else False for n in lay.states]
    targets = {n: float(v.start) for n, v in cm.flat.variables.items() if v.fixed and n not in lay.states}
    for n, v in getattr(cm.flat, "fixed_constants", {}).items():
        targets.setdefault(n, float(v))
    for n in targets:
        if n not in lay.index:
            raise ExportError(f"the fixed start of {n!r} cannot be checked in the FMU: {n!r} is none of its "
                              "variables")
    missing = [s for s in lay.states if der_name(s) not in lay.index]
    if missing:
        raise ExportError(f"the state derivatives of {missing} are not computed by the model's steps")
    tabulated = {pn: v for t in described.values() for pn, v in t.parameters.items()}
    program = cm.program
    order = program.evaluation_order()
    blocks = [st for st in program.steps if isinstance(st, NewtonSolve)]
    newton_guess = [float(g) for st in blocks for g in st.guesses]
    newton_names = [v for st in blocks for v in st.vars]
    origins = sorted({ev.origin for ev in program.events})  # the events' components, sorted as modes.py's messages
    out += [f"#define NT {len(targets)}", f"#define NPT {len(tabulated)}", f"#define NO {len(origins)}",
            # the event iteration's rules, from their one home (acausal.simulation.events)
            f"#define KNEE {_c_double(KNEE)}", f"#define ROUNDOFF {_c_double(ROUNDOFF)}",
            f"#define MAX_CASCADE {CASCADE_ITER}", f"#define MAX_SETTLE {SETTLE_ITER}",
            # simulate()'s default event limit (the FMU's Integer parameter max_events starts there)
            f"#define MAX_EVENTS_DEFAULT {int(MAX_EVENTS)}",
            # the Newton blocks (their start values, their tear variables' names) and runtime.newton's rules
            f"#define NNB {len(blocks)}", f"#define NNY {len(newton_guess)}", f"#define NEWTON_MAX {NEWTON_MAX}",
            f"#define NEWTON_TOL {_c_double(NEWTON_TOL)}", f"#define NEWTON_MAXITER {NEWTON_MAXITER}",
            f"#define NEWTON_HALVINGS {runtime.LINE_SEARCH_HALVINGS}",
            f"#define NEWTON_ACCEPT {_c_double(NEWTON_ACCEPT)}",
            _array("double", "newton_guess", newton_guess, _c_double),
            _array("char *const", "newton_names", newton_names, _c_string),
            _array("double", "start_values", start, _c_double),
            _array("char *const", "var_names", [*lay.params, *lay.states, *lay.unknowns, *lay.aliases,
                                                 *lay.discretes], _c_string),
            _array("int", "der_vr", [lay.index[der_name(s)] for s in lay.states]),
            _array("double", "state_nominal", [float(getattr(cm.flat.variables.get(s), "nominal", 1.0) or 1.0)
                                               for s in lay.states], _c_double),
            _array("int", "state_fixed", [int(f) for f in fixed]),
            _array("int", "target_vr", [lay.index[n] for n in sorted(targets)]),
            _array("double", "target_value", [targets[n] for n in sorted(targets)], _c_double),
            _array("int", "tabulated_vr", [lay.index[n] for n in tabulated]),
            _array("double", "tabulated_value", list(tabulated.values()), _c_double),
            _array("int", "order_vr", [lay.index[n] for n in order if n in lay.index]),
            _array("char *const", "origin_names", origins, _c_string),
            _array("int", "event_origin", [origins.index(ev.origin) for ev in program.events]),
            _array("char *const", "event_zero", [str(ev.zero) for ev in program.events], _c_string),
            _array("char *const", "bound_message", [cm.bound_message(n) if n in bindings else None
                                                     for n in lay.params],
                   lambda m: "NULL" if m is None else _c_string(m))]

    # input tables (their lookup functions follow the runtime, which defines table_value)
    lookups = []
    for k, n in enumerate(cm.input_names):
        t = described[n]
        if t.kind != "table":
            continue
        table = signals[n].table()
        breaks = np.asarray(table.breaks, dtype=float)
        coef = np.asarray(table.coef, dtype=float).T  # (pieces, degree + 1), highest power first
        out.append(_c_comment(f"input {n} of {t.owner}: {t.signal}, {t.pieces} pieces of degree {t.degree}, "
                              f"{t.outside}"))
        out.append(_array("double", f"input_{k}_breaks", breaks, _c_double))
        out.append(_array("double", f"input_{k}_coef", coef.ravel(), _c_double))
        lookups.append(f"static double input_{k}(double arg, int order) {{\n"
                       f"    return table_value(input_{k}_breaks, input_{k}_coef, {t.pieces}, {t.degree}, "
                       f"{_OUTSIDE[t.outside]}, arg, order);\n}}")
    tail = "\n\n".join(lookups + [_functions(cm, lay, printer, names, signals, described)])
    return "\n".join(out), tail, lay, described, start


def source(head: str, tail: str) -> str:
    """The FMU's one C file: the FMI 2.0 declarations, the model's data, the runtime (its events part after the
    rest, which declares the functions it defines) and the model's functions."""
    from importlib import resources
    folder = resources.files("acausal.export") / "templates"
    return "\n".join([(folder / "fmi2_declarations.h").read_text(), head, (folder / "fmi2_runtime.c").read_text(),
                      (folder / "fmi2_events.c").read_text(), tail])


def _functions(cm, lay, printer, names, signals, described) -> str:
    """The generated C functions (after the runtime, which declares the instance type)."""
    def inline(expr):
        return _inline_symbolic(sp.sympify(expr), signals, described)

    parts = []

    # bound parameters
    em = _Emitter(printer, names, "_b")
    program = cm.program
    for name, _, binding, _ in program.parameters:
        if binding is not None:
            em.assign(f"r[{lay.index[name]}]", binding)
    parts.append("static void model_bound_parameters(Inst *m) {\n    double *r = m->r;\n    (void)r;\n"
                 + em.render() + "\n}")

    # parameter bounds
    cases = []
    for name in lay.params:
        info = cm.flat.parameters[name]
        k = lay.index[name]
        unit = f" [{info.unit}]" if info.unit else ""
        checks = [f"        if (!isfinite(v)) {{ log_msg(m, fmi2Error, \"logStatusError\", "
                  f"{_c_string(f'parameter {name!r} of {info.owner} is not finite: %g')}, v); return 1; }}"]
        if info.min is not None:
            checks.append(f"        if (v < {_c_double(info.min - BOUND_RTOL * abs(info.min))}) {{ log_msg(m, fmi2Error, \"logStatusError\", "
                          f"{_c_string(f'parameter {name!r} of {info.owner} = %.17g is below its minimum {info.min:g}{unit}')}"
                          ", v); return 1; }")
        if info.max is not None:
            checks.append(f"        if (v > {_c_double(info.max + BOUND_RTOL * abs(info.max))}) {{ log_msg(m, fmi2Error, \"logStatusError\", "
                          f"{_c_string(f'parameter {name!r} of {info.owner} = %.17g is above its maximum {info.max:g}{unit}')}"
                          ", v); return 1; }")
        cases.append(f"    case {k}:\n" + "\n".join(checks) + "\n        return 0;")
    parts.append("static int model_check_parameter(Inst *m, int vr) {\n    double v = m->r[vr];\n"
                 "    switch (vr) {\n" + "\n".join(cases) + "\n    default: return 0;\n    }\n}")

    # conditions on parameters (Component.assertions), after the bound parameters are evaluated
    em = _Emitter(printer, names, "_a")
    said = []
    for i, (cond, message, origin) in enumerate(program.assertions):
        em.assign(f"ok[{i}]", sp.Piecewise((1.0, cond), (0.0, True)))
        said.append(f"    if (ok[{i}] == 0.0) {{ log_msg(m, fmi2Error, \"logStatusError\", "
                    f"{_c_string(f'{origin}: {message} ({cond} fails)'.replace('%', '%%'))}); bad = 1; }}")
    parts.append("static int model_check_assertions(Inst *m) {\n    double *r = m->r;\n    int bad = 0;\n"
                 f"    double ok[{max(1, len(said))}];\n    (void)r; (void)ok;\n" + em.render() + "\n"
                 + "\n".join(said) + "\n    return bad;\n}")

    # Newton blocks: residuals and Jacobian of the tear variables
    newton_fns = {}
    for k, st in enumerate(program.steps):
        if not isinstance(st, NewtonSolve):
            continue
        if st.split:
            raise ExportError(f"the block of {', '.join(map(repr, st.vars))} (equations from "
                              f"{', '.join(sorted(set(st.origins)))}) may leave them undetermined (friction elements "
                              "stuck together); the FMU's C runtime has no weighted least-norm solve for it")
        local = dict(names)
        for i, v in enumerate(st.vars):
            local[v] = f"y[{i}]"
        bp = _Printer(local, printer._tables)
        em = _Emitter(bp, local, f"_n{k}c")
        m = len(st.vars)
        if m > NEWTON_MAX:
            raise ExportError(f"the block of {', '.join(map(repr, st.vars))} (equations from "
                              f"{', '.join(sorted(set(st.origins)))}) has {m} tear variables; the FMU's C runtime "
                              f"solves Newton blocks of {NEWTON_MAX} at most")
        for i, r in enumerate(st.residuals):
            em.assign(f"res[{i}]", inline(r))
        for i, row in enumerate(st.jac):
            for j, e in enumerate(row):
                em.assign(f"jac[{i * m + j}]", inline(e))
        newton_fns[k] = (f"newton_{k}", program.describe(st))
        parts.append(f"static void newton_{k}(Inst *m, const double *y, double *res, double *jac) {{\n"
                     "    double *r = m->r;\n    const double t = m->time;\n    (void)r; (void)t;\n"
                     + em.render() + "\n}")

    # every unknown, alias and zero function (the tear variables of the block-th Newton block at m->newton_y[at...])
    em = _Emitter(printer, names, "_c")
    block = at = 0
    for k, st in enumerate(program.steps):
        if isinstance(st, Assign):
            em.assign(f"r[{lay.index[st.var]}]", inline(st.expr))
        elif isinstance(st, LinearSolve):
            m = len(st.vars)
            em.code(f"double L{k}A[{m * m}], L{k}b[{m}];")
            for i in range(m):
                for j in range(m):
                    em.assign(f"L{k}A[{i * m + j}]", inline(st.A[i][j]))
                em.assign(f"L{k}b[{i}]", inline(st.b[i]))
            label = _c_string(f"singular linear system in {program.describe(st)}")
            em.code(f"if (solve_linear({m}, L{k}A, L{k}b)) {{ snprintf(m->message, sizeof m->message, \"%s\", "
                    f"{label}); return 1; }}")
            for i, v in enumerate(st.vars):
                em.code(f"r[{lay.index[v]}] = L{k}b[{i}];")
        else:
            fn, label = newton_fns[k]
            m = len(st.vars)
            em.code(f"if (solve_newton(m, {m}, {block}, {at}, {fn}, {_c_string(label)}, newton_names + {at})) "
                    "return 1;")
            for i, v in enumerate(st.vars):
                em.code(f"r[{lay.index[v]}] = m->newton_y[{at + i}];")
            block, at = block + 1, at + m
    for n in lay.aliases:
        em.assign(f"r[{lay.index[n]}]", inline(program.aliases[n]))
    for i, ev in enumerate(program.events):
        em.assign(f"m->z[{i}]", inline(ev.zero))
    parts.append("static int model_evaluate(Inst *m) {\n    double *r = m->r;\n    const double t = m->time;\n"
                 "    (void)r; (void)t;\n" + em.render() + "\n    return 0;\n}")

    # event assignments
    cases = []
    for i, ev in enumerate(program.events):
        for rising in (True, False):
            pairs = ev.rising if rising else ev.falling
            if not pairs:
                continue
            body = [f"            const double a{j} = {printer.doprint(inline(e))};" for j, (_, e) in enumerate(pairs)]
            body += [f"            r[{lay.index[n]}] = a{j};" for j, (n, _) in enumerate(pairs)]
            cases.append(f"    if (i == {i} && {'rising' if rising else '!rising'}) {{\n" + "\n".join(body)
                         + "\n    }")
    parts.append("static void model_event(Inst *m, int i, int rising) {\n    double *r = m->r;\n"
                 "    const double t = m->time;\n    (void)r; (void)t; (void)i; (void)rising;\n"
                 + "\n".join(cases) + "\n}")
    # reinits (Event.reinit: states restarted when the zero function rises), evaluated before any is made
    cases = []
    for i, ev in enumerate(program.events):
        pairs = ev.reinit
        if not pairs:
            continue
        body = [f"        const double a{j} = {printer.doprint(inline(e))};" for j, (_, e) in enumerate(pairs)]
        body += [f"        x[{list(lay.states).index(n)}] = a{j};" for j, (n, _) in enumerate(pairs)]
        cases.append(f"    if (i == {i}) {{\n" + "\n".join(body) + "\n        return 1;\n    }")
    parts.append("static int model_reinit(Inst *m, int i, double *x) {\n    double *r = m->r;\n"
                 "    const double t = m->time;\n    (void)r; (void)t; (void)i; (void)x;\n" + "\n".join(cases)
                 + "\n    return 0;\n}")
    return "\n\n".join(parts) + "\n"
