"""The docs site's generator: the component reference, the command-line usage and the changelog page, made from
the code at every build, and the two adapters the site needs (an MkDocs hook and a griffe extension).

* ``mkdocs build`` runs it as a hook (``hooks:`` in mkdocs.yml):

  - ``on_config``: lays out the Python sources as the *installed* package for griffe (``build/docs-src/``, from
    pyproject's ``package-dir``: ``acausal.library`` is the folder ``library/``, ``acausal.models`` is
    ``models/``) and expands the nav's "Component reference" entry with one page per library module;
  - ``on_files``: generates the pages in a fresh interpreter (``python docs/gen_reference.py --json FILE``: it
    imports acausal, mkdocs never does, and ``mkdocs serve`` follows edits of the code) and adds them to the site
    as virtual files (nothing is written into ``docs/``);
  - ``on_page_markdown``: a link to the repository's ``CHANGELOG.md`` (``../CHANGELOG.md``, right on GitHub)
    goes to the site's changelog page.

* griffe loads :class:`RstRoles` (``extensions:`` of the python handler in mkdocs.yml): the docstrings' Sphinx
  roles (``:class:`~acausal.errors.ModelError```) become cross-references that link where the target is
  documented on the site and show as code where it is not.

* ``python docs/gen_reference.py OUT`` writes the generated pages into the folder OUT, to read them without a
  build.

A component page is made from the component itself: its class docstring (rendered by mkdocstrings), its
declarations as :meth:`Component.describe <acausal.model.components.Component.describe>` lists them (tables, with the
formatting of ``describe()``), its constructor options, its sub-components and connections, its equations and
events as an instance writes them, and the verbatim ``describe()`` listing.
"""
from __future__ import annotations

import html
import importlib
import inspect
import logging
import os
import pkgutil
import re
import sys
import typing
from contextlib import contextmanager
from pathlib import Path

try:
    from mkdocs.plugins import event_priority
except ImportError:  # pragma: no cover - the standalone generator
    def event_priority(priority):
        return lambda fn: fn

try:  # griffe is there whenever mkdocstrings[python] is; the standalone generator does not need it
    import griffe
except ImportError:  # pragma: no cover
    griffe = None

REPO = Path(__file__).resolve().parents[1]
#: where the hook lays out the sources as the installed package (``paths:`` of the python handler in mkdocs.yml;
#: under build/, which git ignores)
SOURCE_TREE = REPO / "build" / "docs-src"
#: the generated pages' folder in the site
COMPONENTS = "reference/components"
#: files of the repository outside docs/ that the site shows as a page of its own: repo path -> site page
MIRRORED = {"CHANGELOG.md": "changelog.md"}
CLI_USAGE = "reference/api/cli-usage.md"
PYGMENTS_CSS = "assets/pygments.css"
#: the nav entry (in mkdocs.yml) that the hook expands with one page per library module
NAV_COMPONENTS = "reference/components/index.md"

#: page titles of the library's modules, in nav order; a module not named here gets its name as its title and
#: comes after these (every module of library/ gets a page)
DOMAINS = {
    "electrical": "Electrical",
    "rotational": "Rotational mechanics",
    "friction": "Friction laws",
    "drives": "Drives",
    "machines": "Machines",
    "sensors": "Power sensors",
    "thermal": "Thermal",
    "maccepa": "MACCEPA linkage",
    "blocks": "Signal blocks",
    "control": "Control",
    "firmware": "Servo firmware",
    "servo": "Servo",
    "gait": "Gait",
}

log = logging.getLogger("mkdocs.hooks.gen_reference")


# ------------------------------------------------------------------------------------------ the source tree
def _toml(path: Path) -> dict:
    try:
        import tomllib
    except ImportError:  # Python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            from pip._vendor import tomli as tomllib
    return tomllib.loads(path.read_text(encoding="utf-8"))


def package_dirs() -> dict[str, Path]:
    """Every package of the distribution and the folder it is built from (pyproject's ``package-dir``)."""
    setuptools = _toml(REPO / "pyproject.toml")["tool"]["setuptools"]
    mapping = setuptools.get("package-dir", {})
    return {pkg: REPO / mapping.get(pkg, pkg.replace(".", "/")) for pkg in setuptools["packages"]}


def _write_if_changed(path: Path, data: bytes) -> None:
    """Atomically, and only when the content differs (a rebuild of ``mkdocs serve`` sees no change)."""
    if path.exists() and path.read_bytes() == data:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def sync_source_tree(dest: Path = SOURCE_TREE) -> Path:
    """Copy the ``.py`` files of every package to where the installed package has them (``library/electrical.py``
    -> ``dest/acausal/library/electrical.py``), so that griffe, which reads folders and not setuptools'
    mapping, finds ``acausal.library`` and ``acausal.models``. Files no longer in the sources are removed."""
    wanted = {}
    for pkg, folder in package_dirs().items():
        for src in sorted(folder.glob("*.py")):
            wanted[dest.joinpath(*pkg.split("."), src.name)] = src
    for target, src in wanted.items():
        _write_if_changed(target, src.read_bytes())
    if dest.exists():
        for old in dest.rglob("*.py"):
            if old not in wanted:
                old.unlink()
    return dest


# ------------------------------------------------------------------------------------------ markdown helpers
_CODE_SPAN = re.compile(r"(`+)(.+?)\1")


def _cell(text) -> str:
    """Text for a markdown table cell: pipes, emphasis characters and HTML escaped outside code spans."""
    text, out, pos = str(text).replace("\n", " "), [], 0

    def plain(t):
        return re.sub(r"([\\*_\[\]|`])", r"\\\1", html.escape(t, quote=False))

    for m in _CODE_SPAN.finditer(text):
        out += [plain(text[pos:m.start()]), m[0]]  # (the tables extension keeps a pipe inside code)
        pos = m.end()
    return "".join(out + [plain(text[pos:])])


def _summary(cls) -> str:
    """The first sentence of a class's docstring, roles as code."""
    first = " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split()).rstrip(":")
    first = _ROLE.sub(lambda m: f"``{_role_title(m[2])}``", first)
    depth = 0  # the first ". " outside code spans and brackets
    for m in re.finditer(r"``.*?``|`[^`]*`|[()]|\.(?=\s|$)", first):
        tok = m[0]
        if tok == "(":
            depth += 1
        elif tok == ")":
            depth = max(depth - 1, 0)
        elif tok == "." and depth == 0:
            return first[:m.end()]
    return first


class Markdown(str):
    """A table cell that is markdown already (a link): not escaped."""


def _table(header: list[str], rows: list[list]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(c if isinstance(c, Markdown) else _cell(c) if c != "" else " " for c in r) + " |"
            for r in rows]
    return out + [""]


def _code(lines: list[str], lang: str = "text") -> list[str]:
    return [f"```{lang}", *lines, "```", ""]


# ------------------------------------------------------------------------------------------ components
def library_modules() -> list[str]:
    """The modules of ``acausal.library`` (the folder library/), in the nav's order."""
    lib = importlib.import_module("acausal.library")
    return _ordered(m.name for m in pkgutil.iter_modules(lib.__path__) if not m.ispkg)


def _library_module_names() -> list[str]:
    """The same, from the folder (for the nav, without importing the package)."""
    return _ordered(p.stem for p in package_dirs()["acausal.library"].glob("*.py"))


def _ordered(names) -> list[str]:
    names = [n for n in names if not n.startswith("_")]
    return sorted(names, key=lambda n: (list(DOMAINS).index(n) if n in DOMAINS else len(DOMAINS), n))


def domain_title(module: str) -> str:
    return DOMAINS.get(module, module.replace("_", " ").capitalize())


def component_classes(module) -> list[type]:
    """The public component classes a module defines, in source order."""
    from acausal.model.components import Component, Connector
    return [o for n, o in vars(module).items()
            if inspect.isclass(o) and issubclass(o, Component) and not issubclass(o, Connector)
            and o.__module__ == module.__name__ and not n.startswith("_")]


def _documented(cls) -> bool:
    """Whether the site has a page section for the class (the component reference's classes)."""
    mod = cls.__module__
    return (mod.startswith("acausal.library.") and not cls.__name__.startswith("_")
            and getattr(sys.modules.get(mod), cls.__name__, None) is cls)


def _class_ref(cls) -> str:
    name = f"`{cls.__name__}`"
    return f"[{name}][{cls.__module__}.{cls.__qualname__}]" if _documented(cls) else name


def _options(cls) -> list[tuple[str, str]]:
    """The constructor's own keywords (structural options such as ``use_support``, ``law``): name, default."""
    from acausal.model.components import Component
    if cls.__init__ is Component.__init__:
        return []
    out = []
    for name, p in inspect.signature(cls.__init__).parameters.items():
        if name in ("self", "doc") or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        out.append((name, "(required)" if p.default is p.empty else repr(p.default)))
    return out


def _instance(cls):
    """An instance with every prescribed input without a default given as a function of time (``v_ref(time)``)
    and every required constructor argument typed as a component given as such a component; built."""
    import sympy as sp

    from acausal import time
    from acausal.model.components import Component, Input
    kw = {k: sp.Function(k)(time) for k, d in cls.declarations().items() if isinstance(d, Input) and d.default is None}
    hints = typing.get_type_hints(cls.__init__)
    for name, p in inspect.signature(cls.__init__).parameters.items():
        if name != "self" and p.default is p.empty and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY):
            hint = hints.get(name)
            if inspect.isclass(hint) and issubclass(hint, Component):
                kw[name] = hint()
                kw[name]._set_path(name)
            else:
                raise TypeError(f"{cls.__name__}() needs the argument {name!r}")
    inst = cls(**kw)
    inst._ensure_built()
    return inst


def _bindings(child) -> str:
    """The parameter values a composite model gives a part (``J = J_a``: bound to its own parameter)."""
    import sympy as sp

    from acausal.model.describe import _number
    if not child._values:
        return ""
    return " (" + ", ".join(f"`{k} = {sp.sstr(v) if isinstance(v, sp.Basic) else _number(v)}`"
                            for k, v in child._values.items()) + ")"


def _equation_text(eq) -> str:
    """An equation as the compiler lists it as written (``CompiledModel.equations()``)."""
    import sympy as sp
    if isinstance(eq, sp.Equality):
        return f"{sp.sstr(eq.lhs)} = {sp.sstr(eq.rhs)}"
    return f"0 = {sp.sstr(eq)}"


def _assignments(d: dict) -> str:
    import sympy as sp
    return ", ".join(f"{sp.sstr(k)} := {sp.sstr(v)}" for k, v in d.items())


def component_section(cls) -> list[str]:
    """The page section of one component class."""
    from acausal.model.components import Connector, Model
    from acausal.model.describe import _bounds, _listed, _number, _unset

    ident = f"{cls.__module__}.{cls.__qualname__}"
    lines = [f"::: {ident}", "    options:", "      show_root_full_path: false", "      members: false",
             "      show_signature: false", "      separate_signature: false", "      show_bases: true", ""]
    decl = cls.declarations()

    pars = _listed(decl, "parameter")
    if pars:
        rows = []
        for k, d in pars:
            source = f"default of {d.device}" if d.device else ""
            if d.default is None:
                source = f"derived: {d.derived}" if getattr(d, "derived", "") else "required: no default"
            rows.append([f"`{k}`", _number(d.default) if d.default is not None else _unset(d), d.unit, _bounds(d),
                         d.doc, source])
        lines += ["**Parameters**", ""]
        lines += _table(["name", "default", "unit", "bounds", "description", "source of the default"], rows)
    ports = _listed(decl, "port")
    if ports:
        lines += ["**Ports**", ""]
        lines += _table(["name", "connector", "domain", "description"],
                        [[f"`{k}`", f"`{type(d).__name__}`", getattr(d, "domain", ""), d.doc] for k, d in ports])
        lines[-len(ports) - 1:-1] = [_link_connectors(r) for r in lines[-len(ports) - 1:-1]]
    inputs = _listed(decl, "input")
    if inputs:
        lines += ["**Inputs** (prescribed signals: a number, an expression of time or a `Signal`)", ""]
        lines += _table(["name", "unit", "default", "description"],
                        [[f"`{k}`", d.unit, _number(d.default) if d.default is not None else "(required)", d.doc]
                         for k, d in inputs])
    var = _listed(decl, "variable")
    if var:
        lines += ["**Variables**", ""]
        lines += _table(["name", "unit", "start", "description"],
                        [[f"`{k}`", getattr(d, "unit", "mode"),
                          _number(d.start) + (" (fixed)" if getattr(d, "fixed", False) else ""), d.doc]
                         for k, d in var])
    options = _options(cls)
    if options:
        lines += ["**Constructor options** (structural: they change the equations)", ""]
        lines += [", ".join(f"`{k}={v}`" for k, v in options), ""]

    try:
        inst = _instance(cls)
    except TypeError as exc:
        lines += [f"*Equations: not listed here ({exc}); see the description above.*", ""]
        inst = None
    if inst is not None:
        children = [(k, c) for k, c in inst.children.items() if not isinstance(c, Connector)]
        if children:
            lines += ["**Made of**", ""]
            lines += [f"* `{k}`: {_class_ref(type(c))}" + _bindings(c) for k, c in children] + [""]
            conns = [", ".join(p.path for p in conn) for conn in inst._connections]
            if conns:
                lines += ["**Connections**", ""] + _code([f"connect({c})" for c in conns])
        eqs = [_equation_text(e) for e in inst.equations()]
        if eqs:
            lines += ["**Equations**" + (" (of its own, beside those of its parts)" if children else ""), ""]
            lines += _code(eqs)
        elif not children and not issubclass(cls, Model):
            lines += ["**Equations**: none of its own.", ""]
        events = inst.events()
        if events:
            lines += ["**Events** (when the zero function crosses zero)", ""]
            rows = []
            for ev in events:
                import sympy as sp
                rows.append([f"`{sp.sstr(ev.zero)}`", f"`{_assignments(ev.on_rising)}`" if ev.on_rising else "",
                             f"`{_assignments(ev.on_falling)}`" if ev.on_falling else "",
                             f"`{_assignments(ev.reinit)}`" if ev.reinit else "", ev.doc])
            lines += _table(["zero function", "rising", "falling", "reinit", "description"], rows)
        checks = inst.assertions()
        if checks:
            import sympy as sp
            lines += ["**Checked on every run**", ""]
            lines += [f"* `{sp.sstr(cond)}`: {_cell(msg)}" for cond, msg in checks] + [""]
    listing = html.escape(str(cls.describe()))
    lines += [f"<details><summary><code>{cls.__name__}.describe()</code></summary>",
              f"<pre><code>{listing}</code></pre>", "</details>", ""]
    return lines


def _link_connectors(row: str) -> str:
    """A ports table row with its connector type linked to the connectors' section of the reference's index."""
    return re.sub(r"\| `(Pin|Flange|HeatPort|RealInput|RealOutput)` \|",
                  lambda m: f"| [`{m[1]}`](index.md#{m[1].lower()}) |", row, count=1)


def _other_names(module) -> list[str]:
    """The module's ``__all__`` names that are not component classes (functions, constants, data classes)."""
    comps = {c.__name__ for c in component_classes(module)}
    return [n for n in getattr(module, "__all__", []) if n not in comps and not n.startswith("_")]


def component_page(name: str) -> str:
    module = importlib.import_module(f"acausal.library.{name}")
    classes = component_classes(module)
    lines = [f"# {domain_title(name)}: `acausal.library.{name}`", "",
             f"*Generated from the components of `library/{name}.py` at every build of the site (`docs/gen_reference.py`).*",
             "", "::: acausal.library." + name, "    options:", "      show_root_heading: false",
             "      show_root_toc_entry: false", "      members: false", ""]
    if classes:
        lines += _table(["component", "what it is"], [[Markdown(f"[`{c.__name__}`][{c.__module__}.{c.__qualname__}]"),
                                                       _summary(c)] for c in classes])
    for cls in classes:
        lines += component_section(cls)
    others = _other_names(module)
    if others:
        lines += ["## Functions and other names", ""]
        for n in others:
            lines += [f"::: acausal.library.{name}.{n}", "    options:", "      heading_level: 3", ""]
    return "\n".join(lines)


def components_index(modules: list[str]) -> str:
    import acausal.model.connectors as conn
    from acausal.model.components import Connector
    from acausal.model.describe import _listed, _number

    lines = ["# Component reference", "",
             "Every component of `acausal.library`, by domain, generated from the components themselves at every "
             "build of the site: the parameters with their units, defaults, bounds and the device a datasheet default "
             "belongs to, the ports, the prescribed inputs, the variables, the constructor's structural options, "
             "the sub-components and connections of composite models, the equations and events as an instance writes "
             "them, and what `describe()` prints. In the equations a name is the component's own (`v`, `p.i`); in a "
             "model it is prefixed with the instance's path (`R1.v`). Units and sign conventions: "
             "[sign conventions](../../sign-conventions.md); where the actuator's values come from: "
             "[the actuator's parameters](../../parameters.md).", "",
             "| domain | module | components |", "|---|---|---|"]
    for name in modules:
        module = importlib.import_module(f"acausal.library.{name}")
        classes = component_classes(module)
        lines.append(f"| [{domain_title(name)}]({name}.md) | `acausal.library.{name}` | {len(classes)} |")
    lines += ["", "## Connectors", "",
              "The ports components are joined by (`acausal.model.connectors`, importable from `acausal`): connected "
              "potentials are equal and connected flows sum to zero; a flow is positive into the component.", ""]
    for name, cls in vars(conn).items():
        if inspect.isclass(cls) and issubclass(cls, Connector) and cls.__module__ == conn.__name__:
            doc = " ".join((cls.__doc__ or "").split())
            lines += [f"### {name}", "", _cell(doc), ""]
            rows = [[f"`{k}`", type(d).__name__.lower(), d.unit, _number(d.start), d.doc]
                    for k, d in _listed(cls.declarations(), "variable")]
            lines += [f"Domain `{cls.domain}`" + (", required (must be connected)" if getattr(
                cls, "required_default", False) else "") + (", drives the inputs it is connected to" if getattr(
                    cls, "drives", False) else "") + ".", ""]
            lines += _table(["variable", "kind", "unit", "start", "description"], rows)
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------ other pages
@contextmanager
def _columns(n: int):
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(n)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


def cli_usage_page() -> str:
    """Every verb's ``--help``, from the parser the command runs (``acausal.cli.build_parser``)."""
    import argparse

    from acausal.cli import build_parser
    with _columns(100):
        parser = build_parser()
        lines = ["# Command-line usage", "",
                 "What `acausal --help` and `acausal VERB --help` print, generated from the parser the command uses "
                 "(`acausal.cli.build_parser`) at every build of the site. The module: [acausal.cli](cli.md).", "",
                 "## acausal", ""] + _code(parser.format_help().rstrip().splitlines())
        subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        for verb, sub in subs.choices.items():
            lines += [f"## acausal {verb}", ""] + _code(sub.format_help().rstrip().splitlines())
    return "\n".join(lines)


def changelog_page() -> str:
    """CHANGELOG.md as the site's page: its links to docs/ files made relative to the page."""
    text = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    return re.sub(r"\]\((?:\./)?docs/([^)]+)\)", r"](\1)", text)


def pygments_css() -> str:
    """The code highlighting's stylesheet (pymdownx.highlight's Pygments classes), so no CDN is needed."""
    from pygments.formatters import HtmlFormatter
    return HtmlFormatter(style="default").get_style_defs(".highlight")


def pages() -> dict[str, str]:
    """Every generated page: its path in the site's docs (``src_uri``) -> markdown."""
    modules = library_modules()
    out = {f"{COMPONENTS}/index.md": components_index(modules)}
    out.update({f"{COMPONENTS}/{name}.md": component_page(name) for name in modules})
    out[CLI_USAGE] = cli_usage_page()
    for page in MIRRORED.values():
        out[page] = changelog_page()
    return out


# ------------------------------------------------------------------------------------------ the mkdocs hook
def _expand_nav(nav, modules):
    for k, item in enumerate(nav or []):
        if isinstance(item, dict):
            (title, value), = item.items()
            if value == NAV_COMPONENTS:
                item[title] = [NAV_COMPONENTS] + [{domain_title(m): f"{COMPONENTS}/{m}.md"} for m in modules]
                return True
            if isinstance(value, list) and _expand_nav(value, modules):
                return True
        elif item == NAV_COMPONENTS:
            nav[k] = {"Component reference": [NAV_COMPONENTS] + [{domain_title(m): f"{COMPONENTS}/{m}.md"}
                                                                 for m in modules]}
            return True
    return False


_PAGES: dict[str, str] = {}


@event_priority(100)  # before mkdocstrings' on_config, which resolves the handler's paths (build/docs-src)
def on_config(config, **kwargs):
    sync_source_tree()
    if not _expand_nav(config["nav"], _library_module_names()):
        log.warning("mkdocs.yml's nav has no entry %s for the component reference", NAV_COMPONENTS)
    return config


def generate_in_subprocess() -> dict[str, str]:
    """:func:`pages`, made by a fresh interpreter: the pages of ``mkdocs serve`` follow edits of the code (this
    process would keep the modules it imported once), and mkdocs itself never imports acausal."""
    import json
    import subprocess
    import tempfile

    from mkdocs.exceptions import PluginError
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "pages.json"
        proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--json", str(out)], cwd=REPO,
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise PluginError(f"docs/gen_reference.py could not generate the reference pages:\n{proc.stderr}")
        return json.loads(out.read_text(encoding="utf-8"))


def on_files(files, config, **kwargs):
    from mkdocs.structure.files import File
    _PAGES.clear()
    _PAGES.update(generate_in_subprocess())
    for src_uri, content in _PAGES.items():
        if files.get_file_from_path(src_uri) is not None:
            log.warning("docs/%s exists and is generated too: remove the file from docs/", src_uri)
            continue
        files.append(File.generated(config, src_uri, content=content))
    files.append(File.generated(config, PYGMENTS_CSS, content=pygments_css()))
    return files


def on_page_markdown(markdown, page, config, files, **kwargs):
    """Links from a page of docs/ to a repository file the site mirrors go to its page in the site."""
    src = Path(config["docs_dir"]) / page.file.src_uri
    here = page.file.src_uri.count("/")

    def fix(m):
        target = m[2]
        if "://" in target or target.startswith("#"):
            return m[0]
        path, _, anchor = target.partition("#")
        try:
            rel = (src.parent / path).resolve().relative_to(REPO).as_posix()
        except ValueError:
            return m[0]
        if rel not in MIRRORED:
            return m[0]
        return f"]({'../' * here}{MIRRORED[rel]}{'#' + anchor if anchor else ''})"

    return re.sub(r"\]\(((?!\s)([^)\s]+))\)", fix, markdown)


# ------------------------------------------------------------------------------------------ the griffe extension
_ROLE = re.compile(r":(?:py:)?(class|func|meth|mod|data|attr|exc|obj|const|term):`([^`]+)`")
_RST_TABLE_BORDER = re.compile(r"^\s*=+(\s+=+)+\s*$")


def _role_title(body: str) -> str:
    body = " ".join(body.split())
    explicit = re.match(r"^(.*?)\s*<([^<>]+)>$", body)
    if explicit:
        return explicit[1].strip()
    return body.lstrip("~").rsplit(".", 1)[-1] if body.startswith("~") else body


_SECTION = re.compile(r"^(\s*)[A-Z][\w ]*:\s*$")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _rst_to_markdown(text: str, resolve) -> str:
    """The reStructuredText of a docstring as markdown: Sphinx roles as optional cross-references (a link where
    the target is on the site, code otherwise), ``::`` before a literal block as ``:``, simple tables kept as
    preformatted text."""
    def role(m):
        kind, body = m[1], " ".join(m[2].split())
        explicit = re.match(r"^(.*?)\s*<([^<>]+)>$", body)
        title, target = _role_title(body), (explicit[2].strip() if explicit else body)
        target = target.lstrip("~").lstrip(".")
        if kind == "term":
            return f"*{html.escape(title)}*"
        full = resolve(target)
        label = f"<code>{html.escape(title)}</code>"
        if not full:
            return label
        return f'<autoref identifier="{html.escape(full)}" optional>{label}</autoref>'

    lines, out, k = text.split("\n"), [], 0
    while k < len(lines):  # simple tables first: preformatted, their roles as plain names
        if _RST_TABLE_BORDER.match(lines[k]):
            block, borders = [], 0
            while k < len(lines) and (lines[k].strip() or borders < 3):
                borders += bool(_RST_TABLE_BORDER.match(lines[k]))
                block.append("    " + _ROLE.sub(lambda m: _role_title(m[2]).ljust(len(m[0])), lines[k]))
                k += 1
                if borders == 3:
                    break
            out += ["", *block, ""]
            continue
        out.append(lines[k])
        k += 1
    text = _ROLE.sub(role, "\n".join(out))  # over the whole text: a role may wrap onto the next line
    out, lines, k = [], text.split("\n"), 0
    while k < len(lines):
        line = lines[k]
        if _SECTION.match(line) and k + 1 < len(lines) and _indent(lines[k + 1]) > _indent(line) \
                and lines[k + 1].strip():  # "Parameters:" over indented lines (no blank): a list
            out += [line, ""]
            k += 1
            item = _indent(lines[k])
            while k < len(lines) and lines[k].strip() and _indent(lines[k]) > _indent(line):
                text_k = lines[k].strip()
                if _indent(lines[k]) <= item:
                    out.append(" " * _indent(line) + "* " + text_k)
                else:
                    out[-1] += " " + text_k
                k += 1
            out.append("")
            continue
        if line.strip() == "::":
            out.append("")
        else:
            out.append(re.sub(r"(\S)::\s*$", r"\1:", line))
        k += 1
    return "\n".join(out)


if griffe is not None:
    class RstRoles(griffe.Extension):
        """Docstrings written for Sphinx read as markdown by mkdocstrings (see :func:`_rst_to_markdown`).

        Names are resolved in the scope of the object whose docstring it is (``:class:`Parameter``` in
        ``acausal.model.declarations`` is ``acausal.model.declarations.Parameter``); a cross-reference is *optional*:
        where its target is documented on the site it links, elsewhere it shows as code and no warning is logged
        (autorefs' optional references, as mkdocstrings makes for type annotations)."""

        def on_package(self, *, pkg, **kwargs):
            seen = set()

            def walk(obj):
                if id(obj) in seen:
                    return
                seen.add(id(obj))
                if obj.docstring is not None:
                    obj.docstring.value = _rst_to_markdown(obj.docstring.value, lambda t: _resolve(obj, t))
                for member in obj.members.values():
                    if not member.is_alias:
                        walk(member)

            walk(pkg)


def _resolve(obj, target: str) -> str | None:
    """The full path of ``target`` seen from ``obj``, or None for a name outside acausal (numpy, the stdlib)."""
    head, _, rest = target.partition(".")
    if head == "acausal":
        return target
    scope = obj
    while scope is not None:
        try:
            full = scope.resolve(head)
            break
        except Exception:  # noqa: BLE001 - griffe's NameResolutionError, or an alias it cannot resolve
            scope = scope.parent
    else:
        return None
    full = f"{full}.{rest}" if rest else full
    return full if full.startswith("acausal") else None


# ------------------------------------------------------------------------------------------ standalone
def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 2 and argv[0] == "--json":  # what the hook runs
        import json
        _write_if_changed(Path(argv[1]), json.dumps(pages()).encode("utf-8"))
        return 0
    if len(argv) != 1:
        print("usage: python docs/gen_reference.py OUT   (writes the generated pages into the folder OUT)",
              file=sys.stderr)
        return 2
    out = Path(argv[0])
    for src_uri, content in pages().items():
        path = out / src_uri
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content, encoding="utf-8")
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
