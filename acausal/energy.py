"""Energy accounts found by convention, and the energy balance of any simulated model.

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
join the first stage; those after the last sensor are in no stage, listed under ""). A model that builds its chain from source to load therefore needs no hand-kept lists.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from .components import Component, Connector

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


@dataclass
class Balance:
    """An energy balance over ``[t0, t1]`` [J]: what the sources and the boundary delivered, what was lost and
    stored; ``residual`` = (delivered - lost - stored change) / delivered."""

    t0: float
    t1: float
    sources: dict
    boundary: dict
    losses: dict
    stored: dict
    efficiency: float | None = None  # energy out at ``to`` / energy in at ``from`` when asked for
    efficiency_path: tuple | None = None  # (from, to) of that efficiency (Result.energy_balance(between=...))
    heat: dict = field(default_factory=dict)  # (loss variable, heat ports) -> J of that loss passed on as heat into
    # the model's thermal network (not in ``losses``: counted where the network stores it or passes it on)

    @property
    def delivered(self) -> float:
        return sum(self.sources.values()) + sum(v for v in self.boundary.values() if v > 0)

    @property
    def residual(self) -> float:
        total = sum(self.sources.values()) + sum(self.boundary.values()) - sum(self.losses.values()) \
            - sum(self.stored.values())
        return total / self.delivered if self.delivered else float(total)

    def table(self) -> str:
        rows = [("source", k, v) for k, v in self.sources.items()]
        rows += [("boundary (delivered)", k, v) for k, v in self.boundary.items() if abs(v) > self._roundoff]
        rows += [("loss", k, v) for k, v in self.losses.items()]
        rows += [("stored (change)", k, v) for k, v in self.stored.items()]
        width = max([len(k) for _, k, _ in rows] + [8])
        lines = [f"energy balance over {self.t0:g} .. {self.t1:g} s [J]"]
        lines += [f"  {kind:<21} {k:<{width}} {v:12.6g}" for kind, k, v in rows]
        lines.append(f"  relative residual {self.residual:.2e}")
        for (loss, ports), v in self.heat.items():
            lines.append(f"  ({loss}: {v:.6g} J more, passed on as heat through {', '.join(ports)})")
        if self.efficiency is not None:
            a, b = self.efficiency_path
            lines.append(f"  efficiency {a} -> {b}: {self.efficiency:.4g}")
        return "\n".join(lines)

    @property
    def _roundoff(self) -> float:
        """Boundary work below this [J] is round-off (an ideal gear or converter: exactly zero in theory)."""
        return 1e-12 * (abs(self.delivered) + sum(abs(v) for v in self.losses.values()))

    def flows(self) -> tuple:
        """``(inflows, outflows)``, both name -> J > 0: what entered (sources, boundary work delivered, stored
        energy released, a negative loss) and what left (losses, energy stored, boundary work absorbed, energy
        a source took back). Their totals differ by the residual."""
        ins, outs = {}, {}

        def put(name, v, sign):
            (ins if v * sign > 0 else outs)[name] = abs(v)

        for n, v in self.sources.items():
            put(n.rsplit(".", 1)[0], v, 1)
        for c, v in self.boundary.items():
            if abs(v) > self._roundoff:
                put(f"{c} (boundary)", v, 1)
        for n, v in self.losses.items():
            if v:
                put(n.rsplit(".", 1)[0] + " loss", v, -1)
        for n, v in self.stored.items():
            if v:
                put(n.rsplit(".", 1)[0] + (" (stored)" if v > 0 else " (released)"), v, -1)
        return ins, outs

    def __str__(self):
        return self.table()


def balance(res, acc: Accounts, k0: int = 0, k1: int = -1, energy=None, change=None) -> Balance:
    """The energy balance of a :class:`~acausal.result.Result` between output samples ``k0`` and ``k1``;
    ``energy``: what gives a cumulative energy by name (default ``res.energy``; the trust check passes the run's
    cumulative energies at the solver's steps, with ``k0 = 0, k1 = -1``); ``change``: what gives a stored energy's
    change between the two samples by name (default: from its values at the outputs)."""
    energy = energy or res.energy
    change = change or (lambda n: float(np.asarray(res[n])[k1] - np.asarray(res[n])[k0]))

    def between(name):
        e = energy(name)
        return float(e[k1] - e[k0])

    boundary = {}
    for comp, ports in acc.boundary:
        delivered = -sum(between(p) for p in ports)
        boundary[comp] = delivered
    passed = {n: -sum(between(p) for p in ports) for n, ports in acc.heat.items()}  # heat out of the component
    return Balance(float(res.t[k0]), float(res.t[k1]), {n: between(n) for n in acc.sources}, boundary,
                   {n: between(n) - passed.get(n, 0.0) for n in acc.losses},
                   {n: change(n) for n in acc.stored},
                   heat={(n, ports): passed[n] for n, ports in acc.heat.items()})


def chain(res, acc: Accounts, k0: int = 0, k1: int = -1) -> list:
    """The energy chain between output samples ``k0`` and ``k1``: one ``(sensor, its component, energy passed on
    [J], components whose losses lie between the sensor before and this one)`` per power sensor, in build order."""
    out = []
    for s in acc.sensors:
        e = res.energy(s)
        out.append((s, s.rsplit(".", 1)[0], float(e[k1] - e[k0]),
                    [n.rsplit(".", 1)[0] for n in acc.stages.get(s, [])]))
    return out


def draw_sankey(res, acc: Accounts, ax=None, k0: int = 0, k1: int = -1, title: str | None = None):
    """The energy passed on at each power sensor (build order) between output samples ``k0`` and ``k1``, each
    stage's loss labelled by the components that dissipate it; returns the axes. A model with fewer than two
    power sensors gets the balance itself as one diagram: what entered (sources, boundary work, stored energy
    released) on the left, each loss, stored energy and absorbed boundary work leaving it."""
    from .sankey import balance_sankey, sankey

    if len(acc.sensors) < 2:
        b = balance(res, acc, k0, k1)
        ins, outs = b.flows()
        if ax is None:
            import matplotlib.pyplot as plt
            _, ax = plt.subplots(figsize=(7, 5))
        balance_sankey(ax, ins, outs, title or f"{res.model.flat.name}: energy balance over {b.t0:g} .. "
                       f"{b.t1:g} s [J]")
        return ax
    if ax is None:
        import matplotlib.pyplot as plt
        _, ax = plt.subplots(figsize=(2.2 * len(acc.sensors) + 2, 5))
    points = chain(res, acc, k0, k1)
    energy = {comp: J for _, comp, J, _ in points}
    names = [(comp, "loss" + (f"\n({', '.join(owners)})" if owners else "")) for _, comp, _, owners in points[1:]]
    top = max(abs(v) for v in energy.values()) or 1.0
    sankey(ax, energy, title=title or f"{res.model.flat.name}: energy at each power sensor [J]", scale=1.0 / top,
           loss_names=names)
    return ax


def integrand_expr(cm, what: str):
    """The sympy expression (in the compiled model's variables, parameters and time) that
    :meth:`Result.energy <acausal.result.Result.energy>` integrates for ``what``: a port's power into its
    component (``v*i``, ``tau*der(phi)``, ``Q_flow``) or a variable; None when a derivative it needs is not
    computed by the model (the result then differentiates numerically)."""
    from .symbols import var_symbol

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
