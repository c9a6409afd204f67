"""The explorer page's introduction, read as text (no browser): its headline counts the claims of ``claims.csv``
(how many hold with each preset, how many of those were fitted targets and how many predictions), it draws the energy
chain with its five measurement points, names the presets and explains the page's words, links the report and
embeds Figs. 7, 13 and 14 when the run wrote them (saying which are missing when not), each with its caption's
verdicts, and counts the figures' verdicts of ``figure_verdicts.csv`` (the report's verdict sentences, as rows).

The page is built from the small ``acausal paper`` run shared with ``tests/results/test_html_page.py``; the
browser test (``tests/docs/test_browser.py``) skips where Chromium is absent.
"""
from __future__ import annotations

import csv
import re
import shutil
from html.parser import HTMLParser

import pytest

from ...results.test_html_page import paper_folder

pytestmark = pytest.mark.slow  # the shared small run takes about 20 s
pytest.importorskip("plotly", reason="the page needs plotly (pip install acausal[html])")

FIGURES = ("fig07_direct_drive.png", "fig13_tracking.png", "fig14_calibration.png")


class Text(HTMLParser):
    """The page's visible text (scripts and the embedded data left out)."""

    def __init__(self):
        super().__init__()
        self.parts, self.skip = [], 0

    def handle_starttag(self, tag, attrs):
        self.skip += tag in ("script", "style")

    def handle_endtag(self, tag):
        self.skip -= tag in ("script", "style")

    def handle_data(self, data):
        if not self.skip:
            self.parts.append(data)


def text_of(page: str) -> str:
    p = Text()
    p.feed(page)
    return re.sub(r"\s+", " ", "".join(p.parts))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return paper_folder(tmp_path_factory)


def test_headline_counts_the_claims_of_claims_csv(run):
    with (run / "claims.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    page = (run / "index.html").read_text()
    text = text_of(page)
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    assert presets == ["paper_fit", "library"]
    for preset in presets:
        mine = [r for r in rows if r["preset"] == preset]
        held = [r for r in mine if r["holds"] == "yes"]
        fitted = sum(r["used_in_fit"] == "yes" for r in held)
        testable = [r for r in mine if r["role"] == "testable prediction"]
        sentence = (f"{preset}: {len(held)} of {len(mine)} claims hold; {fitted} of them fitted targets; "
                    f"{sum(r['holds'] == 'yes' for r in testable)} of {len(testable)} testable predictions hold")
        assert sentence in text, (sentence, re.findall(rf"{preset}: [^.]*\.", text))
        unchecked = sum(r["holds"] == "not checked" for r in mine)
        assert (f"{unchecked} not checked on this run" in text) == (unchecked > 0)
    assert "fit column" in text and "prediction" in text


def test_introduction_draws_the_chain_names_the_presets_and_explains_the_words(run):
    page = (run / "index.html").read_text()
    svg = re.search(r'<svg id="chain-diagram".*?</svg>', page, re.S).group(0)
    assert svg.count("<circle") == 5
    for point in ("source", "driver output", "motor (k i w)", "moment arm (link)", "joint (output)"):
        assert point in svg
    text = text_of(page)
    assert "paper_fit: the headline and the one that reproduces the paper" in text
    assert "library: the a-priori parameter set" in text
    glossary = re.search(r'<dl id="glossary">(.*?)</dl>', page, re.S).group(1)
    terms = re.findall(r"<dt><b>(.*?)</b></dt>", glossary)
    for word in ("k i w", "link", "duty", "replay", "preset", "fit", "closed_loop", "Eq. 4", "pt", "rms"):
        assert any(word in t for t in terms), word
    assert '<a href="report.md">report.md</a>' in page


def test_figures_7_13_14_are_embedded_when_the_run_wrote_them(run, tmp_path):
    from acausal.models.reporting.explorer import paper_page
    page = (run / "index.html").read_text()
    for name in FIGURES:  # the small run writes none of them: the page says so
        assert f"Not in this run: {name}" in text_of(page)
    for f in run.glob("*.csv"):
        shutil.copy(f, tmp_path / f.name)
    png = b"\x89PNG\r\n\x1a\n" + b"\0" * 16  # the bytes are embedded as they are
    for name in FIGURES:
        (tmp_path / name).write_bytes(png)
    text = paper_page(tmp_path).read_text()
    imgs = re.findall(r'<img src="data:image/png;base64,([A-Za-z0-9+/=]+)" alt="([^"]+)"', text)
    assert [alt for _, alt in imgs] == list(FIGURES)
    import base64
    assert all(base64.b64decode(b) == png for b, _ in imgs)
    assert "Not in this run: fig07" not in text_of(text)


def read_rows(path):
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_figure_verdicts_csv_holds_the_reports_verdict_sentences(run):
    from acausal.models.ankle.figures.trends import verdicts
    rows = read_rows(run / "figure_verdicts.csv")
    in_report = verdicts((run / "report.md").read_text())
    assert rows and {(r["figure"], r["trend"]): r["as_in_the_paper"] == "yes" for r in rows} == in_report
    for r in rows:  # the sentence starts with its own verdict and says what the model gives
        head = "as in the paper" if r["as_in_the_paper"] == "yes" else "differs from the paper"
        assert r["text"].startswith(f"{r['figure']}, {r['trend']}: {head}.") and "Model:" in r["text"]
        assert "**" not in r["text"] and (r["as_in_the_paper"] == "yes" or "Why:" in r["text"])
    text = text_of((run / "index.html").read_text())
    shown = sum(r["as_in_the_paper"] == "yes" for r in rows)
    assert f"Of the {len(rows)} trends the paper's text states about its Figs. 7-17, the model shows {shown} " in text


def test_each_embedded_figure_shows_its_own_verdicts(run, tmp_path):
    from acausal.models.reporting.explorer import paper_page
    for f in run.glob("*.csv"):
        shutil.copy(f, tmp_path / f.name)
    for name in FIGURES:
        (tmp_path / name).write_bytes(b"\x89PNG\r\n\x1a\n")
    rows = [dict(figure="Fig. 7", trend="the order of the peaks", as_in_the_paper="no",
                 text="Fig. 7, the order of the peaks: differs from the paper. Paper: 1.4x. Model: 0.87x. Why: <b>."),
            dict(figure="Fig. 14", trend="the fit", as_in_the_paper="yes",
                 text="Fig. 14, the fit: as in the paper. Paper: a. Model: b.")]
    with (tmp_path / "figure_verdicts.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    page = paper_page(tmp_path).read_text()
    cols = re.findall(r'<div class="col"><figure.*?alt="([^"]+)".*?</figure>(.*?)</div>', page, re.S)
    under = {alt: text_of(rest) for alt, rest in cols}
    assert "differs from the paper: Fig. 7, the order of the peaks" in under["fig07_direct_drive.png"]
    assert "Why: <b>." in under["fig07_direct_drive.png"]  # the sentence escaped, shown as text
    assert under["fig13_tracking.png"] == ""
    assert "as in the paper: Fig. 14, the fit" in under["fig14_calibration.png"]
    assert "Of the 2 trends the paper's text states about its Figs. 7-17, the model shows 1 " in text_of(page)
