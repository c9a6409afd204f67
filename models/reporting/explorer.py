"""The energy-chain explorer: ``acausal paper --out DIR`` writes ``DIR/index.html`` and ``acausal compare
... --html`` ``DIR/index.html``, one self-contained page each (:mod:`acausal.results.html`: plotly.js inline, the data
embedded, opens from the file system, offline).

Every number on a page is read from the CSV files of its run and embedded as they are
(``acausal.results.html.read_csv``), so the page and the CSVs cannot disagree; the page's scripts only select, convert
units (m to mm, fractions to %) and take differences of those numbers. The paper's page shows, for the bench condition
picked with the stride-time and precompression sliders (or a click on a map cell), the five-point energy chain of
``paper_fit`` and ``library`` side by side as Sankey diagrams (``protocol.csv``) with the power at the five points over
the stride (``power_traces.csv``); the loss and efficiency maps of Figs. 9-12 and 15 with the Table 1 cell and the
paper's claims about each figure; the design maps of Figs. 16-17 (spring stiffness x precompression, a Sankey per
design); Table 1 with each cell's deviation from the paper; the claims table. A CSV the run did not write (a
partial run) leaves its part out and the page says which file is missing.

The paper's page opens with an introduction for a reader new to the paper (:func:`introduction`, static HTML written
here): what the paper measured, the energy chain and its five measurement points as an inline SVG, the presets and
which one reproduces the paper, a headline counted from ``claims.csv`` (how many claims hold with each preset, how many
of those were fitted targets, how many of the testable predictions hold), what the claims table's *fit* column and
the claims' classes mean, Figs. 7, 13 and 14
(the run's PNGs, embedded as data URIs so the page stays one offline file), a link to ``report.md`` and a glossary of
the page's words.
"""
from __future__ import annotations

import base64
import html
import sys
from pathlib import Path

from acausal import ModelError
from acausal.results.html import INSTALL, page, plotly_available, read_csv, write_page

from .sankey import LABELS

#: the CSV files of ``acausal paper`` the page reads (name -> required); ``protocol.csv`` holds the chain itself
PAPER_FILES = {"protocol": True, "power_traces": False, "table1": False, "claims": False, "fig09_driver_loss": False,
               "fig10_motor_loss": False, "fig11_gearing_loss": False, "fig12_output_loss": False,
               "fig15_efficiency": False, "design_maps": False, "design_optima": False,
               "figure_verdicts": False}
#: the maps (CSV stem, figure number, title, value column, Table 1 column and point of the paper's value there)
MAPS = [("fig09_driver_loss", 9, "driver loss [% of source]", "loss_pct_of_previous_point",
         "paper_loss_vs_previous", "driver"),
        ("fig10_motor_loss", 10, "motor loss [% of driver output]", "loss_pct_of_previous_point",
         "paper_loss_vs_previous", "motor"),
        ("fig11_gearing_loss", 11, "rotor and gearing loss [% of motor power]", "loss_pct_of_previous_point",
         "paper_loss_vs_previous", "link"),
        ("fig12_output_loss", 12, "output (MACCEPA) loss [% of link]", "loss_pct_of_previous_point",
         "paper_loss_vs_previous", "output"),
        ("fig15_efficiency", 15, "overall efficiency [% of source]", "efficiency_pct", "paper_efficiency", "output")]
#: the condition of the paper's Table 1 (8 mm precompression, 2 s/stride: section 4.2), marked on the maps
TABLE1_CONDITION = (8.0, 2.0)
LOSS_LABELS = {"driver": "driver loss", "motor": "motor loss", "gearing": "rotor and gearing loss",
               "output": "output loss"}


def _constants() -> dict:
    """What the scripts need besides the CSVs: the bench's model name, the points and stages of the chain, their
    labels, the driver's duty limit, the maps (the presets are the ones ``protocol.csv`` holds, in its order)."""
    from ..ankle.protocol import BENCH, D_MAX, POINTS, STAGES
    return dict(bench=BENCH, points=list(POINTS), labels=LABELS,
                stages=[list(s) for s in STAGES], loss_labels=LOSS_LABELS, duty_limit=D_MAX,
                table1_condition=list(TABLE1_CONDITION), maps=[list(m) for m in MAPS])


def paper_data(out_dir) -> dict:
    """The page's data: every CSV of :data:`PAPER_FILES` in ``out_dir`` as columns (``tables``), the names of the
    optional ones missing (``missing``) and the constants the page needs (points, stages, duty limit, maps). A
    DataError names a required file that is missing or a file that does not parse."""
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise ModelError(f"explorer: {out_dir} is not a folder (the output folder of acausal paper)")
    tables, missing = {}, []
    for name, required in PAPER_FILES.items():
        path = out_dir / f"{name}.csv"
        if path.exists() or required:
            tables[name] = read_csv(path)
        else:
            missing.append(path.name)
    return dict(tables=tables, missing=missing, constants=_constants())


def paper_page(out_dir, path=None) -> Path:
    """Write the paper's page (default ``out_dir/index.html``) from the CSVs of ``acausal paper``'s ``out_dir``;
    returns its path. A ModelError when plotly is missing (naming the install command)."""
    data = paper_data(out_dir)
    path = Path(out_dir) / "index.html" if path is None else path
    body = PAPER_BODY.replace(INTRO_SLOT, introduction(out_dir, data["tables"].get("claims"),
                                                       data["tables"].get("figure_verdicts")))
    text = page("CYBERLEGs ankle actuator: the energy-chain explorer", body, PAPER_JS, data, "acausal paper")
    return write_page(path, text, "acausal paper")


def write_index(out_dir) -> str:
    """For ``acausal paper``: write ``out_dir/index.html`` and return the report's line about it; without plotly,
    write nothing, say so on stderr and return a line saying why and how to install it."""
    if not plotly_available():
        why = f"`index.html` (the energy-chain explorer) was not written: plotly is not installed ({INSTALL})"
        print(f"acausal paper: {why.replace('`', '')}", file=sys.stderr)
        return f"- {why}."
    path = paper_page(out_dir)
    return (f"- [`{path.name}`]({path.name}): the energy-chain explorer, this run's CSVs on one page (open it in a "
            "browser; it needs no network): Sankey diagrams, powers and maps for any condition, Table 1, the claims.")


def compare_page(out_dir, rows, no_series_link=(), path=None) -> Path:
    """Write the page of an ``acausal compare`` run (default ``out_dir/index.html``) from its ``compare.csv``:
    the runs' energy chains side by side for the picked stride time and precompression, and the table of ``rows``
    (``(column, label, ...)`` each: ``compare.MD_ROWS``); ``no_series_link``: models whose "link" point is the
    gear output (``compare.NO_SERIES_LINK``)."""
    out_dir = Path(out_dir)
    data = dict(tables={"compare": read_csv(out_dir / "compare.csv")},
                constants={**_constants(), "rows": [list(r[:2]) for r in rows], "no_series_link": list(no_series_link)})
    path = out_dir / "index.html" if path is None else path
    text = page("acausal compare: energy chains side by side", COMPARE_BODY, COMPARE_JS, data, "acausal compare")
    return write_page(path, text, "acausal compare --html")


# ---------------------------------------------------------------------------------------------- the introduction

#: where :func:`introduction` goes in :data:`PAPER_BODY`
INTRO_SLOT = "<!-- introduction -->"
#: the figures the introduction shows: (PNG in the run's folder, the figure as its verdicts name it, caption)
INTRO_FIGURES = [
    ("fig07_direct_drive.png", "Fig. 7", "the power the actuator and the bench's output motor draw from the supply "
     "over one stride (8 mm, 3 s/stride). The paper: the output motor's peak about 1.4 times the actuator's."),
    ("fig13_tracking.png", "Fig. 13", "the moment arm's planned and actual angle at 18 mm precompression, 1.2 and "
     "3 s/stride, in closed loop. The paper: at 1.2 s/stride the motor cannot follow in push-off."),
    ("fig14_calibration.png", "Fig. 14", "the motor current of the paper's simple model (Eq. 4) against a virtual "
     "bench recording (simulated, not measured), before and after calibrating R, J, b as the paper did, and with a "
     "mesh efficiency calibrated beside them."),
]
#: the presets the page names: (name, what it is)
PRESETS = [
    ("paper_fit", "the headline and the one that reproduces the paper: the library's components (driver, motor, "
     "lossy gears, frictional MACCEPA linkage) with the parameters the paper does not publish inferred from numbers "
     "it does publish. The claims whose numbers were targets of that inference are marked <i>fit</i> in the claims "
     "table; every other number is a prediction."),
    ("library", "the a-priori parameter set: datasheet motor, catalogue gear efficiency, lossless linkage, the "
     "driver draw the paper measured; nothing fitted to the paper. Shown beside <code>paper_fit</code> to show what "
     "the inference changes."),
    ("paper_optimized_total_arm_side", "the paper's own model, its Eq. 4 (ideal gears and driver) with Table 2's "
     "optimized parameters: the design maps (Figs. 16-17) show it beside <code>paper_fit</code>."),
]
#: the glossary: (word as the page shows it, meaning)
GLOSSARY = [
    ("source", "the electrical power the driver takes from the supply (measurement point 1)."),
    ("driver output", "the electrical power the motor driver delivers to the motor's terminals (point 2)."),
    ("motor (k i w)", "the mechanical power at the motor shaft: torque constant k x current i x speed w, as the paper "
     "computes it from the motor current (its Eq. 6; point 3)."),
    ("moment arm (link)", "the mechanical power at the moment arm, after the gears (point 4)."),
    ("joint (output)", "the mechanical power delivered to the ankle joint, after the MACCEPA linkage and its spring "
     "(point 5)."),
    ("stage loss, loss [% of previous]", "the energy lost between two neighbouring points, as a share of the energy "
     "at the earlier one (driver, motor, rotor and gearing, output loss)."),
    ("efficiency", "the energy at a point over the source's, per stride; the overall efficiency is the joint's."),
    ("J/stride", "energy per stride in joules: the power integrated over one stride."),
    ("stride time", "the duration of one walking cycle [s/stride]; shorter is faster walking."),
    ("precompression (P)", "how far the MACCEPA's spring is compressed before the arm moves [mm]: higher is a "
     "stiffer joint."),
    ("preset", "a named set of parameter values on top of the components' defaults (see above)."),
    ("bench, closed_loop", "the simulation of the paper's test bench: the joint moved along the gait, the moment arm "
     "under a position controller within the driver's voltage, so it can lag where the motor is too slow."),
    ("replay", "the simulation with the joint and arm angles prescribed exactly (the paper's Simulink approach): it "
     "gives the current and voltage the plan requires."),
    ("duty, required duty, duty limit", "the fraction of the supply voltage the driver applies; the driver can apply "
     "at most 0.9 of it. Where the replay requires more, the motor cannot follow the plan (x or hatched cells)."),
    ("balance residual", "what the energy balance leaves over (source - losses - output - stored change) as a "
     "fraction of the source: a check of the simulation, near zero."),
    ("tracking error", "the difference between the planned and the actual moment-arm angle in closed loop."),
    ("Sankey diagram", "the energy chain drawn as flows: the width of each band is the energy per stride."),
    ("claim, holds", "one statement of the paper, checked on this run's CSV files; <i>holds</i> says whether the "
     "simulation agrees within the tolerance the claim is read with (the last column)."),
    ("fit", "yes: the claim's numbers were targets of the inference of <code>paper_fit</code>, so that it holds is "
     "partly by construction; no: a prediction the inference did not see."),
    ("Eq. 4", "the paper's simple actuator model: a DC motor behind ideal gears, driven from an ideal voltage."),
    ("virtual bench recording", "a recording simulated with the full component chain and realistic sensors, standing "
     "in for the paper's bench data, which are not public."),
    ("design map, k, N/mm", "the efficiency over spring stiffness k (in N/mm) x precompression (Figs. 16-17)."),
    ("copper loss", "the winding's R i^2 heat: the motor's loss in the model."),
    ("Table 1 condition", "8 mm precompression, 2 s/stride: the experiment of the paper's Table 1 and Fig. 8, marked "
     "red on the maps."),
    ("pt (points)", "percentage points: the difference of two percentages (Table 1's deviations)."),
    ("rms", "root mean square: the typical size of a quantity that changes sign over the stride."),
]
#: the energy chain's boxes and the points between them (the diagram of the introduction)
_BOXES = [("power supply", "lab supply"), ("motor driver", "EPOS2 70/10"), ("motor", "winding"),
          ("rotor and gears", "86:1 x 10:1"), ("MACCEPA linkage", "and spring"),
          ("ankle joint", "moves along the gait")]
_POINTS = ["1 source", "2 driver output", "3 motor (k i w)", "4 moment arm (link)", "5 joint (output)"]
_LOSSES = ["driver loss", "motor loss", "gearing loss", "output loss"]


def chain_svg() -> str:
    """The energy chain as an inline SVG: six boxes, the five measurement points between them, each stage's loss
    below it (electrical points blue, mechanical ones green)."""
    bw, gap, h = 150, 48, 150
    w = 12 + len(_BOXES) * bw + (len(_BOXES) - 1) * gap
    out = [f'<svg id="chain-diagram" viewBox="0 0 {w} {h}" width="100%" style="max-width:{w}px" role="img" '
           'aria-label="the energy chain from the power supply to the ankle joint with its five measurement points">',
           '<defs><marker id="arrow" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
           'orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>']
    for i, (name, detail) in enumerate(_BOXES):
        x = 6 + i * (bw + gap)
        out.append(f'<rect x="{x}" y="30" width="{bw}" height="44" rx="6" fill="#eef2f7" stroke="#4a78b5"/>')
        out.append(f'<text x="{x + bw / 2}" y="49" text-anchor="middle" font-size="12">{html.escape(name)}</text>')
        out.append(f'<text x="{x + bw / 2}" y="66" text-anchor="middle" font-size="10.5" fill="#555">'
                   f'{html.escape(detail)}</text>')
        if i < len(_POINTS):
            x0, x1 = x + bw, x + bw + gap
            colour = "#2b6cb0" if i < 2 else "#2f855a"
            out.append(f'<line x1="{x0}" y1="52" x2="{x1 - 2}" y2="52" stroke="#555" marker-end="url(#arrow)"/>')
            out.append(f'<circle cx="{(x0 + x1) / 2}" cy="52" r="6" fill="{colour}"/>')
            out.append(f'<text x="{(x0 + x1) / 2}" y="18" text-anchor="middle" font-size="11" fill="{colour}">'
                       f'{html.escape(_POINTS[i])}</text>')
        if 0 < i < len(_POINTS):
            out.append(f'<line x1="{x + bw / 2}" y1="74" x2="{x + bw / 2}" y2="108" stroke="#d0613c" '
                       'stroke-dasharray="3,2" marker-end="url(#arrow)"/>')
            out.append(f'<text x="{x + bw / 2}" y="124" text-anchor="middle" font-size="11" fill="#d0613c">'
                       f'{html.escape(_LOSSES[i - 1])}</text>')
    out.append(f'<text x="6" y="{h - 6}" font-size="10" fill="#555">blue points: electrical power; green points: '
               'mechanical power; each stage between two points loses the energy shown below it (as heat; the '
               'supply takes nothing back)</text></svg>')
    return "".join(out)


#: the classes of the claims (``claims.csv``'s ``role``: acausal.models.ankle.claims' calibration set)
TARGET, TESTABLE, IN_NAME_ONLY = "target", "testable prediction", "prediction in name only"


def headline(claims: dict | None) -> list[dict]:
    """Per preset of ``claims.csv`` (columns as :func:`~acausal.results.html.read_csv` gives them; None when the run
    wrote none): how many claims it has, how many hold, how many of those were fitted targets (``used_in_fit``),
    how many of the testable predictions (``role``) hold of how many, how many predictions in name only hold, and
    how many were not checked."""
    if not claims:
        return []
    rows = rows_of(claims)
    out = []
    for preset in dict.fromkeys(r["preset"] for r in rows):
        mine = [r for r in rows if r["preset"] == preset]
        held = [r for r in mine if r["holds"] == "yes"]
        testable = [r for r in mine if r.get("role") == TESTABLE]
        out.append(dict(preset=preset, claims=len(mine), hold=len(held),
                        fitted=sum(r["used_in_fit"] == "yes" for r in held),
                        testable=len(testable), testable_hold=sum(r["holds"] == "yes" for r in testable),
                        in_name_only=sum(r.get("role") == IN_NAME_ONLY for r in held),
                        unchecked=sum(r["holds"] == "not checked" for r in mine)))
    return out


def _image(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def rows_of(table: dict | None) -> list[dict]:
    """The rows of a table as :func:`~acausal.results.html.read_csv` gives it (columns); none for None."""
    if not table:
        return []
    d = table["data"]
    return [{c: d[c][i] for c in table["columns"]} for i in range(len(d[table["columns"][0]]))]


def verdicts_html(rows: list[dict], figure: str | None = None) -> str:
    """The figures' verdicts (``figure_verdicts.csv``'s rows; those of one ``figure``, e.g. ``"Fig. 7"``, when
    given) as a list: whether the model shows each trend the paper's text states, and the caption's sentence."""
    mine = [r for r in rows if figure is None or r["figure"] == figure]
    if not mine:
        return ""
    items = [f'<li><b>{"as in the paper" if r["as_in_the_paper"] == "yes" else "differs from the paper"}</b>: '
             f'{html.escape(str(r["text"]))}</li>' for r in mine]
    return '<ul class="verdicts">' + "".join(items) + "</ul>"


def introduction(out_dir, claims: dict | None, verdicts: dict | None = None) -> str:
    """The page's introduction (HTML): the paper, the energy chain (:func:`chain_svg`), the presets, the headline
    (:func:`headline`, from ``claims.csv``), the *fit* column, Figs. 7, 13 and 14 with their verdicts and every
    figure's verdict count (``figure_verdicts.csv``), report.md and the glossary."""
    out_dir = Path(out_dir)
    L = ['<h2>What this page shows</h2>',
         '<p>The paper (<i>energetics of the CYBERLEGs ankle prosthesis\'s MACCEPA actuator</i>, section 4) put the '
         'actuator on a test bench that moved its ankle joint along a healthy gait and measured where the electrical '
         'energy of a stride goes: how much the motor driver, the motor, the gears and the linkage each lose on the '
         'way to the joint, over six spring precompressions and six walking speeds. This page shows the same '
         'measurements in simulation, from this run\'s CSV files.</p>',
         '<h3>The energy chain and its five measurement points</h3>', chain_svg()]
    L += ['<h3>Presets: which parameters</h3><ul>']
    L += [f'<li><code>{name}</code>: {text}</li>' for name, text in PRESETS]
    L += ['</ul>']
    heads = headline(claims)
    if heads:
        L += ['<h3>Headline (<code>claims.csv</code>)</h3>', '<ul id="headline">']
        for h in heads:
            L.append(f'<li data-preset="{html.escape(str(h["preset"]))}"><b>{html.escape(str(h["preset"]))}</b>: '
                     f'<b><span class="hold">{h["hold"]}</span> of <span class="claims">{h["claims"]}</span> '
                     f'claims hold</b>; <span class="fitted">{h["fitted"]}</span> of them fitted targets; '
                     f'<b><span class="testable-hold">{h["testable_hold"]}</span> of <span class="testable">'
                     f'{h["testable"]}</span> testable predictions hold</b>'
                     + (f'; <span class="in-name-only">{h["in_name_only"]}</span> a prediction in name only'
                        if h["in_name_only"] else '')
                     + (f'; <span class="unchecked">{h["unchecked"]}</span> not checked on this run'
                        if h["unchecked"] else '') + '.</li>')
        L += ['</ul>', '<p class="note">The claims table (at the end of the page) has a <b>fit</b> column: <i>yes</i> '
              'means the claim\'s numbers were among the targets the <code>paper_fit</code> parameters were '
              'inferred from, so that it holds is partly by construction; <i>no</i> means it was not fitted. Of those, '
              'a <i>testable prediction</i> depends only on what the paper publishes; a <i>prediction in name only</i> '
              'follows from the targets; the rest the published text does not allow to test (the report quotes the '
              'sentence that decides each). A claim that does not hold says by how much and what in the model works '
              'against it.</p>']
    else:
        L += ['<p class="note">Not in this run: <code>claims.csv</code> (no headline).</p>']
    found = rows_of(verdicts)
    shown = sum(r["as_in_the_paper"] == "yes" for r in found)
    count = (f'Of the {len(found)} trends the paper\'s text states about its Figs. 7-17, the model shows '
             f'<span id="verdicts-as">{shown}</span> as the paper does (<code>figure_verdicts.csv</code>); under each '
             f'figure below, its verdicts. ' if found else 'Not in this run: <code>figure_verdicts.csv</code>. ')
    L += ['<h3>Three of the paper\'s figures</h3>',
          f'<p class="note">{count}Every figure, with its caption\'s verdicts (what the model gives and, where it '
          'differs, why), is in the report: <a href="report.md">report.md</a>.</p>',
          '<div class="row">']
    for name, figure, text in INTRO_FIGURES:
        path = out_dir / name
        if path.exists():
            L.append(f'<div class="col"><figure style="margin:0"><img src="{_image(path)}" alt="{html.escape(name)}" '
                     f'style="width:100%"><figcaption class="note">{html.escape(f"{figure}: {text}")}</figcaption></figure>'
                     f'{verdicts_html(found, figure)}</div>')
        else:
            L.append(f'<div class="col"><p class="note">Not in this run: <code>{html.escape(name)}</code>.</p></div>')
    L += ['</div>', '<h3>Glossary</h3>', '<dl id="glossary">']
    L += [f'<dt><b>{html.escape(word)}</b></dt><dd>{text}</dd>' for word, text in GLOSSARY]
    L += ['</dl>', '<h2>The explorer</h2>']
    return "\n".join(L)


# ---------------------------------------------------------------------------------------------- the pages' scripts

#: helpers both pages share: CSV columns as rows, the five-point chain of a row, a slider over values
CHAIN_JS = r"""
const K = DATA.constants, TB = DATA.tables;
const near = (a, b) => a !== null && b !== null && Math.abs(a - b) < 1e-9;
function rowsOf(t) { if (!t) return []; const n = t.data[t.columns[0]].length;
  return Array.from({length: n}, (_, i) => Object.fromEntries(t.columns.map(c => [c, t.data[c][i]]))); }
const uniq = xs => [...new Set(xs.filter(x => x !== null))].sort((a, b) => a - b);
// the five-point chain of a CSV row (columns E_<point>_J and, when losses are given, loss_<stage>_J)
function chainOfRow(r, labels) {
  const points = K.points.map(k => ({label: (labels || K.labels)[k], short: k, J: r[`E_${k}_J`], key: `E_${k}_J`}));
  const losses = K.stages.map(([st, a, b]) => (`loss_${st}_J` in r)
    ? {label: K.loss_labels[st], short: st + ' loss', J: r[`loss_${st}_J`], key: `loss_${st}_J`}
    : {label: K.loss_labels[st], short: st + ' loss', J: r[`E_${a}_J`] - r[`E_${b}_J`], key: `E_${a}_J - E_${b}_J`});
  return chainFlows(points, losses);
}
// a range input ``id`` over ``values``; ``show`` formats the value into #id-value; onchange(index)
function slider(id, values, start, show, onchange) {
  const el = $(id); el.min = 0; el.max = Math.max(values.length - 1, 0); el.step = 1; el.value = start;
  const put = () => { $(id + '-value').textContent = show(values[+el.value]); onchange(+el.value); };
  el.addEventListener('input', put); put(); return el;
}
const missing = f => `<p class="note">Not in this run: <code>${f}</code>.</p>`;
"""

PAPER_BODY = """<h1>CYBERLEGs ankle actuator: where the energy of a stride goes</h1>
<p class="note">The results of <code>acausal paper</code> on one page. Every number is read from the CSV files of this
run (named under each part). Move the sliders or click a map cell to pick a bench condition; hover for values with
units; drag to zoom, double-click to reset. The full report, every table and figure next to the paper:
<a href="report.md">report.md</a>.</p>
<!-- introduction -->
<div class="controls"><label>stride time <input type="range" id="stride-time"><span class="value"
id="stride-time-value"></span></label><label>precompression <input type="range" id="precompression"><span
class="value" id="precompression-value"></span></label><span id="condition-note" class="note"></span></div>
<h2>The energy chain of one stride on the bench (<code>protocol.csv</code>)</h2>
<div class="row" id="chains"></div>
<h2>Power at the five measurement points over the stride (<code>power_traces.csv</code>)</h2>
<div class="row" id="powers"></div>
<h2>Loss and efficiency maps (Figs. 9-12, 15)</h2>
<div class="controls"><label>map <select id="map-select"></select></label><span class="note">click a cell to pick
its condition; x: the motor cannot follow there (the replay needs more than the driver's duty limit)</span></div>
<div class="row"><div class="col"><div id="map" class="plot tall"></div></div>
<div class="col" id="map-claims"></div></div>
<h2>Spring design maps (Figs. 16-17, <code>design_maps.csv</code>)</h2><div id="design"></div>
<h2>Table 1: simulation next to the paper (<code>table1.csv</code>)</h2><div id="table1"></div>
<h2>The paper's claims (<code>claims.csv</code>)</h2><div id="claims"></div>
<p class="small" id="files"></p>
"""

PAPER_JS = CHAIN_JS + r"""
const protocol = rowsOf(TB.protocol), bench = protocol.filter(r => r.model === K.bench);
const presets = [...new Set(bench.map(r => r.preset))];  // paper_fit, library: the order of protocol.csv
const Ps = uniq(bench.map(r => r.P_mm)), Ts = uniq(bench.map(r => r.stride_time_s));
const claims = rowsOf(TB.claims), PT = TB.power_traces ? TB.power_traces.data : null, traceRows = {};
if (PT) PT.preset.forEach((p, i) => { if (PT.model[i] !== K.bench) return;  // row numbers by condition, once
  const key = `${p}|${PT.P_mm[i]}|${PT.stride_time_s[i]}`; (traceRows[key] = traceRows[key] || []).push(i); });
const state = {P: Ps.includes(K.table1_condition[0]) ? K.table1_condition[0] : Ps[0],
               T: Ts.includes(K.table1_condition[1]) ? K.table1_condition[1] : Ts[0]};
const find = (rows, model, preset) => rows.find(r => r.model === model && r.preset === preset &&
  near(r.P_mm, state.P) && near(r.stride_time_s, state.T));
$('chains').innerHTML = presets.map(p => `<div class="col"><div id="sankey-${p}" class="plot"></div>` +
  `<div id="chain-table-${p}"></div></div>`).join('');
$('powers').innerHTML = TB.power_traces ? presets.map(p => `<div class="col"><div id="power-${p}" class="plot">` +
  `</div></div>`).join('') : missing('power_traces.csv');
function drawChains() {
  for (const p of presets) {
    const r = find(bench, K.bench, p), rep = find(protocol, 'replay', p);
    if (!r) { Plotly.purge('sankey-' + p); $('sankey-' + p).innerHTML = `<p>no ${p} run at this condition</p>`;
              continue; }
    if (!$('sankey-' + p).data) $('sankey-' + p).innerHTML = '';
    drawSankey('sankey-' + p, chainOfRow(r), `<b>${p}</b>: ${fmt(r.E_source_J)} J from the source, ` +
      `${fmt(r.E_output_J)} J to the joint (${fmt(100 * r.efficiency)} %)`);
    const rowsT = K.points.map((k, i) => { const st = i ? K.stages[i - 1][0] : null;
      return [K.labels[k], {v: fmt(r[`E_${k}_J`], 2), cls: 'n'}, {v: st ? fmt(r[`loss_${st}_J`], 2) : '', cls: 'n'},
              {v: st ? fmt(100 * r[`loss_${st}_J`] / r[`E_${K.stages[i - 1][1]}_J`]) : '', cls: 'n'}]; });
    $('chain-table-' + p).innerHTML = table(['point', 'energy [J/stride]', 'stage loss [J]', 'loss [% of previous]'],
      rowsT) + `<p class="note">balance residual ${r.balance_residual.toExponential(1)}; largest duty ` +
      `${fmt(r.max_duty, 2)}; tracking error rms ${fmt(r.tracking_rms_rad * 180 / Math.PI, 2)} deg` +
      (rep ? `; the replay of the plan needs duty ${fmt(rep.max_duty, 2)}: the motor ` +
             (rep.max_duty > K.duty_limit ? '<b>cannot follow</b>' : 'can follow') : '') + '</p>';
    if (!PT) continue;
    const tr = traceRows[`${p}|${state.P}|${state.T}`] || [];
    drawLines('power-' + p, tr.map(i => PT.time_ms[i]), K.points.map(k => ({name: K.labels[k], unit: 'W',
      y: tr.map(i => PT[`P_${k}_W`][i])})), 'time in the stride [ms] (heel strike at 0)', 'power [W]',
      `<b>${p}</b>: power at the five points, ${state.P} mm, ${state.T} s/stride`, 'ms');
  }
}
const maps = K.maps.filter(m => TB[m[0]]);
$('map-select').innerHTML = maps.map((m, i) => `<option value="${i}">Fig. ${m[1]}: ${m[2]}</option>`).join('');
const t1 = rowsOf(TB.table1), cellOf = v => Ts.findIndex(t => near(t, v));
function drawMap() {
  if (!maps.length) { $('map').innerHTML = missing('fig09_driver_loss.csv ... fig15_efficiency.csv'); return; }
  const [stem, fig, title, col, paperCol, point] = maps[+$('map-select').value];
  const rows = rowsOf(TB[stem]), xs = Ts.map(t => `${t} s`), ys = Ps.map(P => `${P} mm`);
  const at = (P, T) => rows.find(r => near(r.P_mm, P) && near(r.stride_time_s, T));
  const z = Ps.map(P => Ts.map(T => { const r = at(P, T); return r ? r[col] : null; }));
  const stuck = rows.filter(r => r.motor_can_follow === 'False');
  const shapes = [], notes = [];
  const box = (P, T, color, d) => ({type: 'rect', xref: 'x', yref: 'y', x0: cellOf(T) - d, x1: cellOf(T) + d,
    y0: Ps.findIndex(p => near(p, P)) - d, y1: Ps.findIndex(p => near(p, P)) + d, line: {color, width: 3}});
  const [P1, T1] = K.table1_condition, paper = t1.find(r => r.point === point);
  if (paper && at(P1, T1)) { shapes.push(box(P1, T1, 'red', 0.44));
    notes.push({x: cellOf(T1), y: Ps.findIndex(p => near(p, P1)) + 0.5, yanchor: 'bottom', showarrow: false,
      text: `paper (Table 1): ${fmt(100 * paper[paperCol])} %`, font: {color: 'red', size: 11}, bgcolor: 'white'}); }
  shapes.push(box(state.P, state.T, 'black', 0.5));
  const preset = rows.length ? rows[0].preset : '';
  Plotly.react('map', [{type: 'heatmap', x: xs, y: ys, z, colorscale: col === 'efficiency_pct' ? 'Viridis' : 'YlOrRd',
      texttemplate: '%{z:.1f}', hovertemplate: `${title}: %{z:.2f} %<br>%{y}, %{x}/stride<extra></extra>`,
      colorbar: {title: {text: '%'}}},
    {type: 'scatter', mode: 'markers', x: stuck.map(r => `${r.stride_time_s} s`), y: stuck.map(r => `${r.P_mm} mm`),
     marker: {symbol: 'x-thin-open', size: 26, color: 'rgba(60,60,60,0.6)'}, hoverinfo: 'skip', showlegend: false}],
    {title: TITLE(`Fig. ${fig}: ${title}, ${preset} on the bench (${stem}.csv)`),
     xaxis: {title: {text: 'stride time [s/stride]'}, type: 'category'}, shapes, annotations: notes,
     yaxis: {title: {text: 'precompression [mm]'}, type: 'category'}, margin: {l: 70, r: 10, t: 40, b: 45}}, CONFIG);
  const own = claims.filter(c => new RegExp(`Fig\\. ${fig}\\b`).test(c.statement));
  $('map-claims').innerHTML = own.length ? '<p><b>What the paper says about this figure</b> (claims.csv)</p>' +
    table(['id', 'preset', 'claim', 'paper', 'simulated', 'holds'], own.map(c => [c.id, c.preset, esc(c.statement),
      esc(c.paper), esc(c.simulated), {v: c.holds, cls: c.holds === 'yes' ? 'good' : c.holds === 'no' ? 'bad' : ''}]))
    : (TB.claims ? '' : missing('claims.csv'));
}
let mapWired = false;
function pick(P, T) { state.P = P; state.T = T; $('precompression').value = Ps.findIndex(p => near(p, P));
  $('stride-time').value = Ts.findIndex(t => near(t, T)); update(); }
function update() {
  $('precompression-value').textContent = `${state.P} mm`; $('stride-time-value').textContent = `${state.T} s/stride`;
  drawChains(); drawMap();
  if (!mapWired && maps.length) { mapWired = true;
    $('map').on('plotly_click', ev => { const pt = ev.points[0];
      if (pt.curveNumber === 0) pick(Ps[ys_index(pt.y)], Ts[xs_index(pt.x)]); }); }
}
const ys_index = y => Ps.findIndex(P => `${P} mm` === y), xs_index = x => Ts.findIndex(T => `${T} s` === x);
$('map-select').addEventListener('change', drawMap);
""" + r"""
function drawDesign() {
  if (!TB.design_maps) { $('design').innerHTML = missing('design_maps.csv'); return; }
  const D = rowsOf(TB.design_maps), O = rowsOf(TB.design_optima);
  $('design').innerHTML = `<div class="controls"><label>model <select id="d-preset"></select></label>` +
    `<label>stride time <select id="d-T"></select></label><label>spring stiffness <input type="range" id="d-k">` +
    `<span class="value" id="d-k-value"></span></label><label>precompression <input type="range" id="d-P">` +
    `<span class="value" id="d-P-value"></span></label></div><div class="row"><div class="col"><div id="d-map" ` +
    `class="plot tall"></div></div><div class="col"><div id="d-sankey" class="plot tall"></div></div></div>`;
  const dp = [...new Set(D.map(r => r.preset))], dT = uniq(D.map(r => r.stride_time_s));
  const ks = uniq(D.map(r => r.k_Npm)), dPs = uniq(D.map(r => r.P_m)), s = {k: 0, P: 0};
  $('d-preset').innerHTML = dp.map(p => `<option>${p}</option>`).join('');
  $('d-T').innerHTML = dT.map(t => `<option value="${t}">${t} s/stride</option>`).join('');
  const draw = () => {
    const p = $('d-preset').value, T = +$('d-T').value, k = ks[s.k], P = dPs[s.P];
    const rows = D.filter(r => r.preset === p && near(r.stride_time_s, T));
    const at = (kk, PP) => rows.find(r => near(r.k_Npm, kk) && near(r.P_m, PP));
    const z = dPs.map(PP => ks.map(kk => { const r = at(kk, PP);
      return r && r.feasible ? 100 * r.efficiency : null; }));
    const over = rows.filter(r => r.feasible && r.max_duty > K.duty_limit);
    const opt = O.find(r => r.preset === p && near(r.stride_time_s, T) && !r.variant);
    const marks = opt ? [{type: 'scatter', mode: 'markers+text', x: [opt.paper_design_kNpm, opt.refined_kNpm],
      y: [opt.paper_design_P_mm, opt.refined_P_mm], text: ["paper's design", 'efficiency optimum'],
      textposition: 'top center', marker: {symbol: ['square', 'star'], size: [11, 15], color: ['red', 'magenta'],
      line: {color: 'black', width: 1}}, hovertemplate: '%{text}: %{x:.1f} N/mm, %{y:.2f} mm<extra></extra>',
      showlegend: false}] : [];
    Plotly.react('d-map', [{type: 'heatmap', x: ks.map(v => v / 1e3), y: dPs.map(v => 1e3 * v), z,
        colorscale: 'Viridis', colorbar: {title: {text: '%'}},
        hovertemplate: 'efficiency %{z:.2f} %<br>k %{x} N/mm, P %{y} mm<extra></extra>'},
      {type: 'scatter', mode: 'markers', x: over.map(r => r.k_Npm / 1e3), y: over.map(r => 1e3 * r.P_m),
       marker: {symbol: 'x-thin-open', size: 6, color: 'rgba(255,255,255,0.45)'}, hoverinfo: 'skip', showlegend: false},
      ...marks],
      {title: TITLE(`overall efficiency per stride, ${p}, ${T} s/stride (x: duty > ${K.duty_limit})`),
       xaxis: {title: {text: 'spring stiffness k [N/mm]'}}, yaxis: {title: {text: 'precompression P [mm]'}},
       shapes: [{type: 'rect', x0: k / 1e3 - 5, x1: k / 1e3 + 5, y0: 1e3 * P - 0.5, y1: 1e3 * P + 0.5,
                 line: {color: 'white', width: 3}}], margin: {l: 60, r: 10, t: 40, b: 45}}, CONFIG);
    const r = at(k, P);
    if (!r || !r.feasible) { Plotly.purge('d-sankey'); $('d-sankey').innerHTML =
      `<p>k ${k / 1e3} N/mm, P ${1e3 * P} mm: no design (the gait torque is beyond the linkage's reach)</p>`; }
    else { if (!$('d-sankey').data) $('d-sankey').innerHTML = '';
      drawSankey('d-sankey', chainOfRow(r), `${p}: k ${k / 1e3} N/mm, ` +
      `P ${1e3 * P} mm, ${T} s/stride: efficiency ${fmt(100 * r.efficiency)} %, copper loss ${fmt(r.E_copper_J)} J`); }
  };
  slider('d-k', ks, Math.max(0, ks.findIndex(v => near(v, 130e3))), v => `${v / 1e3} N/mm`, i => { s.k = i; draw(); });
  slider('d-P', dPs, Math.max(0, dPs.findIndex(v => near(v, 0.007))), v => `${1e3 * v} mm`, i => { s.P = i; draw(); });
  ['d-preset', 'd-T'].forEach(id => $(id).addEventListener('change', draw));
  $('d-map').on('plotly_click', ev => { const pt = ev.points[0]; if (pt.curveNumber !== 0) return;
    s.k = ks.findIndex(v => near(v / 1e3, pt.x)); s.P = dPs.findIndex(v => near(1e3 * v, pt.y));
    $('d-k').value = s.k; $('d-P').value = s.P; $('d-k-value').textContent = `${pt.x} N/mm`;
    $('d-P-value').textContent = `${pt.y} mm`; draw(); });
}
function drawTable1() {
  if (!TB.table1) { $('table1').innerHTML = missing('table1.csv'); return; }
  const dev = (v, unit) => ({v: (v >= 0 ? '+' : '') + fmt(v) + unit,
    cls: Math.abs(v) <= (unit === ' %' ? 10 : 5) ? 'good' : Math.abs(v) <= (unit === ' %' ? 25 : 10) ? 'mid' : 'bad'});
  const lib = presets[1], head = t1.length ? t1[0].preset : '';
  $('table1').innerHTML = table(['point', `energy ${head} [J]`, 'energy paper [J]', 'deviation', `efficiency ${head}`,
    'efficiency paper', 'deviation', `loss vs previous ${head}`, 'loss vs previous paper', 'deviation',
    `energy ${lib} [J]`, 'deviation', `loss vs previous ${lib}`, 'deviation'],
    t1.map(r => [K.labels[r.point] || r.point, {v: fmt(r.sim_energy_J), cls: 'n'}, {v: fmt(r.paper_energy_J), cls: 'n'},
      dev(100 * (r.ratio_energy - 1), ' %'), {v: fmt(100 * r.sim_efficiency) + ' %', cls: 'n'},
      {v: fmt(100 * r.paper_efficiency) + ' %', cls: 'n'}, dev(100 * (r.sim_efficiency - r.paper_efficiency), ' pt'),
      {v: fmt(100 * r.sim_loss_vs_previous) + ' %', cls: 'n'},
      {v: fmt(100 * r.paper_loss_vs_previous) + ' %', cls: 'n'},
      dev(100 * (r.sim_loss_vs_previous - r.paper_loss_vs_previous), ' pt'),
      {v: fmt(r[`${lib}_energy_J`]), cls: 'n'}, dev(100 * (r[`${lib}_energy_J`] / r.paper_energy_J - 1), ' %'),
      {v: fmt(100 * r[`${lib}_loss_vs_previous`]) + ' %', cls: 'n'},
      dev(100 * (r[`${lib}_loss_vs_previous`] - r.paper_loss_vs_previous), ' pt')])) +
    '<p class="note">deviation: simulated / paper - 1 for energies [%], simulated - paper for fractions [percentage ' +
    'points]; green within 10 % (5 points), yellow within 25 % (10 points), red beyond.</p>';
}
function drawClaims() {
  if (!TB.claims) { $('claims').innerHTML = missing('claims.csv'); return; }
  const ids = [...new Set(claims.map(c => c.id))], by = (id, p) => claims.find(c => c.id === id && c.preset === p);
  const holds = c => c ? {v: c.holds, cls: c.holds === 'yes' ? 'good' : c.holds === 'no' ? 'bad' : ''} : '-';
  const cp = [...new Set(claims.map(c => c.preset))];
  $('claims').innerHTML = table(['id', 'the paper says', 'paper', ...cp.flatMap(p => [p, 'holds']), 'fit',
    'how it is read; what opposes it'], ids.map(id => { const a = cp.map(p => by(id, p)).find(c => c);
      return [id, esc(a.statement), esc(a.paper), ...cp.flatMap(p => { const c = by(id, p);
        return [c ? esc(c.simulated) : '-', holds(c)]; }), a.used_in_fit, {v: esc(a.note), cls: 'small'}]; }));
}
slider('stride-time', Ts, Ts.findIndex(t => near(t, state.T)), v => `${v} s/stride`,
       i => { state.T = Ts[i]; update(); });
slider('precompression', Ps, Ps.findIndex(p => near(p, state.P)), v => `${v} mm`, i => { state.P = Ps[i]; update(); });
drawDesign(); drawTable1(); drawClaims();
$('files').textContent = 'Read from: ' + Object.values(TB).map(t => t.file).join(', ') +
  (DATA.missing.length ? '; not in this run: ' + DATA.missing.join(', ') : '') + '.';
ready();
"""

COMPARE_BODY = """<h1>acausal compare: energy chains side by side</h1>
<p class="note">Every number is read from <code>compare.csv</code>. Pick a stride time and precompression (models
without a precompression run once per stride time); hover for values with units.</p>
<div class="controls"><label>stride time <input type="range" id="stride-time"><span class="value"
id="stride-time-value"></span></label><label>precompression <input type="range" id="precompression"><span
class="value" id="precompression-value"></span></label></div>
<div class="row" id="chains"></div><h2>Every run (<code>compare.csv</code>)</h2><div id="runs"></div>
"""

COMPARE_JS = CHAIN_JS + r"""
const runs = rowsOf(TB.compare), models = [...new Set(runs.map(r => r.model))];
const Ts = uniq(runs.map(r => r.stride_time_s)), Ps = uniq(runs.map(r => r.P_mm)), state = {T: Ts[0], P: Ps[0]};
$('chains').innerHTML = models.map(m => `<div class="col"><div id="sankey-${m}" class="plot"></div></div>`).join('');
function update() {
  for (const m of models) {
    const r = runs.find(x => x.model === m && near(x.stride_time_s, state.T) &&
                             (x.P_mm === null || near(x.P_mm, state.P)));
    if (!r) continue;
    const labels = K.no_series_link.includes(m) ? {...K.labels, link: 'gear output (link)'} : K.labels;
    drawSankey('sankey-' + m, chainOfRow(r, labels), `<b>${m}</b>` + (r.P_mm === null ? '' : `, ${r.P_mm} mm`) +
      `, ${r.stride_time_s} s/stride: ${fmt(r.E_source_J)} J from the source, ${fmt(r.E_output_J)} J to the joint`);
  }
}
if (Ps.length) slider('precompression', Ps, 0, v => `${v} mm`, i => { state.P = Ps[i]; update(); });
else $('precompression').parentElement.style.display = 'none';  // no compared model has a precompression
slider('stride-time', Ts, 0, v => `${v} s/stride`, i => { state.T = Ts[i]; update(); });
$('runs').innerHTML = table(['quantity', ...runs.map(r => `${r.model}<br>` + (r.P_mm === null ? '' : `${r.P_mm} mm, `) +
  `${r.stride_time_s} s`)], [...K.rows.map(([key, label]) => [label, ...runs.map(r => ({v: typeof r[key] === 'number'
  ? r[key].toPrecision(4) : esc(r[key]), cls: 'n'}))]), ['limits exceeded', ...runs.map(r => esc(r.limits_exceeded))]]);
ready();
"""
