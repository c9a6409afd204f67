"""The README's example runs and does what it says."""
import re
from pathlib import Path

import numpy as np


def test_readme_example_runs():
    text = (Path(__file__).parents[1] / "README.md").read_text()
    block = re.search(r"## A first model.*?```python\n(.*?)```", text, re.S).group(1)
    ns = {}
    exec(compile(block, "README.md", "exec"), ns)
    res = ns["res"]
    assert np.isfinite(res["L.i"]).all()
    assert res["R.R"][0] == 0.6
