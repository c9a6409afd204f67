"""Self-contained HTML pages of results (``Result.to_html``; the paper's explorer in
``acausal.models.reporting.explorer``): one file with plotly.js inline and the data embedded as JSON, drawn in the
browser, so that it opens from the file system, offline, with no server.

Needs plotly (an optional dependency: ``python3 -m pip install "acausal[html]"``); only its plotly.js bundle is
used. Without it every page writer raises :class:`~acausal.errors.ModelError` naming the package and the install
command; the PNG paths (:meth:`Result.sankey <acausal.results.result.Result.sankey>`, ``Result.plot``) need only
matplotlib.

The page of a :class:`~acausal.results.result.Result` shows its energy accounts found by convention
(:mod:`acausal.results.energy`): the energy passed on at each power sensor as a Sankey diagram (or, with fewer than two
sensors, the energy balance as one: what entered, each loss and stored energy leaving), the powers of every account over
time [W], the energy balance table [J] and its relative residual over the window. Pages are deterministic: the same data
give the same bytes.
"""
from __future__ import annotations

import csv
import html as _html
import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import DataError, ModelError

#: how to install what the pages need
INSTALL = 'python3 -m pip install "acausal[html]"  (or: python3 -m pip install plotly)'


def require_plotly(who: str) -> None:
    """A ModelError naming ``who``, the missing package and the install command when plotly is not installed."""
    if not plotly_available():
        raise ModelError(f"{who}: writing an HTML page needs plotly, which is not installed; install it with "
                         f"{INSTALL}. The PNG figures (Result.sankey, Result.plot) need only matplotlib")


def plotly_available() -> bool:
    """Whether plotly can be imported (the pages can be written)."""
    try:
        import plotly.offline  # noqa: F401
    except ImportError:
        return False
    return True


def plotly_js(who: str) -> str:
    """The plotly.js bundle (about 4.8 MB of JavaScript) to inline in a page (:func:`require_plotly` first)."""
    require_plotly(who)
    from plotly.offline import get_plotlyjs
    return get_plotlyjs()


def plain(value):
    """``value`` as JSON-ready data: numpy arrays and numbers as lists and floats, NaN and infinities as None."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def read_csv(path) -> dict:
    """A CSV file as columns: ``{"file": name, "columns": [...], "data": {column: [values]}}``; a column whose every
    non-empty cell is a number (or that is empty or NaN throughout) holds floats, empty cells and NaN as None; any
    other column holds its text. A DataError names the file when it is missing, empty or has rows of another
    length than its header."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such CSV file")
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    if len(rows) < 2:
        raise DataError(f"{path}: no rows (a header and at least one row expected)")
    header, body = rows[0], rows[1:]
    for n, row in enumerate(body, start=2):
        if len(row) != len(header):
            raise DataError(f"{path}, line {n}: {len(row)} cells for {len(header)} columns")
    data = {}
    for j, name in enumerate(header):
        cells = [row[j] for row in body]
        data[name] = _numbers(cells)
        if data[name] is None:
            data[name] = cells
    return {"file": path.name, "columns": header, "data": data}


def _numbers(cells: list):
    """The cells as floats (None for empty cells and NaN), or None when one is not a number."""
    out = []
    for c in cells:
        if c.strip() == "":
            out.append(None)
            continue
        try:
            v = float(c)
        except ValueError:
            return None
        out.append(v if math.isfinite(v) else None)
    return out


CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:0 auto;max-width:1500px;padding:0 18px 40px;
color:#222;line-height:1.4}
h1{font-size:1.45em;margin:18px 0 4px}h2{font-size:1.15em;margin:26px 0 6px;border-bottom:1px solid #ddd}
.row{display:flex;flex-wrap:wrap;gap:14px}.col{flex:1 1 560px;min-width:0}
.plot{width:100%;height:380px}.tall{height:470px}
.controls{display:flex;flex-wrap:wrap;gap:18px;align-items:center;background:#f4f6f8;padding:8px 12px;
border-radius:6px;margin:8px 0}
.controls label{display:flex;gap:8px;align-items:center}.controls input[type=range]{width:220px}
.value{font-weight:600;min-width:90px;display:inline-block}
table{border-collapse:collapse;font-size:.88em;margin:6px 0}td,th{border:1px solid #ccc;padding:3px 7px;
vertical-align:top}th{background:#f0f0f0}td.n{text-align:right;font-variant-numeric:tabular-nums}
.good{background:#e3f4e1}.bad{background:#fbe1df}.mid{background:#fff4d6}
.note{color:#555;font-size:.88em}.small{font-size:.8em;color:#666}
"""

#: helpers every page's script shares: number formatting, tables, the Sankey of an energy chain, line plots
COMMON_JS = r"""
window.acausalScriptMs = performance.now();  // plotly.js is parsed: the page's own drawing starts
const DATA = JSON.parse(document.getElementById('acausal-data').textContent);
const CONFIG = {responsive: true, displaylogo: false, displayModeBar: 'hover',
  modeBarButtonsToRemove: ['select2d', 'lasso2d', 'zoomIn2d', 'zoomOut2d', 'autoScale2d']};
const TITLE = text => ({text, x: 0.01, xanchor: 'left', font: {size: 13}});
const $ = id => document.getElementById(id);
function fmt(v, d) { if (v === null || v === undefined || Number.isNaN(v)) return '-';
  if (typeof v !== 'number') return String(v); d = d === undefined ? 1 : d;
  return (Math.abs(v) < 0.5 * 10 ** -d ? 0 : v).toFixed(d); }  // no '-0.00' for round-off
const ESC = {'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'};
function esc(s) { return String(s).replace(/[&<>"]/g, c => ESC[c]); }
// a table: header (list of text), rows (lists of cells: text, or {v: text, cls: class, title: tooltip})
function table(header, rows) {
  const cell = (c, tag) => (c !== null && typeof c === 'object')
    ? `<${tag} class="${c.cls || ''}" title="${esc(c.title || '')}">${c.v}</${tag}>` : `<${tag}>${c}</${tag}>`;
  return '<table><tr>' + header.map(h => cell(h, 'th')).join('') + '</tr>' +
    rows.map(r => '<tr>' + r.map(c => cell(c, 'td')).join('') + '</tr>').join('') + '</table>';
}
// the energy chain as Sankey nodes and links: points [{label, J, key, short}] in chain order, losses [{label, J, key,
// short}] one per stage, between point i and i+1 (``short``: the label drawn, optional); a stage whose loss is not
// positive, or a point that passes no energy on, gets no link, and a note says so
function chainFlows(points, losses) {
  // laid out as a chain: points along the top, from left to right, each stage's loss dropping out below the next
  // point (node x, y: centres in 0..1 of the plot, y down; heights in proportion to J, the source's about 0.8)
  const top = Math.max(...points.map(p => Math.abs(p.J)), 1e-300), h = J => 0.8 * Math.max(J, 0) / top;
  const x = i => 0.01 + 0.86 * i / Math.max(points.length - 1, 1), small = 1e-6 * top;
  const nodes = points.map((p, i) => ({label: `${p.short || p.label}<br>${fmt(p.J, 1)} J`, hover: p.label,
                                        color: '#4a78b5', x: x(i), y: 0.02 + h(p.J) / 2}));
  const links = [], notes = [];
  points.slice(1).forEach((p, i) => {
    links.push({source: i, target: i + 1, value: p.J, key: p.key, label: `${points[i].label} → ${p.label}`});
    if (!(p.J > 0)) notes.push(`${p.label}: ${fmt(p.J, 3)} J passed on (not drawn: the diagram shows positive flows)`);
    const l = losses[i];
    if (l.J > small) {
      nodes.push({label: `${l.short || l.label}<br>${fmt(l.J, 1)} J`, hover: l.label, color: '#d0613c', x: x(i + 1),
                  y: Math.min(0.02 + h(p.J) + 0.06 + h(l.J) / 2, 0.98)});
      links.push({source: i, target: nodes.length - 1, value: l.J, key: l.key, label: l.label, loss: true});
    } else notes.push(l.J < -small ? `${l.label}: the energy grows by ${fmt(-l.J, 3)} J (stored energy released)`
                                   : `${l.label}: 0 J (nothing lost)`);
  });
  return {nodes, links, notes};
}
// draw flows ({nodes, links, notes}) as a Sankey diagram in div ``id`` (link values in J; links with a value that is
// not positive are left out); each link keeps its ``key`` (the CSV column or account it comes from) as customdata
function drawSankey(id, flows, title) {
  const keep = flows.links.filter(l => l.value > 0);
  const trace = {type: 'sankey', arrangement: 'fixed', valueformat: '.2f', valuesuffix: ' J',
    node: {label: flows.nodes.map(n => n.label), color: flows.nodes.map(n => n.color), pad: 16, thickness: 14,
           align: 'left', customdata: flows.nodes.map(n => n.hover || n.label),
           hovertemplate: '%{customdata}: %{value}<extra></extra>',
           ...(flows.nodes.every(n => n.x !== undefined) ? {x: flows.nodes.map(n => n.x), y: flows.nodes.map(n => n.y)}
                                                          : {})},
    link: {source: keep.map(l => l.source), target: keep.map(l => l.target), value: keep.map(l => l.value),
           customdata: keep.map(l => l.key), label: keep.map(l => l.label),
           color: keep.map(l => l.loss ? 'rgba(208,97,60,0.35)' : 'rgba(74,120,181,0.35)')}};
  const notes = flows.notes.length ? [{text: flows.notes.map(esc).join('<br>'), showarrow: false, xref: 'paper',
    yref: 'paper', x: 0, y: -0.04, xanchor: 'left', yanchor: 'top', font: {size: 10, color: '#a33'}}] : [];
  return Plotly.react(id, [trace], {title: TITLE(title), font: {size: 11}, annotations: notes,
    margin: {l: 10, r: 10, t: 44, b: flows.notes.length ? 40 : 10}}, CONFIG);
}
// lines over x: series [{name, y, unit}], hover with values and units
function drawLines(id, x, series, xtitle, ytitle, title, xunit, yaxis) {
  const traces = series.map(s => ({type: 'scatter', mode: 'lines', x: x, y: s.y, name: s.name,
    hovertemplate: `%{y:.4g} ${s.unit || ''} at %{x:.4g} ${xunit || ''}<extra>${esc(s.name)}</extra>`}));
  return Plotly.react(id, traces, {title: TITLE(title), hovermode: 'x unified',
    xaxis: {title: {text: xtitle}}, yaxis: {title: {text: ytitle}, zeroline: true, ...(yaxis || {})},
    legend: {font: {size: 10}}, margin: {l: 60, r: 10, t: 40, b: 45}}, CONFIG);
}
function ready() { window.acausalReadyMs = performance.now(); window.acausalReady = true; }
"""


def page(title: str, body: str, script: str, data: dict, who: str) -> str:
    """A whole HTML document: ``body`` (HTML), plotly.js inline, ``data`` embedded as JSON (``DATA`` in the
    scripts), :data:`COMMON_JS`, then ``script``; ``who`` names the caller in the error when plotly is missing."""
    js = plotly_js(who)
    blob = json.dumps(plain(data), separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_html.escape(title)}</title>\n<meta name=\"viewport\" content=\"width=device-width, "
            f"initial-scale=1\">\n<link rel=\"icon\" href=\"data:,\">\n<style>{CSS}</style>\n"
            f"<script>{js}</script>\n</head><body>\n{body}\n"
            f"<script type=\"application/json\" id=\"acausal-data\">{blob}</script>\n"
            f"<script>{COMMON_JS}\n{script}</script>\n</body></html>\n")


def write_page(path, text: str, who: str) -> Path:
    """Write a page to ``path`` (atomically; see :func:`check_path`)."""
    from .files import atomic_write_text
    return atomic_write_text(check_path(path, who), text)


def check_path(path, who: str) -> Path:
    """``path`` as a Path; a ModelError naming ``who`` when it is no path, a folder, or its folder does not exist."""
    if not isinstance(path, (str, os.PathLike)):
        raise ModelError(f"{who}: path must be a file path (str or Path), got {path!r}")
    path = Path(path)
    if path.is_dir():
        raise ModelError(f"{who}: {path} is a folder; give a file path (e.g. {path / 'index.html'})")
    if not path.parent.is_dir():
        raise ModelError(f"{who}: the folder {path.parent} of {path} does not exist")
    return path


# ---------------------------------------------------------------------------------------------- any Result

def result_data(res, t0=None, t1=None, names=(), max_points: int = 4000) -> dict:
    """What :func:`result_page` shows, from ``res`` between output times ``t0`` and ``t1`` [s]: the Sankey flows
    [J] (chain of power sensors, or the balance), the powers of every account [W] and the variables ``names`` over
    time [s] (thinned to at most ``max_points`` samples; the energies come from the whole run), the energy balance
    [J] with its relative residual, and the residual over time."""
    from .energy import balance
    if isinstance(names, str) or not all(isinstance(n, str) for n in names):
        raise ModelError(f"to_html: names must be a list of variable names (str), got {names!r}")
    if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 2:
        raise ModelError(f"to_html: max_points must be a whole number >= 2, got {max_points!r}")
    k0, k1 = res._window(t0, t1)
    acc = res.model.accounts
    b = balance(res, acc, k0, k1)
    step = max(1, -(-(k1 - k0 + 1) // max_points))
    keep = np.unique(np.append(np.arange(k0, k1 + 1, step), k1))

    def unit(n):
        return res._unit(n) or ("W" if n in acc.sensors or n in acc.losses or n in acc.sources else "")

    series = [dict(name=n, unit=unit(n), y=np.asarray(res[n], dtype=float)[keep])
              for n in dict.fromkeys([*acc.sensors, *acc.sources, *acc.losses, *names])]
    series += [dict(name=f"{c} (boundary, delivered)", unit="W",
                    y=-sum(np.asarray(res.power(p), dtype=float) for p in ports)[keep])
               for c, ports in acc.boundary if abs(b.boundary[c]) > b._roundoff]
    rows = [["source", k, v] for k, v in b.sources.items()]
    rows += [["boundary (delivered)", k, v] for k, v in b.boundary.items() if abs(v) > b._roundoff]
    rows += [["loss", k, v] for k, v in b.losses.items()] + [["stored (change)", k, v] for k, v in b.stored.items()]
    return dict(model=res.model.flat.name, t0=b.t0, t1=b.t1, time=res.t[keep], series=series,
                sankey=_chain(res, acc, k0, k1) if len(acc.sensors) >= 2 else _balance_flows(b),
                balance=dict(rows=rows, residual=b.residual, delivered=b.delivered,
                             heat=[[loss, list(ports), v] for (loss, ports), v in b.heat.items()],
                             residual_t=_residual_over_time(res, acc, k0, k1, b.delivered)[keep - k0]),
                accounts=dict(sensors=list(acc.sensors), sources=list(acc.sources), losses=list(acc.losses),
                              stored=list(acc.stored), boundary=[c for c, _ in acc.boundary]))


def _chain(res, acc, k0, k1) -> dict:
    """Energy [J] passed on at each power sensor (build order) and each stage's loss named by its components
    (:func:`acausal.results.energy.chain`)."""
    from .energy import chain
    links = chain(res, acc, k0, k1)
    points = [dict(label=comp, J=J, key=s) for s, comp, J, _ in links]
    losses = [dict(label="loss" + (f" ({', '.join(owners)})" if owners else ""), J=before[2] - J,
                   key=f"loss before {s}") for before, (s, _, J, owners) in zip(links, links[1:])]
    return dict(kind="chain", points=points, losses=losses)


def _balance_flows(b) -> dict:
    """The balance as Sankey flows: what entered -> the model -> each loss, stored energy, absorbed work [J]."""
    ins, outs = b.flows()
    nodes = [dict(label=f"{k} {v:.4g} J", color="#4a78b5") for k, v in ins.items()]
    nodes += [dict(label="model", color="#888")]
    nodes += [dict(label=f"{k} {v:.4g} J", color="#d0613c") for k, v in outs.items()]
    mid = len(ins)
    links = [dict(source=i, target=mid, value=v, key=k, label=k) for i, (k, v) in enumerate(ins.items())]
    links += [dict(source=mid, target=mid + 1 + j, value=v, key=k, label=k, loss=True)
              for j, (k, v) in enumerate(outs.items())]
    return dict(kind="balance", nodes=nodes, links=links, notes=[])


def _residual_over_time(res, acc, k0, k1, delivered) -> np.ndarray:
    """(delivered - lost - stored change) from ``t0`` to each output time, over the energy delivered in the whole
    window (the balance's residual at ``t1``), as :func:`acausal.results.energy.balance` sums them."""
    def since(name):
        e = np.asarray(res.energy(name), dtype=float)[k0:k1 + 1]
        return e - e[0]
    total = np.zeros(k1 - k0 + 1)
    for n in acc.sources:
        total += since(n)
    for _, ports in acc.boundary:
        total -= sum(since(p) for p in ports)
    for n in acc.losses:
        passed = -sum(since(p) for p in acc.heat.get(n, ())) if n in acc.heat else 0.0
        total -= since(n) - passed
    for n in acc.stored:
        x = np.asarray(res[n], dtype=float)[k0:k1 + 1]
        total -= x - x[0]
    return total / delivered if delivered else total


RESULT_JS = r"""
const S = DATA.sankey;
const flows = S.kind === 'chain' ? chainFlows(S.points, S.losses) : S;
drawSankey('sankey', flows, S.kind === 'chain' ? 'energy passed on at each power sensor [J]'
                                               : 'energy balance: what entered, where it went [J]');
const units = [...new Set(DATA.series.map(s => s.unit))];
$('traces').innerHTML = units.map((u, i) => `<div class="col"><div id="trace${i}" class="plot"></div></div>`).join('');
units.forEach((u, i) => drawLines('trace' + i, DATA.time, DATA.series.filter(s => s.unit === u), 'time [s]',
  u ? `[${u}]` : '(no unit)', u === 'W' ? 'power of every account [W]' : `variables in [${u || 'no unit'}]`, 's'));
const B = DATA.balance;
$('balance').innerHTML = table(['kind', 'account', 'energy [J]'],
  B.rows.map(r => [r[0], r[1], {v: r[2].toPrecision(6), cls: 'n'}])) +
  `<p>energy delivered ${B.delivered.toPrecision(6)} J; relative residual ` +
  `<b id="residual">${B.residual.toExponential(2)}</b>` +
  ` (delivered - lost - stored change, over delivered)</p>` +
  B.heat.map(h => `<p class="note">${esc(h[0])}: ${h[2].toPrecision(6)} J more, passed on as heat through ` +
                  `${esc(h[1].join(', '))}</p>`).join('');
drawLines('residual_t', DATA.time, [{name: 'relative residual', y: B.residual_t, unit: ''}], 'time [s]',
  'relative residual', `energy balance residual from ${DATA.t0} s`, 's', {exponentformat: 'e'});
const A = DATA.accounts;
$('accounts').innerHTML = table(['account (by convention)', 'names'],
  [['power sensors (points of the chain)', A.sensors],
  ['sources (source_power)', A.sources], ['losses (loss_power)', A.losses], ['stored (energy, *_energy)', A.stored],
  ['boundary (components delivering through their ports)', A.boundary]].map(r => [r[0], esc(r[1].join(', ') || '-')]));
ready();
"""


def result_page(res, path, t0=None, t1=None, title: str | None = None, names=(), max_points: int = 4000) -> Path:
    """Write the page of ``res`` to ``path`` (see :meth:`Result.to_html <acausal.results.result.Result.to_html>`)."""
    who = "to_html"
    require_plotly(who)  # the missing package and a bad path are said before anything is computed
    check_path(path, who)
    if title is not None and not isinstance(title, str):
        raise ModelError(f"{who}: title must be a str, got {title!r}")
    data = result_data(res, t0, t1, names, max_points)
    title = title or f"{data['model']}: energy accounts over {data['t0']:g} .. {data['t1']:g} s"
    body = (f"<h1>{_html.escape(title)}</h1>\n<p class=\"note\">Energy accounts found by convention "
            "(<code>loss_power</code>, <code>energy</code>, <code>source_power</code>, power sensors; "
            "<code>acausal.compile.accounts</code>). Hover for values with units; drag to zoom, double-click to "
            "reset.</p>\n"
            "<div class=\"row\"><div class=\"col\"><h2>Where the energy went</h2><div id=\"sankey\" "
            "class=\"plot tall\"></div></div><div class=\"col\"><h2>Energy balance</h2><div id=\"balance\"></div>"
            "<div id=\"residual_t\" class=\"plot\"></div></div></div>\n<h2>Over time</h2>"
            "<div id=\"traces\" class=\"row\"></div>\n<h2>Accounts</h2><div id=\"accounts\"></div>\n")
    return write_page(path, page(title, body, RESULT_JS, data, who), who)
