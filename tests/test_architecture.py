"""The framework's house plan: `acausal/` in stage folders, in import order. A stage imports only the stages above
it (at module level or inside a function alike); a helper module with a single importer lives in that importer's
folder; the framework imports no model and no component of the library; nothing imports the module paths of the
release before the stage folders, which still work for users (a warning names the new path).

The order and why: docs/design/architecture.md."""
from __future__ import annotations

import ast
import importlib
import re
import shutil
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "acausal"

#: the stages, in import order: each may import itself and those before it
STAGES = ["errors", "model", "compile", "backends", "results", "simulation", "identify", "compiled_model", "export",
          "cli"]
#: modules above every stage: the public API and the old paths' shim
TOP = {"", "_moved"}
#: modules whose single importer may sit elsewhere: stages the façade composes (each is one step of the pipeline
#: or one capability of CompiledModel, not a helper of the façade)
COMPOSED = {"compile.pipeline", "compile.introspect", "backends.numpy.printer", "simulation.batch",
            "simulation.sensitivity", "simulation.compiled.path"}


def modules() -> dict[str, Path]:
    """``name -> file`` of every module of the framework, named relative to ``acausal`` ("" is the package)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def imports(name: str, path: Path, known: dict) -> set[str]:
    """The framework modules ``name`` imports (module level and inside functions)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    if name == "":
        package = []
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and (node.module == "acausal" or node.module.startswith("acausal.")):
                target = node.module[len("acausal."):] if node.module != "acausal" else ""
            else:
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}" if target else alias.name
                found.add(sub if sub in known else target)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("acausal."):
                    found.add(alias.name[len("acausal."):])
    found.discard(name)
    return found


GRAPH = {n: imports(n, p, modules()) for n, p in modules().items()}


def stage(name: str) -> int | None:
    if name in TOP:
        return None
    return STAGES.index(name.split(".")[0])


def test_every_module_is_in_a_stage():
    strays = [n for n in GRAPH if n not in TOP and n.split(".")[0] not in STAGES]
    assert not strays, f"modules outside the stage folders {STAGES}: {strays}"
    top = sorted(p.name for p in PACKAGE.iterdir() if not p.name.startswith((".", "__pycache__")))
    assert top == sorted(["__init__.py", "_moved.py", "errors.py", "compiled_model.py", *(
        s for s in STAGES if (PACKAGE / s).is_dir())]), top


def test_no_import_runs_back_up():
    upward = []
    for name, targets in GRAPH.items():
        if stage(name) is None:
            continue
        for t in targets:
            if t.split(".")[0] in ("library", "models"):
                if name.split(".")[0] == "cli":
                    continue  # the command line is the shipped models' too (`acausal paper`, `bench`, ...)
                upward.append(f"{name} -> acausal.{t} (the framework knows no model or component)")
            elif t in TOP:
                if t == "" and name.split(".")[0] in ("cli", "export"):
                    continue  # the version string, read by the command and the FMU's description
                upward.append(f"{name} -> acausal{'.' + t if t else ''}")
            elif stage(t) > stage(name):
                upward.append(f"{name} ({STAGES[stage(name)]}) -> {t} ({STAGES[stage(t)]})")
    assert not upward, "imports that run back up the stages:\n" + "\n".join(sorted(upward))


def test_a_module_with_one_importer_lives_in_its_folder():
    importers: dict[str, set] = {n: set() for n in GRAPH}
    for name, targets in GRAPH.items():
        for t in targets:
            if t in importers:
                importers[t].add(name)
    # the library and the models count as importers too
    for folder, prefix in ((ROOT / "library", "library"), (ROOT / "models", "models")):
        for path in folder.rglob("*.py"):
            for t in re.findall(r"^\s*(?:from|import) acausal\.([\w.]+)", path.read_text(encoding="utf-8"), re.M):
                if t in importers:
                    importers[t].add(f"{prefix}:{path.relative_to(folder)}")
    def folder_of(n):
        return n if (PACKAGE / n.replace(".", "/")).is_dir() else n.rpartition(".")[0]
    astray = []
    for name, who in importers.items():
        if len(who) != 1 or name in TOP or name in COMPOSED or "." not in name:
            continue
        (importer,) = who
        if ":" in importer:
            continue  # a framework module the library or a model uses: the stage's public tool
        if folder_of(importer) != folder_of(name) and \
                not folder_of(name).startswith(folder_of(importer) + ".") and folder_of(importer) != name:
            astray.append(f"{name} (folder {folder_of(name) or 'acausal'}) has one importer: {importer}")
    assert not astray, "\n".join(astray)


def test_nothing_here_imports_the_old_paths():
    from acausal._moved import MOVED
    old = sorted(MOVED, key=len, reverse=True)
    pattern = re.compile(r"^\s*(?:from|import)\s+(" + "|".join(re.escape(o) for o in old) + r")(?![\w.])", re.M)
    hits = []
    for folder in ("acausal", "library", "models", "tests", "examples", "docs"):
        for path in (ROOT / folder).rglob("*"):
            if path.suffix in (".py", ".md") and path.name != "_moved.py":
                for m in pattern.finditer(path.read_text(encoding="utf-8")):
                    hits.append(f"{path.relative_to(ROOT)}: {m.group(0).strip()}")
    assert not hits, hits


@pytest.mark.parametrize("old", ["acausal.result", "acausal.compiled.native_loop", "acausal.partials",
                                 "acausal.energy", "acausal.structure.blt"])
def test_an_old_module_path_still_imports_and_names_the_new_one(old):
    from acausal._moved import MOVED
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    assert any(MOVED[old] in str(w.message) and w.category is DeprecationWarning for w in caught), \
        [str(w.message) for w in caught]
    if old == "acausal.energy":  # split: each name from where it went
        from acausal.compile.accounts import accounts
        from acausal.results.energy import Balance
        assert module.accounts is accounts and module.Balance is Balance
    else:
        assert module is importlib.import_module(MOVED[old])


def test_every_package_folder_is_a_package_that_git_keeps():
    """Each folder the distribution ships (pyproject's ``packages``) holds an ``__init__.py`` that git tracks and no
    ignore rule hides: a clean clone (and a wheel built from one) sees the same packages as this checkout."""
    import subprocess
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = project["package-dir"]
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: which files git keeps cannot be asked")
    tracked = set(subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                                 check=True).stdout.split())
    data_only = {"acausal.export.templates", "acausal.library.data"}
    missing = []
    for package in project["packages"]:
        if package in data_only or ".data." in package:
            continue
        init = f"{folders.get(package, package.replace('.', '/'))}/__init__.py"
        if init not in tracked:
            missing.append(init)
    assert not missing, f"not in git (ignored or never added): {missing}"
