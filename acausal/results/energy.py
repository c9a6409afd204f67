"""The energy balance of a simulated model over its accounts (:mod:`acausal.compile.accounts`): sources,
boundary work, losses and stored energy between two output samples, the energy chain at its power sensors, and
its Sankey diagram."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..compile.accounts import Accounts


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
    """The energy balance of a :class:`~acausal.results.result.Result` between output samples ``k0`` and ``k1``;
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
