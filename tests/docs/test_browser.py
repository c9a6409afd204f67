"""The explorer in a real browser: headless Chromium, driven by selenium, opens the paper's page from disk
(the small run of ``tests/results/test_html_page.py``), finds no console error, moves the stride-time and precompression
sliders, and reads the Sankey diagrams' link values back from the drawn figures: they equal the energies of
``protocol.csv`` for the condition the sliders show; the headline it draws counts the claims of ``claims.csv``. A
screenshot goes to the test's temporary folder; the load time
is printed (``-s`` shows it), never asserted. A page of ``Result.to_html`` is opened the same way.

Skips, saying why, where selenium, Chromium or its driver is missing (``.ci/run`` installs Debian's ``chromium`` and
``chromium-driver`` when it can).
"""
from __future__ import annotations

import csv
import time

import pytest

from ..results.test_html_page import Chain, paper_folder

pytest.importorskip("plotly", reason="the pages need plotly (pip install acausal[html])")
webdriver = pytest.importorskip("selenium.webdriver", reason="the browser test drives Chromium with selenium "
                                "(pip install selenium, in the test extra)")

def _browser():
    """(chromium binary, chromedriver) or a skip naming what is missing (acausal info's lookup)."""
    from acausal.cli.accelerators import browser, browser_and_driver
    found = browser()
    if not found.present:
        pytest.skip(f"{found.found} on this machine (Debian: {found.get}; .ci/run installs them when apt-get can)")
    return browser_and_driver()


@pytest.fixture(scope="module")
def browser():
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    binary, driver = _browser()
    options = Options()
    options.binary_location = binary
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1400,1000"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        d = webdriver.Chrome(service=Service(driver), options=options)
    except WebDriverException as e:
        pytest.skip(f"headless Chromium ({binary}, {driver}) did not start: {str(e).splitlines()[0]}")
    yield d
    d.quit()


def open_page(d, path, what: str) -> float:
    """Load ``path`` from disk and wait until its script has drawn everything; returns and prints the load time
    [s] (wall time of the load, and the page's own time from navigation to ``acausalReady``)."""
    t0 = time.perf_counter()
    d.get(path.as_uri())
    deadline = t0 + 60
    while not d.execute_script("return window.acausalReady === true"):
        assert time.perf_counter() < deadline, f"{what}: not drawn within 60 s; console: {d.get_log('browser')}"
        time.sleep(0.05)
    wall = time.perf_counter() - t0
    ms = d.execute_script("return window.acausalReadyMs")
    print(f"\n{what}: {path.stat().st_size / 1e6:.2f} MB, loaded and drawn in {wall:.2f} s wall time "
          f"({ms / 1e3:.2f} s from navigation to the last plot, headless Chromium)")
    return wall


def severe(d) -> list:
    return [e for e in d.get_log("browser") if e["level"] == "SEVERE"]


def sankey_links(d, div: str) -> dict:
    """The drawn Sankey diagram's links: the CSV column (or account) each comes from -> its value [J]."""
    link = d.execute_script(f"const l = document.getElementById('{div}').data[0].link; "
                            "return [l.customdata, l.value];")
    return dict(zip(*link))


def test_explorer_follows_the_sliders_and_shows_the_csvs_energies(browser, tmp_path_factory, tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    run = paper_folder(tmp_path_factory)
    open_page(browser, run / "index.html", "explorer (small run)")
    assert not severe(browser), severe(browser)
    with (run / "protocol.csv").open() as f:
        bench = [r for r in csv.DictReader(f) if r["model"] == "closed_loop"]
    Ps = sorted({float(r["P_mm"]) for r in bench})
    Ts = sorted({float(r["stride_time_s"]) for r in bench})

    def check(what):
        P = Ps[int(browser.find_element(By.ID, "precompression").get_attribute("value"))]
        T = Ts[int(browser.find_element(By.ID, "stride-time").get_attribute("value"))]
        for preset in ("paper_fit", "library"):
            row = next(r for r in bench if r["preset"] == preset and float(r["P_mm"]) == P
                       and float(r["stride_time_s"]) == T)
            links = sankey_links(browser, f"sankey-{preset}")
            for key in ("E_driver_J", "E_motor_J", "E_link_J", "E_output_J"):
                assert links[key] == float(row[key]), (what, preset, P, T, key)
            for key in ("loss_driver_J", "loss_motor_J", "loss_gearing_J", "loss_output_J"):
                if float(row[key]) > 1e-6 * float(row["E_source_J"]):
                    assert links[key] == float(row[key]), (what, preset, P, T, key)
                else:  # nothing lost there: no link, a note says so
                    assert key not in links, (what, preset, key)
            power = browser.execute_script(f"return document.getElementById('power-{preset}').data[0].y.length")
            assert power == 101, (what, preset)
        return P, T

    first = check("as loaded")
    assert first == (8.0, 2.0)  # the page opens on the paper's Table 1 condition
    browser.find_element(By.ID, "stride-time").send_keys(Keys.ARROW_LEFT)
    assert check("stride time moved") == (8.0, 1.2)
    browser.find_element(By.ID, "precompression").send_keys(Keys.ARROW_LEFT)
    assert check("precompression moved") == (5.0, 1.2)
    assert browser.find_element(By.ID, "stride-time-value").text == "1.2 s/stride"
    browser.find_element(By.ID, "map-select").send_keys(Keys.ARROW_DOWN)  # another loss map
    browser.find_element(By.ID, "d-k").send_keys(Keys.ARROW_RIGHT)  # another spring design
    assert browser.execute_script("return document.getElementById('d-sankey').data[0].type") == "sankey"
    assert not severe(browser), severe(browser)
    shot = tmp_path / "explorer.png"
    browser.save_screenshot(str(shot))
    print(f"screenshot: {shot}")


def test_result_page_in_the_browser(browser, tmp_path):
    from acausal import compile_model
    res = compile_model(Chain()).simulate(0.2, n_points=401)
    open_page(browser, res.to_html(tmp_path / "chain.html"), "Result.to_html page")
    assert not severe(browser), severe(browser)
    links = sankey_links(browser, "sankey")
    for s in ("P_shaft.P",):
        assert links[s] == pytest.approx(float(res.energy(s)[-1]), rel=1e-12)
    residual = browser.execute_script("return document.getElementById('residual').textContent")
    assert float(residual) == pytest.approx(res.energy_balance().residual, rel=0.01, abs=1e-12)
    browser.save_screenshot(str(tmp_path / "result_page.png"))


def test_explorer_headline_as_drawn_equals_the_claims_csv(browser, tmp_path_factory):
    """The headline the browser shows (the spans of ``#headline``) counts the claims of ``claims.csv``: per preset,
    how many hold, how many of them were fitted, how many testable predictions hold of how many."""
    from selenium.webdriver.common.by import By

    run = paper_folder(tmp_path_factory)
    open_page(browser, run / "index.html", "explorer (small run)")
    with (run / "claims.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    items = browser.find_elements(By.CSS_SELECTOR, "#headline li")
    assert [li.get_attribute("data-preset") for li in items] == list(dict.fromkeys(r["preset"] for r in rows))
    for li in items:
        mine = [r for r in rows if r["preset"] == li.get_attribute("data-preset")]
        held = [r for r in mine if r["holds"] == "yes"]
        testable = [r for r in mine if r["role"] == "testable prediction"]
        drawn = {c: int(li.find_element(By.CLASS_NAME, c).text) for c in ("hold", "claims", "fitted", "testable-hold",
                                                                            "testable")}
        assert drawn == {"hold": len(held), "claims": len(mine),
                         "fitted": sum(r["used_in_fit"] == "yes" for r in held),
                         "testable-hold": sum(r["holds"] == "yes" for r in testable), "testable": len(testable)}
        assert li.is_displayed()
    assert not severe(browser), severe(browser)
