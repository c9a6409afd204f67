"""The lowered program (acausal.compile.program): one record per compile that every backend prints, and its one rule for
common subexpressions."""
from dataclasses import replace

import numpy as np
import sympy as sp

from acausal import compile_model
from acausal.backends.numpy.printer import CodeGenerator
from acausal.compile.program import lower
from acausal.model.signals import SampledSignal

from ..circuit_models import RC, Bridge6


def test_a_temporary_is_placed_just_before_its_first_use_after_what_defines_its_inputs():
    x, y, z = sp.symbols("x y z", real=True)
    shared = sp.sin(z) * sp.cos(z)
    items = [("assign", "a", x + 1), ("code", "z = solve(a)", None),
             ("assign", "b", shared + sp.exp(shared)), ("assign", "c", 2 * shared + y)]
    out = lower(items, "_t")
    kinds = [k for k, _, _ in out]
    # a first, then the code that defines z, and only then the temporaries that read z, before b
    assert kinds[:2] == ["assign", "code"] and out[0][1] == "a" and kinds[-2:] == ["assign", "assign"]
    temps = [(s, e) for k, s, e in out if k == "temp"]
    assert temps and all(out.index(("temp", s, e)) > 1 for s, e in temps)
    # every temporary is defined before anything reads it
    seen = set()
    for kind, target, expr in out:
        if kind == "code":
            continue
        assert expr.free_symbols & {s for s, _ in temps} <= seen, (target, expr)
        if kind == "temp":
            seen.add(target)
    # and the statements compute what they were given
    values = {x: 0.3, y: -1.2, z: 0.7}
    got = {}
    for kind, target, expr in out:
        if kind != "code":
            v = float(expr.xreplace(got).xreplace(values))
            got[target if kind == "temp" else sp.Symbol(target)] = v
    assert abs(got[sp.Symbol("b")] - float((shared + sp.exp(shared)).subs(values))) < 1e-15
    assert abs(got[sp.Symbol("c")] - float((2 * shared + y).subs(values))) < 1e-15


def test_the_numpy_printer_prints_the_program_it_is_given_and_nothing_else():
    cm = compile_model(Bridge6())
    program = cm.program
    assert len(program.events) == len(cm.event_zeros) > 0
    flipped = replace(program, events=tuple(replace(ev, zero=-ev.zero) for ev in program.events))
    t = np.linspace(0.0, 0.02, 7)
    x = np.vstack([np.full_like(t, 3.0) for _ in cm.state_names])
    p, d, u = cm.param_vector(), cm.discrete_start(), cm.input_tuple()
    z = np.asarray(cm.funcs["zeros"](t, x, p, d, u), dtype=float)
    z_flipped = np.asarray(CodeGenerator(flipped).entry("zeros")(t, x, p, d, u), dtype=float)
    assert np.abs(z).max() > 0 and np.array_equal(z_flipped, -z)


def test_the_program_slices_its_steps_and_lists_its_signal_reads():
    t = np.linspace(0.0, 1.0, 21)
    cm = compile_model(RC(v_ref=SampledSignal(t, np.sin(3 * t), name="log")))
    program = cm.program
    assert list(program.inputs) == cm.input_names and program.signal_orders == cm.signal_orders
    calls = program.signal_calls
    assert calls and {c[0] for c in calls} == set(cm.input_names) and all(c[1] == 0 for c in calls)
    # the state derivative needs fewer steps than every unknown, and its slice computes it
    from acausal.compile.solve import step_vars
    from acausal.model.symbols import der_name, var_symbol

    target = var_symbol(der_name(cm.state_names[0]))
    part = program.slice([target])
    assert 0 < len(part) < len(program.steps)
    assert target in {var_symbol(v) for k in part for v in step_vars(program.steps[k])}
    assert program.evaluation_order() == [v for st in cm.steps for v in step_vars(st)]
