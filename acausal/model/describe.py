"""What a component class says about itself: the parameter, port, input and variable tables of
:meth:`Component.describe <acausal.model.components.Component.describe>` and of a component class's docstring."""
from __future__ import annotations


class Listing(str):
    """Text that shows as itself (not as a quoted string) in a notebook or at the prompt: what
    :meth:`Component.describe` and :meth:`CompiledModel.equations <acausal.compiled_model.CompiledModel.equations>`
    return. It is a ``str``: ``print`` it, search it, write it to a file."""

    def __repr__(self):
        return str(self)


class ClassOrInstanceMethod:
    """A method that works on the class (``DCMotor.describe()``) and on an instance (``motor.describe()``)."""

    def __init__(self, fn):
        self.fn = fn
        self.__doc__ = fn.__doc__

    def __get__(self, obj, owner=None):
        return lambda *a, **k: self.fn(owner, obj, *a, **k)


def _number(v) -> str:
    return "-" if v is None else f"{v:g}" if isinstance(v, (int, float)) else str(v)


def _bounds(d) -> str:
    if d.min is None and d.max is None:
        return ""
    return f"[{_number(d.min) if d.min is not None else '-inf'}, {_number(d.max) if d.max is not None else 'inf'}]"


def _table(rows, indent="    ") -> list:
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]) - 1)]
    return [indent + "  ".join(c.ljust(w) for c, w in zip(r[:-1], widths)) + ("  " + r[-1] if r[-1] else "")
            for r in rows]


def describe_component(cls, obj=None) -> Listing:
    """The parameter table (value or default, unit, bounds, doc, the device a datasheet default belongs to),
    the ports and the variables of a component class, or of an instance with the values it was given."""
    decl = cls.declarations()
    where = f"{cls.__module__}.{cls.__qualname__}"
    head = f"{cls.__name__} ({where})" if obj is None or not obj._path else f"{cls.__name__} {obj._path!r} ({where})"
    lines = [head]
    doc = " ".join(x.strip() for x in (cls.__doc__ or "").strip().split("\n\n")[0].split("\n")).rstrip(":")
    if doc and not doc.startswith("Parameters"):
        lines.append("  " + doc + ("." if not doc.endswith(".") else ""))
    pars = _listed(decl, "parameter")
    if pars:
        lines.append("  parameters (name = value, unit, bounds, doc):")
        rows = []
        for k, d in pars:
            given = obj is not None and k in obj._values
            value = obj._values[k] if given else d.default
            text = ("" if given or not d.device else f"[default of {d.device}] ") + d.doc
            rows.append((k, "=", _number(value) if value is not None else _unset(d), d.unit, _bounds(d), text))
        lines += _table(rows)
    ports = _listed(decl, "port")
    if obj is not None:
        ports += [(k, v) for k, v in _listed(obj._children, "port") if k not in decl]
    if ports:
        lines.append("  ports:")
        lines += _table([(k, type(d).__name__, f"({d.domain})", d.doc) for k, d in ports])
    inputs = _listed(decl, "input")
    if inputs:
        lines.append("  inputs (prescribed signals):")
        lines += _table([(k, d.unit, d.doc) for k, d in inputs])
    var = _listed(decl, "variable")
    if var:
        lines.append("  variables (name, unit, start, doc):")
        lines += _table([(k, getattr(d, "unit", "mode"),
                          f"start {_number(d.start)}" + (" fixed" if getattr(d, "fixed", False) else ""), d.doc)
                         for k, d in var])
    return Listing("\n".join(lines))


def _listed(declarations: dict, section: str) -> list:
    """``(name, declaration)`` of the declarations a section lists (their class's ``listed_as``:
    :mod:`acausal.model.components`)."""
    return [(k, d) for k, d in declarations.items() if getattr(d, "listed_as", None) == section]


def _unset(d) -> str:
    """What a parameter without a default shows: the rule that sets it when not given, else "(required)"."""
    return f"({d.derived})" if getattr(d, "derived", "") else "(required)"


def doc_table(cls) -> str:
    """The parameter table appended to a component class's docstring (what ``help()`` shows)."""
    rows = [(k, "=", _number(d.default) if d.default is not None else _unset(d), d.unit, _bounds(d),
             (f"[default of {d.device}] " if d.device else "") + d.doc)
            for k, d in _listed(cls.declarations(), "parameter")]
    lines = ["Parameters (name = default, unit, bounds, doc):"] + _table(rows)
    ports = _listed(cls.declarations(), "port")
    if ports:
        lines += ["Ports:"] + _table([(k, type(d).__name__, f"({d.domain})", d.doc) for k, d in ports])
    return "\n".join(lines)
