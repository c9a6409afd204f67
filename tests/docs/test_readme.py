"""The README is the front door: short, without issue numbers, its two commands the ones CI runs, and its first
model runs and does what it says."""
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).parents[2]
README = ROOT / "README.md"
INSTALL_AND_RUN = 'python3 -m pip install -e ".[test,fast]" && acausal paper --out results/'
TEST_COMMAND = "python3 -m pytest -n 2 --dist loadfile"
#: an issue number, in a heading or anywhere in the README: "issue 37", "(issue 5)", "issues 16 and 36"
ISSUE = re.compile(r"\bissues?\s+#?\d+", re.I)


def _text() -> str:
    return README.read_text(encoding="utf-8")


def test_readme_example_runs():
    block = re.search(r"^## A first model.*?```python\n(.*?)```", _text(), re.S | re.M).group(1)
    ns = {}
    exec(compile(block, "README.md", "exec"), ns)
    res = ns["res"]
    assert np.isfinite(res["L.i"]).all()
    assert res["R.R"][0] == 0.6
    # a sensible operating point: the datasheet motor below its no-load speed (24 V / k = 879 rad/s) and within
    # its 3.5 A nominal current the whole time, the joint torque of a gait's order (tens of N m)
    assert 0 < np.max(res["rotor.w"]) < 24.0 / 0.0273 and np.max(np.abs(res["L.i"])) < 3.5
    assert 20.0 < abs(res["gear.flange_b.tau"][-1]) < 100.0
    assert abs(res.energy_balance().residual) < 1e-6


def test_readme_two_commands():
    """One bash block under "The two commands" holds exactly the install-and-run line and the test command, and
    .ci/run runs the same install and the same test command."""
    section = re.search(r"^## The two commands\n(.*?)(?=^## )", _text(), re.S | re.M).group(1)
    blocks = re.findall(r"```bash\n(.*?)```", section, re.S)
    assert len(blocks) == 1, "the two commands belong in one ```bash block"
    commands = [ln.split("#")[0].strip() for ln in blocks[0].splitlines() if ln.strip()]
    assert commands == [INSTALL_AND_RUN, TEST_COMMAND]
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    ci_lines = [ln.strip() for ln in ci.splitlines() if not ln.lstrip().startswith("#")]
    assert TEST_COMMAND.replace("python3 ", "python ") in ci_lines, ".ci/run must run the README's test command"
    assert any('pip install' in ln and '-e ".[test,fast]"' in ln for ln in ci_lines), \
        ".ci/run must install with the README's command"
    assert "acausal paper" in ci


def test_readme_is_a_front_door():
    text = _text()
    n = len(text.splitlines())
    assert n <= 200, f"README.md has {n} lines; at most 200 (details belong in docs/)"
    found = [ln for ln in text.splitlines() if ISSUE.search(ln)]
    assert not found, f"README.md names issue numbers: {found}"
    for name in ("docs/index.md", "docs/benchmarks.md", "CHANGELOG.md", "LICENSE"):
        assert f"({name})" in text, f"README.md does not link {name}"
        assert (ROOT / name).exists(), name
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (ROOT / image).exists(), f"README.md shows a missing picture {image}"
    assert text.find("(docs/index.md)") < len(text) // 4, "the pointer to the docs belongs near the top"
    assert 'pytest -m "not slow"' in text


def test_no_issue_numbers_in_headings():
    files = [README, *sorted((ROOT / "docs").rglob("*.md"))]
    found = []
    for path in files:
        fence = False
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if line.lstrip().startswith(("```", "~~~")):
                fence = not fence
            elif not fence and line.startswith("#") and ISSUE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{i}: {line}")
    assert not found, "headings that name issue numbers:\n" + "\n".join(found)
