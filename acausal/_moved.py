"""Module paths of the release before the stage folders, importable for one more release.

Each old path is the new module itself (so a patch of one is a patch of the other); importing it warns
(``DeprecationWarning``) with the new path. A module that was split answers each name from where it went.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import types
import warnings

#: old module path -> new module path
MOVED = {
    "acausal.accelerators": "acausal.cli.accelerators",
    "acausal.alias": "acausal.compile.alias",
    "acausal.batch": "acausal.simulation.batch",
    "acausal.ccompiler": "acausal.backends.ccompiler",
    "acausal.cli_values": "acausal.cli.values",
    "acausal.codegen": "acausal.backends.numpy.printer",
    "acausal.compile_checks": "acausal.compile.checks",
    "acausal.compiled": "acausal.simulation.compiled",
    "acausal.compiled.calls": "acausal.simulation.compiled.calls",
    "acausal.compiled.events": "acausal.simulation.compiled.events",
    "acausal.compiled.fixed_step": "acausal.simulation.compiled.fixed_step",
    "acausal.compiled.native": "acausal.simulation.compiled.native",
    "acausal.compiled.native_loop": "acausal.simulation.compiled.native_loop",
    "acausal.compiled.path": "acausal.simulation.compiled.path",
    "acausal.compiled.translate": "acausal.backends.casadi",
    "acausal.compiler": "acausal.compiled_model",
    "acausal.components": "acausal.model.components",
    "acausal.connectors": "acausal.model.connectors",
    "acausal.declarations": "acausal.model.declarations",
    "acausal.describe": "acausal.model.describe",
    "acausal.energy": "acausal.results.energy",
    "acausal.failures": "acausal.simulation.scipy.failures",
    "acausal.fileio": "acausal.results.files",
    "acausal.finite": "acausal.results.finite",
    "acausal.flatten": "acausal.compile.flatten",
    "acausal.gauss": "acausal.results.gauss",
    "acausal.html": "acausal.results.html",
    "acausal.interpolants": "acausal.results.interpolants",
    "acausal.introspect": "acausal.compile.introspect",
    "acausal.modes": "acausal.simulation.events",
    "acausal.ondemand": "acausal.backends.numpy.ondemand",
    "acausal.parameter_values": "acausal.compile.parameters",
    "acausal.partials": "acausal.model.partials",
    "acausal.plotting": "acausal.results.plotting",
    "acausal.program": "acausal.compile.program",
    "acausal.quadratures": "acausal.simulation.scipy.quadratures",
    "acausal.references": "acausal.cli.references",
    "acausal.result": "acausal.results.result",
    "acausal.run_balance": "acausal.results.run_balance",
    "acausal.runtime": "acausal.backends.numpy.runtime",
    "acausal.sankey": "acausal.results.sankey",
    "acausal.sensitivity": "acausal.simulation.sensitivity",
    "acausal.signals": "acausal.model.signals",
    "acausal.simulate": "acausal.simulation.simulate",
    "acausal.simulation.compiled_driver": "acausal.simulation.compiled.driver",
    "acausal.simulation.scipy_driver": "acausal.simulation.scipy.driver",
    "acausal.solve": "acausal.compile.solve",
    "acausal.structure": "acausal.compile.structure",
    "acausal.structure.balance": "acausal.compile.structure.balance",
    "acausal.structure.blt": "acausal.compile.structure.blt",
    "acausal.structure.pantelides": "acausal.compile.structure.pantelides",
    "acausal.structure.system": "acausal.compile.structure.system",
    "acausal.sweep": "acausal.simulation.sweep",
    "acausal.symbols": "acausal.model.symbols",
    "acausal.time_events": "acausal.compile.time_events",
    "acausal.trust": "acausal.results.trust",
}
#: split modules: the names that went elsewhere than MOVED says
SPLIT = {
    "acausal.energy": {n: "acausal.compile.accounts" for n in ("Accounts", "accounts", "integrand_expr",
                                                                "balance_integrals", "account_integrals")},
    "acausal.quadratures": {"StatesOnly": "acausal.results.interpolants"},
}


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name in MOVED else None

    def create_module(self, spec):
        new = MOVED[spec.name]
        warnings.warn(f"{spec.name} is now {new}; the old path works until the next release", DeprecationWarning,
                      stacklevel=4)
        if spec.name not in SPLIT:
            return importlib.import_module(new)
        module = types.ModuleType(spec.name, f"Moved: {new} and the modules its names went to.")
        elsewhere = SPLIT[spec.name]

        def __getattr__(name):
            return getattr(importlib.import_module(elsewhere.get(name, new)), name)
        module.__getattr__ = __getattr__
        return module

    def exec_module(self, module):
        pass


def install() -> None:
    """Put the old paths' finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.insert(0, _OldPaths())
