"""Looking into a compiled model: its equations as written or solved, exact time derivatives of its variables,
name filters and the compiler's report (what :class:`~acausal.compiled_model.CompiledModel` methods return)."""
from __future__ import annotations

import fnmatch

import sympy as sp

from ..model.describe import Listing
from ..errors import ModelError
from .solve import LinearSolve, NewtonSolve
from ..model.symbols import der, split_der, var_symbol


def equations_listing(cm, component, solved):
    """:meth:`CompiledModel.equations <acausal.compiled_model.CompiledModel.equations>`."""
    if component and component not in cm.flat.components:
        raise cm.unknown_name_error(component, "component", [c for c in cm.flat.components if c])
    if solved:
        eqs = [e for e in cm.flat.equations if not component or e.origin in
               {w.origin for w in cm.flat.equations_of(component)}]
        rows = [(e.origin, f"0 = {sp.sstr(e.residual)}") for e in eqs]
        inside = (component + ".") if component else ""
        rows += [("aliases (eliminated)", f"{n} = {sp.sstr(v)}") for n, v in sorted(cm.flat.aliases.items())
                 if n.startswith(inside)]
    else:
        rows = [(e.origin, e.text) for e in cm.flat.equations_of(component)]
    lines = [f"model {cm.flat.name}" + (f", {component}" if component else "") + (
        ": equations after alias elimination" if solved else ": equations as written") + f" ({len(rows)})"]
    last = None
    for origin, text in rows:
        if origin != last:
            lines.append(f"  {origin}:")
            last = origin
        lines.append(f"    {text}")
    return Listing("\n".join(lines))


def rate_expr(cm, name):
    """:meth:`CompiledModel.rate_expr <acausal.compiled_model.CompiledModel.rate_expr>`."""
    cache = cm.derived.setdefault("rates", {})
    if name in cache:
        return cache[name]
    known = set(cm.unknown_names) | set(cm.state_names)
    if name in known:
        expr = var_symbol(name)
    elif name in cm.flat.aliases:
        expr = sp.sympify(cm.flat.aliases[name])
    else:
        cache[name] = None
        return None
    d = der(expr)
    out = None
    for _ in range(16):
        missing = {s for s in d.free_symbols if s.name.startswith("der(") and s.name not in known}
        if not missing:
            out = d
            break
        sub = {}
        for s in missing:
            base, order = split_der(s.name)
            src = cm.program.assignment(base) if order == 1 else None
            if src is None or src.has(sp.Min, sp.Max, sp.Abs, sp.Piecewise, sp.sign, sp.Heaviside):
                sub = None
                break
            sub[s] = der(src)
        if sub is None:
            break
        d = d.xreplace(sub)
    if out is not None and out.has(sp.Derivative, sp.Subs, sp.DiracDelta, sp.Heaviside):
        out = None
    cache[name] = out
    return out


def report(cm) -> str:
    """:meth:`CompiledModel.report <acausal.compiled_model.CompiledModel.report>`."""
    red = cm.reduction
    n_num = sum(isinstance(s, (LinearSolve, NewtonSolve)) for s in cm.steps)
    sizes = [len(b[0]) for b in cm.blocks]
    lines = [
        f"model {cm.flat.name}: compiled in {cm.compile_seconds * 1e3:.0f} ms",
        f"  variables after alias elimination: {len(cm.flat.variables)} "
        f"({len(cm.flat.aliases)} aliases removed)",
        f"  equations after index reduction: {len(red.residuals)} "
        f"({len(red.residuals) - len(cm.flat.equations)} differentiated)",
        f"  differential index: {red.index} (equations differentiated up to {red.differentiations} times)",
        f"  states ({len(cm.state_names)}): {', '.join(cm.state_names) or 'none'}",
        f"  dummy derivatives: {', '.join(sorted(red.dummies)) or 'none'}",
        f"  BLT blocks: {len(cm.blocks)} (largest {max(sizes, default=0)}), numeric blocks: {n_num}",
    ]
    for s in cm.steps:
        if isinstance(s, NewtonSolve):
            lines.append(f"    Newton on {s.vars} (from {sorted(set(s.origins))})")
        elif isinstance(s, LinearSolve):
            lines.append(f"    linear solve for {s.vars}")
    lines.append(f"  simulation path: {cm.simulation_path()}")
    for n, used in cm.parametric_inputs().items():
        lines.append(f"  input {n} is rebuilt from the parameters {', '.join(used)}")
    dev = cm.device_defaults()
    if dev:
        lines.append(f"  left at a device's datasheet default ({len(dev)}; set them for your device, at "
                     "construction or per run with params=...):")
        for device in dict.fromkeys(d for _, _, d in dev.values()):
            lines.append(f"    {device}: " + ", ".join(
                f"{n} = {v:g} {u}" for n, (v, u, d) in dev.items() if d == device))
    free = [e.origin.split("'")[1] for e in cm.flat.written
            if e.origin.startswith("unconnected port ")]
    if free:
        lines.append(f"  unconnected ports ({len(free)}; their flows are zero: an open pin, a free flange, an "
                     f"adiabatic heat port): {', '.join(sorted(dict.fromkeys(free)))}")
    if cm.signal_orders:
        lines.append("  input derivatives used: " + ", ".join(
            f"{k} up to order {v}" for k, v in sorted(cm.signal_orders.items())))
    return "\n".join(lines)


def filtered(names: list, pattern: str | None) -> list:
    """``names`` matching ``pattern`` (a shell-style wildcard, or a substring when it has no wildcard)."""
    if pattern is not None and not isinstance(pattern, str):
        raise ModelError(f"names: pattern must be a str (a wildcard such as 'motor.*' or a substring), got "
                         f"{pattern!r}")
    if not pattern:
        return names
    if any(ch in pattern for ch in "*?["):
        return [n for n in names if fnmatch.fnmatchcase(n, pattern)]
    return [n for n in names if pattern in n]
