"""``modelDescription.xml`` (FMI 2.0, Model Exchange) of an exported model, and the FMU's documentation page.

Variables, in value-reference order (``index`` = value reference + 1):

* parameters: ``causality="parameter"``, ``variability="fixed"`` (set before ``fmi2ExitInitializationMode``), start
  = the export's value, ``unit``, ``min``, ``max``; a parameter bound to others is a ``calculatedParameter``;
* states: outputs with their start value (``initial="exact"``, or ``"approx"`` when initialisation adjusts them
  to meet the fixed start of another variable) and ``nominal``;
* unknowns (state derivatives with their ``derivative`` attribute, algebraic variables) and aliases: outputs,
  ``initial="calculated"``;
* discrete modes: ``local``, ``discrete``;
* last, ``max_events``: an Integer ``parameter`` (value reference one past the last Real's), the event limit,
  starting at simulate()'s default ``max_events``.

``numberOfEventIndicators`` is the number of the model's event zero functions.
"""
from __future__ import annotations

import html
import re
from xml.sax.saxutils import quoteattr

from ..model.symbols import der_name, split_der
from .ccode import MAX_EVENTS, MAX_EVENTS_NAME

#: the description of the FMU's event limit (modelDescription.xml and the documentation page)
MAX_EVENTS_DOC = (f"the event limit: more events than this stop the FMU with an error (fmi2Error, naming the time), "
                  f"as simulate(max_events=...) stops (its default, {MAX_EVENTS})")

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")


def naming_convention(names) -> str:
    """``"structured"`` when every name is a dotted identifier or ``der()`` of one (FMI 2.0's structured names),
    else ``"flat"`` (e.g. ``der(der(x))``, which the structured grammar spells ``der(x,2)``)."""
    for n in names:
        base, order = split_der(n)
        if order > 1 or not _NAME.match(base):
            return "flat"
    return "structured"


def _unit_of(cm, name: str) -> str:
    base, order = split_der(name)
    info = cm.flat.variables.get(base) or cm.flat.alias_info.get(base)
    unit = getattr(info, "unit", "") or ""
    if order:
        unit = "/".join([unit if unit not in ("", "1") else "1"] + ["s"] * order)
    return "" if unit in ("", "1") else unit


def _doc_of(cm, name: str) -> str:
    base, order = split_der(name)
    info = cm.flat.variables.get(base) or cm.flat.alias_info.get(base)
    doc = getattr(info, "doc", "") or ""
    if order:
        return f"time derivative of {base}" + (f" ({doc})" if doc else "")
    return doc


def _real(attrs: dict) -> str:
    return "<Real" + "".join(f" {k}={quoteattr(str(v))}" for k, v in attrs.items() if v is not None) + "/>"


def _num(v) -> str:
    return repr(float(v))


def variables(cm, layout, start, tabulated, adjusted: set) -> list:
    """One dict per variable (value-reference order): name, causality, variability, initial, description and the
    Real element's attributes."""
    out = []
    off = layout.offsets
    bindings = cm.bindings
    notes = {}
    for t in tabulated.values():
        for pn, value in t.parameters.items():
            notes.setdefault(pn, []).append(
                f"the input {t.name} was tabulated at export with {pn} = {value:g}; changing it here does not "
                "rebuild (replan) that input")
    for k, name in enumerate(layout.params):
        info = cm.flat.parameters[name]
        desc = [info.doc] if info.doc else []
        bound = name in bindings
        if bound:
            desc.append(f"= {bindings[name]}")
        desc += notes.get(name, [])
        out.append(dict(name=name, causality="calculatedParameter" if bound else "parameter", variability="fixed",
                        initial="calculated" if bound else "exact", description="; ".join(desc),
                        real=dict(start=None if bound else _num(start[k]), unit=info.unit if info.unit not in
                                  ("", "1") else None, min=None if info.min is None else _num(info.min),
                                  max=None if info.max is None else _num(info.max))))
    state_index = {s: off["X"] + i + 1 for i, s in enumerate(layout.states)}
    for i, name in enumerate(layout.states):
        info = cm.flat.variables.get(name)
        nominal = getattr(info, "nominal", 1.0) or 1.0
        out.append(dict(name=name, causality="output", variability="continuous",
                        initial="approx" if name in adjusted else "exact", description=_doc_of(cm, name),
                        real=dict(start=_num(start[off["X"] + i]), unit=_unit_of(cm, name) or None,
                                  nominal=None if nominal == 1.0 else _num(nominal))))
    derivative_of = {der_name(s): s for s in layout.states}
    for name in layout.unknowns + layout.aliases:
        real = dict(unit=_unit_of(cm, name) or None)
        if name in derivative_of:
            real["derivative"] = state_index[derivative_of[name]]
        out.append(dict(name=name, causality="output", variability="continuous", initial="calculated",
                        description=_doc_of(cm, name), real=real))
    for name in layout.discretes:
        info = cm.flat.discretes[name]
        out.append(dict(name=name, causality="local", variability="discrete", initial="calculated",
                        description=info.doc or "discrete mode", real={}))
    return out


def model_description(cm, layout, start, tabulated, *, identifier: str, guid: str, description: str,
                      source_file: str | None, version: str, adjusted: set, stop_time: float | None = None) -> str:
    """The text of ``modelDescription.xml``."""
    vs = variables(cm, layout, start, tabulated, adjusted)
    units = sorted({v["real"].get("unit") for v in vs if v["real"].get("unit")})
    names = [v["name"] for v in vs]
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<fmiModelDescription fmiVersion="2.0" modelName=' + quoteattr(cm.flat.name) + " guid=" + quoteattr(guid)
             + " description=" + quoteattr(description) + ' generationTool=' + quoteattr(f"acausal {version}")
             + ' variableNamingConvention="' + naming_convention(names) + '" numberOfEventIndicators="'
             + str(len(cm.event_zeros)) + '">',
             '  <ModelExchange modelIdentifier=' + quoteattr(identifier) + ' needsExecutionTool="false" '
             'completedIntegratorStepNotNeeded="' + ('false' if cm.event_zeros else 'true') + '" canBeInstantiatedOnlyOncePerProcess="false" '
             'canNotUseMemoryManagementFunctions="false" canGetAndSetFMUstate="true" canSerializeFMUstate="false" '
             'providesDirectionalDerivative="false">']
    if source_file:
        lines += ["    <SourceFiles>", f"      <File name={quoteattr(source_file)}/>", "    </SourceFiles>"]
    lines.append("  </ModelExchange>")
    if units:
        lines += ["  <UnitDefinitions>", *(f"    <Unit name={quoteattr(u)}/>" for u in units), "  </UnitDefinitions>"]
    lines += ["  <LogCategories>",
              '    <Category name="logEvents" description="every event: time, indicator, direction"/>',
              '    <Category name="logNewton" description="a Newton block solved from its start values after its '
              'iteration from the last solution failed (time, block, why)"/>',
              '    <Category name="logStatusWarning" description="warnings"/>',
              '    <Category name="logStatusError" description="errors: what failed, with the variable or block"/>',
              "  </LogCategories>"]
    if stop_time is not None:
        lines.append(f'  <DefaultExperiment startTime="0.0" stopTime="{_num(stop_time)}"/>')
    lines.append("  <ModelVariables>")
    for k, v in enumerate(vs):
        attrs = f"name={quoteattr(v['name'])} valueReference=\"{k}\""
        if v["description"]:
            attrs += f" description={quoteattr(v['description'])}"
        attrs += f" causality=\"{v['causality']}\" variability=\"{v['variability']}\" initial=\"{v['initial']}\""
        lines.append(f"    <!-- index {k + 1} -->")
        lines.append(f"    <ScalarVariable {attrs}>")
        lines.append(f"      {_real(v['real'])}")
        lines.append("    </ScalarVariable>")
    lines += [f"    <!-- index {len(vs) + 1} -->",
              f"    <ScalarVariable name={quoteattr(MAX_EVENTS_NAME)} valueReference=\"{layout.offsets['R']}\" "
              f"description={quoteattr(MAX_EVENTS_DOC)} causality=\"parameter\" variability=\"fixed\" "
              "initial=\"exact\">",
              f"      <Integer start=\"{int(MAX_EVENTS)}\" min=\"0\"/>", "    </ScalarVariable>"]
    lines.append("  </ModelVariables>")
    outputs = [k + 1 for k, v in enumerate(vs) if v["causality"] == "output"]
    derivatives = [layout.index[der_name(s)] + 1 for s in layout.states]
    initial = sorted({k + 1 for k, v in enumerate(vs) if (v["causality"] == "output" and v["initial"] != "exact")
                      or v["causality"] == "calculatedParameter"} | set(derivatives))
    lines.append("  <ModelStructure>")
    for tag, idx in (("Outputs", outputs), ("Derivatives", derivatives), ("InitialUnknowns", initial)):
        if idx:
            lines += [f"    <{tag}>", *(f'      <Unknown index="{i}"/>' for i in idx), f"    </{tag}>"]
    lines += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def documentation(cm, layout, start, tabulated, *, description: str, doc: str, identifier: str,
                  adjusted: set) -> str:
    """``documentation/index.html``: what the model is, its parameters, inputs, initialisation and events."""
    esc = html.escape
    bindings = cm.bindings
    rows = []
    for k, name in enumerate(layout.params):
        info = cm.flat.parameters[name]
        value = f"= {bindings[name]}" if name in bindings else f"{start[k]:.6g}"
        bounds = ", ".join(b for b in (None if info.min is None else f"min {info.min:g}",
                                       None if info.max is None else f"max {info.max:g}") if b)
        rows.append(f"<tr><td><code>{esc(name)}</code></td><td>{esc(value)}</td><td>{esc(info.unit)}</td>"
                    f"<td>{esc(bounds)}</td><td>{esc(info.doc)}</td></tr>")
    inputs = []
    for t in tabulated.values():
        how = (f"{t.pieces} polynomial pieces of degree {t.degree} ({t.outside} outside them)" if t.kind == "table"
               else "its closed-form expression")
        text = f"<li><code>{esc(t.name)}</code> of {esc(t.owner)}: {esc(t.signal)}, compiled in as {esc(how)}"
        if t.parameters:
            text += (". Built at export with " + ", ".join(f"<code>{esc(p)}</code> = {v:g}"
                                                             for p, v in t.parameters.items())
                     + ": setting these parameters in the FMU does <b>not</b> rebuild (replan) it (a warning is "
                     "logged); export again with other values instead")
        inputs.append(text + "</li>")
    events = [f"<li>{esc(ev.origin)}: zero function <code>{esc(str(z))}</code></li>"
              for ev, z in zip(cm.flat.events, cm.event_zeros)]
    init = ("The states start at their start values." if not adjusted else
            "The states " + ", ".join(f"<code>{esc(s)}</code>" for s in sorted(adjusted)) + " are adjusted "
            "(minimum-norm Gauss-Newton from their start values) so that the variables with a fixed start hold; "
            "a state set through <code>fmi2SetReal</code> before initialisation stays fixed.")
    parts = [f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{esc(cm.flat.name)}</title></head><body>",
             f"<h1>{esc(cm.flat.name)}</h1>", f"<p>{esc(description)}</p>"]
    if doc and doc.strip() != description.strip():
        parts.append(f"<pre>{esc(doc)}</pre>")
    parts += [
        "<h2>This FMU</h2>",
        f"<p>FMI 2.0 Model Exchange, model identifier <code>{esc(identifier)}</code>, exported by acausal "
        "(<code>acausal.export_fmu</code>). The binary is compiled from C code printed from the model's solved "
        "equations; <code>sources/</code> holds that one C file (no other file is needed to build it).</p>",
        "<h2>Initialisation</h2>",
        "<p>In <code>fmi2ExitInitializationMode</code>: bound parameters are computed and every parameter is "
        f"checked against its bounds. {init} With events, the discrete modes are then settled by the signs of "
        "the event indicators and the states initialised again, as <code>simulate()</code> does.</p>",
        "<h2>Events</h2>",
        ("<ul>" + "".join(events) + "</ul><p>An indicator that crosses zero applies its rising or falling "
         "assignments in <code>fmi2NewDiscreteStates</code>; mode changes that flip other indicators cascade until "
         "nothing flips, in the same call, as in <code>simulate()</code> (acausal.simulation.events). A return to "
         "modes "
         "already visited keeps the present modes when the flips that close it are within 1e-6 of zero (a "
         "switching point); otherwise no mode is consistent, and the call fails (<code>fmi2Error</code>) with a "
         "message naming the components. A NaN or infinite indicator is an error naming its event.</p>")
        if events else "<p>None.</p>",
        f"<p>The Integer parameter <code>{esc(MAX_EVENTS_NAME)}</code> ({MAX_EVENTS} unless set, the default of "
        "<code>simulate(max_events=...)</code>): more events than that stop the FMU with <code>fmi2Error</code> and "
        "a message naming the limit, the time and the last event's component, as they stop <code>simulate()</code>; "
        "a model that chatters stops instead of stepping on from event to event.</p>" if events else "",
        "<h2>Inputs compiled in</h2>", ("<ul>" + "".join(inputs) + "</ul>") if inputs else "<p>None.</p>",
        "<h2>Parameters</h2>",
        "<table border=\"1\"><tr><th>name</th><th>value</th><th>unit</th><th>bounds</th><th>description</th></tr>"
        + "".join(rows) + "</table>",
        "<h2>Compiler report</h2>", f"<pre>{esc(cm.report())}</pre>", "</body></html>", ""]
    return "\n".join(parts)
