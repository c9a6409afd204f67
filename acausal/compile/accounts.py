"""Energy accounts found by convention: what each component of a model does with energy, read off its variables'
names when the model is compiled (``CompiledModel.accounts``), and the integrals the balance needs of a run.

A component says what it does with energy by the names of its variables (the library follows this everywhere):

* ``loss_power`` [W]: power it dissipates (>= 0);
* ``energy`` or ``*_energy`` [J]: energy it stores;
* ``source_power`` [W]: power an ideal source inside it delivers to the model;
* a class whose name ends in ``PowerSensor`` with a variable ``P`` [W]: a lossless power meter (a measurement
  point, not an account).

Only the outermost declaration counts: a rectifier's ``loss_power`` already holds its diode's, so the diode is not
counted again. Every other component with physical ports (pins, flanges, heat ports) that is not inside an
accounted component is a *boundary*: the power it delivers into the model through its ports (a prescribed motion,
an ideal voltage source, a ground, an ideal gear's round-off) enters the balance as it is, so that

    sum(source_power) + sum(boundary power delivered) = sum(loss_power) + d/dt sum(stored energy)

holds for any model built from such components (Tellegen's theorem per connection set).

Measurement points and stages follow the build order: the power sensors in the order the model created them, and
each loss in the stage that ends at the first sensor created after it (losses created before the first sensor
join the first stage; those after the last sensor are in no stage, listed under ""). A model that builds its
chain from source to load therefore needs no hand-kept lists.

The balance of a simulated run over these accounts: :mod:`acausal.results.energy`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model.components import Component, Connector

LOSS = "loss_power"
SOURCE = "source_power"
SENSOR_SUFFIX = "PowerSensor"
PHYSICAL_DOMAINS = ("electrical", "rotational", "thermal")


def _is_stored(var: str) -> bool:
    return var == "energy" or var.endswith("_energy")


@dataclass(frozen=True)
class Accounts:
    """The energy accounts of a model (variable and port names, in build order)."""

    losses: tuple  # loss-power variables
    stored: tuple  # stored-energy variables
    sources: tuple  # source-power variables (power delivered by ideal sources)
    boundary: tuple  # (component, (ports...)): power delivered into the model through these ports
    sensors: tuple  # power-sensor readings ("P_source.P", ...), build order
    stages: dict = field(default_factory=dict)  # sensor reading -> loss variables between it and the previous one;
    # "" -> losses after the last sensor (or of a model without sensors)
    heat: dict = field(default_factory=dict)  # loss variable -> heat ports of its component: the part of the loss
    # that leaves through them stays in the model (the thermal network stores it or passes it to its boundary)


def accounts(model: Component) -> Accounts:
    """The accounts of a built model instance (a compiled model keeps them as ``CompiledModel.accounts``)."""
    model._ensure_built()
    losses, stored, sources, boundary, sensors, heat = [], [], [], [], [], {}
    segments: list = [[]]  # losses between consecutive sensors: segments[i] comes before sensors[i]

    def visit(parent):
        for c in parent._children.values():  # build order; an accounted component's parts are not looked at
            if isinstance(c, Connector):
                continue
            names = [k for k, d in c.declarations().items() if not isinstance(d, Component)]
            if type(c).__name__.endswith(SENSOR_SUFFIX) and "P" in names:
                sensors.append(f"{c.path}.P")
                segments.append([])
                continue
            own = [f"{c.path}.{n}" for n in names if n == LOSS]
            keep = [f"{c.path}.{n}" for n in names if _is_stored(n)]
            src = [f"{c.path}.{n}" for n in names if n == SOURCE]
            if own or keep or src:
                ports = [ch.path for ch in c._children.values() if isinstance(ch, Connector) and ch.domain == "thermal"]
                heat.update({n: tuple(ports) for n in own if ports})
                losses.extend(own)
                segments[-1].extend(own)
                stored.extend(keep)
                sources.extend(src)
            elif any(not isinstance(ch, Connector) for ch in c._children.values()):
                visit(c)  # a composite without accounts of its own: its parts are looked at
            else:
                ports = tuple(ch.path for ch in c._children.values()
                              if isinstance(ch, Connector) and ch.domain in PHYSICAL_DOMAINS)
                if ports:
                    boundary.append((c.path, ports))
    visit(model)
    stages = {s: segments[i] for i, s in enumerate(sensors)}
    if len(sensors) > 1:  # losses before the first sensor join the first stage
        stages[sensors[1]] = segments[0] + stages[sensors[1]]
        stages[sensors[0]] = []
    if segments[-1]:
        stages[""] = segments[-1]  # after the last sensor (or no sensor at all): no stage
    return Accounts(tuple(losses), tuple(stored), tuple(sources), tuple(boundary), tuple(sensors), stages, heat)


def integrand_expr(cm, what: str):
    """The sympy expression (in the compiled model's variables, parameters and time) that
    :meth:`Result.energy <acausal.results.result.Result.energy>` integrates for ``what``: a port's power into its
    component (``v*i``, ``tau*der(phi)``, ``Q_flow``) or a variable; None when a derivative it needs is not
    computed by the model (the result then differentiates numerically)."""
    from ..model.symbols import var_symbol

    known = set(cm.state_names) | set(cm.unknown_names)

    def value(name):
        if name in known:
            return var_symbol(name)
        return sp.sympify(cm.flat.aliases[name]) if name in cm.flat.aliases else None

    def rate(name):
        return cm.rate_expr(name) if value(name) is not None else None

    names = known | set(cm.flat.aliases)
    if f"{what}.v" in names and f"{what}.i" in names:
        return value(f"{what}.v") * value(f"{what}.i")
    if f"{what}.phi" in names and f"{what}.tau" in names:
        w = rate(f"{what}.phi")
        return None if w is None else value(f"{what}.tau") * w
    if f"{what}.Q_flow" in names:
        return value(f"{what}.Q_flow")
    return value(what)


def balance_integrals(acc: Accounts) -> list:
    """Every name whose energy the balance integrates (sources, boundary ports, losses, heat ports), once each."""
    names = list(acc.sources) + [p for _, ports in acc.boundary for p in ports] + list(acc.losses) + \
        [p for ports in acc.heat.values() for p in ports]
    return list(dict.fromkeys(names))


def account_integrals(acc: Accounts) -> list:
    """Every name whose energy the balance and the Sankey diagram integrate (:func:`balance_integrals` and the
    power sensors), once each."""
    return list(dict.fromkeys(balance_integrals(acc) + list(acc.sensors)))
