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
    # a sensible operating point (issue 22): the datasheet motor below its no-load speed (24 V / k = 879 rad/s)
    # and within its 3.5 A nominal current the whole time, the joint torque of a gait's order (tens of N m)
    assert 0 < np.max(res["rotor.w"]) < 24.0 / 0.0273 and np.max(np.abs(res["L.i"])) < 3.5
    assert 20.0 < abs(res["gear.flange_b.tau"][-1]) < 100.0
    assert abs(res.energy_balance().residual) < 1e-6
