"""The users' guide (docs/*.md) runs: every ```python block of a chapter is executed, in order, in one namespace
per file, in a temporary working directory (so files a block writes land there), with matplotlib's Agg backend.

A failing block is reported with its file and the line of the markdown file where it starts; tracebacks point at
the markdown file's own line numbers (each block is compiled under the file's path, padded to its position).
"""
from __future__ import annotations

import re
import traceback
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

DOCS = Path(__file__).resolve().parents[2] / "docs"

#: chapters without code blocks: the table of contents, the chapter the lead engineer writes, and the benchmarks'
#: figures (measured by tests/benchmarks, not by the guide)
NO_CODE_ALLOWED = {"index.md", "README.md", "benchmarks.md"}

#: chapters whose code needs a C compiler (FMU binaries): where there is none they skip, saying so, and the
#: fallback the chapter promises is checked instead
NEEDS_C_COMPILER = {"fmu-export.md"}

_FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})\s*([\w+-]*)")


def doc_files() -> list[Path]:
    return sorted(DOCS.glob("*.md"))


def python_blocks(path: Path) -> list[tuple[int, str]]:
    """``(line number of the first code line, source)`` of every ```python fenced block, in order."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang = m.group(1), m.group(2), m.group(3).lower()
        start = i + 1
        j = start
        while j < len(lines) and not (lines[j].strip().startswith(fence[0] * len(fence))
                                      and lines[j].strip().strip(fence[0]) == ""):
            j += 1
        if j == len(lines):
            raise AssertionError(f"{path.name}:{i + 1}: code fence opened here is never closed")
        if lang in ("python", "py", "python3"):
            body = [ln[len(indent):] if ln.startswith(indent) else ln for ln in lines[start:j]]
            blocks.append((start + 1, "\n".join(body) + "\n"))
        i = j + 1
    return blocks


def test_docs_exist():
    files = doc_files()
    assert files, f"no markdown files in {DOCS}"
    names = {p.name for p in files}
    assert names & {"index.md", "README.md"}, "docs/ needs a table of contents (index.md or README.md)"
    missing = sorted(p.name for p in files if p.name not in NO_CODE_ALLOWED and not python_blocks(p))
    assert not missing, f"chapters without a ```python block (every chapter must run something): {missing}"


def test_index_links_every_chapter():
    index = DOCS / "index.md" if (DOCS / "index.md").exists() else DOCS / "README.md"
    text = index.read_text(encoding="utf-8")
    unlinked = [p.name for p in doc_files() if p.name != index.name and f"({p.name}" not in text]
    assert not unlinked, f"{index.name} does not link {unlinked}"


@pytest.mark.slow
@pytest.mark.parametrize("name", [p.name for p in doc_files()])
def test_doc_code_runs(name, tmp_path, monkeypatch):
    path = DOCS / name
    blocks = python_blocks(path)
    if not blocks:
        assert name in NO_CODE_ALLOWED, f"{name} has no ```python block"
        return
    monkeypatch.chdir(tmp_path)
    if name in NEEDS_C_COMPILER:
        _without_a_compiler_the_fallback_holds(name, tmp_path)
    import matplotlib.pyplot as plt

    ns: dict = {"__name__": f"docs.{path.stem}"}
    failure = None
    try:
        for line, src in blocks:
            code = compile("\n" * (line - 1) + src, str(path), "exec")
            try:
                exec(code, ns)
            except Exception as exc:  # noqa: BLE001 - report which block failed, then fail the test
                tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__, limit=-6))
                failure = f"docs/{name}: the python block starting at line {line} failed:\n{tb}"
                break
    finally:
        plt.close("all")
    if failure:
        pytest.fail(failure, pytrace=False)


def _without_a_compiler_the_fallback_holds(name, tmp_path):
    """Where the machine has no C compiler: ``export_fmu`` says so and what to do, ``binary=False`` writes a
    source-only FMU (as the chapter says); then the chapter is skipped with the reason. Returns where there is one."""
    import zipfile

    from acausal import compile_model, export_fmu
    from acausal.export import ExportError
    from acausal.export.fmu import find_compiler
    try:
        find_compiler()
        return
    except ExportError as exc:
        why = str(exc)
    from ..drive_models import MotorGearLoad
    sim = compile_model(MotorGearLoad())
    with pytest.raises(ExportError, match="C compiler"):
        export_fmu(sim, tmp_path / "binary.fmu")
    with zipfile.ZipFile(export_fmu(sim, tmp_path / "source.fmu", binary=False)) as z:
        names = z.namelist()
    assert any(n.startswith("sources/") for n in names) and not any(n.startswith("binaries/") for n in names)
    pytest.skip(f"docs/{name} builds FMU binaries and there is no C compiler here ({why}); the source-only FMU "
                "it offers instead was written")


def _significant(text: str) -> int:
    digits = text.lower().split("e")[0].replace("-", "").replace(".", "").lstrip("0")
    return max(len(digits), 1)


def test_the_paper_pages_inferred_values_are_the_shipped_records():
    """docs/paper.md's table of inferred values is typed prose: each value and sd must be the shipped record's,
    rounded to the digits the page prints (mm on the page for m in the record), so a new record cannot leave it
    stale."""
    from acausal.models.ankle.presets import paper_fit_record
    record = paper_fit_record()
    rows = {u["parameter"]: u for u in record["unknowns"]}
    text = (DOCS / "paper.md").read_text()
    seen = set()
    for m in re.finditer(r"^\| `([a-z_.A-Z]+)`[^|]*\| ([-0-9.e]+) ?([a-zA-Z ]*?[0-9]?) \| ([-0-9.e]+) ?[a-zA-Z0-9 ]*\|",
                         text, re.M):
        name, value, unit, sd = m.groups()
        if name not in rows:
            continue
        scale = 1e-3 if unit.strip() == "mm" else 1.0
        for printed, actual in ((value, rows[name]["value"]), (sd, rows[name]["sd"])):
            n = _significant(printed)
            assert float(f"{actual / scale:.{n}g}") == float(printed), (name, printed, actual)
        seen.add(name)
    assert seen == set(rows), set(rows) - seen
