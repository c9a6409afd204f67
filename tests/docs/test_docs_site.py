"""The docs site builds strictly (mkdocs.yml: a broken link or anchor, a page left out of the nav, or a warning of
the generator fails the build), and the pages generated from the code say what the code says: the component
reference lists every component with its parameters and units, the API reference has the top-level functions, and
the limitations page is in the site.

Needs the docs extra (mkdocs, mkdocstrings[python]); skips without it. One build, about 15 s.
"""
from __future__ import annotations

import html
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

pytest.importorskip("mkdocs", reason="the docs site needs mkdocs (pip install -e \".[docs]\")")
pytest.importorskip("mkdocstrings", reason="the docs site needs mkdocstrings[python] (pip install -e \".[docs]\")")
pytest.importorskip("mkdocstrings_handlers.python",
                    reason="the docs site needs mkdocstrings' python handler (pip install -e \".[docs]\")")

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    return out


def page(site: Path, src_uri: str) -> str:
    """The HTML of the page built from ``src_uri`` (directory URLs: ``a/b.md`` -> ``a/b/index.html``)."""
    stem = src_uri[:-len(".md")]
    if stem == "index" or stem.endswith("/index"):
        path = site / f"{stem}.html"
    else:
        path = site / stem / "index.html"
    assert path.exists(), f"{src_uri} is not in the site ({path} missing)"
    return path.read_text(encoding="utf-8")


def text(html_page: str) -> str:
    return html.unescape(re.sub(r"<[^>]+>", "", html_page))


def _generator():
    sys.path.insert(0, str(REPO / "docs"))
    try:
        return importlib.import_module("gen_reference")
    finally:
        sys.path.remove(str(REPO / "docs"))


def test_component_reference_has_every_component(site):
    gen = _generator()
    modules = gen.library_modules()
    assert {"electrical", "rotational", "thermal", "servo"} <= set(modules)
    for name in modules:
        body = page(site, f"reference/components/{name}.md")
        module = importlib.import_module(f"acausal.library.{name}")
        for cls in gen.component_classes(module):
            ident = f"{cls.__module__}.{cls.__qualname__}"
            assert f'id="{ident}"' in body, f"{ident} has no section on the {name} page"
            for line in str(cls.describe()).splitlines():  # every parameter describe() lists is in the table
                m = re.match(r"^    (\w+)\s+=\s", line)
                if m:
                    assert f"<code>{m[1]}</code>" in body, f"{ident}: parameter {m[1]} is not on the page"


def test_resistor_parameter_unit_and_equation(site):
    body = page(site, "reference/components/electrical.md")
    section = body[body.index('id="acausal.library.electrical.Resistor"'):
                   body.index('id="acausal.library.electrical.Conductor"')]
    row = re.search(r"<tr>\s*<td><code>R</code></td>(.*?)</tr>", section, re.S)
    assert row, "Resistor's parameter table has no row for R"
    cells = re.findall(r"<td>(.*?)</td>", row[1], re.S)
    assert cells[:2] == ["1", "Ohm"], cells  # default 1, unit Ohm
    assert "v = R*i" in text(section)
    assert "Resistor.describe()" in text(section)
    motor = page(site, "reference/components/drives.md")
    assert "default of maxon EC-4pole 30" in text(motor)  # the source of a datasheet default


def test_api_reference_has_the_entry_points(site):
    body = page(site, "reference/api/acausal.md")
    for ident in ("acausal.compile_model", "acausal.CompiledModel.simulate", "acausal.Result", "acausal.connect"):
        assert f'id="{ident}"' in body, f"{ident} is not on the API page"
    assert "simulate" in text(body) and "compile_model" in text(body)
    assert 'id="acausal.identify.load_recording"' in page(site, "reference/api/identify.md")
    assert 'id="acausal.export.export_fmu"' in page(site, "reference/api/export.md")
    usage = text(page(site, "reference/api/cli-usage.md"))
    assert "acausal export" in usage and "--fmu" in usage
    models = page(site, "reference/api/models.md")
    for pkg in sorted(p.name for p in (REPO / "models").iterdir() if (p / "__init__.py").exists()):
        assert f'id="acausal.models.{pkg}"' in models, f"acausal.models.{pkg} is not on the models page"


def test_limitations_and_changelog_are_in_the_site(site):
    body = text(page(site, "limitations.md"))
    assert "Known limitations" in body and "cost speed, not answers" in body
    assert "Changelog" in text(page(site, "changelog.md"))
    index = page(site, "index.md")
    assert 'href="limitations/"' in index and 'href="changelog/"' in index  # ../CHANGELOG.md -> the site's page


def test_no_cdn(site):
    """Nothing is fetched from another host to read the site (highlight.js's CDN is off; Pygments highlights)."""
    for path in site.rglob("*.html"):
        body = path.read_text(encoding="utf-8")
        found = re.findall(r"<(?:script|link)[^>]+(?:src|href)=\"(https?://[^\"]+)\"", body)
        assert not found, f"{path.relative_to(site)} loads {found}"
    assert (site / "assets" / "pygments.css").exists()
