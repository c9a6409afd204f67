"""Session times that cannot be what they say are refused, naming the recordings (they were
clamped to a zero pause, and one recording without the key silently turned session handling off)."""
import numpy as np
import pytest

from acausal import DataError
from acausal.identify.recordings import Recording
from acausal.models.bench.diagnosis import AnkleProblem
from acausal.models.bench.session import check_session, is_session


def _rec(name, start=None, length=4.0):
    t = np.arange(0.0, length, 0.001)
    meta = {} if start is None else {"session_time_s": start}
    return Recording(name, {"time_s": t}, meta)


def test_a_sane_session_passes_in_any_order():
    recs = [_rec("b", 14.0), _rec("a", 0.0), _rec("c", 18.0)]  # back to back is fine (18 = 14 + 4)
    check_session(recs)
    assert is_session(recs)
    check_session([_rec("a"), _rec("b")])  # no session at all: nothing to check


def test_one_recording_without_the_key_is_named():
    with pytest.raises(DataError, match=r"2 of 3 recordings say when they were made .* 1 do not \(b\)"):
        check_session([_rec("a", 0.0), _rec("b"), _rec("c", 20.0)])


@pytest.mark.parametrize("starts", [(0.0, 0.0), (0.0, 2.5)], ids=["equal", "overlapping"])
def test_overlapping_session_times_are_refused(starts):
    with pytest.raises(DataError, match=r"b: session_time_s = .* but a started at 0 s and lasts 3.999 s: the "
                                        r"recordings overlap"):
        check_session([_rec("a", starts[0]), _rec("b", starts[1])])


def test_session_times_in_ms_are_refused():
    with pytest.raises(DataError, match=r"c: session_time_s = 2\.8e\+08 s, 7\.778e\+04 h after the first .* in ms"):
        check_session([_rec("a", 0.0), _rec("b", 1.4e8), _rec("c", 2.8e8)])


def test_the_diagnosis_checks_its_session():
    with pytest.raises(DataError, match="overlap"):
        AnkleProblem([_rec("a", 0.0), _rec("b", 1.0)])
