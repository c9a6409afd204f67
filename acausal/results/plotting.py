"""Variables of a :class:`~acausal.results.result.Result` over time with matplotlib (:meth:`Result.plot
<acausal.results.result.Result.plot>`): one y axis per unit, labels checked against the names plotted."""
from __future__ import annotations

from ..errors import ModelError


def plot_result(res, names, ax, label, kwargs):
    """:meth:`Result.plot <acausal.results.result.Result.plot>` of ``res``: the axes drawn on."""
    import warnings

    import matplotlib
    if not names:
        raise ModelError("plot: name at least one variable, e.g. res.plot('L.i')")
    labels = plot_labels(res, names, label)
    values = [res[n] for n in names]  # an unknown name fails here, before any figure is made
    if ax is None:
        matplotlib.use(matplotlib.get_backend())
        import matplotlib.pyplot as plt
        _, ax = plt.subplots()
    units = list(dict.fromkeys(res._unit(n) for n in names))
    if len(units) > 2:
        warnings.warn(f"plot: {len(units)} units ({', '.join(u or 'no unit' for u in units)}); the curves in "
                      f"{', '.join(u or 'no unit' for u in units[1:])} share the right-hand axis", stacklevel=3)
    axes = {units[0]: ax}
    if len(units) > 1:
        ax.twin = getattr(ax, "twin", None) or ax.twinx()
        for unit in units[1:]:
            axes[unit] = ax.twin
    colors = iter(matplotlib.rcParams["axes.prop_cycle"].by_key().get("color", [None]) * len(names))
    for n, v, text in zip(names, values, labels):
        unit = res._unit(n)
        style = dict(kwargs)
        if "color" not in style and "c" not in style:
            style["color"] = next(colors)  # one color cycle over both axes
        axes[unit].plot(res.t, v, label=text, **style)
    ax.set_ylabel(f"[{units[0]}]" if units[0] else "")
    if len(units) > 1:
        ax.twin.set_ylabel(", ".join(f"[{u}]" if u else "(no unit)" for u in units[1:]))
    ax.set_xlabel("time [s]")
    handles = [h for a in dict.fromkeys(axes.values()) for h in a.get_lines()]
    ax.legend(handles, [h.get_label() for h in handles])
    ax.grid(True, alpha=0.3)
    return ax


def plot_labels(res, names, label) -> list:
    """The legend labels of :meth:`Result.plot <acausal.results.result.Result.plot>`: ``label`` (None: each name with
    its unit; a str for one name; a dict name -> label; a list, one per name), checked against ``names``."""
    if label is None:
        return [f"{n} [{res._unit(n)}]" if res._unit(n) else n for n in names]
    if isinstance(label, str):
        if len(names) != 1:
            raise ModelError(f"plot: label={label!r} is one string for {len(names)} variables; give a list "
                             "(one per name) or a dict (name -> label)")
        return [label]
    if isinstance(label, dict):
        unknown = [k for k in label if k not in names]
        if unknown:
            raise ModelError(f"plot: label names {unknown} that are not plotted (plotted: {list(names)})")
        default = plot_labels(res, names, None)
        return [label.get(n, d) for n, d in zip(names, default)]
    labels = list(label)
    if len(labels) != len(names):
        raise ModelError(f"plot: {len(labels)} labels for {len(names)} variables {list(names)}")
    return [str(x) for x in labels]
