"""Generate numeric Python functions from a compile's lowered program (:class:`~acausal.compile.program.Program`): the
numpy printer, one of three (the compiled path's CasADi translation and the FMU's C are the others).

Generated functions all have the signature ``f(t, x, p, d, u, g=None)``: time, state vector, parameter vector,
discrete modes, and the tuple of numeric input signals (each called as ``u[k](t, order)``); ``g``, optional, gives
Newton blocks their start values by variable name (an integrator's algebraic variables where it solved them: a
block then converges in an iteration or two instead of from its constant start values). Every value broadcasts,
so ``t`` may be an array of samples and ``p`` an array of parameter sets (``p[k]`` of shape ``(B, 1)``) at no
extra cost. Parameters are arguments: changing one never recompiles.

* ``all_values``: every unknown (algebraic variables and state derivatives), in :attr:`unknown_names` order;
* ``rhs``: the state derivatives only (a backward slice of the steps);
* ``jac``: the exact Jacobian of ``rhs`` with respect to the states, by forward differentiation through the
  steps (implicit-function rule through numeric blocks);
* ``zeros``: the event zero-crossing functions.

On demand (never at compile time), :meth:`CodeGenerator.sensitivity_function` generates a function of the same
signature returning chosen outputs with their exact partial derivatives with respect to the states and to chosen
parameters (forward differentiation seeded at the states and the parameters), for parameter sensitivities.

Common subexpressions are eliminated per function by the printers' one rule (:func:`acausal.compile.program.lower`): a
shared subexpression is emitted just before its first use, so it never runs ahead of the block that defines its
inputs.
"""
from __future__ import annotations

import functools
from collections.abc import Mapping
import re

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from . import runtime
from ...errors import ModelError
from ...model.signals import SignalCall
from .ondemand import OnDemand
from ...compile.solve import Assign, LinearSolve, NewtonSolve
from ...compile.program import lower
from ...model.symbols import der_name, par_symbol, time, var_symbol


class _Printer(NumPyPrinter):
    def __init__(self, names):
        # order "none": sums and products printed in sympy's own (canonical) argument order, not sorted again
        super().__init__({"fully_qualified_modules": True, "inline": True, "allow_unknown_functions": False,
                          "order": "none"})
        self._names = names

    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise ModelError(f"code generation: no value for symbol {expr.name!r}") from None

    def _print_DiracDelta(self, expr):
        # the derivative of a step (sign, Heaviside) in a Jacobian: zero everywhere but at the switch, which the
        # integrator's step control crosses (the same as a Min/Max kink's one-sided slope)
        return "0.0"

    def _print_Piecewise(self, expr):
        # a runtime helper instead of numpy.select: the same for arrays, a plain branch for the integrator's
        # scalar calls (numpy.select on scalars costs tens of microseconds per call)
        args = ", ".join(f"{self._print(e)}, {self._print(c)}" for e, c in expr.args)
        return f"_piecewise({args})"


class CodeGenerator(OnDemand):
    """Generates the numeric functions of a :class:`~acausal.compile.program.Program` (its states, unknowns, steps and
    event zeros, with the parameters, discrete modes and numeric inputs named in the order the generated
    functions take them); it reads nothing else."""

    def __init__(self, program):
        self.program = program
        self.event_zeros = program.zeros
        self._entries: dict = {}  # entry point name -> function, generated when first asked for (entry())
        self._entry_sources: dict = {}
        self.states, self.params, self.discretes = list(program.states), list(program.params), list(program.discretes)
        self.inputs, self.unknowns, self.steps = list(program.inputs), list(program.unknowns), list(program.steps)
        self.names: dict = {time: "t"}
        for i, n in enumerate(self.states):
            self.names[var_symbol(n)] = f"_x{i}"
        for i, n in enumerate(self.unknowns):
            self.names[var_symbol(n)] = f"_v{i}"
        for i, n in enumerate(self.params):
            self.names[par_symbol(n)] = f"_p{i}"
        for i, n in enumerate(self.discretes):
            self.names[par_symbol(n)] = f"_d{i}"
        self._input_index = {n: i for i, n in enumerate(self.inputs)}
        self._signal_idents: dict = {}  # (input index, order, argument) -> identifier
        self._blocks: list[str] = []  # source of Newton residual functions
        self._labels: dict = {}  # Newton block (step index) -> description for error messages
        self._newton_args: dict = {}  # Newton block -> the outside symbols it takes
        # the globals every generated function sees (the entry points and those generated on demand)
        self._namespace = {"numpy": np, "functools": functools, "_np_array": np.array, "_bstack": runtime.bstack,
                           "_linsolve": runtime.linsolve, "_newton": runtime.newton, "_piecewise": runtime.piecewise,
                           "_starts": runtime.starts, "_labels": self._labels}
        self._on_demand: dict = {}  # value and sensitivity functions generated when first asked for (ondemand)

    # ------------------------------------------------------------------ helpers
    def _signal_symbols(self, expr):
        """Replace every ``SignalCall(token, order, arg)`` by a symbol evaluated once per call as
        ``u[k](arg, order)``; ``arg`` is time or an expression of time and parameters (e.g. ``time/T_stride``)."""
        if not expr.has(SignalCall):
            return expr
        rep = {}
        for call in expr.atoms(SignalCall):
            token, order, arg = call.args[0].name, int(call.args[1]), call.args[2]
            k = self._input_index[token]
            key = (k, order, arg)
            ident = self._signal_idents.get(key)
            if ident is None:
                ident = f"_u{k}_{order}" + ("" if arg == time else f"_a{len(self._signal_idents)}")
                self._signal_idents[key] = ident
            sym = sp.Symbol(ident, real=True)
            self.names[sym] = ident
            rep[call] = sym
        return expr.xreplace(rep)

    def _slice(self, targets) -> list[int]:
        """Indices of the steps needed to compute the target symbols (in order): :meth:`Program.slice`."""
        return self.program.slice(targets)

    # ------------------------------------------------------------------ body
    def _body(self, step_ids, with_jac=False, seeds=None):
        """Statement list: ("assign", ident, expr) | ("code", text, used_symbols), and the derivative table.

        Forward differentiation through the steps: ``D[symbol] = {column: derivative}`` starts from the seeds and
        is propagated through every step (chain rule through assignments, implicit-function rule through linear
        and Newton blocks). ``with_jac`` seeds the states (``D[x_i] = {i: 1}``); ``seeds`` adds any other seeds
        (e.g. parameters, ``{par_symbol(name): {column: expr}}``). Without seeds no derivative is generated.
        """
        items = []
        D: dict = {}
        if with_jac:
            for i, n in enumerate(self.states):
                D[var_symbol(n)] = {i: sp.Integer(1)}
        for s, col in (seeds or {}).items():
            D[s] = dict(col)
        track = with_jac or seeds is not None
        for k in step_ids:
            st = self.steps[k]
            if isinstance(st, Assign):
                sym = var_symbol(st.var)
                expr = self._signal_symbols(st.expr)
                if isinstance(expr, sp.Symbol) and expr in self.names:
                    self.names[sym] = self.names[expr]  # a plain copy: share the value, emit nothing
                    if track and expr in D:
                        D[sym] = D[expr]
                    continue
                items.append(("assign", self.names[sym], expr))
                if track:
                    self._jac_assign(sym, expr, D, items)
            elif isinstance(st, LinearSolve):
                A = [[self._signal_symbols(e) for e in row] for row in st.A]
                b = [self._signal_symbols(e) for e in st.b]
                self._label(k, st)
                self._emit_linear(k, st.vars, A, b, items)
                if track:
                    ys = [var_symbol(v) for v in st.vars]
                    res = [sum(A[i][j] * ys[j] for j in range(len(ys))) - b[i] for i in range(len(ys))]
                    self._jac_block(k, ys, res, A, D, items)
            else:
                self._emit_newton(k, st, items)
                if track:
                    ys = [var_symbol(v) for v in st.vars]
                    res = [self._signal_symbols(r) for r in st.residuals]
                    J = [[self._signal_symbols(e) for e in row] for row in st.jac]
                    self._jac_block(k, ys, res, J, D, items, split=bool(st.split))
        return items, D

    def _emit_linear(self, k, vars_, A, b, items):
        m = len(vars_)
        a_names = [[f"_L{k}a{i}_{j}" for j in range(m)] for i in range(m)]
        b_names = [f"_L{k}b{i}" for i in range(m)]
        for i in range(m):
            for j in range(m):
                items.append(("assign", a_names[i][j], A[i][j]))
            items.append(("assign", b_names[i], b[i]))
        targets = ", ".join(self.names[var_symbol(v)] for v in vars_)
        rows = "[" + ", ".join("[" + ", ".join(r) + "]" for r in a_names) + "]"
        items.append(("code", f"{targets}, = _linsolve({rows}, [{', '.join(b_names)}], _labels[{k}], t)", set()))

    def _label(self, k, st):
        """Describe numeric block ``k`` (its variables, the components of its equations and its start values) for
        the error messages of :mod:`acausal.backends.numpy.runtime`; generated code passes ``_labels[k]`` with its
        time."""
        if k not in self._labels:
            free = [rule is not None for rule in st.split] if getattr(st, "split", None) else ()
            self._labels[k] = runtime.Block("nonlinear" if isinstance(st, NewtonSolve) else "linear", st.vars,
                                            sorted(set(st.origins)), getattr(st, "guesses", ()), free)

    def _emit_newton(self, k, st, items):
        """Call the residual/Jacobian function of Newton block ``k``; the function itself is generated once
        (every generated entry point that needs the block shares it). The call passes the entry point's time
        ``t``, which a failure message names, and starts from the block's start values or, where the caller gives
        them (the entry point's ``g``: values by variable name), from those."""
        if k not in self._newton_args:
            self._label(k, st)
            self._define_newton(k, st)
        ext = self._newton_args[k]
        args = ", ".join(self.names[s] for s in ext)
        targets = ", ".join(self.names[var_symbol(v)] for v in st.vars)
        guesses = ", ".join(repr(float(g)) for g in st.guesses)
        split = f", split=_newton_split{k}" if st.split else ""
        starts = f"(({guesses},) if g is None else _starts(g, {tuple(st.vars)!r}, ({guesses},)))"
        items.append(("code", f"{targets}, = _newton(_newton_block{k}, {starts}, ({args}{',' if args else ''}), "
                              f"_labels[{k}], t=t{split})", set(ext)))

    def _define_newton(self, k, st):
        ys = [var_symbol(v) for v in st.vars]
        res = [self._signal_symbols(r) for r in st.residuals]
        J = [[self._signal_symbols(e) for e in row] for row in st.jac]
        rules = [self._signal_symbols(e) for rule in (st.split or ()) if rule for e in rule]
        ext = sorted({s for e in res + [x for row in J for x in row] + rules for s in e.free_symbols} - set(ys),
                     key=lambda s: s.name)
        args = [self.names[s] for s in ext]
        local = dict(self.names)
        for i, y in enumerate(ys):
            local[y] = f"_y[{i}]"
        m = len(ys)
        items = [("assign", f"_r{i}", r) for i, r in enumerate(res)]
        items += [("assign", f"_j{i}_{j}", e) for i, row in enumerate(J) for j, e in enumerate(row)]
        statements = lower(items, f"_n{k}c")
        for kind, ident, _ in statements:
            if kind == "temp":
                local[ident] = ident.name
        pr = _Printer(local)
        lines = [f"def _newton_block{k}(_y, {', '.join(args)}):" if args else f"def _newton_block{k}(_y):"]
        lines += [f"    {ident.name if kind == 'temp' else ident} = {pr.doprint(e)}" for kind, ident, e in statements]
        rr = ", ".join(f"_r{i}" for i in range(m))
        jj = ", ".join("(" + ", ".join(f"_j{i}_{j}" for j in range(m)) + ",)" for i in range(m))
        lines.append(f"    return ({rr},), ({jj},)")
        self._blocks.append("\n".join(lines))
        self._newton_args[k] = ext
        if st.split:
            self._define_split(k, st, ys, args, local)

    def _define_split(self, k, st, ys, args, local):
        """``_newton_split{k}(_y, *args)``: the nominal values and scales of block ``k``'s tear variables
        (:attr:`~acausal.compile.solve.NewtonSolve.split`; a determined variable's nominal is its iterate, its scale
        1)."""
        pr = _Printer(local)
        nominal, scale = [], []
        for i, rule in enumerate(st.split):
            if rule is None:
                nominal.append(f"_y[{i}]")
                scale.append("1.0")
            else:
                nominal.append(pr.doprint(self._signal_symbols(rule[0])))
                scale.append(pr.doprint(self._signal_symbols(rule[1])))
        head = f"def _newton_split{k}(_y, {', '.join(args)}):" if args else f"def _newton_split{k}(_y):"
        self._blocks.append(f"{head}\n    return ({', '.join(nominal)},), ({', '.join(scale)},)")

    def _jac_assign(self, sym, expr, D, items):
        d = {}
        for s in expr.free_symbols:
            if s in D:
                fs = expr.diff(s)
                if fs == 0:
                    continue
                for c, ds in D[s].items():
                    d[c] = d.get(c, 0) + fs * ds
        out = {}
        for c in sorted(d):  # column order, not the hash order of the symbols
            e = d[c]
            if e != 0:
                name = f"{self.names[sym]}_J{c}"
                js = sp.Symbol(name, real=True)
                self.names[js] = name
                items.append(("assign", name, e))
                out[c] = js
        if out:
            D[sym] = out

    def _jac_block(self, k, ys, res, J, D, items, split=False):
        """Implicit-function rule: dy/dx_c = -J^-1 * sum_s dr/ds * ds/dx_c over symbols s outside the block.
        A ``split`` block (indeterminate tear variables) may be singular: there the derivative is that of its
        weighted least-norm solution with the scales held (``_linsolve(..., scale=...)``)."""
        m = len(ys)
        yset = set(ys)
        cols = sorted({c for r in res for s in r.free_symbols if s in D and s not in yset for c in D[s]})
        if not cols:
            return
        scale = ""
        if split:
            args = "".join(f", {self.names[s]}" for s in self._newton_args[k])
            items.append(("code", f"_B{k}s = _newton_split{k}(({', '.join(self.names[y] for y in ys)},){args})[1]",
                          set(self._newton_args[k]) | set(ys)))
            scale = f", scale=_B{k}s"
        jn = [[f"_B{k}j{i}_{j}" for j in range(m)] for i in range(m)]
        for i in range(m):
            for j in range(m):
                items.append(("assign", jn[i][j], J[i][j]))
        for y in ys:
            D[y] = {}
        for c in cols:
            w = []
            for i, r in enumerate(res):
                acc = 0
                for s in r.free_symbols:
                    if s in D and s not in yset and c in D[s]:
                        acc += r.diff(s) * D[s][c]
                wn = f"_B{k}w{i}_{c}"
                items.append(("assign", wn, -acc))
                w.append(wn)
            targets = []
            for y in ys:
                name = f"{self.names[y]}_J{c}"
                js = sp.Symbol(name, real=True)
                self.names[js] = name
                D[y][c] = js
                targets.append(name)
            rows = "[" + ", ".join("[" + ", ".join(r) + "]" for r in jn) + "]"
            items.append(("code", f"{', '.join(targets)}, = _linsolve({rows}, [{', '.join(w)}], _labels[{k}], t"
                                  f"{scale})", set()))

    # ------------------------------------------------------------------ emission
    def _render(self, fname, items, result_lines):
        statements = lower(items, f"_{fname}c")  # common subexpressions as temporaries (the printers' one rule)
        names = dict(self.names)
        for kind, ident, _ in statements:
            if kind == "temp":
                names[ident] = ident.name
            elif kind == "assign":
                names.setdefault(sp.Symbol(ident, real=True), ident)
        pr = _Printer(names)
        lines = []
        for kind, ident, payload in statements:
            if kind == "temp":
                lines.append(f"    {ident.name} = {pr.doprint(payload)}")
            elif kind == "assign":
                lines.append(f"    {ident} = {pr.doprint(payload)}")
            else:
                lines.append(f"    {ident}")
        # prologue: unpack what is used (states, parameters, modes, signals); signal arguments may use parameters
        text = "\n".join(lines) + "\n" + "\n".join(result_lines)
        pr = _Printer(self.names)
        sig = [f"    {ident} = u[{k}]({pr.doprint(arg)}, {o})"
               for (k, o, arg), ident in self._signal_idents.items() if re.search(rf"\b{ident}\b", text)]
        used_ids = set(re.findall(r"\b_[xpd]\d+\b", text + "\n".join(sig)))
        head = [f"def {fname}(t, x, p, d, u, g=None):"]
        head += [f"    _x{i} = x[{i}]" for i in range(len(self.states)) if f"_x{i}" in used_ids]
        head += [f"    _p{i} = p[{i}]" for i in range(len(self.params)) if f"_p{i}" in used_ids]
        head += [f"    _d{i} = d[{i}]" for i in range(len(self.discretes)) if f"_d{i}" in used_ids]
        head += sig
        return "\n".join(head + lines + list(result_lines))

    #: the entry points, in the order :attr:`source` lists them
    ENTRIES = ("all_values", "rhs", "rhs_vec", "jac", "zeros")

    def entry(self, name: str):
        """Entry point ``name`` (one of :data:`ENTRIES`), generated when first asked for: a run that never
        evaluates the model in numpy (the CasADi fixed step) does not pay for printing them (half of a small
        model's compile time), and one that only initialises prints ``all_values`` alone."""
        if name not in self._entries:
            if name not in self.ENTRIES:
                raise KeyError(name)
            for fname, src in getattr(self, f"_src_{'rhs' if name == 'rhs_vec' else name}")().items():
                self._entry_sources[fname] = src
                self._entries[fname] = self._define(fname, src)
        return self._entries[name]

    def functions(self) -> dict:
        """Every entry point by name (:data:`ENTRIES`), generated now where not yet."""
        return {k: self.entry(k) for k in self.ENTRIES}

    @property
    def source(self) -> str:
        """The generated Python source of the entry points (and the Newton blocks they call)."""
        self.functions()
        return "\n\n".join(self._blocks + [self._entry_sources[k] for k in self.ENTRIES]) + "\n"

    def _src_all_values(self) -> dict:
        items, _ = self._body(list(range(len(self.steps))))
        outs = ", ".join(self.names[var_symbol(v)] for v in self.unknowns)
        return {"all_values": self._render("all_values", items,
                                           [f"    return [{outs}{',' if len(self.unknowns) == 1 else ''}]"])}

    def _src_rhs(self) -> dict:
        """``rhs`` and ``rhs_vec``: the same body (one common-subexpression pass), returning an array or a stack."""
        dnames = [var_symbol(der_name(s)) for s in self.states]
        items, _ = self._body(self._slice(dnames))
        vals = ", ".join(self.names[d] for d in dnames)
        rhs = self._render("rhs", items, [f"    return _np_array([{vals}], dtype=float)"])
        return {"rhs": rhs, "rhs_vec": rhs.replace("def rhs(", "def rhs_vec(", 1).rsplit("\n", 1)[0]
                + f"\n    return _bstack([{vals}{',' if len(dnames) == 1 else ''}])"}

    def _src_jac(self) -> dict:
        dnames = [var_symbol(der_name(s)) for s in self.states]
        items, D = self._body(self._slice(dnames), with_jac=True)
        n = len(self.states)
        rows = []
        for d in dnames:
            row = D.get(d, {})
            rows.append("[" + ", ".join(self.names[row[j]] if j in row and row[j] in self.names else
                                         (pr_const(row[j]) if j in row else "0.0") for j in range(n)) + "]")
        return {"jac": self._render("jac", items, [f"    return _np_array([{', '.join(rows)}], dtype=float)"])}

    def _src_zeros(self) -> dict:
        zeros = [self._signal_symbols(z) for z in self.event_zeros]
        items, _ = self._body(self._slice([s for z in zeros for s in z.free_symbols]))
        for i, z in enumerate(zeros):
            items.append(("assign", f"_z{i}", z))
        zs = ", ".join(f"_z{i}" for i in range(len(zeros)))
        return {"zeros": self._render("zeros", items, [f"    return [{zs}{',' if len(zeros) == 1 else ''}]"])}


def pr_const(e):
    return repr(float(e))


class Functions(Mapping):
    """A compiled model's numeric entry points by name (:meth:`CodeGenerator.entry`), each generated when first
    asked for."""

    def __init__(self, gen):
        self._gen = gen

    def __getitem__(self, name):
        return self._gen.entry(name)

    def __iter__(self):
        return iter(self._gen.ENTRIES)

    def __len__(self):
        return len(self._gen.ENTRIES)
