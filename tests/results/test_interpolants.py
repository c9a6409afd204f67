"""The stacked evaluation of scipy's step interpolants (:mod:`acausal.results.interpolants`) gives what calling each
step's interpolant gives, for LSODA and BDF (stacked) and Radau (called step by step)."""
import numpy as np
import pytest

from acausal import compile_model
from acausal.results.interpolants import states_at

from ..drive_models import MotorGearLoad


@pytest.mark.parametrize("method", ["LSODA", "BDF", "Radau"])
def test_states_at_gauss_nodes_equal_each_steps_own_interpolant(method):
    cm = compile_model(MotorGearLoad())
    res = cm.simulate(1.0, method=method, trust="off")
    segs = res.dense.steps
    tn = np.stack([np.linspace(s[0], s[1], 5) for s in segs])
    which = np.arange(len(segs))
    stacked = states_at(segs, which, tn, len(cm.state_names))
    each = np.stack([np.asarray(s[2](tn[k])) for k, s in enumerate(segs)], axis=1)
    assert len(segs) > 50
    assert np.max(np.abs(stacked - each)) <= 1e-13 * np.max(np.abs(each))
